// libFuzzer target: glTF 2.0 files (load_gltf, scene/gltf_import.h). The first byte picks the form (.gltf JSON or
// binary .glb); the rest is the file. Any input must give either a valid result (at least one placed triangle or
// instance, every vertex finite, every triangle's material in range, every mesh's indices, slots and slot
// materials in range, every instance's mesh in range and its transform finite and invertible, a camera with a
// finite position and a field of view in (0°, 180°)) or an error message naming the file; a crash, a sanitizer report, a hang or an oversized
// allocation is a finding. Seeds: tests/fuzz/seeds/gltf (each with its selector byte first: 0 .gltf, 1 .glb).
// Build and run: tools/fuzz.sh (docs/reliability.md).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "fuzz_input.h"
#include "scene/gltf_import.h"

const char* const pt::fuzz::kTarget = "fuzz_gltf";

using pt::fuzz::finding;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const std::string path = pt::fuzz::write_input(data + 1, size - 1, data[0] % 2 == 0 ? ".gltf" : ".glb");
  try {
    const pt::GltfContents g = pt::load_gltf(path);
    if (g.triangles.empty() && g.instances.empty()) finding("a file without triangles accepted", path);
    if (g.triangle_material.size() != g.triangles.size()) finding("triangles and materials differ in number", path);
    for (const auto& tri : g.triangles)
      for (const auto& v : tri)
        if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z)) finding("non-finite vertex accepted", path);
    for (const pt::GltfMesh& m : g.meshes) {
      const pt::MeshDesc& d = m.mesh;
      if (d.index.empty() || d.slot.size() != d.index.size() || m.slot_material.size() != d.slots)
        finding("a mesh without triangles, or with slots that do not add up", path);
      for (const auto& p : d.position)
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) finding("non-finite mesh vertex accepted", path);
      for (const auto& t : d.index)
        for (uint32_t v : t)
          if (v >= d.position.size()) finding("a mesh index past its vertices", path);
      for (uint32_t slot : d.slot)
        if (slot >= d.slots) finding("a material slot out of range", path);
      for (int mat : m.slot_material)
        if (mat < 0 || static_cast<size_t>(mat) >= g.materials.size()) finding("a slot's material out of range", path);
    }
    for (const pt::GltfInstance& in : g.instances) {
      if (in.mesh >= g.meshes.size()) finding("an instance of a mesh that does not exist", path);
      const double det = glm::determinant(glm::dmat3(in.transform));
      if (!std::isfinite(det) || det == 0.0) finding("a singular or non-finite instance transform accepted", path);
    }
    for (int m : g.triangle_material)
      if (m < 0 || static_cast<size_t>(m) >= g.materials.size()) finding("material index out of range", path);
    if (g.camera && (!std::isfinite(g.camera->position.x + g.camera->position.y + g.camera->position.z) ||
                     !(g.camera->fov_deg > 0.0 && g.camera->fov_deg < 180.0)))
      finding("a bad camera accepted", path);
  } catch (const std::runtime_error& e) {
    if (std::string(e.what()).rfind(path, 0) != 0) finding("error message does not name the file", e.what());
  }
  return 0;
}
