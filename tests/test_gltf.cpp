// glTF 2.0 import (scene/gltf_import.h): hand-built files whose answers are known (node transform order, mirror
// winding, camera, index types, material mapping), refusals that name the glTF path, and Debian's
// assimp-testmodels corpus: every well-formed file loads and renders, every broken one is refused.
#include <doctest/doctest.h>

#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <set>
#include <string>
#include <vector>

#include "film/film.h"
#include "render/renderer.h"
#include "gltf_helpers.h"
#include "scene/gltf_import.h"
#include "scene/scene.h"
#include "scene/scene_json.h"
#include "skip.h"

using namespace pt;

namespace {

std::string base64(const std::string& bytes) {
  static const char* k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const uint32_t v = (uint8_t(bytes[i]) << 16) | (uint8_t(bytes[i + 1]) << 8) | uint8_t(bytes[i + 2]);
    out += {k[v >> 18], k[(v >> 12) & 63], k[(v >> 6) & 63], k[v & 63]};
  }
  if (i + 1 == bytes.size()) {
    const uint32_t v = uint8_t(bytes[i]) << 16;
    out += {k[v >> 18], k[(v >> 12) & 63], '=', '='};
  } else if (i + 2 == bytes.size()) {
    const uint32_t v = (uint8_t(bytes[i]) << 16) | (uint8_t(bytes[i + 1]) << 8);
    out += {k[v >> 18], k[(v >> 12) & 63], k[(v >> 6) & 63], '='};
  }
  return out;
}

template <class T>
void append(std::string& buf, const std::vector<T>& v) {
  buf.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
}

struct TempDir {
  std::filesystem::path path;
  TempDir() {
    path = std::filesystem::temp_directory_path() / ("pt_gltf_test_" + std::to_string(::getpid()));
    std::filesystem::create_directories(path);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
  std::string write(const std::string& name, const std::string& text) const {
    const std::string p = (path / name).string();
    std::ofstream(p, std::ios::binary) << text;
    return p;
  }
};

// One triangle (0,0,0), (1,0,0), (0,1,0) (counter-clockwise seen from +z) with unsigned-short indices, in a
// buffer embedded as a data URI. `nodes`, `extra` (more top-level members) and `primitive` (more primitive
// members) are JSON fragments; the scene's roots are `roots`.
std::string triangle_gltf(const std::string& nodes, const std::string& roots, const std::string& extra = "",
                          const std::string& primitive = "", const std::string& materials = "") {
  std::string buf;
  append(buf, std::vector<float>{0, 0, 0, 1, 0, 0, 0, 1, 0});
  append(buf, std::vector<uint16_t>{0, 1, 2, 0});  // padded to 4 bytes
  return R"({"asset": {"version": "2.0"},
  "buffers": [{"byteLength": )" + std::to_string(buf.size()) + R"(, "uri": "data:application/octet-stream;base64,)" +
         base64(buf) + R"("}],
  "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 6}],
  "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"},
                {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}],
  "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1)" + primitive + R"(}]}],
  "materials": [)" + materials + R"(],
  "nodes": [)" + nodes + R"(],
  "scenes": [{"nodes": [)" + roots + R"(]}], "scene": 0)" + extra + "}";
}

void replace_once(std::string& s, const std::string& from, const std::string& to) {
  const size_t at = s.find(from);
  REQUIRE(at != std::string::npos);
  s.replace(at, from.size(), to);
}

void check_vertex(DVec3 got, DVec3 want) {
  INFO("got " << got.x << " " << got.y << " " << got.z << ", want " << want.x << " " << want.y << " " << want.z);
  CHECK(glm::length(got - want) < 1e-12);
}

// The error message of loading `text`, or "" when it loads.
std::string load_error(const TempDir& dir, const std::string& text) {
  try {
    load_gltf(dir.write("bad.gltf", text));
  } catch (const SceneError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST_CASE("gltf: node transforms compose parent then child and translation then rotation then scale") {
  TempDir dir;
  // Child: scale 2 then a quarter turn about +z then a move by (1, 2, 3); parent: a move by (10, 0, 0).
  // (1,0,0) -> (2,0,0) -> (0,2,0) -> (1,4,3) -> (11,4,3); (0,1,0) -> (0,2,0) -> (-2,0,0) -> (-1,2,3) -> (9,2,3).
  const std::string s = std::to_string(std::sqrt(0.5));
  const GltfContents g = test::flat_gltf(dir.write("trs.gltf", triangle_gltf(
      R"({"translation": [10, 0, 0], "children": [1]},
         {"mesh": 0, "translation": [1, 2, 3], "rotation": [0, 0, )" + s + ", " + s + R"(], "scale": [2, 2, 2]})",
      "0")));
  REQUIRE(g.triangles.size() == 1);
  check_vertex(g.triangles[0][0], DVec3(11, 2, 3));
  check_vertex(g.triangles[0][1], DVec3(11, 4, 3));
  check_vertex(g.triangles[0][2], DVec3(9, 2, 3));
  // The same as one column-major matrix: columns (0,2,0), (-2,0,0), (0,0,2), (11,2,3).
  const GltfContents m = test::flat_gltf(dir.write("matrix.gltf", triangle_gltf(
      R"({"mesh": 0, "matrix": [0,2,0,0, -2,0,0,0, 0,0,2,0, 11,2,3,1]})", "0")));
  REQUIRE(m.triangles.size() == 1);
  for (int k = 0; k < 3; ++k) check_vertex(m.triangles[0][k], g.triangles[0][k]);
  // Nodes outside the scene are not shown; a mesh used by two nodes is shown twice, by two instances of it.
  const GltfContents two = load_gltf(dir.write("two.gltf", triangle_gltf(
      R"({"mesh": 0}, {"mesh": 0, "translation": [0, 0, 5]}, {"mesh": 0, "translation": [0, 0, 9]})", "0, 1")));
  CHECK(two.triangles.empty());
  REQUIRE(two.instances.size() == 2);
  CHECK(two.meshes.size() == 1);
  CHECK(two.instances[0].transform[3][2] == 0.0);
  CHECK(two.instances[1].transform[3][2] == 5.0);
}

TEST_CASE("gltf: a mirroring transform keeps each face's front by listing its vertices the other way round") {
  TempDir dir;
  auto front_z = [](const std::array<DVec3, 3>& t) { return glm::cross(t[1] - t[0], t[2] - t[0]).z; };
  const GltfContents plain = test::flat_gltf(dir.write("plain.gltf", triangle_gltf(R"({"mesh": 0})", "0")));
  const GltfContents mirrored = test::flat_gltf(dir.write("mirror.gltf", triangle_gltf(R"({"mesh": 0, "scale": [-1, 1, 1]})", "0")));
  REQUIRE(plain.triangles.size() == 1);
  REQUIRE(mirrored.triangles.size() == 1);
  CHECK(front_z(plain.triangles[0]) > 0.0);
  CHECK(front_z(mirrored.triangles[0]) > 0.0);  // without the swap the mirror image faces -z
  std::set<double> xs;
  for (const DVec3& v : mirrored.triangles[0]) xs.insert(v.x);
  CHECK(xs == std::set<double>{-1.0, 0.0});
}

TEST_CASE("gltf: the first perspective camera gives position, view direction, field of view and film shape") {
  TempDir dir;
  const std::string text = triangle_gltf(
      R"({"mesh": 0}, {"camera": 0, "translation": [0, 0, 5], "rotation": [0, 1, 0, 0]})", "0, 1",
      R"(, "cameras": [{"type": "perspective", "perspective": {"yfov": 0.5, "aspectRatio": 2.0, "znear": 0.1}}])");
  const GltfContents g = load_gltf(dir.write("camera.gltf", text));
  REQUIRE(g.camera);
  check_vertex(g.camera->position, DVec3(0, 0, 5));
  // A half turn about +y: the camera's -z view direction becomes +z.
  check_vertex(g.camera->look_at, DVec3(0, 0, 6));
  check_vertex(g.camera->up, DVec3(0, 1, 0));
  CHECK(g.camera->fov_deg == doctest::Approx(0.5 * 180.0 / 3.14159265358979).epsilon(1e-12));
  CHECK(g.aspect_ratio == 2.0);
  const SceneDesc s = gltf_scene(dir.path.string() + "/camera.gltf");
  CHECK(s.width == 640);
  CHECK(s.height == 320);
  // No camera: one that frames the triangle, looking at the centre of its bounds.
  const SceneDesc framed = gltf_scene(dir.write("nocam.gltf", triangle_gltf(R"({"mesh": 0})", "0")));
  check_vertex(framed.camera.look_at, DVec3(0.5, 0.5, 0));
  // Turned 45° about +z by its node, it is framed by its vertices as placed, (0, 0), (√½, √½), (−√½, √½): not by
  // its turned box, whose centre would sit at y = √½.
  const std::string q = std::to_string(std::sin(glm::pi<double>() / 8)), w = std::to_string(std::cos(glm::pi<double>() / 8));
  const SceneDesc turned = gltf_scene(dir.write("turned.gltf", triangle_gltf(R"({"mesh": 0, "rotation": [0, 0, )" + q + ", " + w + "]}", "0")));
  CHECK(std::abs(turned.camera.look_at.x) < 1e-6);
  CHECK(turned.camera.look_at.y == doctest::Approx(0.5 * std::sqrt(0.5)).epsilon(1e-6));
}

TEST_CASE("gltf: materials map to the metallic-roughness BRDF or glass and emitters decide the background") {
  TempDir dir;
  const std::string materials =
      R"({"name": "gold", "pbrMetallicRoughness": {"baseColorFactor": [1, 0.8, 0.3, 1], "metallicFactor": 1, "roughnessFactor": 0.25}},
         {"name": "water", "pbrMetallicRoughness": {"metallicFactor": 0, "roughnessFactor": 0},
          "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1}, "KHR_materials_ior": {"ior": 1.33}}},
         {"name": "paint", "pbrMetallicRoughness": {"baseColorFactor": [0.2, 0.4, 0.6, 1], "metallicFactor": 0.3, "roughnessFactor": 0.5},
          "extensions": {"KHR_materials_ior": {"ior": 1.7}}},
         {"name": "lamp", "emissiveFactor": [1, 0.5, 0.25], "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 4}},
          "pbrMetallicRoughness": {"metallicFactor": 0}})";
  for (int which = 0; which < 4; ++which) {
    const GltfContents g = test::flat_gltf(dir.write("m.gltf", triangle_gltf(R"({"mesh": 0})", "0", "",
                                                                     ", \"material\": " + std::to_string(which), materials)));
    REQUIRE(g.materials.size() == 4);
    REQUIRE(g.triangle_material.size() == 1);
    const MaterialDesc& d = g.materials[g.triangle_material[0]];
    INFO("material " << which << " " << d.name);
    if (which == 0) {
      CHECK(d.type == MaterialType::MetallicRoughness);
      CHECK(d.albedo == Rgb(1.f, 0.8f, 0.3f));
      CHECK(d.metallic == 1.f);
      CHECK(d.roughness == 0.25f);
      CHECK(d.ior == 1.5f);  // the specification's dielectric F0 = 0.04
    } else if (which == 1) {
      CHECK(d.type == MaterialType::Dielectric);
      CHECK(d.ior == 1.33f);
      CHECK(d.roughness == 0.f);
    } else if (which == 2) {
      CHECK(d.type == MaterialType::MetallicRoughness);
      CHECK(d.metallic == 0.3f);  // kept as it is, not rounded
      CHECK(d.roughness == 0.5f);
      CHECK(d.ior == 1.7f);
      CHECK(d.albedo == Rgb(0.2f, 0.4f, 0.6f));
    } else {
      CHECK(d.emission == Rgb(4.f, 2.f, 1.f));
      CHECK(g.emits);
    }
  }
  // A primitive without a material: the specification's default (white, metallic 1, roughness 1).
  const GltfContents none = load_gltf(dir.write("none.gltf", triangle_gltf(R"({"mesh": 0})", "0")));
  REQUIRE(none.materials.size() == 1);
  CHECK(none.materials[0].type == MaterialType::MetallicRoughness);
  CHECK(none.materials[0].metallic == 1.f);
  CHECK(none.materials[0].albedo == Rgb(1.f));
  CHECK(none.materials[0].roughness == 1.f);
  CHECK_FALSE(none.emits);
  CHECK(gltf_scene(dir.path.string() + "/none.gltf").environment.type == EnvironmentType::Sky);  // daylight
  const SceneDesc lamp = gltf_scene(dir.path.string() + "/m.gltf");  // its own lamp, in the dark
  CHECK(lamp.environment.type == EnvironmentType::Constant);
  CHECK(lamp.environment.radiance == Rgb(0.f));
}

TEST_CASE("gltf: broken files are refused with the file and the glTF path of the fault") {
  TempDir dir;
  struct Bad {
    std::string text, expect;
  };
  const std::string ok_nodes = R"({"mesh": 0})";
  std::vector<Bad> bad = {
      {triangle_gltf(ok_nodes, "0", "", ", \"mode\": 1"), "meshes[0].primitives[0].mode: mode 1 is not supported"},
      {triangle_gltf(ok_nodes, "0", "", ", \"material\": 3"), "meshes[0].primitives[0].material: material 3 does not exist"},
      {triangle_gltf(R"({"mesh": 0, "children": [1]}, {"children": [0]})", "0"), "the node graph has a cycle"},
      {triangle_gltf(R"({"mesh": 4})", "0"), "nodes[0].mesh: mesh 4 does not exist"},
      {triangle_gltf(ok_nodes, "0", R"(, "extensionsRequired": ["KHR_draco_mesh_compression"], "extensionsUsed": ["KHR_draco_mesh_compression"])"),
       "the extension KHR_draco_mesh_compression is required but not supported"},
  };
  // An index past the vertex count, an accessor past its view, a view past its buffer, a NaN position.
  std::string t = triangle_gltf(ok_nodes, "0");
  std::string idx = t;
  replace_once(idx, R"("count": 3, "type": "SCALAR")", R"("count": 4, "type": "SCALAR")");
  bad.push_back({idx, "meshes[0].primitives[0].indices (accessors[1]): 4 elements from byte 0 run past the end of its buffer view"});
  std::string view = t;
  replace_once(view, R"("byteOffset": 36, "byteLength": 6})", R"("byteOffset": 36, "byteLength": 60})");
  bad.push_back({view, "bufferViews[1]: bytes 36 + 60 run past the end of buffers[0]"});
  {
    std::string buf;
    append(buf, std::vector<float>{0, 0, 0, std::nanf(""), 0, 0, 0, 1, 0});
    append(buf, std::vector<uint16_t>{0, 1, 2, 0});
    std::string nan = t;
    const size_t at = nan.find("base64,") + 7;
    nan.replace(at, nan.find('"', at) - at, base64(buf));
    bad.push_back({nan, "meshes[0].primitives[0].attributes.POSITION: position 1 is not finite"});
  }
  {
    std::string buf;
    append(buf, std::vector<float>{0, 0, 0, 1, 0, 0, 0, 1, 0});
    append(buf, std::vector<uint16_t>{0, 1, 7, 0});
    std::string past = t;
    const size_t at = past.find("base64,") + 7;
    past.replace(at, past.find('"', at) - at, base64(buf));
    bad.push_back({past, "meshes[0].primitives[0].indices: index 2 is 7, past the 3 vertices"});
  }
  bad.push_back({"{\"asset\": {\"version\": \"2.0\"}, \"nodes\": [", "not a valid glTF 2.0 file"});
  for (const Bad& b : bad) {
    const std::string err = load_error(dir, b.text);
    INFO("expected: " << b.expect << "\ngot: " << err);
    CHECK(err.find(dir.path.string() + "/bad.gltf: ") == 0);
    CHECK(err.find(b.expect) != std::string::npos);
  }
}

TEST_CASE("gltf: index types and a .glb file read alike") {
  TempDir dir;
  // Unsigned bytes and ints instead of shorts.
  std::string bytes_buf, ints_buf;
  append(bytes_buf, std::vector<float>{0, 0, 0, 1, 0, 0, 0, 1, 0});
  ints_buf = bytes_buf;
  append(bytes_buf, std::vector<uint8_t>{0, 1, 2, 0});
  append(ints_buf, std::vector<uint32_t>{0, 1, 2});
  for (const auto& [buf, type, len] : {std::tuple{bytes_buf, 5121, 3}, std::tuple{ints_buf, 5125, 12}}) {
    std::string t = triangle_gltf(R"({"mesh": 0})", "0");
    const size_t at = t.find("base64,") + 7;
    t.replace(at, t.find('"', at) - at, base64(buf));
    replace_once(t, "\"byteLength\": 44", "\"byteLength\": " + std::to_string(buf.size()));
    replace_once(t, "\"byteOffset\": 36, \"byteLength\": 6}", "\"byteOffset\": 36, \"byteLength\": " + std::to_string(len) + "}");
    replace_once(t, "\"componentType\": 5123", "\"componentType\": " + std::to_string(type));
    const GltfContents g = test::flat_gltf(dir.write("idx.gltf", t));
    REQUIRE(g.triangles.size() == 1);
    check_vertex(g.triangles[0][2], DVec3(0, 1, 0));
  }
  // The same triangle as a binary .glb: a JSON chunk and a BIN chunk (glTF 2.0 §4.4).
  std::string bin;
  append(bin, std::vector<float>{0, 0, 0, 1, 0, 0, 0, 1, 0});
  append(bin, std::vector<uint16_t>{0, 1, 2, 0});
  std::string json = R"({"asset": {"version": "2.0"}, "buffers": [{"byteLength": 44}],
    "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 6}],
    "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"},
                  {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
    "nodes": [{"mesh": 0, "translation": [0, 0, -2]}], "scenes": [{"nodes": [0]}]})";
  while (json.size() % 4) json += ' ';
  auto u32 = [](uint32_t v) { return std::string(reinterpret_cast<const char*>(&v), 4); };
  const std::string glb = "glTF" + u32(2) + u32(12 + 8 + json.size() + 8 + bin.size()) + u32(json.size()) +
                          "JSON" + json + u32(bin.size()) + std::string("BIN\0", 4) + bin;
  const GltfContents g = test::flat_gltf(dir.write("tri.glb", glb));
  REQUIRE(g.triangles.size() == 1);
  check_vertex(g.triangles[0][1], DVec3(1, 0, -2));
  // A header that claims far more bytes than the file has is refused, not trusted.
  std::string lying = glb;
  lying.replace(8, 4, u32(0xFFFFFFF0u));
  CHECK(load_error(dir, lying).find("not a valid glTF 2.0 file") != std::string::npos);
}

TEST_CASE("gltf: every well-formed file of Debian's assimp-testmodels corpus renders and every broken one is refused") {
  const std::filesystem::path corpus = "/usr/share/assimp/models/glTF2";
  if (!std::filesystem::is_directory(corpus)) {
    test::skip_for_missing("assimp-testmodels", "the glTF corpus test");
    return;
  }
  // Refused, each for a reason named in its message: broken files, and features refused rather than guessed.
  const std::vector<std::pair<std::string, std::string>> refused = {
      {"BoxWithInfinites-glTF-Binary/BoxWithInfinites.glb", "is not finite"},
      {"IncorrectVertexArrays/Cube.gltf", "do not make whole triangles"},
      {"IndexOutOfRange/AllIndicesOutOfRange.gltf", "past the 24 vertices"},
      {"IndexOutOfRange/IndexOutOfRange.gltf", "past the 24 vertices"},
      {"MissingBin/BoxTextured.gltf", "not found"},
      {"RecursiveNodes/RecursiveNodes.gltf", "cycle"},
      {"SchemaFailures/sceneWrongType.gltf", "not a valid glTF 2.0 file"},
      {"TestNoRootNode/NoScene.gltf", "no triangles to show"},
      {"TestNoRootNode/SceneWithoutNodes.gltf", "no triangles to show"},
      {"draco/2CylinderEngine.gltf", "not a valid glTF 2.0 file"},
      {"wrongTypes/badArray.gltf", "no triangles to show"},
      {"wrongTypes/badNumber.gltf", "not a valid glTF 2.0 file"},
      {"BoxTextured-glTF-techniqueWebGL/BoxTextured.gltf", "KHR_technique_webgl is required"},
  };
  std::set<std::string> expected_refusals;
  for (const auto& r : refused) expected_refusals.insert(r.first);
  int rendered = 0, refusals = 0;
  Renderer renderer(2);
  for (const auto& entry : std::filesystem::recursive_directory_iterator(corpus)) {
    const std::string ext = entry.path().extension().string();
    if (ext != ".gltf" && ext != ".glb") continue;
    const std::string rel = std::filesystem::relative(entry.path(), corpus).string();
    INFO(rel);
    // Primitive modes other than triangles (points, lines, strips, fans) are refused by name.
    const bool other_mode = rel.find("Mesh_PrimitiveMode_") != std::string::npos;
    std::string error;
    SceneDesc desc;
    try {
      desc = gltf_scene(entry.path().string());
    } catch (const SceneError& e) {
      error = e.what();
    }
    if (!error.empty()) {
      ++refusals;
      CHECK(error.find(entry.path().string() + ": ") == 0);
      const auto it = std::find_if(refused.begin(), refused.end(), [&](const auto& r) { return r.first == rel; });
      if (it != refused.end()) CHECK(error.find(it->second) != std::string::npos);
      else {
        const bool refused_mode = other_mode && error.find("is not supported (only triangles, mode 4)") != std::string::npos;
        CHECK_MESSAGE(refused_mode, "refused unexpectedly: " << error);
      }
      continue;
    }
    CHECK(expected_refusals.count(rel) == 0);
    desc.width = 16;
    desc.height = 12;
    const auto scene = compile_scene(desc);
    Film film(desc.width, desc.height);
    renderer.render_pass(*scene, desc.render, film, 1);
    const std::vector<float> img = film.mean_image();
    bool finite = true;
    for (float v : img) finite = finite && std::isfinite(v);
    CHECK(finite);
    CHECK(film.min_count() == 1u);
    ++rendered;
  }
  MESSAGE(rendered << " files rendered, " << refusals << " refused");
  CHECK(rendered >= 20);
  CHECK(refusals >= static_cast<int>(refused.size()));
}

TEST_CASE("gltf: a scene file places a glTF model with a transform, its materials named after it and overridable") {
  TempDir dir;
  const std::string materials =
      R"({"name": "paint", "pbrMetallicRoughness": {"baseColorFactor": [0.2, 0.4, 0.6, 1], "metallicFactor": 0}})";
  dir.write("model.gltf", triangle_gltf(R"({"mesh": 0, "translation": [1, 0, 0]})", "0", "", R"(, "material": 0)", materials));
  auto scene_json = [](const std::string& extra_materials, const std::string& shape_extra) {
    return R"({"camera": {"position": [0, 0, 10], "look_at": [0, 0, 0], "fov_deg": 40},
      "materials": {"white": {"type": "diffuse", "albedo": [0.7, 0.7, 0.7]})" + extra_materials + R"(},
      "shapes": [{"type": "quad", "vertices": [[-5,-5,-1],[5,-5,-1],[5,5,-1],[-5,5,-1]], "material": "white"},
                 {"type": "gltf", "name": "toy", "file": "model.gltf",
                  "transform": {"scale": 2, "translate": [0, 0, 3]})" + shape_extra + R"(}]})";
  };
  const SceneDesc s = parse_scene(scene_json("", ""), "placed.json", dir.path.string());
  REQUIRE(s.objects.size() == 1);
  const ObjectDesc& o = s.objects[0];
  CHECK(o.kind == ObjectKind::Gltf);
  CHECK(o.name == "toy");
  CHECK(o.shape_count == 0);  // its mesh is placed by an instance
  const std::vector<test::PlacedTriangle> placed = test::object_triangles(s, 0);
  REQUIRE(placed.size() == 1);
  const test::PlacedTriangle& t = placed[0];
  // File (0,0,0),(1,0,0),(0,1,0), moved by its node to x + 1, then scaled by 2 and lifted by 3 in z.
  check_vertex(t.v[0], DVec3(2, 0, 3));
  check_vertex(t.v[1], DVec3(4, 0, 3));
  check_vertex(t.v[2], DVec3(2, 2, 3));
  REQUIRE(s.materials.size() == 2);
  CHECK(s.materials[t.material].name == "toy/paint");
  CHECK(s.materials[t.material].albedo == Rgb(0.2f, 0.4f, 0.6f));
  // Saved and read back: the same triangles and materials (the model stays a reference to its file).
  const std::string saved = scene_to_json(s, dir.path.string());
  CHECK(saved.find("\"type\": \"gltf\"") != std::string::npos);
  const SceneDesc back = parse_scene(saved, "saved.json", dir.path.string());
  CHECK(test::object_triangles(back, 0)[0].v == t.v);
  CHECK(back.materials.size() == 2);
  // An edited model material is written among the materials and overrides the file's on reading.
  SceneDesc edited = s;
  edited.materials[t.material].albedo = Rgb(0.9f, 0.1f, 0.1f);
  const SceneDesc edited_back = parse_scene(scene_to_json(edited, dir.path.string()), "e.json", dir.path.string());
  REQUIRE(edited_back.materials.size() == 2);
  CHECK(edited_back.materials[test::object_triangles(edited_back, 0)[0].material].albedo == Rgb(0.9f, 0.1f, 0.1f));
  // "material" gives the whole model one of the scene's materials; so does saving a model recoloured so.
  const SceneDesc one = parse_scene(scene_json("", R"(, "material": "white")"), "one.json", dir.path.string());
  CHECK(one.materials.size() == 1);
  CHECK(test::object_triangles(one, 0)[0].material == 0);
  SceneDesc recoloured = s;
  REQUIRE(recoloured.instances.size() == 1);
  recoloured.instances[0].materials = {0};
  const std::string recoloured_text = scene_to_json(recoloured, dir.path.string());
  const SceneDesc recoloured_back = parse_scene(recoloured_text, "r.json", dir.path.string());
  CHECK(test::object_triangles(recoloured_back, 0)[0].material == recoloured_back.shapes[0].material);
  // It renders (the model in front of the wall).
  SceneDesc small = s;
  small.width = small.height = 16;
  const std::shared_ptr<Scene> compiled = compile_scene(small);
  CHECK(compiled->polygons.size() == 2);  // a triangle: placed as a polygon (instances_as_polygons)
  CHECK(compiled->polygon_instance == std::vector<uint32_t>{Scene::kNoInstance, 0});
  // Errors name the shape: a missing file, a name with '/'.
  try {
    parse_scene(scene_json("", "").replace(scene_json("", "").find("model.gltf"), 10, "none.gltf"), "bad.json",
                dir.path.string());
    FAIL("a missing glTF file was accepted");
  } catch (const SceneError& e) {
    CHECK(std::string(e.what()).find("bad.json: shapes[1].file: ") != std::string::npos);
  }
  std::string slash = scene_json("", "");
  replace_once(slash, "\"name\": \"toy\"", "\"name\": \"a/b\"");
  CHECK_THROWS_WITH_AS(parse_scene(slash, "slash.json", dir.path.string()), doctest::Contains("shapes[1].name"), SceneError);
}

TEST_CASE("gltf: the shipped cornell-gltf scene loads its models, keeps their materials and agrees with the box") {
  const SceneDesc s = load_scene(std::string(PT_SCENES_DIR) + "/cornell-gltf.json");
  const SceneDesc box = load_scene("cornell");
  REQUIRE(s.objects.size() == box.objects.size() + 2);
  const ObjectDesc& toys = s.objects[box.objects.size()];
  CHECK(toys.kind == ObjectKind::Gltf);
  const std::vector<test::PlacedTriangle> toy_triangles = test::object_triangles(s, box.objects.size());
  CHECK(toy_triangles.size() == 48 * 24 * 2 + 8);  // the torus's quads as triangle pairs, the gem's eight faces
  std::set<std::string> names;
  for (const test::PlacedTriangle& t : toy_triangles) names.insert(s.materials[t.material].name);
  CHECK(names == std::set<std::string>{"toys/gold", "toys/crystal"});
  // Everything of the Cornell box is there unchanged, and the lens is on (so auto picks mis).
  CHECK(s.materials.size() == box.materials.size() + 3);
  // The ball: an OBJ with vertex normals, texture coordinates and its .mtl's textured material.
  const ObjectDesc& ball = s.objects.back();
  CHECK(ball.kind == ObjectKind::Mesh);
  const MaterialDesc& paint = s.materials[s.shapes[ball.first_shape].material];
  CHECK(paint.name == "ball/ball");
  CHECK(paint.albedo_map);
  CHECK(s.shapes[ball.first_shape].shading != kNoShading);
  CHECK(s.smooth_shading());
  for (size_t k = 0; k < toys.first_shape; ++k) CHECK(s.shapes[k].vertices == box.shapes[k].vertices);
  CHECK(s.camera.aperture_radius == 6.0);
  // The torus rests on the short block (top at y = 165): its lowest point lies on it, within rounding.
  double lowest = 1e30;
  for (const test::PlacedTriangle& t : toy_triangles)
    if (s.materials[t.material].name == "toys/gold")
      for (int v = 0; v < 3; ++v) lowest = std::min(lowest, t.v[v].y);
  CHECK(lowest == doctest::Approx(165.0).epsilon(0.002));
}

namespace {

// The triangle of triangle_gltf with NORMAL (0,0,1), (0.6,0,0.8), (0,0.6,0.8) and TEXCOORD_0 (0,0), (1,0), (0,1).
std::string smooth_triangle_gltf(const std::string& nodes) {
  std::string buf;
  append(buf, std::vector<float>{0, 0, 0, 1, 0, 0, 0, 1, 0});
  append(buf, std::vector<float>{0, 0, 1, 0.6f, 0, 0.8f, 0, 0.6f, 0.8f});
  append(buf, std::vector<float>{0, 0, 1, 0, 0, 1});
  return R"({"asset": {"version": "2.0"},
  "buffers": [{"byteLength": )" + std::to_string(buf.size()) + R"(, "uri": "data:application/octet-stream;base64,)" +
         base64(buf) + R"("}],
  "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 36},
                  {"buffer": 0, "byteOffset": 72, "byteLength": 24}],
  "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"},
                {"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC3"},
                {"bufferView": 2, "componentType": 5126, "count": 3, "type": "VEC2"}],
  "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}}]}],
  "nodes": [)" + nodes + R"(], "scenes": [{"nodes": [0]}], "scene": 0})";
}

void check_unit(Vec3 got, Vec3 want) {
  want = glm::normalize(want);
  INFO("got " << got.x << " " << got.y << " " << got.z << ", want " << want.x << " " << want.y << " " << want.z);
  CHECK(glm::length(got - want) < 1e-6f);
}

}  // namespace

TEST_CASE("gltf: NORMAL follows the node transform by its inverse transpose and TEXCOORD_0 the vertices") {
  TempDir dir;
  // Scale x by 2, then a quarter turn about +z: (0.6,0,0.8) → S⁻¹ (0.3,0,0.8) → R (0,0.3,0.8).
  const std::string r = std::to_string(std::sqrt(0.5));
  const GltfContents g = test::flat_gltf(dir.write("n.gltf", smooth_triangle_gltf(
      R"({"mesh": 0, "rotation": [0, 0, )" + r + ", " + r + R"(], "scale": [2, 1, 1]})")));
  REQUIRE(g.shading.size() == 1);
  check_unit(g.shading[0].normal[0], Vec3(0, 0, 1));
  check_unit(g.shading[0].normal[1], Vec3(0, 0.3f, 0.8f));
  check_unit(g.shading[0].normal[2], Vec3(-0.6f, 0, 0.8f));
  CHECK(g.shading[0].uv[1] == Vec2(1, 0));
  CHECK(g.shading[0].uv[2] == Vec2(0, 1));
  // Mirrored: the vertices' order flips to keep the front, and the normals and uv go with their vertices.
  const GltfContents m = test::flat_gltf(dir.write("m.gltf", smooth_triangle_gltf(R"({"mesh": 0, "scale": [-1, 1, 1]})")));
  REQUIRE(m.shading.size() == 1);
  check_unit(m.shading[0].normal[1], Vec3(0, 0.6f, 0.8f));
  check_unit(m.shading[0].normal[2], Vec3(-0.6f, 0, 0.8f));
  CHECK(m.shading[0].uv[2] == Vec2(1, 0));
  CHECK(m.triangles[0][2].x == -1.0);
  // A standalone file and a scene file's gltf shape both hand the normals on (and auto then picks mis).
  const SceneDesc alone = gltf_scene(dir.path / "n.gltf");
  REQUIRE(alone.smooth_shading());
  REQUIRE(alone.meshes.size() == 1);
  CHECK(alone.meshes[0]->normal.size() == 3);
  // A NORMAL accessor that is not float VEC3, or of another length than POSITION, is refused by its path.
  std::string bad = smooth_triangle_gltf(R"({"mesh": 0})");
  replace_once(bad, R"({"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC3"})",
               R"({"bufferView": 1, "componentType": 5126, "count": 2, "type": "VEC3"})");
  CHECK(load_error(dir, bad).find("meshes[0].primitives[0].attributes.NORMAL") != std::string::npos);
  std::string nan = smooth_triangle_gltf(R"({"mesh": 0})");
  replace_once(nan, R"("componentType": 5126, "count": 3, "type": "VEC2")", R"("componentType": 5126, "count": 3, "type": "VEC3")");
  CHECK(load_error(dir, nan).find("TEXCOORD_0") != std::string::npos);
}

TEST_CASE("gltf: TANGENT is read per vertex and made unit with its handedness as +-1 and refused unless float VEC4") {
  TempDir dir;
  std::string buf;
  append(buf, std::vector<float>{0, 0, 0, 1, 0, 0, 0, 1, 0});
  append(buf, std::vector<float>{2, 0, 0, 1, 0, 3, 0, -0.5f, 0, 0, 0, 1});  // the last one is unusable
  const auto file = [&](const std::string& type) {
    return R"({"asset": {"version": "2.0"},
    "buffers": [{"byteLength": 84, "uri": "data:application/octet-stream;base64,)" + base64(buf) + R"("}],
    "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 48}],
    "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"},
                  {"bufferView": 1, "componentType": 5126, "count": 3, "type": ")" + type + R"("}],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TANGENT": 1}}]}],
    "nodes": [{"mesh": 0}], "scenes": [{"nodes": [0]}], "scene": 0})";
  };
  const GltfContents g = load_gltf(dir.write("t.gltf", file("VEC4")));
  REQUIRE(g.meshes.size() == 1);
  const std::vector<Vec4>& t = g.meshes[0].mesh.tangent;
  REQUIRE(t.size() == 3);
  CHECK(t[0] == Vec4(1, 0, 0, 1));
  CHECK(t[1] == Vec4(0, 1, 0, -1));
  CHECK(t[2] == Vec4(0.f));
  CHECK(load_error(dir, file("VEC3")).find("meshes[0].primitives[0].attributes.TANGENT: must be float VEC4") != std::string::npos);
}

TEST_CASE("gltf: a model file alone is one object that a saved scene refers to, normals, texture and edits kept") {
  // Debian's textured box with normals: saved from its standalone scene, the file names the model instead of
  // listing its triangles, and reads back to the same shapes, vertex normals and texture; an edited material
  // comes back as an override.
  const std::string box = "/usr/share/assimp/models/glTF2/BoxTextured-glTF-Binary/BoxTextured.glb";
  if (!std::filesystem::exists(box)) {
    test::skip_for_missing("assimp-testmodels", "the standalone glTF save test");
    return;
  }
  SceneDesc s = gltf_scene(box);
  REQUIRE(s.objects.size() == 1);
  CHECK(s.objects[0].kind == ObjectKind::Gltf);
  const std::vector<test::PlacedTriangle> placed = test::object_triangles(s, 0);
  REQUIRE(placed.size() == 12);
  const size_t m = static_cast<size_t>(placed[0].material);
  CHECK(s.materials[m].name.rfind("BoxTextured/", 0) == 0);
  REQUIRE(s.materials[m].albedo_map);
  s.materials[m].roughness = 0.25f;
  TempDir dir;
  const std::string text = scene_to_json(s, dir.path.string());
  CHECK(text.find("\"type\": \"gltf\"") != std::string::npos);
  CHECK(text.find("\"triangle\"") == std::string::npos);
  const SceneDesc back = parse_scene(text, "back.json", dir.path.string());
  const std::vector<test::PlacedTriangle> back_placed = test::object_triangles(back, 0);
  REQUIRE(back_placed.size() == placed.size());
  for (size_t k = 0; k < placed.size(); ++k) CHECK(back_placed[k].v == placed[k].v);
  const MaterialDesc& bm = back.materials[back_placed[0].material];
  CHECK(bm.name == s.materials[m].name);
  CHECK(bm.roughness == 0.25f);
  CHECK(bm.albedo_map);  // the file's texture stays with its overridden material
  CHECK(back.smooth_shading() == s.smooth_shading());
}
