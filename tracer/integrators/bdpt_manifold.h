// The bidirectional estimator's manifold strategy: next-event estimation through a specular sphere (manifold
// next-event estimation, Hanika, Droske and Fascione 2015; the geometry is manifold_sphere.h).
//
// Why. A path eye → S … → x → S … S → light (x diffuse, S smooth mirror or glass vertices: the floor's caustic
// seen through the glass ball or in the mirror ball, the mirror ball's light on a wall seen in either ball) can
// be made by no connection when every edge touches a specular vertex: only path tracing (s = 0) makes it, by
// hitting the light through the sphere by chance. This strategy makes it on purpose: at x it draws one sphere
// chain (one reflection, or refraction in and out) and a point y on a polygon light (uniform by area, with the
// s = 1 connection's random numbers), and solves for the paths x → sphere → y.
//
// Its estimate for one solution ω (direction at x), with throughput β_x at x:
//   β_x · f_x(ω) |cos θ_x| · T · L_e(y) / p_M,    p_M = P(chain) · P(light) · (1/A) · dA_y/dω,
// T the chain's specular weights as the camera walk would have applied them (Fresnel, tint; the two 1/η² of
// refraction cancel), dA_y/dω the chain's measure conversion. Per solid angle at x, path tracing makes the same
// path with density p_0 = pdf_x(ω) · Π (the chain's lobe choices).
//
// Which paths, and the weights. Only where no connection strategy can make the path (manifold_vertex: the eye's
// neighbour and x's predecessor specular, no two non-specular vertices adjacent): there path tracing's existing
// weight is 1, and the power heuristic over the two strategies left is w_M = p_M² / (p_M² + p_0²) for this one
// and p_0²/(p_M² + p_0²) for path tracing. A path tracing hit of that shape asks the same root search whether it
// would have found the path (ends x and y, the same chain) and takes p_M = 0 when not, so the two weights sum
// to one for every path, found or not (unbiased whatever roots the search misses). Elsewhere (a diffuse vertex
// next to another, or the eye's neighbour diffuse) light tracing or a connection may make the path, and this
// strategy is not used.
#pragma once
#include "integrators/bdpt_vertex.h"
#include "integrators/manifold_sphere.h"
#include "geometry/scene_queries.h"

namespace pt {
namespace bdpt_detail {

// The strategy follows one chain per vertex: one sphere, and for glass either refraction in and out or the
// reflection off it (a chain of its own: the lobe choice differs). It draws the chain with probability ∝ the
// sphere's solid angle seen from x (1 − cos of the silhouette's half-angle: a far sphere rarely holds a solution
// worth its search), glass's reflection at kGlassReflectionShare of that (it carries F ≈ 4 %).
inline constexpr double kGlassReflectionShare = 0.25;

// Calls visit(sphere index, chain, weight) for every chain through every smooth, non-emitting sphere seen from x.
template <class Visit>
void for_each_chain(const Scene& s, DVec3 x, Visit&& visit) {
  for (uint32_t i = 0; i < s.spheres.size(); ++i) {
    const Material& m = s.materials[s.spheres.material[i]];
    const BsdfFlags flags = bsdf_flags(m);
    if (!only_specular(flags) || s.light_of(s.sphere_begin() + i) >= 0) continue;
    SpecularSphere chain{s.spheres.center[i], s.spheres.radius[i], false, static_cast<double>(m.ior)};
    const DVec3 to_c = chain.center - x;
    const double sin2 = chain.radius * chain.radius / glm::dot(to_c, to_c);
    if (!(sin2 < 1.0)) continue;
    const double solid = sin2 / (1.0 + std::sqrt(1.0 - sin2));  // 1 − cos α, without cancellation
    if (is_transmissive(flags)) {
      chain.refracts = true;
      visit(i, chain, solid);
      chain.refracts = false;
      visit(i, chain, solid * kGlassReflectionShare);
    } else {
      visit(i, chain, solid);
    }
  }
}

struct ChainPick {
  SpecularSphere chain;
  uint32_t sphere = 0;
  float prob = 0.f;
};

// Draws the chain from x with u. False when x sees no smooth sphere.
inline bool pick_chain(const Scene& s, DVec3 x, float u, ChainPick& pick) {
  double total = 0.0;
  for_each_chain(s, x, [&](uint32_t, const SpecularSphere&, double w) { total += w; });
  if (!(total > 0.0)) return false;
  double rest = u * total;
  bool picked = false;
  for_each_chain(s, x, [&](uint32_t i, const SpecularSphere& chain, double w) {
    if (picked || !(w > 0.0)) return;
    pick = {chain, i, static_cast<float>(w / total)};  // the last one keeps rounding's remainder
    if (rest < w) picked = true;
    else rest -= w;
  });
  return true;
}

// The chain through sphere `sphere` (refracting or reflecting) as pick_chain would draw it from x, with the
// probability that it does. False when pick_chain cannot draw it.
inline bool find_chain(const Scene& s, DVec3 x, uint32_t sphere, bool refracts, ChainPick& pick) {
  double total = 0.0, mine = 0.0;
  for_each_chain(s, x, [&](uint32_t i, const SpecularSphere& chain, double w) {
    total += w;
    if (i == sphere && chain.refracts == refracts) mine = w, pick.chain = chain;
  });
  pick.sphere = sphere;
  pick.prob = total > 0.0 ? static_cast<float>(mine / total) : 0.f;
  return pick.prob > 0.f;
}

// A light the strategy samples: a polygon, uniform by area.
inline bool manifold_light(const Light& l) { return l.polygon(); }

// Camera vertex k may be the x of a manifold path: it scatters non-specularly, and no connection strategy can
// make a path that passes through the camera subpath's first k vertices, the vertex before x and the eye's
// neighbour being specular and no two non-specular vertices adjacent (a connection joins two neighbours that are
// both non-specular; light tracing joins the eye's neighbour to the eye).
inline bool manifold_vertex(const Scene& s, const std::vector<BdptVertex>& camera, int k) {
  if (k < 2 || camera[k].kind != VertexKind::Surface || !connectible(s, camera[k])) return false;
  if (!camera[1].delta || !camera[k - 1].delta) return false;
  for (int i = 2; i < k - 1; ++i)
    if (!camera[i].delta && !camera[i - 1].delta) return false;
  return true;
}

// One solution ω of the chain from x to light point y (normal n_y): the chain, its specular weight T as the
// camera walk would have applied it (the material sampled with the chain's lobe forced: a smooth dielectric
// reflects when uc < F), and the densities per solid angle at x of this strategy (p_m; p_choice: of the chain,
// the light and y) and of path tracing (p_0 = pdf_x(ω) × the chain's lobe-choice probabilities). False when the
// material would not scatter along the chain (grazing, total internal reflection) or p_m vanishes. The strategy
// and path tracing's share both read it, so that both weigh a path with the same densities.
struct ManifoldSolution {
  SphereChain ch;
  Rgb T{1.f};
  float p_m = 0.f, p_0 = 0.f;
};
inline bool manifold_solution(const Scene& s, const ChainPick& pick, const BdptVertex& x, DVec3 w, DVec3 y,
                              DVec3 n_y, float p_choice, ManifoldSolution& out) {
  const SpecularSphere& sph = pick.chain;
  const DVec3 xd(x.it.p);
  if (!trace_sphere_chain(sph, xd, w, out.ch)) return false;
  const Material& m = s.materials[s.spheres.material[pick.sphere]];
  float choice = 1.f;
  out.T = Rgb(1.f);
  DVec3 arrive = w;
  for (int e = 0; e < (sph.refracts ? 2 : 1); ++e) {
    const DVec3 p = e == 0 ? out.ch.p1 : out.ch.p2;
    const DVec3 leave = e == 0 && sph.refracts ? glm::normalize(out.ch.p2 - out.ch.p1) : out.ch.out;
    const Frame frame = Frame::from_normal(Vec3((p - sph.center) / sph.radius));
    BsdfSample bs;
    const float uc = sph.refracts ? kOneMinusEpsilon : 0.f;
    if (!bsdf_sample(m, frame.to_local(Vec3(-arrive)), uc, Vec2(0.5f), bs) || !is_specular(bs.flags) ||
        is_transmissive(bs.flags) != sph.refracts || !(bs.pdf > 0.f))
      return false;
    // The sampled direction must be the chain's (float against double: a loose bound).
    if (glm::dot(frame.to_world(bs.wi), Vec3(leave)) < 0.9999f) return false;
    out.T *= bs.f * std::abs(bs.wi.z);
    choice *= bs.pdf;
    arrive = leave;
  }
  if (is_black(out.T)) return false;
  out.p_m = static_cast<float>(p_choice * sphere_chain_area_per_solid_angle(sph, xd, w, y, n_y));
  if (!(out.p_m > 0.f) || !std::isfinite(out.p_m)) return false;
  const Frame frame_x = walk_frame(x, x.wo);
  out.p_0 = bsdf_pdf(material_of(s, x), frame_x.to_local(x.wo), frame_x.to_local(Vec3(w))) * choice;
  return true;
}

// The closest hit along the segment from `from` (skipping `skip`) in direction d must be primitive `prim` at
// about `dist`; fills the hit's interaction.
template <uint32_t F>
bool reaches(const Scene& s, Vec3 from, Vec3 d, uint32_t skip, uint32_t prim, double dist, Interaction& it,
             RayCount& count) {
  ++count.rays;
  const Ray ray{from, d};
  Hit h;
  if (!intersect_scene<F>(s, ray, kInfinity, skip, h) || h.prim != prim) return false;
  if (std::abs(static_cast<double>(h.t) - dist) > 1e-3 * dist) return false;
  it = make_interaction<F>(s, ray, h);
  return true;
}

// Strategy "manifold" at camera vertex x = camera[t − 1] (manifold_vertex): one chain drawn, the sum over its
// solutions, MIS-weighted against path tracing.
template <class Sampler, uint32_t F>
Rgb connect_through_spheres(const Scene& s, const Sampler& rng, const BdptDimensions& dims, const BdptVertex& x,
                            int t, int max_bounces, RayCount& count) {
  const uint32_t bounce = static_cast<uint32_t>(t - 2);
  const DVec3 xd(x.it.p);
  ChainPick pick;
  if (!pick_chain(s, xd, rng.get_1d(BdptDimensions::manifold_chain_choice(bounce)), pick)) return Rgb(0.f);
  const SpecularSphere& sph = pick.chain;
  if ((t - 1) + (sph.refracts ? 2 : 1) > max_bounces) return Rgb(0.f);
  const int li = choose_light(s, rng.get_1d(BdptDimensions::connection_light_choice(bounce)));
  const Light& l = s.lights[li];
  if (!manifold_light(l)) return Rgb(0.f);
  const Vec3 y = sample_polygon_area(s.polygons, l.prim, rng.get_2d(dims.connection_point(bounce)));
  const Vec3 n_y = s.polygons.normal[l.prim];
  const float p_choice = pick.prob * s.light_pmf[li] / l.area;  // of the chain, the light and the point y
  const Material& mx = material_of(s, x);
  const bool smooth = smooth_vertex(x);  // bdpt_vertex.h
  const Frame frame_x = walk_frame(x, x.wo);
  const Vec3 wo_x = frame_x.to_local(x.wo);
  const uint32_t prim = s.sphere_begin() + pick.sphere;
  const SphereChainRoots roots = solve_sphere_chain(sph, xd, DVec3(y));
  Rgb sum(0.f);
  for (int r = 0; r < roots.count; ++r) {
    const Vec3 wf(roots.w[r]);
    ManifoldSolution sol;
    if (!manifold_solution(s, pick, x, roots.w[r], DVec3(y), DVec3(n_y), p_choice, sol)) continue;
    const SphereChain& ch = sol.ch;
    const Rgb Le = area_light_emission(l, n_y, Vec3(-ch.out));
    const Vec3 wf_x = frame_x.to_local(wf);
    const Rgb f = bsdf_eval(mx, wo_x, wf_x);
    if (is_black(Le) || is_black(f)) continue;
    // Visibility, segment by segment, with the scene's own rays.
    Interaction a, b, c;
    if (!reaches<F>(s, leaving_origin(x.it, wf, wf_x.z), wf, skip_on_leave(x.it), prim, glm::length(ch.p1 - xd), a,
                    count))
      continue;
    const Interaction* exit = &a;
    if (sph.refracts) {
      const Vec3 in(glm::normalize(ch.p2 - ch.p1));
      if (!reaches<F>(s, offset_ray_origin(a, in), in, ~0u, prim, glm::length(ch.p2 - ch.p1), b, count)) continue;
      exit = &b;
    }
    const Vec3 out(ch.out);
    if (!reaches<F>(s, offset_ray_origin(*exit, out), out, ~0u, l.prim, glm::length(DVec3(y) - ch.p2), c, count))
      continue;
    const float w_m = sol.p_m * sol.p_m / (sol.p_m * sol.p_m + sol.p_0 * sol.p_0);
    const float cos_x = smooth ? std::abs(wf_x.z) : std::abs(glm::dot(wf, x.it.ng));
    sum += x.beta * f * sol.T * Le * (cos_x * w_m / sol.p_m);
  }
  return sum;
}

// The angle within which path_tracing_share takes a root for the path it was given, at the least.
inline constexpr double kManifoldMatchAngle = 2e-3;

// Path tracing's share p_0²/(p_0² + p_M²) of a path it made by hitting a light at camera vertex t − 1, when the
// manifold strategy could have made the path too; 1 otherwise.
inline float path_tracing_share(const Scene& s, const std::vector<BdptVertex>& camera, int t) {
  const BdptVertex& yv = camera[t - 1];
  if (yv.kind != VertexKind::Surface || yv.light < 0 || t < 5) return 1.f;
  const Light& l = s.lights[yv.light];
  if (!manifold_light(l)) return 1.f;
  const uint32_t exit_prim = camera[t - 2].it.prim;
  if (!camera[t - 2].delta || !s.is_sphere(exit_prim)) return 1.f;
  const uint32_t i = exit_prim - s.sphere_begin();
  // Two vertices on the sphere are the way in and out (a reflection off a convex sphere cannot meet it again).
  const bool through = camera[t - 3].it.prim == exit_prim;
  if (through && !camera[t - 3].delta) return 1.f;
  const int k = t - 2 - (through ? 2 : 1);  // x's index
  if (camera[k].delta || !manifold_vertex(s, camera, k)) return 1.f;
  const BdptVertex& x = camera[k];
  const DVec3 xd(x.it.p);
  ChainPick pick;
  if (!find_chain(s, xd, i, through, pick)) return 1.f;
  const DVec3 to_entry = DVec3(camera[k + 1].it.p) - xd;
  const double entry_dist = glm::length(to_entry);
  if (!(entry_dist > 0.0)) return 1.f;
  const DVec3 w0 = to_entry / entry_dist;
  const SphereChainRoots roots = solve_sphere_chain(pick.chain, xd, DVec3(yv.it.p));
  // The path's own direction is known only to the float rounding of x and of the entry point, which a nearby x
  // (the caustic at the sphere's foot) turns into angles of 1e-4 and more; near a fold the root for the path's
  // float y moves further still, or vanishes: rounding put y just outside the fold, where the search finds a
  // near root only. So the nearest root or near root stands for the path if it lies within that uncertainty
  // and the next one, if any, lies well farther. A near root's path is the float image of exact paths just
  // inside the fold, which the strategy makes with nearly all the weight: taking its density keeps path tracing
  // from counting them a second time (weight 1 there had made the brightest remaining fireflies).
  const double tolerance = std::max(kManifoldMatchAngle,
                                    4.0 * double(glm::length(x.it.p_error) + glm::length(camera[k + 1].it.p_error)) /
                                        entry_dist);
  const DVec3* nearest = nullptr;
  double best = kInfinity, second = kInfinity;
  const auto consider = [&](const DVec3& w) {
    const double angle = glm::length(w - w0);  // chord ≈ angle for the small angles that matter
    if (angle < best) second = best, best = angle, nearest = &w;
    else second = std::min(second, angle);
  };
  for (int r = 0; r < roots.count; ++r) consider(roots.w[r]);
  for (int r = 0; r < roots.near_count; ++r) consider(roots.near[r]);
  if (!nearest || best > tolerance || second < 2.0 * best) return 1.f;
  ManifoldSolution sol;
  if (!manifold_solution(s, pick, x, *nearest, DVec3(yv.it.p), DVec3(s.polygons.normal[l.prim]),
                         pick.prob * s.light_pmf[yv.light] / l.area, sol))
    return 1.f;
  return sol.p_0 * sol.p_0 / (sol.p_0 * sol.p_0 + sol.p_m * sol.p_m);
}

}  // namespace bdpt_detail
}  // namespace pt
