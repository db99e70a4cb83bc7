// The path tracer: one path per call. Notation after pbrt-v4 ch. 13 (PathIntegrator::Li): L accumulates
// radiance, beta is the path throughput (product of f·|cos|/pdf so far, divided by Russian-roulette survival
// probabilities). The loop sees materials only through the BSDF interface (materials/bsdf.h: flags, eval, pdf,
// sample) and lights only through the light interface (lights/light_sampling.h); it never names a material or
// light type.
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

#include <array>
#include <utility>

#include "geometry/scene_queries.h"
#include "lights/light_sampling.h"
#include "materials/bsdf.h"

namespace pt {

namespace integrator_detail {

// Shadow rays stop just short of the light point: the light's own primitive is skipped too, so this factor
// only has to guard against geometry coplanar with the light (relative, so scale-independent).
constexpr float kShadowRayShorten = 1.f - 0x1p-12f;

// MIS weight and contribution of the infinite lights along an escaping ray (pbrt-v4 loops over its infinite
// lights the same way: each is its own sampling strategy with its own density).
template <bool kWeighted>
inline Rgb escaped_radiance(const Scene& s, Vec3 w, Vec3 prev_n, float bsdf_pdf) {
  Rgb L(0.f);
  for (const uint32_t li : s.infinite_lights) {
    const Light& l = s.lights[li];
    const Rgb Le = infinite_light_Le(s, l, w);
    if (is_black(Le)) continue;
    if constexpr (kWeighted) {
      L += Le * power_heuristic(bsdf_pdf, s.light_pmf[li] * infinite_light_pdf(s, l, prev_n, w));
    } else {
      L += Le;
    }
  }
  return L;
}

// F: what the kernel is compiled for (KernelFeature): intersection code for primitive kinds outside F is compiled
// out, and so is the BSDF dispatch when every material is Lambertian.
template <class Sampler, uint32_t F>
Rgb trace(const Scene& s, const RenderSettings& settings, const Ray& camera_ray, Sampler& rng, RayCount& count,
          const std::atomic<bool>* cancel) {
  constexpr MaterialSet kM = (F & kFeatureGeneralMaterials) != 0 ? MaterialSet::Any : MaterialSet::Lambert;
  const Estimator estimator = settings.estimator;
  const bool light_sampling = estimator == Estimator::Nee || estimator == Estimator::Mis;
  const bool mis = estimator == Estimator::Mis;
  Ray ray = camera_ray;
  const int max_bounces = settings.max_bounces;
  const int rr_depth = settings.russian_roulette_depth;
  Rgb L(0.f), beta(1.f);
  float eta_scale = 1.f;      // undoes the 1/η² of refraction when judging the path's worth for roulette
  bool count_emission = true; // camera ray or a specular bounce: no light sample covered this direction
  float prev_bsdf_pdf = 0.f;  // solid-angle pdf of the non-specular sample that produced `ray` (for MIS)
  Vec3 prev_p(0.f), prev_n(0.f);  // the last non-specular vertex (for MIS weights of emission found from it)
  uint32_t skip = ~0u;

  for (int depth = 0;; ++depth) {
    if (depth % kCancelPollBounces == kCancelPollBounces - 1 && cancel && cancel->load(std::memory_order_relaxed))
      break;
    Hit h;
    ++count.rays;
    if (!intersect_scene<F>(s, ray, kInfinity, skip, h)) {
      // Infinite lights are lights like any other: with light sampling they are counted here only where no light
      // sample covered them (camera, specular bounce), or MIS-weighted.
      if (!s.infinite_lights.empty()) {
        if (!light_sampling || count_emission) L += beta * escaped_radiance<false>(s, ray.d, prev_n, prev_bsdf_pdf);
        else if (mis) L += beta * escaped_radiance<true>(s, ray.d, prev_n, prev_bsdf_pdf);
      }
      break;
    }
    const Interaction it = make_interaction<F>(s, ray, h);
    const Material& m = s.materials[it.material];
    const Vec3 wo = -ray.d;

    if (!is_black(m.emission)) {
      const int li = s.light_of_prim[it.prim];
      const Light& light = s.lights[li];
      const Rgb Le = area_light_emission(light, it.ng, wo);
      if (!light_sampling || count_emission) {
        L += beta * Le;
      } else if (mis && !is_black(Le)) {
        L += beta * Le * power_heuristic(prev_bsdf_pdf, lights_pdf_area<F>(s, li, prev_p, it.p, it.ng));
      }
    }
    if (depth >= max_bounces) break;

    // The shading frame: z is the front geometric normal; `n` faces the viewer (the side lights are sampled on,
    // for BSDFs that only reflect: they are two-sided).
    const Frame frame = Frame::from_normal(it.ng);
    const Vec3 wo_local = frame.to_local(wo);
    const Vec3 n = wo_local.z >= 0.f ? it.ng : -it.ng;
    const uint32_t flags = bsdf_flags<kM>(m);

    if (light_sampling && has_non_specular(flags)) {
      const float u_light = rng.next_1d();
      const Vec2 u_point = rng.next_2d();
      LightSample ls;
      int li;
      if (sample_lights<F>(s, {it.p, n}, u_light, u_point, ls, li) && !is_black(ls.Le)) {
        const Vec3 wi_local = frame.to_local(ls.wi);
        const Rgb f = bsdf_eval<kM>(m, wo_local, wi_local);
        if (!is_black(f)) {  // no shadow ray where the BSDF is zero
          const Vec3 origin = offset_ray_origin(it, ls.wi);
          Vec3 dir = ls.wi;
          float t_max = kInfinity;
          if (ls.dist != kInfinity) {
            const Vec3 to_light = ls.p - origin;
            const float dist = glm::length(to_light);
            dir = to_light / dist;
            t_max = dist * kShadowRayShorten;
          }
          ++count.rays;
          if (t_max > 0.f && !occluded_scene<F>(s, {origin, dir}, t_max, skip_on_leave(it), ls.prim)) {
            const float w = mis ? power_heuristic(ls.pdf, bsdf_pdf<kM>(m, wo_local, wi_local)) : 1.f;
            L += beta * f * ls.Le * (std::abs(wi_local.z) * w / ls.pdf);
          }
        }
      }
    }

    // Continue the path: sample the BSDF (or, for the uniform estimator, the hemisphere of a diffuse BSDF).
    const float uc = rng.next_1d();
    const Vec2 u = rng.next_2d();
    BsdfSample bs;
    if (estimator == Estimator::Uniform && (flags & ~(kBsdfReflection | kBsdfDiffuse)) == 0) {
      Vec3 local = sample_uniform_hemisphere(u);
      if (wo_local.z < 0.f) local.z = -local.z;
      bs = {local, bsdf_eval<kM>(m, wo_local, local), uniform_hemisphere_pdf(), kBsdfReflection | kBsdfDiffuse, 1.f};
    } else if (!bsdf_sample<kM>(m, wo_local, uc, u, bs)) {
      break;
    }
    if (!(bs.pdf > 0.f) || bs.wi.z == 0.f) break;  // grazing sample of measure zero
    beta *= bs.f * (std::abs(bs.wi.z) / bs.pdf);
    if (is_specular(bs.flags)) {
      count_emission = true;
    } else {
      count_emission = false;
      prev_bsdf_pdf = bs.pdf;
      prev_p = it.p;
      prev_n = n;
    }
    if (is_transmissive(bs.flags)) eta_scale *= sqr(bs.eta);
    const Vec3 wi = frame.to_world(bs.wi);

    // Russian roulette (unbiased: survivors are re-weighted by 1/q). q follows the throughput, so paths through
    // dark materials end early; q ≤ 1 − 2^-10 so even albedo-1 rooms terminate (mean length ~1000 bounces) while
    // rooms of albedo ρ < 1 keep finite variance (a cap c needs ρ² < c: 0.95 would not do for ρ = 0.999).
    if (rr_depth >= 0 && depth >= rr_depth) {
      const float q = std::min(1.f - 0x1p-10f, max_component(beta) * eta_scale);
      if (!(rng.next_1d() < q)) break;
      beta /= q;
    }
    if (is_black(beta) || !is_finite(beta)) break;
    ray = {offset_ray_origin(it, wi), wi};
    skip = skip_on_leave(it);
  }
  return L;
}

template <class Sampler, size_t... F>
constexpr std::array<RadianceKernel<Sampler>, sizeof...(F)> kernels_for(std::index_sequence<F...>) {
  return {&trace<Sampler, static_cast<uint32_t>(F)>...};
}

// One kernel per feature set, indexed by the KernelFeature mask (masks without geometry never run).
template <class Sampler>
constexpr std::array<RadianceKernel<Sampler>, kAllFeatures + 1> kKernels =
    kernels_for<Sampler>(std::make_index_sequence<kAllFeatures + 1>{});

}  // namespace integrator_detail

template <class Sampler>
RadianceKernel<Sampler> select_kernel(const Scene& scene, bool generic) {
  const uint32_t features = generic ? kAllFeatures : scene.kernel_features();
  return integrator_detail::kKernels<Sampler>[features];
}

template <class Sampler>
Rgb estimate_radiance(const Scene& scene, const RenderSettings& settings, const Ray& ray, Sampler& sampler,
                      RayCount& count) {
  return select_kernel<Sampler>(scene, settings.generic_kernel)(scene, settings, ray, sampler, count, nullptr);
}

}  // namespace pt
