// The shading lanes' lobes (shading_lanes.h), besides the Lambert lobe the lanes shade themselves: per lane, the
// coupled lobe the plastic and glTF's metallic–roughness material share (materials/layered_lobe.h; a smooth layer's
// reflection is a Dirac lobe over the base), the rough conductor (materials/conductor.h) or the subsurface BRDF
// (materials/subsurface.h, sampled as Lambert's) or rough glass (materials/dielectric.h: reflection and refraction,
// its light sample on either side), each written once over the number type, or a Dirac lobe: the
// mirror, the smooth conductor or smooth glass (materials/dielectric.h), which are only sampled; so that a lane
// rounds as bsdf_value<Any> and bsdf_sample<Any> do for one path. Structure of arrays: a lane's material is read one
// lane at a time (take), then each step runs on all lanes at once, every lane selecting its own lobe's result; a
// kind of lobe no lane holds costs nothing. What stays one lane at a time: the directional-albedo table lookups
// E(μ) and the visible-normal sample (Heitz's sampler calls sin and cos).
#pragma once
#include <cstdint>

#include "core/lanes.h"
#include "core/simd_sqrt_warnings.h"
#include "materials/conductor.h"
#include "materials/dielectric.h"
#include "materials/fresnel.h"
#include "materials/metallic_roughness.h"
#include "materials/plastic.h"
#include "materials/subsurface.h"

namespace pt {
namespace integrator_detail {

PT_SIMD_SQRT_WARNINGS_OFF  // every lane is computed here
struct LaneLobes {
  static constexpr int N = kLanes;
  using M = vmask;

  // Per lane (0 or 1): the coupled lobe, the plastic's exact Fresnel in it, the rough conductor, a conductor's
  // complex index; a Dirac lobe, and which: smooth glass, or a mirror's constant tint (else a smooth conductor).
  alignas(64) float layered[N], coat[N], metal[N], complex[N], dirac[N], glass[N], tint[N];
  // Per lane (0 or 1): a smooth layer over the coupled lobe's base (its reflection a Dirac lobe); and, after
  // sample, whether the lane took that reflection.
  alignas(64) float smooth_layer[N], layer_dirac[N];
  // Per lane (0 or 1): the subsurface BRDF, whose α′ is `colour` and index eta[0]; its R_d, ss_norm and phase
  // asymmetry g (written into every lane at the packet's first subsurface lane).
  alignas(64) float sss[N], rd[3][N], norm[3][N], hg[N];
  // Per lane (0 or 1): rough glass, whose index is eta[0] and roughness α; the relative index η for wo's side (at:
  // the index entering from the front, its inverse leaving from the back).
  alignas(64) float rough_glass[N], glass_eta[N];
  // The lobe's parameters: f0 (the conductor's albedo); the base colour (the layered lobe's diffuse colour, the
  // conductor's F_ms); the coat's index, the conductor's complex index and the glass's index (eta[0]); the base's
  // luminance; 1 − E_avg (layered) or E_avg (conductor); α. A Dirac lobe's f0 is its tint or Schlick's F0.
  alignas(64) float f0[3][N], colour[3][N], eta[3][N], k[3][N], lum[N], avg[N], alpha[N];
  alignas(64) float e_o[N], wo[3][N];  // E(μo), and wo in the shading frame mirrored to the front
  const Material* material[N];
  bool any_layered = false, any_coat = false, any_metal = false, any_complex = false, any_dirac = false,
       any_glass = false;
  bool any_reflector = false, any_reflector_complex = false;  // a Dirac mirror or conductor; one with a complex index
  bool any_smooth_layer = false;
  bool any_sss = false;
  bool any_rough_glass = false;

  bool any() const { return any_rough() || any_dirac; }
  bool any_rough() const { return any_layered || any_metal || any_sss || any_rough_glass; }  // with a light sample
  M lobe_mask() const {  // the lanes of those lobes
    return lanes_of(layered) != 0.f || lanes_of(metal) != 0.f || lanes_of(sss) != 0.f || lanes_of(rough_glass) != 0.f;
  }
  M dirac_mask() const { return lanes_of(dirac) != 0.f; }
  M rough_glass_mask() const { return lanes_of(rough_glass) != 0.f; }

  // Before the first take: no lobe in any lane.
  void clear() {
    for (float* a : {layered, coat, metal, complex, dirac, glass, tint, smooth_layer, sss, rough_glass})
      st(a, vfloat(0.f));
  }

  // Lane l shades with m, a plastic or glTF material, a rough conductor, a subsurface material, rough glass, or a
  // mirror, smooth conductor or smooth glass (wavefront.h: layered_lane_material, conductor_lane_material,
  // sss_lane_material, rough_glass_lane_material, dirac_lane_material), which outlives the lanes.
  void take(int l, const Material& m) {
    if (!any()) defaults();
    material[l] = &m;
    if (m.type == MaterialType::Conductor && !effectively_smooth(m.alpha)) {
      const ConductorLobe<float> g = conductor_lobe(m);
      metal[l] = 1.f;
      complex[l] = m.complex_ior ? 1.f : 0.f;
      store(l, g.f0, f0), store(l, g.f_ms, colour), store(l, g.eta, eta), store(l, g.k, k);
      avg[l] = g.e_avg, alpha[l] = g.alpha;
      any_metal = true;
      any_complex = any_complex || m.complex_ior;
    } else if (m.type == MaterialType::Plastic || m.type == MaterialType::MetallicRoughness) {
      const bool plastic = m.type == MaterialType::Plastic;
      const LayeredLobe<float> g = plastic ? plastic_lobe(m) : gltf_lobe(m, gltf_f0(m));
      layered[l] = 1.f;
      coat[l] = plastic ? 1.f : 0.f;
      if (effectively_smooth(m.alpha)) smooth_layer[l] = 1.f, any_smooth_layer = true;
      store(l, g.f0, f0), store(l, g.diffuse, colour);
      eta[0][l] = g.eta, lum[l] = g.diffuse_lum, avg[l] = g.one_minus_avg, alpha[l] = g.alpha;
      any_layered = true;
      any_coat = any_coat || plastic;
    } else if (m.type == MaterialType::Subsurface) {
      take_sss(l, m);
    } else if (m.type == MaterialType::Dielectric && !effectively_smooth(m.alpha)) {
      rough_glass[l] = 1.f;
      eta[0][l] = m.ior, alpha[l] = m.alpha;
      any_rough_glass = true;
    } else {
      take_dirac(l, m);
    }
  }


  // At the first take: harmless parameters in every lane (the lanes compute every lane), which take overwrites
  // with those its lobe uses; the rest keep these (a layered lane's η[1], η[2] and k, a conductor's base
  // luminance, a glass lane's f0, ...).
  void defaults() {
    st(lum, vfloat(0.f)), st(avg, vfloat(1.f)), st(alpha, vfloat(1.f));
    for (int c = 0; c < 3; ++c)
      st(f0[c], vfloat(0.04f)), st(colour[c], vfloat(0.f)), st(eta[c], vfloat(1.5f)), st(k[c], vfloat(0.f));
  }

  // E(μ) of lane l's lobe: the plastic's coat, glTF's layer, the conductor's GGX lobe.
  float albedo_at(int l, float mu) const {
    const Material& m = *material[l];
    if (metal[l] != 0.f) return m.energy(mu);
    return coat[l] != 0.f ? plastic_coat_albedo(m, mu) : gltf_layer_albedo(m, mu);
  }

  // The lobes at wo (the shading frame's, mirrored to the front; `below`: wo was under the surface): E(μo), one
  // lane at a time, and rough glass's η for wo's side (dielectric_eta).
  void at(const lanes::Vec3T<vfloat>& w, const M& below) {
    st(wo[0], w.x), st(wo[1], w.y), st(wo[2], w.z);
    for (int l = 0; l < N; ++l) e_o[l] = layered[l] != 0.f || metal[l] != 0.f ? albedo_at(l, wo[2][l]) : 0.f;
    if (any_rough_glass) st(glass_eta, select(below, 1.f / lanes_of(eta[0]), lanes_of(eta[0])));
  }

  // f and pdf of each lane's lobe towards wi (the shading frame's, mirrored as wo is), as bsdf_value<Any> evaluates it
  // for wo.z > 0 and wi.z > 0 (the caller masks the rest), and for rough glass on either side. Lanes without a lobe
  // get 0. `glass`: evaluate rough glass (sample has its own f and pdf).
  void value(const lanes::Vec3T<vfloat>& wi, lanes::Vec3T<vfloat>& f, vfloat& pdf, bool glass = true) const {
    alignas(64) float wz[N], e_i[N];
    st(wz, wi.z);
    for (int l = 0; l < N; ++l) e_i[l] = layered[l] != 0.f || metal[l] != 0.f ? albedo_at(l, wz[l]) : 0.f;
    const lanes::Vec3T<vfloat> w{lanes_of(wo[0]), lanes_of(wo[1]), lanes_of(wo[2])};
    const vfloat eo = lanes_of(e_o), ei = lanes_of(e_i);
    f = {vfloat(0.f), vfloat(0.f), vfloat(0.f)};
    pdf = vfloat(0.f);
    if (any_layered) {
      const LayeredLobe<vfloat> g = layered_lobe();
      if (any_coat) layered_value<LayerFresnel::Either, true, true>(g, eo, ei, w, wi, f, pdf);
      else layered_value<LayerFresnel::Schlick, true, true>(g, eo, ei, w, wi, f, pdf);
    }
    if (any_sss) {  // subsurface_eval and subsurface_pdf (the cosine's)
      const SubsurfaceLobe<vfloat> b{vec(colour), vec(rd), vec(norm), lanes_of(hg), lanes_of(eta[0])};
      const lanes::Vec3T<vfloat> fs = subsurface_f(b, w, wi);
      const M on = lanes_of(sss) != 0.f;
      f = {select(on, fs.x, f.x), select(on, fs.y, f.y), select(on, fs.z, f.z)};
      pdf = select(on, cosine_hemisphere_pdf(wi.z), pdf);
    }
    if (any_metal) {
      const ConductorLobe<vfloat> g = conductor_lobe_lanes();
      lanes::Vec3T<vfloat> fc;
      vfloat pc;
      if (any_complex) conductor_lobe_value<ConductorFresnel::Either, true, true>(g, eo, ei, w, wi, fc, pc);
      else conductor_lobe_value<ConductorFresnel::Schlick, true, true>(g, eo, ei, w, wi, fc, pc);
      const M on = lanes_of(metal) != 0.f;
      f = {select(on, fc.x, f.x), select(on, fc.y, f.y), select(on, fc.z, f.z)};
      pdf = select(on, pc, pdf);
    }
    if (glass && any_rough_glass) {  // dielectric_value
      vfloat fg, pg;
      dielectric_lobe_value<true, true>(w, wi, lanes_of(alpha), lanes_of(glass_eta), fg, pg);
      const M on = rough_glass_mask();
      f = {select(on, fg, f.x), select(on, fg, f.y), select(on, fg, f.z)};
      pdf = select(on, pg, pdf);
    }
  }

  // The lobes' samples (metallic_roughness_sample, plastic_sample, conductor_sample, subsurface_sample,
  // dielectric_sample): per lane with wo.z > 0, the visible-normal reflection or the cosine direction `cosine`
  // (sample_cosine_hemisphere of the same u), as the lobe choice u_lobe says (the subsurface BRDF's: the cosine
  // direction); then f and pdf there. wi is (0, 0, 1) where a lane has no lobe or wo.z ≤ 0. A smooth layer's
  // reflection (layer_dirac, set here) is its Dirac lobe: wi = (−wo.x, −wo.y, wo.z), f = F/μ with the layer's
  // Fresnel F at μ = wo.z, pdf = the layer's probability. Rough glass reflects about its visible normal or refracts
  // through it (`refracts`), its f and pdf from that normal (dielectric_lobe_sample). `ok`: the lanes of these lobes
  // with a sample, as their scalar functions return one for wo.z > 0 (wi on its lobe's side, pdf > 0, a smooth
  // layer's F not black, glass's f and pdf finite).
  void sample(const float* u_lobe, const float* ux, const float* uy, const lanes::Vec3T<vfloat>& cosine,
              lanes::Vec3T<vfloat>& wi, lanes::Vec3T<vfloat>& f, vfloat& pdf, M& ok, M& refracts) {
    alignas(64) float p[N], cx[N], cy[N], cz[N], gx[N], gy[N], gz[N], mx[N], my[N], mz[N];
    // The probability of the reflection's visible normal: the layer's share, or 1 − the conductor's cosine share.
    const vfloat eo = lanes_of(e_o), w_z = lanes_of(wo[2]);
    vfloat p_vndf(0.f);
    if (any_layered) {
      const LayeredLobe<vfloat> g = layered_lobe();
      p_vndf = any_coat ? layer_prob<LayerFresnel::Either>(g, w_z, eo) : layer_prob<LayerFresnel::Schlick>(g, w_z, eo);
    }
    st(p, p_vndf);
    st(cx, cosine.x), st(cy, cosine.y), st(cz, cosine.z);
    if (any_smooth_layer) st(layer_dirac, vfloat(0.f));
    for (int l = 0; l < N; ++l) {
      gx[l] = gy[l] = mx[l] = my[l] = 0.f;
      gz[l] = mz[l] = 1.f;
      if (any_rough_glass && rough_glass[l] != 0.f) {  // its visible normal (dielectric_sample_up)
        if (!(wo[2][l] > 0.f)) continue;
        const Vec3 m = ggx_sample_vndf(Vec3(wo[0][l], wo[1][l], wo[2][l]), alpha[l], Vec2(ux[l], uy[l]));
        mx[l] = m.x, my[l] = m.y, mz[l] = m.z;
        continue;
      }
      const bool subsurface = any_sss && sss[l] != 0.f;
      if ((layered[l] == 0.f && metal[l] == 0.f && !subsurface) || !(wo[2][l] > 0.f)) continue;
      // conductor_sample: the cosine lobe where u < p_ms; the layered lobes: the reflection where u < p_s.
      const bool vndf = !subsurface &&
                        (metal[l] != 0.f ? !(u_lobe[l] < conductor_ms_prob(avg[l], e_o[l])) : u_lobe[l] < p[l]);
      const Vec3 w(wo[0][l], wo[1][l], wo[2][l]);
      Vec3 d(cx[l], cy[l], cz[l]);
      if (vndf && any_smooth_layer && smooth_layer[l] != 0.f) {
        d = Vec3(-w.x, -w.y, w.z);
        layer_dirac[l] = 1.f;
      } else if (vndf) {
        d = reflect(-w, ggx_sample_vndf(w, alpha[l], Vec2(ux[l], uy[l])));
      }
      gx[l] = d.x, gy[l] = d.y, gz[l] = d.z;
    }
    wi = {lanes_of(gx), lanes_of(gy), lanes_of(gz)};
    value(wi, f, pdf, false);
    M layer_ok(true);
    if (any_smooth_layer) {
      const M D = lanes_of(layer_dirac) != 0.f;
      const LayeredLobe<vfloat> g = layered_lobe();
      const lanes::Vec3T<vfloat> F = any_coat ? layer_fresnel<LayerFresnel::Either>(g, w_z)
                                              : layer_fresnel<LayerFresnel::Schlick>(g, w_z);
      f = {select(D, F.x / wi.z, f.x), select(D, F.y / wi.z, f.y), select(D, F.z / wi.z, f.z)};
      pdf = select(D, p_vndf, pdf);
      layer_ok = !D || !(F.x == 0.f && F.y == 0.f && F.z == 0.f);
    }
    ok = w_z > 0.f && wi.z > 0.f && pdf > 0.f && layer_ok;
    refracts = M(false);
    if (!any_rough_glass) return;
    const M RG = rough_glass_mask();
    const lanes::Vec3T<vfloat> w{lanes_of(wo[0]), lanes_of(wo[1]), w_z};
    lanes::Vec3T<vfloat> wg;
    vfloat fg, pg;
    M through;
    const M g_ok = dielectric_lobe_sample(w, {lanes_of(mx), lanes_of(my), lanes_of(mz)}, lanes_of(u_lobe),
                                          lanes_of(alpha), lanes_of(glass_eta), true, wg, fg, pg, through);
    wi = {select(RG, wg.x, wi.x), select(RG, wg.y, wi.y), select(RG, wg.z, wi.z)};
    f = {select(RG, fg, f.x), select(RG, fg, f.y), select(RG, fg, f.z)};
    pdf = select(RG, pg, pdf);
    ok = (RG && w_z > 0.f && g_ok) || (!RG && ok);
    refracts = RG && through;
  }

  // The Dirac lobes' samples, as bsdf_sample<Any> takes them with wo mirrored to the front (`below`: wo was
  // under the surface), for the lanes of dirac_mask (the others compute harmless values):
  // - mirror_sample and conductor_sample's smooth lobe: wi = (−wo.x, −wo.y, wo.z), f = F/μ with F the mirror's
  //   tint or the conductor's Fresnel at μ = wo.z (Schlick's or the complex index's), pdf 1; none where F is black;
  // - dielectric_sample's smooth interface: η = the index for wo's side (below: 1/ior); reflection with
  //   probability F(μ, η) (u_lobe < F, or total internal reflection), f = F/μ, pdf F (none where F = 0); else
  //   the refraction about z, f = (1 − F)/(|wt.z| η²) (radiance), pdf 1 − F, and `eta_t` = η (1 elsewhere).
  // `ok`: a sample where wo.z > 0.
  void sample_dirac(const float* u_lobe, const M& below, lanes::Vec3T<vfloat>& wi, lanes::Vec3T<vfloat>& f,
                    vfloat& pdf, M& transmits, vfloat& eta_t, M& ok) const {
    const lanes::Vec3T<vfloat> w{lanes_of(wo[0]), lanes_of(wo[1]), lanes_of(wo[2])};
    const vfloat mu = w.z;
    wi = {-w.x, -w.y, w.z};
    f = {vfloat(0.f), vfloat(0.f), vfloat(0.f)};
    pdf = vfloat(1.f);
    ok = M(false);
    if (any_reflector) {  // the mirror's and the smooth conductor's reflectance
      const ConductorLobe<vfloat> g = conductor_lobe_lanes();
      lanes::Vec3T<vfloat> F = any_reflector_complex ? conductor_fresnel<ConductorFresnel::Either>(g, mu)
                                                     : conductor_fresnel<ConductorFresnel::Schlick>(g, mu);
      const M tinted = lanes_of(tint) != 0.f;
      F = {select(tinted, g.f0.x, F.x), select(tinted, g.f0.y, F.y), select(tinted, g.f0.z, F.z)};
      f = {F.x / wi.z, F.y / wi.z, F.z / wi.z};
      ok = mu > 0.f && !(F.x == 0.f && F.y == 0.f && F.z == 0.f);
    }
    transmits = M(false);
    eta_t = vfloat(1.f);
    if (!any_glass) return;
    const M G = lanes_of(glass) != 0.f;
    const vfloat ior = lanes_of(eta[0]);
    const vfloat eta_g = select(below, 1.f / ior, ior);
    const vfloat fd = fresnel_dielectric(mu, eta_g);
    lanes::Vec3T<vfloat> wt;
    const M refracts = refract_t(w, {vfloat(0.f), vfloat(0.f), vfloat(1.f)}, eta_g, wt);
    const M reflects = lanes_of(u_lobe) < fd || !refracts;
    const vfloat fr = fd / wi.z;
    const vfloat ft = (1.f - fd) / ((-wt.z * eta_g) * eta_g);
    const vfloat fg = select(reflects, fr, ft);
    f = {select(G, fg, f.x), select(G, fg, f.y), select(G, fg, f.z)};
    pdf = select(G, select(reflects, fd, 1.f - fd), pdf);
    ok = (G && mu > 0.f && ((reflects && fd > 0.f) || (!reflects && wt.z < 0.f))) || (!G && ok);
    transmits = G && !reflects;
    wi = {select(transmits, wt.x, wi.x), select(transmits, wt.y, wi.y), select(transmits, wt.z, wi.z)};
    eta_t = select(transmits, eta_g, eta_t);
  }

 private:
  // The subsurface BRDF in lane l; at the packet's first, harmless R_d, ss_norm and g in every lane.
  void take_sss(int l, const Material& m) {
    if (!any_sss) {
      for (int c = 0; c < 3; ++c) st(rd[c], vfloat(0.f)), st(norm[c], vfloat(1.f));
      st(hg, vfloat(0.f));
      any_sss = true;
    }
    sss[l] = 1.f;
    store(l, lanes::of(m.albedo), colour), store(l, lanes::of(m.rd), rd), store(l, lanes::of(m.ss_norm), norm);
    eta[0][l] = m.ior, hg[l] = m.g;
  }
  // The mirror, the smooth conductor or smooth glass in lane l.
  void take_dirac(int l, const Material& m) {
    dirac[l] = 1.f;
    any_dirac = true;
    if (m.type == MaterialType::Dielectric) {
      glass[l] = 1.f;
      eta[0][l] = m.ior;
      any_glass = true;
      return;
    }
    store(l, lanes::of(m.albedo), f0);
    any_reflector = true;
    if (m.type == MaterialType::Mirror) {
      tint[l] = 1.f;
      return;
    }
    complex[l] = m.complex_ior ? 1.f : 0.f;  // the smooth conductor
    store(l, lanes::of(m.eta), eta), store(l, lanes::of(m.k), k);
    any_reflector_complex = any_reflector_complex || m.complex_ior;
  }
  [[gnu::always_inline]] static vfloat lanes_of(const float* a) { return vfloat(a, stdx::vector_aligned); }
  [[gnu::always_inline]] static void st(float* a, const vfloat& v) { v.copy_to(a, stdx::vector_aligned); }
  static void store(int l, const lanes::Vec3T<float>& v, float (&a)[3][N]) { a[0][l] = v.x, a[1][l] = v.y, a[2][l] = v.z; }
  lanes::Vec3T<vfloat> vec(const float (&a)[3][N]) const { return {lanes_of(a[0]), lanes_of(a[1]), lanes_of(a[2])}; }
  LayeredLobe<vfloat> layered_lobe() const {
    return {vec(f0), lanes_of(eta[0]), lanes_of(coat) != 0.f, vec(colour), lanes_of(lum), lanes_of(avg), lanes_of(alpha)};
  }
  ConductorLobe<vfloat> conductor_lobe_lanes() const {
    return {vec(f0), vec(eta), vec(k), lanes_of(complex) != 0.f, vec(colour), lanes_of(avg), lanes_of(alpha)};
  }
};
PT_SIMD_SQRT_WARNINGS_ON

}  // namespace integrator_detail
}  // namespace pt
