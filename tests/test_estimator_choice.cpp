// The `auto` estimator (scene/estimator_choice.h): its rule on hand-made scenes, its pick on every built-in scene
// (docs/estimators.md measures both estimators there), and the renderer resolving it per pass.
#include <doctest/doctest.h>

#include "film/film.h"
#include "materials/texture.h"
#include "render/renderer.h"
#include "run_command.h"
#include "scene/estimator_choice.h"
#include "scene/scene.h"
#include "scene/scene_json.h"
#include "test_helpers.h"
#include "uv_scenes.h"

namespace pt {
namespace {

// A diffuse floor and one sphere of material `ball` under a lamp.
SceneDesc floor_and_ball(MaterialType type, float roughness) {
  SceneDesc s = test::origin_camera_scene(8, 8);
  MaterialDesc floor, ball, lamp;
  floor.name = "floor";
  ball.name = "ball";
  ball.type = type;
  ball.roughness = roughness;
  lamp.name = "lamp";
  lamp.albedo = Rgb(0.f);  // a black lamp receives nothing
  lamp.emission = Rgb(4.f);
  s.materials = {floor, ball, lamp};
  s.shapes.push_back(stress::quad({-4, -1, 4}, {4, -1, 4}, {4, -1, -8}, {-4, -1, -8}, 0));
  ShapeDesc sphere;
  sphere.type = ShapeType::Sphere;
  sphere.center = DVec3(0, 0, -3);
  sphere.radius = 0.5;
  sphere.material = 1;
  s.shapes.push_back(sphere);
  s.shapes.push_back(stress::quad({-1, 3, -2}, {1, 3, -2}, {1, 3, -4}, {-1, 3, -4}, 2));
  return s;
}

}  // namespace

TEST_CASE("auto estimator: bdpt where glass, a mirror or polished metal can focus light onto a diffuse surface") {
  CHECK(choose_estimator(floor_and_ball(MaterialType::Diffuse, 0.f)).estimator == Estimator::Mis);
  CHECK(choose_estimator(floor_and_ball(MaterialType::Plastic, 0.f)).estimator == Estimator::Mis);  // a 4 % coat
  CHECK(choose_estimator(floor_and_ball(MaterialType::Mirror, 0.f)).estimator == Estimator::Bdpt);
  CHECK(choose_estimator(floor_and_ball(MaterialType::Dielectric, 0.f)).estimator == Estimator::Bdpt);
  CHECK(choose_estimator(floor_and_ball(MaterialType::Conductor, kFocusingRoughness - 0.01f)).estimator == Estimator::Bdpt);
  CHECK(choose_estimator(floor_and_ball(MaterialType::Conductor, kFocusingRoughness)).estimator == Estimator::Mis);
  // glTF's metallic-roughness: a polished mostly-metal ball focuses; a glossy dielectric one (4 %) does not, and
  // its diffuse base receives.
  SceneDesc gltf_metal = floor_and_ball(MaterialType::MetallicRoughness, 0.1f);
  gltf_metal.materials[1].metallic = 0.9f;
  CHECK(choose_estimator(gltf_metal).estimator == Estimator::Bdpt);
  gltf_metal.materials[1].metallic = 0.2f;
  CHECK(choose_estimator(gltf_metal).estimator == Estimator::Mis);
  SceneDesc gltf_floor = floor_and_ball(MaterialType::Mirror, 0.f);
  gltf_floor.materials[0].type = MaterialType::MetallicRoughness;  // metallic 0: its base receives the caustic
  CHECK(choose_estimator(gltf_floor).estimator == Estimator::Bdpt);
  gltf_floor.materials[0].metallic = 1.f;  // a metal floor has no diffuse part
  CHECK(choose_estimator(gltf_floor).estimator == Estimator::Mis);
  const EstimatorChoice glass = choose_estimator(floor_and_ball(MaterialType::Dielectric, 0.1f));
  CHECK(glass.estimator == Estimator::Bdpt);
  CHECK(glass.reason.find("'ball'") != std::string::npos);  // it names the material
  // Nothing to receive the caustic: the floor made a mirror too.
  SceneDesc mirrors = floor_and_ball(MaterialType::Mirror, 0.f);
  mirrors.materials[0].type = MaterialType::Mirror;
  CHECK(choose_estimator(mirrors).estimator == Estimator::Mis);
  // A focusing material no shape uses does not count.
  SceneDesc unused = floor_and_ball(MaterialType::Diffuse, 0.f);
  MaterialDesc glass_spare;
  glass_spare.name = "spare";
  glass_spare.type = MaterialType::Dielectric;
  unused.materials.push_back(glass_spare);
  CHECK(choose_estimator(unused).estimator == Estimator::Mis);
  // Beyond bdpt's bounce limit: mis, and it says why.
  SceneDesc deep = floor_and_ball(MaterialType::Dielectric, 0.f);
  deep.render.max_bounces = kMaxBdptBounces + 1;
  CHECK(choose_estimator(deep).estimator == Estimator::Mis);
  CHECK(choose_estimator(deep).reason.find("limit") != std::string::npos);
}

TEST_CASE("auto estimator: the built-in scenes' picks (docs/estimators.md: bdpt/mis same-time relMSE 3.96, 0.18, "
          "0.72, 0.18, 2.54)") {
  CHECK(choose_estimator(load_scene("cornell")).estimator == Estimator::Mis);
  CHECK(choose_estimator(load_scene("cornell-spheres")).estimator == Estimator::Bdpt);
  CHECK(choose_estimator(load_scene("materials")).estimator == Estimator::Bdpt);
  CHECK(choose_estimator(load_scene("sky")).estimator == Estimator::Bdpt);
  CHECK(choose_estimator(load_scene("shadertoy")).estimator == Estimator::Mis);
  for (const std::string& name : builtin_scene_names())
    if (name != "shadertoy") CHECK(load_scene(name).render.estimator == Estimator::Auto);  // shadertoy: cosine
}

TEST_CASE("auto estimator: the renderer traces auto as its pick, bit for bit, and follows a material edit") {
  for (const MaterialType type : {MaterialType::Diffuse, MaterialType::Dielectric}) {
    SceneDesc d = floor_and_ball(type, 0.f);
    d.width = d.height = 16;
    d.render.max_bounces = 4;
    const Estimator pick = choose_estimator(d).estimator;
    const auto scene = compile_scene(d);
    Film a, b;
    a.reset(d.width, d.height);
    b.reset(d.width, d.height);
    RenderSettings explicit_settings = d.render;
    explicit_settings.estimator = pick;
    Renderer(2).render_pass(*scene, d.render, a, 4);
    Renderer(2).render_pass(*scene, explicit_settings, b, 4);
    CHECK(a.mean_image() == b.mean_image());
  }
  // A typed edit of the compiled scene (the viewer's): the glass ball made diffuse, auto traces mis.
  SceneDesc d = floor_and_ball(MaterialType::Dielectric, 0.f);
  const auto scene = compile_scene(d);
  CHECK(choose_estimator(*scene, d.render.max_bounces) == Estimator::Bdpt);
  MaterialDesc diffuse = d.materials[1];
  diffuse.type = MaterialType::Diffuse;
  REQUIRE(apply_edit(*scene, MaterialEdit{1, diffuse}));
  CHECK(choose_estimator(*scene, d.render.max_bounces) == Estimator::Mis);
}

TEST_CASE("auto estimator: the compiled scene traces the pick the description names, for every scene trait") {
  // The renderer resolves auto on the compiled scene (resolved_render_settings), the panel and render's summary
  // line name the description's pick: the two must agree. Before they shared one rule, the compiled form still
  // sent smooth-shaded and textured scenes to mis while the line said bdpt.
  const auto agree = [](const SceneDesc& d, Estimator want) {
    const auto scene = compile_scene(d);
    CHECK(choose_estimator(d).estimator == want);
    CHECK(resolved_render_settings(*scene, d.render).estimator == want);
  };
  SceneDesc glass = floor_and_ball(MaterialType::Dielectric, 0.f);
  agree(glass, Estimator::Bdpt);
  agree(floor_and_ball(MaterialType::Diffuse, 0.f), Estimator::Mis);
  // A textured floor (its uv square under the ball) and a smooth-shaded one (vertex normals on the same square).
  SceneDesc textured = glass;
  auto shading = std::make_shared<std::vector<TriangleShading>>();
  test::add_uv_square(textured, *shading, -1.0, 4.0, 0);
  textured.shading = shading;
  textured.materials[0].albedo_map = make_texture(2, 1, {0.2f, 0.4f, 0.6f, 0.8f, 0.6f, 0.4f}, TextureWrap::Repeat,
                                                  TextureWrap::Repeat, "two texels");
  agree(textured, Estimator::Bdpt);
  SceneDesc smooth = glass;
  auto normals = std::make_shared<std::vector<TriangleShading>>();
  test::add_uv_square(smooth, *normals, -1.0, 4.0, 0);
  for (TriangleShading& t : *normals)
    t.normal = {glm::normalize(Vec3(0.1f, 1.f, 0.f)), glm::normalize(Vec3(0.f, 1.f, 0.1f)), Vec3(0.f, 1.f, 0.f)};
  smooth.shading = normals;
  agree(smooth, Estimator::Bdpt);
  // A point light besides the lamp: bdpt (its caustics through the glass are light paths mis cannot find at all).
  SceneDesc lit = glass;
  PunctualLightDesc point;
  point.position = DVec3(0, 2, -3);
  lit.punctual_lights.push_back(point);
  agree(lit, Estimator::Bdpt);
  // A normal-mapped floor: bdpt since it takes normal maps (session 36; mis before, in both forms).
  SceneDesc mapped = textured;
  mapped.materials[0].normal_map.texture =
      make_texture(1, 1, {0.75f, 0.5f, 0.933f}, TextureWrap::Repeat, TextureWrap::Repeat, "tilt");
  agree(mapped, Estimator::Bdpt);
}

TEST_CASE("cli: render names auto's pick and why (stderr), and in the summary line") {
  const test::Run r = test::run_pathtracer("", "render --scene cornell-spheres --spp 1 --width 16 --height 16 "
                                               "--pfm /dev/null");
  INFO(r.out << r.err);
  CHECK(r.status == 0);
  CHECK(r.err.find("estimator auto: bdpt: 'chrome' (mirror) focuses light") != std::string::npos);
  CHECK(r.out.find("auto=bdpt/sobol") != std::string::npos);
  const test::Run m = test::run_pathtracer("", "render --scene cornell --spp 1 --width 16 --height 16 --estimator mis "
                                               "--pfm /dev/null");
  CHECK(m.out.find(" mis/sobol") != std::string::npos);
  CHECK(m.err.find("estimator auto") == std::string::npos);
}

}  // namespace pt
