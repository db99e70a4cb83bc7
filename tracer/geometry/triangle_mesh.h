// An indexed triangle mesh in its own coordinates, as glTF stores one: float vertex positions (a glTF file's own
// numbers, so nothing is rounded), per-vertex normals and texture coordinates, three vertex indices per
// triangle and a material slot per triangle. Instances place it in the scene (instances.h); it is stored once
// and shared, never changed, by the scene's description, its copies (the viewer's edits) and the compiled scene.
// About 32 bytes a triangle where a triangle placed as a shape takes some 400 (docs/performance.md, "Meshes").
#pragma once
#include <array>
#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

#include "core/math.h"

namespace pt {

struct TriangleMesh {
  std::vector<Vec3> position;                    // per vertex
  std::vector<Vec3> normal;                      // per vertex, unit (zero: faces there stay flat), or empty
  std::vector<Vec2> uv;                          // per vertex, v downwards (materials/texture.h), or empty
  // Per vertex, or empty: a normal map's tangent (glTF TANGENT): xyz the unit direction in which u grows, w = ±1
  // the bitangent's handedness (bitangent = w·(normal × tangent)); zero where the file's is unusable.
  std::vector<Vec4> tangent;
  std::vector<std::array<uint32_t, 3>> index;    // per triangle, its vertices, counter-clockwise seen from the front
  std::vector<uint32_t> slot;                    // per triangle, its material slot (< slots)
  uint32_t slots = 1;
  Vec3 lo{0.f}, hi{0.f};                         // the positions' bounds (fit_box)

  size_t size() const { return index.size(); }
  Vec3 vertex(size_t triangle, int k) const { return position[index[triangle][k]]; }
  // Triangle t's vertex normals, or false where the mesh has none or one of them is zero (the face stays flat,
  // as glTF asks of a primitive without normals).
  bool vertex_normals(size_t t, std::array<Vec3, 3>& n) const {
    if (normal.empty()) return false;
    for (int k = 0; k < 3; ++k) {
      n[k] = normal[index[t][k]];
      if (n[k] == Vec3(0.f)) return false;
    }
    return true;
  }
  bool any_normals() const {
    for (const Vec3& n : normal)
      if (n != Vec3(0.f)) return true;
    return false;
  }
  void fit_box() {
    lo = Vec3(std::numeric_limits<float>::infinity()), hi = -lo;
    for (const Vec3& p : position) lo = glm::min(lo, p), hi = glm::max(hi, p);
  }
};

// A mesh's placement in the world, in double: the transform, the normals' map (the inverse transpose of its
// linear part) and whether it mirrors.
struct MeshPlacement {
  glm::dmat4 world;
  glm::dmat3 normal_matrix;
  bool mirrors;
  explicit MeshPlacement(const glm::dmat4& w)
      : world(w), normal_matrix(glm::transpose(glm::inverse(glm::dmat3(w)))), mirrors(glm::determinant(glm::dmat3(w)) < 0.0) {}
};

// A mesh triangle placed in the world as a shape or polygon holds it (instances place theirs at each hit
// instead, interaction.h): vertices in double, unit normals by the normal map, and under a mirroring
// placement the vertices (with their normals and uv) listed the other way round, so the front stays the
// file's.
struct PlacedTriangle {
  std::array<DVec3, 3> v;
  std::array<Vec3, 3> normal{};  // zero where the face is flat (TriangleMesh::vertex_normals)
  std::array<Vec2, 3> uv{};      // zero without uv
  bool smooth = false;
};
inline PlacedTriangle place_triangle(const TriangleMesh& m, size_t t, const MeshPlacement& p) {
  PlacedTriangle out;
  std::array<Vec3, 3> n;
  out.smooth = m.vertex_normals(t, n);
  for (int k = 0; k < 3; ++k) {
    out.v[k] = DVec3(p.world * glm::dvec4(DVec3(m.vertex(t, k)), 1.0));
    if (out.smooth) out.normal[k] = Vec3(glm::normalize(p.normal_matrix * DVec3(n[k])));
    if (!m.uv.empty()) out.uv[k] = m.uv[m.index[t][k]];
  }
  if (p.mirrors) {
    std::swap(out.v[1], out.v[2]);
    std::swap(out.normal[1], out.normal[2]);
    std::swap(out.uv[1], out.uv[2]);
  }
  return out;
}

}  // namespace pt
