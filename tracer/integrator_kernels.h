// Path tracing estimators. Notation after pbrt-v4 ch. 13: L accumulates radiance, beta is the path throughput
// (product of f·|cos|/pdf so far, possibly divided by Russian-roulette survival probabilities).
//
// - uniform: diffuse bounces sample the hemisphere uniformly (pdf 1/2π), weight = 2·ρ·cos θ; emission is added at
//   every hit.
// - cosine:  diffuse bounces sample cos θ/π, weight = ρ; emission at every hit (the Shadertoy tracer).
// - nee:     at every diffuse vertex one light sample (shadow ray); emission found by BSDF sampling is counted only
//   from the camera and after delta (mirror/glass) bounces, since the light sample already covers it.
// - mis:     both, weighted by the power heuristic (Veach 1997, §9.2).
// Delta materials scatter the same way under every estimator. Emission found after a bounce that the bounce
// limit forbids to continue is still counted (max_bounces counts scattering events after the first hit).
//
// This header holds the kernel templates; integrator_independent.cpp and integrator_sobol.cpp instantiate them
// (4 estimators × 16 feature sets each), one sampler per translation unit so the two compile in parallel.
#pragma once
#include "integrator.h"

#include <array>
#include <utility>

#include "bsdf.h"
#include "lights.h"
#include "scene_queries.h"

namespace pt {

namespace integrator_detail {

// Shadow rays stop just short of the light point: the light's own primitive is skipped too, so this factor
// only has to guard against geometry coplanar with the light (relative, so scale-independent).
constexpr float kShadowRayShorten = 1.f - 0x1p-12f;

// F: the kernel's feature set (see KernelFeature). Tests of features outside F are compiled out: a Cornell box
// kernel has no sphere test, no mirror or glass branch and no background lookup.
template <Estimator E, class Sampler, uint32_t F>
Rgb trace(const Scene& s, const Ray& camera_ray, Sampler& rng, RayCount& count) {
  constexpr bool kLightSampling = E == Estimator::Nee || E == Estimator::Mis;
  constexpr bool kDelta = (F & kFeatureDelta) != 0, kBackground = (F & kFeatureEnvironment) != 0;
  Ray ray = camera_ray;
  const int max_bounces = s.render.max_bounces;
  const int rr_depth = s.render.russian_roulette_depth;
  Rgb L(0.f), beta(1.f);
  float eta_scale = 1.f;      // undoes the 1/η² of refraction when judging the path's worth for roulette
  bool count_emission = true; // camera ray or a delta bounce: no light sample covered this direction
  float bsdf_pdf = 0.f;       // solid-angle pdf of the diffuse sample that produced `ray` (for MIS)
  Vec3 prev_p(0.f), prev_n(0.f);  // the last diffuse vertex (for MIS weights of emission found from it)
  uint32_t skip = ~0u;

  for (int depth = 0;; ++depth) {
    Hit h;
    ++count.rays;
    if (!intersect_scene<F>(s, ray, kInfinity, skip, h)) {
      // The background is a light like any other: with light sampling it is counted here only where no light
      // sample covered it (camera, delta bounce), or MIS-weighted.
      if constexpr (!kBackground) {
      } else if (!kLightSampling || count_emission) {
        L += beta * s.background;
      } else if constexpr (E == Estimator::Mis) {
        if (s.environment_light >= 0)
          L += beta * s.background * power_heuristic(bsdf_pdf, environment_pdf(s, prev_n, ray.d));
      }
      break;
    }
    const Interaction it = make_interaction<F>(s, ray, h);
    const Material& m = s.materials[it.material];
    const Vec3 wo = -ray.d;

    if (!is_black(m.emission)) {
      const int li = s.light_of_prim[it.prim];
      const Rgb Le = light_emission(s.lights[li], it.ng, wo);
      if (!kLightSampling || count_emission) {
        L += beta * Le;
      } else if constexpr (E == Estimator::Mis) {
        if (!is_black(Le)) L += beta * Le * power_heuristic(bsdf_pdf, light_pdf<F>(s, li, prev_p, it.p, it.ng));
      }
    }
    if (depth >= max_bounces) break;

    const Vec3 n = glm::dot(it.ng, wo) >= 0.f ? it.ng : -it.ng;  // two-sided shading: face the viewer
    Vec3 wi;
    if (!kDelta || m.type == MaterialType::Diffuse) {
      if (is_black(m.albedo)) break;
      const Rgb f = diffuse_f(m.albedo);
      if constexpr (kLightSampling) {
        const float u_light = rng.next_1d();
        const Vec2 u_point = rng.next_2d();
        LightSample ls;
        if (!s.lights.empty() && sample_light<F>(s, it.p, n, u_light, u_point, ls) && !is_black(ls.Le)) {
          const float cos_i = glm::dot(n, ls.wi);
          if (cos_i > 0.f) {  // the BSDF is zero below the surface: no shadow ray
            const Vec3 origin = offset_ray_origin(it, ls.wi);
            Vec3 dir = ls.wi;
            float t_max = kInfinity;
            if (ls.prim != kEnvironment) {
              const Vec3 to_light = ls.p - origin;
              const float dist = glm::length(to_light);
              dir = to_light / dist;
              t_max = dist * kShadowRayShorten;
            }
            ++count.rays;
            if (t_max > 0.f && !occluded_scene<F>(s, {origin, dir}, t_max, skip_on_leave(it), ls.prim)) {
              float w = 1.f;
              if constexpr (E == Estimator::Mis) w = power_heuristic(ls.pdf, cosine_hemisphere_pdf(cos_i));
              L += beta * f * ls.Le * (cos_i * w / ls.pdf);
            }
          }
        }
      }
      const Frame frame = Frame::from_normal(n);
      const Vec2 u = rng.next_2d();
      Vec3 local;
      if constexpr (E == Estimator::Uniform) {
        local = sample_uniform_hemisphere(u);
        beta *= m.albedo * (2.f * local.z);  // f·cos/pdf = (ρ/π)·cos θ·2π
        bsdf_pdf = uniform_hemisphere_pdf();
      } else {
        local = sample_cosine_hemisphere(u);
        beta *= m.albedo;  // f·cos/pdf = (ρ/π)·cos θ·π/cos θ
        bsdf_pdf = cosine_hemisphere_pdf(local.z);
      }
      if (!(local.z > 0.f)) break;  // grazing sample of measure zero
      wi = frame.to_world(local);
      count_emission = false;
    } else if constexpr (kDelta) {
      if (m.type == MaterialType::Mirror) {
        wi = reflect(ray.d, n);
        beta *= m.albedo;
      } else {
        const DeltaSample ds = sample_dielectric(wo, it.ng, m.ior, rng.next_1d());
        wi = ds.wi;
        beta *= ds.weight;
        eta_scale *= ds.eta_scale;
      }
      count_emission = true;
    }

    // Russian roulette (unbiased: survivors are re-weighted by 1/q). q follows the throughput, so paths through
    // dark materials end early; q ≤ 1 − 2^-10 so even albedo-1 rooms terminate (mean length ~1000 bounces) while
    // rooms of albedo ρ < 1 keep finite variance (a cap c needs ρ² < c: 0.95 would not do for ρ = 0.999).
    if (rr_depth >= 0 && depth >= rr_depth) {
      const float q = std::min(1.f - 0x1p-10f, max_component(beta) * eta_scale);
      if (!(rng.next_1d() < q)) break;
      beta /= q;
    }
    if (is_black(beta)) break;
    prev_p = it.p;
    prev_n = n;
    ray = {offset_ray_origin(it, wi), wi};
    skip = skip_on_leave(it);
  }
  return L;
}

template <Estimator E, class Sampler, size_t... F>
constexpr std::array<RadianceKernel<Sampler>, sizeof...(F)> kernels_for(std::index_sequence<F...>) {
  return {&trace<E, Sampler, static_cast<uint32_t>(F)>...};
}

// Every estimator × every feature set: 4 × 16 kernels per sampler, indexed [estimator][features].
template <class Sampler>
constexpr std::array<std::array<RadianceKernel<Sampler>, kAllFeatures + 1>, 4> kKernels = {
    kernels_for<Estimator::Uniform, Sampler>(std::make_index_sequence<kAllFeatures + 1>{}),
    kernels_for<Estimator::Cosine, Sampler>(std::make_index_sequence<kAllFeatures + 1>{}),
    kernels_for<Estimator::Nee, Sampler>(std::make_index_sequence<kAllFeatures + 1>{}),
    kernels_for<Estimator::Mis, Sampler>(std::make_index_sequence<kAllFeatures + 1>{}),
};

}  // namespace integrator_detail

template <class Sampler>
RadianceKernel<Sampler> select_kernel(const Scene& scene, Estimator estimator, bool generic) {
  const uint32_t features = generic ? kAllFeatures : scene.kernel_features();
  return integrator_detail::kKernels<Sampler>[static_cast<size_t>(estimator)][features];
}

template <class Sampler>
Rgb estimate_radiance(const Scene& scene, Estimator estimator, const Ray& ray, Sampler& sampler, RayCount& count) {
  return select_kernel<Sampler>(scene, estimator, false)(scene, ray, sampler, count);
}

}  // namespace pt
