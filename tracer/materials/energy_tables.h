// Directional-albedo tables for energy compensation, computed when a material is prepared (material.cpp).
// Deterministic (fixed quadrature, no random numbers) and fast (well under a millisecond per table), since they
// are recomputed whenever a material is edited live.
#pragma once
#include "materials/material.h"

namespace pt {

// Directional albedo E(μo) = ∫ f_r(wo, wi) cos θi dωi of the GGX reflection lobe f_r = D G2 F / (4 μo μi)
// (height-correlated Smith G2), with F = 1 when eta == 0 and the exact dielectric Fresnel F(wo·wm, eta)
// otherwise. Quadrature over the visible-normal sampling square (Heitz 2018), where the integrand is the bounded
// weight F·G2/G1(wo) (discontinuous only where wi crosses the horizon); the plane-of-incidence symmetry halves
// the φ range. n ≤ 0: the tables' rule (a fixed 987-point lattice); n > 0: an n×n product midpoint grid in the
// same variables, for reference values.
float ggx_directional_albedo(float cos_o, float alpha, float eta, int n = 0);

// E(μ) of the GGX lobe with F = 1 at the table's cosines, and E_avg (Kulla & Conty 2017 compensation).
EnergyTable ggx_energy_table(float alpha);
// E(μ) of the GGX reflection lobe of a dielectric coat (outside → index eta) (plastic's coupling).
EnergyTable ggx_dielectric_energy_table(float alpha, float eta);
// The smooth-coat limit: E(μ) = F(μ, eta) at the table's cosines, with the exact average 2∫F(μ)μ dμ (the
// smooth plastic evaluates F itself, so its average must not carry table interpolation error).
EnergyTable fresnel_dielectric_table(float eta);

// Directional albedo of the GGX reflection lobe with Schlick's Fresnel F = f0 + (1 − f0)(1 − wo·wm)⁵ (glTF's
// dielectric layer, metallic_roughness.h), for any f0 and roughness from one table computed once: E is linear
// in f0, E = f0·E₁(μ) + (1 − f0)·E₅(μ), with E₁ the albedo for F = 1 and E₅ for F = (1 − wo·wm)⁵, each an
// EnergyTable per roughness row (kRows rows over roughness [0, 1], α = roughness²; row 0 the smooth limit,
// E₁ = 1 and E₅ = (1 − μ)⁵) and interpolated linearly between rows. e_avg is the exact average of what e
// returns (linear interpolation of the rows' exact averages), so a coupling through it conserves energy to
// rounding.
struct SchlickAlbedoTable {
  static constexpr int kRows = 32;
  std::array<EnergyTable, kRows> one, schlick;
  float e(float f0, float roughness, float mu) const;
  float e_avg(float f0, float roughness) const;

 private:
  struct Row {
    int j;
    float t;
  };
  Row row(float roughness) const;
};
// The table, computed on first use (~2·10⁶ lobe evaluations) and shared.
const SchlickAlbedoTable& ggx_schlick_albedo_table();

// Cosine-weighted average reflectance F_avg = 2∫F(μ)μ dμ.
float fresnel_dielectric_avg(float eta);
Rgb fresnel_schlick_avg(Rgb f0);  // analytic: F0 + (1 − F0)/21
Rgb fresnel_complex_avg(Rgb eta, Rgb k);

// Single-scattering albedo per unit α′ of the subsurface BRDF (subsurface.h):
//   S(μo) = ∫ F_t(μi) p(cos θ) / (|n·ωi′| + |n·ωo′|) cos θi dωi,
// by a 32×32 Gauss–Legendre product rule in (cos θi, Δφ ∈ [0, π]) (the integrand is symmetric in Δφ; the
// nodes cluster at Δφ = 0 where back-scattering phase functions peak).
float subsurface_single_albedo(float cos_o, float g, float eta);

// E_avg = 2∫E(μ)μ dμ of the table's piecewise-linear interpolant, integrated exactly: the compensation lobes
// integrate to 1 − E(μ) exactly only if E_avg matches what EnergyTable::operator() returns.
float energy_table_average(const EnergyTable& t);

}  // namespace pt
