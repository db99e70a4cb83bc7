// The shading lanes: shade_vertex (path_tracer.h), with its sample_direct (direct_light.h) and roulette
// (russian_roulette.h), for a packet's worth of paths at once, where a path's hit is on a polygon, a sphere or a kept
// instance's triangle (an emitter's too: its emission is added one lane at a time) of a material written over the
// number type: the Lambert lobe, and (in the kernels for any material) the lobes of lane_lobes.h (the coupled lobe that
// glTF's metallic–roughness material and the plastic are, the rough conductor, the subsurface BRDF and rough glass,
// whose light sample may lie behind the surface), lit by next-event estimation, and its Dirac lobes (the mirror, the
// smooth conductor and smooth glass), which are only sampled, as shade_vertex samples no light where a material has no
// other lobe (a packet of Dirac lanes alone skips the light and rough samples' stages); a smooth plastic's or glTF
// layer's reflection is a Dirac lobe over a lit base. A parallelogram light of uniform emission sampled by area is
// sampled in the lanes; any other light's sample (sample_li) is taken one lane at a time and weighed in the lanes.
// The scene data of the kLanes paths is gathered into arrays (structure of arrays), then every step runs on
// std::experimental::native_simd<float> lanes (one vector per quantity: kLanes = its width). The formulas both loops
// share are written once over the number type (core/lanes.h) and instantiated here for vfloat: the shading frame
// (frame_tangents), the Lambert lobe and its cosine-weighted sample and pdf (lambert_f, cosine_hemisphere), the rough
// lobes' f and pdf, the Fresnel factors and Snell's refraction, the power heuristic, vertex_shading's normal and
// terminator offset, the spawned ray's origin (lanes::offset_point) and the roulette's survival. The rest performs
// exactly the float operations of the scalar functions, in the same order (glm's vector operators evaluate
// component-wise, dot products as (x + y) + z; -ffp-contract=off keeps multiplies and adds apart; std::max is (a < b) ?
// b : a), so a path's radiance is bit-identical to the scalar loop's (tested by the wavefront and smooth-shading tests,
// which compare images byte for byte). (Plain loops over the arrays were tried first: GCC 12 vectorised none of them
// and the code ran 40 % slower than the scalar path; docs/performance.md.)
//
// kM is the kernel's material set (materials/bsdf.h). Under MaterialSet::Any the lanes evaluate the lobes as
// bsdf_value<Any> and bsdf_sample<Any> do (wo and wi mirrored to the front, strictly on one side but for glass); which
// materials they take is wavefront.h's (lane_material: every kind). On a smooth-shaded mesh they shade as shade_vertex
// does: the frame about the interpolated normal, rays leaving from the lifted point. A textured material (its albedo's,
// glTF's metallic–roughness, normal and emission images) is resolved at the hit by the scalar material_at, one lane at
// a time, over the ray cone shade_vertex filters with. A sphere's hit is located by make_interaction's own sphere_point
// in the gather and is flat (its normal is its shading normal); a ray leaving it may hit it again. A kept instance's
// hit is located by make_interaction in the gather too (its triangle placed in double, its vertex shading there). A
// lane takes the scalar path instead (the caller runs shade_vertex for it) when its hit has textures on a sphere or on
// a mesh without texture coordinates, or when no light can reach it, or where shading_normal would bend its normal (a
// grazing view of a smooth mesh); the caller uses the lanes only below the bounce limit. What stays one lane at a time:
// the gathers (a sphere's hit point among them), an emitter's emission and MIS weight, the texture lookups, the light
// choice, the other lights' samples, the 1D random numbers, and lane_lobes.h's table lookups and visible-normal
// samples.
//
// shade_lanes runs in stages, each a function of its own over the packet's arrays (lane_packet.h: LanePacket):
// gather_lanes, lane_hit_points, resolve_textured_lanes, lane_frames, choose_lane_lights, lane_light_samples,
// lane_bsdf_samples, lane_dirac_samples, lane_continuations and write_back_lanes. Each stage reads what the ones before
// it wrote.
#pragma once
#include <array>
#include <cstdint>
#include <utility>

#include "core/simd_sqrt_warnings.h"
#include "geometry/simd_polygons.h"
#include "integrators/lane_lobes.h"
#include "integrators/lane_packet.h"
#include "integrators/path_tracer.h"
#include "integrators/wavefront.h"

namespace pt {
namespace integrator_detail {

// What the lanes hand back: per lane, whether it was shaded here, and if so its shadow ray and whether the path
// goes on (its PathState is updated in place).
struct LaneShading {
  bool handled[kLanes];
  bool shadow[kLanes];
  bool continues[kLanes];
  ShadowRay shadow_ray[kLanes];
};

namespace lane_detail {

using M = vmask;
using lanes::Vec3T;

[[gnu::always_inline]] inline vfloat ld(const float* a) { return vfloat(a, stdx::vector_aligned); }
[[gnu::always_inline]] inline void st(float* a, const vfloat& v) { v.copy_to(a, stdx::vector_aligned); }
[[gnu::always_inline]] inline vfloat one_where(const M& m) { return select(m, vfloat(1.f), vfloat(0.f)); }

// The shading lanes' view of the scene and the bounce.
template <MaterialSet kM>
struct LaneContext {
  const Scene& s;
  const PathOptions& o;
  uint32_t depth;
  // The general-material kernels of a scene with vertex normals shade with them (make_interaction<F>), its
  // polygons' (Scene::shading) or its kept instances' meshes'; the Lambert kernels never see such a scene
  // (Scene::kernel_features).
  bool smooth_scene;
  bool polygon_shading;  // the polygons have vertex normals and texture coordinates (Scene::shading)
  bool roulette;         // roulette_applies at this depth
};

PT_SIMD_SQRT_WARNINGS_OFF  // every lane is computed here

// What the lanes read of lane l's material m.
template <MaterialSet kM>
[[gnu::always_inline]] inline void take_material(LanePacket& pk, LaneLobes& lobes, int l, const Material& m) {
  pk.material.of[l] = &m;
  pk.material.alb_r[l] = m.albedo.x, pk.material.alb_g[l] = m.albedo.y, pk.material.alb_b[l] = m.albedo.z;
  if (kM == MaterialSet::Any && m.type != MaterialType::Diffuse) lobes.take(l, m);
}

// A hit located by make_interaction in lane l, a sphere's or a kept instance's: its point, error bound and
// geometric normal (also as three vertex normals, so that lane_hit_points' vertex_shading keeps it flat there); an
// instance's shading normal and terminator offset, which lane_hit_points takes instead.
[[gnu::always_inline]] inline void gather_given_point(const Interaction& it, bool smooth_scene, LanePolygons& g,
                                                      int l) {
  g.spx[l] = it.p.x, g.spy[l] = it.p.y, g.spz[l] = it.p.z;
  g.sex[l] = it.p_error.x, g.sey[l] = it.p_error.y, g.sez[l] = it.p_error.z;
  g.ngx[l] = it.ng.x, g.ngy[l] = it.ng.y, g.ngz[l] = it.ng.z;
  if (!smooth_scene) return;
  for (int v = 0; v < 3; ++v) g.vn[v][0][l] = it.ng.x, g.vn[v][1][l] = it.ng.y, g.vn[v][2][l] = it.ng.z;
  g.insx[l] = it.ns.x, g.insy[l] = it.ns.y, g.insz[l] = it.ns.z;
  g.ilfx[l] = it.lift.x, g.ilfy[l] = it.lift.y, g.ilfz[l] = it.lift.z;
  g.ilifted[l] = it.lifted ? 1.f : 0.f;
}
// A kept instance's hit in lane l; out of line, so that the gather's loop compiles about as it did without it
// (inlined, it cost `cornell` 0.2 % more instructions; docs/performance.md, session 47).
template <uint32_t F>
[[gnu::noinline]] void gather_instance_point(const Scene& s, bool smooth_scene, const Ray& ray, const Hit& hit,
                                             LanePolygons& g, int l) {
  gather_given_point(make_interaction<F>(s, ray, hit), smooth_scene, g, l);
  g.instance[l] = 1.f;
}
// Whether a kept instance's hit has texture coordinates (its mesh's).
inline bool instance_has_uv(const Scene& s, uint32_t prim) {
  return !s.instances.instance_of(prim).geometry->mesh->uv.empty();
}

// ---- Gather (scalar): which lanes the lanes shade, their rays, hit polygons, spheres or kept instances' triangles
// (located here by make_interaction: the triangle placed in double) and materials. A textured material is marked for
// resolve_textured_lanes, an emitting one for add_lane_emission. Returns whether any lane is active; sets
// `any_textured`, `any_sphere`, `any_instance` and `any_emitter`.
template <MaterialSet kM, uint32_t F>
[[gnu::always_inline]] inline bool gather_lanes(const LaneContext<kM>& c, const uint16_t* ids, int k,
                                                const Hit* hits, const bool* found, const PathState* paths,
                                                LanePacket& pk, LaneLobes& lobes, LaneShading& out,
                                                bool& any_textured, bool& any_sphere, bool& any_instance,
                                                bool& any_emitter) {
  constexpr bool kSpheres = (F & kFeatureSpheres) != 0;
  constexpr int N = kLanes;
  const Scene& s = c.s;
  const PolygonSoA& P = s.polygons;
  for (int l = 0; l < N; ++l) {
    pk.active[l] = 0;
    out.handled[l] = out.shadow[l] = out.continues[l] = false;
  }
  pk.ray.clear();
  pk.polygon.clear(c.smooth_scene);
  pk.material.clear();
  pk.light.clear();
  pk.u.clear();
  if constexpr (kM == MaterialSet::Any) lobes.clear();
  bool any = false;
  // Locals: a bool& might alias the packet's byte arrays.
  bool textured = false, spheres = false, instances = false, emitters = false;
  for (int l = 0; l < k; ++l) {
    pk.material.textured[l] = 0;
    if (!found[l]) continue;
    const uint32_t prim = hits[l].prim;
    const bool beyond = prim >= s.sphere_begin();  // a sphere's or a kept instance's triangle
    const bool sphere = kSpheres && beyond && s.is_sphere(prim);
    const bool instance = beyond && !sphere;
    pk.material.index[l] = sphere     ? s.spheres.material[prim - s.sphere_begin()]
                           : instance ? s.material_of(prim)
                                      : P.material[prim];
    const Material& m = s.materials[pk.material.index[l]];
    const bool emits = !is_black(m.emission);
    pk.material.emits[l] = emits ? 1 : 0;
    if constexpr (kM == MaterialSet::Any) {
      if (!lane_material(m)) continue;
      if (has_textures(m)) {
        // No texture coordinates: the scalar path.
        if (sphere || (instance ? !instance_has_uv(s, prim) : !c.polygon_shading)) continue;
        pk.material.textured[l] = 1;  // its material once the hit is known
        textured = true;
      } else {
        take_material<kM>(pk, lobes, l, m);
      }
    } else {
      take_material<kM>(pk, lobes, l, m);
    }
    const PathState& p = paths[ids[l]];
    LaneRays& r = pk.ray;
    r.ox[l] = p.ray.o.x, r.oy[l] = p.ray.o.y, r.oz[l] = p.ray.o.z;
    r.dx[l] = p.ray.d.x, r.dy[l] = p.ray.d.y, r.dz[l] = p.ray.d.z;
    r.t[l] = hits[l].t;
    r.beta_r[l] = p.beta.x, r.beta_g[l] = p.beta.y, r.beta_b[l] = p.beta.z;
    r.eta[l] = p.eta_scale;
    if (sphere || instance) {
      if (!spheres && !instances) pk.polygon.clear_given_points(c.smooth_scene);
      if (sphere) {
        Interaction it;
        sphere_point(s, p.ray, hits[l], it);
        gather_given_point(it, c.smooth_scene, pk.polygon, l);
        pk.polygon.sphere[l] = 1.f;
        spheres = true;
      } else {
        gather_instance_point<F>(s, c.smooth_scene, p.ray, hits[l], pk.polygon, l);
        instances = true;
      }
      pk.active[l] = 1;
      any = true;
      emitters = emitters || emits;
      continue;
    }
    LanePolygons& g = pk.polygon;
    const Vec3 a = P.v[0][prim], b = P.v[1][prim], cc = P.v[2][prim], d = P.v[3][prim];
    g.ax[l] = a.x, g.ay[l] = a.y, g.az[l] = a.z, g.v1x[l] = b.x, g.v1y[l] = b.y, g.v1z[l] = b.z;
    g.v2x[l] = cc.x, g.v2y[l] = cc.y, g.v2z[l] = cc.z, g.v3x[l] = d.x, g.v3y[l] = d.y, g.v3z[l] = d.z;
    const auto& dual = P.dual[prim];
    g.d00x[l] = dual[0][0].x, g.d00y[l] = dual[0][0].y, g.d00z[l] = dual[0][0].z;
    g.d01x[l] = dual[0][1].x, g.d01y[l] = dual[0][1].y, g.d01z[l] = dual[0][1].z;
    g.d10x[l] = dual[1][0].x, g.d10y[l] = dual[1][0].y, g.d10z[l] = dual[1][0].z;
    g.d11x[l] = dual[1][1].x, g.d11y[l] = dual[1][1].y, g.d11z[l] = dual[1][1].z;
    const auto& margin = P.edge_margin[prim];
    g.m0x[l] = margin[0].x, g.m0y[l] = margin[0].y, g.m0z[l] = margin[0].z;
    g.m1x[l] = margin[1].x, g.m1y[l] = margin[1].y, g.m1z[l] = margin[1].z;
    const Vec3 ng = P.normal[prim];
    g.ngx[l] = ng.x, g.ngy[l] = ng.y, g.ngz[l] = ng.z;
    if (c.polygon_shading) {
      const std::array<Vec3, 3>& vns = s.shading.normal[prim];
      for (int v = 0; v < 3; ++v) g.vn[v][0][l] = vns[v].x, g.vn[v][1][l] = vns[v].y, g.vn[v][2][l] = vns[v].z;
    } else if (c.smooth_scene) {  // a flat polygon in a scene whose instances are smooth-shaded
      for (int v = 0; v < 3; ++v) g.vn[v][0][l] = ng.x, g.vn[v][1][l] = ng.y, g.vn[v][2][l] = ng.z;
    }
    g.quad[l] = P.triangle[prim] ? 0.f : 1.f;
    pk.active[l] = 1;
    any = true;
    emitters = emitters || emits;
  }
  any_textured = textured, any_sphere = spheres, any_instance = instances, any_emitter = emitters;
  return any;
}

// ---- make_interaction (polygons): barycentrics from the dual vectors, margins, the re-interpolated point; on a
// smooth-shaded scene, vertex_shading's normal and terminator offset (it.ns, it.lift, it.lifted). A sphere's or an
// instance's lane (any_given) keeps the point and error bound the gather wrote, an instance's (any_instance) its
// shading normal and terminator offset too.
[[gnu::always_inline]] inline void lane_hit_points(const LaneRays& r, const LanePolygons& g, bool smooth_scene,
                                                   bool any_textured, bool any_given, bool any_instance, LaneHits& h) {
  using lanes::std_max;
  const vfloat T = ld(r.t), Ax = ld(g.ax), Ay = ld(g.ay), Az = ld(g.az);
  const vfloat qx = (ld(r.ox) + T * ld(r.dx)) - Ax, qy = (ld(r.oy) + T * ld(r.dy)) - Ay,
               qz = (ld(r.oz) + T * ld(r.dz)) - Az;
  vfloat b1 = (qx * ld(g.d00x) + qy * ld(g.d00y)) + qz * ld(g.d00z);
  vfloat b2 = (qx * ld(g.d01x) + qy * ld(g.d01y)) + qz * ld(g.d01z);
  const M half = b1 < 0.f && ld(g.quad) != 0.f;
  b1 = select(half, (qx * ld(g.d10x) + qy * ld(g.d10y)) + qz * ld(g.d10z), b1);
  b2 = select(half, (qx * ld(g.d11x) + qy * ld(g.d11y)) + qz * ld(g.d11z), b2);
  vfloat b0 = (1.f - b1) - b2;
  const vfloat Bx = select(half, ld(g.v2x), ld(g.v1x)), By = select(half, ld(g.v2y), ld(g.v1y)),
               Bz = select(half, ld(g.v2z), ld(g.v1z));
  const vfloat Cx = select(half, ld(g.v3x), ld(g.v2x)), Cy = select(half, ld(g.v3y), ld(g.v2y)),
               Cz = select(half, ld(g.v3z), ld(g.v2z));
  const vfloat mx = select(half, ld(g.m1x), ld(g.m0x)), my = select(half, ld(g.m1y), ld(g.m0y)),
               mz = select(half, ld(g.m1z), ld(g.m0z));
  const M clamp = b0 < mx || b1 < my || b2 < mz;
  if (stdx::any_of(clamp)) {
    const vfloat c0 = std_max(b0, mx), c1 = std_max(b1, my), c2 = std_max(b2, mz);
    const vfloat inv = 1.f / ((c0 + c1) + c2);
    b0 = select(clamp, c0 * inv, b0), b1 = select(clamp, c1 * inv, b1), b2 = select(clamp, c2 * inv, b2);
  }
  Vec3T<vfloat> p{(b0 * Ax + b1 * Bx) + b2 * Cx, (b0 * Ay + b1 * By) + b2 * Cy, (b0 * Az + b1 * Bz) + b2 * Cz};
  st(h.px, p.x), st(h.py, p.y), st(h.pz, p.z);
  if (any_textured) st(h.bary[0], b0), st(h.bary[1], b1), st(h.bary[2], b2);
  constexpr float g7 = gamma_bound(7);
  st(h.ex, g7 * ((stdx::abs(b0 * Ax) + stdx::abs(b1 * Bx)) + stdx::abs(b2 * Cx)));
  st(h.ey, g7 * ((stdx::abs(b0 * Ay) + stdx::abs(b1 * By)) + stdx::abs(b2 * Cy)));
  st(h.ez, g7 * ((stdx::abs(b0 * Az) + stdx::abs(b1 * Bz)) + stdx::abs(b2 * Cz)));
  if (any_given) {  // the spheres' and instances' lanes: the gather's point and bound
    const M S = ld(g.sphere) != 0.f || ld(g.instance) != 0.f;
    for (auto [to, from] : {std::pair{h.px, g.spx}, {h.py, g.spy}, {h.pz, g.spz}, {h.ex, g.sex}, {h.ey, g.sey},
                            {h.ez, g.sez}})
      st(to, select(S, ld(from), ld(to)));
    p = {ld(h.px), ld(h.py), ld(h.pz)};
  }
  if (!smooth_scene) return;
  // vertex_shading: a face whose three normals are ng (one without vertex normals) stays exactly flat.
  const Vec3T<vfloat> ng{ld(g.ngx), ld(g.ngy), ld(g.ngz)};
  const Vec3T<vfloat> v[3] = {{Ax, Ay, Az}, {Bx, By, Bz}, {Cx, Cy, Cz}};
  const vfloat b[3] = {b0, b1, b2};
  Vec3T<vfloat> n[3];
  M flat = M(true);
  for (int k = 0; k < 3; ++k) {
    n[k] = {ld(g.vn[k][0]), ld(g.vn[k][1]), ld(g.vn[k][2])};
    flat = flat && n[k].x == ng.x && n[k].y == ng.y && n[k].z == ng.z;
  }
  vfloat side;
  const Vec3T<vfloat> ns = interpolated_normal(n, b, ng, side);
  st(h.nsx, select(flat, ng.x, ns.x)), st(h.nsy, select(flat, ng.y, ns.y)), st(h.nsz, select(flat, ng.z, ns.z));
  const Vec3T<vfloat> lift = terminator_lift(n, v, b, p, side);
  const M up = !flat && lanes::dot(lift, ng) > 0.f;
  st(h.lfx, lift.x), st(h.lfy, lift.y), st(h.lfz, lift.z);
  st(h.lifted, one_where(up));
  if (!any_instance) return;
  const M I = ld(g.instance) != 0.f;  // instance_point's own vertex_shading
  for (auto [to, from] : {std::pair{h.nsx, g.insx}, {h.nsy, g.insy}, {h.nsz, g.insz}, {h.lfx, g.ilfx}, {h.lfy, g.ilfy},
                          {h.lfz, g.ilfz}, {h.lifted, g.ilifted}})
    st(to, select(I, ld(from), ld(to)));
}

// ---- A textured lane's material at its hit (one lane at a time): vertex_shading's texture coordinates (on a kept
// instance, make_interaction's again, its tangents included), then material_at over the ray cone shade_vertex filters
// with; a normal map bends the shading normal there (a metallic–roughness image may make the lobe smooth there: its
// layer's reflection is then a Dirac lobe). `any_instance`: some lane's hit is on an instance.
template <MaterialSet kM, uint32_t F>
[[gnu::always_inline]] inline void resolve_textured_lanes(const LaneContext<kM>& c, const uint16_t* ids, int k,
                                                          const Hit* hits, const PathState* paths, bool any_instance,
                                                          LanePacket& pk, LaneLobes& lobes, MaterialScratch* resolved) {
  const PolygonSoA& P = c.s.polygons;
  LaneHits& h = pk.hit;
  for (int l = 0; l < k; ++l) {
    if (!pk.material.textured[l]) continue;
    const uint32_t prim = hits[l].prim;
    const PathState& p = paths[ids[l]];
    Interaction it;
    if (any_instance && pk.polygon.instance[l] != 0.f) {
      it = make_interaction<F>(c.s, p.ray, hits[l]);
    } else {
      it.prim = prim;
      it.material = pk.material.index[l];
      it.ng = P.normal[prim];
      it.ns = Vec3(h.nsx[l], h.nsy[l], h.nsz[l]);
      surface_uv(c.s.shading.uv[prim], h.bary[0][l], h.bary[1][l], h.bary[2][l], P.dual[prim][0], it);
    }
    h.u[l] = it.uv.x, h.v[l] = it.uv.y;  // an emission map's texel (add_lane_emission)
    const Material& m = material_at<kM>(c.s, it, p.ray.d, p.cone_width + p.cone_spread * hits[l].t, resolved[l]);
    if (lane_material(m)) take_material<kM>(pk, lobes, l, m);
    else pk.active[l] = 0;
    h.nsx[l] = it.ns.x, h.nsy[l] = it.ns.y, h.nsz[l] = it.ns.z;
  }
}

// ---- The shading frame (Frame::from_normal) about the front geometric normal, or on a smooth-shaded hit the
// shading normal (shade_vertex: smooth where it.ns != it.ng); wo's z in it; the lit side's geometric normal.
// A smooth hit whose normal shading_normal would bend (the mirror reflection of wo dips under the surface: a
// grazing view) takes the scalar path.
[[gnu::always_inline]] inline void lane_frames(const LaneRays& r, const LanePolygons& g, const LaneHits& h,
                                               bool smooth_scene, uint8_t* active, LaneFrames& f) {
  const vfloat Nx = ld(g.ngx), Ny = ld(g.ngy), Nz = ld(g.ngz);
  const Vec3T<vfloat> wo{-ld(r.dx), -ld(r.dy), -ld(r.dz)};
  Vec3T<vfloat> fn{Nx, Ny, Nz};
  if (smooth_scene) {
    const Vec3T<vfloat> ns{ld(h.nsx), ld(h.nsy), ld(h.nsz)};
    const M bent = ns.x != Nx || ns.y != Ny || ns.z != Nz;
    const M clears = reflection_clears(ns, {Nx, Ny, Nz}, wo).clears;
    for (int l = 0; l < kLanes; ++l)
      if (bent[l] && !clears[l]) active[l] = 0;  // shading_normal's bend: the scalar path
    fn = {select(bent, ns.x, Nx), select(bent, ns.y, Ny), select(bent, ns.z, Nz)};
    st(f.smooth, one_where(bent));
  }
  st(f.fnx, fn.x), st(f.fny, fn.y), st(f.fnz, fn.z);
  vfloat s[3], t[3];
  frame_tangents(lanes::sign_of(fn.z), fn.x, fn.y, fn.z, s, t);
  st(f.sx, s[0]), st(f.sy, s[1]), st(f.sz, s[2]);
  st(f.tx, t[0]), st(f.ty, t[1]), st(f.tz, t[2]);
  st(f.wlz, lanes::dot(wo, fn));
  const M front = lanes::dot(wo, {Nx, Ny, Nz}) >= 0.f;
  st(f.nx, select(front, Nx, -Nx)), st(f.ny, select(front, Ny, -Ny)), st(f.nz, select(front, Nz, -Nz));
}

// ---- Light choice and the lanes' random numbers (scalar): lanes whose light this code cannot sample go to the
// scalar path.
template <MaterialSet kM, uint32_t F, class RngOf>
[[gnu::always_inline]] inline void choose_lane_lights(const LaneContext<kM>& c, const RngOf& rng_of, int k,
                                                      const Hit* hits, const LaneLobes& lobes, LanePacket& pk) {
  const Scene& s = c.s;
  const PolygonSoA& P = s.polygons;
  const uint32_t choice_dim = c.o.dims.light_choice(c.depth), point_dim = c.o.dims.light_point(c.depth);
  const uint32_t dir_dim = c.o.dims.bsdf_direction(c.depth), rr_dim = c.o.dims.roulette(c.depth);
  const uint32_t lobe_dim = c.o.dims.bsdf_lobe(c.depth);
  const LaneHits& h = pk.hit;
  const LaneFrames& f = pk.frame;
  LaneLights& L = pk.light;
  const bool any_dirac = kM == MaterialSet::Any && lobes.any_dirac;
  const bool any_rough = kM == MaterialSet::Any && lobes.any_rough();
  for (int l = 0; l < k; ++l) {
    if (!pk.active[l]) continue;
    const auto& rng = rng_of(l);
    if (any_dirac && lobes.dirac[l] != 0.f) {
      // A Dirac lobe alone: no light sample (shade_vertex samples lights only where a lobe has_non_specular), and
      // only glass chooses between its lobes.
      if (lobes.glass[l] != 0.f) pk.u.u_lobe[l] = rng.get_1d(lobe_dim);
      if (c.roulette) pk.u.u_rr[l] = rng.get_1d(rr_dim);
      continue;
    }
    const Vec3 ref(h.px[l], h.py[l], h.pz[l]);
    if (!s.lights.empty()) {
      float pmf = 0.f;
      const int li = choose_light_at(s, ref, Vec3(f.nx[l], f.ny[l], f.nz[l]), rng.get_1d(choice_dim), pmf);
      if (li < 0) {
        pk.active[l] = 0;  // no light reaches it: the scalar path
        continue;
      }
      const Light& light = s.lights[li];
      if (!parallelogram_by_area(light, ref)) {
        // Any other light (spherical rectangles, triangles, spheres, punctual and infinite lights): sample_li's
        // own sample, as sample_lights and sample_direct take it; the lanes weigh it like the parallelogram's.
        L.general[l] = 1.f;
        LightSample ls;
        if (sample_li<F>(s, light, {ref, Vec3(f.nx[l], f.ny[l], f.nz[l]), hits[l].prim}, rng.get_2d(point_dim), ls,
                         c.o.mis)) {
          ls.pdf *= pmf;
          L.light_ok[l] = ls.pdf > 0.f && !is_black(ls.Le) ? 1.f : 0.f;
          L.g_wx[l] = ls.wi.x, L.g_wy[l] = ls.wi.y, L.g_wz[l] = ls.wi.z;
          L.g_px[l] = ls.p.x, L.g_py[l] = ls.p.y, L.g_pz[l] = ls.p.z;
          L.g_pdf[l] = ls.pdf;
          L.g_inf[l] = ls.dist == kInfinity ? 1.f : 0.f;
          L.g_delta[l] = ls.delta ? 1.f : 0.f;
          L.le_r[l] = ls.Le.x, L.le_g[l] = ls.Le.y, L.le_b[l] = ls.Le.z;
        }
        L.prim[l] = ls.prim;
      } else {
        const uint32_t lp = light.prim;
        // sample_li: a one-sided light seen from behind gives no sample.
        L.light_ok[l] = light.two_sided || glm::dot(P.normal[lp], ref - P.v[0][lp]) > 0.f ? 1.f : 0.f;
        const Vec3 la = P.v[0][lp], lb = P.v[1][lp], lc = P.v[2][lp], ln = P.normal[lp];
        L.la_x[l] = la.x, L.la_y[l] = la.y, L.la_z[l] = la.z, L.lb_x[l] = lb.x, L.lb_y[l] = lb.y, L.lb_z[l] = lb.z;
        L.lc_x[l] = lc.x, L.lc_y[l] = lc.y, L.lc_z[l] = lc.z, L.ln_x[l] = ln.x, L.ln_y[l] = ln.y, L.ln_z[l] = ln.z;
        L.l_area[l] = light.area;
        L.l_pmf[l] = pmf;
        L.le_r[l] = light.emission.x, L.le_g[l] = light.emission.y, L.le_b[l] = light.emission.z;
        L.two_sided[l] = light.two_sided ? 1.f : 0.f;
        L.prim[l] = lp;
        const Vec2 u = rng.get_2d(point_dim);
        L.ux[l] = u.x, L.uy[l] = u.y;
      }
    }
    const Vec2 bu = rng.get_2d(dir_dim);
    pk.u.bux[l] = bu.x, pk.u.buy[l] = bu.y;
    if (any_rough && (lobes.layered[l] != 0.f || lobes.metal[l] != 0.f || lobes.rough_glass[l] != 0.f))
      pk.u.u_lobe[l] = rng.get_1d(lobe_dim);
    if (c.roulette) pk.u.u_rr[l] = rng.get_1d(rr_dim);
  }
}

// offset_ray_origin(it, back) of every lane: a lifted hit leaves its front from p + lift (vertex_shading).
[[gnu::always_inline]] inline Vec3T<vfloat> lane_spawn_origin(const LaneHits& h, const LanePolygons& g,
                                                              bool smooth_scene, const M& back) {
  Vec3T<vfloat> p{ld(h.px), ld(h.py), ld(h.pz)};
  if (smooth_scene) {
    const M up = ld(h.lifted) != 0.f && !back;
    p = {select(up, p.x + ld(h.lfx), p.x), select(up, p.y + ld(h.lfy), p.y), select(up, p.z + ld(h.lfz), p.z)};
  }
  return lanes::offset_point(p, {ld(h.ex), ld(h.ey), ld(h.ez)}, {ld(g.ngx), ld(g.ngy), ld(g.ngz)}, back);
}

// wo in each lane's shading frame, mirrored to the front (bsdf_value<Any> and bsdf_sample<Any> mirror wo and wi
// when wo is below).
[[gnu::always_inline]] inline Vec3T<vfloat> lane_wo_local(const LaneRays& r, const LaneFrames& f) {
  const Vec3T<vfloat> wo{-ld(r.dx), -ld(r.dy), -ld(r.dz)};
  const vfloat Wz = ld(f.wlz);
  return {lanes::dot(wo, {ld(f.sx), ld(f.sy), ld(f.sz)}), lanes::dot(wo, {ld(f.tx), ld(f.ty), ld(f.tz)}),
          select(Wz < 0.f, -Wz, Wz)};
}

// The Lambert lobe's f, ρ/π, of every lane.
[[gnu::always_inline]] inline Vec3T<vfloat> lambert_lanes(const LaneMaterials& m) {
  return {lambert_f(ld(m.alb_r)), lambert_f(ld(m.alb_g)), lambert_f(ld(m.alb_b))};
}

// ---- The light sample (sample_li by area, sample_lights' choice probability), the BSDF there, the shadow ray
// and its contribution. `Gl`: the lanes with a rough lobe other than Lambert's (lane_lobes.h); a lane with a
// Dirac lobe has no light sample (choose_lane_lights left its light_ok 0), so no shadow ray.
template <MaterialSet kM>
[[gnu::always_inline]] inline void lane_light_samples(const LaneContext<kM>& c, const LanePacket& pk,
                                                      const LaneLobes& lobes, bool any_rough, const M& Gl,
                                                      LaneShadows& out) {
  const LaneLights& L = pk.light;
  const LaneFrames& fr = pk.frame;
  const Vec3T<vfloat> P_{ld(pk.hit.px), ld(pk.hit.py), ld(pk.hit.pz)};
  const Vec3T<vfloat> FN{ld(fr.fnx), ld(fr.fny), ld(fr.fnz)};  // the shading frame's z
  const vfloat Wz = ld(fr.wlz);
  // sample_polygon_area of a parallelogram: a + u.x·(b − a) + u.y·(c − b).
  const vfloat Ux = ld(L.ux), Uy = ld(L.uy);
  const vfloat Lax = ld(L.la_x), Lay = ld(L.la_y), Laz = ld(L.la_z), Lbx = ld(L.lb_x), Lby = ld(L.lb_y),
               Lbz = ld(L.lb_z);
  // Lanes with another light (G) take the scalar sample's point, direction and density instead.
  const M G = ld(L.general) != 0.f;
  const vfloat lpx = select(G, ld(L.g_px), (Lax + Ux * (Lbx - Lax)) + Uy * (ld(L.lc_x) - Lbx));
  const vfloat lpy = select(G, ld(L.g_py), (Lay + Ux * (Lby - Lay)) + Uy * (ld(L.lc_y) - Lby));
  const vfloat lpz = select(G, ld(L.g_pz), (Laz + Ux * (Lbz - Laz)) + Uy * (ld(L.lc_z) - Lbz));
  const vfloat ddx = lpx - P_.x, ddy = lpy - P_.y, ddz = lpz - P_.z;
  const vfloat dist2 = (ddx * ddx + ddy * ddy) + ddz * ddz;
  const vfloat dist = stdx::sqrt(dist2);
  const vfloat wix = select(G, ld(L.g_wx), ddx / dist), wiy = select(G, ld(L.g_wy), ddy / dist),
               wiz = select(G, ld(L.g_wz), ddz / dist);
  const vfloat Lnx = ld(L.ln_x), Lny = ld(L.ln_y), Lnz = ld(L.ln_z);
  const vfloat cos_l = stdx::abs((Lnx * wix + Lny * wiy) + Lnz * wiz);
  const vfloat c_e = (Lnx * -wix + Lny * -wiy) + Lnz * -wiz;  // area_light_emission(n, −wi)
  const M le_on = G || c_e > 0.f || (ld(L.two_sided) != 0.f && c_e < 0.f);
  vfloat pdf = dist2 / (cos_l * ld(L.l_area));
  M ok = ld(L.light_ok) != 0.f && dist2 > 0.f && cos_l != 0.f && stdx::isfinite(pdf);
  pdf *= ld(L.l_pmf);
  const vfloat Ler = ld(L.le_r), Leg = ld(L.le_g), Leb = ld(L.le_b);
  ok = ok && pdf > 0.f && le_on && !(Ler == 0.f && Leg == 0.f && Leb == 0.f);
  // sample_lights and sample_direct's tests for another light were made with its sample (light_ok).
  pdf = select(G, ld(L.g_pdf), pdf);
  ok = (G && ld(L.light_ok) != 0.f) || (!G && ok);
  // wi's z in the shading frame.
  const vfloat wil_z = (wix * FN.x + wiy * FN.y) + wiz * FN.z;
  // bsdf_eval<Lambert>: ρ/π where wo and wi are on one side (their cosines' product is positive); bsdf_eval<Any>
  // mirrors both to the front first (then both are strictly positive), which differs where the product
  // underflows.
  M same_side;
  if constexpr (kM == MaterialSet::Lambert) same_side = Wz * wil_z > 0.f;
  else same_side = (Wz > 0.f && wil_z > 0.f) || (Wz < 0.f && wil_z < 0.f);
  // The lanes whose lobe sees the light there: rough glass's on either side (dielectric_value), the others' on wo's.
  M seen = same_side;
  if (kM == MaterialSet::Any && any_rough && lobes.any_rough_glass) seen = same_side || lobes.rough_glass_mask();
  // The BSDF towards wi: ρ/π, or the other lobe's f and pdf (lane_lobes.h, as bsdf_value<Any> evaluates it).
  const vfloat cos_abs = stdx::abs(wil_z);
  Vec3T<vfloat> nf = lambert_lanes(pk.material);
  vfloat bpdf = select(same_side, cosine_hemisphere_pdf(cos_abs), vfloat(0.f));
  if (any_rough) {
    const Vec3T<vfloat> wi_l{(wix * ld(fr.sx) + wiy * ld(fr.sy)) + wiz * ld(fr.sz),
                             (wix * ld(fr.tx) + wiy * ld(fr.ty)) + wiz * ld(fr.tz), select(Wz < 0.f, -wil_z, wil_z)};
    Vec3T<vfloat> f;
    vfloat gpdf;
    lobes.value(wi_l, f, gpdf);
    const vfloat zero(0.f);
    nf = {select(Gl, select(seen, f.x, zero), nf.x), select(Gl, select(seen, f.y, zero), nf.y),
          select(Gl, select(seen, f.z, zero), nf.z)};
    bpdf = select(Gl, select(seen, gpdf, zero), bpdf);
  }
  ok = ok && seen && !(nf.x == 0.f && nf.y == 0.f && nf.z == 0.f);
  st(out.traced, one_where(ok));
  // shadow_segment leaves on the side of the shading frame wi is on (sample_direct).
  const Vec3T<vfloat> origin = lane_spawn_origin(pk.hit, pk.polygon, c.smooth_scene, wil_z < 0.f);
  const vfloat tlx = lpx - origin.x, tly = lpy - origin.y, tlz = lpz - origin.z;
  const vfloat sdist = stdx::sqrt((tlx * tlx + tly * tly) + tlz * tlz);
  // shadow_segment: towards a light at infinity the ray is unbounded, along wi.
  const M at_infinity = ld(L.g_inf) != 0.f;
  const vfloat t_max = select(at_infinity, vfloat(kInfinity), sdist * kShadowRayShorten);
  // power_heuristic(ls.pdf, bsdf_pdf); a punctual light has no MIS partner.
  const vfloat w = c.o.mis ? select(ld(L.g_delta) != 0.f, vfloat(1.f), power_heuristic(pdf, bpdf)) : vfloat(1.f);
  const vfloat scale = (cos_abs * w) / pdf;
  st(out.ok, one_where(ok && t_max > 0.f));
  st(out.ox, origin.x), st(out.oy, origin.y), st(out.oz, origin.z);
  st(out.dx, select(at_infinity, wix, tlx / sdist)), st(out.dy, select(at_infinity, wiy, tly / sdist));
  st(out.dz, select(at_infinity, wiz, tlz / sdist));
  st(out.t_max, t_max);
  const LaneRays& r = pk.ray;
  st(out.c_r, ((ld(r.beta_r) * nf.x) * select(le_on, Ler, vfloat(0.f))) * scale);
  st(out.c_g, ((ld(r.beta_g) * nf.y) * select(le_on, Leg, vfloat(0.f))) * scale);
  st(out.c_b, ((ld(r.beta_b) * nf.z) * select(le_on, Leb, vfloat(0.f))) * scale);
}

// ---- The BSDF sample (cosine-weighted, or the rough lobe's), in the shading frame mirrored to the front.
[[gnu::always_inline]] inline void lane_bsdf_samples(const LanePacket& pk, LaneLobes& lobes, bool any_rough,
                                                     const M& Gl, LaneSamples& out) {
  const LaneMaterials& mat = pk.material;
  const vfloat Wz = ld(pk.frame.wlz);
  M ok = select(Wz < 0.f, -Wz, Wz) > 0.f && !(ld(mat.alb_r) == 0.f && ld(mat.alb_g) == 0.f && ld(mat.alb_b) == 0.f);
  // sample_cosine_hemisphere: the concentric disk (sampling.h), then z = √max(0, 1 − x² − y²).
  const Vec3T<vfloat> local = cosine_hemisphere(ld(pk.u.bux), ld(pk.u.buy));
  vfloat dxs = local.x, dys = local.y, wz0 = local.z;
  ok = ok && wz0 > 0.f;
  vfloat pdf = cosine_hemisphere_pdf(wz0);
  Vec3T<vfloat> f = lambert_lanes(mat);
  M refracts(false);  // rough glass's refraction
  if (any_rough) {
    // metallic_roughness_sample, plastic_sample, conductor_sample, subsurface_sample and dielectric_sample: the
    // visible normal's reflection (or refraction) or the cosine direction, as each lane's lobe choice says; then f
    // and pdf of the direction.
    Vec3T<vfloat> wi, fl;
    vfloat gpdf;
    M g_ok;
    lobes.sample(pk.u.u_lobe, pk.u.bux, pk.u.buy, {dxs, dys, wz0}, wi, fl, gpdf, g_ok, refracts);
    ok = (Gl && g_ok) || (!Gl && ok);
    dxs = select(Gl, wi.x, dxs), dys = select(Gl, wi.y, dys), wz0 = select(Gl, wi.z, wz0);
    pdf = select(Gl, gpdf, pdf);
    f = {select(Gl, fl.x, f.x), select(Gl, fl.y, f.y), select(Gl, fl.z, f.z)};
  }
  st(out.ok, one_where(ok));
  st(out.wx, dxs), st(out.wy, dys), st(out.wz, wz0);
  st(out.f_r, f.x), st(out.f_g, f.y), st(out.f_b, f.z), st(out.pdf, pdf);
  // A smooth layer's reflection is a Dirac sample; rough glass's refraction scales the path's η scale by η² before
  // the roulette judges it (shade_vertex).
  if (any_rough && lobes.any_smooth_layer) st(out.specular, ld(lobes.layer_dirac));
  if (any_rough && (lobes.any_smooth_layer || lobes.any_rough_glass)) {
    const vfloat eta_t = lobes.any_rough_glass ? select(refracts, ld(lobes.glass_eta), vfloat(1.f)) : vfloat(1.f);
    const vfloat eta = ld(pk.ray.eta);
    st(out.transmits, one_where(refracts)), st(out.eta_t, eta_t);
    st(out.eta, select(refracts, eta * (eta_t * eta_t), eta));
  }
}

// ---- The Dirac lobes' samples (the mirror's, the smooth conductor's and smooth glass's), in place of the others
// in their lanes; a refraction scales the path's η scale by η² before the roulette judges it (shade_vertex). Run
// only where some lane has one, so that the other packets pay nothing for them. `merge`: lane_bsdf_samples wrote the
// other lanes' refractions and η scales (rough glass's), which stay.
[[gnu::always_inline]] inline void lane_dirac_samples(const LanePacket& pk, const LaneLobes& lobes, bool merge,
                                                      LaneSamples& s) {
  const M D = lobes.dirac_mask();
  Vec3T<vfloat> wi, f;
  vfloat pdf, eta_t;
  M transmits, ok;
  lobes.sample_dirac(pk.u.u_lobe, ld(pk.frame.wlz) < 0.f, wi, f, pdf, transmits, eta_t, ok);
  st(s.ok, select(D, one_where(ok), ld(s.ok)));
  st(s.wx, select(D, wi.x, ld(s.wx))), st(s.wy, select(D, wi.y, ld(s.wy))), st(s.wz, select(D, wi.z, ld(s.wz)));
  st(s.f_r, select(D, f.x, ld(s.f_r))), st(s.f_g, select(D, f.y, ld(s.f_g))), st(s.f_b, select(D, f.z, ld(s.f_b)));
  st(s.pdf, select(D, pdf, ld(s.pdf)));
  // A smooth layer's reflection (lane_bsdf_samples) stays a Dirac sample.
  st(s.specular, lobes.any_smooth_layer ? select(D, vfloat(1.f), ld(s.specular)) : one_where(D));
  const vfloat eta = ld(pk.ray.eta), eta_after = select(transmits, eta * (eta_t * eta_t), eta);
  if (merge) {
    st(s.transmits, select(D, one_where(transmits), ld(s.transmits))), st(s.eta_t, select(D, eta_t, ld(s.eta_t)));
    st(s.eta, select(D, eta_after, ld(s.eta)));
  } else {
    st(s.transmits, one_where(transmits)), st(s.eta_t, eta_t), st(s.eta, eta_after);
  }
}

// ---- The path takes the sample (mirrored back to wo's side): the throughput, roulette, the next ray.
// `eta_known`: the samples hold the path's η scale after them (LaneSamples::eta).
template <MaterialSet kM>
[[gnu::always_inline]] inline void lane_continuations(const LaneContext<kM>& c, const LanePacket& pk, bool eta_known,
                                                      LaneContinuations& out) {
  using lanes::std_max;
  const LaneFrames& fr = pk.frame;
  const LaneSamples& s = pk.sample;
  const LaneRays& r = pk.ray;
  const vfloat dxs = ld(s.wx), dys = ld(s.wy), pdf = ld(s.pdf);
  const vfloat wz = select(ld(fr.wlz) < 0.f, -ld(s.wz), ld(s.wz));
  M ok = ld(s.ok) != 0.f && pdf > 0.f && wz != 0.f;
  const vfloat k_scale = stdx::abs(wz) / pdf;
  vfloat nbr = ld(r.beta_r) * (ld(s.f_r) * k_scale), nbg = ld(r.beta_g) * (ld(s.f_g) * k_scale),
         nbb = ld(r.beta_b) * (ld(s.f_b) * k_scale);
  // frame.to_world: s·x + t·y + n·z.
  const vfloat wwx = (ld(fr.sx) * dxs + ld(fr.tx) * dys) + ld(fr.fnx) * wz;
  const vfloat wwy = (ld(fr.sy) * dxs + ld(fr.ty) * dys) + ld(fr.fny) * wz;
  const vfloat wwz = (ld(fr.sz) * dxs + ld(fr.tz) * dys) + ld(fr.fnz) * wz;
  if (c.roulette) {
    const vfloat eta = ld(eta_known ? s.eta : r.eta);
    const vfloat q = roulette_survival(std_max(nbr, std_max(nbg, nbb)) * eta);
    ok = ok && ld(pk.u.u_rr) < q;
    nbr = nbr / q, nbg = nbg / q, nbb = nbb / q;
  }
  ok = ok && !(nbr == 0.f && nbg == 0.f && nbb == 0.f) && stdx::isfinite(nbr) && stdx::isfinite(nbg) &&
       stdx::isfinite(nbb);
  st(out.goes_on, one_where(ok));
  st(out.beta_r, nbr), st(out.beta_g, nbg), st(out.beta_b, nbb);
  // The side it leaves on: wi's in the world on a flat hit, the shading frame's on a smooth one (shade_vertex).
  const LanePolygons& g = pk.polygon;
  M back = lanes::dot(Vec3T<vfloat>{wwx, wwy, wwz}, Vec3T<vfloat>{ld(g.ngx), ld(g.ngy), ld(g.ngz)}) < 0.f;
  if (c.smooth_scene) {
    const M bent = ld(fr.smooth) != 0.f;
    back = (bent && wz < 0.f) || (!bent && back);
  }
  const Vec3T<vfloat> origin = lane_spawn_origin(pk.hit, g, c.smooth_scene, back);
  st(out.ox, origin.x), st(out.oy, origin.y), st(out.oz, origin.z);
  st(out.dx, wwx), st(out.dy, wwy), st(out.dz, wwz);
}

// ---- The emission found at an emitting lane's hit (scalar, lane order), as shade_vertex adds it first
// (add_found_emission). Run after the last stage that may hand a lane back to shade_vertex (choose_lane_lights), so
// that no path adds it twice. An emission map is a textured material's: resolve_textured_lanes computed its uv.
template <MaterialSet kM, uint32_t F>
[[gnu::always_inline]] inline void add_lane_emission(const LaneContext<kM>& c, const uint16_t* ids, int k,
                                                     const Hit* hits, const LanePacket& pk, PathState* paths) {
  const LaneHits& h = pk.hit;
  const LanePolygons& g = pk.polygon;
  for (int l = 0; l < k; ++l) {
    if (!pk.active[l] || !pk.material.emits[l]) continue;
    const Vec2 uv = pk.material.textured[l] ? Vec2(h.u[l], h.v[l]) : Vec2(0.f);  // written for textured lanes only
    add_found_emission<F>(c.s, c.o, paths[ids[l]], hits[l].prim, Vec3(h.px[l], h.py[l], h.pz[l]),
                          Vec3(g.ngx[l], g.ngy[l], g.ngz[l]), uv);
  }
}

// ---- Write back (scalar, lane order): the feature buffers at a first hit, the shadow ray, the next ray and the
// path's new state. `eta_known`: the samples hold the path's η scale after them; `any_specular`: some lane's
// sample may be a Dirac lobe's (the Dirac lobes', a smooth layer's reflection); `any_sphere`: some lane's hit is on
// a sphere.
template <MaterialSet kM>
[[gnu::always_inline]] inline void write_back_lanes(const LaneContext<kM>& c, const uint16_t* ids, int k,
                                                    const Hit* hits, const LanePacket& pk, bool eta_known,
                                                    bool any_specular, bool any_sphere, PathState* paths,
                                                    LaneShading& out, RayCount& count) {
  const LaneHits& h = pk.hit;
  const LanePolygons& g = pk.polygon;
  const LaneShadows& sh = pk.shadow;
  const LaneSamples& sample = pk.sample;
  const LaneContinuations& next = pk.next;
  for (int l = 0; l < k; ++l) {
    if (!pk.active[l]) continue;
    out.handled[l] = true;
    PathState& p = paths[ids[l]];
    p.cone_width += p.cone_spread * hits[l].t;  // the ray cone a texture further down the path is filtered over
    if (p.features.out) [[unlikely]] {  // the first hit of a film with feature buffers: shade_vertex's own call
      Interaction it;
      it.p = Vec3(h.px[l], h.py[l], h.pz[l]);
      it.ng = Vec3(g.ngx[l], g.ngy[l], g.ngz[l]);
      it.ns = c.smooth_scene ? Vec3(h.nsx[l], h.nsy[l], h.nsz[l]) : it.ng;
      p.features.at_vertex<kM>(static_cast<int>(c.depth), p.ray.o, it, -p.ray.d, *pk.material.of[l], false, p.L);
    }
    if (sh.traced[l] != 0.f) ++count.rays;
    if (sh.ok[l] != 0.f) {
      out.shadow[l] = true;
      out.shadow_ray[l] = {{Vec3(sh.ox[l], sh.oy[l], sh.oz[l]), Vec3(sh.dx[l], sh.dy[l], sh.dz[l])},
                           sh.t_max[l], hits[l].prim, pk.light.prim[l], Rgb(sh.c_r[l], sh.c_g[l], sh.c_b[l])};
    }
    if (next.goes_on[l] == 0.f) continue;
    out.continues[l] = true;
    p.beta = Rgb(next.beta_r[l], next.beta_g[l], next.beta_b[l]);
    if (eta_known) p.eta_scale = sample.eta[l];
    if (any_specular && sample.specular[l] != 0.f) {
      p.count_emission = true;  // no light sample covered the direction
      if (p.features.out) [[unlikely]] {
        const BsdfFlags side = sample.transmits[l] != 0.f ? BsdfFlags::Transmission : BsdfFlags::Reflection;
        p.features.through_specular({Vec3(sample.wx[l], sample.wy[l], sample.wz[l]),
                                     Rgb(sample.f_r[l], sample.f_g[l], sample.f_b[l]), sample.pdf[l],
                                     side | BsdfFlags::Specular, sample.eta_t[l]});
      }
    } else {
      p.count_emission = false;
      p.prev_bsdf_pdf = sample.pdf[l];
      p.prev_p = Vec3(h.px[l], h.py[l], h.pz[l]);
      p.prev_n = Vec3(pk.frame.nx[l], pk.frame.ny[l], pk.frame.nz[l]);
    }
    p.ray = {Vec3(next.ox[l], next.oy[l], next.oz[l]), Vec3(next.dx[l], next.dy[l], next.dz[l])};
    p.skip = hits[l].prim;
    p.depth = static_cast<int>(c.depth) + 1;
  }
  // skip_on_leave: a polygon cannot be hit again by a ray leaving it, a sphere can (from inside, or elsewhere).
  if (any_sphere)
    for (int l = 0; l < k; ++l) {
      if (!pk.active[l] || g.sphere[l] == 0.f) continue;
      out.shadow_ray[l].skip_a = ~0u;
      paths[ids[l]].skip = ~0u;
    }
}

PT_SIMD_SQRT_WARNINGS_ON

}  // namespace lane_detail

PT_SIMD_SQRT_WARNINGS_OFF  // every lane is computed here
// The lanes [0, k) of a packet: path ids[l] hit hits[l] (found[l]); rng_of(l) is lane l's sampler. Requires
// o.light_sampling (so no uniform estimator) and p.depth < o.max_bounces for every path (the caller checks; all
// live paths of a batch share one depth).
template <MaterialSet kM, uint32_t F, class RngOf>
void shade_lanes(const Scene& s, const PathOptions& o, const RngOf& rng_of, const uint16_t* ids, int k,
                 const Hit* hits, const bool* found, PathState* paths, uint32_t depth, LaneShading& out,
                 RayCount& count) {
  using namespace lane_detail;
  const bool polygon_shading = kM == MaterialSet::Any && !s.shading.empty();
  const LaneContext<kM> c{s, o, depth, polygon_shading || (kM == MaterialSet::Any && s.features.smooth_shading),
                          polygon_shading, roulette_applies(static_cast<int>(depth), o.rr_depth)};
  LanePacket pk;
  LaneLobes lobes;  // the rough lobes besides Lambert's (lane_lobes.h)
  constexpr bool kSpheres = (F & kFeatureSpheres) != 0;
  bool any_textured = false, gathered_sphere = false, any_instance = false, any_emitter = false;
  if (!gather_lanes<kM, F>(c, ids, k, hits, found, paths, pk, lobes, out, any_textured, gathered_sphere, any_instance,
                           any_emitter))
    return;  // nothing for the lanes: every path takes shade_vertex
  const bool any_sphere = kSpheres && gathered_sphere;  // false at compile time in a kernel without spheres
  lane_hit_points(pk.ray, pk.polygon, c.smooth_scene, any_textured, any_sphere || any_instance, any_instance, pk.hit);
  // A textured lane's material with what its images say at the hit (material_at's copy, held here).
  MaterialScratch resolved[kLanes];
  if (kM == MaterialSet::Any && any_textured)
    resolve_textured_lanes<kM, F>(c, ids, k, hits, paths, any_instance, pk, lobes, resolved);
  lane_frames(pk.ray, pk.polygon, pk.hit, c.smooth_scene, pk.active, pk.frame);
  choose_lane_lights<kM, F>(c, rng_of, k, hits, lobes, pk);
  // The lanes with another lobe: wo, and E(μo) of the rough ones (Gl) there, rough glass's η (lane_lobes.h).
  const bool any_lobe = kM == MaterialSet::Any && lobes.any();
  const bool any_rough = any_lobe && lobes.any_rough();
  const M Gl = any_rough ? lobes.lobe_mask() : M(false);
  if (any_lobe) lobes.at(lane_wo_local(pk.ray, pk.frame), ld(pk.frame.wlz) < 0.f);
  const bool any_dirac = kM == MaterialSet::Any && lobes.any_dirac;
  // A packet whose lanes all have a Dirac lobe (a mirror's or glass's, hits lane_sort_key grouped) has no light
  // sample and no other BSDF sample to compute.
  bool only_dirac = any_dirac;
  if (any_dirac)
    for (int l = 0; l < k; ++l) only_dirac = only_dirac && !(pk.active[l] && lobes.dirac[l] == 0.f);
  if (only_dirac) {
    pk.shadow.none();
    pk.sample.none();
  } else {
    lane_light_samples(c, pk, lobes, any_rough, Gl, pk.shadow);
    lane_bsdf_samples(pk, lobes, any_rough, Gl, pk.sample);
  }
  // lane_bsdf_samples wrote refractions and η scales (LaneSamples::eta) where a lane has rough glass or a smooth
  // layer; lane_dirac_samples writes them where one has a Dirac lobe.
  const bool bsdf_eta = !only_dirac && any_rough && (lobes.any_rough_glass || lobes.any_smooth_layer);
  if (any_dirac) lane_dirac_samples(pk, lobes, bsdf_eta, pk.sample);
  const bool eta_known = any_dirac || bsdf_eta;
  lane_continuations(c, pk, eta_known, pk.next);
  const bool any_specular = any_dirac || (any_rough && lobes.any_smooth_layer);
  if (any_emitter) add_lane_emission<kM, F>(c, ids, k, hits, pk, paths);
  write_back_lanes(c, ids, k, hits, pk, eta_known, any_specular, any_sphere, paths, out, count);
}
PT_SIMD_SQRT_WARNINGS_ON

}  // namespace integrator_detail
}  // namespace pt
