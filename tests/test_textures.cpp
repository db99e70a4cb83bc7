// Image textures (materials/texture.h): sRGB decoding, wrap modes and texel centres against hand-computed values,
// the mip pyramid's box filter, a receding checkerboard against its supersampled render (no aliasing), and
// textures as scene files and glTF files give them.
#include <doctest/doctest.h>

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "core/thread_pool.h"
#include "film/film.h"
#include "integrators/feature_pass.h"
#include "io/image_io.h"
#include "io/texture_io.h"
#include "materials/texture.h"
#include "render/renderer.h"
#include "scene/camera.h"
#include "scene/estimator_choice.h"
#include "gltf_helpers.h"
#include "scene/gltf_import.h"
#include "scene/scene.h"
#include "scene/scene_json.h"
#include "skip.h"
#include "temp_folder.h"
#include "test_helpers.h"
#include "uv_scenes.h"

using namespace pt;

namespace {


std::string read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

Image image(int w, int h, const std::vector<float>& rgb) {
  Image i;
  i.width = w;
  i.height = h;
  i.rgb = rgb;
  return i;
}

}  // namespace

TEST_CASE("textures: 8-bit colour images decode from sRGB with the exact transfer function, data images as they are") {
  test::TempFolder f("tex");
  // One row: 0, 10, 128, 255 in red; green and blue fixed.
  write_png_rgb8(f.path("row.png"), 4, 1, {0, 1, 2, 10, 1, 2, 128, 1, 2, 255, 1, 2});
  const Image srgb = decode_image(read_bytes(f.path("row.png")), true, "row.png");
  REQUIRE(srgb.width == 4);
  REQUIRE(srgb.height == 1);
  // IEC 61966-2-1: v ≤ 0.04045 → v/12.92, else ((v + 0.055)/1.055)^2.4.
  CHECK(srgb.at(0, 0).x == 0.f);
  CHECK(srgb.at(1, 0).x == doctest::Approx(10.0 / 255.0 / 12.92).epsilon(1e-6));
  CHECK(srgb.at(2, 0).x == doctest::Approx(std::pow((128.0 / 255.0 + 0.055) / 1.055, 2.4)).epsilon(1e-6));
  CHECK(srgb.at(2, 0).x == doctest::Approx(0.2158605).epsilon(1e-5));
  CHECK(srgb.at(3, 0).x == doctest::Approx(1.0));
  const Image data = decode_image(read_bytes(f.path("row.png")), false, "row.png");
  CHECK(data.at(2, 0).x == doctest::Approx(128.0 / 255.0));
  // Not an image: refused with the name given.
  try {
    decode_image("not an image at all", true, "bad.png");
    FAIL("garbage decoded");
  } catch (const ImageError& e) {
    CHECK(std::string(e.what()).rfind("bad.png: ", 0) == 0);
  }
}

TEST_CASE("textures: a 16-bit PGM that stb decodes at 8 bits is read within its buffer") {
  // Found by fuzz_texture: a 1 × 1 PGM with maxval 62155 and its data cut short, which stb_image calls 16-bit
  // and whose 16-bit load came back as 3 bytes; reading it as 16-bit texels ran past them (AddressSanitizer's
  // heap-buffer-overflow, caught by the sanitizer stage). Decoded at 8 bits it is one texel in [0, 1].
  std::ifstream in(std::string(PT_TEST_DATA_DIR) + "/pgm_16bit_truncated.pgm", std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  REQUIRE(bytes.size() == 14);
  try {
    const Image img = decode_image(bytes, true, "short.pgm");
    REQUIRE(img.rgb.size() == 3u * img.width * img.height);
    for (float v : img.rgb) CHECK((v >= 0.f && v <= 1.f));
  } catch (const ImageError& e) {
    CHECK(std::string(e.what()).rfind("short.pgm: ", 0) == 0);
  }
}

TEST_CASE("textures: a binary PNM shorter than its header announces is refused before stb reads it") {
  // Found by fuzz_texture: "P5 56 556 5660" and one byte of data (a 16-bit PGM of 56 × 556 texels) made Debian's
  // stb_image read far outside the buffer (AddressSanitizer: SEGV in stbi_load_from_memory). Refused by size.
  std::ifstream in(std::string(PT_TEST_DATA_DIR) + "/pgm_16bit_short.pgm", std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  REQUIRE(bytes.size() == 14);
  CHECK_THROWS_WITH_AS(decode_image(bytes, true, "short.pgm"), doctest::Contains("short.pgm: truncated"), ImageError);
  CHECK_THROWS_WITH_AS(decode_alpha(bytes, "short.pgm", true), doctest::Contains("short.pgm: truncated"), ImageError);
  // A whole one of the same kind decodes: 2 × 1, 16 bits, maxval 65535.
  const std::string whole = std::string("P5 2 1 65535\n") + std::string("\xff\xff\x00\x00", 4);
  const Image img = decode_image(whole, false, "whole.pgm");
  CHECK(img.width == 2);
  CHECK(img.rgb[0] == 1.f);
  CHECK(img.rgb[3] == 0.f);
}

TEST_CASE("textures: texel centres, bilinear weights and the three wrap modes") {
  // Four texels in a row with values 0, 1, 2, 3 (red), one texel high.
  const Image row = image(4, 1, {0, 0, 0, 1, 0, 0, 2, 0, 0, 3, 0, 0});
  const auto at = [&](TextureWrap w, float u) {
    return texture_lookup(*make_texture(row, w, TextureWrap::Repeat, "row"), Vec2(u, 0.5f), 0.f).x;
  };
  // Texel i's centre is u = (i + ½)/4; halfway between two centres the weights are ½ each.
  CHECK(at(TextureWrap::Repeat, 0.375f) == doctest::Approx(1.0));
  CHECK(at(TextureWrap::Repeat, 0.5f) == doctest::Approx(1.5));
  // u = 1.125 is texel 0's centre one period on (repeat), texel 3's edge beyond (clamp), and the mirror image
  // of u = 0.875, texel 3's centre (mirror).
  CHECK(at(TextureWrap::Repeat, 1.125f) == doctest::Approx(0.0));
  CHECK(at(TextureWrap::Clamp, 1.125f) == doctest::Approx(3.0));
  CHECK(at(TextureWrap::Mirror, 1.125f) == doctest::Approx(3.0));
  // Between texel 3 and the next: repeat blends with texel 0, clamp holds texel 3, mirror repeats texel 3.
  CHECK(at(TextureWrap::Repeat, 1.0f) == doctest::Approx(1.5));
  CHECK(at(TextureWrap::Clamp, 1.0f) == doctest::Approx(3.0));
  CHECK(at(TextureWrap::Mirror, 1.0f) == doctest::Approx(3.0));
  // Negative coordinates: u = −0.125 is texel 3's centre repeated, texel 0 clamped, texel 0 mirrored.
  CHECK(at(TextureWrap::Repeat, -0.125f) == doctest::Approx(3.0));
  CHECK(at(TextureWrap::Clamp, -0.125f) == doctest::Approx(0.0));
  CHECK(at(TextureWrap::Mirror, -0.125f) == doctest::Approx(0.0));
  // Far away and non-finite coordinates stay defined.
  CHECK(std::isfinite(at(TextureWrap::Repeat, 3.0e9f)));
  CHECK(std::isfinite(at(TextureWrap::Mirror, std::nanf(""))));
}

TEST_CASE("textures: each mip level is the 2 x 2 box mean of the one above and lookups blend the two around the footprint") {
  // A 4 × 4 checkerboard of single texels (0 and 1): level 1 is 0.5 everywhere, level 2 too.
  std::vector<float> rgb;
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 4; ++x) {
      const float v = static_cast<float>((x + y) % 2);
      rgb.insert(rgb.end(), {v, v, v});
    }
  const auto t = make_texture(image(4, 4, rgb), TextureWrap::Repeat, TextureWrap::Repeat, "checker");
  REQUIRE(t->levels.size() == 3);
  CHECK(t->levels[1].width == 2);
  CHECK(t->levels[2].width == 1);
  for (const Rgb& c : t->levels[1].texels) CHECK(c.x == 0.5f);
  CHECK(t->levels[2].texels[0].x == 0.5f);
  // At texel (1, 0)'s centre (value 1): a footprint of one texel or less reads level 0; two texels, level 1;
  // √2 texels, halfway between (log2 √2 = ½).
  const Vec2 centre(1.5f / 4.f, 0.5f / 4.f);
  CHECK(texture_lookup(*t, centre, 1.f).x == doctest::Approx(1.0));
  CHECK(texture_lookup(*t, centre, 2.f).x == doctest::Approx(0.5));
  CHECK(texture_lookup(*t, centre, std::sqrt(2.f)).x == doctest::Approx(0.75));
  CHECK(texture_lookup(*t, centre, 1e9f).x == doctest::Approx(0.5));  // beyond the last level: the last level
  // An odd size: a 3 × 1 row (0, 1, 2) halves to 1 texel holding the mean of texels 0 and 1.
  const auto odd = make_texture(image(3, 1, {0, 0, 0, 1, 0, 0, 2, 0, 0}), TextureWrap::Repeat, TextureWrap::Repeat, "odd");
  REQUIRE(odd->levels.size() == 2);
  CHECK(odd->levels[1].texels[0].x == doctest::Approx(0.5));
}

namespace {

// A floor plane receding from a camera 1 above it, textured with a fine checkerboard repeated `repeats` times
// across its 200 × 200 extent, under a white sky (no floor is seen from below it): a diffuse surface of albedo
// a under a uniform unit sky reflects exactly a, so every pixel is the texture's filtered value, noise-free but
// for how the texture is sampled.
SceneDesc checker_floor_scene(const std::shared_ptr<const Texture>& checker, float repeats) {
  SceneDesc s;
  s.camera.position = DVec3(0, 1, 0);
  s.camera.look_at = DVec3(0, 0.8, -10);
  s.camera.fov_deg = 40;
  s.width = 48;
  s.height = 32;
  s.render.max_bounces = 1;
  s.render.estimator = Estimator::Mis;
  s.render.sampler = SamplerType::Independent;
  s.environment.radiance = Rgb(1.f);
  MaterialDesc floor;
  floor.name = "floor";
  floor.albedo = Rgb(1.f);
  floor.albedo_map = checker;
  s.materials = {floor};
  auto shading = std::make_shared<std::vector<TriangleShading>>();
  test::add_uv_square(s, *shading, 0.0, 100.0, 0, repeats);
  s.shading = shading;
  return s;
}

}  // namespace

TEST_CASE("textures: a receding checkerboard filtered by ray cones matches its supersampled render without aliasing") {
  // 64 × 64 texels in checks of 8 × 8, repeated 50 times across the plane (checks 0.5 wide): near the camera a
  // check spans pixels, towards the horizon hundreds fall in one. The reference is independent of the renderer's
  // filtering: each pixel the mean of the unfiltered texture (level 0) over 32 × 32 stratified points of it,
  // traced to the plane y = −1 (camera-relative) by hand.
  std::vector<float> rgb;
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 64; ++x) {
      const float v = static_cast<float>((x / 8 + y / 8) % 2);
      rgb.insert(rgb.end(), {v, v, v});
    }
  const auto checker = make_texture(image(64, 64, rgb), TextureWrap::Repeat, TextureWrap::Repeat, "checker");
  const float repeats = 50.f;
  SceneDesc d = checker_floor_scene(checker, repeats);
  const Camera camera = compile_camera(d.camera, d.width, d.height);
  const auto reference_at = [&](int x, int y) {
    double sum = 0;
    for (int j = 0; j < 32; ++j)
      for (int i = 0; i < 32; ++i) {
        const Ray r = camera.generate_ray(x + (i + 0.5f) / 32.f, y + (j + 0.5f) / 32.f);
        if (!(r.d.y < 0.f)) continue;
        const Vec3 p = r.o + (-1.f / r.d.y) * r.d;  // world x, z (the camera sits at x = z = 0)
        sum += texture_lookup(*checker, Vec2((p.x + 100.f) / 200.f * repeats, (p.z + 100.f) / 200.f * repeats), 0.f).x;
      }
    return sum / (32 * 32);
  };
  const auto rms_error = [&](const Film& film, int y0, int y1) {
    double sq = 0;
    int n = 0;
    for (int y = y0; y < y1; ++y)
      for (int x = 0; x < d.width; ++x) {
        const double e = film.mean(static_cast<size_t>(y) * d.width + x).x - reference_at(x, y);
        sq += e * e;
        ++n;
      }
    return std::sqrt(sq / n);
  };
  const int horizon = d.height / 2 + 2;  // the first rows below the horizon: 64 to 1000 texels per pixel
  d.render.seed = 4;
  const double far4 = rms_error(test::render_film(d, 4, 2), horizon, horizon + 4);
  const double all64 = rms_error(test::render_film(d, 64, 2), horizon, d.height);
  MESSAGE("rms error against the supersampled reference: far rows at 4 spp " << far4 << ", whole floor at 64 spp " << all64);
  // Far away the filtered lookups hold the mean of many checks: measured 0.085, against 0.135 with level 0
  // forced (unfiltered: each of the 4 samples is 0 or 1). Over the floor, 64 samples converge on the reference
  // with little bias: measured 0.036, against 0.088 for a cone a whole pixel wide at every sample (which blurs
  // each pixel over two). Deterministic (fixed seed): the bounds sit between the right and the wrong figures.
  CHECK(far4 < 0.11);
  CHECK(all64 < 0.05);
}

TEST_CASE("textures: the feature guide and the film's albedo layer see the textured albedo") {
  // A floor of a uniform texture (0.2, 0.6, 0.9) × factor (1, 1, 0.5): the guide the viewer's preview multiplies
  // back, and the albedo layer of a render, hold the product (the untextured factor alone would be (1, 1, 0.5)).
  const auto tint = make_texture(image(1, 1, {0.2f, 0.6f, 0.9f}), TextureWrap::Repeat, TextureWrap::Repeat, "tint");
  SceneDesc d = checker_floor_scene(tint, 4.f);
  d.materials[0].albedo = Rgb(1.f, 1.f, 0.5f);
  const auto scene = compile_scene(d);
  ThreadPool pool(2);
  FeatureImage guide;
  trace_feature_image(*scene, d.render, pool, guide);
  const size_t i = static_cast<size_t>(d.height - 2) * d.width + d.width / 2;  // a floor pixel
  CHECK(guide.albedo[3 * i] == doctest::Approx(0.2f));
  CHECK(guide.albedo[3 * i + 1] == doctest::Approx(0.6f));
  CHECK(guide.albedo[3 * i + 2] == doctest::Approx(0.45f));
  const Film film = test::render_film(d, 2, 2, true);
  CHECK(film.albedo_image()[3 * i + 1] == doctest::Approx(0.6f));
}

TEST_CASE("textures: a scene file's albedo_texture loads, multiplies albedo, saves as a file reference and is checked") {
  test::TempFolder f("tex");
  write_png_rgb8(f.path("red.png"), 2, 2, {255, 0, 0, 255, 0, 0, 255, 0, 0, 255, 0, 0});
  const auto scene_with = [&](const std::string& material) {
    return R"({"camera": {"position": [0, 0, 5], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov_deg": 40},
      "film": {"width": 8, "height": 8}, "render": {"max_bounces": 2, "estimator": "auto"}, "background": [1, 1, 1],
      "materials": {"paint": )" + material + R"(},
      "shapes": [{"type": "triangle", "vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0]], "material": "paint"}]})";
  };
  const SceneDesc s = parse_scene(scene_with(R"({"type": "diffuse", "albedo_texture": "red.png"})"), "s.json", f.dir.string());
  REQUIRE(s.materials[0].albedo_map);
  CHECK(s.materials[0].albedo == Rgb(1.f));  // without "albedo" the texture stands alone
  CHECK(s.materials[0].albedo_map->width() == 2);
  CHECK(s.materials[0].albedo_map->levels[0].at(1, 1) == Rgb(1.f, 0.f, 0.f));
  // Saved relative to where it is written, read back the same; bdpt takes it (test_bdpt_textures.cpp), auto
  // takes mis (nothing focuses light).
  const std::string text = scene_to_json(s, f.dir.string());
  CHECK(text.find("\"albedo_texture\": \"red.png\"") != std::string::npos);
  const SceneDesc back = parse_scene(text, "back.json", f.dir.string());
  CHECK(back.materials[0].albedo_texture == "red.png");
  CHECK(choose_estimator(s).estimator == Estimator::Mis);
  SceneDesc bdpt = s;
  bdpt.render.estimator = Estimator::Bdpt;
  CHECK(validate_scene(bdpt).empty());
  // A texture on a material that takes none, and a file that is no image, are refused by their keys.
  const auto error = [&](const std::string& material) {
    try {
      parse_scene(scene_with(material), "s.json", f.dir.string());
    } catch (const SceneError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  CHECK(error(R"({"type": "dielectric", "albedo_texture": "red.png"})").find("materials.paint") != std::string::npos);
  f.write("junk.png", "junk");
  CHECK(error(R"({"type": "diffuse", "albedo_texture": "junk.png"})").find("materials.paint.albedo_texture") != std::string::npos);
  CHECK(error(R"({"type": "diffuse", "albedo_texture": "missing.png"})").find("materials.paint.albedo_texture") != std::string::npos);
  CHECK(error(R"({"type": "subsurface", "albedo_texture": "red.png"})").find("albedo_texture") != std::string::npos);
}

TEST_CASE("textures: a glTF base colour texture from a file beside the model, its sampler and its factor") {
  test::TempFolder f("tex");
  // 2 × 2: top-left red, top-right green, bottom-left blue, bottom-right white (rows top first).
  write_png_rgb8(f.path("four.png"), 2, 2, {255, 0, 0, 0, 255, 0, 0, 0, 255, 255, 255, 255});
  test::one_triangle_gltf(f, "tri.gltf", R"("images": [{"uri": "four.png"}],
    "samplers": [{"wrapS": 33071, "wrapT": 33648}],
    "textures": [{"source": 0, "sampler": 0}],
    "materials": [{"name": "painted", "pbrMetallicRoughness": {"baseColorFactor": [0.5, 1, 1, 1],
                   "baseColorTexture": {"index": 0}, "metallicFactor": 0}}])");
  const GltfContents g = test::flat_gltf(f.path("tri.gltf"));
  REQUIRE(g.materials.size() == 1);
  const MaterialDesc& m = g.materials[0];
  REQUIRE(m.albedo_map);
  CHECK(m.albedo == Rgb(0.5f, 1.f, 1.f));  // the factor; the texture multiplies it when shading
  CHECK(m.albedo_map->wrap_u == TextureWrap::Clamp);
  CHECK(m.albedo_map->wrap_v == TextureWrap::Mirror);
  // glTF's uv origin is the image's top-left texel: uv (0, 0) is red, (1, 0) green, (0, 1) blue.
  const Texture& t = *m.albedo_map;
  CHECK(texture_lookup(t, Vec2(0.25f, 0.25f), 0.f) == Rgb(1.f, 0.f, 0.f));
  CHECK(texture_lookup(t, Vec2(0.75f, 0.25f), 0.f) == Rgb(0.f, 1.f, 0.f));
  CHECK(texture_lookup(t, Vec2(0.25f, 0.75f), 0.f) == Rgb(0.f, 0.f, 1.f));
  REQUIRE(g.shading.size() == 1);
  CHECK(g.shading[0].has_uv);
  CHECK(g.shading[0].uv[2] == Vec2(0, 1));
  // The image missing, or not an image: refused with the glTF path.
  std::filesystem::remove(f.path("four.png"));
  try {
    load_gltf(f.path("tri.gltf"));
    FAIL("a missing image was accepted");
  } catch (const SceneError& e) {
    CHECK(std::string(e.what()).find("images[0]") != std::string::npos);
  }
  f.write("four.png", "not a png");
  try {
    load_gltf(f.path("tri.gltf"));
    FAIL("an undecodable image was accepted");
  } catch (const SceneError& e) {
    CHECK(std::string(e.what()).find("images[0]") != std::string::npos);
  }
}

TEST_CASE("textures: KHR_texture_transform's offset, rotation and scale as Khronos' TextureTransformTest checks them") {
  // The sample model marks the right rotation green: u' = u cos r + v sin r, v' = −u sin r + v cos r (seen:
  // every arrow of its bottom row points at its green marker; with the README's GLSL matrix, at the red one).
  const std::string file = "/usr/share/assimp/models/glTF2/textureTransform/TextureTransformTest.gltf";
  if (!std::filesystem::exists(file)) {
    test::skip_for_missing("assimp-testmodels", "the texture transform test");
    return;
  }
  const GltfContents g = load_gltf(file);
  const auto transform_of = [&](const std::string& name) {
    for (const MaterialDesc& m : g.materials)
      if (m.name == name) return m.albedo_uv_transform;
    FAIL("no material " << name);
    return glm::mat3(1.f);
  };
  const auto apply = [](const glm::mat3& m, float u, float v) { return Vec2(m * glm::vec3(u, v, 1.f)); };
  const auto near = [](Vec2 a, Vec2 b) { return glm::length(a - b) < 1e-6f; };
  CHECK(near(apply(transform_of("Offset U"), 0.2f, 0.3f), Vec2(0.7f, 0.3f)));
  CHECK(near(apply(transform_of("Offset UV"), 0.2f, 0.3f), Vec2(0.7f, 0.8f)));
  const float r = 0.39269908169872414f;
  CHECK(near(apply(transform_of("Rotation"), 1.f, 0.f), Vec2(std::cos(r), -std::sin(r))));
  CHECK(near(apply(transform_of("Rotation"), 0.f, 1.f), Vec2(std::sin(r), std::cos(r))));
  CHECK(near(apply(transform_of("Scale"), 0.2f, 0.4f), Vec2(0.3f, 0.6f)));
  // All: offset (−0.2, −0.1), rotation 0.3, scale 1.5, applied scale first.
  const Vec2 s(1.5f * 0.4f, 1.5f * 0.2f);
  const Vec2 all(s.x * std::cos(0.3f) + s.y * std::sin(0.3f) - 0.2f, -s.x * std::sin(0.3f) + s.y * std::cos(0.3f) - 0.1f);
  CHECK(near(apply(transform_of("All"), 0.4f, 0.2f), all));
  CHECK(transform_of("Correct") == glm::mat3(1.f));
}
