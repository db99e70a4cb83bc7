// Next-event estimation's one step (pbrt-v4's SampleLd, src/pbrt/cpu/integrators.cpp): from a receiver, choose a
// light in proportion to its power, sample it as seen from there, evaluate the BSDF towards the sample, and set
// up the shadow ray that decides whether it is seen. The path tracer's scalar and wavefront loops call
// sample_direct at every vertex with a non-specular lobe (path_tracer.h: shade_vertex); bdpt's strategy s = 1
// (bdpt_kernels.h: connect_light_sample) samples the light itself, since it picks infinite lights' directions
// by their emission distribution to match its MIS densities, and shares the shadow ray (shadow_segment). The
// SIMD shading lanes (shading_lanes.h) are this function written over lanes for their receivers (they
// sample parallelogram lights themselves and take sample_li's sample of any other), with the same operations in
// the same order (the wavefront renders the scalar loop's bits). Each caller weights the sample its own way (MIS
// against BSDF sampling, or bdpt's weights).
#pragma once
#include "geometry/interaction.h"
#include "integrators/integrator.h"
#include "lights/light_sampling.h"
#include "materials/bsdf.h"

namespace pt {

// The shadow ray from receiver `it` towards a light sample along wi: it leaves the receiver on wi's side
// (offset_ray_origin) and stops short of the light's point by kShadowRayShorten, relative, so that geometry
// coplanar with the light does not hide it (the light's own primitive is skipped as well); towards an infinite
// light it is unbounded. t_max ≤ 0 (or NaN) when the light's point is at the origin: no ray to cast.
struct ShadowSegment {
  Ray ray{Vec3(0.f), Vec3(0.f)};
  float t_max = 0.f;
};
// `back`: the side of the receiver it leaves on (offset_ray_origin), by default the one wi points to.
inline ShadowSegment shadow_segment(const Interaction& it, Vec3 wi, Vec3 p_light, bool infinite, bool back) {
  ShadowSegment seg{{offset_ray_origin(it, back), wi}, kInfinity};
  if (infinite) return seg;
  const Vec3 to_light = p_light - seg.ray.o;
  const float dist = glm::length(to_light);
  seg.ray.d = to_light / dist;
  seg.t_max = dist * kShadowRayShorten;
  return seg;
}

inline ShadowSegment shadow_segment(const Interaction& it, Vec3 wi, Vec3 p_light, bool infinite) {
  return shadow_segment(it, wi, p_light, infinite, glm::dot(wi, it.ng) < 0.f);
}

struct DirectLightSample {
  LightSample ls;       // ls.pdf includes the light's choice probability
  int light = -1;       // its index in Scene::lights
  Vec3 wi_local;        // ls.wi in the receiver's shading frame
  Rgb f;                // the BSDF at (wo, wi), for radiance
  float bsdf_pdf = 0.f;  // the density with which BSDF sampling would give wi (for MIS)
  ShadowSegment shadow;
};

// Samples one light for the receiver `it` (shading frame `frame`, `n` the normal of the side lit, `wo_local` the
// outgoing direction in that frame) with u_choice (which light) and u (where on it); `mis`: the caller weighs it
// against BSDF sampling by MIS, so lights may use an incomplete density (light_sampling.h). False when there is nothing
// to trace: no light, no usable sample, no emission towards the receiver, or a BSDF that is zero there. The
// BSDF's f and its sampling density of wi come from one pass (bsdf_value); MIS weighs the sample with the
// density, the other estimators leave it (asking for f alone there, with the lobes still inlined into
// bsdf_value, made the path loop's code larger and `materials` under mis 2 % slower).
template <MaterialSet kM, uint32_t F>
[[gnu::always_inline]] inline bool sample_direct(const Scene& s, const Interaction& it, Vec3 n, const Frame& frame,
                                                 const Material& m, Vec3 wo_local, float u_choice, Vec2 u, bool mis,
                                                 DirectLightSample& d) {
  if (!sample_lights<F>(s, {it.p, n, it.prim}, u_choice, u, d.ls, d.light, mis) || is_black(d.ls.Le)) return false;
  d.wi_local = frame.to_local(d.ls.wi);
  const BsdfValue v = bsdf_value<kM>(m, wo_local, d.wi_local);
  d.f = v.f;
  d.bsdf_pdf = v.pdf;
  if (is_black(d.f)) return false;  // no shadow ray where the BSDF is zero
  // The side it leaves on is the shading frame's (offset_ray_origin); on a flat surface wi_local.z is wi·ng.
  d.shadow = shadow_segment(it, d.ls.wi, d.ls.p, d.ls.dist == kInfinity, d.wi_local.z < 0.f);
  return true;
}

}  // namespace pt
