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
#include "integrator.h"

#include "bsdf.h"
#include "lights.h"

namespace pt {

namespace {

// Shadow rays stop just short of the light point: the light's own primitive is skipped too, so this factor
// only has to guard against geometry coplanar with the light (relative, so scale-independent).
constexpr float kShadowRayShorten = 1.f - 0x1p-12f;

template <Estimator E, class Sampler>
Rgb trace(const Scene& s, Ray ray, Sampler& rng, RayCount& count) {
  constexpr bool kLightSampling = E == Estimator::Nee || E == Estimator::Mis;
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
    if (!s.intersect(ray, kInfinity, skip, h)) {
      // The background is a light like any other: with light sampling it is counted here only where no light
      // sample covered it (camera, delta bounce), or MIS-weighted.
      if (!kLightSampling || count_emission) {
        L += beta * s.background;
      } else if constexpr (E == Estimator::Mis) {
        if (s.environment_light >= 0)
          L += beta * s.background * power_heuristic(bsdf_pdf, environment_pdf(s, prev_n, ray.d));
      }
      break;
    }
    const Interaction it = make_interaction(s, ray, h);
    const Material& m = s.materials[it.material];
    const Vec3 wo = -ray.d;

    if (!is_black(m.emission)) {
      const int li = s.light_of_prim[it.prim];
      const Rgb Le = light_emission(s.lights[li], it.ng, wo);
      if (!kLightSampling || count_emission) {
        L += beta * Le;
      } else if constexpr (E == Estimator::Mis) {
        if (!is_black(Le)) L += beta * Le * power_heuristic(bsdf_pdf, light_pdf(s, li, prev_p, it.p, it.ng));
      }
    }
    if (depth >= max_bounces) break;

    const Vec3 n = glm::dot(it.ng, wo) >= 0.f ? it.ng : -it.ng;  // two-sided shading: face the viewer
    Vec3 wi;
    if (m.type == MaterialType::Diffuse) {
      if (is_black(m.albedo)) break;
      const Rgb f = diffuse_f(m.albedo);
      if constexpr (kLightSampling) {
        const float u_light = rng.next_1d();
        const Vec2 u_point = rng.next_2d();
        LightSample ls;
        if (!s.lights.empty() && sample_light(s, it.p, n, u_light, u_point, ls) && !is_black(ls.Le)) {
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
            if (t_max > 0.f && !s.occluded({origin, dir}, t_max, skip_on_leave(it), ls.prim)) {
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
    } else if (m.type == MaterialType::Mirror) {
      wi = reflect(ray.d, n);
      beta *= m.albedo;
      count_emission = true;
    } else {
      const DeltaSample ds = sample_dielectric(wo, it.ng, m.ior, rng.next_1d());
      wi = ds.wi;
      beta *= ds.weight;
      eta_scale *= ds.eta_scale;
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

}  // namespace

template <class Sampler>
Rgb estimate_radiance(const Scene& scene, Estimator estimator, const Ray& ray, Sampler& sampler, RayCount& count) {
  switch (estimator) {
    case Estimator::Uniform: return trace<Estimator::Uniform>(scene, ray, sampler, count);
    case Estimator::Cosine: return trace<Estimator::Cosine>(scene, ray, sampler, count);
    case Estimator::Nee: return trace<Estimator::Nee>(scene, ray, sampler, count);
    case Estimator::Mis: return trace<Estimator::Mis>(scene, ray, sampler, count);
  }
  return Rgb(0.f);
}

template Rgb estimate_radiance(const Scene&, Estimator, const Ray&, IndependentSampler&, RayCount&);
template Rgb estimate_radiance(const Scene&, Estimator, const Ray&, SobolSampler&, RayCount&);

}  // namespace pt
