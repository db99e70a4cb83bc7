#include "scene/studio.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>

#include "scene/gltf_import.h"
#include "scene/mesh_obj.h"
#include "scene/scene.h"
#include "scene/scene_json.h"

namespace pt {

bool is_model_file(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext == ".obj" || is_gltf_file(path);
}

CameraDesc framing_camera(DVec3 lo, DVec3 hi) {
  const DVec3 centre = 0.5 * (lo + hi);
  const double radius = std::max(0.5 * glm::length(hi - lo), 1e-9);
  CameraDesc c;
  c.fov_deg = 35.0;
  c.fov_axis = FovAxis::Vertical;
  c.up = DVec3(0, 1, 0);
  const double elevation = glm::radians(25.0), azimuth = glm::radians(30.0);
  const DVec3 from(std::sin(azimuth) * std::cos(elevation), std::sin(elevation), std::cos(azimuth) * std::cos(elevation));
  const double distance = radius / std::sin(0.5 * 0.9 * glm::radians(c.fov_deg));
  c.look_at = centre;
  c.position = centre + distance * from;
  return c;
}

EnvironmentDesc daylight_environment() {
  EnvironmentDesc e;
  e.type = EnvironmentType::Sky;
  const double sun = glm::radians(40.0), sun_azimuth = glm::radians(35.0);
  e.sun_direction = DVec3(std::sin(sun_azimuth) * std::cos(sun), std::sin(sun), std::cos(sun_azimuth) * std::cos(sun));
  e.sun = true;
  // Preetham's sky and sun in their own units are bright: this scale puts the sunlit ground (albedo 0.5) near
  // 0.4 on the display, as the `sky` scene's scale 0.5 does its darker ground.
  e.scale = 0.15f;
  return e;
}

SceneDesc studio_scene(const std::string& model_path) {
  if (is_gltf_file(model_path)) return gltf_scene(model_path);
  MeshTriangles mesh;
  try {
    mesh = load_obj_mesh(model_path, ObjectTransform{});
  } catch (const std::bad_alloc&) {
    throw;  // out of memory is no fault of the file: exit status 3, not 2
  } catch (const std::exception& e) {
    throw SceneError(e.what());
  }
  if (mesh.triangles.empty()) throw SceneError(model_path + ": no triangles to show");
  DVec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
  for (const auto& t : mesh.triangles)
    for (const DVec3& v : t) lo = glm::min(lo, v), hi = glm::max(hi, v);
  const DVec3 centre = 0.5 * (lo + hi);
  const double radius = std::max(0.5 * glm::length(hi - lo), 1e-9);

  SceneDesc s;
  s.width = 640;
  s.height = 480;
  s.render.max_bounces = 16;
  // The model's own .mtl materials when it names a library ("STEM/NAME", as in a scene file; faces without one
  // take the format's default), else one grey diffuse material; the ground last.
  const std::string stem = std::filesystem::path(model_path).stem().string();
  for (const std::string& w : mesh.warnings) std::fprintf(stderr, "warning: %s: %s\n", model_path.c_str(), w.c_str());
  if (mesh.materials.empty()) {
    MaterialDesc model;
    model.name = "model";
    model.albedo = Rgb(0.7f);
    s.materials = {model};
    mesh.triangle_material.assign(mesh.triangles.size(), 0);
  } else {
    s.materials = mesh.materials;
    for (int& m : mesh.triangle_material)
      if (m < 0) {
        if (s.materials.size() == mesh.materials.size()) {
          MaterialDesc d;  // the .mtl default: diffuse, Kd 0.8
          d.name = "default";
          s.materials.push_back(d);
        }
        m = static_cast<int>(s.materials.size() - 1);
      }
    for (MaterialDesc& m : s.materials) m.name = stem + "/" + m.name;
  }
  MaterialDesc ground;
  ground.name = "ground";
  ground.albedo = Rgb(0.5f);
  const int ground_index = static_cast<int>(s.materials.size());
  s.materials.push_back(ground);
  s.shapes.reserve(mesh.triangles.size() + 1);
  std::vector<TriangleShading> shading;
  for (size_t i = 0; i < mesh.triangles.size(); ++i) {
    const auto& t = mesh.triangles[i];
    ShapeDesc tri;
    tri.type = ShapeType::Triangle;
    tri.vertices = {t[0], t[1], t[2], DVec3(0.0)};
    tri.material = mesh.triangle_material[i];
    if (!mesh.shading.empty() && mesh.shading[i].any()) {
      tri.shading = static_cast<uint32_t>(shading.size());
      shading.push_back(mesh.shading[i]);
    }
    s.shapes.push_back(tri);
  }
  if (!shading.empty()) s.shading = std::make_shared<const std::vector<TriangleShading>>(std::move(shading));
  ObjectDesc object;  // the model is one object, saved as a reference to its file
  object.kind = ObjectKind::Mesh;
  object.name = stem;
  object.file = object.resolved_file = model_path;
  object.shape_count = mesh.triangles.size();
  s.objects.push_back(object);
  const double g = 20.0 * radius, y = lo.y;
  ShapeDesc floor;
  floor.type = ShapeType::Quad;  // counter-clockwise seen from above: its front faces +y
  floor.vertices = {DVec3(centre.x - g, y, centre.z + g), DVec3(centre.x + g, y, centre.z + g),
                    DVec3(centre.x + g, y, centre.z - g), DVec3(centre.x - g, y, centre.z - g)};
  floor.material = ground_index;
  s.shapes.push_back(floor);

  s.environment = daylight_environment();

  s.camera = framing_camera(lo, hi);
  if (std::string err = validate_scene(s); !err.empty()) throw SceneError(model_path + ": " + err);
  return s;
}

}  // namespace pt
