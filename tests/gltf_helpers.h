// glTF models for tests that check where a file's triangles land, written apart from the tracer's placement
// code: a loaded file with every instance's triangles placed in the file's world (flatten_gltf), and a scene
// object's triangles in world coordinates whether they are its shapes or its instances'.
#pragma once
#include <array>
#include <string>
#include <vector>

#include "scene/gltf_import.h"
#include "scene/scene.h"

namespace pt::test {

inline GltfContents flat_gltf(const std::string& path) {
  GltfContents g = load_gltf(path);
  flatten_gltf(g);
  return g;
}

struct PlacedTriangle {
  std::array<DVec3, 3> v;  // world coordinates, the file's vertex order
  int material = 0;        // index into SceneDesc::materials
};

// Object `object`'s triangles: its shapes, then each of its instances' mesh triangles placed by the instance's
// world transform (its object's included).
inline std::vector<PlacedTriangle> object_triangles(const SceneDesc& s, size_t object) {
  std::vector<PlacedTriangle> out;
  const ObjectDesc& o = s.objects[object];
  for (size_t k = o.first_shape; k < o.first_shape + o.shape_count; ++k)
    out.push_back({{s.shapes[k].vertices[0], s.shapes[k].vertices[1], s.shapes[k].vertices[2]}, s.shapes[k].material});
  for (const InstanceDesc& in : s.instances) {
    if (in.object != static_cast<int>(object)) continue;
    const MeshDesc& m = *s.meshes[in.mesh];
    const glm::dmat4 world = instance_world(s, in);
    for (size_t t = 0; t < m.size(); ++t) {
      PlacedTriangle p;
      for (int k = 0; k < 3; ++k) p.v[k] = DVec3(world * glm::dvec4(DVec3(m.vertex(t, k)), 1.0));
      p.material = in.materials[m.slot[t]];
      out.push_back(p);
    }
  }
  return out;
}

}  // namespace pt::test
