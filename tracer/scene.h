// The render-ready scene: an immutable snapshot compiled from a validated SceneDesc.
//
// All geometry is stored relative to the camera position (subtracted in double at compile time, then rounded to
// float). Camera rays therefore start exactly at the origin, and the float precision available to a hit point
// depends on its distance from the camera, not on where the scene sits in the world: a scene translated by 10^6
// renders the same image.
//
// Primitives are kept as structure-of-arrays by type (triangles, convex planar quads, spheres) so that the SIMD
// kernels test 16 (AVX-512) primitives per instruction; a primitive's global id is its index in the
// concatenation triangles ‖ quads ‖ spheres. Quads that are planar and convex stay quads (one lane instead of
// two): the Cornell box is 16 quads, one SIMD block per ray.
#pragma once
#include <array>
#include <memory>
#include <vector>

#include "camera.h"
#include "geometry.h"
#include "scene_desc.h"
#include "simd_polygons.h"

namespace pt {

struct Material {
  MaterialType type;
  Rgb albedo;
  Rgb emission;
  bool two_sided;
  float ior;
};

// Structure of arrays of polygons with N vertices (3: triangles, 4: convex planar quads). A quad is split by its
// diagonal a–c into the triangles ("halves") (a, b, c) and (a, c, d); hits report barycentrics in one half.
template <int N>
struct PolygonSoA {
  std::vector<Vec3> v[N];        // vertex k of every polygon
  std::vector<Vec3> normal;      // unit front normal normalize((b−a)×(c−a))
  std::vector<float> area;       // world units²
  std::vector<uint32_t> material;
  // Per triangle half, the smallest barycentrics (b0, b1, b2) a hit point may take: 4·γ7·max|vertex| over the
  // altitude to the opposite edge. Keeps interpolated hit points inside the polygon by more than their rounding
  // error, so a point near an edge shared with another face can never round to the far side of that face (a
  // light leak through closed geometry).
  std::vector<std::array<Vec3, N - 2>> edge_margin;
  // Quads only: parallelograms map a 2D sample onto their area directly (keeping its stratification); other
  // quads pick a half with probability area(a, b, c)/area, stored here.
  std::vector<uint8_t> parallelogram;
  std::vector<float> first_half_fraction;
  size_t size() const { return normal.size(); }
};

struct SphereSoA {
  std::vector<DVec3> center;  // camera-relative, double: the stable intersection runs in double
  std::vector<double> radius;
  std::vector<uint32_t> material;
  size_t size() const { return center.size(); }
};

// One emitting primitive, or the environment (the uniform background radiance, prim = kEnvironment).
// Lights are chosen with probability proportional to emitted power.
inline constexpr uint32_t kEnvironment = ~0u;
struct Light {
  uint32_t prim;    // global primitive id, or kEnvironment
  float area;       // world units² (0 for the environment)
  Rgb emission;
  bool two_sided;
};

// What the scene contains, recorded at compile time (the kernels will specialise on it).
struct SceneFeatures {
  bool triangles = false, quads = false, spheres = false;
  bool delta_materials = false, dielectrics = false, emissive_spheres = false, background = false;
};

struct Hit {
  float t = kInfinity;
  uint32_t prim = ~0u;
  float b0 = 0, b1 = 0, b2 = 0;  // barycentrics for polygons (for quads: in the half `half`, see PolygonSoA)
  uint32_t half = 0;
};

class Scene {
 public:
  Camera camera;
  RenderSettings render;
  Rgb background{0.f};
  int width = 0, height = 0;
  DVec3 world_origin{0.0};  // the camera position subtracted from all geometry

  std::vector<Material> materials;
  PolygonSoA<3> triangles;
  PolygonSoA<4> quads;
  SphereSoA spheres;
  PolygonLanes<3> triangle_lanes;  // the same vertices, padded SoA for the SIMD tests
  PolygonLanes<4> quad_lanes;
  SceneFeatures features;

  std::vector<Light> lights;
  std::vector<int32_t> light_of_prim;  // light index of each primitive, −1 for non-emitters
  std::vector<float> light_cdf;        // cumulative power-proportional selection probabilities
  std::vector<float> light_pmf;
  int environment_light = -1;          // index of the background in `lights`, −1 if the background is black
  double bounding_radius = 0.0;        // of a sphere around all geometry (centred at the camera)

  uint32_t triangle_begin() const { return 0; }
  uint32_t quad_begin() const { return static_cast<uint32_t>(triangles.size()); }
  uint32_t sphere_begin() const { return quad_begin() + static_cast<uint32_t>(quads.size()); }
  uint32_t primitive_count() const { return sphere_begin() + static_cast<uint32_t>(spheres.size()); }
  uint32_t material_of(uint32_t prim) const;

  // Closest hit in (0, t_max), never reporting `skip` (the planar primitive a spawned ray leaves; ~0u for none).
  bool intersect(const Ray& ray, float t_max, uint32_t skip, Hit& hit) const;
  // Any hit in (0, t_max) ignoring primitives skip_a and skip_b: for shadow rays.
  bool occluded(const Ray& ray, float t_max, uint32_t skip_a, uint32_t skip_b) const;
};

// Builds the render-ready scene. The description must already be valid (scene_json validates files; code that
// builds a SceneDesc by hand can call validate_scene). Throws std::invalid_argument on anything it cannot render.
std::shared_ptr<const Scene> compile_scene(const SceneDesc& desc);

// Checks a SceneDesc built in code; returns an empty string when valid, else "path: reason".
std::string validate_scene(const SceneDesc& desc);

}  // namespace pt
