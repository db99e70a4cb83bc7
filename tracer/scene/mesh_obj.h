// Triangle meshes from Wavefront OBJ files, for the scene file's "mesh" shape (docs/scene-format.md). The file
// is read with the scene's safety rules (a regular file, at most kMaxSceneFileBytes) and parsed by tinyobjloader
// (Debian's libtinyobjloader-dev); polygons are triangulated as fans (listed the other way round under a
// mirroring transform, so faces keep their front). Vertex normals (vn) make a face smooth-shaded where all three
// of its corners name one (a normal of zero length leaves that face flat); texture coordinates (vt) are kept
// with them. The material libraries it names (mtllib, relative to the OBJ's folder) give each face's material
// (usemtl), mapped by scene/mtl_material.h; the scene uses them when it names no material for the mesh.
#pragma once
#include <array>
#include <cstddef>
#include <string>
#include <vector>

#include "core/math.h"
#include "scene/object_transform.h"
#include "scene/scene_desc.h"

namespace pt {

inline constexpr size_t kMaxMeshTriangles = size_t{1} << 24;  // per mesh: ~2.5 GB of scene description


struct MeshTriangles {
  std::vector<std::array<DVec3, 3>> triangles;  // transformed, zero-area triangles left out
  size_t degenerate = 0;                        // zero-area triangles left out (they can never be hit)
  // Per triangle, its vertex normals (in the file's coordinates, unit) and texture coordinates, in the file's
  // vertex order; empty when no face has normals; a face without them has zero normals (TriangleShading).
  std::vector<TriangleShading> shading;
  // The .mtl materials (scene/mtl_material.h), and per triangle its index there or −1 where the face names
  // none (or a name no library defines); both empty when the file names no material library.
  std::vector<MaterialDesc> materials;
  std::vector<int> triangle_material;
  std::vector<std::string> warnings;  // what was not read (a missing library, textures), one line each
};

// Throws std::runtime_error with the reason (the file's name, a line where the parser gives one).
MeshTriangles load_obj_mesh(const std::string& path, const ObjectTransform& transform);

}  // namespace pt
