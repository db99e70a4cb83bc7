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

TEST_CASE("bdpt textures: the whole estimator agrees with mis, normal maps are refused and auto says so") {
  SceneDesc d = textured_room(3);
  d.render.estimator = Estimator::Bdpt;
  CHECK(validate_scene(d).empty());
  SceneDesc mapped = d;
  mapped.materials[0].normal_map.texture =
      make_texture(1, 1, {0.75f, 0.5f, 0.933f}, TextureWrap::Repeat, TextureWrap::Repeat, "tilt");
  CHECK(validate_scene(mapped).find("normal maps") != std::string::npos);
  mapped.render.estimator = Estimator::Auto;
  CHECK(choose_estimator(mapped).reason.find("normal maps") != std::string::npos);
  CHECK(blocks_agree(render_estimator(d, Estimator::Bdpt, 128, 7), render_estimator(d, Estimator::Mis, 256, 8),
                     "bdpt vs mis"));
  // auto: nothing here focuses light, so mis, and no word of textures in the reason.
  d.render.estimator = Estimator::Auto;
  const EstimatorChoice c = choose_estimator(d);
  CHECK(c.estimator == Estimator::Mis);
  CHECK(c.reason.find("texture") == std::string::npos);
}
