// bdpt with textures (integrators/bdpt_kernels.h, material_at.h): each vertex of either subpath is shaded with
// the material its textures make there (albedo, normal map) and lights read their emission textures wherever
// they are sampled or hit, so each strategy alone estimates what the path tracer does. Statistical checks use
// stress::compare_blocks: z-scores of 8×8 block means from the films' own variances, fixed seeds, Bonferroni
// bound at α = 1e-5 over all z-scores and a χ² bound on the mean z².
#include <doctest/doctest.h>

#include <memory>
#include <string>
#include <vector>

#include "film/film.h"
#include "integrators/bdpt_kernels.h"
#include "materials/texture.h"
#include "scene/estimator_choice.h"
#include "scene/scene.h"
#include "test_helpers.h"
#include "uv_scenes.h"

using namespace pt;
using test::blocks_agree;
using test::render_estimator;

namespace {

// A floor with a colour-ramp albedo texture, a flat wall behind it, and above them a small downward lamp whose
// emission texture is bright on one half and dim on the other: every texture a vertex of either subpath can meet.
// The ramp is linear in u (8 texels, each channel its own slope), so bilinear lookups and the ray cones' filtering
// reproduce it exactly wherever they look it up: the camera subpath filters over its cone, the light subpath reads
// the finest level (material_at.h), and on a ramp both read the same values. (On a checker they differ at the
// squares' edges by the cone's blur.)
SceneDesc textured_room(int max_bounces) {
  SceneDesc s;
  s.camera.position = DVec3(0, 3, 4.5);
  s.camera.look_at = DVec3(0, 0.5, 0);
  s.camera.fov_deg = 55;
  s.width = 48;
  s.height = 32;
  s.render.max_bounces = max_bounces;
  s.render.sampler = SamplerType::Independent;
  MaterialDesc floor, lamp, wall;
  floor.name = "floor";
  std::vector<float> ramp;
  for (int x = 0; x < 8; ++x) {
    const float u = static_cast<float>(x) / 7.f;
    for (const float c : {0.1f + 0.8f * u, 0.5f, 0.9f - 0.7f * u}) ramp.push_back(c);
  }
  floor.albedo_map = make_texture(8, 1, ramp, TextureWrap::Clamp, TextureWrap::Clamp, "ramp");
  lamp.name = "lamp";
  lamp.albedo = Rgb(0.f);
  lamp.emission = Rgb(12.f);
  lamp.emission_map.texture = make_texture(4, 1, {1, 1, 1, 1, 1, 1, 0.2f, 0.2f, 0.2f, 0.2f, 0.2f, 0.2f},
                                           TextureWrap::Clamp, TextureWrap::Clamp, "two-tone");
  wall.name = "wall";
  wall.albedo = Rgb(0.6f, 0.6f, 0.5f);
  s.materials = {floor, lamp, wall};
  auto shading = std::make_shared<std::vector<TriangleShading>>();
  test::add_uv_square(s, *shading, 0.0, 4.0, 0, 1.f);
  test::add_uv_square(s, *shading, 2.5, 0.6, 1, 1.f, true);
  s.shading = shading;
  ShapeDesc w;
  w.type = ShapeType::Quad;
  w.vertices = {DVec3(-4, 0, -4), DVec3(4, 0, -4), DVec3(4, 5, -4), DVec3(-4, 5, -4)};
  w.material = 2;
  s.shapes.push_back(w);
  return s;
}
}  // namespace

TEST_CASE("bdpt textures: every strategy alone reads the albedo and emission textures as the path tracer does") {
  // One bounce: path tracing (0, 3) hits the lamp (its emission texture where the ray lands), light tracing
  // (2, 1) starts on the lamp (the texture at the emitted point) and weighs the floor by its textured albedo
  // from the light's side; both against next-event estimation (1, 2). Two bounces: light
  // tracing (3, 1) scatters the light walk on the textured floor, the connection (2, 2) weighs its light end
  // there; against (1, 3).
  // Leaving out any of these lookups fails its strategy (checked: the emitted point's texture, the hit's, and
  // the light walk's materials).
  const SceneDesc one = textured_room(1);
  const Film nee1 = render_estimator(one, Estimator::Bdpt, 256, 1, 1, 2);
  CHECK(blocks_agree(render_estimator(one, Estimator::Bdpt, 1024, 2, 0, 3), nee1, "(0, 3) vs (1, 2)"));
  CHECK(blocks_agree(render_estimator(one, Estimator::Bdpt, 256, 3, 2, 1), nee1, "(2, 1) vs (1, 2)"));
  const SceneDesc two = textured_room(2);
  const Film nee2 = render_estimator(two, Estimator::Bdpt, 256, 4, 1, 3);
  CHECK(blocks_agree(render_estimator(two, Estimator::Bdpt, 512, 5, 3, 1), nee2, "(3, 1) vs (1, 3)"));
  CHECK(blocks_agree(render_estimator(two, Estimator::Bdpt, 256, 6, 2, 2), nee2, "(2, 2) vs (1, 3)"));
}

TEST_CASE("bdpt textures: the whole estimator agrees with mis, and auto does not turn away textured scenes") {
  SceneDesc d = textured_room(3);
  d.render.estimator = Estimator::Bdpt;
  CHECK(validate_scene(d).empty());
  CHECK(blocks_agree(render_estimator(d, Estimator::Bdpt, 128, 7), render_estimator(d, Estimator::Mis, 256, 8),
                     "bdpt vs mis"));
  // auto: nothing here focuses light, so mis, and no word of textures in the reason.
  d.render.estimator = Estimator::Auto;
  const EstimatorChoice c = choose_estimator(d);
  CHECK(c.estimator == Estimator::Mis);
  CHECK(c.reason.find("texture") == std::string::npos);
}

// A normal map tilting the floor's shading normal 30° towards +u everywhere (one texel: the ray cones' filtering
// cannot change it), so the shading frame is far from the surface's and the frames bent for the eye's and the
// light's directions (interaction.h, shading_normal) differ: each strategy alone, and the whole estimator
// against mis.
TEST_CASE("bdpt textures: under a 30 degree normal map every strategy and the whole estimator agree with mis") {
  SceneDesc one = textured_room(1);
  one.materials[0].normal_map.texture =
      make_texture(1, 1, {0.75f, 0.5f, 0.933f}, TextureWrap::Repeat, TextureWrap::Repeat, "tilt");
  one.render.estimator = Estimator::Bdpt;
  CHECK(validate_scene(one).empty());
  const Film nee1 = render_estimator(one, Estimator::Bdpt, 256, 11, 1, 2);
  CHECK(blocks_agree(render_estimator(one, Estimator::Bdpt, 1024, 12, 0, 3), nee1, "tilt (0, 3) vs (1, 2)"));
  CHECK(blocks_agree(render_estimator(one, Estimator::Bdpt, 256, 13, 2, 1), nee1, "tilt (2, 1) vs (1, 2)"));
  SceneDesc two = one;
  two.render.max_bounces = 2;
  const Film nee2 = render_estimator(two, Estimator::Bdpt, 256, 14, 1, 3);
  CHECK(blocks_agree(render_estimator(two, Estimator::Bdpt, 512, 15, 3, 1), nee2, "tilt (3, 1) vs (1, 3)"));
  CHECK(blocks_agree(render_estimator(two, Estimator::Bdpt, 256, 16, 2, 2), nee2, "tilt (2, 2) vs (1, 3)"));
  SceneDesc three = one;
  three.render.max_bounces = 3;
  CHECK(blocks_agree(render_estimator(three, Estimator::Bdpt, 128, 17),
                     render_estimator(three, Estimator::Mis, 256, 18), "tilt bdpt vs mis"));
}

// Each walk stores, at every vertex, the density with which the other walk would have made its predecessor
// (pdf_rev), and the MIS weights recompute the same densities at a connection's ends (pdf_at). Under the tilted
// normal map the camera walk's must be the light walk's defensive mixture (bdpt_vertex.h) and the light walk's
// the camera walk's plain BSDF density: both stored values equal pdf_at's for every vertex of 512 subpaths of
// each kind. Checked: leaving the mixture out of the camera walk's stored density fails it (a relative difference of
// up to 7 %, which the image comparisons above are too weak to see).
TEST_CASE("bdpt textures: under a normal map the walks store the reverse densities the MIS weights compute") {
  SceneDesc d = textured_room(3);
  d.materials[0].normal_map.texture =
      make_texture(1, 1, {0.75f, 0.5f, 0.933f}, TextureWrap::Repeat, TextureWrap::Repeat, "tilt");
  const auto scene = compile_scene(d);
  const Scene& sc = *scene;
  const bdpt_detail::Options o(sc, d.render);
  BdptScratch scratch;
  RayCount count;
  int camera_checked = 0, light_checked = 0, smooth_seen = 0;
  float worst = 0.f;
  const auto compare = [&](float stored, float expected) {
    worst = std::max(worst, std::abs(stored - expected) / std::max(expected, 1e-12f));
  };
  for (int k = 0; k < 512; ++k) {
    const int x = k % 48, y = 8 + k % 24;
    const SobolSampler rng(static_cast<uint64_t>(y * 48 + x), static_cast<uint64_t>(k), 9);
    const Vec2 j = rng.get_2d(SampleDimensions::kCameraJitter);
    const Ray ray = sc.camera.generate_ray(static_cast<float>(x) + j.x, static_cast<float>(y) + j.y);
    bdpt_detail::FirstVertexSplit split;
    REQUIRE(bdpt_detail::camera_subpath<SobolSampler, kAllFeatures>(sc, o, rng, ray, scratch.camera,
                                                                    scratch.camera_materials, nullptr, split, count,
                                                                    nullptr));
    REQUIRE(bdpt_detail::light_subpath<SobolSampler, kAllFeatures>(sc, o, rng, scratch.light, scratch.light_materials,
                                                                   count, nullptr));
    const auto& cam = scratch.camera;
    for (size_t i = 1; i + 1 < cam.size(); ++i) {
      if (cam[i].delta || cam[i + 1].infinite) continue;
      smooth_seen += bdpt_detail::smooth_vertex(cam[i]);
      const bdpt_detail::Link to_next = bdpt_detail::link(cam[i], cam[i + 1]);
      compare(cam[i - 1].pdf_rev,
              bdpt_detail::pdf_at(sc, cam[i], &to_next, bdpt_detail::link(cam[i], cam[i - 1]), cam[i - 1], true));
      ++camera_checked;
    }
    const auto& light = scratch.light;
    for (size_t i = 1; i + 1 < light.size(); ++i) {
      if (light[i].delta) continue;
      const bdpt_detail::Link to_next = bdpt_detail::link(light[i], light[i + 1]);
      compare(light[i - 1].pdf_rev,
              bdpt_detail::pdf_at(sc, light[i], &to_next, bdpt_detail::link(light[i], light[i - 1]), light[i - 1], false));
      ++light_checked;
    }
  }
  MESSAGE("compared " << camera_checked << " camera and " << light_checked << " light vertices (" << smooth_seen
                      << " normal-mapped), largest relative difference " << worst);
  CHECK(camera_checked > 30);
  CHECK(light_checked > 30);
  CHECK(smooth_seen > 10);
  CHECK(worst < 1e-3f);
}
