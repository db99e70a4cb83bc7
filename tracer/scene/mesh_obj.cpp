#include "scene/mesh_obj.h"

#include <tiny_obj_loader.h>

#include <cmath>
#include <stdexcept>

#include "io/safe_file.h"
#include "scene/scene.h"
#include "scene/scene_json.h"

namespace pt {

MeshTriangles load_obj_mesh(const std::string& path, const MeshTransform& t) {
  const std::string text = read_file_limited(path, kMaxSceneFileBytes);  // FileError names the path
  tinyobj::ObjReaderConfig config;
  config.triangulate = true;
  config.vertex_color = false;
  tinyobj::ObjReader reader;
  // From memory, with no material library: .mtl files named by the OBJ are not opened.
  if (!reader.ParseFromString(text, std::string(), config)) {
    std::string why = reader.Error();
    while (!why.empty() && (why.back() == '\n' || why.back() == '\r')) why.pop_back();
    throw std::runtime_error(path + ": not a readable OBJ file" + (why.empty() ? "" : " (" + why + ")"));
  }
  const std::vector<tinyobj::real_t>& v = reader.GetAttrib().vertices;
  const size_t vertex_count = v.size() / 3;

  // Rodrigues' rotation about the unit axis: R = cos θ I + sin θ [k]× + (1 − cos θ) k kᵀ.
  const double theta = glm::radians(t.degrees);
  const DVec3 k = glm::normalize(t.axis);
  const double c = std::cos(theta), s = std::sin(theta);
  const auto transform = [&](DVec3 p) {
    p *= t.scale;
    p = c * p + s * glm::cross(k, p) + (1.0 - c) * glm::dot(k, p) * k;
    return p + t.translate;
  };

  MeshTriangles out;
  for (const tinyobj::shape_t& shape : reader.GetShapes()) {
    const auto& idx = shape.mesh.indices;
    if (idx.size() % 3 != 0) throw std::runtime_error(path + ": a face was not triangulated");
    for (size_t f = 0; f + 2 < idx.size(); f += 3) {
      std::array<DVec3, 3> tri;
      for (int j = 0; j < 3; ++j) {
        const int vi = idx[f + j].vertex_index;
        if (vi < 0 || static_cast<size_t>(vi) >= vertex_count)
          throw std::runtime_error(path + ": a face refers to a vertex the file does not have (it has " +
                                   std::to_string(vertex_count) + ")");
        const DVec3 p(v[3 * vi], v[3 * vi + 1], v[3 * vi + 2]);
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
          throw std::runtime_error(path + ": vertex " + std::to_string(vi + 1) + " is not finite");
        tri[j] = transform(p);
      }
      if (degenerate_triangle(tri[0], tri[1], tri[2])) {
        ++out.degenerate;
        continue;
      }
      if (out.triangles.size() >= kMaxMeshTriangles)
        throw std::runtime_error(path + ": more than " + std::to_string(kMaxMeshTriangles) + " triangles");
      out.triangles.push_back(tri);
    }
  }
  if (out.triangles.empty()) throw std::runtime_error(path + ": the mesh has no triangle of non-zero area");
  return out;
}

}  // namespace pt
