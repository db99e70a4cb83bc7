// libFuzzer target: the geometry inputs that are not scene JSON: Wavefront OBJ meshes (load_obj_mesh) and ray
// files (read_ray_file). The first byte picks the reader; the rest is the file. Any input must give either a
// valid result (OBJ: at least one triangle, every coordinate finite; rays: at least one, each finite with a
// non-zero direction and 0 <= tnear <= tfar) or an error message naming the file; a crash, a sanitizer report,
// a hang or an oversized allocation is a finding. Build and run: tools/fuzz.sh (docs/reliability.md).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "fuzz_input.h"
#include "io/ray_file.h"
#include "scene/mesh_obj.h"

const char* const pt::fuzz::kTarget = "fuzz_geometry_files";

using pt::fuzz::finding;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const bool obj = data[0] % 2 == 0;
  const std::string path = pt::fuzz::write_input(data + 1, size - 1, obj ? ".obj" : ".rays");
  try {
    if (obj) {
      const pt::MeshTriangles mesh = pt::load_obj_mesh(path, pt::ObjectTransform{});
      if (mesh.triangles.empty()) finding("a mesh without triangles accepted", path);
      for (const auto& tri : mesh.triangles)
        for (const auto& v : tri)
          if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z))
            finding("non-finite vertex accepted", std::to_string(v.x) + " " + std::to_string(v.y) + " " + std::to_string(v.z));
    } else {
      const std::vector<pt::RecordedRay> rays = pt::read_ray_file(path);
      if (rays.empty()) finding("an empty ray file accepted", path);
      for (const pt::RecordedRay& r : rays) {
        bool ok = std::isfinite(r.tnear) && !std::isnan(r.tfar) && r.tnear >= 0.f && r.tfar >= r.tnear;
        for (int k = 0; k < 3; ++k) ok = ok && std::isfinite(r.origin[k]) && std::isfinite(r.direction[k]);
        ok = ok && (r.direction[0] != 0.f || r.direction[1] != 0.f || r.direction[2] != 0.f);
        if (!ok) finding("a bad ray accepted", path);
      }
    }
  } catch (const std::runtime_error& e) {
    if (std::string(e.what()).rfind(path, 0) != 0) finding("error message does not name the file", e.what());
  }
  return 0;
}
