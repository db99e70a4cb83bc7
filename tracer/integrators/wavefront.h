// The wavefront path loop: a batch of paths (one tile's worth of camera samples) advances bounce by bounce.
// Each bounce runs in stages over the live paths, as pbrt-v4's wavefront integrator runs its work queues
// (wavefront/workitems.h): closest hits for kLanes rays at a time through the packet kernels
// (geometry/packet_polygons.h), then each path's vertex (the scalar loop's own shade_vertex), then the queued
// shadow rays, kLanes at a time. Paths that end drop out of the queue, so the packets stay full.
//
// Each path performs exactly the arithmetic of the scalar loop (path_tracer.h), and its random numbers
// depend on (pixel, sample, seed, dimension) alone (sample_dimensions.h), so every sample's radiance is
// bit-identical to the scalar loop's (tested). Why it is faster: tiny scenes are searched by brute force, where
// sixteen rays against one polygon per SIMD step beat one ray against sixteen polygons (no dependency chain);
// on every scene, the Sobol points of a bounce are computed for all its paths at once (sampling/sobol_batch.h),
// Lambertian, glTF, plastic, conductor, subsurface, mirror and smooth glass polygons and spheres, textured or not
// (polygons), emitting or not, are shaded in SIMD lanes (shading_lanes.h), and each stage's loop runs one kind of
// work.
#pragma once
#include <algorithm>
#include <atomic>

#include "integrators/integrator.h"
#include "materials/bsdf.h"

namespace pt {

// Paths per batch: one 16×16 tile at one sample per pixel.
inline constexpr int kWavefrontBatch = 256;

// Radiance of n ≤ kWavefrontBatch camera samples: path i starts along camera_rays[i] and draws its random
// numbers from samplers[i]; its estimate goes to L[i], and its feature buffers to features[i] unless `features`
// is null (the caller initialises them). Returns false, leaving L unspecified, if `cancel` was set (polled once
// per bounce): the whole batch must then be dropped.
template <class Sampler>
using BatchKernel = bool (*)(const Scene&, const RenderSettings&, const Sampler* samplers, const Ray* camera_rays,
                             int n, Rgb* L, PixelFeatures* features, RayCount& count, const std::atomic<bool>* cancel);

// The batch kernel compiled for the scene's feature set (or all features with settings.generic_kernel), or null
// where settings.path_loop asks for the scalar loop.
template <class Sampler>
BatchKernel<Sampler> select_batch_kernel(const Scene& scene, const RenderSettings& settings);

// Whether the batch kernel compiled for `features` shades this scene's hits on polygons and spheres in SIMD lanes
// (shading_lanes.h; at the bounces where lights are sampled): every kernel with polygons (flat or smooth-shaded)
// or spheres, scenes of spheres alone included, where some material that does not emit is one the lanes take (a
// scene of others alone would only pay for their gathers); where they run, they shade the emitters they take too.
// Asked per batch, so a material edited live is seen at once. Every kind of light is sampled there
// (parallelograms by area in the lanes, the others by the scalar sample_li).
//
// The images the lanes read at a hit (through material_at, in the kernels for any material, on meshes with
// texture coordinates): the albedo's, glTF's metallic–roughness, the normal map and the emission's (whose texel and
// MIS weight a scalar step adds per emitting lane: shading_lanes.h, add_lane_emission).
// The Lambert lobe.
inline bool lambert_lane_material(const Material& m) { return is_lambertian(m); }
// The coupled lobe of materials/layered_lobe.h, glTF's metallic–roughness or the plastic, rough or smooth (a smooth
// layer's reflection is a Dirac lobe over the base); only in the kernels for any material.
inline bool layered_lane_material(const Material& m) {
  return m.type == MaterialType::MetallicRoughness || m.type == MaterialType::Plastic;
}
// The rough conductor (materials/conductor.h: GGX with Kulla–Conty's compensation, Schlick's or the complex
// index's Fresnel); only in the kernels for any material.
inline bool conductor_lane_material(const Material& m) {
  return m.type == MaterialType::Conductor && !effectively_smooth(m.alpha);
}
// The subsurface BRDF (materials/subsurface.h: Jensen et al.'s far-field approximation, cosine-sampled); only in the
// kernels for any material.
inline bool sss_lane_material(const Material& m) { return m.type == MaterialType::Subsurface; }
// Rough glass (materials/dielectric.h: Walter et al.'s GGX reflection and refraction); its light sample may lie on
// either side. Only in the kernels for any material.
inline bool rough_glass_lane_material(const Material& m) {
  return m.type == MaterialType::Dielectric && !effectively_smooth(m.alpha);
}
// A Dirac lobe alone, only sampled (no light sample there): the mirror, the smooth conductor and smooth glass;
// only in the kernels for any material.
inline bool dirac_lane_material(const Material& m) {
  const bool smooth_kind = m.type == MaterialType::Conductor || m.type == MaterialType::Dielectric;
  return m.type == MaterialType::Mirror || (smooth_kind && effectively_smooth(m.alpha));
}
// Any material the lanes shade, in the kernels for any material.
inline bool lane_material(const Material& m) {
  return lambert_lane_material(m) || layered_lane_material(m) || conductor_lane_material(m) ||
         sss_lane_material(m) || rough_glass_lane_material(m) || dirac_lane_material(m);
}
// The order the kernels for any material shade a bounce's hits in (trace_batch), in a scene whose materials the lanes
// take are of several kinds (MaterialKeys::mixed): by this key, so that a packet of the shading lanes holds one kind
// of lobe where it can. The lanes compute every kind of lobe some lane of the packet holds for all its lanes
// (lane_lobes.h), so a packet mixing kinds pays for each in every lane; and packets of misses or of hits the lanes
// hand back skip them. (A queue per kind of material, as pbrt-v4's wavefront integrator keeps one per material type
// and evaluates each in its own kernel, wavefront/integrator.cpp: EvaluateMaterialsAndBSDFs; Laine, Karras and Aila
// 2013, "Megakernels Considered Harmful: Wavefront Path Tracing on GPUs".) Only the order of work changes: each
// path's arithmetic is its own, so the images stay the scalar loop's bits.
enum class LaneSortKey : uint8_t {
  Missed,           // the ray left the scene
  Scalar,           // shade_vertex: a material the lanes do not take
  Lambert,
  Plastic,          // the coupled lobe with the coat's exact Fresnel
  Gltf,             // the coupled lobe with Schlick's
  Conductor,        // rough, Schlick's Fresnel
  ComplexConductor, // rough, the complex index's
  Subsurface,
  Mirror,
  SmoothConductor,
  Glass,
  RoughGlass,
  Count
};
inline LaneSortKey material_sort_key(const Material& m) {
  if (!lane_material(m)) return LaneSortKey::Scalar;
  switch (m.type) {
    case MaterialType::Diffuse: return LaneSortKey::Lambert;
    case MaterialType::Plastic: return LaneSortKey::Plastic;
    case MaterialType::MetallicRoughness: return LaneSortKey::Gltf;
    case MaterialType::Mirror: return LaneSortKey::Mirror;
    case MaterialType::Dielectric: return effectively_smooth(m.alpha) ? LaneSortKey::Glass : LaneSortKey::RoughGlass;
    case MaterialType::Subsurface: return LaneSortKey::Subsurface;
    case MaterialType::Conductor:
      if (effectively_smooth(m.alpha)) return LaneSortKey::SmoothConductor;
      return m.complex_ior ? LaneSortKey::ComplexConductor : LaneSortKey::Conductor;
    default: return LaneSortKey::Scalar;
  }
}
// The keys of a scene's first kKeyedMaterials materials, looked up once per batch (a material edited live is
// seen at the next one); the others' are found at each hit. `mixed`: the lanes take more than one kind of lobe
// here (or there are more materials than that), so sorting pays; with one kind it may not (instructions per sample,
// sorted against not: WusonOBJ.obj +0.7 %, the 2CylinderEngine −1.0 %; docs/performance.md, session 45).
struct MaterialKeys {
  static constexpr size_t kKeyedMaterials = 256;
  LaneSortKey key[kKeyedMaterials];
  bool mixed = false;
  void look_up(const Scene& s) {
    const size_t n = std::min(s.materials.size(), kKeyedMaterials);
    LaneSortKey first = LaneSortKey::Scalar;
    mixed = s.materials.size() > kKeyedMaterials;
    for (size_t i = 0; i < n; ++i) {
      key[i] = material_sort_key(s.materials[i]);
      if (key[i] == LaneSortKey::Scalar) continue;
      if (first == LaneSortKey::Scalar) first = key[i];
      mixed = mixed || key[i] != first;
    }
  }
  // The key of material m of scene s (the table's, or found now beyond it).
  LaneSortKey of(const Scene& s, uint32_t m) const {
    return m < kKeyedMaterials ? key[m] : material_sort_key(s.materials[m]);
  }
};
// A kept instance's triangle's key (out of line: the instance's material is found by a search).
[[gnu::noinline]] inline LaneSortKey instance_sort_key(const Scene& s, uint32_t prim, const MaterialKeys& keys) {
  return keys.of(s, s.material_of(prim));
}
[[gnu::always_inline]] inline LaneSortKey lane_sort_key(const Scene& s, const Hit& h, bool found,
                                                        const MaterialKeys& keys) {
  if (!found) return LaneSortKey::Missed;
  if (h.prim >= s.primitive_count()) [[unlikely]] return instance_sort_key(s, h.prim, keys);
  // SceneGeometry::material_of without its instance branch (GCC called that out of line here: 3 M instructions on
  // `materials`' callgrind).
  return keys.of(s, h.prim < s.sphere_begin() ? s.polygons.material[h.prim]
                                              : s.spheres.material[h.prim - s.sphere_begin()]);
}

inline bool shading_lanes_apply(const Scene& scene, uint32_t features) {
  if ((features & (kFeaturePolygons | kFeatureSpheres)) == 0) return false;
  const bool any = (features & kFeatureGeneralMaterials) != 0;
  return std::any_of(scene.materials.begin(), scene.materials.end(), [&](const Material& m) {
    if (has_textures(m) && scene.shading.empty()) return false;  // no texture coordinates: shade_vertex
    if (!is_black(m.emission)) return false;  // lamps alone, seldom hit, would not repay every packet's gather
    return any ? lane_material(m) : lambert_lane_material(m);
  });
}

// Whether settings.path_loop runs the wavefront loop (select_batch_kernel's choice). PathLoop::Auto takes it on
// every scene: it measured level with the scalar loop or faster on each one tried, brute-force polygons, polygons
// in a BVH, instances and spheres alone (docs/performance.md, session 38); the scalar loop stays for tests and
// measurements.
inline bool runs_wavefront(const RenderSettings& settings) { return settings.path_loop != PathLoop::Scalar; }

}  // namespace pt
