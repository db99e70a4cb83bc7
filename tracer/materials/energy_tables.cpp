// Directional-albedo tables (energy_tables.h).
#include "materials/energy_tables.h"

#include <array>
#include <cmath>

#include "materials/fresnel.h"
#include "materials/microfacet.h"
#include "materials/subsurface.h"
#include "sampling/quadrature.h"

namespace pt {

namespace {

// Quadrature points of the tables: a Fibonacci lattice (Korobov rank-1 lattice with N = F_16 = 987 points and
// generator F_15 = 610) over the VNDF sampling square. Unlike a product grid it has no axis-aligned rows to
// alias with the integrand's one discontinuity (the reflected direction crossing the horizon); measured against
// a 768×768 reference it is within 4e-4 of E(μ) at every table cosine for α ∈ [1e-3, 1], F = 1 or dielectric.
constexpr int kLatticeN = 987, kLatticeG = 610;
constexpr double kPiD = 3.14159265358979323846;

// The disk-radius coordinate is warped by u1 = 1 − v³ (dv-density 3v²), which packs points towards the disk's
// rim where GGX's long tail (the most tilted visible normals) lives.
struct LatticePoint {
  float r, weight, cos_phi, sin_phi;
};

const std::array<LatticePoint, kLatticeN>& lattice() {
  static const std::array<LatticePoint, kLatticeN> points = [] {
    std::array<LatticePoint, kLatticeN> p{};
    for (int i = 0; i < kLatticeN; ++i) {
      const double v = (i + 0.5) / kLatticeN;
      double y = (double(i) * kLatticeG + 0.5) / kLatticeN;
      y -= std::floor(y);
      // φ ∈ [−π/2, π/2]: the integrand is symmetric under φ → π − φ (mirroring across the plane of incidence).
      const double phi = kPiD * (y - 0.5);
      p[i] = {static_cast<float>(std::sqrt(1.0 - v * v * v)), static_cast<float>(3.0 * v * v / kLatticeN),
              static_cast<float>(std::cos(phi)), static_cast<float>(std::sin(phi))};
    }
    return p;
  }();
  return points;
}

// The Gauss–Legendre rule of the subsurface albedo table (sampling/quadrature.h), computed once.
constexpr int kGaussN = 24;
const GaussLegendreRule& gauss_rule() {
  static const GaussLegendreRule rule = gauss_legendre(kGaussN);
  return rule;
}

// The Fresnel factor of a table's lobe: none (F = 1), the exact dielectric F(wo·wm, η), or Schlick's weight
// (1 − wo·wm)⁵ (what multiplies 1 − f0 in Schlick's F).
enum class LobeFresnel { One, Dielectric, SchlickWeight };

// ∫ weight over the VNDF sampling square for wo = (sin θo, 0, cos θo) (energy_tables.h), Heitz 2018 listing 1
// inlined with the per-wo basis hoisted out of the loop. n > 0 selects an n×n product midpoint grid in the
// same variables instead of the lattice (for references).
template <LobeFresnel kFresnel>
float vndf_albedo(float cos_o, float alpha, float eta, int n) {
  const float mu = std::clamp(cos_o, 0.f, 1.f);
  const Vec3 wo(safe_sqrt(1.f - mu * mu), 0.f, mu);
  const Vec3 vh = glm::normalize(Vec3(alpha * wo.x, 0.f, wo.z));
  const Vec3 t1 = vh.x > 0.f ? Vec3(0.f, 1.f, 0.f) : Vec3(1.f, 0.f, 0.f);
  const Vec3 t2 = glm::cross(vh, t1);
  const float s = 0.5f * (1.f + vh.z);
  const float ro = ggx_smith_r(mu, wo.x * wo.x, alpha);
  auto weight = [&](const LatticePoint& q) {
    const float p1 = q.r * q.cos_phi;
    const float p2 = (1.f - s) * safe_sqrt(1.f - p1 * p1) + s * q.r * q.sin_phi;
    const Vec3 nh = p1 * t1 + p2 * t2 + safe_sqrt(1.f - p1 * p1 - p2 * p2) * vh;
    const Vec3 wm = glm::normalize(Vec3(alpha * nh.x, alpha * nh.y, std::max(0.f, nh.z)));
    const float cos_om = glm::dot(wo, wm);
    const float mu_i = 2.f * cos_om * wm.z - mu;  // (reflect(−wo, wm)).z
    if (!(mu_i > 0.f)) return 0.f;
    const float ri = ggx_smith_r(mu_i, std::max(0.f, 1.f - mu_i * mu_i), alpha);
    float w = mu_i * (mu + ro) / (mu_i * ro + mu * ri);  // G2/G1(wo) = (1 + Λo)/(1 + Λo + Λi)
    if constexpr (kFresnel == LobeFresnel::Dielectric) w *= fresnel_dielectric(cos_om, eta);
    if constexpr (kFresnel == LobeFresnel::SchlickWeight) {
      const float c = 1.f - std::clamp(cos_om, 0.f, 1.f), c2 = c * c;
      w *= c2 * c2 * c;
    }
    return w * q.weight;
  };
  double sum = 0.0;
  if (n <= 0) {
    for (const LatticePoint& q : lattice()) sum += weight(q);
    return static_cast<float>(sum);
  }
  for (int j = 0; j < n; ++j) {
    const double phi = kPiD * ((j + 0.5) / n - 0.5);
    for (int i = 0; i < n; ++i) {
      const double v = (i + 0.5) / n;
      sum += weight({static_cast<float>(std::sqrt(1.0 - v * v * v)), static_cast<float>(3.0 * v * v / (double(n) * n)),
                     static_cast<float>(std::cos(phi)), static_cast<float>(std::sin(phi))});
    }
  }
  return static_cast<float>(sum);
}

template <class F>
EnergyTable tabulate(F&& e_of_mu) {
  EnergyTable t;
  for (int i = 0; i < EnergyTable::kSize; ++i) t.e[i] = e_of_mu(static_cast<float>(i) / (EnergyTable::kSize - 1));
  t.e_avg = energy_table_average(t);
  return t;
}

// 2∫g(μ)μ dμ over [0, 1] by composite Simpson with kIntervals (even) intervals.
template <class G>
double cosine_average(G&& g) {
  constexpr int kIntervals = 256;
  double sum = 0.0;
  for (int i = 0; i <= kIntervals; ++i) {
    const double mu = double(i) / kIntervals;
    const double w = (i == 0 || i == kIntervals) ? 1.0 : (i % 2 ? 4.0 : 2.0);
    sum += w * g(static_cast<float>(mu)) * mu;
  }
  return 2.0 * sum / (3.0 * kIntervals);
}

}  // namespace

float ggx_directional_albedo(float cos_o, float alpha, float eta, int n) {
  return eta == 0.f ? vndf_albedo<LobeFresnel::One>(cos_o, alpha, 1.f, n)
                    : vndf_albedo<LobeFresnel::Dielectric>(cos_o, alpha, eta, n);
}

float subsurface_single_albedo(float cos_o, float g, float eta) {
  const GaussLegendreRule& gl = gauss_rule();
  const float mu_o = std::clamp(cos_o, 0.f, 1.f);
  const float inv_eta2 = 1.f / (eta * eta);
  const float sin_o = safe_sqrt(1.f - mu_o * mu_o);
  const float co = safe_sqrt(1.f - sin_o * sin_o * inv_eta2);  // |n·ωo′|
  std::array<float, kGaussN> cos_dphi;
  for (int j = 0; j < kGaussN; ++j) cos_dphi[j] = static_cast<float>(std::cos(kPiD * gl.x[j]));
  double sum = 0.0;
  // θi over [0, θo] and [θo, π/2] (dωi = sin θi dθi dΔφ): the back-scattering peak (ωi = ωo) sits on the shared
  // edge, at Δφ = 0, where the nodes of both rules cluster.
  const double theta_o = std::acos(double(mu_o));
  for (int part = 0; part < 2; ++part) {
    const double lo = part == 0 ? 0.0 : theta_o, len = part == 0 ? theta_o : 0.5 * kPiD - theta_o;
    if (!(len > 0.0)) continue;
    for (int i = 0; i < kGaussN; ++i) {
      const double theta_i = lo + len * gl.x[i];
      const float mu_i = static_cast<float>(std::cos(theta_i)), sin_i = static_cast<float>(std::sin(theta_i));
      const float ci = safe_sqrt(1.f - sin_i * sin_i * inv_eta2);  // |n·ωi′|
      const float ft_i = 1.f - fresnel_dielectric(mu_i, eta);
      double row = 0.0;
      for (int j = 0; j < kGaussN; ++j) {
        // Scattering angle as in subsurface_eval (subsurface.h).
        const float cos_theta = std::clamp(-sin_i * sin_o * cos_dphi[j] * inv_eta2 - ci * co, -1.f, 1.f);
        row += gl.w[j] * henyey_greenstein(cos_theta, g);
      }
      sum += len * gl.w[i] * ft_i * mu_i * sin_i / (ci + co) * row;
    }
  }
  return static_cast<float>(2.0 * kPiD * sum);  // Δφ ∈ [0, π] (symmetric), doubled
}

float energy_table_average(const EnergyTable& t) {
  const double h = 1.0 / (EnergyTable::kSize - 1);
  double sum = 0.0;
  for (int i = 0; i + 1 < EnergyTable::kSize; ++i) {
    const double a = t.e[i], b = t.e[i + 1], mu_a = i * h;
    sum += h * (mu_a * (a + b) / 2 + h * (a / 6 + b / 3));  // ∫ over the segment of the linear interpolant × μ
  }
  return static_cast<float>(2.0 * sum);
}

EnergyTable ggx_energy_table(float alpha) {
  return tabulate([&](float mu) { return vndf_albedo<LobeFresnel::One>(mu, alpha, 1.f, 0); });
}

EnergyTable ggx_dielectric_energy_table(float alpha, float eta) {
  return tabulate([&](float mu) { return vndf_albedo<LobeFresnel::Dielectric>(mu, alpha, eta, 0); });
}

EnergyTable fresnel_dielectric_table(float eta) {
  EnergyTable t = tabulate([&](float mu) { return fresnel_dielectric(mu, eta); });
  t.e_avg = fresnel_dielectric_avg(eta);
  return t;
}

float fresnel_dielectric_avg(float eta) {
  return static_cast<float>(cosine_average([&](float mu) { return fresnel_dielectric(mu, eta); }));
}

const SchlickAlbedoTable& ggx_schlick_albedo_table() {
  static const SchlickAlbedoTable table = [] {
    SchlickAlbedoTable t;
    for (int j = 0; j < SchlickAlbedoTable::kRows; ++j) {
      const float r = static_cast<float>(j) / (SchlickAlbedoTable::kRows - 1), alpha = r * r;
      if (effectively_smooth(alpha)) {  // the smooth limit: the lobe reflects F(μ) itself
        t.one[j] = tabulate([](float) { return 1.f; });
        t.schlick[j] = tabulate([](float mu) { return std::pow(1.f - mu, 5.f); });
      } else {
        t.one[j] = ggx_energy_table(alpha);
        t.schlick[j] = tabulate([&](float mu) { return vndf_albedo<LobeFresnel::SchlickWeight>(mu, alpha, 1.f, 0); });
      }
    }
    return t;
  }();
  return table;
}

SchlickAlbedoTable::Row SchlickAlbedoTable::row(float roughness) const {
  const float x = std::clamp(roughness, 0.f, 1.f) * (kRows - 1);
  const int j = std::min(static_cast<int>(x), kRows - 2);
  return {j, x - static_cast<float>(j)};
}

float SchlickAlbedoTable::e(float f0, float roughness, float mu) const {
  const Row r = row(roughness);
  const auto at = [&](int j) { return f0 * one[j](mu) + (1.f - f0) * schlick[j](mu); };
  return at(r.j) + r.t * (at(r.j + 1) - at(r.j));
}

float SchlickAlbedoTable::e_avg(float f0, float roughness) const {
  const Row r = row(roughness);
  const auto at = [&](int j) { return f0 * one[j].e_avg + (1.f - f0) * schlick[j].e_avg; };
  return at(r.j) + r.t * (at(r.j + 1) - at(r.j));
}

Rgb fresnel_schlick_avg(Rgb f0) { return f0 + (Rgb(1.f) - f0) * (1.f / 21.f); }

Rgb fresnel_complex_avg(Rgb eta, Rgb k) {
  Rgb avg;
  for (int c = 0; c < 3; ++c)
    avg[c] = static_cast<float>(cosine_average([&](float mu) { return fresnel_complex(mu, eta[c], k[c]); }));
  return avg;
}

}  // namespace pt
