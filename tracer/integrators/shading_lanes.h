// The shading lanes: shade_vertex (path_tracer.h), with its sample_direct (direct_light.h) and roulette
// (russian_roulette.h), for a packet's worth of paths at once, where a path's hit is on a non-emitting polygon of
// a material written over the number type: the Lambert lobe, and (in the kernels for any material) the rough lobes
// of lane_lobes.h (the coupled lobe that glTF's metallic–roughness material and the plastic are, and the rough
// conductor), lit by next-event estimation. A parallelogram light sampled by area is sampled in the lanes; any
// other light's sample (sample_li) is taken one lane at a time and weighed in the lanes. The scene data of the
// kLanes paths is gathered into arrays (structure of arrays), then every step runs on
// std::experimental::native_simd<float> lanes (one vector per quantity: kLanes = its width). The formulas both
// loops share are written once over the number type (core/lanes.h) and instantiated here for vfloat: the shading
// frame (frame_tangents), the Lambert lobe and its cosine-weighted sample and pdf (lambert_f, cosine_hemisphere),
// the rough lobes' f and pdf, the power heuristic, vertex_shading's normal and terminator offset, the spawned
// ray's origin (lanes::offset_point) and the roulette's survival. The rest performs exactly the float operations
// of the scalar functions, in the same order (glm's vector operators evaluate component-wise, dot products as
// (x + y) + z; -ffp-contract=off keeps multiplies and adds apart; std::max is (a < b) ? b : a), so a path's
// radiance is bit-identical to the scalar loop's (tested by the wavefront and smooth-shading tests, which compare
// images byte for byte). (Plain loops over the arrays were tried first: GCC 12 vectorised none of them and the
// code ran 40 % slower than the scalar path; docs/performance.md.)
//
// kM is the kernel's material set (materials/bsdf.h). Under MaterialSet::Any the lanes evaluate the lobes as
// bsdf_value<Any> and bsdf_sample<Any> do (wo and wi mirrored to the front, strictly on one side); which materials
// they take is wavefront.h's (lane_material, lane_textures). On a smooth-shaded mesh they shade as shade_vertex
// does: the frame about the interpolated normal, rays leaving from the lifted point. A textured material (its
// albedo's, glTF's metallic–roughness and normal images) is resolved at the hit by the scalar material_at, one lane
// at a time, over the ray cone shade_vertex filters with. A lane takes the scalar path instead (the caller runs
// shade_vertex for it) when its hit is on a sphere or an instance, or emits, or has another material (a smooth
// lobe, glass, subsurface), or textures on a mesh without texture coordinates, or when no light can reach it, or
// where shading_normal would bend its normal (a grazing view of a smooth mesh); the caller uses the lanes only
// below the bounce limit. What stays one lane at a time: the gathers, the texture lookups, the
// light choice, the other lights' samples, the 1D random numbers, and lane_lobes.h's table lookups and
// visible-normal samples.
#pragma once
#include <array>
#include <cstdint>

#include "core/simd_sqrt_warnings.h"
#include "geometry/simd_polygons.h"
#include "integrators/lane_lobes.h"
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

[[gnu::always_inline]] inline vfloat ld(const float* a) { return vfloat(a, stdx::vector_aligned); }
[[gnu::always_inline]] inline void st(float* a, const vfloat& v) { v.copy_to(a, stdx::vector_aligned); }

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
  using lanes::std_max, lanes::Vec3T;
  using M = vmask;
  constexpr int N = kLanes;
  const PolygonSoA& P = s.polygons;
  // ---- Gather (scalar): the ray, the hit polygon, its material, the chosen light.
  alignas(64) float ox[N], oy[N], oz[N], dx[N], dy[N], dz[N], t[N];
  alignas(64) float ax[N], ay[N], az[N], v1x[N], v1y[N], v1z[N], v2x[N], v2y[N], v2z[N], v3x[N], v3y[N], v3z[N];
  alignas(64) float d00x[N], d00y[N], d00z[N], d01x[N], d01y[N], d01z[N];
  alignas(64) float d10x[N], d10y[N], d10z[N], d11x[N], d11y[N], d11z[N];
  alignas(64) float m0x[N], m0y[N], m0z[N], m1x[N], m1y[N], m1z[N], ngx[N], ngy[N], ngz[N];
  alignas(64) float alb_r[N], alb_g[N], alb_b[N], beta_r[N], beta_g[N], beta_b[N], eta[N];
  alignas(64) float ux[N], uy[N], bux[N], buy[N], u_rr[N];
  alignas(64) float la_x[N], la_y[N], la_z[N], lb_x[N], lb_y[N], lb_z[N], lc_x[N], lc_y[N], lc_z[N];
  alignas(64) float ln_x[N], ln_y[N], ln_z[N], l_area[N], l_pmf[N], le_r[N], le_g[N], le_b[N];
  alignas(64) float quad[N], two_sided[N], light_ok[N];  // 0 or 1
  // Any other light's sample, taken by the scalar sample_li: whether the lane has one (0 or 1), its direction,
  // point, density (with the choice probability), and whether it is at infinity or punctual (0 or 1).
  alignas(64) float general[N], g_wx[N], g_wy[N], g_wz[N], g_px[N], g_py[N], g_pz[N], g_pdf[N], g_inf[N], g_delta[N];
  // Smooth shading (vertex_shading, interaction.h): the hit polygon's three vertex normals, where the scene has any.
  alignas(64) float vn[3][3][N];  // [vertex][axis][lane]
  // The rough lobes besides Lambert's (lane_lobes.h), and the lobe-choice number of their BSDF sample.
  LaneLobes lobes;
  alignas(64) float u_lobe[N];
  alignas(64) uint8_t active[N];
  alignas(64) uint32_t light_prim[N], material[N];
  const bool roulette = roulette_applies(static_cast<int>(depth), o.rr_depth);
  // The general-material kernels of a scene with vertex normals shade with them (make_interaction<F>); the
  // Lambert kernels never see such a scene (Scene::kernel_features).
  const bool smooth_scene = kM == MaterialSet::Any && !s.shading.empty();
  for (int l = 0; l < N; ++l) {
    active[l] = 0;
    light_ok[l] = 0.f;
    out.handled[l] = out.shadow[l] = out.continues[l] = false;
    // Inactive lanes compute on harmless values; their results are never used.
    ox[l] = oy[l] = oz[l] = dx[l] = dy[l] = t[l] = 0.f;
    dz[l] = 1.f;
    ax[l] = ay[l] = az[l] = v1x[l] = v1y[l] = v1z[l] = v2x[l] = v2y[l] = v2z[l] = v3x[l] = v3y[l] = v3z[l] = 0.f;
    d00x[l] = d00y[l] = d00z[l] = d01x[l] = d01y[l] = d01z[l] = 0.f;
    d10x[l] = d10y[l] = d10z[l] = d11x[l] = d11y[l] = d11z[l] = 0.f;
    m0x[l] = m0y[l] = m0z[l] = m1x[l] = m1y[l] = m1z[l] = 0.f;
    ngx[l] = ngy[l] = 0.f;
    ngz[l] = 1.f;
    alb_r[l] = alb_g[l] = alb_b[l] = beta_r[l] = beta_g[l] = beta_b[l] = eta[l] = 1.f;
    ux[l] = uy[l] = bux[l] = buy[l] = u_rr[l] = 0.5f;
    la_x[l] = la_y[l] = la_z[l] = lb_x[l] = lb_y[l] = lb_z[l] = lc_x[l] = lc_y[l] = lc_z[l] = 0.f;
    ln_x[l] = ln_y[l] = 0.f;
    ln_z[l] = 1.f;
    l_area[l] = l_pmf[l] = 1.f;
    le_r[l] = le_g[l] = le_b[l] = 0.f;
    quad[l] = two_sided[l] = 0.f;
    general[l] = g_inf[l] = g_delta[l] = 0.f;
    g_wx[l] = g_wy[l] = g_px[l] = g_py[l] = g_pz[l] = 0.f;
    g_wz[l] = g_pdf[l] = 1.f;
    light_prim[l] = kNoPrimitive;
    if (smooth_scene)
      for (int v = 0; v < 3; ++v) vn[v][0][l] = vn[v][1][l] = 0.f, vn[v][2][l] = 1.f;
    lobes.clear(l);
  }
  int lanes_active = 0;
  bool any_textured = false;
  // The material a lane shades with (mats[l]): the scene's, or for a textured one its copy with what its images
  // say at the hit (material_at, into resolved[l], once the hit's texture coordinates are known).
  const Material* mats[N];
  MaterialScratch resolved[N];
  alignas(64) uint8_t textured[N];
  // What the lanes read of lane l's material.
  const auto take_material = [&](int l, const Material& m) {
    mats[l] = &m;
    alb_r[l] = m.albedo.x, alb_g[l] = m.albedo.y, alb_b[l] = m.albedo.z;
    if (kM == MaterialSet::Any && m.type != MaterialType::Diffuse) lobes.take(l, m);
  };
  for (int l = 0; l < k; ++l) {
    textured[l] = 0;
    if (!found[l]) continue;
    const uint32_t prim = hits[l].prim;
    if (prim >= s.sphere_begin()) continue;  // a sphere or an instance's triangle: the scalar path
    material[l] = P.material[prim];
    const Material& m = s.materials[material[l]];
    if (!is_black(m.emission)) continue;  // emission and its MIS weight: the scalar path
    if constexpr (kM == MaterialSet::Any) {
      if (!lane_material(m)) continue;
      if (has_textures(m)) {
        if (!smooth_scene) continue;  // no texture coordinates: the scalar path
        textured[l] = 1;  // its material once the hit is known
        any_textured = true;
      } else {
        take_material(l, m);
      }
    } else {
      take_material(l, m);
    }
    const PathState& p = paths[ids[l]];
    ox[l] = p.ray.o.x, oy[l] = p.ray.o.y, oz[l] = p.ray.o.z;
    dx[l] = p.ray.d.x, dy[l] = p.ray.d.y, dz[l] = p.ray.d.z;
    t[l] = hits[l].t;
    const Vec3 a = P.v[0][prim], b = P.v[1][prim], c = P.v[2][prim], d = P.v[3][prim];
    ax[l] = a.x, ay[l] = a.y, az[l] = a.z, v1x[l] = b.x, v1y[l] = b.y, v1z[l] = b.z;
    v2x[l] = c.x, v2y[l] = c.y, v2z[l] = c.z, v3x[l] = d.x, v3y[l] = d.y, v3z[l] = d.z;
    const auto& dual = P.dual[prim];
    d00x[l] = dual[0][0].x, d00y[l] = dual[0][0].y, d00z[l] = dual[0][0].z;
    d01x[l] = dual[0][1].x, d01y[l] = dual[0][1].y, d01z[l] = dual[0][1].z;
    d10x[l] = dual[1][0].x, d10y[l] = dual[1][0].y, d10z[l] = dual[1][0].z;
    d11x[l] = dual[1][1].x, d11y[l] = dual[1][1].y, d11z[l] = dual[1][1].z;
    const auto& margin = P.edge_margin[prim];
    m0x[l] = margin[0].x, m0y[l] = margin[0].y, m0z[l] = margin[0].z;
    m1x[l] = margin[1].x, m1y[l] = margin[1].y, m1z[l] = margin[1].z;
    const Vec3 ng = P.normal[prim];
    ngx[l] = ng.x, ngy[l] = ng.y, ngz[l] = ng.z;
    if (smooth_scene) {
      const std::array<Vec3, 3>& vns = s.shading.normal[prim];
      for (int v = 0; v < 3; ++v) vn[v][0][l] = vns[v].x, vn[v][1][l] = vns[v].y, vn[v][2][l] = vns[v].z;
    }
    quad[l] = P.triangle[prim] ? 0.f : 1.f;
    beta_r[l] = p.beta.x, beta_g[l] = p.beta.y, beta_b[l] = p.beta.z;
    eta[l] = p.eta_scale;
    active[l] = 1;
    ++lanes_active;
  }
  if (lanes_active == 0) return;  // nothing for the lanes: every path takes shade_vertex

  // ---- make_interaction (polygons): barycentrics from the dual vectors, margins, re-interpolated point; on a
  // smooth-shaded scene, vertex_shading's normal and terminator offset (it.ns, it.lift, it.lifted).
  alignas(64) float px[N], py[N], pz[N], ex[N], ey[N], ez[N], bary[3][N];
  alignas(64) float nsx[N], nsy[N], nsz[N], lfx[N], lfy[N], lfz[N], lifted[N];
  {
    const vfloat T = ld(t), Ax = ld(ax), Ay = ld(ay), Az = ld(az);
    const vfloat qx = (ld(ox) + T * ld(dx)) - Ax, qy = (ld(oy) + T * ld(dy)) - Ay, qz = (ld(oz) + T * ld(dz)) - Az;
    vfloat b1 = (qx * ld(d00x) + qy * ld(d00y)) + qz * ld(d00z);
    vfloat b2 = (qx * ld(d01x) + qy * ld(d01y)) + qz * ld(d01z);
    const M half = b1 < 0.f && ld(quad) != 0.f;
    b1 = select(half, (qx * ld(d10x) + qy * ld(d10y)) + qz * ld(d10z), b1);
    b2 = select(half, (qx * ld(d11x) + qy * ld(d11y)) + qz * ld(d11z), b2);
    vfloat b0 = (1.f - b1) - b2;
    const vfloat Bx = select(half, ld(v2x), ld(v1x)), By = select(half, ld(v2y), ld(v1y)),
                 Bz = select(half, ld(v2z), ld(v1z));
    const vfloat Cx = select(half, ld(v3x), ld(v2x)), Cy = select(half, ld(v3y), ld(v2y)),
                 Cz = select(half, ld(v3z), ld(v2z));
    const vfloat mx = select(half, ld(m1x), ld(m0x)), my = select(half, ld(m1y), ld(m0y)),
                 mz = select(half, ld(m1z), ld(m0z));
    const M clamp = b0 < mx || b1 < my || b2 < mz;
    if (stdx::any_of(clamp)) {
      const vfloat c0 = std_max(b0, mx), c1 = std_max(b1, my), c2 = std_max(b2, mz);
      const vfloat inv = 1.f / ((c0 + c1) + c2);
      b0 = select(clamp, c0 * inv, b0), b1 = select(clamp, c1 * inv, b1), b2 = select(clamp, c2 * inv, b2);
    }
    const Vec3T<vfloat> p{(b0 * Ax + b1 * Bx) + b2 * Cx, (b0 * Ay + b1 * By) + b2 * Cy, (b0 * Az + b1 * Bz) + b2 * Cz};
    st(px, p.x), st(py, p.y), st(pz, p.z);
    if (any_textured) st(bary[0], b0), st(bary[1], b1), st(bary[2], b2);
    constexpr float g7 = gamma_bound(7);
    st(ex, g7 * ((stdx::abs(b0 * Ax) + stdx::abs(b1 * Bx)) + stdx::abs(b2 * Cx)));
    st(ey, g7 * ((stdx::abs(b0 * Ay) + stdx::abs(b1 * By)) + stdx::abs(b2 * Cy)));
    st(ez, g7 * ((stdx::abs(b0 * Az) + stdx::abs(b1 * Bz)) + stdx::abs(b2 * Cz)));
    if (smooth_scene) {
      // vertex_shading: a face whose three normals are ng (one without vertex normals) stays exactly flat.
      const Vec3T<vfloat> ng{ld(ngx), ld(ngy), ld(ngz)};
      const Vec3T<vfloat> v[3] = {{Ax, Ay, Az}, {Bx, By, Bz}, {Cx, Cy, Cz}};
      const vfloat b[3] = {b0, b1, b2};
      Vec3T<vfloat> n[3];
      M flat = M(true);
      for (int k = 0; k < 3; ++k) {
        n[k] = {ld(vn[k][0]), ld(vn[k][1]), ld(vn[k][2])};
        flat = flat && n[k].x == ng.x && n[k].y == ng.y && n[k].z == ng.z;
      }
      vfloat side;
      const Vec3T<vfloat> ns = interpolated_normal(n, b, ng, side);
      st(nsx, select(flat, ng.x, ns.x)), st(nsy, select(flat, ng.y, ns.y)), st(nsz, select(flat, ng.z, ns.z));
      const Vec3T<vfloat> lift = terminator_lift(n, v, b, p, side);
      const M up = !flat && lanes::dot(lift, ng) > 0.f;
      st(lfx, lift.x), st(lfy, lift.y), st(lfz, lift.z);
      st(lifted, select(up, vfloat(1.f), vfloat(0.f)));
    }
  }

  // ---- A textured lane's material at its hit (one lane at a time): vertex_shading's texture coordinates, then
  // material_at over the ray cone shade_vertex filters with; a normal map bends the shading normal there. A
  // metallic–roughness image that makes the lobe smooth there sends the lane to the scalar path.
  if (kM == MaterialSet::Any && any_textured)
    for (int l = 0; l < k; ++l) {
      if (!textured[l]) continue;
      const uint32_t prim = hits[l].prim;
      const PathState& p = paths[ids[l]];
      Interaction it;
      it.prim = prim;
      it.material = material[l];
      it.ng = P.normal[prim];
      it.ns = Vec3(nsx[l], nsy[l], nsz[l]);
      surface_uv(s.shading.uv[prim], bary[0][l], bary[1][l], bary[2][l], P.dual[prim][0], it);
      const Material& m = material_at<kM>(s, it, p.ray.d, p.cone_width + p.cone_spread * hits[l].t, resolved[l]);
      if (lane_material(m)) take_material(l, m);
      else active[l] = 0;
      nsx[l] = it.ns.x, nsy[l] = it.ns.y, nsz[l] = it.ns.z;
    }
  if (lobes.any()) lobes.finish();

  // ---- The shading frame (Frame::from_normal) about the front geometric normal, or on a smooth-shaded hit the
  // shading normal (shade_vertex: smooth where it.ns != it.ng); wo's z in it; the lit side's geometric normal.
  // A smooth hit whose normal shading_normal would bend (the mirror reflection of wo dips under the surface: a
  // grazing view) takes the scalar path.
  alignas(64) float sx[N], sy[N], sz[N], tx[N], ty[N], tz[N], wlz[N], nx[N], ny[N], nz[N];
  alignas(64) float fnx[N], fny[N], fnz[N], smooth[N];
  {
    const vfloat Nx = ld(ngx), Ny = ld(ngy), Nz = ld(ngz);
    const Vec3T<vfloat> wo{-ld(dx), -ld(dy), -ld(dz)};
    Vec3T<vfloat> fn{Nx, Ny, Nz};
    if (smooth_scene) {
      const Vec3T<vfloat> ns{ld(nsx), ld(nsy), ld(nsz)};
      const M bent = ns.x != Nx || ns.y != Ny || ns.z != Nz;
      const M clears = reflection_clears(ns, {Nx, Ny, Nz}, wo).clears;
      for (int l = 0; l < N; ++l)
        if (bent[l] && !clears[l]) active[l] = 0;  // shading_normal's bend: the scalar path
      fn = {select(bent, ns.x, Nx), select(bent, ns.y, Ny), select(bent, ns.z, Nz)};
      st(smooth, select(bent, vfloat(1.f), vfloat(0.f)));
    }
    st(fnx, fn.x), st(fny, fn.y), st(fnz, fn.z);
    vfloat s[3], t[3];
    frame_tangents(lanes::sign_of(fn.z), fn.x, fn.y, fn.z, s, t);
    st(sx, s[0]), st(sy, s[1]), st(sz, s[2]);
    st(tx, t[0]), st(ty, t[1]), st(tz, t[2]);
    st(wlz, lanes::dot(wo, fn));
    const M front = lanes::dot(wo, {Nx, Ny, Nz}) >= 0.f;
    st(nx, select(front, Nx, -Nx)), st(ny, select(front, Ny, -Ny)), st(nz, select(front, Nz, -Nz));
  }

  // ---- Light choice and the lanes' random numbers (scalar): lanes whose light this code cannot sample go to
  // the scalar path.
  const uint32_t choice_dim = o.dims.light_choice(depth), point_dim = o.dims.light_point(depth);
  const uint32_t dir_dim = o.dims.bsdf_direction(depth), rr_dim = o.dims.roulette(depth);
  const uint32_t lobe_dim = o.dims.bsdf_lobe(depth);
  for (int l = 0; l < k; ++l) {
    if (!active[l]) continue;
    const auto& rng = rng_of(l);
    const Vec3 ref(px[l], py[l], pz[l]);
    if (!s.lights.empty()) {
      float pmf = 0.f;
      const int li = choose_light_at(s, ref, Vec3(nx[l], ny[l], nz[l]), rng.get_1d(choice_dim), pmf);
      if (li < 0) {
        active[l] = 0;  // no light reaches it: the scalar path
        continue;
      }
      const Light& light = s.lights[li];
      if (!parallelogram_by_area(P, light, ref)) {
        // Any other light (spherical rectangles, triangles, spheres, punctual and infinite lights): sample_li's
        // own sample, as sample_lights and sample_direct take it; the lanes weigh it like the parallelogram's.
        general[l] = 1.f;
        LightSample ls;
        if (sample_li<F>(s, light, {ref, Vec3(nx[l], ny[l], nz[l]), hits[l].prim}, rng.get_2d(point_dim), ls, o.mis)) {
          ls.pdf *= pmf;
          light_ok[l] = ls.pdf > 0.f && !is_black(ls.Le) ? 1.f : 0.f;
          g_wx[l] = ls.wi.x, g_wy[l] = ls.wi.y, g_wz[l] = ls.wi.z;
          g_px[l] = ls.p.x, g_py[l] = ls.p.y, g_pz[l] = ls.p.z;
          g_pdf[l] = ls.pdf;
          g_inf[l] = ls.dist == kInfinity ? 1.f : 0.f;
          g_delta[l] = ls.delta ? 1.f : 0.f;
          le_r[l] = ls.Le.x, le_g[l] = ls.Le.y, le_b[l] = ls.Le.z;
        }
        light_prim[l] = ls.prim;
      } else {
        const uint32_t lp = light.prim;
        // sample_li: a one-sided light seen from behind gives no sample.
        light_ok[l] = light.two_sided || glm::dot(P.normal[lp], ref - P.v[0][lp]) > 0.f ? 1.f : 0.f;
        const Vec3 la = P.v[0][lp], lb = P.v[1][lp], lc = P.v[2][lp], ln = P.normal[lp];
        la_x[l] = la.x, la_y[l] = la.y, la_z[l] = la.z, lb_x[l] = lb.x, lb_y[l] = lb.y, lb_z[l] = lb.z;
        lc_x[l] = lc.x, lc_y[l] = lc.y, lc_z[l] = lc.z, ln_x[l] = ln.x, ln_y[l] = ln.y, ln_z[l] = ln.z;
        l_area[l] = light.area;
        l_pmf[l] = pmf;
        le_r[l] = light.emission.x, le_g[l] = light.emission.y, le_b[l] = light.emission.z;
        two_sided[l] = light.two_sided ? 1.f : 0.f;
        light_prim[l] = lp;
        const Vec2 u = rng.get_2d(point_dim);
        ux[l] = u.x, uy[l] = u.y;
      }
    }
    const Vec2 bu = rng.get_2d(dir_dim);
    bux[l] = bu.x, buy[l] = bu.y;
    if (lobes.layered[l] != 0.f || lobes.metal[l] != 0.f) u_lobe[l] = rng.get_1d(lobe_dim);
    if (roulette) u_rr[l] = rng.get_1d(rr_dim);
  }

  // ---- The light sample (sample_li by area, sample_lights' choice probability), the BSDF there, the shadow ray
  // and its contribution.
  const Vec3T<vfloat> P_{ld(px), ld(py), ld(pz)}, E_{ld(ex), ld(ey), ld(ez)}, NG{ld(ngx), ld(ngy), ld(ngz)};
  const Vec3T<vfloat> FN{ld(fnx), ld(fny), ld(fnz)};  // the shading frame's z
  // offset_ray_origin(it, back): a lifted hit leaves its front from p + lift (vertex_shading).
  const auto spawn_point = [&](const M& back) -> Vec3T<vfloat> {
    if (!smooth_scene) return P_;
    const M up = ld(lifted) != 0.f && !back;
    return {select(up, P_.x + ld(lfx), P_.x), select(up, P_.y + ld(lfy), P_.y), select(up, P_.z + ld(lfz), P_.z)};
  };
  const vfloat Wz = ld(wlz);
  const vfloat Fr = lambert_f(ld(alb_r)), Fg = lambert_f(ld(alb_g)), Fb = lambert_f(ld(alb_b));
  // The lanes with another lobe: wo in the shading frame mirrored to the front (bsdf_value<Any> and
  // bsdf_sample<Any> mirror wo and wi when wo is below), and E(μo) there.
  const bool any_lobe = kM == MaterialSet::Any && lobes.any();
  const M Gl = any_lobe ? lobes.lobe_mask() : M(false);
  if (any_lobe) {
    const Vec3T<vfloat> wo{-ld(dx), -ld(dy), -ld(dz)};
    lobes.at({lanes::dot(wo, {ld(sx), ld(sy), ld(sz)}), lanes::dot(wo, {ld(tx), ld(ty), ld(tz)}),
              select(Wz < 0.f, -Wz, Wz)});
  }
  const vfloat Br = ld(beta_r), Bg = ld(beta_g), Bb = ld(beta_b);
  alignas(64) float traced[N], shadow_ok[N];
  alignas(64) float so_x[N], so_y[N], so_z[N], sd_x[N], sd_y[N], sd_z[N], st_max[N], sc_r[N], sc_g[N], sc_b[N];
  {
    // sample_polygon_area of a parallelogram: a + u.x·(b − a) + u.y·(c − b).
    const vfloat Ux = ld(ux), Uy = ld(uy);
    const vfloat Lax = ld(la_x), Lay = ld(la_y), Laz = ld(la_z), Lbx = ld(lb_x), Lby = ld(lb_y), Lbz = ld(lb_z);
    // Lanes with another light (G) take the scalar sample's point, direction and density instead.
    const M G = ld(general) != 0.f;
    const vfloat lpx = select(G, ld(g_px), (Lax + Ux * (Lbx - Lax)) + Uy * (ld(lc_x) - Lbx));
    const vfloat lpy = select(G, ld(g_py), (Lay + Ux * (Lby - Lay)) + Uy * (ld(lc_y) - Lby));
    const vfloat lpz = select(G, ld(g_pz), (Laz + Ux * (Lbz - Laz)) + Uy * (ld(lc_z) - Lbz));
    const vfloat ddx = lpx - P_.x, ddy = lpy - P_.y, ddz = lpz - P_.z;
    const vfloat dist2 = (ddx * ddx + ddy * ddy) + ddz * ddz;
    const vfloat dist = stdx::sqrt(dist2);
    const vfloat wix = select(G, ld(g_wx), ddx / dist), wiy = select(G, ld(g_wy), ddy / dist),
                 wiz = select(G, ld(g_wz), ddz / dist);
    const vfloat Lnx = ld(ln_x), Lny = ld(ln_y), Lnz = ld(ln_z);
    const vfloat cos_l = stdx::abs((Lnx * wix + Lny * wiy) + Lnz * wiz);
    const vfloat c_e = (Lnx * -wix + Lny * -wiy) + Lnz * -wiz;  // area_light_emission(n, −wi)
    const M le_on = G || c_e > 0.f || (ld(two_sided) != 0.f && c_e < 0.f);
    vfloat pdf = dist2 / (cos_l * ld(l_area));
    M ok = ld(light_ok) != 0.f && dist2 > 0.f && cos_l != 0.f && stdx::isfinite(pdf);
    pdf *= ld(l_pmf);
    const vfloat Ler = ld(le_r), Leg = ld(le_g), Leb = ld(le_b);
    ok = ok && pdf > 0.f && le_on && !(Ler == 0.f && Leg == 0.f && Leb == 0.f);
    // sample_lights and sample_direct's tests for another light were made with its sample (light_ok).
    pdf = select(G, ld(g_pdf), pdf);
    ok = (G && ld(light_ok) != 0.f) || (!G && ok);
    // wi's z in the shading frame.
    const vfloat wil_z = (wix * FN.x + wiy * FN.y) + wiz * FN.z;
    // bsdf_eval<Lambert>: ρ/π where wo and wi are on one side (their cosines' product is positive); bsdf_eval<Any>
    // mirrors both to the front first (then both are strictly positive), which differs where the product
    // underflows.
    M same_side;
    if constexpr (kM == MaterialSet::Lambert) same_side = Wz * wil_z > 0.f;
    else same_side = (Wz > 0.f && wil_z > 0.f) || (Wz < 0.f && wil_z < 0.f);
    // The BSDF towards wi: ρ/π, or the other lobe's f and pdf (lane_lobes.h, as bsdf_value<Any> evaluates it).
    const vfloat cos_abs = stdx::abs(wil_z);
    vfloat nf_r = Fr, nf_g = Fg, nf_b = Fb;
    vfloat bpdf = select(same_side, cosine_hemisphere_pdf(cos_abs), vfloat(0.f));
    if (any_lobe) {
      const Vec3T<vfloat> wi_l{(wix * ld(sx) + wiy * ld(sy)) + wiz * ld(sz), (wix * ld(tx) + wiy * ld(ty)) + wiz * ld(tz),
                               select(Wz < 0.f, -wil_z, wil_z)};
      Vec3T<vfloat> f;
      vfloat gpdf;
      lobes.value(wi_l, f, gpdf);
      const vfloat zero(0.f);
      nf_r = select(Gl, select(same_side, f.x, zero), Fr);
      nf_g = select(Gl, select(same_side, f.y, zero), Fg);
      nf_b = select(Gl, select(same_side, f.z, zero), Fb);
      bpdf = select(Gl, select(same_side, gpdf, zero), bpdf);
    }
    ok = ok && same_side && !(nf_r == 0.f && nf_g == 0.f && nf_b == 0.f);
    st(traced, select(ok, vfloat(1.f), vfloat(0.f)));
    // shadow_segment leaves on the side of the shading frame wi is on (sample_direct).
    const M back = wil_z < 0.f;
    const Vec3T<vfloat> origin = lanes::offset_point(spawn_point(back), E_, NG, back);
    const vfloat tlx = lpx - origin.x, tly = lpy - origin.y, tlz = lpz - origin.z;
    const vfloat sdist = stdx::sqrt((tlx * tlx + tly * tly) + tlz * tlz);
    // shadow_segment: towards a light at infinity the ray is unbounded, along wi.
    const M at_infinity = ld(g_inf) != 0.f;
    const vfloat t_max = select(at_infinity, vfloat(kInfinity), sdist * kShadowRayShorten);
    // power_heuristic(ls.pdf, bsdf_pdf); a punctual light has no MIS partner.
    const vfloat w = o.mis ? select(ld(g_delta) != 0.f, vfloat(1.f), power_heuristic(pdf, bpdf)) : vfloat(1.f);
    const vfloat scale = (cos_abs * w) / pdf;
    st(shadow_ok, select(ok && t_max > 0.f, vfloat(1.f), vfloat(0.f)));
    st(so_x, origin.x), st(so_y, origin.y), st(so_z, origin.z);
    st(sd_x, select(at_infinity, wix, tlx / sdist)), st(sd_y, select(at_infinity, wiy, tly / sdist));
    st(sd_z, select(at_infinity, wiz, tlz / sdist));
    st(st_max, t_max);
    st(sc_r, ((Br * nf_r) * select(le_on, Ler, vfloat(0.f))) * scale);
    st(sc_g, ((Bg * nf_g) * select(le_on, Leg, vfloat(0.f))) * scale);
    st(sc_b, ((Bb * nf_b) * select(le_on, Leb, vfloat(0.f))) * scale);
  }

  // ---- The BSDF sample (cosine-weighted, mirrored to wo's side), the throughput, roulette, the next ray.
  alignas(64) float goes_on[N], nb_r[N], nb_g[N], nb_b[N], b_pdf[N], no_x[N], no_y[N], no_z[N];
  alignas(64) float nd_x[N], nd_y[N], nd_z[N];
  {
    const M flip = Wz < 0.f;
    M ok = select(flip, -Wz, Wz) > 0.f && !(ld(alb_r) == 0.f && ld(alb_g) == 0.f && ld(alb_b) == 0.f);
    // sample_cosine_hemisphere: the concentric disk (sampling.h), then z = √max(0, 1 − x² − y²).
    const Vec3T<vfloat> local = cosine_hemisphere(ld(bux), ld(buy));
    vfloat dxs = local.x, dys = local.y, wz0 = local.z;
    ok = ok && wz0 > 0.f;
    vfloat pdf = cosine_hemisphere_pdf(wz0);
    vfloat fr = Fr, fg = Fg, fb = Fb;
    if (any_lobe) {
      // metallic_roughness_sample, plastic_sample and conductor_sample: the visible normal's reflection or the
      // cosine direction, as each lane's lobe choice says; then f and pdf of the direction.
      Vec3T<vfloat> wi, f;
      vfloat gpdf;
      lobes.sample(u_lobe, bux, buy, {dxs, dys, wz0}, wi, f, gpdf);
      const M g_ok = ld(lobes.wo[2]) > 0.f && wi.z > 0.f && gpdf > 0.f;
      ok = (Gl && g_ok) || (!Gl && ok);
      dxs = select(Gl, wi.x, dxs), dys = select(Gl, wi.y, dys), wz0 = select(Gl, wi.z, wz0);
      pdf = select(Gl, gpdf, pdf);
      fr = select(Gl, f.x, fr), fg = select(Gl, f.y, fg), fb = select(Gl, f.z, fb);
    }
    const vfloat wz = select(flip, -wz0, wz0);
    ok = ok && pdf > 0.f && wz != 0.f;
    const vfloat k_scale = stdx::abs(wz) / pdf;
    vfloat nbr = Br * (fr * k_scale), nbg = Bg * (fg * k_scale), nbb = Bb * (fb * k_scale);
    // frame.to_world: s·x + t·y + n·z.
    const vfloat wwx = (ld(sx) * dxs + ld(tx) * dys) + FN.x * wz;
    const vfloat wwy = (ld(sy) * dxs + ld(ty) * dys) + FN.y * wz;
    const vfloat wwz = (ld(sz) * dxs + ld(tz) * dys) + FN.z * wz;
    if (roulette) {
      const vfloat q = roulette_survival(std_max(nbr, std_max(nbg, nbb)) * ld(eta));
      ok = ok && ld(u_rr) < q;
      nbr = nbr / q, nbg = nbg / q, nbb = nbb / q;
    }
    ok = ok && !(nbr == 0.f && nbg == 0.f && nbb == 0.f) && stdx::isfinite(nbr) && stdx::isfinite(nbg) &&
         stdx::isfinite(nbb);
    st(goes_on, select(ok, vfloat(1.f), vfloat(0.f)));
    st(nb_r, nbr), st(nb_g, nbg), st(nb_b, nbb);
    st(b_pdf, pdf);
    // The side it leaves on: wi's in the world on a flat hit, the shading frame's on a smooth one (shade_vertex).
    M back = lanes::dot({wwx, wwy, wwz}, NG) < 0.f;
    if (smooth_scene) {
      const M bent = ld(smooth) != 0.f;
      back = (bent && wz < 0.f) || (!bent && back);
    }
    const Vec3T<vfloat> origin = lanes::offset_point(spawn_point(back), E_, NG, back);
    st(no_x, origin.x), st(no_y, origin.y), st(no_z, origin.z);
    st(nd_x, wwx), st(nd_y, wwy), st(nd_z, wwz);
  }

  // ---- Write back (scalar, lane order).
  for (int l = 0; l < k; ++l) {
    if (!active[l]) continue;
    out.handled[l] = true;
    PathState& p = paths[ids[l]];
    p.cone_width += p.cone_spread * hits[l].t;  // the ray cone a texture further down the path is filtered over
    if (p.features.out) [[unlikely]] {  // the first hit of a film with feature buffers: shade_vertex's own call
      Interaction it;
      it.p = Vec3(px[l], py[l], pz[l]);
      it.ng = Vec3(ngx[l], ngy[l], ngz[l]);
      it.ns = smooth_scene ? Vec3(nsx[l], nsy[l], nsz[l]) : it.ng;
      p.features.at_vertex<kM>(static_cast<int>(depth), p.ray.o, it, -p.ray.d, *mats[l], false, p.L);
    }
    if (traced[l] != 0.f) ++count.rays;
    if (shadow_ok[l] != 0.f) {
      out.shadow[l] = true;
      out.shadow_ray[l] = {{Vec3(so_x[l], so_y[l], so_z[l]), Vec3(sd_x[l], sd_y[l], sd_z[l])},
                           st_max[l], hits[l].prim, light_prim[l], Rgb(sc_r[l], sc_g[l], sc_b[l])};
    }
    if (goes_on[l] == 0.f) continue;
    out.continues[l] = true;
    p.beta = Rgb(nb_r[l], nb_g[l], nb_b[l]);
    p.count_emission = false;
    p.prev_bsdf_pdf = b_pdf[l];
    p.prev_p = Vec3(px[l], py[l], pz[l]);
    p.prev_n = Vec3(nx[l], ny[l], nz[l]);
    p.ray = {Vec3(no_x[l], no_y[l], no_z[l]), Vec3(nd_x[l], nd_y[l], nd_z[l])};
    p.skip = hits[l].prim;
    p.depth = static_cast<int>(depth) + 1;
  }
}

PT_SIMD_SQRT_WARNINGS_ON

}  // namespace integrator_detail
}  // namespace pt
