// Textured test geometry shared by the texture suites (textures, normal maps, cut-outs, emission textures): a
// square of two triangles with texture coordinates, and a one-triangle glTF file whose materials a test writes.
#pragma once
#include <array>
#include <string>
#include <utility>
#include <vector>

#include "scene/scene_desc.h"
#include "temp_folder.h"

namespace pt::test {

// Adds the square y = height, x and z in [−half, half], as two triangles of `material` with texture
// coordinates u along +x and v along +z (0 to uv_scale; so glTF's image up, v decreasing, is −z), facing up (+y),
// or down when `facing_down`. Their shading entries go to `shading` (point the scene's SceneDesc::shading at it).
inline void add_uv_square(SceneDesc& s, std::vector<TriangleShading>& shading, double height, double half,
                          int material, float uv_scale = 1.f, bool facing_down = false) {
  const DVec3 a(-half, height, half), b(half, height, half), c(half, height, -half), d(-half, height, -half);
  const Vec2 ua(0, uv_scale), ub(uv_scale, uv_scale), uc(uv_scale, 0), ud(0, 0);
  for (auto [v, uv] : {std::pair{std::array<DVec3, 3>{a, b, c}, std::array<Vec2, 3>{ua, ub, uc}},
                       std::pair{std::array<DVec3, 3>{a, c, d}, std::array<Vec2, 3>{ua, uc, ud}}}) {
    if (facing_down) {
      std::swap(v[1], v[2]);
      std::swap(uv[1], uv[2]);
    }
    ShapeDesc tri;
    tri.type = ShapeType::Triangle;
    tri.vertices = {v[0], v[1], v[2], DVec3(0.0)};
    tri.material = material;
    TriangleShading sh;
    sh.uv = uv;
    sh.has_uv = true;
    tri.shading = static_cast<uint32_t>(shading.size());
    shading.push_back(sh);
    s.shapes.push_back(tri);
  }
}

// The camera at (0, 4, 0) looking straight down at the origin, the image's up along −z (so its left is −x:
// small u on add_uv_square's squares), its vertical field of view `fov_deg`.
inline void look_down_from_4(SceneDesc& s, double fov_deg) {
  s.camera.position = DVec3(0, 4, 0);
  s.camera.look_at = DVec3(0, 0, 0);
  s.camera.up = DVec3(0, 0, -1);
  s.camera.fov_deg = fov_deg;
}

// Writes `name` in `folder`: a glTF file of one triangle (0,0,0), (1,0,0), (0,1,0) with TEXCOORD_0 (0,0), (1,0),
// (0,1) (its buffer tri.bin beside it) using material 0, and `assets`, the file's "images", "samplers",
// "textures" and "materials" members as the test writes them (without a trailing comma). Returns its path.
inline std::string one_triangle_gltf(const TempFolder& folder, const std::string& name, const std::string& assets) {
  std::string buf;
  const std::vector<float> pos{0, 0, 0, 1, 0, 0, 0, 1, 0}, uv{0, 0, 1, 0, 0, 1};
  buf.append(reinterpret_cast<const char*>(pos.data()), 36);
  buf.append(reinterpret_cast<const char*>(uv.data()), 24);
  folder.write("tri.bin", buf);
  return folder.write(name, R"({"asset": {"version": "2.0"},
    "buffers": [{"byteLength": 60, "uri": "tri.bin"}],
    "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 24}],
    "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"},
                  {"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC2"}],
    )" + assets + R"(,
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "material": 0}]}],
    "nodes": [{"mesh": 0}], "scenes": [{"nodes": [0]}], "scene": 0})");
}

}  // namespace pt::test
