// The bidirectional estimator's kernel (integrators/bdpt.h): subpath generation, the connection strategies and
// their MIS weights. Notation after pbrt-v3 §16.3 (GenerateCameraSubpath, GenerateLightSubpath, RandomWalk,
// ConnectBDPT, MISWeight); bdpt.cpp instantiates it per sampler.
#pragma once
#include "integrators/bdpt.h"

#include "geometry/scene_queries.h"
#include "integrators/bdpt_manifold.h"
#include "integrators/direct_light.h"
#include "sampling/sample_dimensions.h"

namespace pt {
namespace bdpt_detail {

using D = BdptDimensions;

struct Options {
  Options(const Scene& s, const RenderSettings& r)
      : max_bounces(std::min(r.max_bounces, kMaxBdptBounces)),  // validated; the clamp guards memory
        // A directional light starts its paths on the infinite lights' disks: the same case as the sun.
        rr_depth(roulette_depth(r.russian_roulette_depth, true, !s.infinite_lights.empty() || s.directional_lights)),
        only_s(r.bdpt_only.s),
        only_t(r.bdpt_only.t),
        has_lights(!s.lights.empty()),
        // It connects to a light: none without one (choose_light has nothing to choose from).
        manifold(r.bdpt_manifold && s.features.spheres && only_s < 0 && has_lights),
        pixel_angle(pixel_angle_of(s.camera)),
        dims(s.camera.thin_lens()) {}
  int max_bounces, rr_depth, only_s, only_t;
  bool has_lights;
  bool manifold;      // the manifold strategy through smooth spheres (bdpt_manifold.h)
  float pixel_angle;  // for the camera subpath's ray cone (material_at.h), as the path tracer's
  BdptDimensions dims;  // the sampler's dimensions (sampling/sample_dimensions.h): shifted by a thin lens
  template <class Sampler>
  float cone_spread(const Sampler& rng) const {
    return ray_cone_spread(pixel_angle, rng.sample_index());
  }
};

// Splitting the camera subpath at its first vertex when that vertex has two Dirac lobes only (smooth glass:
// reflection with probability F, refraction with 1 − F, bsdf.h's contract for specular samples). The walk picks
// one lobe; bdpt_sample then also follows the other and weights each branch by its lobe's probability instead
// of dividing by it: the lobe choice is integrated exactly (two strata of the lobe-choice dimension, on each of
// which the path is constant). Without it the glass ball's outside reflection of the light and of the floor's
// caustic (a few per cent of the camera samples carrying 1/F ≈ 25× weight) was a fifth of bdpt's error on
// cornell-spheres. Every strategy that makes such a path samples this vertex on the camera side, so its lobe
// probability is a common factor of their densities and the MIS weights are unchanged.
struct FirstVertexSplit {
  float forced_uc = -1.f;  // in: ≥ 0 replaces the lobe-choice value at the first vertex (the second branch)
  bool active = false;     // out: the first vertex has two Dirac lobes and the walk went on from it
  float taken_pdf = 1.f;   // out: the probability of the lobe the walk took
  float other_uc = 0.f;    // out: a lobe-choice value that takes the other lobe
  float other_pdf = 0.f;   // out: that lobe's probability (taken_pdf + other_pdf = 1)
};

// At a vertex whose lobes are all Dirac, where `taken` was sampled: finds the other lobe at the two ends of the
// lobe-choice dimension (which one the BSDF maps where is its own business). No split when there is none
// (total internal reflection) or the two probabilities do not make up the whole.
template <MaterialSet kM>
void find_other_lobe(const Material& m, Vec3 wo, Vec2 u, const BsdfSample& taken, FirstVertexSplit& split) {
  for (const float uc : {0.f, kOneMinusEpsilon}) {
    BsdfSample other;
    if (!bsdf_sample<kM>(m, wo, uc, u, other) || !is_specular(other.flags) || other.flags == taken.flags ||
        !(other.pdf > 0.f) || std::abs(taken.pdf + other.pdf - 1.f) > 1e-4f)
      continue;
    split.active = true;
    split.taken_pdf = taken.pdf;
    split.other_uc = uc;
    split.other_pdf = other.pdf;
    return;
  }
}

// The MIS weights' ratio recursion (pbrt-v3 MISWeight, §16.3.4, power heuristic: w = p_s² / Σ_i p_i²). The
// densities of the other strategies follow from the current one's by walking out from the connection, each step
// multiplying by pdf_rev/pdf_fwd of one vertex; strategies that would have to connect at a specular vertex
// cannot produce the path and are left out.
//
// Specular chains. Between non-specular vertices a (light side) and b (camera side) joined through specular
// vertices, the ratio of the densities of the strategies on either side of the chain is
//   A_a p⊥_L(a → a+1) / (B_b p⊥_C(b → b−1)),
// A and B the area densities made by the light and the camera walk, p⊥ the directional densities per projected
// solid angle at the chain's ends: the geometry terms of the chain's segments appear on both sides and cancel,
// as do the specular lobes' Dirac densities (symmetric per projected solid angle; the η² of refraction cancels
// on entering and leaving). pbrt-v3's recursion keeps the area densities A_{a+1} and B_{b−1} instead, which
// multiplies that ratio by G(a, a+1)/G(b−1, b): the weights still sum to one (unbiased), but on the glass
// ball's caustic seen directly (light → glass → glass → floor → eye) they gave path tracing (s = 0) nearly all
// the weight although light tracing (t = 1) samples it far better. Dividing those two densities by their
// segment's geometry term restores the ratio (Mitsuba 0.5 converts them to projected solid angle likewise).
struct RatioStep {
  float ratio;  // pdf_rev/pdf_fwd of the vertex (zero densities taken as 1: pbrt-v3's remap0)
  bool counts;  // the strategy that connects just before this vertex can make the path
};
inline float remap0(float f) { return f != 0.f ? f : 1.f; }
// A specular vertex v's area density made by its non-specular neighbour n, divided by G(n, v): the density per
// projected solid angle at n (the chains above).
inline float projected(float pdf, const BdptVertex& v, const BdptVertex& n) {
  const float g = geometry_term(v, n);
  return pdf > 0.f && g > 0.f ? pdf / g : pdf;
}
// Camera vertex i, 0 < i < size − 1 (the eye is never a step).
inline RatioStep camera_step(const std::vector<BdptVertex>& camera, int i) {
  float rev = camera[i].pdf_rev, fwd = camera[i].pdf_fwd;
  if (camera[i].delta) {  // not the connection's end, which mis_weight marks non-specular
    if (!camera[i + 1].delta) rev = projected(rev, camera[i], camera[i + 1]);
    if (!camera[i - 1].delta) fwd = projected(fwd, camera[i], camera[i - 1]);
  }
  return {remap0(rev) / remap0(fwd), !camera[i].delta && !camera[i - 1].delta};
}
// Light vertex i, 0 ≤ i < size − 1 (a punctual light, vertex 0, is a Dirac: no camera path reaches it).
inline RatioStep light_step(const std::vector<BdptVertex>& light, int i) {
  float rev = light[i].pdf_rev, fwd = light[i].pdf_fwd;
  if (light[i].delta) {
    if (!light[i - 1].delta) fwd = projected(fwd, light[i], light[i - 1]);
    if (!light[i + 1].delta) rev = projected(rev, light[i], light[i + 1]);
  }
  return {remap0(rev) / remap0(fwd), !light[i].delta && !light[i].delta_light && !(i > 0 && light[i - 1].delta)};
}

// The recursion's sums over the vertices no strategy edits, once per subpath instead of once per strategy. A
// strategy edits only its two end vertices and their predecessors (new reverse densities, the ends made
// non-specular), so for a strategy with t camera vertices the camera side of the sum is
//   Σ_{i ≤ t−1, counts} (ρ_{t−1} ρ_{t−2} · Π_{j=i..t−3} ρ_j)² = [its own two steps] + (ρ_{t−1} ρ_{t−2})² S_{t−3},
//   S_k = Σ_{i ≤ k, counts} Π_{j=i..k} ρ_j² = ρ_k² (counts_k + S_{k−1}),
// ρ_j the step ratios of the subpath as walked (the same for every strategy that leaves j three or more
// vertices from its end); the light side likewise. Kept in double: a product of ratios of area densities can
// leave float's range where the strategy's own two steps would bring it back. Georgiev's recursive MIS for
// vertex connection and merging ("Implementing Vertex Connection and Merging", 2012) carries the same sums along
// the walk. Call once a subpath is complete (its densities final).
template <class Step>
void mis_prefix_sums(std::vector<BdptVertex>& path, int first, const Step& step) {
  double sum = 0.0;
  for (int k = first; k + 1 < static_cast<int>(path.size()); ++k) {
    const RatioStep st = step(path, k);
    sum = static_cast<double>(st.ratio) * st.ratio * ((st.counts ? 1.0 : 0.0) + sum);
    path[k].mis_prefix = sum;
  }
}
inline void camera_mis_prefix(std::vector<BdptVertex>& camera) { mis_prefix_sums(camera, 1, camera_step); }
inline void light_mis_prefix(std::vector<BdptVertex>& light) { mis_prefix_sums(light, 0, light_step); }

// Continues a subpath from its last vertex along `ray` (pbrt-v3 RandomWalk) until max_vertices, a miss, an
// absorbed sample or roulette. pdf_dir: solid-angle density of ray.d at the last vertex. Vertex i's textured
// material goes to materials[i] (max_vertices slots), looked up over a ray cone of this spread (the camera
// subpath's as the path tracer's; 0, the finest texels, on the light subpath). On the camera subpath
// a miss adds a vertex at infinity when the scene has infinite lights; `features` (camera subpath only; may be
// null) receives the sample's feature buffers (features.h); `split` (camera subpath only; may be null) is the
// first vertex's split, FirstVertexSplit. Returns false if cancelled.
template <class Sampler, uint32_t F>
bool random_walk(const Scene& s, const Options& o, const Sampler& rng, Ray ray, uint32_t skip, Rgb beta,
                 float pdf_dir, bool light_subpath, std::vector<BdptVertex>& path, size_t max_vertices,
                 MaterialScratch* materials, float cone_spread, PixelFeatures* features, FirstVertexSplit* split,
                 RayCount& count, const std::atomic<bool>* cancel) {
  constexpr MaterialSet kM = (F & kFeatureGeneralMaterials) != 0 ? MaterialSet::Any : MaterialSet::Lambert;
  const float beta_scale = max_component(beta);  // roulette judges the throughput relative to the start
  float eta_scale = 1.f;
  FeatureTrace feature_trace{features};
  Rgb chain_emission(0.f);  // emission the camera subpath found through its specular chain (features.h)
  float cone_width = 0.f;
  for (uint32_t bounce = 0;; ++bounce) {
    if (path.size() >= max_vertices) return true;
    if (bounce % kCancelPollBounces == kCancelPollBounces - 1 && cancel && cancel->load(std::memory_order_relaxed))
      return false;
    Hit h;
    ++count.rays;
    const size_t prev = path.size() - 1;
    if (!intersect_scene<F>(s, ray, kInfinity, skip, h)) {
      if (!light_subpath && !s.infinite_lights.empty()) {
        BdptVertex v;
        v.kind = VertexKind::Light;
        v.infinite = true;
        v.it.p = path[prev].it.p;
        v.it.ng = -ray.d;
        v.wo = -ray.d;
        v.beta = beta;
        v.pdf_fwd = pdf_dir;
        path.push_back(v);
        // Seen directly or through specular vertices only: no other strategy makes this path, its weight is 1.
        if (feature_trace.out) [[unlikely]]
          feature_trace.escaped(chain_emission + beta * emitted(s, v));
      }
      return true;
    }
    // Made in place, not copied in (this copy and with_strategy_edits's per weight: 2 % of bdpt's time).
    BdptVertex& v = path.emplace_back();
    v.it = make_interaction<F>(s, ray, h);
    cone_width += cone_spread * h.t;
    // May bend it.ns: by a normal map read at its finest level on both walks (material_at.h, NormalLookup).
    v.material = &material_at<kM>(s, v.it, ray.d, cone_width, materials[prev + 1], NormalLookup::Finest);
    v.wo = -ray.d;
    v.beta = beta;
    v.light = s.light_of(v.it.prim);
    v.pdf_fwd = to_area_density(pdf_dir, path[prev], v);
    const Material& m = *v.material;
    if (feature_trace.out) [[unlikely]] {
      if (v.emits()) chain_emission += beta * emitted(s, v);
      feature_trace.at_vertex<kM>(static_cast<int>(bounce), ray.o, v.it, v.wo, m, path.size() >= max_vertices,
                                  chain_emission);
    }
    if (path.size() >= max_vertices) return true;

    const size_t cur = prev + 1;
    const bool smooth = smooth_vertex(v);  // bdpt_vertex.h: the shading frame and the light subpath's adjoint
    const Frame frame = walk_frame(v, v.wo);
    const Vec3 wo = frame.to_local(v.wo);
    const bool first_split = split && bounce == 0;
    float uc = rng.get_1d(light_subpath ? D::light_lobe(bounce) : D::camera_lobe(bounce));
    if (first_split && split->forced_uc >= 0.f) uc = split->forced_uc;
    const Vec2 u = rng.get_2d(light_subpath ? o.dims.light_direction(bounce) : o.dims.camera_direction(bounce));
    BsdfSample bs;
    const TransportMode mode = light_subpath ? TransportMode::Importance : TransportMode::Radiance;
    // The light walk's defensive mixture at a smooth vertex (bdpt_vertex.h): the lobe-choice number picks the
    // uniform direction below kLightWalkUniform and is stretched over the BSDF's choice above it.
    const bool mixes = light_subpath && smooth && light_walk_mixes(v, m);
    if (mixes && uc < kLightWalkUniform) {
      bs.wi = sample_uniform_sphere(u);
      bs.flags = BsdfFlags::Diffuse | (bs.wi.z * wo.z > 0.f ? BsdfFlags::Reflection : BsdfFlags::Transmission);
      bs.pdf = light_walk_pdf(bsdf_pdf<kM>(m, wo, bs.wi));
      if (bs.wi.z == 0.f) return true;
    } else {
      if (mixes) uc = std::min((uc - kLightWalkUniform) / (1.f - kLightWalkUniform), kOneMinusEpsilon);
      if (!bsdf_sample<kM>(m, wo, uc, u, bs, mode) || !(bs.pdf > 0.f) || bs.wi.z == 0.f) return true;
      if (mixes) bs.pdf = is_specular(bs.flags) ? (1.f - kLightWalkUniform) * bs.pdf : light_walk_pdf(bs.pdf);
    }
    if (first_split && split->forced_uc < 0.f && is_specular(bs.flags) && only_specular(bsdf_flags<kM>(m)))
      find_other_lobe<kM>(m, wo, u, bs, *split);
    Rgb f = bs.f;
    float pdf_rev = 0.f;
    const Vec3 wi = frame.to_world(bs.wi);
    if (is_specular(bs.flags)) {
      // From the light side bsdf_sample gave importance's value: no 1/η² on refraction (Veach 1997 §5.2).
      path[cur].delta = true;
      pdf_dir = 0.f;
      if (feature_trace.out) [[unlikely]]
        feature_trace.through_specular(bs);
      if (smooth && light_subpath) {
        // The adjoint's correction |wo·n_s| |wi·n_g| / (|wo·n_g| |wi·n_s|) (a Dirac lobe is not evaluated again).
        const float den = std::abs(glm::dot(v.wo, v.it.ng)) * std::abs(bs.wi.z);
        f *= den > 0.f ? std::abs(wo.z) * std::abs(glm::dot(wi, v.it.ng)) / den : 0.f;
      }
    } else if (smooth) {
      // The reverse walk would arrive from wi: its frame is the one bent for wi (walk_frame).
      const Frame back = walk_frame(v, wi);
      const Vec3 wi_b = back.to_local(wi), wo_b = back.to_local(v.wo);
      pdf_dir = bs.pdf;
      pdf_rev = bsdf_pdf<kM>(m, wi_b, wo_b);
      // The camera walk's reverse density is the light walk's, arriving from wi: its mixture.
      if (!light_subpath && light_walk_mixes(v, m)) pdf_rev = light_walk_pdf(pdf_rev);
      if (light_subpath) {
        // f_sn(wi, wo)·|wi·n_g| / |wi·n_s|, so that the product below is f_sn·|wi·n_g|/pdf.
        const float den = std::abs(glm::dot(v.wo, v.it.ng)) * std::abs(bs.wi.z);
        f = den > 0.f ? bsdf_eval<kM>(m, wi_b, wo_b) * (std::abs(wo_b.z) * std::abs(glm::dot(wi, v.it.ng)) / den)
                      : Rgb(0.f);
      }
    } else {
      // Light subpath: the light arrives from wo and leaves along wi; the adjoint BSDF is the transpose.
      if (light_subpath) f = bsdf_eval<kM>(m, bs.wi, wo);
      pdf_dir = bs.pdf;
      pdf_rev = bsdf_pdf<kM>(m, bs.wi, wo);
    }
    beta *= f * (std::abs(bs.wi.z) / bs.pdf);
    path[prev].pdf_rev = to_area_density(pdf_rev, path[cur], path[prev]);
    if (!light_subpath && is_transmissive(bs.flags)) eta_scale *= sqr(bs.eta);
    if (roulette_applies(static_cast<int>(bounce), o.rr_depth)) {  // russian_roulette.h
      const uint32_t dim = light_subpath ? D::light_roulette(bounce) : D::camera_roulette(bounce);
      if (!survives_roulette(beta, max_component(beta) * eta_scale / beta_scale, rng.get_1d(dim))) return true;
    }
    if (is_black(beta) || !is_finite(beta)) return true;
    ray = {leaving_origin(path[cur].it, wi, bs.wi.z), wi};
    skip = skip_on_leave(path[cur].it);
  }
}

// The camera subpath: the eye, then up to max_bounces + 1 surface vertices (the last only to find emission).
template <class Sampler, uint32_t F>
bool camera_subpath(const Scene& s, const Options& o, const Sampler& rng, const Ray& ray,
                    std::vector<BdptVertex>& path, std::vector<MaterialScratch>& materials,
                    PixelFeatures* features, FirstVertexSplit& split, RayCount& count,
                    const std::atomic<bool>* cancel) {
  path.clear();
  const size_t max_vertices = static_cast<size_t>(o.max_bounces) + 2;
  if (materials.size() < max_vertices) materials.resize(max_vertices);
  BdptVertex eye;
  eye.kind = VertexKind::Camera;
  eye.it.p = ray.o;
  eye.it.ng = Vec3(0.f);
  path.push_back(eye);
  if (!random_walk<Sampler, F>(s, o, rng, ray, ~0u, Rgb(1.f), s.camera.direction_pdf(ray.o, ray.d), false, path,
                               max_vertices, materials.data(), o.cone_spread(rng), features, &split, count, cancel))
    return false;
  camera_mis_prefix(path);
  return true;
}

// The light subpath: a point on a light chosen ∝ power, then up to max_bounces surface vertices.
template <class Sampler, uint32_t F>
bool light_subpath(const Scene& s, const Options& o, const Sampler& rng, std::vector<BdptVertex>& path,
                   std::vector<MaterialScratch>& materials, RayCount& count, const std::atomic<bool>* cancel) {
  path.clear();
  if (!o.has_lights) return true;
  const size_t max_vertices = static_cast<size_t>(o.max_bounces) + 1;
  if (materials.size() < max_vertices) materials.resize(max_vertices);
  const int li = choose_light(s, rng.get_1d(D::kLightChoice));
  const Light& l = s.lights[li];
  const float pmf = s.light_pmf[li];
  EmissionSample es;
  if (!(pmf > 0.f) || !sample_emission<F>(s, l, rng.get_2d(D::kEmissionPoint), rng.get_2d(D::kEmissionDirection), es))
    return true;
  // An emission texture, as next-event estimation reads it at a sampled point (light_sampling.h: sample_li).
  if (l.emission_map.texture) [[unlikely]] es.Le *= emission_texel(l, polygon_uv_at(s, l.prim, es.p));
  if (is_black(es.Le)) return true;
  BdptVertex v;
  v.kind = VertexKind::Light;
  v.infinite = l.infinite() || l.kind == LightKind::Directional;
  v.delta_light = l.delta();
  v.light = li;
  v.it.p = es.p;
  v.it.p_error = es.p_error;
  v.it.ng = es.n;
  v.it.prim = l.prim;
  v.it.planar = !l.sphere();
  v.beta = es.Le;
  v.pdf_fwd = es.pdf_pos * pmf;
  path.push_back(v);
  const Rgb beta = es.Le * (std::abs(glm::dot(es.n, es.d)) / (pmf * es.pdf_pos * es.pdf_dir));
  const Ray ray{v.infinite ? es.p : offset_ray_origin(v.it, es.d), es.d};
  const uint32_t skip = v.infinite ? ~0u : skip_on_leave(v.it);
  if (!random_walk<Sampler, F>(s, o, rng, ray, skip, beta, es.pdf_dir, true, path, max_vertices,
                               materials.data(), 0.f, nullptr, nullptr, count, cancel))
    return false;
  if (v.infinite) {
    // At infinity the origin density is over directions and the first vertex's over the disk's area
    // (pbrt-v3 §16.3.2).
    if (path.size() > 1) {
      path[1].pdf_fwd = es.pdf_pos;
      if (path[1].on_surface()) path[1].pdf_fwd *= std::abs(glm::dot(es.d, path[1].it.ng));
    }
    path[0].pdf_fwd = pdf_light_origin(s, path[0]);
  }
  light_mis_prefix(path);
  return true;
}

// Restores a value when it goes out of scope (pbrt-v3 ScopedAssignment): the MIS weight edits the subpaths'
// end vertices for the strategy being weighted.
template <class T>
class Scoped {
 public:
  Scoped() = default;
  void set(T* target, T value) {
    target_ = target;
    saved_ = *target;
    *target = value;
  }
  ~Scoped() {
    if (target_) *target_ = saved_;
  }
  Scoped(const Scoped&) = delete;
  Scoped& operator=(const Scoped&) = delete;

 private:
  T* target_ = nullptr;
  T saved_{};
};

// Sets the reverse densities of strategy (s, t)'s end vertices and their predecessors as the other subpath
// would have made them and marks the ends non-specular, then calls weigh(pt, qs) with the two end vertices
// (either may be null); the edits are undone on return. `sampled` is the end vertex the strategy sampled
// afresh (s = 1: the light point; t = 1: the eye), which stands in for the subpath's first vertex: it is the
// end itself, edited and restored like the others (not copied per weight); the subpaths stay as they are.
template <class Weigh>
float with_strategy_edits(const Scene& s, std::vector<BdptVertex>& light, std::vector<BdptVertex>& camera,
                          BdptVertex& sampled, int ns, int nt, const Weigh& weigh) {
  BdptVertex* qs = ns == 1 ? &sampled : ns > 0 ? &light[ns - 1] : nullptr;
  BdptVertex* pt = nt == 1 ? &sampled : nt > 0 ? &camera[nt - 1] : nullptr;
  BdptVertex* qs_minus = ns > 1 ? &light[ns - 2] : nullptr;
  BdptVertex* pt_minus = nt > 1 ? &camera[nt - 2] : nullptr;
  Scoped<bool> a2, a3;
  if (pt) a2.set(&pt->delta, false);
  if (qs) a3.set(&qs->delta, false);
  // Each segment's unit direction and squared length once: the connection's, and each end's to its predecessor.
  const Link p_to_q = pt && qs ? link(*pt, *qs) : Link{}, q_to_p = reversed(p_to_q);
  const Link p_to_pm = pt_minus ? link(*pt, *pt_minus) : Link{}, q_to_qm = qs_minus ? link(*qs, *qs_minus) : Link{};
  Scoped<float> a4, a5, a6, a7;
  // The light walk goes on from qs to pt and from pt to pt_minus; the camera walk from pt to qs and on to qs_minus.
  if (pt) a4.set(&pt->pdf_rev, ns > 0 ? pdf_at(s, *qs, &q_to_qm, q_to_p, *pt, true) : pdf_light_origin(s, *pt));
  if (pt_minus)
    a5.set(&pt_minus->pdf_rev,
           ns > 0 ? pdf_at(s, *pt, &p_to_q, p_to_pm, *pt_minus, true) : pdf_light(s, *pt, p_to_pm, *pt_minus));
  if (qs) a6.set(&qs->pdf_rev, pdf_at(s, *pt, &p_to_pm, p_to_q, *qs, false));
  if (qs_minus) a7.set(&qs_minus->pdf_rev, pdf_at(s, *qs, &q_to_p, q_to_qm, *qs_minus, false));
  return weigh(static_cast<const BdptVertex*>(pt), static_cast<const BdptVertex*>(qs));
}

// The steps of a strategy's own end vertices (non-specular for it): pt = camera[nt − 1], t ≥ 2, and qs =
// light[ns − 1], s ≥ 1 (for s = 1 the sampled light point).
inline RatioStep camera_end_step(const std::vector<BdptVertex>& camera, const BdptVertex& pt, int nt) {
  return {remap0(pt.pdf_rev) / remap0(pt.pdf_fwd), !camera[nt - 2].delta};
}
inline RatioStep light_end_step(const std::vector<BdptVertex>& light, const BdptVertex& qs, int ns) {
  return {remap0(qs.pdf_rev) / remap0(qs.pdf_fwd), !qs.delta_light && !(ns > 1 && light[ns - 2].delta)};
}

// The power-heuristic weight of strategy (s, t) for the path it made: the strategy's own end vertices and
// their predecessors stepped through, the rest of each subpath from its mis_prefix (camera_mis_prefix and
// light_mis_prefix must have run on both subpaths).
inline float mis_weight(const Scene& s, std::vector<BdptVertex>& light, std::vector<BdptVertex>& camera,
                        BdptVertex& sampled, int ns, int nt) {
  if (ns + nt == 2) return 1.f;
  return with_strategy_edits(s, light, camera, sampled, ns, nt, [&](const BdptVertex* pt, const BdptVertex* qs) {
    double sum = 0.0;
    float r = 1.f;
    const auto add = [&](RatioStep step) {
      r *= step.ratio;
      if (step.counts) sum += r * r;
    };
    if (nt >= 2) add(camera_end_step(camera, *pt, nt));
    if (nt >= 3) add(camera_step(camera, nt - 2));
    if (nt >= 4) sum += static_cast<double>(r) * r * camera[nt - 3].mis_prefix;
    r = 1.f;
    if (ns >= 1) add(light_end_step(light, *qs, ns));
    if (ns >= 2) add(light_step(light, ns - 2));
    if (ns >= 3) sum += static_cast<double>(r) * r * light[ns - 3].mis_prefix;
    return static_cast<float>(1.0 / (1.0 + sum));
  });
}

// The same weight by walking both subpaths vertex by vertex (pbrt-v3's form, O(s + t) per strategy): the
// reference the tests hold mis_weight to.
inline float mis_weight_by_walking(const Scene& s, std::vector<BdptVertex>& light, std::vector<BdptVertex>& camera,
                                   BdptVertex& sampled, int ns, int nt) {
  if (ns + nt == 2) return 1.f;
  return with_strategy_edits(s, light, camera, sampled, ns, nt, [&](const BdptVertex* pt, const BdptVertex* qs) {
    float sum = 0.f, r = 1.f;
    const auto add = [&](RatioStep step) {
      r *= step.ratio;
      if (step.counts) sum += r * r;
    };
    if (nt >= 2) add(camera_end_step(camera, *pt, nt));
    for (int i = nt - 2; i > 0; --i) add(camera_step(camera, i));
    r = 1.f;
    if (ns >= 1) add(light_end_step(light, *qs, ns));
    for (int i = ns - 2; i >= 0; --i) add(light_step(light, i));
    return 1.f / (1.f + sum);
  });
}

// The shadow ray between two vertices (neither at infinity): from a's surface towards b's, both ends pushed off
// their surfaces by their rounding bounds; the planar primitives they lie on are skipped.
template <uint32_t F>
bool unoccluded(const Scene& s, const BdptVertex& a, const BdptVertex& b, RayCount& count) {
  ++count.rays;
  const Vec3 dir = b.it.p - a.it.p;
  const Vec3 from = a.kind == VertexKind::Camera ? a.it.p : offset_ray_origin(a.it, dir);
  const Vec3 to = b.kind == VertexKind::Camera ? b.it.p : offset_ray_origin(b.it, -dir);
  const Vec3 d = to - from;
  const float dist = glm::length(d);
  if (!(dist > 0.f)) return false;
  const uint32_t skip_a = a.kind == VertexKind::Camera ? ~0u : skip_on_leave(a.it);
  const uint32_t skip_b = b.kind == VertexKind::Camera ? ~0u : skip_on_leave(b.it);
  // The shortening guards against geometry coplanar with a surface at b; the eye lies on no surface. It is
  // relative, so a long ray loses dist × 2^-12 at its end: towards the eye, that hid the wall right behind
  // the camera from light vertices inside the stress matrix's huge spheres (radius 1e5 × the room: 49 units of
  // a 2e5-long ray), whose splats then passed through it (bdpt 1.6e-4 high in the huge-sphere furnace room).
  const float t_max = b.kind == VertexKind::Camera ? dist : dist * kShadowRayShorten;
  return !occluded_scene<F>(s, {from, d / dist}, t_max, skip_a, skip_b);
}

// Strategy s = 1: a light sampled from camera vertex pt (its index t − 1; bounce t − 2). Fills `sampled`.
template <class Sampler, uint32_t F>
Rgb connect_light_sample(const Scene& s, const Options& o, const Sampler& rng, const BdptVertex& pt, int t,
                         BdptVertex& sampled, RayCount& count) {
  const uint32_t bounce = static_cast<uint32_t>(t - 2);
  const int li = choose_light(s, rng.get_1d(D::connection_light_choice(bounce)));
  const Light& l = s.lights[li];
  const float pmf = s.light_pmf[li];
  const Vec2 u = rng.get_2d(o.dims.connection_point(bounce));
  sampled = BdptVertex{};
  sampled.kind = VertexKind::Light;
  sampled.light = li;
  Vec3 wi;
  if (l.infinite()) {
    Rgb Le;
    float pdf;
    if (!sample_infinite_light_direction(s, l, u, wi, Le, pdf) || is_black(Le)) return Rgb(0.f);
    sampled.infinite = true;
    sampled.it.ng = -wi;
    sampled.beta = Le / (pdf * pmf);
  } else {
    // An area light's point, or a punctual light's Dirac (pdf 1, Le the irradiance's factor: light_sampling.h).
    LightSample ls;
    if (!sample_li<F>(s, l, {pt.it.p, pt.it.ng, pt.it.prim}, u, ls, false) || is_black(ls.Le)) return Rgb(0.f);
    wi = ls.wi;
    sampled.delta_light = l.delta();
    if (l.kind == LightKind::Directional) {
      sampled.infinite = true;
      sampled.it.ng = -wi;
    } else {
      sampled.it.p = ls.p;
      sampled.it.ng = l.delta() ? -wi : area_light_normal(s, l, ls.p);
      sampled.it.prim = l.prim;
    }
    sampled.beta = ls.Le / (ls.pdf * pmf);
  }
  sampled.pdf_fwd = pdf_light_origin(s, sampled);
  const bool smooth = smooth_vertex(pt);
  const Frame frame = walk_frame(pt, pt.wo);
  const Vec3 wi_local = frame.to_local(wi);
  const Rgb f = bsdf_eval(material_of(s, pt), frame.to_local(pt.wo), wi_local);
  const Rgb L = pt.beta * f * sampled.beta * (smooth ? std::abs(wi_local.z) : std::abs(glm::dot(wi, pt.it.ng)));
  if (is_black(L)) return L;
  // The shadow ray as the path tracer casts it: the light's own primitive is skipped (a sphere light's sampled
  // point is on the side facing the receiver), and a smooth receiver leaves on its shading frame's side.
  ++count.rays;
  const ShadowSegment seg = smooth ? shadow_segment(pt.it, wi, sampled.it.p, sampled.infinite, wi_local.z < 0.f)
                                   : shadow_segment(pt.it, wi, sampled.it.p, sampled.infinite);  // direct_light.h
  if (!(seg.t_max > 0.f) || occluded_scene<F>(s, seg.ray, seg.t_max, skip_on_leave(pt.it), l.prim)) return Rgb(0.f);
  return L;
}

// Strategy t = 1: light vertex qs joined to the eye, or to a point of a thin lens (uniform over it; one point
// per sample, shared by the light subpath's vertices). Fills `sampled` (the eye) and the pixel it lands on.
template <class Sampler, uint32_t F>
Rgb connect_eye(const Scene& s, const Sampler& rng, const BdptVertex& qs, BdptVertex& sampled, uint32_t& pixel,
                RayCount& count) {
  const Camera& cam = s.camera;
  const Vec3 eye = cam.thin_lens() ? cam.lens_point(rng.get_2d(BdptDimensions::kEyeLens)) : cam.origin;
  const Vec3 d = qs.it.p - eye;
  const float dist2 = glm::dot(d, d);
  if (!(dist2 > 0.f)) return Rgb(0.f);
  const Vec3 w = d / std::sqrt(dist2);
  float x, y;
  if (!cam.raster_of(eye, w, x, y)) return Rgb(0.f);
  sampled = BdptVertex{};
  sampled.kind = VertexKind::Camera;
  sampled.it.p = eye;
  sampled.it.ng = Vec3(0.f);
  // We·cos θ at the eye over the density of the eye as seen from qs (per solid angle: dist²/cos at a lens of
  // unit area), pbrt-v3 PerspectiveCamera::Sample_Wi; with a thin lens the lens area cancels (scene/camera.h).
  sampled.beta = Rgb(cam.importance_cos(w) / dist2);
  const Rgb L = qs.beta * vertex_f(s, qs, sampled, true) * sampled.beta * std::abs(glm::dot(w, qs.it.ng));
  if (is_black(L) || !unoccluded<F>(s, qs, sampled, count)) return Rgb(0.f);
  pixel = static_cast<uint32_t>(std::min(static_cast<int>(y), cam.height - 1)) * static_cast<uint32_t>(cam.width) +
          static_cast<uint32_t>(std::min(static_cast<int>(x), cam.width - 1));
  return L;
}

// Paths on which every vertex between the eye and the light is specular (E S+ L: the light in the mirror ball,
// through the glass ball, behind the glass's internal reflections). Every edge of such a path touches a Dirac
// vertex, so no connection, light tracing or manifold search makes it: the camera walk's hit (s = 0) is its only
// estimator, with weight 1. A walk picks one Fresnel lobe per glass vertex, so it finds the light behind an
// internal reflection with probability F ≈ 4 % and a weight of 1: a pixel's light-coloured firefly (Le/spp,
// the brightest in bdpt's 10-s renders of cornell-spheres). Here these paths are summed over both lobes of every
// glass vertex instead (a tree of chains, each branch weighted by its lobe's f·|cos θ|, which is F or 1 − F, in
// place of dividing by the probability of picking it), so the Fresnel choices add no variance; bdpt_sample
// leaves these paths out of the walk's s = 0 term. A branch whose throughput falls below kSpecularTreeRoulette
// goes on with probability throughput / kSpecularTreeRoulette (Russian roulette, unbiased; it keeps the tree
// small when internal reflections repeat). `camera` is the camera subpath (its first hit is the tree's root).
inline constexpr float kSpecularTreeRoulette = 0.05f;

inline bool pure_specular(const Material& m) { return only_specular(bsdf_flags(m)); }
inline bool pure_specular(const Scene& s, const BdptVertex& v) { return pure_specular(material_of(s, v)); }
inline const Material& branch_material(const Scene& s, const SpecularBranch& b) {
  return b.textured ? b.resolved.m : s.materials[b.it.material];
}

template <class Sampler, uint32_t F>
Rgb specular_chain_emission(const Scene& s, const Options& o, const Sampler& rng, const std::vector<BdptVertex>& camera,
                            std::vector<SpecularBranch>& stack, RayCount& count) {
  Rgb sum(0.f);
  if (camera.size() < 2 || camera[1].kind != VertexKind::Surface || !pure_specular(s, camera[1]) ||
      o.max_bounces < 1)
    return sum;
  stack.clear();
  SpecularBranch root;
  root.it = camera[1].it;
  root.wo = camera[1].wo;
  root.beta = Rgb(1.f);
  root.bounce = 0;
  const float spread = o.cone_spread(rng);
  root.cone_width = spread * glm::length(camera[1].it.p - camera[0].it.p);
  if (camera[1].material && camera[1].material != &s.materials[camera[1].it.material]) {
    root.textured = true;
    new (&root.resolved.m) Material(*camera[1].material);
  }
  stack.push_back(root);
  while (!stack.empty()) {
    const SpecularBranch b = stack.back();
    stack.pop_back();
    const Material& m = branch_material(s, b);
    const Frame frame = shading_frame(b.it, b.wo);  // as the camera walk shades it
    const Vec3 wo = frame.to_local(b.wo);
    // The vertex's Dirac lobes: the two ends of the lobe-choice dimension (find_other_lobe's rule).
    BsdfSample lobes[2];
    int n = 0;
    for (const float uc : {0.f, kOneMinusEpsilon}) {
      BsdfSample bs;
      if (bsdf_sample(m, wo, uc, Vec2(0.5f), bs) && bs.pdf > 0.f && bs.wi.z != 0.f && is_specular(bs.flags) &&
          (n == 0 || bs.flags != lobes[0].flags))
        lobes[n++] = bs;
    }
    for (int k = 0; k < n; ++k) {
      const BsdfSample& bs = lobes[k];
      // One lobe: the walk's own weight f|cos|/pdf (pdf 1 but for rounding); two: each its f|cos|.
      Rgb beta = b.beta * bs.f * (n == 1 ? std::abs(bs.wi.z) / bs.pdf : std::abs(bs.wi.z));
      const float q = max_component(beta) / kSpecularTreeRoulette;
      if (q < 1.f) {
        if (!(rng.get_1d(D::camera_roulette(b.bounce)) < q)) continue;
        beta /= q;
      }
      if (is_black(beta) || !is_finite(beta)) continue;
      const Vec3 wi = frame.to_world(bs.wi);
      const Ray ray{leaving_origin(b.it, wi, bs.wi.z), wi};
      ++count.rays;
      Hit h;
      BdptVertex v;
      if (!intersect_scene<F>(s, ray, kInfinity, skip_on_leave(b.it), h)) {
        if (s.infinite_lights.empty()) continue;
        v.kind = VertexKind::Light;
        v.infinite = true;
        v.it.ng = -ray.d;
        v.wo = -ray.d;
        sum += beta * emitted(s, v);
        continue;
      }
      v.it = make_interaction<F>(s, ray, h);
      SpecularBranch next;
      next.it = v.it;
      next.wo = -ray.d;
      next.beta = beta;
      next.bounce = b.bounce + 1;
      next.cone_width = b.cone_width + spread * h.t;
      const Material& mv =
          material_at<MaterialSet::Any>(s, next.it, ray.d, next.cone_width, next.resolved, NormalLookup::Finest);
      next.textured = &mv != &s.materials[next.it.material];
      v.it = next.it;
      v.wo = -ray.d;
      v.light = s.light_of(v.it.prim);
      if (v.emits()) sum += beta * emitted(s, v);
      // The next vertex scatters event bounce + 1, within max_bounces events in all (the walk's limit).
      if (b.bounce + 2 <= static_cast<uint32_t>(o.max_bounces) && pure_specular(mv)) stack.push_back(next);
    }
  }
  return sum;
}

// Whether the camera subpath reaches vertex t − 1 through pure-specular vertices only (t ≥ 3): the paths
// specular_chain_emission sums.
inline bool specular_chain_to(const Scene& s, const std::vector<BdptVertex>& camera, int t) {
  if (t < 3) return false;
  for (int i = 1; i <= t - 2; ++i)
    if (camera[i].kind != VertexKind::Surface || !pure_specular(s, camera[i])) return false;
  return true;
}

// One camera sample: both subpaths, every strategy; both branches of a split first vertex (FirstVertexSplit).
template <class Sampler, uint32_t F>
bool bdpt_sample(const Scene& s, const RenderSettings& settings, const Sampler& rng, const Ray& camera_ray,
                 BdptScratch& scratch, std::vector<Splat>& splats, Rgb& L, PixelFeatures* features,
                 RayCount& count, const std::atomic<bool>* cancel) {
  const Options o(s, settings);
  std::vector<BdptVertex>& camera = scratch.camera;
  std::vector<BdptVertex>& light = scratch.light;
  L = Rgb(0.f);
  FirstVertexSplit split;
  if (!camera_subpath<Sampler, F>(s, o, rng, camera_ray, camera, scratch.camera_materials, features, split, count,
                                  cancel))
    return false;
  if (!light_subpath<Sampler, F>(s, o, rng, light, scratch.light_materials, count, cancel)) return false;
  const int nl = static_cast<int>(light.size());
  const bool only = o.only_s >= 0;
  // The eye's pure-specular chains to a light, summed over their lobes (off for a single strategy's image).
  const bool chains = !only;
  if (chains) {
    const Rgb chain = specular_chain_emission<Sampler, F>(s, o, rng, camera, scratch.branches, count);
    L += chain;
    // The emission feature (features.h) of a first hit that is pure specular is what the image counts for its
    // chains, the lobes summed, not the emission of the one lobe the walk sampled: with that, a Fresnel
    // reflection of the lamp that 1 sample in 25 picks became a lone bright pixel in the feature, which the
    // denoiser adds back unfiltered over an image that has it 25 times weaker.
    if (features && camera.size() >= 2 && camera[1].kind == VertexKind::Surface && pure_specular(s, camera[1]))
      features->emission = (camera[1].emits() ? camera[1].beta * emitted(s, camera[1]) : Rgb(0.f)) + chain;
  }
  // The strategies with t camera vertices, their contributions scaled by `scale` (a branch's probability).
  // `sampled`: the light point of s = 1 or the eye of t = 1, which connect_light_sample and connect_eye fill
  // afresh before a contribution that mis_weight reads it for.
  BdptVertex sampled;
  const auto strategies = [&](int t, float scale) {
    if (o.manifold && t >= 3 && manifold_vertex(s, camera, t - 1))
      L += scale * connect_through_spheres<Sampler, F>(s, rng, o.dims, camera[t - 1], t, o.max_bounces, count);
    for (int ns = 0; ns <= nl; ++ns) {
      const int depth = ns + t - 2;
      if ((ns == 1 && t == 1) || depth < 0 || depth > o.max_bounces) continue;
      if (only && (ns != o.only_s || t != o.only_t)) continue;
      const BdptVertex& pt = camera[t - 1];
      if (t > 1 && ns != 0 && pt.infinite) continue;  // a vertex at infinity only ends a path (s = 0)
      Rgb c(0.f);
      uint32_t pixel = 0;
      if (ns == 0) {
        if (pt.emits() && !(chains && specular_chain_to(s, camera, t))) c = pt.beta * emitted(s, pt);
      } else if (t == 1) {
        const BdptVertex& qs = light[ns - 1];
        if (connectible(s, qs)) c = connect_eye<Sampler, F>(s, rng, qs, sampled, pixel, count);
      } else if (ns == 1) {
        if (connectible(s, pt)) c = connect_light_sample<Sampler, F>(s, o, rng, pt, t, sampled, count);
      } else {
        const BdptVertex& qs = light[ns - 1];
        if (connectible(s, qs) && connectible(s, pt)) {
          c = qs.beta * vertex_f(s, qs, pt, true) * vertex_f(s, pt, qs, false) * pt.beta;
          if (!is_black(c)) {
            c *= geometry_term(pt, qs);
            if (!unoccluded<F>(s, pt, qs, count)) c = Rgb(0.f);
          }
        }
      }
      if (is_black(c)) continue;
      if (!only) c *= mis_weight(s, light, camera, sampled, ns, t);
      if (ns == 0 && o.manifold) c *= path_tracing_share(s, camera, t);
      if (t == 1) splats.push_back({pixel, c});
      else L += scale * c;
    }
  };
  // Strategies with t ≤ 2 end at the eye or at the first vertex, before the split: they run once.
  int nc = static_cast<int>(camera.size());
  for (int t = 1; t <= nc; ++t) {
    if (t % 64 == 0 && cancel && cancel->load(std::memory_order_relaxed)) return false;  // long paths: O(nc·nl)
    strategies(t, t >= 3 && split.active ? split.taken_pdf : 1.f);
  }
  if (!split.active) return true;
  FirstVertexSplit other;
  other.forced_uc = split.other_uc;
  if (!camera_subpath<Sampler, F>(s, o, rng, camera_ray, camera, scratch.camera_materials, nullptr, other, count,
                                  cancel))
    return false;
  nc = static_cast<int>(camera.size());
  for (int t = 3; t <= nc; ++t) {
    if (t % 64 == 0 && cancel && cancel->load(std::memory_order_relaxed)) return false;
    strategies(t, split.other_pdf);
  }
  return true;
}

}  // namespace bdpt_detail

template <class Sampler>
BdptKernel<Sampler> select_bdpt_kernel(const Scene&, const RenderSettings&) {
  return &bdpt_detail::bdpt_sample<Sampler, kAllFeatures>;
}

}  // namespace pt
