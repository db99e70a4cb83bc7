// The primitives as the ray queries read them. They are kept as structure-of-arrays by kind (polygons, spheres)
// so that the SIMD kernels test 16 (AVX-512) polygons per instruction; a primitive's global id is its index in the
// concatenation polygons ‖ spheres. Triangles and convex planar quads share one polygon array (a triangle is a
// quad with a flag), so a scene of up to 16 polygons, whatever their mix, costs one SIMD block per ray; the
// Cornell box (15 planar quads and the two triangles of its non-planar right wall) costs one block and a 4-wide
// tail. Coordinates are camera-relative (scene/scene.h says why).
#pragma once
#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "geometry/alpha_mask.h"
#include "geometry/geometry.h"
#include "geometry/instances.h"
#include "geometry/polygon_bvh.h"
#include "geometry/simd_polygons.h"
#include "geometry/sphere_lanes.h"

namespace pt {

inline constexpr uint32_t kNoPrimitive = ~0u;

// Structure of arrays of polygons: triangles (a, b, c) and convex planar quads (a, b, c, d). A quad is split by
// its diagonal a–c into two triangles ("halves") (a, b, c) and (a, c, d); a triangle is its own half 0.
struct PolygonSoA {
  std::vector<Vec3> v[4];         // vertex k of every polygon; a triangle's v[3] repeats v[0]
  std::vector<uint8_t> triangle;  // 1 for triangles, 0 for quads
  std::vector<Vec3> normal;       // unit front normal normalize((b−a)×(c−a))
  std::vector<float> area;        // world units²
  std::vector<uint32_t> material;
  // Per half, the smallest barycentrics (b0, b1, b2) a hit point may take: 4·γ7·max|vertex| over the altitude
  // to the opposite edge. Keeps interpolated hit points inside the polygon by more than their rounding error,
  // so a point near an edge shared with another face can never round to the far side of that face (a light
  // leak through closed geometry).
  std::vector<std::array<Vec3, 2>> edge_margin;
  // Per half (a, q, r), the dual vectors that give the barycentrics of q and r of a point p in the plane:
  // b_q = (p − a)·dual[half][0], b_r = (p − a)·dual[half][1] (with e1 = q − a, e2 = r − a, n = e1 × e2:
  // dual = (e2 × n, n × e1)/|n|²). Shading turns the hit distance into barycentrics with them.
  std::vector<std::array<std::array<Vec3, 2>, 2>> dual;
  // Parallelograms map a 2D light sample onto their area directly (keeping its stratification); other quads
  // pick a half with probability area(a, b, c)/area, stored here (1 for triangles).
  std::vector<uint8_t> parallelogram;
  std::vector<float> first_half_fraction;
  size_t size() const { return normal.size(); }
};

struct SphereSoA {
  std::vector<DVec3> center;  // camera-relative, double: the stable intersection runs in double
  std::vector<double> radius;
  std::vector<uint32_t> material;
  SphereLanes lanes;  // centres and squared radii again, in SIMD lanes (sphere_lanes.h)
  size_t size() const { return center.size(); }
  void add(DVec3 c, double r, uint32_t m) {
    lanes.add(c, r);
    center.push_back(c);
    radius.push_back(r);
    material.push_back(m);
  }
};

// Smooth shading: per polygon, its vertices' normals and texture coordinates, in the order of its vertices
// (v[0], v[1], v[2]). Empty when no shape of the scene has any (make_interaction then reads neither); when some
// have, every other polygon repeats its face normal (and takes uv 0), so one array serves all.
struct PolygonShading {
  std::vector<std::array<Vec3, 3>> normal;
  std::vector<std::array<Vec2, 3>> uv;
  bool empty() const { return normal.empty(); }
};

// What a rendering kernel is compiled for (a bit mask, a template argument): the geometry, whose intersection
// code for a primitive kind outside the set is not in the kernel at all, and whether any material is more than
// Lambertian (without it the BSDF dispatch is compiled out: materials/bsdf.h, MaterialSet). Lights and the
// estimator are chosen at run time (a few well-predicted branches per bounce), so there are 6 kernels per
// sampler. kAllFeatures is the generic kernel, used by the plain query functions and for comparisons.
enum KernelFeature : uint32_t {
  kFeaturePolygons = 1,          // triangles or quads
  kFeatureSpheres = 2,           // spheres (emitting ones included)
  kFeatureGeneralMaterials = 4,  // a material other than Lambert, or smooth shading (vertex normals)
};
inline constexpr uint32_t kAllFeatures = kFeaturePolygons | kFeatureSpheres | kFeatureGeneralMaterials;

// What the ray queries report. Polygon barycentrics are recomputed for the one winning polygon when the hit is
// shaded (make_interaction), so the SIMD kernels only track distances.
struct Hit {
  float t = kInfinity;
  uint32_t prim = ~0u;
};

// The scalar watertight test of polygon i (triangle or quad).
inline bool intersect_polygon(const PolygonSoA& p, uint32_t i, Vec3 o, const RayShear& s, float t_max, PolygonHit& h) {
  if (p.triangle[i]) return intersect_triangle(p.v[0][i], p.v[1][i], p.v[2][i], o, s, t_max, h);
  return intersect_quad(p.v[0][i], p.v[1][i], p.v[2][i], p.v[3][i], o, s, t_max, h);
}

// What the ray queries (scene_queries.h) and make_interaction (interaction.h) read: the primitives, and the
// same polygons' vertices for the SIMD tests: all of them in padded SoA (brute force) when there are fewer than
// kBvhMinPolygons, else in the hierarchy's leaves (polygon_lanes then stays empty); and the instanced meshes
// (instances.h), whose triangles take the ids after the spheres'.
struct SceneGeometry {
  PolygonSoA polygons;
  PolygonShading shading;  // parallel to `polygons`, or empty
  SphereSoA spheres;
  PolygonLanes polygon_lanes;
  PolygonBvh polygon_bvh;
  // Cut-outs (alpha_mask.h): per material, its mask or null; empty when no material has one (then the queries
  // run without the test). A scene with cut-outs always has a hierarchy (its traversal applies them).
  std::vector<std::shared_ptr<const AlphaMask>> material_mask;
  InstanceSet instances;

  uint32_t sphere_begin() const { return static_cast<uint32_t>(polygons.size()); }
  // The scene's own primitives (polygons, spheres); the instances' triangles follow them.
  uint32_t primitive_count() const { return sphere_begin() + static_cast<uint32_t>(spheres.size()); }
  bool is_sphere(uint32_t prim) const { return prim >= sphere_begin() && prim < primitive_count(); }
  uint32_t material_of(uint32_t prim) const {
    if (prim < sphere_begin()) return polygons.material[prim];
    if (prim < primitive_count()) return spheres.material[prim - sphere_begin()];
    const Instance& in = instances.instance_of(prim);
    return in.material[in.geometry->slot(prim - in.first_prim)];
  }
  bool has_cutouts() const { return !material_mask.empty(); }
  // Whether polygon p's hit h (its barycentrics) falls where its material's mask cuts the surface away (xi: the
  // ray's own number for partial transparency, ray_uniform).
  bool cut_away(uint32_t p, const PolygonHit& h, float xi) const {
    const uint32_t m = polygons.material[p];
    const AlphaMask* mask = m < material_mask.size() ? material_mask[m].get() : nullptr;
    if (!mask) return false;
    Vec2 uv(0.f);
    if (!shading.empty()) {
      const std::array<Vec2, 3>& t = shading.uv[p];
      uv = h.b0 * t[0] + h.b1 * t[1] + h.b2 * t[2];
    }
    return !mask->opaque_at(uv, xi);
  }
  // The same for the hit h on triangle i of instance `in`'s mesh (barycentrics in the mesh's vertex order).
  bool cut_away(const Instance& in, uint32_t i, const PolygonHit& h, float xi) const {
    const TriangleMesh& mesh = *in.geometry->mesh;
    const uint32_t m = in.material[mesh.slot[i]];
    const AlphaMask* mask = m < material_mask.size() ? material_mask[m].get() : nullptr;
    if (!mask) return false;
    Vec2 uv(0.f);
    if (!mesh.uv.empty()) {
      const std::array<uint32_t, 3>& t = mesh.index[i];
      uv = h.b0 * mesh.uv[t[0]] + h.b1 * mesh.uv[t[1]] + h.b2 * mesh.uv[t[2]];
    }
    return !mask->opaque_at(uv, xi);
  }
};

}  // namespace pt
