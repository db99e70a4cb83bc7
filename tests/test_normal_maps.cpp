// Normal maps and the metallic-roughness texture (materials/normal_map.h, integrators/path_tracer.h:
// material_at): the tangent frame's convention against hand-worked frames, a normal-mapped floor under a
// directional light against the closed form, the white furnace, and glTF's normalTexture and
// metallicRoughnessTexture read and applied.
#include <doctest/doctest.h>

#include <cmath>
#include <string>
#include <vector>

#include "film/film.h"
#include "io/image_io.h"
#include "io/texture_io.h"
#include "materials/normal_map.h"
#include "render/renderer.h"
#include "scene/gltf_import.h"
#include "scene/scene.h"
#include "temp_folder.h"
#include "test_helpers.h"
#include "uv_scenes.h"

using namespace pt;

namespace {

// No tangent from the file: the frame comes from the uv mapping.
const Vec4 kUvFrame(0.f);

// The texel that encodes the tangent-space normal n (unit, z > 0).
Rgb encode(Vec3 n) { return (n + Vec3(1.f)) * 0.5f; }

std::shared_ptr<const Texture> constant_map(Rgb texel) {
  return make_texture(1, 1, {texel.x, texel.y, texel.z}, TextureWrap::Repeat, TextureWrap::Repeat, "constant");
}

// A floor y = 0 (20 wide, uv (0, 0) at its far-left corner, u along +x, v along +z: glTF's v grows down the
// image, so the image's up is −z), seen straight down from y = 4 by a narrow camera whose image's up is −z.
// One bounce, black surroundings unless `furnace` (a constant environment of radiance 1, many bounces).
SceneDesc mapped_floor(const MaterialDesc& material, bool furnace) {
  SceneDesc s;
  test::look_down_from_4(s, 2);
  s.width = s.height = 4;
  s.render.max_bounces = furnace ? 64 : 1;
  s.render.russian_roulette_depth = -1;
  s.render.estimator = Estimator::Mis;
  s.render.sampler = SamplerType::Independent;
  if (furnace) s.environment.radiance = Rgb(1.f);
  s.materials = {material};
  auto shading = std::make_shared<std::vector<TriangleShading>>();
  test::add_uv_square(s, *shading, 0.0, 10.0, 0);
  s.shading = shading;
  return s;
}

// The light of the closed-form floor tests: a diffuse floor of albedo 0.5 under a directional light of 3 W/m²
// towards l = (1, 1, −0.5)/|·|. One bounce of a delta light gives L = ρ/π · E · max(0, n·l) exactly for the
// shading normal n, whatever the map's tilt.
struct SunOnFloor {
  MaterialDesc floor;
  PunctualLightDesc sun;
  DVec3 l = glm::normalize(DVec3(1, 1, -0.5));
  SunOnFloor() {
    floor.name = "floor";
    floor.albedo = Rgb(0.5f);
    sun.kind = PunctualKind::Directional;
    sun.direction = -l;
    sun.intensity = Rgb(3.f);
  }
  // The floor's material with a constant map of the tangent-space normal n.
  MaterialDesc mapped(Vec3 n) const {
    MaterialDesc m = floor;
    m.normal_map.texture = constant_map(encode(n));
    return m;
  }
  double radiance(DVec3 world_normal) const { return 0.5 / glm::pi<double>() * 3.0 * std::max(0.0, glm::dot(world_normal, l)); }
};

double mean_of(const Film& film) {
  double sum = 0;
  for (size_t i = 0; i < film.pixel_count(); ++i) sum += film.mean(i).x;
  return sum / static_cast<double>(film.pixel_count());
}

}  // namespace

TEST_CASE("normal maps: the tangent frame is (dp/du, image up, n) and mirrored uv keeps the bumps") {
  // A surface z = 0 seen from +z, u growing along +x and v along −y (so the image's up is +y).
  const Vec3 ng(0, 0, 1), du_dp(1, 0, 0), dv_dp(0, -1, 0);
  const float s30 = 0.5f, c30 = std::sqrt(3.f) / 2.f;
  const auto close = [](Vec3 a, Vec3 b) { return glm::length(a - b) < 1e-5f; };
  CHECK(close(normal_mapped(ng, ng, du_dp, dv_dp, kUvFrame, encode({0, 0, 1}), 1.f), ng));  // the flat texel
  CHECK(close(normal_mapped(ng, ng, du_dp, dv_dp, kUvFrame, encode({s30, 0, c30}), 1.f), Vec3(s30, 0, c30)));  // red: +u
  CHECK(close(normal_mapped(ng, ng, du_dp, dv_dp, kUvFrame, encode({0, s30, c30}), 1.f), Vec3(0, s30, c30)));  // green: up
  // Scaled x and y (glTF's normalTexture.scale), renormalised.
  CHECK(close(normal_mapped(ng, ng, du_dp, dv_dp, kUvFrame, encode({s30, 0, c30}), 0.5f),
              glm::normalize(Vec3(0.5f * s30, 0, c30))));
  // uv mirrored in u (an island flipped in the atlas): the tangent follows u, to −x.
  CHECK(close(normal_mapped(ng, ng, -du_dp, dv_dp, kUvFrame, encode({s30, 0, c30}), 1.f), Vec3(-s30, 0, c30)));
  // uv mirrored in v: the image's up follows, to −y.
  CHECK(close(normal_mapped(ng, ng, du_dp, -dv_dp, kUvFrame, encode({0, s30, c30}), 1.f), Vec3(0, -s30, c30)));
  // Stretched and sheared uv: t stays along dp/du (v constant), here the x axis for dv_dp along y.
  CHECK(close(normal_mapped(ng, ng, Vec3(3, 1, 0), Vec3(0, -2, 0), kUvFrame, encode({s30, 0, c30}), 1.f), Vec3(s30, 0, c30)));
  // A texel below the surface is held 1° above it; a degenerate uv mapping leaves the normal alone.
  const Vec3 low = normal_mapped(ng, ng, du_dp, dv_dp, kUvFrame, Rgb(0.f, 0.5f, 0.5f), 1.f);
  CHECK(glm::dot(low, ng) == doctest::Approx(std::sin(glm::radians(1.f))).epsilon(1e-3));
  CHECK(low.x < 0.f);
  CHECK(close(normal_mapped(ng, ng, du_dp, du_dp, kUvFrame, encode({s30, 0, c30}), 1.f), ng));
  CHECK(close(normal_mapped(ng, ng, Vec3(0.f), dv_dp, kUvFrame, encode({s30, 0, c30}), 1.f), ng));
  // On a smooth-shaded surface the map tilts the interpolated normal (the frame is built around it).
  const Vec3 ns = glm::normalize(Vec3(0, 0.2f, 1));
  const Vec3 bent = normal_mapped(ns, ng, du_dp, dv_dp, kUvFrame, encode({0, 0, 1}), 1.f);
  CHECK(close(bent, ns));
}

TEST_CASE("normal maps: a file's tangent t gives the frame t and w·(n × t) and n and takes precedence over the uv mapping") {
  // The same surface as above (uv frame t = +x, b = +y), but the file's tangent says +y: red tilts towards +y,
  // green towards w·(z × y) = −w·x.
  const Vec3 ng(0, 0, 1), du_dp(1, 0, 0), dv_dp(0, -1, 0);
  const float s30 = 0.5f, c30 = std::sqrt(3.f) / 2.f;
  const auto close = [](Vec3 a, Vec3 b) { return glm::length(a - b) < 1e-5f; };
  CHECK(close(normal_mapped(ng, ng, du_dp, dv_dp, Vec4(0, 1, 0, 1), encode({s30, 0, c30}), 1.f), Vec3(0, s30, c30)));
  CHECK(close(normal_mapped(ng, ng, du_dp, dv_dp, Vec4(0, 1, 0, 1), encode({0, s30, c30}), 1.f), Vec3(-s30, 0, c30)));
  CHECK(close(normal_mapped(ng, ng, du_dp, dv_dp, Vec4(0, 1, 0, -1), encode({0, s30, c30}), 1.f), Vec3(s30, 0, c30)));
  // Not unit, and not orthogonal to the shading normal: made so (Gram–Schmidt), its length irrelevant.
  CHECK(close(normal_mapped(ng, ng, du_dp, dv_dp, Vec4(0, 3, 2, 1), encode({s30, 0, c30}), 1.f), Vec3(0, s30, c30)));
  // A tangent along the normal gives no frame: the uv mapping's is used.
  CHECK(close(normal_mapped(ng, ng, du_dp, dv_dp, Vec4(0, 0, 1, 1), encode({s30, 0, c30}), 1.f), Vec3(s30, 0, c30)));
  // And without a uv mapping, the file's frame alone still bends the normal.
  CHECK(close(normal_mapped(ng, ng, Vec3(0.f), Vec3(0.f), Vec4(0, 1, 0, 1), encode({s30, 0, c30}), 1.f), Vec3(0, s30, c30)));
}

namespace {

// mapped_floor's floor as an instanced mesh (its uv the same) whose vertices carry the file tangent `tangent`,
// placed by `place`.
SceneDesc tangent_floor(const MaterialDesc& material, Vec4 tangent, const glm::dmat4& place) {
  SceneDesc s = mapped_floor(material, false);
  s.shapes.clear();
  s.shading.reset();
  auto m = std::make_shared<MeshDesc>();
  const float h = 10.f;
  m->position = {Vec3(-h, 0, h), Vec3(h, 0, h), Vec3(h, 0, -h), Vec3(-h, 0, -h)};
  m->uv = {Vec2(0, 1), Vec2(1, 1), Vec2(1, 0), Vec2(0, 0)};
  m->tangent.assign(4, tangent);
  m->index = {{0, 1, 2}, {0, 2, 3}};
  m->slot = {0, 0};
  m->fit_box();
  s.meshes.push_back(m);
  InstanceDesc in;
  in.mesh = 0;
  in.transform = place;
  in.materials = {0};
  s.instances.push_back(in);
  return s;
}

}  // namespace

TEST_CASE("normal maps: a floor tilted by its map shines by the cosine of the tilted normal") {
  // On this floor (mapped_floor) the tangent frame is t = +x (u), b = −z (the image's up), n = +y, so a map
  // normal (x, y, z) is x·t + y·b + z·n in the world.
  const SunOnFloor lit;
  const float s30 = 0.5f, c30 = std::sqrt(3.f) / 2.f;
  for (const Vec3 n : {Vec3(0, 0, 1), Vec3(s30, 0, c30), Vec3(0, s30, c30), Vec3(0, -s30, c30), Vec3(-s30, 0, c30)}) {
    SceneDesc d = mapped_floor(lit.mapped(n), false);
    d.punctual_lights = {lit.sun};
    const DVec3 world = double(n.x) * DVec3(1, 0, 0) + double(n.y) * DVec3(0, 0, -1) + double(n.z) * DVec3(0, 1, 0);
    INFO("map normal (" << n.x << " " << n.y << " " << n.z << ")");
    CHECK(mean_of(test::render_film(d, 4, 2)) == doctest::Approx(lit.radiance(world)).epsilon(2e-3));
  }
}

TEST_CASE("normal maps: a mesh's file tangents turn its bumps and a mirroring placement mirrors them") {
  // The floor of the test above with the file's tangent +z (the uv mapping's is +x): a map normal (x, y, z) is
  // x·t + y·b + z·n with t = +z, b = (+y) × (+z) = +x, n = +y. Mirrored in x by its placement, the floor shows
  // the mirror image of those bumps: the world normal's x negated. The uv frame would give other values
  // (checked, so the test can tell the frames apart).
  const SunOnFloor lit;
  const float s30 = 0.5f, c30 = std::sqrt(3.f) / 2.f;
  glm::dmat4 mirror(1.0);
  mirror[0][0] = -1.0;
  for (const bool mirrored : {false, true})
    for (const Vec3 n : {Vec3(s30, 0, c30), Vec3(0, s30, c30), Vec3(-s30, 0, c30), Vec3(0, -s30, c30)}) {
      SceneDesc d = tangent_floor(lit.mapped(n), Vec4(0, 0, 1, 1), mirrored ? mirror : glm::dmat4(1.0));
      d.punctual_lights = {lit.sun};
      DVec3 world = double(n.x) * DVec3(0, 0, 1) + double(n.y) * DVec3(1, 0, 0) + double(n.z) * DVec3(0, 1, 0);
      if (mirrored) world.x = -world.x;
      const DVec3 uv_world = double(n.x) * DVec3(1, 0, 0) + double(n.y) * DVec3(0, 0, -1) + double(n.z) * DVec3(0, 1, 0);
      INFO("map normal (" << n.x << " " << n.y << " " << n.z << ")" << (mirrored ? ", mirrored" : ""));
      REQUIRE(std::abs(lit.radiance(world) - lit.radiance(uv_world)) > 0.01 * lit.radiance(world));
      CHECK(mean_of(test::render_film(d, 4, 2)) == doctest::Approx(lit.radiance(world)).epsilon(2e-3));
    }
}

TEST_CASE("normal maps: a normal-mapped floor in the white furnace stays at its albedo") {
  // Strong bumps (normals up to 60° off, in every direction) on a diffuse floor under radiance 1: every path
  // must return ρ on average, whichever way the map turns the shading frame (light sampling and BSDF sampling
  // alike), with nothing lost where a shading hemisphere dips below the surface. 4 standard errors.
  std::vector<float> rgb;
  for (int j = 0; j < 8; ++j)
    for (int i = 0; i < 8; ++i) {
      const float phi = 0.7f * static_cast<float>(i + 8 * j), theta = glm::radians(15.f + 5.f * static_cast<float>((i * 3 + j) % 10));
      const Rgb t = encode({std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)});
      rgb.insert(rgb.end(), {t.x, t.y, t.z});
    }
  for (float rho : {0.7f, 1.f})
    for (Estimator est : {Estimator::Cosine, Estimator::Mis}) {
      MaterialDesc m;
      m.name = "bumpy";
      m.albedo = Rgb(rho);
      m.normal_map.texture = make_texture(8, 8, rgb, TextureWrap::Repeat, TextureWrap::Repeat, "bumps");
      SceneDesc d = mapped_floor(m, true);
      d.render.estimator = est;
      d.camera.fov_deg = 30;  // many bumps in view
      d.width = d.height = 16;
      const test::MeanWithError e = test::film_mean(test::render_film(d, 256, 2));
      INFO("albedo " << rho << ", " << std::string(to_string(est)) << ": " << e.mean.x << " ± " << e.se.x);
      CHECK(std::abs(e.mean.x - rho) <= 4 * e.se.x + 1e-4);
    }
}

TEST_CASE("normal maps: glTF's normalTexture and metallicRoughnessTexture are read, and the latter scales the factors") {
  test::TempFolder f("nmap");
  // A 1 × 1 normal map tilted towards +u, and a metallic-roughness texel (r unused, g roughness 0.5, b metallic 0).
  write_png_rgb8(f.path("n.png"), 1, 1, {191, 128, 221});
  write_png_rgb8(f.path("mr.png"), 1, 1, {0, 128, 0});
  test::one_triangle_gltf(f, "tri.gltf", R"("images": [{"uri": "n.png"}, {"uri": "mr.png"}],
    "textures": [{"source": 0}, {"source": 1}],
    "materials": [{"name": "bumpy", "normalTexture": {"index": 0, "scale": 0.5},
                   "pbrMetallicRoughness": {"metallicFactor": 1, "roughnessFactor": 1,
                                            "metallicRoughnessTexture": {"index": 1}}}])");
  const GltfContents g = load_gltf(f.path("tri.gltf"));
  REQUIRE(g.materials.size() == 1);
  const MaterialDesc& m = g.materials[0];
  REQUIRE(m.normal_map.texture);
  REQUIRE(m.metallic_roughness_map.texture);
  CHECK(m.normal_scale == 0.5f);
  // Data textures are linear: 128/255, not its sRGB decoding (0.216).
  CHECK(texture_lookup(*m.metallic_roughness_map.texture, Vec2(0.5f), 0.f).y == doctest::Approx(128.f / 255.f));
  CHECK(texture_lookup(*m.normal_map.texture, Vec2(0.5f), 0.f).x == doctest::Approx(191.f / 255.f));

  // Applied: a metallic-roughness floor whose texture says metallic × 0 and roughness × 0.5 renders exactly as
  // the same material with metallic 0 and roughness 0.5 given as numbers (same seed, same samples).
  MaterialDesc textured;
  textured.name = "floor";
  textured.type = MaterialType::MetallicRoughness;
  textured.albedo = Rgb(0.8f, 0.5f, 0.2f);
  textured.metallic = 1.f;
  textured.roughness = 1.f;
  textured.metallic_roughness_map.texture = constant_map(Rgb(0.f, 0.5f, 0.f));
  MaterialDesc plain = textured;
  plain.metallic_roughness_map = {};
  plain.metallic = 0.f;
  plain.roughness = 0.5f;
  PunctualLightDesc sun;
  sun.kind = PunctualKind::Directional;
  sun.direction = glm::normalize(DVec3(-1, -2, 0.3));
  SceneDesc a = mapped_floor(textured, false), b = mapped_floor(plain, false);
  a.punctual_lights = b.punctual_lights = {sun};
  a.camera.position = b.camera.position = DVec3(-2, 4, 0);  // off the mirror direction: glossy and diffuse both
  const Film fa = test::render_film(a, 8, 1), fb = test::render_film(b, 8, 1);
  for (size_t i = 0; i < fa.pixel_count(); ++i) CHECK(fa.mean(i) == fb.mean(i));
  // And the metal it would be without the texture renders differently (the check above can fail).
  SceneDesc metal = a;
  metal.materials[0].metallic_roughness_map = {};
  CHECK(test::render_film(metal, 8, 1).mean(0) != fa.mean(0));
}
