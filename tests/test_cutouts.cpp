// Cut-outs (geometry/alpha_mask.h; glTF alpha mode MASK): the mask's rule, a cut quad seen against a bright
// background, its shadow, and glTF's alphaMode/alphaCutoff/baseColorFactor alpha read with the image's alpha.
#include <doctest/doctest.h>

#include <stb_image_write.h>

#include <cmath>
#include <string>
#include <vector>

#include "film/film.h"
#include "geometry/alpha_mask.h"
#include "io/texture_io.h"
#include "render/renderer.h"
#include "scene/gltf_import.h"
#include "scene/scene.h"
#include "temp_folder.h"
#include "test_helpers.h"
#include "uv_scenes.h"

using namespace pt;

namespace {

// A mask whose left half (u < 0.5) is cut away: 2 × 1 texels, alpha 0 then 1, clamped at the edges.
std::shared_ptr<const AlphaMask> left_half_cut() {
  auto m = std::make_shared<AlphaMask>();
  m->alpha = make_texture(2, 1, {0, 0, 0, 1, 1, 1}, TextureWrap::Clamp, TextureWrap::Clamp, "half");
  m->cutoff = 0.5f;
  return m;
}

// Seen straight down from y = 4 (image up = −z, so image left = −x = u < 0.5), 8 × 8 pixels over x ∈ ±0.9.
SceneDesc looking_down() {
  SceneDesc s;
  test::look_down_from_4(s, 2.0 * glm::degrees(std::atan(0.9 / 4.0)));
  s.width = s.height = 8;
  s.render.max_bounces = 1;
  s.render.estimator = Estimator::Mis;
  s.render.sampler = SamplerType::Independent;
  return s;
}

// Mean radiance of the image's left and right halves.
std::pair<double, double> halves(const Film& f, int width, int height) {
  double left = 0, right = 0;
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) (x < width / 2 ? left : right) += f.mean(static_cast<size_t>(y) * width + x).x;
  const double n = width * height / 2.0;
  return {left / n, right / n};
}

}  // namespace

TEST_CASE("cut-outs: the mask's rule: opaque where factor x alpha reaches the cutoff") {
  AlphaMask m;
  m.alpha = make_texture(2, 1, {0.2f, 0.2f, 0.2f, 0.8f, 0.8f, 0.8f}, TextureWrap::Clamp, TextureWrap::Clamp, "a");
  m.cutoff = 0.5f;
  CHECK_FALSE(m.opaque_at(Vec2(0.1f, 0.5f)));  // 0.2
  CHECK(m.opaque_at(Vec2(0.9f, 0.5f)));        // 0.8
  CHECK(m.opaque_at(Vec2(0.5f, 0.5f)));        // bilinear: 0.5, the cutoff itself is opaque (glTF: alpha ≥ cutoff)
  m.factor = 0.5f;                              // 0.4 at the right: cut too
  CHECK_FALSE(m.opaque_at(Vec2(0.9f, 0.5f)));
  AlphaMask constant;  // no image: the factor alone
  constant.factor = 0.3f;
  CHECK_FALSE(constant.opaque_at(Vec2(0.7f)));
  constant.factor = 0.6f;
  CHECK(constant.opaque_at(Vec2(0.7f)));
}

TEST_CASE("cut-outs: a black square cut in its left half shows the bright background there and nothing else") {
  SceneDesc s = looking_down();
  s.environment.radiance = Rgb(1.f);  // radiance 1 wherever a ray escapes
  MaterialDesc black;
  black.name = "black";
  black.albedo = Rgb(0.f);
  black.cutout = left_half_cut();
  s.materials = {black};
  auto shading = std::make_shared<std::vector<TriangleShading>>();
  test::add_uv_square(s, *shading, 0.0, 1.0, 0);
  s.shading = shading;
  for (Estimator est : {Estimator::Cosine, Estimator::Mis}) {
    s.render.estimator = est;
    const auto [left, right] = halves(test::render_film(s, 16, 2), s.width, s.height);
    INFO(std::string(to_string(est)) << ": left " << left << ", right " << right);
    CHECK(left == doctest::Approx(1.0));  // through the cut: the background
    CHECK(right == 0.0);                  // the black surface (its own reflections see nothing but black)
  }
  // Without the mask the square is black everywhere (the check above can fail).
  s.materials[0].cutout = nullptr;
  CHECK(halves(test::render_film(s, 4, 2), s.width, s.height).first == 0.0);
}

TEST_CASE("cut-outs: light passes through the cut part of a blocker and not through the rest") {
  // A sun straight down; a white floor at y = 0 seen from y = 4; a blocker at y = 6 (above the camera, out of
  // view) cut in its left half. The floor's left half is lit, ρ/π · E, its right half in shadow.
  SceneDesc s = looking_down();
  MaterialDesc floor, blocker;
  floor.name = "floor";
  floor.albedo = Rgb(0.5f);
  blocker.name = "blocker";
  blocker.albedo = Rgb(0.5f);
  blocker.cutout = left_half_cut();
  s.materials = {floor, blocker};
  auto shading = std::make_shared<std::vector<TriangleShading>>();
  test::add_uv_square(s, *shading, 0.0, 10.0, 0);
  test::add_uv_square(s, *shading, 6.0, 10.0, 1);
  s.shading = shading;
  PunctualLightDesc sun;
  sun.kind = PunctualKind::Directional;
  sun.direction = DVec3(0, -1, 0);
  sun.intensity = Rgb(2.f);
  s.punctual_lights = {sun};
  const auto [left, right] = halves(test::render_film(s, 4, 2), s.width, s.height);
  CHECK(left == doctest::Approx(0.5 / glm::pi<double>() * 2.0).epsilon(1e-4));
  CHECK(right == 0.0);
}

TEST_CASE("cut-outs: glTF alphaMode MASK reads alphaCutoff, the factor's alpha and the texture's alpha channel") {
  test::TempFolder f("cut");
  // 2 × 1 RGBA: left transparent, right opaque.
  const unsigned char rgba[] = {255, 255, 255, 0, 255, 255, 255, 255};
  REQUIRE(stbi_write_png(f.path("leaf.png").c_str(), 2, 1, 4, rgba, 8));
  const auto gltf = [&](const std::string& name, const std::string& material) {
    return test::one_triangle_gltf(f, name, R"("images": [{"uri": "leaf.png"}], "textures": [{"source": 0}],
    "materials": [)" + material + "]");
  };
  gltf("mask.gltf", R"({"name": "leaf", "alphaMode": "MASK", "alphaCutoff": 0.3,
      "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 0.8], "baseColorTexture": {"index": 0}}})");
  const GltfContents g = load_gltf(f.path("mask.gltf"));
  REQUIRE(g.materials[0].cutout);
  const AlphaMask& m = *g.materials[0].cutout;
  CHECK(m.cutoff == 0.3f);
  CHECK(m.factor == 0.8f);
  REQUIRE(m.alpha);
  CHECK_FALSE(m.opaque_at(Vec2(0.1f, 0.5f)));
  CHECK(m.opaque_at(Vec2(0.9f, 0.5f)));
  // The colour texture of the same image stays RGB (its alpha is not its colour).
  REQUIRE(g.materials[0].albedo_map);
  CHECK(texture_lookup(*g.materials[0].albedo_map, Vec2(0.1f, 0.5f), 0.f) == Rgb(1.f));
  // OPAQUE (the default) has no mask; BLEND is opaque, with a warning.
  gltf("opaque.gltf", R"({"name": "plain", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}})");
  CHECK_FALSE(load_gltf(f.path("opaque.gltf")).materials[0].cutout);
  gltf("blend.gltf", R"({"name": "glassy", "alphaMode": "BLEND", "pbrMetallicRoughness": {}})");
  const GltfContents blend = load_gltf(f.path("blend.gltf"));
  CHECK_FALSE(blend.materials[0].cutout);
  bool warned = false;
  for (const std::string& w : blend.warnings) warned = warned || w.find("BLEND") != std::string::npos;
  CHECK(warned);
}
