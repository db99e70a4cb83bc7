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

// A sun straight down (irradiance 2); a floor of albedo 0.5 at y = 0 seen from y = 4; a blocker at y = 6 (above
// the camera, out of view) with the given mask.
SceneDesc sunlit_floor_under(std::shared_ptr<const AlphaMask> mask) {
  SceneDesc s = looking_down();
  MaterialDesc floor, blocker;
  floor.name = "floor";
  floor.albedo = Rgb(0.5f);
  blocker.name = "blocker";
  blocker.albedo = Rgb(0.5f);
  blocker.cutout = std::move(mask);
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
    const auto [left_, right_] = halves(test::render_film(s, 16, 2), s.width, s.height);
    const auto& left = left_; const auto& right = right_;  // clang 14: lambdas cannot capture bindings
    INFO(std::string(to_string(est)) << ": left " << left << ", right " << right);
    CHECK(left == doctest::Approx(1.0));  // through the cut: the background
    CHECK(right == 0.0);                  // the black surface (its own reflections see nothing but black)
  }
  // Without the mask the square is black everywhere (the check above can fail).
  s.materials[0].cutout = nullptr;
  CHECK(halves(test::render_film(s, 4, 2), s.width, s.height).first == 0.0);
}

TEST_CASE("cut-outs: light passes through the cut part of a blocker and not through the rest") {
  // The floor's left half is lit, ρ/π · E, its right half in shadow.
  const SceneDesc s = sunlit_floor_under(left_half_cut());
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
  // OPAQUE (the default) has no mask; BLEND is partial transparency: the factor's alpha times the texture's.
  gltf("opaque.gltf", R"({"name": "plain", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}})");
  CHECK_FALSE(load_gltf(f.path("opaque.gltf")).materials[0].cutout);
  gltf("blend.gltf", R"({"name": "glassy", "alphaMode": "BLEND",
      "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 0.6], "baseColorTexture": {"index": 0}}})");
  const GltfContents blend = load_gltf(f.path("blend.gltf"));
  REQUIRE(blend.materials[0].cutout);
  const AlphaMask& b = *blend.materials[0].cutout;
  CHECK(b.blend);
  CHECK(b.factor == doctest::Approx(0.6));
  // At the texel centres (the sampler repeats, so elsewhere the two texels blend): there with probability
  // 0.6 × 1 on the right, never on the left (alpha 0).
  CHECK_FALSE(b.opaque_at(Vec2(0.75f, 0.5f), 0.61f));
  CHECK(b.opaque_at(Vec2(0.75f, 0.5f), 0.59f));
  CHECK_FALSE(b.opaque_at(Vec2(0.25f, 0.5f), 0.f));
}

TEST_CASE("cut-outs: a BLEND surface of alpha 0.3 shows 0.7 of what is behind it and lets 0.7 of the light through") {
  // Stochastic transparency: every ray meets the surface with probability 0.3, each decided anew, so a pixel's
  // samples average to 0.7 of the background over a black square, and a floor under a blocker gets 0.7 of the
  // sun. Bounds: 4.5 standard errors of the Bernoulli(0.7) average (a false failure about once in 150,000 runs;
  // seeds fixed); an opaque surface (0), the cut-out rule (alpha 0.3 < 0.5: 1) or 1 − alpha swapped (0.3) fail.
  const auto blend = [](float alpha) {
    auto m = std::make_shared<AlphaMask>();
    m->blend = true;
    m->factor = alpha;
    return std::shared_ptr<const AlphaMask>(m);
  };
  SceneDesc s = looking_down();
  s.environment.radiance = Rgb(1.f);
  MaterialDesc black;
  black.name = "black";
  black.albedo = Rgb(0.f);
  black.cutout = blend(0.3f);
  s.materials = {black};
  auto shading = std::make_shared<std::vector<TriangleShading>>();
  test::add_uv_square(s, *shading, 0.0, 1.0, 0);
  s.shading = shading;
  constexpr int kSpp = 256;
  const double se = std::sqrt(0.21 / (kSpp * 64.0));
  for (Estimator est : {Estimator::Cosine, Estimator::Mis}) {
    s.render.estimator = est;
    const auto [left_, right_] = halves(test::render_film(s, kSpp, 2), s.width, s.height);
    const auto& left = left_; const auto& right = right_;  // clang 14: lambdas cannot capture bindings
    INFO(std::string(to_string(est)) << ": " << 0.5 * (left + right) << " (0.7 expected, SE " << se << ")");
    CHECK(std::abs(0.5 * (left + right) - 0.7) <= 4.5 * se);
  }

  const SceneDesc lit = sunlit_floor_under(blend(0.3f));
  const double full = 0.5 / glm::pi<double>() * 2.0;  // ρ/π · E without the blocker
  const auto [left_, right_] = halves(test::render_film(lit, kSpp, 2), lit.width, lit.height);
  const auto& left = left_; const auto& right = right_;  // clang 14: lambdas cannot capture bindings
  INFO("floor: " << 0.5 * (left + right) << ", expected " << 0.7 * full);
  CHECK(std::abs(0.5 * (left + right) - 0.7 * full) <= 4.5 * se * full);
}
