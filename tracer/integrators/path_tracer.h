// The path tracer: one path per call. Notation after pbrt-v4 ch. 13 (PathIntegrator::Li): L accumulates
// radiance, beta is the path throughput (product of f·|cos|/pdf so far, divided by Russian-roulette survival
// probabilities). The loop sees materials only through the BSDF interface (materials/bsdf.h: flags, eval, pdf,
// sample) and lights only through the light interface (lights/light_sampling.h); it never names a material or
// light type. Nor do the SIMD shading lanes (shading_lanes.h) and bdpt (bdpt_kernels.h, bdpt_manifold.h): they
// ask a light what it is (Light::polygon, sphere; parallelogram_by_area) rather than test LightKind.
//
// Estimators (docs/estimators.md), chosen at run time:
// - uniform: purely diffuse BSDFs are sampled uniformly over the hemisphere of wo (pdf 1/2π); other BSDFs by
//   their own sampling; emission is added at every hit.
// - cosine:  BSDF sampling (cos θ/π for diffuse); emission at every hit (the Shadertoy tracer).
// - nee:     at every vertex with a non-specular lobe one light sample (shadow ray); emission found by BSDF
//   sampling is counted only from the camera and after specular bounces, since the light sample covers the rest.
// - mis:     both, weighted by the power heuristic (Veach 1997, §9.2) with the BSDF's own pdf.
// Emission found after a bounce that the bounce limit forbids to continue is still counted (max_bounces counts
// scattering events after the first hit).
//
// This header holds the kernel template; integrator_independent.cpp and integrator_sobol.cpp instantiate it for
// the 3 geometry sets (polygons, spheres, both) × 2 material sets (Lambert, any), one sampler per translation
// unit.
#pragma once
#include "integrators/integrator.h"
#include "integrators/direct_light.h"
#include "integrators/features.h"
#include "integrators/material_at.h"

#include <array>
#include <new>
#include <type_traits>
#include <utility>

#include "geometry/scene_queries.h"
#include "lights/light_sampling.h"
#include "materials/bsdf.h"
#include "materials/normal_map.h"
#include "materials/texture.h"
#include "sampling/sample_dimensions.h"

namespace pt {

namespace integrator_detail {


// MIS weight and contribution of the infinite lights along an escaping ray (pbrt-v4 loops over its infinite
// lights the same way: each is its own sampling strategy with its own density).
template <bool kWeighted>
inline Rgb escaped_radiance(const Scene& s, Vec3 w, Vec3 prev_n, float bsdf_pdf) {
  Rgb L(0.f);
  for (const uint32_t li : s.infinite_lights) {
    const Light& l = s.lights[li];
    if constexpr (kWeighted) {
      float pdf = 0.f;
      const Rgb Le = infinite_light_Le(s, l, prev_n, w, pdf, true);  // under MIS: the incomplete density
      if (is_black(Le)) continue;
      L += Le * power_heuristic(bsdf_pdf, s.light_pmf[li] * pdf);
    } else {
      const Rgb Le = infinite_light_Le(s, l, w);
      if (is_black(Le)) continue;
      L += Le;
    }
  }
  return L;
}

// The state of one path between bounces: what the scalar loop keeps in locals and the wavefront loop keeps per
// path in its batch.
struct PathState {
  Ray ray;                    // the ray to trace next
  uint32_t skip = ~0u;        // the planar primitive it leaves
  int depth = 0;              // scattering events so far
  Rgb L{0.f}, beta{1.f};      // radiance so far; throughput
  float eta_scale = 1.f;      // undoes the 1/η² of refraction when judging the path's worth for roulette
  bool count_emission = true; // camera ray or a specular bounce: no light sample covered this direction
  float prev_bsdf_pdf = 0.f;  // solid-angle pdf of the non-specular sample that produced `ray` (for MIS)
  Vec3 prev_p{0.f}, prev_n{0.f};  // the last non-specular vertex (for MIS weights of emission found from it)
  float cone_width = 0.f;         // the ray cone's width at the last hit (world units; texture filtering)
  float cone_spread = 0.f;        // its spread angle (PathOptions::cone_spread_for)
  FeatureTrace features;          // the sample's feature buffers while they are pending (features.h)
};

// A light sample's shadow ray, and what it adds to the path's L if nothing blocks it.
struct ShadowRay {
  Ray ray{Vec3(0.f), Vec3(0.f)};
  float t_max = 0.f;
  uint32_t skip_a = ~0u, skip_b = ~0u;  // the primitive it leaves and the light's own
  Rgb contribution{0.f};
};

// The render settings as the path loop reads them, resolved once per tile.
struct PathOptions {
  PathOptions(const RenderSettings& s, const Camera& camera)
      : uniform(s.estimator == Estimator::Uniform),
        light_sampling(s.estimator == Estimator::Nee || s.estimator == Estimator::Mis),
        mis(s.estimator == Estimator::Mis),
        dims(light_sampling, camera.thin_lens()),
        max_bounces(s.max_bounces),
        rr_depth(roulette_depth(s.russian_roulette_depth, false, false)),
        pixel_angle(pixel_angle_of(camera)) {}
  bool uniform, light_sampling, mis;
  SampleDimensions dims;
  int max_bounces, rr_depth;
  float pixel_angle;  // the angle one pixel spans (at the image's centre)

  // The ray cone's spread angle for the pixel's sample number `index` (material_at.h: ray_cone_spread).
  float cone_spread_for(uint32_t index) const { return ray_cone_spread(pixel_angle, index); }
};

// A ray that left the scene: infinite lights are lights like any other, so with light sampling they are counted
// here only where no light sample covered them (camera, specular bounce), or MIS-weighted.
inline void add_escaped_radiance(const Scene& s, const PathOptions& o, PathState& p) {
  if (!s.infinite_lights.empty()) {
    if (!o.light_sampling || p.count_emission) p.L += p.beta * escaped_radiance<false>(s, p.ray.d, p.prev_n, p.prev_bsdf_pdf);
    else if (o.mis) p.L += p.beta * escaped_radiance<true>(s, p.ray.d, p.prev_n, p.prev_bsdf_pdf);
  }
  if (p.features.out) [[unlikely]]
    p.features.escaped(p.L);
}

// The emission a path finds where p.ray hits primitive `prim` of an area light (at point `at`, front normal ng,
// texture coordinates uv): counted whole where no light sample covered the ray (a camera ray, a specular bounce, or
// an estimator without light sampling), else MIS-weighted against the light sample that could have chosen this point
// from the previous vertex. shade_vertex's first step, and the SIMD shading lanes' (shading_lanes.h), one lane at a
// time.
template <uint32_t F>
[[gnu::always_inline]] inline void add_found_emission(const Scene& s, const PathOptions& o, PathState& p, uint32_t prim,
                                                      Vec3 at, Vec3 ng, Vec2 uv) {
  const int li = s.light_of(prim);
  const Light& light = s.lights[li];
  Rgb Le = area_light_emission(light, ng, -p.ray.d);
  if (light.emission_map.texture) [[unlikely]] Le *= emission_texel(light, uv);
  if (!o.light_sampling || p.count_emission) {
    p.L += p.beta * Le;
  } else if (o.mis && !is_black(Le)) {
    p.L += p.beta * Le * power_heuristic(p.prev_bsdf_pdf, lights_pdf_area<F>(s, li, p.prev_p, p.prev_n, at, ng));
  }
}

// One vertex of the path at hit `h` of p.ray: adds the emission found there, prepares the light sample's shadow
// ray (`shadow`, when the result's `shadow_ray` is set; its contribution is the caller's to add if unoccluded),
// and samples the next direction into p (when `continues`). F: what the kernel is compiled for (KernelFeature):
// intersection code for primitive kinds outside F is compiled out, and so is the BSDF dispatch when every
// material is Lambertian.
struct VertexResult {
  bool continues = false;
  bool shadow_ray = false;
};
template <class Sampler, uint32_t F>
[[gnu::always_inline]] inline VertexResult shade_vertex(const Scene& s, const PathOptions& o, const Sampler& rng,
                                                        const Hit& h, PathState& p, ShadowRay& shadow,
                                                        RayCount& count) {
  constexpr MaterialSet kM = (F & kFeatureGeneralMaterials) != 0 ? MaterialSet::Any : MaterialSet::Lambert;
  VertexResult result;
  const int depth = p.depth;
  Interaction it = make_interaction<F>(s, p.ray, h);
  p.cone_width += p.cone_spread * h.t;
  MaterialScratch scratch;
  const Material& m = material_at<kM>(s, it, p.ray.d, p.cone_width, scratch);
  const Vec3 wo = -p.ray.d;

  if (!is_black(m.emission)) add_found_emission<F>(s, o, p, it.prim, it.p, it.ng, it.uv);
  if (p.features.out) [[unlikely]]
    p.features.at_vertex<kM>(depth, p.ray.o, it, wo, m, depth >= o.max_bounces, p.L);
  if (depth >= o.max_bounces) return result;

  // The shading frame: z is the front geometric normal, or on a smooth-shaded mesh the shading normal
  // (interaction.h: shading_normal); `n` is the geometric normal facing the viewer (the side lights are sampled
  // on, for BSDFs that only reflect: they are two-sided).
  const bool smooth = kM == MaterialSet::Any && it.ns != it.ng;
  const Frame frame = Frame::from_normal(smooth ? shading_normal(it, wo) : it.ng);
  const Vec3 wo_local = frame.to_local(wo);
  const Vec3 n = glm::dot(wo, it.ng) >= 0.f ? it.ng : -it.ng;
  const BsdfFlags flags = bsdf_flags<kM>(m);

  if (o.light_sampling && has_non_specular(flags)) {  // next-event estimation (direct_light.h)
    const float u_light = rng.get_1d(o.dims.light_choice(depth));
    const Vec2 u_point = rng.get_2d(o.dims.light_point(depth));
    DirectLightSample d;
    if (sample_direct<kM, F>(s, it, n, frame, m, wo_local, u_light, u_point, o.mis, d)) {
      ++count.rays;
      if (d.shadow.t_max > 0.f) {
        const float w = o.mis && !d.ls.delta ? power_heuristic(d.ls.pdf, d.bsdf_pdf) : 1.f;
        shadow = {d.shadow.ray, d.shadow.t_max, skip_on_leave(it), d.ls.prim,
                  p.beta * d.f * d.ls.Le * (std::abs(d.wi_local.z) * w / d.ls.pdf)};
        result.shadow_ray = true;
      }
    }
  }

  // Continue the path: sample the BSDF (or, for the uniform estimator, the hemisphere of a diffuse BSDF).
  const float uc = rng.get_1d(o.dims.bsdf_lobe(depth));
  const Vec2 u = rng.get_2d(o.dims.bsdf_direction(depth));
  BsdfSample bs;
  if (o.uniform && !any(flags & ~(BsdfFlags::Reflection | BsdfFlags::Diffuse))) {
    Vec3 local = sample_uniform_hemisphere(u);
    if (wo_local.z < 0.f) local.z = -local.z;
    bs = {local, bsdf_eval<kM>(m, wo_local, local), uniform_hemisphere_pdf(), BsdfFlags::Reflection | BsdfFlags::Diffuse, 1.f};
  } else if (!bsdf_sample<kM>(m, wo_local, uc, u, bs)) {
    return result;
  }
  if (!(bs.pdf > 0.f) || bs.wi.z == 0.f) return result;  // grazing sample of measure zero
  p.beta *= bs.f * (std::abs(bs.wi.z) / bs.pdf);
  if (p.features.out) [[unlikely]]
    p.features.through_specular(bs);
  if (is_specular(bs.flags)) {
    p.count_emission = true;
  } else {
    p.count_emission = false;
    p.prev_bsdf_pdf = bs.pdf;
    p.prev_p = it.p;
    p.prev_n = n;
  }
  if (is_transmissive(bs.flags)) p.eta_scale *= sqr(bs.eta);
  const Vec3 wi = frame.to_world(bs.wi);

  // Russian roulette (russian_roulette.h).
  if (roulette_applies(depth, o.rr_depth) &&
      !survives_roulette(p.beta, max_component(p.beta) * p.eta_scale, rng.get_1d(o.dims.roulette(depth))))
    return result;
  if (is_black(p.beta) || !is_finite(p.beta)) return result;
  p.ray = {smooth ? offset_ray_origin(it, bs.wi.z < 0.f) : offset_ray_origin(it, wi), wi};
  p.skip = skip_on_leave(it);
  p.depth = depth + 1;
  result.continues = true;
  return result;
}

// The scalar path loop: one path per call, the reference the wavefront loop (wavefront.h) must agree with.
template <class Sampler, uint32_t F>
Rgb trace(const Scene& s, const RenderSettings& settings, const Ray& camera_ray, Sampler& rng, RayCount& count,
          PixelFeatures* features, const std::atomic<bool>* cancel) {
  const PathOptions o(settings, s.camera);
  PathState p;
  p.ray = camera_ray;
  p.cone_spread = o.cone_spread_for(rng.sample_index());
  p.features.out = features;
  for (;;) {
    if (p.depth % kCancelPollBounces == kCancelPollBounces - 1 && cancel && cancel->load(std::memory_order_relaxed))
      break;
    Hit h;
    ++count.rays;
    if (!intersect_scene<F>(s, p.ray, kInfinity, p.skip, h)) {
      add_escaped_radiance(s, o, p);
      break;
    }
    ShadowRay shadow;
    const VertexResult v = shade_vertex<Sampler, F>(s, o, rng, h, p, shadow, count);
    if (v.shadow_ray && !occluded_scene<F>(s, shadow.ray, shadow.t_max, shadow.skip_a, shadow.skip_b))
      p.L += shadow.contribution;
    if (!v.continues) break;
  }
  return p.L;
}

template <class Sampler, size_t... F>
constexpr std::array<RadianceKernel<Sampler>, sizeof...(F)> kernels_for(std::index_sequence<F...>) {
  return {&trace<Sampler, static_cast<uint32_t>(F)>...};
}

// Sanitizer and fuzzing builds (PT_GENERIC_KERNELS_ONLY, set by CMake with PT_SANITIZE and PT_FUZZ) compile
// only the all-features kernels and serve every feature set with them: they run every line the specialised ones
// do, and instrumented builds of 8 feature sets × 2 samplers × 2 path loops took most of CI's time.
#if defined(PT_GENERIC_KERNELS_ONLY)
inline constexpr bool kGenericKernelsOnly = true;
#else
inline constexpr bool kGenericKernelsOnly = false;
#endif

// One kernel per feature set, indexed by the KernelFeature mask (masks without geometry never run).
template <class Sampler>
constexpr std::array<RadianceKernel<Sampler>, kAllFeatures + 1> make_kernels() {
  if constexpr (kGenericKernelsOnly) {
    std::array<RadianceKernel<Sampler>, kAllFeatures + 1> all{};
    all.fill(&trace<Sampler, kAllFeatures>);
    return all;
  } else {
    return kernels_for<Sampler>(std::make_index_sequence<kAllFeatures + 1>{});
  }
}
template <class Sampler>
constexpr std::array<RadianceKernel<Sampler>, kAllFeatures + 1> kKernels = make_kernels<Sampler>();

}  // namespace integrator_detail

template <class Sampler>
RadianceKernel<Sampler> select_kernel(const Scene& scene, bool generic) {
  return integrator_detail::kKernels<Sampler>[selected_kernel_features(scene, generic)];
}

template <class Sampler>
Rgb estimate_radiance(const Scene& scene, const RenderSettings& settings, const Ray& ray, Sampler& sampler,
                      RayCount& count) {
  // One path: `auto` is traced as mis (bdpt traces whole rounds of pixels, render/renderer.h).
  if (settings.estimator == Estimator::Auto) {
    RenderSettings mis = settings;
    mis.estimator = Estimator::Mis;
    return estimate_radiance(scene, mis, ray, sampler, count);
  }
  return select_kernel<Sampler>(scene, settings.generic_kernel)(scene, settings, ray, sampler, count, nullptr,
                                                                 nullptr);
}

}  // namespace pt
