// Textured emitters (glTF emissiveTexture; lights/light_sampling.h: emission_texel): the texture seen directly,
// light sampling reading the same texture as rays that hit the light (estimators that find the light only by
// hitting it agree with those that sample it), and glTF's emissiveTexture read.
#include <doctest/doctest.h>

#include <cmath>
#include <string>
#include <vector>

#include "film/film.h"
#include "io/image_io.h"
#include "io/texture_io.h"
#include "render/renderer.h"
#include "scene/gltf_import.h"
#include "scene/scene.h"
#include "temp_folder.h"
#include "test_helpers.h"
#include "uv_scenes.h"

using namespace pt;

namespace {

// 4 × 1 texels, linear: the left two `left`, the right two `right` (clamped at the edges).
std::shared_ptr<const Texture> two_tone(float left, float right) {
  return make_texture(4, 1, {left, left, left, left, left, left, right, right, right, right, right, right},
                      TextureWrap::Clamp, TextureWrap::Clamp, "two-tone");
}

}  // namespace

TEST_CASE("emission textures: an emitter seen directly shows its factor times its texture") {
  SceneDesc s;
  test::look_down_from_4(s, 2.0 * glm::degrees(std::atan(0.9 / 4.0)));  // image left = −x = small u
  s.width = s.height = 8;
  s.render.max_bounces = 1;
  MaterialDesc lamp;
  lamp.name = "lamp";
  lamp.albedo = Rgb(0.f);
  lamp.emission = Rgb(2.f);
  lamp.emission_map.texture = two_tone(0.25f, 1.f);
  s.materials = {lamp};
  auto shading = std::make_shared<std::vector<TriangleShading>>();
  test::add_uv_square(s, *shading, 0.0, 1.0, 0);
  s.shading = shading;
  const Film f = test::render_film(s, 4, 2);
  // The outer pixel columns see u in [0.05, 0.16] and [0.84, 0.95]: texels of one tone only.
  for (int y = 0; y < s.height; ++y) {
    CHECK(f.mean(static_cast<size_t>(y) * s.width).x == doctest::Approx(0.5));
    CHECK(f.mean(static_cast<size_t>(y) * s.width + s.width - 1).x == doctest::Approx(2.0));
  }
}

TEST_CASE("emission textures: light samples read the texture as hits do: cosine and mis agree on the lit floor") {
  // A floor (albedo 0.5) under a downward-facing square lamp, bright on its −x half, dim on its +x half. cosine
  // finds the lamp only by hitting it; mis mostly by sampling it. Each half of the image agrees within 4.5
  // standard errors of the difference (fixed seeds; two-sided ~7e-6 per check). Were the light samples to read
  // the factor alone, or the texture mirrored, mis would be 2.3x too bright on one side.
  SceneDesc s;
  s.camera.position = DVec3(0, 3, 3);
  s.camera.look_at = DVec3(0, 0, 0);
  s.camera.fov_deg = 40;
  s.width = 16;
  s.height = 12;
  s.render.max_bounces = 1;
  s.render.sampler = SamplerType::Independent;
  MaterialDesc floor, lamp;
  floor.name = "floor";
  floor.albedo = Rgb(0.5f);
  lamp.name = "lamp";
  lamp.albedo = Rgb(0.f);
  lamp.emission = Rgb(3.f);
  lamp.emission_map.texture = two_tone(1.f, 0.1f);
  s.materials = {floor, lamp};
  auto shading = std::make_shared<std::vector<TriangleShading>>();
  test::add_uv_square(s, *shading, 0.0, 4.0, 0);
  test::add_uv_square(s, *shading, 1.0, 0.6, 1, 1.f, true);
  s.shading = shading;
  // The pixels of a half differ by the real falloff across the floor, so the comparison takes the difference of
  // the two estimators pixel by pixel (same pixels, independent noise) and its spread over the half.
  SceneDesc a = s, b = s;
  a.render.estimator = Estimator::Cosine;
  b.render.estimator = Estimator::Mis;
  a.render.seed = 1;
  b.render.seed = 2;
  const Film fa = test::render_film(a, 1024, 2), fb = test::render_film(b, 256, 2);
  for (int side = 0; side < 2; ++side) {
    std::vector<double> diff;
    double level = 0;
    for (int y = s.height / 2; y < s.height; ++y)
      for (int x = side * s.width / 2; x < (side + 1) * s.width / 2; ++x) {
        const size_t i = static_cast<size_t>(y) * s.width + x;
        diff.push_back(double(fa.mean(i).x) - double(fb.mean(i).x));
        level += fb.mean(i).x;
      }
    level /= double(diff.size());
    double m = 0, q = 0;
    for (double x : diff) m += x;
    m /= double(diff.size());
    for (double x : diff) q += (x - m) * (x - m);
    const double se = std::sqrt(q / (double(diff.size()) - 1) / double(diff.size()));
    INFO("side " << side << ": cosine - mis = " << m << " +- " << se << " (mis mean " << level << ")");
    CHECK(std::abs(m) <= 4.5 * se);
    CHECK(se < 0.05 * level);  // the comparison is sharp enough to see a 2.3x error
  }
}

TEST_CASE("emission textures: glTF's emissiveTexture times the factor and strength") {
  test::TempFolder f("emit");
  write_png_rgb8(f.path("glow.png"), 1, 1, {255, 128, 0});
  test::one_triangle_gltf(f, "tri.gltf", R"("images": [{"uri": "glow.png"}], "textures": [{"source": 0}],
    "materials": [{"name": "sign", "emissiveFactor": [1, 1, 1], "emissiveTexture": {"index": 0},
                   "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 5}}}])");
  const GltfContents g = load_gltf(f.path("tri.gltf"));
  REQUIRE(g.materials.size() == 1);
  const MaterialDesc& m = g.materials[0];
  CHECK(m.emission == Rgb(5.f));
  REQUIRE(m.emission_map.texture);
  // sRGB-decoded like a colour: 128 → 0.2158.
  CHECK(texture_lookup(*m.emission_map.texture, Vec2(0.5f), 0.f).y == doctest::Approx(srgb_to_linear(128.f / 255.f)));
  CHECK(g.emits);
}

TEST_CASE("emission textures: an emitter without texture coordinates emits its factor, seen and sampled alike") {
  // A scene-file quad has no uv: its light reads no texture, and a hit on it must not either (a texel at uv
  // (0, 0), black here, would make the lamp black where rays hit it and bright where light samples land).
  SceneDesc s;
  test::look_down_from_4(s, 10);
  s.width = s.height = 4;
  s.render.max_bounces = 1;
  MaterialDesc lamp;
  lamp.name = "lamp";
  lamp.albedo = Rgb(0.f);
  lamp.emission = Rgb(2.f);
  lamp.emission_map.texture = two_tone(0.f, 1.f);
  s.materials = {lamp};
  ShapeDesc q;
  q.type = ShapeType::Quad;
  q.vertices = {DVec3(-1, 0, 1), DVec3(1, 0, 1), DVec3(1, 0, -1), DVec3(-1, 0, -1)};
  s.shapes = {q};
  const Film f = test::render_film(s, 2, 2);
  for (size_t i = 0; i < f.pixel_count(); ++i) CHECK(f.mean(i).x == doctest::Approx(2.0));
}
