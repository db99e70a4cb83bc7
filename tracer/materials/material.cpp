// prepare_material: derives what the BSDFs read at every hit from the material's parameters (material.h).
#include "materials/material.h"

#include "materials/conductor_presets.h"
#include "materials/energy_tables.h"
#include "materials/microfacet.h"
#include "materials/subsurface.h"

namespace pt {

void prepare_material(Material& m) {
  const float roughness = std::clamp(m.roughness, 0.f, 1.f);
  m.alpha = roughness * roughness;  // α < kSmoothAlpha is treated as smooth (microfacet.h)
  const bool smooth = effectively_smooth(m.alpha);
  m.energy = EnergyTable{};
  m.energy.e.fill(1.f);
  m.energy.e_avg = 1.f;
  m.f_avg = Rgb(1.f);
  m.rd = Rgb(0.f);
  m.ss_norm = Rgb(1.f);
  switch (m.type) {
    case MaterialType::Conductor:
      if (m.metal != MetalPreset::None) {
        const ConductorIor ior = conductor_preset(m.metal);
        m.eta = ior.eta;
        m.k = ior.k;
        m.complex_ior = true;
      }
      // F_avg: the rough lobe's energy compensation, and every conductor's denoising albedo (bsdf_albedo).
      m.f_avg = m.complex_ior ? fresnel_complex_avg(m.eta, m.k) : fresnel_schlick_avg(m.albedo);
      if (!smooth) m.energy = ggx_energy_table(m.alpha);
      break;
    case MaterialType::Plastic:
      m.energy = smooth ? fresnel_dielectric_table(m.ior) : ggx_dielectric_energy_table(m.alpha, m.ior);
      break;
    case MaterialType::Subsurface: {
      m.rd = subsurface_rd(m.albedo, m.ior);
      // Directional albedo E(μo) = F_t(μo) [R_d (1 − F_avg) + α′ S(μo)] (subsurface.h); where its maximum over
      // μo exceeds 1 (α′ near 1, mostly back-scattering g), scale the channel down to a maximum of 1.
      constexpr int kNodes = 24;
      const float t_avg = 1.f - fresnel_dielectric_avg(m.ior);
      Rgb e_max(0.f);
      for (int i = 1; i <= kNodes; ++i) {
        const float mu = static_cast<float>(i) / kNodes;
        const float ft = 1.f - fresnel_dielectric(mu, m.ior);
        const float s = subsurface_single_albedo(mu, m.g, m.ior);
        e_max = glm::max(e_max, ft * (m.rd * t_avg + glm::clamp(m.albedo, 0.f, 1.f) * s));
      }
      for (int c = 0; c < 3; ++c) m.ss_norm[c] = e_max[c] > 1.f ? 1.f / e_max[c] : 1.f;
      break;
    }
    case MaterialType::Diffuse:
    case MaterialType::Mirror:
    case MaterialType::Dielectric:
    case MaterialType::MetallicRoughness:  // evaluates its formulas directly: nothing to tabulate
      break;
  }
}

Material with_albedo(const Material& m, Rgb albedo) {
  Material t = m;
  t.albedo = albedo;
  if (t.type == MaterialType::Conductor && !t.complex_ior) t.f_avg = fresnel_schlick_avg(albedo);
  return t;
}

}  // namespace pt
