#include "scene/scene.h"

#include "geometry/scene_queries.h"
#include "geometry/triangle_frame.h"
#include "io/image_io.h"
#include "lights/sky_preetham.h"
#include "materials/bsdf.h"

#include <glm/gtx/component_wise.hpp>
#include <algorithm>
#include <cmath>
#include <limits>

#include <sstream>
#include <stdexcept>

namespace pt {

bool degenerate_triangle(DVec3 a, DVec3 b, DVec3 c) {
  const DVec3 e1 = b - a, e2 = c - a;
  const double l1 = glm::length(e1), l2 = glm::length(e2);
  if (!(l1 > 0.0) || !(l2 > 0.0)) return true;
  return !(glm::length(glm::cross(e1, e2)) > 1e-12 * l1 * l2);
}

namespace {

bool finite3(DVec3 v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }
bool finite3(Vec3 v) { return is_finite(v); }

// A quad is a parallelogram when d = a + c − b up to rounding of the input (relative 1e-9 of the quad's size).
bool is_parallelogram(const ShapeDesc& s) {
  const DVec3 a = s.vertices[0], b = s.vertices[1], c = s.vertices[2], d = s.vertices[3];
  const double size = std::max(glm::length(c - a), glm::length(d - b));
  return glm::length(a + c - b - d) <= 1e-9 * size;
}

// A quad stays one primitive when it is planar (d within 1e-9 of the quad's size from the plane of a, b, c: far
// below float rounding, so the plane through a, b, c that the hit test uses is the quad's own) and strictly
// convex (every corner turns the same way, sine above 1e-9), which is what the four-edge inside test assumes.
// Any other valid quad becomes the two triangles (a, b, c), (a, c, d).
bool is_planar_convex_quad(const ShapeDesc& s) {
  const auto& v = s.vertices;
  const DVec3 n = glm::normalize(glm::cross(v[1] - v[0], v[2] - v[0]));
  const double size = std::max(glm::length(v[2] - v[0]), glm::length(v[3] - v[1]));
  if (!(std::abs(glm::dot(v[3] - v[0], n)) <= 1e-9 * size)) return false;
  for (int k = 0; k < 4; ++k) {
    const DVec3 e1 = v[(k + 1) % 4] - v[k], e2 = v[(k + 2) % 4] - v[(k + 1) % 4];
    if (!(glm::dot(glm::cross(e1, e2), n) > 1e-9 * glm::length(e1) * glm::length(e2))) return false;
  }
  return true;
}

// "1e+12"-style text of a limit or an offending value, for messages.
std::string short_number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}

}  // namespace

std::string radiance_problem(Rgb c) {
  if (!finite3(c) || glm::any(glm::lessThan(c, Vec3(0.f)))) return "components must be finite and >= 0";
  if (max_component(c) > kMaxRadiance)
    return "component " + short_number(max_component(c)) + " is above the largest radiance the tracer represents, " +
           short_number(kMaxRadiance);
  return {};
}

namespace {

std::string validate_environment(const EnvironmentDesc& e) {
  if (std::string why = radiance_problem(e.radiance); !why.empty()) return "environment.radiance: " + why;
  if (!(std::isfinite(e.scale) && e.scale >= 0.f && e.scale <= kMaxEnvironmentScale))
    return "environment.scale: must be in [0, " + short_number(kMaxEnvironmentScale) + "]";
  if (e.type == EnvironmentType::Map && e.image) {
    float brightest = 0.f;
    for (float v : e.image->rgb) brightest = std::max(brightest, v);
    if (static_cast<double>(brightest) * e.scale > kMaxRadiance)
      return "environment.scale: the map's brightest texel (" + short_number(brightest) + ") times scale " +
             short_number(e.scale) + " is above the largest radiance the tracer represents, " +
             short_number(kMaxRadiance);
  }
  if (e.type == EnvironmentType::Sky) {
    if (!finite3(e.sun_direction) || !(glm::length(e.sun_direction) > 0.0))
      return "environment.sun_direction: must be a finite, non-zero vector";
    if (!(e.turbidity >= 1.7f && e.turbidity <= 10.f)) return "environment.turbidity: must be in [1.7, 10]";
  }
  if (e.type == EnvironmentType::Map) {
    if (!std::isfinite(e.rotation_deg)) return "environment.rotation_deg: must be finite";
    if (e.file.empty() && !e.image) return "environment.file: missing (a .exr, .hdr or .pfm lat-long image)";
  }
  return {};
}

std::string validate_camera(const CameraDesc& c) {
  if (!finite3(c.position)) return "camera.position: must be finite";
  if (!finite3(c.look_at)) return "camera.look_at: must be finite";
  if (!finite3(c.up)) return "camera.up: must be finite";
  if (!(glm::length(c.look_at - c.position) > 0.0)) return "camera.look_at: must differ from camera.position";
  const DVec3 f = glm::normalize(c.look_at - c.position);
  if (!(glm::length(c.up) > 0.0) || glm::length(glm::cross(f, glm::normalize(c.up))) < 1e-9)
    return "camera.up: must not be zero or parallel to the viewing direction";
  if (!(c.fov_deg > 0.0 && c.fov_deg < 180.0)) return "camera.fov_deg: must be in (0, 180) degrees";
  if (!(c.aperture_radius >= 0.0 && std::isfinite(c.aperture_radius)))
    return "camera.aperture_radius: must be finite and >= 0 (0: a pinhole)";
  if (!(c.focus_distance >= 0.0 && std::isfinite(c.focus_distance)))
    return "camera.focus_distance: must be finite and >= 0 (0: the distance to look_at)";
  return {};
}

}  // namespace

std::string validate_material(const MaterialDesc& m) {
  const std::string p = "materials." + m.name;
  if (!finite3(m.albedo) || glm::any(glm::lessThan(m.albedo, Vec3(0.f))) ||
      glm::any(glm::greaterThan(m.albedo, Vec3(1.f))))
    return p + ".albedo: components must be in [0, 1]";
  if (std::string why = radiance_problem(m.emission); !why.empty()) return p + ".emission: " + why;
  if (m.type == MaterialType::Dielectric && !(std::isfinite(m.ior) && m.ior > 0.f))
    return p + ".ior: must be finite and > 0 (the index inside; outside is 1)";
  if ((m.type == MaterialType::Plastic || m.type == MaterialType::Subsurface ||
       m.type == MaterialType::MetallicRoughness) &&
      !(m.ior >= 1.f && m.ior <= 4.f))
    return p + ".ior: must be in [1, 4] (the index inside; outside is 1)";
  if (!(m.roughness >= 0.f && m.roughness <= 1.f)) return p + ".roughness: must be in [0, 1]";
  if (!(m.g > -1.f && m.g < 1.f)) return p + ".g: must be in (-1, 1)";
  if (!(m.metallic >= 0.f && m.metallic <= 1.f)) return p + ".metallic: must be in [0, 1]";
  if (m.complex_ior) {
    if (!finite3(m.eta) || !glm::all(glm::greaterThan(m.eta, Vec3(0.f)))) return p + ".eta: components must be finite and > 0";
    if (!finite3(m.k) || glm::any(glm::lessThan(m.k, Vec3(0.f)))) return p + ".k: components must be finite and >= 0";
  }
  if (m.albedo_map || !m.albedo_texture.empty()) {
    if (!takes(m.type, MaterialParam::Albedo) || m.type == MaterialType::Subsurface ||
        (m.type == MaterialType::Conductor && m.metal != MetalPreset::None))
      return p + ".albedo_texture: a " + std::string(to_string(m.type)) +
             " material takes no albedo texture (diffuse, mirror, plastic and albedo-coloured conductors do)";
    if (!m.albedo_map) return p + ".albedo_texture: the image is not loaded";
  }
  return {};
}

namespace {

}  // namespace

std::string validate_film_size(int width, int height) {
  const std::string range = "[1, " + std::to_string(kMaxFilmSide) + "]";
  if (width < 1 || width > kMaxFilmSide) return "film.width: must be in " + range;
  if (height < 1 || height > kMaxFilmSide) return "film.height: must be in " + range;
  return {};
}

std::string validate_render_settings(const RenderSettings& r) {
  if (r.max_bounces < 0) return "render.max_bounces: must be >= 0";
  if (r.russian_roulette_depth < -1 && r.russian_roulette_depth != kRouletteDepthAuto)
    return "render.russian_roulette_depth: must be >= 0, -1 for off, or \"auto\"";
  if (r.estimator == Estimator::Bdpt && r.max_bounces > kMaxBdptBounces)
    return "render.max_bounces: bdpt traces at most " + std::to_string(kMaxBdptBounces) +
           " bounces (it stores both subpaths and connects every pair of vertices); use mis for longer paths";
  if (r.bdpt_only.s >= 0 && (r.bdpt_only.t < 1 || r.bdpt_only.s + r.bdpt_only.t < 2 ||
                             (r.bdpt_only.s == 1 && r.bdpt_only.t == 1)))
    return "bdpt strategy: needs t >= 1, s + t >= 2 and not s = t = 1 (s light and t camera vertices)";
  return {};
}

std::string validate_objects(const SceneDesc& s) {
  size_t next_free = 0;  // the first shape no earlier object holds
  for (size_t i = 0; i < s.objects.size(); ++i) {
    const ObjectDesc& o = s.objects[i];
    const std::string path = "objects[" + std::to_string(i) + "]";
    if (o.shape_count == 0) {
      const bool places = std::any_of(s.instances.begin(), s.instances.end(),
                                      [i](const InstanceDesc& in) { return in.object == static_cast<int>(i); });
      if (!places) return path + ": an object holds at least one shape or instance";
      if (o.first_shape < next_free || o.first_shape > s.shapes.size())
        return path + ": its place among the shapes is out of order";
      if (std::string err = transform_error(o.transform); !err.empty()) return path + ".transform: " + err;
      if (o.kind == ObjectKind::Group) return path + ": a group holds shapes";
      if (o.file.empty()) return path + ".file: a model names its file";
      next_free = o.first_shape;
      continue;
    }
    if (o.first_shape < next_free) return path + ": its shapes overlap an earlier object's (objects go in shape order)";
    if (o.first_shape > s.shapes.size() || o.shape_count > s.shapes.size() - o.first_shape)
      return path + ": its shapes run past the scene's " + std::to_string(s.shapes.size());
    if (std::string err = transform_error(o.transform); !err.empty()) return path + ".transform: " + err;
    if (o.kind != ObjectKind::Group && o.file.empty()) return path + ".file: a model names its file";
    const int material = s.shapes[o.first_shape].material;
    for (size_t k = o.first_shape; k < o.first_shape + o.shape_count; ++k) {
      // A model file's triangles keep the file's materials (glTF, OBJ with .mtl); a group has one.
      if (o.kind == ObjectKind::Group && s.shapes[k].material != material)
        return path + ": its shapes have one material (shape " + std::to_string(k) + " differs)";
      if (o.kind != ObjectKind::Group && s.shapes[k].type != ShapeType::Triangle) return path + ": a model is made of triangles";
    }
    next_free = o.first_shape + o.shape_count;
  }
  return {};
}

std::optional<size_t> object_containing(const SceneDesc& s, size_t shape) {
  // Objects are in shape order: the last one starting at or before `shape` is the only candidate.
  const auto it = std::upper_bound(s.objects.begin(), s.objects.end(), shape,
                                   [](size_t v, const ObjectDesc& o) { return v < o.first_shape; });
  if (it == s.objects.begin()) return std::nullopt;
  const ObjectDesc& o = *(it - 1);
  if (shape - o.first_shape >= o.shape_count) return std::nullopt;
  return static_cast<size_t>(it - 1 - s.objects.begin());
}

std::string validate_punctual_for_estimator(const SceneDesc& s, const RenderSettings& r) {
  if (s.punctual_lights.empty()) return {};
  if (r.estimator == Estimator::Uniform || r.estimator == Estimator::Cosine)
    return std::string("render.estimator: ") + to_string(r.estimator) +
           " cannot reach point, spot or directional lights (no ray hits a light of no size): use nee, mis, bdpt or auto";
  return {};
}

namespace {

std::string validate_punctual_lights(const SceneDesc& s) {
  for (size_t i = 0; i < s.punctual_lights.size(); ++i) {
    const PunctualLightDesc& l = s.punctual_lights[i];
    const std::string p = "punctual_lights[" + std::to_string(i) + "] (" + l.name + ")";
    if (!finite3(l.position)) return p + ".position: must be finite";
    if (!finite3(l.direction) || !(glm::length(l.direction) > 0.0)) return p + ".direction: must be finite and not zero";
    if (std::string why = radiance_problem(l.intensity); !why.empty()) return p + ".intensity: " + why;
    if (l.kind == PunctualKind::Spot &&
        !(l.inner_cone >= 0.0 && l.inner_cone < l.outer_cone && l.outer_cone <= 0.5 * glm::pi<double>()))
      return p + ": spot cone angles must satisfy 0 <= inner < outer <= pi/2";
    if (l.object >= static_cast<int>(s.objects.size())) return p + ": no such object";
  }
  return {};
}

}  // namespace

namespace {

// The instances (InstanceDesc) and their meshes; widens `farthest` by the placed meshes' boxes.
std::string validate_instances(const SceneDesc& s, double& farthest) {
  for (size_t i = 0; i < s.meshes.size(); ++i) {
    const std::string path = "meshes[" + std::to_string(i) + "]";
    if (!s.meshes[i]) return path + ": missing";
    const MeshDesc& m = *s.meshes[i];
    const size_t vertices = m.position.size();
    if (m.index.empty() || m.slot.size() != m.index.size() || m.slots == 0)
      return path + ": no triangles, or not one material slot per triangle";
    if ((!m.normal.empty() && m.normal.size() != vertices) || (!m.uv.empty() && m.uv.size() != vertices) ||
        (!m.tangent.empty() && m.tangent.size() != vertices))
      return path + ": normals, uv or tangents not one per vertex";
    Vec3 lo(std::numeric_limits<float>::infinity()), hi(-std::numeric_limits<float>::infinity());
    for (const Vec3& p : m.position) {
      if (!finite3(p)) return path + ": a vertex is not finite";
      lo = glm::min(lo, p), hi = glm::max(hi, p);
    }
    if (lo != m.lo || hi != m.hi) return path + ": its box is not its vertices' bounds (MeshDesc::fit_box)";
    for (const Vec3& n : m.normal)
      if (!finite3(n)) return path + ": a vertex normal is not finite";
    for (const Vec2& t : m.uv)
      if (!std::isfinite(t.x) || !std::isfinite(t.y)) return path + ": a texture coordinate is not finite";
    for (const Vec4& t : m.tangent)
      if (!finite3(Vec3(t)) || !(t.w == 0.f || t.w == 1.f || t.w == -1.f))
        return path + ": a tangent is not finite or its handedness not ±1";
    for (size_t t = 0; t < m.index.size(); ++t) {
      const std::array<uint32_t, 3>& v = m.index[t];
      if (m.slot[t] >= m.slots) return path + ".slot: past the mesh's slots";
      if (v[0] >= vertices || v[1] >= vertices || v[2] >= vertices)
        return path + ": triangle " + std::to_string(t) + " names a vertex past its " + std::to_string(vertices);
      if (degenerate_triangle(DVec3(m.position[v[0]]), DVec3(m.position[v[1]]), DVec3(m.position[v[2]])))
        return path + ": degenerate triangle " + std::to_string(t);
    }
  }
  size_t triangles = 0;
  for (size_t k = 0; k < s.instances.size(); ++k) {
    const InstanceDesc& in = s.instances[k];
    const std::string path = "instances[" + std::to_string(k) + "]";
    if (in.mesh >= s.meshes.size()) return path + ".mesh: no such mesh";
    const MeshDesc& m = *s.meshes[in.mesh];
    if (in.object < -1 || in.object >= static_cast<int>(s.objects.size())) return path + ".object: no such object";
    if (in.materials.size() != m.slots) return path + ".materials: not one per material slot of its mesh";
    for (int mat : in.materials) {
      if (mat < 0 || mat >= static_cast<int>(s.materials.size())) return path + ".materials: no such material";
      if (!is_black(s.materials[mat].emission)) {
        const std::string where = in.object >= 0 ? "model \"" + s.objects[in.object].name + "\" (" + path + ".materials)"
                                                 : path + ".materials";
        return where + ": " + shown_material(s, mat) +
               " emits light, which an instanced mesh cannot do (its triangles are not among the lights; a glTF "
               "model's emitting meshes are lights when its own file gives them the emission)";
      }
    }
    const glm::dmat4 world = instance_world(s, in);
    const double det = glm::determinant(glm::dmat3(world));
    bool finite = true;
    for (int c = 0; c < 4; ++c)
      for (int r = 0; r < 4; ++r) finite = finite && std::isfinite(world[c][r]);
    if (!finite || world[0][3] != 0.0 || world[1][3] != 0.0 || world[2][3] != 0.0 || world[3][3] != 1.0)
      return path + ".transform: must be a finite affine transform";
    if (!(std::abs(det) > 0.0 && std::isfinite(1.0 / det))) return path + ".transform: must be invertible";
    const auto [lo, hi] = placed_box(s, in);
    for (int c = 0; c < 8; ++c) {
      const DVec3 p = box_corner(lo, hi, c) - s.camera.position;
      const double d = std::hypot(p.x, p.y, p.z);
      if (!(d <= kMaxCameraDistance))
        return path + ": the placed mesh reaches " + short_number(d) + " from the camera, beyond the " +
               short_number(kMaxCameraDistance) + " the tracer represents";
      farthest = std::max(farthest, d);
    }
    triangles += m.size();
    if (triangles > kMaxInstancedTriangles)
      return path + ": the instances place more than " + std::to_string(kMaxInstancedTriangles) + " triangles";
  }
  return {};
}

}  // namespace

std::pair<DVec3, DVec3> placed_box(const SceneDesc& s, const InstanceDesc& in) {
  const MeshDesc& m = *s.meshes[in.mesh];
  const glm::dmat4 world = instance_world(s, in);
  DVec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
  for (int c = 0; c < 8; ++c) {
    const DVec3 p(world * glm::dvec4(box_corner(DVec3(m.lo), DVec3(m.hi), c), 1.0));
    lo = glm::min(lo, p), hi = glm::max(hi, p);
  }
  return {lo, hi};
}

glm::dmat4 instance_world(const SceneDesc& s, const InstanceDesc& in) {
  if (in.object < 0 || in.object >= static_cast<int>(s.objects.size())) return in.transform;
  return world_matrix(s.objects[in.object].transform) * in.transform;
}

std::string shown_material(const SceneDesc& s, int material) {
  return material >= 0 && material < static_cast<int>(s.materials.size()) ? "material \"" + s.materials[material].name + "\""
                                                                           : "material " + std::to_string(material);
}

std::string validate_scene(const SceneDesc& s) {
  if (std::string err = validate_camera(s.camera); !err.empty()) return err;
  if (std::string err = validate_film_size(s.width, s.height); !err.empty()) return err;
  if (std::string err = validate_render_settings(s.render); !err.empty()) return err;
  if (std::string err = validate_punctual_for_estimator(s, s.render); !err.empty()) return err;
  if (std::string err = validate_punctual_lights(s); !err.empty()) return err;
  if (std::string err = validate_environment(s.environment); !err.empty()) return err;
  if (s.materials.empty()) return "materials: the scene defines no material";
  for (const MaterialDesc& m : s.materials)
    if (std::string err = validate_material(m); !err.empty()) return err;
  if (s.shapes.empty() && s.instances.empty()) return "shapes: the scene has no shape";
  const DVec3 eye = s.camera.position;
  const std::string too_far = " from the camera, beyond the " + short_number(kMaxCameraDistance) +
                              " the tracer represents (move the camera closer or scale the scene down)";
  // Distances by hypot, which does not overflow: a vertex at 1e200 is 1e200 away, not "inf".
  const auto distance = [](DVec3 a, DVec3 b) { return std::hypot(a.x - b.x, a.y - b.y, a.z - b.z); };
  double farthest = 0.0;  // of any point of any shape from the camera
  for (size_t i = 0; i < s.shapes.size(); ++i) {
    const ShapeDesc& sh = s.shapes[i];
    // The path is built only for a message: scenes have millions of shapes.
    const auto path = [i] { return "shapes[" + std::to_string(i) + "]"; };
    if (sh.material < 0 || sh.material >= static_cast<int>(s.materials.size()))
      return path() + ".material: no such material";
    if (sh.shading != kNoShading) {
      if (sh.type != ShapeType::Triangle || !s.shading || sh.shading >= s.shading->size())
        return path() + ": vertex normals that the scene does not hold (or on a shape that is not a triangle)";
      for (const Vec3& n : (*s.shading)[sh.shading].normal)
        if (!std::isfinite(n.x) || !std::isfinite(n.y) || !std::isfinite(n.z)) return path() + ": a vertex normal is not finite";
    }
    if (sh.type == ShapeType::Sphere) {
      if (!finite3(sh.center)) return path() + ".center: must be finite";
      if (!(std::isfinite(sh.radius) && sh.radius > 0.0)) return path() + ".radius: must be finite and > 0";
      const double d = distance(sh.center, eye) + sh.radius;
      if (!(d <= kMaxCameraDistance)) return path() + ".radius: the sphere reaches " + short_number(d) + too_far;
      farthest = std::max(farthest, d);
      continue;
    }
    const int n = sh.type == ShapeType::Triangle ? 3 : 4;
    for (int k = 0; k < n; ++k) {
      const auto vk = [&] { return path() + ".vertices[" + std::to_string(k) + "]"; };
      if (!finite3(sh.vertices[k])) return vk() + ": must be finite";
      const double d = distance(sh.vertices[k], eye);
      if (!(d <= kMaxCameraDistance)) return vk() + ": " + short_number(d) + too_far;
      farthest = std::max(farthest, d);
    }
    const auto& v = sh.vertices;
    if (degenerate_triangle(v[0], v[1], v[2]) || (n == 4 && degenerate_triangle(v[0], v[2], v[3])))
      return path() + ".vertices: degenerate polygon (zero area or repeated/collinear vertices)";
    if (n == 4 && !is_planar_convex_quad(sh)) {
      // Two triangles: their front normals must agree, or the quad folds over itself.
      const DVec3 n1 = glm::cross(v[1] - v[0], v[2] - v[0]), n2 = glm::cross(v[2] - v[0], v[3] - v[0]);
      if (glm::dot(n1, n2) <= 0.0) return path() + ".vertices: quad is folded or not convex (vertex order?)";
    }
  }
  if (std::string err = validate_instances(s, farthest); !err.empty()) return err;
  if (std::string err = validate_objects(s); !err.empty()) return err;
  if (farthest < kMinSceneExtent)
    return "shapes: the whole scene lies within " + short_number(farthest) + " of the camera, below the " +
           short_number(kMinSceneExtent) + " the tracer represents (scale the scene up)";
  return {};
}

namespace {

// Appends a triangle (N = 3) or a convex planar quad (N = 4).
template <int N>
void add_polygon(PolygonSoA& soa, const std::array<DVec3, N>& world, DVec3 origin, uint32_t material,
                 bool parallelogram = false) {
  const DVec3 n = glm::cross(world[1] - world[0], world[2] - world[0]);
  // Planar polygon area: half the cross product of the diagonals (for a triangle, half of n).
  const double area = N == 4 ? 0.5 * glm::length(glm::cross(world[2] - world[0], world[3] - world[1]))
                             : 0.5 * glm::length(n);
  for (int k = 0; k < 4; ++k) soa.v[k].push_back(Vec3(world[k < N ? k : 0] - origin));
  soa.triangle.push_back(N == 3);
  soa.normal.push_back(Vec3(glm::normalize(n)));
  soa.area.push_back(static_cast<float>(area));
  soa.material.push_back(material);
  double max_abs = 0.0;
  for (int k = 0; k < N; ++k) max_abs = std::max(max_abs, glm::compMax(glm::abs(world[k] - origin)));
  const double err = hit_error_bound(max_abs);
  std::array<Vec3, 2> margins{Vec3(0.f), Vec3(0.f)};
  std::array<std::array<Vec3, 2>, 2> dual{};
  for (int h = 0; h < N - 2; ++h) {
    margins[h] = triangle_margins(world[0], world[h + 1], world[h + 2], err);
    dual[h] = triangle_dual(world[0], world[h + 1], world[h + 2]);
  }
  soa.edge_margin.push_back(margins);
  soa.dual.push_back(dual);
  soa.parallelogram.push_back(parallelogram);
  soa.first_half_fraction.push_back(static_cast<float>(std::min(1.0, 0.5 * glm::length(n) / area)));
}

// Fills SceneGeometry::shading (primitives.h) when some shape has vertex normals: each shape's normals mapped
// by its object's transform (the inverse transpose of its linear part, R·S⁻¹) and put in the order the shape
// lists its vertices (swapped under a mirroring transform, as transform_shape swaps the vertices); every other
// polygon repeats its face normal.
class ShadingCompiler {
 public:
  explicit ShadingCompiler(const SceneDesc& desc) {
    if (!desc.shading || desc.shading->empty()) return;
    for (const ShapeDesc& sh : desc.shapes)
      if (sh.shading != kNoShading) {
        const TriangleShading& t = (*desc.shading)[sh.shading];
        active_ = active_ || t.any();
        smooth_ = smooth_ || t.has_normals();
      }
  }
  bool active() const { return active_; }  // some shape has normals or uv: SceneGeometry::shading is filled
  bool smooth() const { return smooth_; }  // some shape has normals

  void add(const SceneDesc& desc, size_t shape, const PolygonSoA& polygons, size_t first, PolygonShading& out) const {
    const ShapeDesc& sh = desc.shapes[shape];
    for (size_t i = first; i < polygons.size(); ++i) {
      const Vec3 ng = polygons.normal[i];
      out.normal.push_back({ng, ng, ng});
      out.uv.push_back({Vec2(0.f), Vec2(0.f), Vec2(0.f)});
    }
    if (sh.shading == kNoShading || polygons.size() != first + 1) return;
    const TriangleShading& t = (*desc.shading)[sh.shading];
    std::array<Vec3, 3> n = t.normal;
    std::array<Vec2, 3> uv = t.uv;
    if (const std::optional<size_t> obj = object_containing(desc, shape)) {
      const ObjectTransform& tr = desc.objects[*obj].transform;
      if (t.has_normals())
        for (Vec3& v : n) v = Vec3(glm::normalize(normal_to_world(tr, DVec3(v))));
      if (mirrors(tr)) std::swap(n[1], n[2]), std::swap(uv[1], uv[2]);
    }
    if (t.has_normals()) out.normal.back() = n;
    out.uv.back() = uv;
  }

 private:
  bool active_ = false, smooth_ = false;
};

// A mesh that instances place, in its own coordinates, with its hierarchy (geometry/instances.h).
std::shared_ptr<const MeshGeometry> compile_mesh(const std::shared_ptr<const MeshDesc>& d) {
  auto g = std::make_shared<MeshGeometry>();
  g->mesh = d;
  g->bvh = build_mesh_bvh(*d);
  return g;
}

// The instances' triangles placed as polygons (instances_as_polygons) by place_triangle (triangle_mesh.h), as a
// model file's emitting triangles are placed as shapes; their vertex normals and uv into SceneGeometry::shading,
// which then covers every polygon.
void add_instance_polygons(const SceneDesc& desc, Scene& s) {
  const DVec3 o = s.world_origin;
  s.polygon_instance.assign(s.polygons.size(), Scene::kNoInstance);
  bool shaded = !s.shading.empty();
  for (size_t k = 0; k < desc.instances.size(); ++k) {
    const InstanceDesc& in = desc.instances[k];
    const MeshDesc& m = *desc.meshes[in.mesh];
    shaded = shaded || !m.normal.empty() || !m.uv.empty();
  }
  if (shaded && s.shading.empty())  // the shapes' polygons had none: their face normals, uv 0
    for (const Vec3& ng : s.polygons.normal) {
      s.shading.normal.push_back({ng, ng, ng});
      s.shading.uv.push_back({Vec2(0.f), Vec2(0.f), Vec2(0.f)});
    }
  for (size_t k = 0; k < desc.instances.size(); ++k) {
    const InstanceDesc& in = desc.instances[k];
    const MeshDesc& m = *desc.meshes[in.mesh];
    const MeshPlacement place(instance_world(desc, in));
    for (size_t t = 0; t < m.size(); ++t) {
      const PlacedTriangle p = place_triangle(m, t, place);
      const uint32_t material = static_cast<uint32_t>(in.materials[m.slot[t]]);
      add_polygon<3>(s.polygons, p.v, o, material);
      s.material_used[material] = 1;
      s.polygon_instance.push_back(static_cast<uint32_t>(k));
      if (!shaded) continue;
      const Vec3 ng = s.polygons.normal.back();
      s.shading.normal.push_back(p.smooth ? p.normal : std::array<Vec3, 3>{ng, ng, ng});
      s.shading.uv.push_back(p.uv);
      s.features.smooth_shading = s.features.smooth_shading || p.smooth;
    }
  }
}

// The instances (geometry/instances.h): each mesh compiled once, each placement camera-relative.
void compile_instances(const SceneDesc& desc, Scene& s) {
  if (desc.instances.empty()) return;
  InstanceSet& set = s.instances;
  std::vector<int> geometry_of(desc.meshes.size(), -1);
  uint32_t next = s.primitive_count();
  set.prim_begin = next;
  for (size_t k = 0; k < desc.instances.size(); ++k) {
    const InstanceDesc& d = desc.instances[k];
    const MeshDesc& mesh = *desc.meshes[d.mesh];
    if (geometry_of[d.mesh] < 0) {
      geometry_of[d.mesh] = static_cast<int>(set.meshes.size());
      set.meshes.push_back(compile_mesh(desc.meshes[d.mesh]));
      s.features.smooth_shading = s.features.smooth_shading || mesh.any_normals();
    }
    Instance in;
    in.mesh = static_cast<uint32_t>(geometry_of[d.mesh]);
    in.geometry = set.meshes[in.mesh].get();
    in.triangles = static_cast<uint32_t>(in.geometry->size());
    in.first_prim = next;
    in.desc = static_cast<uint32_t>(k);
    const glm::dmat4 world = instance_world(desc, d);
    in.to_world_linear = glm::dmat3(world);
    in.to_world_offset = DVec3(world[3]) - s.world_origin;
    const glm::dmat3 inverse = glm::inverse(in.to_world_linear);
    in.to_mesh.linear = glm::mat3(inverse);
    in.to_mesh.offset = Vec3(-(inverse * in.to_world_offset));
    in.normal_to_world = glm::mat3(glm::transpose(inverse));
    in.mirrors = glm::determinant(in.to_world_linear) < 0.0;
    for (int m : d.materials) {
      in.material.push_back(static_cast<uint32_t>(m));
      s.material_used[static_cast<size_t>(m)] = 1;
    }
    // The placed box: its corners in double, rounded outwards to float.
    DVec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
    for (int c = 0; c < 8; ++c) {
      const DVec3 p = in.to_world_linear * box_corner(DVec3(mesh.lo), DVec3(mesh.hi), c) + in.to_world_offset;
      lo = glm::min(lo, p), hi = glm::max(hi, p);
    }
    for (int a = 0; a < 3; ++a) {
      in.lo[a] = next_float_down(static_cast<float>(lo[a]));
      in.hi[a] = next_float_up(static_cast<float>(hi[a]));
    }
    next += static_cast<uint32_t>(mesh.size());
    set.instances.push_back(std::move(in));
  }
  set.prim_end = next;
  build_instance_hierarchy(set);
  s.features.triangles = true;
}

Material compile_material(const MaterialDesc& d) {
  Material m;
  m.type = d.type;
  m.albedo = d.albedo;
  m.emission = d.emission;
  m.two_sided = d.two_sided;
  m.ior = d.ior;
  m.roughness = d.roughness;
  m.g = d.g;
  m.metallic = d.metallic;
  m.metal = d.metal;
  m.complex_ior = d.complex_ior;
  m.eta = d.eta;
  m.k = d.k;
  m.albedo_texture = d.albedo_map.get();  // kept alive by Scene::textures
  m.albedo_uv_transform = d.albedo_uv_transform;
  if (d.type == MaterialType::MetallicRoughness)  // the others have no metallic or roughness to scale by it
    m.metallic_roughness_map = {d.metallic_roughness_map.texture.get(), d.metallic_roughness_map.uv_transform};
  m.normal_map = {d.normal_map.texture.get(), d.normal_map.uv_transform};
  m.emission_map = {d.emission_map.texture.get(), d.emission_map.uv_transform};
  m.normal_scale = d.normal_scale;
  prepare_material(m);
  return m;
}

// Resolution of the lat-long image the analytic sky is tabulated into (its importance sampling and lookups then
// work exactly as for a map file). 512×256 texels of 0.7°: the sky varies smoothly; the sun is a light of its own.
constexpr int kSkyTableWidth = 512, kSkyTableHeight = 256;

void compile_environment(const EnvironmentDesc& e, Scene& s) {
  s.environment = EnvironmentLight{};
  EnvironmentLight& env = s.environment;
  if (e.type == EnvironmentType::Sky && e.sun) {
    const SunDisk sun = preetham_sun(Vec3(glm::normalize(e.sun_direction)), e.turbidity);
    env.sun.kind = LightKind::Sun;
    env.sun.direction = Vec3(glm::normalize(e.sun_direction));
    env.sun.emission = sun.radiance * e.scale;
    env.sun.one_minus_cos_max = sun.one_minus_cos;
  }
  switch (e.type) {
    case EnvironmentType::Constant:
      env.radiance = e.radiance;
      env.present = !is_black(e.radiance);
      return;
    case EnvironmentType::Sky: {
      Image sky = make_sky_image(Vec3(glm::normalize(e.sun_direction)), e.turbidity, kSkyTableWidth, kSkyTableHeight);
      env.map = std::make_shared<EnvironmentMap>(sky, e.scale, 0.f);
      break;
    }
    case EnvironmentType::Map: {
      std::shared_ptr<const Image> image = e.image;
      if (!image) {
        HdrImageResult read = read_hdr_image(e.resolved_file.empty() ? e.file : e.resolved_file);
        if (!read.ok()) throw std::invalid_argument("environment.file: " + read.error);
        image = std::make_shared<Image>(std::move(read.image));
      }
      env.map = std::make_shared<EnvironmentMap>(*image, e.scale, e.rotation_deg);
      break;
    }
  }
  env.uses_map = true;
  env.present = env.map->power_weight() > 0.0;
}

// The scene features that follow from its compiled materials.
void note_material_features(Scene& s) {
  s.features.lambertian_only = std::all_of(s.materials.begin(), s.materials.end(), is_lambertian);
  s.features.textures = std::any_of(s.materials.begin(), s.materials.end(), has_textures);
}

// Keeps a material's texture alive as long as the scene (its compiled material points to it; a texture replaced
// by an edit stays too, since a render may still read it).
void keep_texture(const MaterialDesc& m, Scene& s) {
  for (const std::shared_ptr<const Texture>& t :
       {m.albedo_map, m.metallic_roughness_map.texture, m.normal_map.texture, m.emission_map.texture})
    if (t && std::find(s.textures.begin(), s.textures.end(), t) == s.textures.end()) s.textures.push_back(t);
}
void keep_textures(const SceneDesc& desc, Scene& s) {
  for (const MaterialDesc& m : desc.materials) keep_texture(m, s);
}

void compile_materials(const SceneDesc& desc, Scene& s) {
  s.materials.clear();
  for (const MaterialDesc& m : desc.materials) s.materials.push_back(compile_material(m));
  keep_textures(desc, s);
  note_material_features(s);
}

bool same_material(const MaterialDesc& a, const MaterialDesc& b) {
  return a.type == b.type && a.albedo == b.albedo && a.emission == b.emission && a.two_sided == b.two_sided &&
         a.ior == b.ior && a.roughness == b.roughness && a.g == b.g && a.metal == b.metal &&
         a.complex_ior == b.complex_ior && a.eta == b.eta && a.k == b.k && a.albedo_texture == b.albedo_texture &&
         a.albedo_map == b.albedo_map && a.albedo_uv_transform == b.albedo_uv_transform;
}

bool same_environment(const EnvironmentDesc& a, const EnvironmentDesc& b) {
  return a.type == b.type && a.radiance == b.radiance && a.sun_direction == b.sun_direction &&
         a.turbidity == b.turbidity && a.sun == b.sun && a.scale == b.scale && a.file == b.file &&
         a.resolved_file == b.resolved_file && a.rotation_deg == b.rotation_deg && a.image == b.image;
}

// The light list (emitting primitives, then the environment and the sun) and its power-proportional selection
// distribution, from the compiled materials, geometry and environment.
// SceneDesc::punctual_lights into Scene::punctual_lights: placed by their objects' transforms, camera-relative.
void compile_punctual_lights(const SceneDesc& desc, Scene& s) {
  s.punctual_lights.clear();
  for (const PunctualLightDesc& d : desc.punctual_lights) {
    DVec3 position = d.position, direction = d.direction;
    if (d.object >= 0 && static_cast<size_t>(d.object) < desc.objects.size()) {
      const ObjectTransform& t = desc.objects[static_cast<size_t>(d.object)].transform;
      position = to_world(t, d.position);
      direction = to_world(t, d.direction) - to_world(t, DVec3(0.0));
    }
    Light l;
    l.emission = d.intensity;
    l.position = Vec3(position - s.world_origin);
    switch (d.kind) {
      case PunctualKind::Point:
        l.kind = LightKind::Point;
        break;
      case PunctualKind::Spot:
        l.kind = LightKind::Spot;
        l.direction = Vec3(glm::normalize(direction));
        l.cos_inner = static_cast<float>(std::cos(d.inner_cone));
        l.cos_outer = static_cast<float>(std::cos(d.outer_cone));
        break;
      case PunctualKind::Directional:
        l.kind = LightKind::Directional;
        l.direction = Vec3(-glm::normalize(direction));  // towards the light
        break;
    }
    s.punctual_lights.push_back(l);
  }
}

// Scene::emission_focus_*: a sphere around the box of every polygon and sphere whose material has a glossy or
// specular lobe, and of every instanced mesh (its slots' materials are not looked at: a finite object either way).
// Instanced triangles placed as polygons count as polygons.
void compile_emission_focus(Scene& s) {
  s.emission_focus_center = Vec3(0.f);
  s.emission_focus_radius = 0.f;
  if (s.infinite_lights.empty()) return;  // only infinite lights emit from a disk
  DVec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
  const auto focuses = [&](uint32_t material) {
    return any(bsdf_flags(s.materials[material]) & (BsdfFlags::Glossy | BsdfFlags::Specular));
  };
  const PolygonSoA& P = s.polygons;
  for (size_t i = 0; i < P.size(); ++i) {
    if (!focuses(P.material[i])) continue;
    for (int k = 0; k < (P.triangle[i] ? 3 : 4); ++k) {
      lo = glm::min(lo, DVec3(P.v[k][i]));
      hi = glm::max(hi, DVec3(P.v[k][i]));
    }
  }
  for (size_t i = 0; i < s.spheres.size(); ++i) {
    if (!focuses(s.spheres.material[i])) continue;
    lo = glm::min(lo, s.spheres.center[i] - DVec3(s.spheres.radius[i]));
    hi = glm::max(hi, s.spheres.center[i] + DVec3(s.spheres.radius[i]));
  }
  for (const Instance& in : s.instances.instances) {
    lo = glm::min(lo, DVec3(in.lo));
    hi = glm::max(hi, DVec3(in.hi));
  }
  if (!(lo.x <= hi.x)) return;  // nothing that focuses light
  const double radius = 0.5 * glm::length(hi - lo);
  // Aiming half the paths at a disk of more than a quarter of the whole one's area gains little.
  if (!(radius > 0.0) || radius > 0.5 * s.bounding_radius) return;
  s.emission_focus_center = Vec3(0.5 * (lo + hi));
  s.emission_focus_radius = static_cast<float>(radius) * (1.f + 1e-5f);  // float rounding must not cut the box
}

// The light tree over the bounded lights (lights/light_tree.h), where there are enough of them; `power` as
// compile_lights counts it, per light.
void compile_light_tree(Scene& s, const std::vector<double>& power) {
  s.light_tree = LightTree();
  std::vector<LightBounds> bounds;
  std::vector<uint32_t> members;
  const PolygonSoA& P = s.polygons;
  for (uint32_t li = 0; li < s.lights.size(); ++li) {
    const Light& l = s.lights[li];
    LightBounds b;
    b.phi = static_cast<float>(power[li]);
    if (l.polygon()) {
      b.lo = b.hi = P.v[0][l.prim];
      for (int k = 1; k < 4; ++k) {
        b.lo = glm::min(b.lo, P.v[k][l.prim]);
        b.hi = glm::max(b.hi, P.v[k][l.prim]);
      }
      b.w = P.normal[l.prim];
      b.cos_theta_o = 1.f;
      // A surface emits over a hemisphere about its normal (θe = π/2); a hair wider, so that rounding never
      // gives a receiver grazing the light's plane importance 0.
      b.cos_theta_e = -1e-3f;
      b.two_sided = l.two_sided;
    } else if (l.sphere()) {
      const Vec3 c = s.spheres.center[l.prim - s.sphere_begin()];
      const float r = s.spheres.radius[l.prim - s.sphere_begin()];
      b.lo = c - Vec3(r);
      b.hi = c + Vec3(r);
      b.cos_theta_o = -1.f;  // normals in every direction
    } else if (l.kind == LightKind::Point) {
      b.lo = b.hi = l.position;
      b.cos_theta_o = -1.f;  // every direction
    } else if (l.kind == LightKind::Spot) {
      // pbrt-v4's SpotLight::Bounds: full strength about the axis out to the inner cone (θo), falling to nothing
      // at the outer one (θe = θ_outer − θ_inner), so a receiver outside the outer cone gets importance 0. θe is
      // widened by 1e-3 rad: rounding must not rule out a receiver the falloff still reaches, and a nearly
      // hard-edged spot must not get θe ≈ 0 (pbrt-v4's test cos θ' ≤ cos θe would then rule out its whole cone).
      b.lo = b.hi = l.position;
      b.w = l.direction;
      const double inner = std::acos(std::clamp(double(l.cos_inner), -1.0, 1.0));
      const double outer = std::acos(std::clamp(double(l.cos_outer), -1.0, 1.0));
      b.cos_theta_o = static_cast<float>(std::cos(std::min(inner, outer)));
      b.cos_theta_e = static_cast<float>(std::cos(std::max(outer - inner, 0.0) + 1e-3));
    } else {
      continue;  // the environment, the sun, directional lights: chosen by power beside the tree
    }
    if (!(b.phi > 0.f)) continue;
    bounds.push_back(b);
    members.push_back(li);
  }
  if (bounds.size() >= LightTree::kMinLights) s.light_tree = LightTree(bounds, members, s.light_pmf);
}

void compile_lights(Scene& s) {
  s.lights.clear();
  s.light_pmf.clear();
  s.light_cdf.clear();
  s.infinite_lights.clear();
  s.directional_lights = false;
  s.features.emissive_spheres = false;
  // Every primitive whose material emits. Selection ∝ emitted power = π·A·mean(Le)·(sides).
  s.light_of_prim.assign(s.primitive_count(), -1);
  std::vector<double> power;
  for (uint32_t prim = 0; prim < s.primitive_count(); ++prim) {
    const Material& m = s.materials[s.material_of(prim)];
    if (is_black(m.emission)) continue;
    Light l;
    l.prim = prim;
    l.emission = m.emission;
    l.two_sided = m.two_sided;
    // A textured emitter (a model's triangles) reads its image where it is sampled; its power counts the
    // image's mean (the pyramid's last level), which only steers the choice among lights.
    double texture_mean = 1.0;
    if (m.emission_map.texture && prim < s.sphere_begin() && !s.shading.empty()) {
      l.emission_map = m.emission_map;
      const Rgb mean = m.emission_map.texture->levels.back().at(0, 0);
      texture_mean = std::max(1e-3, double(mean.x + mean.y + mean.z) / 3.0);
    }
    if (prim < s.sphere_begin()) {
      l.area = s.polygons.area[prim];
      l.kind = LightKind::Polygon;
      const PolygonSoA& P = s.polygons;
      l.uniform_parallelogram = P.parallelogram[prim] && !l.emission_map.texture;
      if (l.uniform_parallelogram) {
        // A rectangle (perpendicular edges) is sampled in solid angle: far less noise near the light.
        const Vec3 ex = P.v[1][prim] - P.v[0][prim], ey = P.v[3][prim] - P.v[0][prim];
        if (std::abs(glm::dot(ex, ey)) <= 1e-5f * glm::length(ex) * glm::length(ey)) {
          l.kind = LightKind::Rectangle;
          l.corner = P.v[0][prim];
          l.edge_x = ex;
          l.edge_y = ey;
        }
      }
    } else {
      const double r = s.spheres.radius[prim - s.sphere_begin()];
      l.area = static_cast<float>(4.0 * glm::pi<double>() * r * r);
      l.kind = LightKind::Sphere;
      s.features.emissive_spheres = true;
    }
    s.light_of_prim[prim] = static_cast<int32_t>(s.lights.size());
    s.lights.push_back(l);
    power.push_back(double(l.area) * (m.emission.x + m.emission.y + m.emission.z) * (m.two_sided ? 2.0 : 1.0) *
                    texture_mean);
  }
  // Infinite lights' power is counted as pbrt-v4 counts it, Φ = π R²·∫Le dω for the scene's bounding radius R
  // (camera-centred); only its ratio to the other lights matters, and any positive choice keeps the estimate
  // unbiased.
  const double disk = glm::pi<double>() * std::max(s.bounding_radius * s.bounding_radius, 1e-30);
  if (s.environment.present) {
    s.infinite_lights.push_back(static_cast<uint32_t>(s.lights.size()));
    Light l;
    l.kind = LightKind::Environment;
    s.lights.push_back(l);
    // power_weight() integrates luminance; ×3 puts it on the same footing as the RGB sums used for area lights.
    const double integral = s.environment.uses_map ? 3.0 * s.environment.map->power_weight()
                                                   : 4.0 * glm::pi<double>() * (s.environment.radiance.x + s.environment.radiance.y + s.environment.radiance.z);
    power.push_back(disk * integral);
  }
  if (const Light& l = s.environment.sun; !is_black(l.emission)) {
    s.infinite_lights.push_back(static_cast<uint32_t>(s.lights.size()));
    s.lights.push_back(l);
    power.push_back(disk * 2.0 * glm::pi<double>() * l.one_minus_cos_max * (l.emission.x + l.emission.y + l.emission.z));
  }
  s.features.environment = !s.infinite_lights.empty();
  // Punctual lights, by the area lights' convention (their Φ = π·A·Le is counted as A·Le, i.e. Φ/π): a point
  // 4·I, a spot 2(1 − cos of its mean cone angle)·I; a directional light as the infinite ones, π R²·E.
  for (const Light& l : s.punctual_lights) {
    const double sum = double(l.emission.x) + l.emission.y + l.emission.z;
    double p = 0.0;
    if (l.kind == LightKind::Point) p = 4.0 * sum;
    else if (l.kind == LightKind::Spot) p = 2.0 * (1.0 - 0.5 * (double(l.cos_inner) + l.cos_outer)) * sum;
    else p = disk * sum;
    if (!(p > 0.0)) continue;
    s.lights.push_back(l);
    s.directional_lights = s.directional_lights || l.kind == LightKind::Directional;
    power.push_back(p);
  }
  double total = 0.0;
  for (double p : power) total += p;
  double running = 0.0;
  for (double p : power) {
    running += p;
    s.light_pmf.push_back(static_cast<float>(p / total));
    s.light_cdf.push_back(static_cast<float>(running / total));
  }
  if (!s.light_cdf.empty()) s.light_cdf.back() = 1.f;
  compile_light_tree(s, power);
  compile_emission_focus(s);
}

}  // namespace

std::shared_ptr<Scene> compile_scene(const SceneDesc& desc) {
  if (std::string err = validate_scene(desc); !err.empty()) throw std::invalid_argument(err);
  auto scene = std::make_shared<Scene>();
  Scene& s = *scene;
  s.width = desc.width;
  s.height = desc.height;
  s.world_origin = desc.camera.position;
  s.camera = compile_camera(desc.camera, desc.width, desc.height);

  const DVec3 o = s.world_origin;
  s.material_used.assign(desc.materials.size(), 0);
  const ShadingCompiler shading(desc);
  for (size_t shape = 0; shape < desc.shapes.size(); ++shape) {
    const ShapeDesc& sh = desc.shapes[shape];
    const size_t polygons_before = s.polygons.size();
    const uint32_t mat = static_cast<uint32_t>(sh.material);
    if (mat < s.material_used.size()) s.material_used[mat] = 1;
    const auto& v = sh.vertices;
    if (sh.type == ShapeType::Triangle) {
      add_polygon<3>(s.polygons, {v[0], v[1], v[2]}, o, mat);
    } else if (sh.type == ShapeType::Quad) {
      if (is_planar_convex_quad(sh)) {
        add_polygon<4>(s.polygons, {v[0], v[1], v[2], v[3]}, o, mat, is_parallelogram(sh));
      } else {
        add_polygon<3>(s.polygons, {v[0], v[1], v[2]}, o, mat);
        add_polygon<3>(s.polygons, {v[0], v[2], v[3]}, o, mat);
      }
    } else {
      s.spheres.add(sh.center - o, sh.radius, mat);
    }
    if (shading.active()) shading.add(desc, shape, s.polygons, polygons_before, s.shading);
  }
  s.features.smooth_shading = shading.smooth();
  const bool instances_placed = instances_as_polygons(desc);
  if (instances_placed) add_instance_polygons(desc, s);
  // Cut-outs (geometry/alpha_mask.h): the hierarchy's traversal applies them, so a scene with one always has it.
  if (std::any_of(desc.materials.begin(), desc.materials.end(), [](const MaterialDesc& m) { return m.cutout != nullptr; }))
    for (const MaterialDesc& m : desc.materials) s.material_mask.push_back(m.cutout);
  if (s.polygons.size() >= kBvhMinPolygons || s.has_cutouts())
    s.polygon_bvh = build_polygon_bvh(s.polygons.v, s.polygons.triangle);
  else
    s.polygon_lanes.assign(s.polygons.v, s.polygons.triangle);
  for (uint8_t tri : s.polygons.triangle) (tri ? s.features.triangles : s.features.quads) = true;
  s.features.spheres = s.spheres.size() > 0;
  if (!instances_placed) compile_instances(desc, s);

  double r2 = 0.0;
  for (const auto& arr : s.polygons.v)
    for (const Vec3& p : arr) r2 = std::max(r2, static_cast<double>(glm::dot(p, p)));
  for (size_t i = 0; i < s.spheres.size(); ++i) {
    const double r = glm::length(s.spheres.center[i]) + s.spheres.radius[i];
    r2 = std::max(r2, r * r);
  }
  for (const Instance& in : s.instances.instances) {
    const Vec3 far = glm::max(glm::abs(in.lo), glm::abs(in.hi));
    r2 = std::max(r2, static_cast<double>(glm::dot(far, far)));
  }
  s.bounding_radius = std::sqrt(r2);
  compile_punctual_lights(desc, s);
  compile_materials(desc, s);
  compile_environment(desc.environment, s);
  compile_lights(s);
  return scene;
}

namespace {

bool same_camera(const CameraDesc& a, const CameraDesc& b) {
  return a.position == b.position && a.look_at == b.look_at && a.up == b.up && a.fov_deg == b.fov_deg &&
         a.fov_axis == b.fov_axis && a.aperture_radius == b.aperture_radius && a.focus_distance == b.focus_distance;
}

// The camera moved within this many bounding radii of the origin the geometry was compiled around keeps the
// geometry: its float precision relative to the eye stays that of the scene's own extent. Farther moves
// recompile, so that precision never depends on how far the camera has travelled.
constexpr double kCameraRebaseRadii = 1.0;

}  // namespace

bool instances_as_polygons(const SceneDesc& desc) {
  if (desc.instances.empty() || desc.render.instancing == Instancing::Keep) return false;
  size_t polygons = 0;
  for (const ShapeDesc& sh : desc.shapes)
    if (sh.type != ShapeType::Sphere) polygons += sh.type == ShapeType::Quad && !is_planar_convex_quad(sh) ? 2 : 1;
  for (const InstanceDesc& in : desc.instances) {
    const MeshDesc& m = *desc.meshes[in.mesh];
    if (!m.tangent.empty()) return false;
    polygons += m.size();
    if (polygons > kPlacedPolygonsMax) return false;
  }
  // Each placed triangle must stay a triangle (a placement at an extreme scale could round one flat; the
  // instance path never places it): then primitive ids match primitive_shapes one for one.
  for (const InstanceDesc& in : desc.instances) {
    const MeshDesc& m = *desc.meshes[in.mesh];
    const MeshPlacement place(instance_world(desc, in));
    for (size_t t = 0; t < m.size(); ++t) {
      const std::array<DVec3, 3> v = place_triangle(m, t, place).v;
      if (degenerate_triangle(v[0], v[1], v[2])) return false;
    }
  }
  return true;
}

std::vector<uint32_t> primitive_shapes(const SceneDesc& desc) {
  // The order of compile_scene's loop: polygons as they come (two for a quad that is not planar and convex),
  // the instances' triangles where it places them as polygons (no shape: the shapes' count stands for them),
  // then the spheres.
  std::vector<uint32_t> polygons, spheres;
  for (size_t i = 0; i < desc.shapes.size(); ++i) {
    const ShapeDesc& sh = desc.shapes[i];
    const uint32_t id = static_cast<uint32_t>(i);
    if (sh.type == ShapeType::Sphere) spheres.push_back(id);
    else {
      polygons.push_back(id);
      if (sh.type == ShapeType::Quad && !is_planar_convex_quad(sh)) polygons.push_back(id);
    }
  }
  if (instances_as_polygons(desc))
    for (const InstanceDesc& in : desc.instances)
      polygons.insert(polygons.end(), desc.meshes[in.mesh]->size(), static_cast<uint32_t>(desc.shapes.size()));
  polygons.insert(polygons.end(), spheres.begin(), spheres.end());
  return polygons;
}

bool same_shapes(const SceneDesc& a, const SceneDesc& b) {
  if (a.materials.size() != b.materials.size() || a.shapes.size() != b.shapes.size()) return false;
  for (size_t i = 0; i < a.shapes.size(); ++i) {
    const ShapeDesc &x = a.shapes[i], &y = b.shapes[i];
    if (x.type != y.type || x.vertices != y.vertices || x.center != y.center || x.radius != y.radius ||
        x.material != y.material || x.shading != y.shading)
      return false;
  }
  // The instances: the same meshes (shared, never changed), placed alike.
  if (a.meshes != b.meshes || a.instances.size() != b.instances.size()) return false;
  for (size_t i = 0; i < a.instances.size(); ++i) {
    const InstanceDesc &x = a.instances[i], &y = b.instances[i];
    if (x.mesh != y.mesh || x.materials != y.materials || instance_world(a, x) != instance_world(b, y)) return false;
  }
  // The vertex normals (shared, never changed: the same table, or both without).
  return a.shading == b.shading || (!a.smooth_shading() && !b.smooth_shading());
}

bool same_geometry(const SceneDesc& a, const SceneDesc& b) {
  return a.width == b.width && a.height == b.height && same_shapes(a, b);
}

namespace {

// Moves the eye in place; false (nothing changed) when it moved too far from where the geometry was compiled.
bool move_camera(Scene& s, const CameraDesc& c) {
  const DVec3 offset = c.position - s.world_origin;
  if (glm::length(offset) > kCameraRebaseRadii * s.bounding_radius) return false;
  s.camera = compile_camera(c, s.width, s.height);
  s.camera.origin = Vec3(offset);
  return true;
}

}  // namespace

bool update_scene_appearance(Scene& s, const SceneDesc& before, const SceneDesc& after) {
  if (std::string err = validate_scene(after); !err.empty()) throw std::invalid_argument(err);
  // The film size may differ (a reduced-resolution preview of the same scene): the compiled scene keeps its own.
  if (!same_shapes(before, after)) throw std::invalid_argument("update_scene_appearance: the geometry changed");
  if (!same_camera(before.camera, after.camera) && !move_camera(s, after.camera)) return false;
  for (size_t i = 0; i < after.materials.size(); ++i)
    if (!same_material(before.materials[i], after.materials[i])) s.materials[i] = compile_material(after.materials[i]);
  keep_textures(after, s);
  note_material_features(s);
  if (!same_environment(before.environment, after.environment)) compile_environment(after.environment, s);
  compile_lights(s);
  return true;
}

std::string validate_edit(const SceneDesc& desc, const SceneEdit& edit) {
  if (const auto* m = std::get_if<MaterialEdit>(&edit)) {
    if (m->index >= desc.materials.size()) return "materials[" + std::to_string(m->index) + "]: no such material";
    if (!is_black(m->material.emission))
      for (const InstanceDesc& in : desc.instances)
        if (std::find(in.materials.begin(), in.materials.end(), static_cast<int>(m->index)) != in.materials.end())
          return "materials." + m->material.name +
                 ".emission: an instanced mesh has this material, and instanced meshes cannot emit light";
    return validate_material(m->material);
  }
  if (const auto* c = std::get_if<CameraDesc>(&edit)) return validate_camera(*c);
  if (const auto* f = std::get_if<FilmSize>(&edit)) return validate_film_size(f->width, f->height);
  return validate_environment(std::get<EnvironmentDesc>(edit));
}

void apply_edit(SceneDesc& desc, const SceneEdit& edit) {
  if (const auto* m = std::get_if<MaterialEdit>(&edit)) desc.materials.at(m->index) = m->material;
  else if (const auto* c = std::get_if<CameraDesc>(&edit)) desc.camera = *c;
  else if (const auto* f = std::get_if<FilmSize>(&edit)) desc.width = f->width, desc.height = f->height;
  else desc.environment = std::get<EnvironmentDesc>(edit);
}

void set_scene_resolution(Scene& s, int width, int height, const CameraDesc& c) {
  s.width = width;
  s.height = height;
  const Vec3 origin = s.camera.origin;  // the eye relative to where the geometry was compiled
  s.camera = compile_camera(c, width, height);
  s.camera.origin = origin;
}

bool apply_edit(Scene& s, const SceneEdit& edit) {
  if (const auto* c = std::get_if<CameraDesc>(&edit)) return move_camera(s, *c);
  if (std::holds_alternative<FilmSize>(edit)) return false;  // needs the camera: set_scene_resolution
  if (const auto* m = std::get_if<MaterialEdit>(&edit)) {
    s.materials.at(m->index) = compile_material(m->material);
    keep_texture(m->material, s);
    note_material_features(s);
  } else {
    compile_environment(std::get<EnvironmentDesc>(edit), s);
  }
  compile_lights(s);  // emitters and the sun may have changed
  return true;
}


bool Scene::intersect(const Ray& ray, float t_max, uint32_t skip, Hit& hit) const {
  return intersect_scene<kAllFeatures>(*this, ray, t_max, skip, hit);
}

bool Scene::occluded(const Ray& ray, float t_max, uint32_t skip_a, uint32_t skip_b) const {
  return occluded_scene<kAllFeatures>(*this, ray, t_max, skip_a, skip_b);
}

void Scene::intersect_packet(const Ray* rays, const float* t_max, const uint32_t* skip, int n, Hit* hits,
                             bool* found) const {
  intersect_scene_packet<kAllFeatures>(*this, rays, t_max, skip, n, hits, found);
}

uint32_t Scene::occluded_packet(const Ray* rays, const float* t_max, const uint32_t* skip_a, const uint32_t* skip_b,
                                int n) const {
  return occluded_scene_packet<kAllFeatures>(*this, rays, t_max, skip_a, skip_b, n);
}

}  // namespace pt
