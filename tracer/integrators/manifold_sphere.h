// Specular paths through one sphere between two given points: the geometry of manifold next-event estimation
// (Hanika, Droske and Fascione 2015, "Manifold Next Event Estimation"; Zeltner, Georgiev and Jakob 2020,
// "Specular Manifold Sampling", which also treat the unknown number of solutions) for the one shape where the
// specular constraint reduces to a single unknown.
//
// A path from x to y that reflects once off a sphere, or refracts into it and out again, lies in the plane
// through x, y and the centre c: the incident ray, the normal (radial, through c) and the scattered ray of each
// event share one plane, and the chord inside shares it with both events. So the path is fixed by one angle α,
// the direction from x within that plane, and solving for it is a root search in one dimension (traced in the
// plane's two coordinates): every zero crossing of the angle between the outgoing ray and the direction to y,
// over a grid of directions across the sphere's silhouette, is refined by regula falsi, and dips of the
// residual towards zero between grid points (two roots inside one cell, where solutions merge at a caustic's
// fold) are followed to their bottom. Roots can
// still be missed (a pair in a cell whose dip the grid does not show); the estimator stays unbiased because the
// weight it gives to path tracing for a path asks this same search whether it would have found that path
// (bdpt_manifold.h).
//
// The measure conversion dA_y/dω_x (area on the light per solid angle at x, the "generalized geometry term" of
// the chain; Hanika et al. derive it from the manifold's tangent space) is taken by central differences of the
// whole chain's map ω ↦ y in double precision.
//
// Everything here is in double: the chain magnifies errors of its entry point (by the sphere's focusing).
#pragma once
#include <array>

#include "core/lanes.h"
#include "core/math.h"
#include "core/simd_sqrt_warnings.h"

namespace pt {

struct SpecularSphere {
  DVec3 center;
  double radius;
  bool refracts;  // true: in and out through the surface (relative index ior); false: one mirror reflection
  double ior;
};

// The path from x along unit direction w through the sphere: entry p1, exit p2 (= p1 for a reflection), and
// the ray leaving the sphere (from p2 along out).
struct SphereChain {
  DVec3 p1{0.0}, p2{0.0}, out{0.0};
};

namespace manifold_detail {
// Snell refraction of travel direction d at a surface with unit normal n facing the incident side (d·n < 0),
// eta = n_i/n_t. False under total internal reflection.
inline bool refract_travel(DVec3 d, DVec3 n, double eta, DVec3& t) {
  const double cos_i = -glm::dot(d, n);
  const double sin2_t = eta * eta * std::max(0.0, 1.0 - cos_i * cos_i);
  if (sin2_t >= 1.0) return false;
  t = glm::normalize(eta * d + (eta * cos_i - std::sqrt(1.0 - sin2_t)) * n);
  return true;
}
}  // namespace manifold_detail

// Follows the chain from x (outside the sphere) along unit w. False when w misses the sphere.
inline bool trace_sphere_chain(const SpecularSphere& s, DVec3 x, DVec3 w, SphereChain& out) {
  const DVec3 f = x - s.center;
  const double b = glm::dot(f, w);
  const double c = glm::dot(f, f) - s.radius * s.radius;
  if (!(c > 0.0) || !(b < 0.0)) return false;  // x inside, or the sphere behind
  const DVec3 l = f - b * w;                    // perpendicular from the centre to the ray (stable discriminant)
  const double disc = s.radius * s.radius - glm::dot(l, l);
  if (!(disc > 0.0)) return false;
  const double t = c / (-b + std::sqrt(disc));  // the nearer root, without cancellation
  out.p1 = x + t * w;
  const DVec3 n1 = (out.p1 - s.center) / s.radius;
  if (!s.refracts) {
    out.p2 = out.p1;
    out.out = w - 2.0 * glm::dot(w, n1) * n1;
    return true;
  }
  DVec3 inside;
  if (!manifold_detail::refract_travel(w, n1, 1.0 / s.ior, inside)) return false;
  const double chord = -2.0 * glm::dot(out.p1 - s.center, inside);
  if (!(chord > 0.0)) return false;
  out.p2 = out.p1 + chord * inside;
  const DVec3 n2 = (out.p2 - s.center) / s.radius;
  return manifold_detail::refract_travel(inside, -n2, s.ior, out.out);
}

// Up to kMaxSphereChainRoots directions from x whose chain passes through y.
inline constexpr int kMaxSphereChainRoots = 4;
struct SphereChainRoots {
  std::array<DVec3, kMaxSphereChainRoots> w;
  int count = 0;
  // Directions whose chain passes y within rounding at a fold's edge without an exact root: not paths of the
  // strategy, but where a path-tracing path made in float may lie (bdpt_manifold.h, path_tracing_share).
  std::array<DVec3, kMaxSphereChainRoots> near;
  int near_count = 0;
  int evaluations = 0;  // chains traced by the search (its cost)
};

// The grid of the root search: directions across the silhouette, evenly spaced in the angle of incidence on the
// sphere (where the chain's outgoing direction turns fastest, near grazing, the grid is densest), both grazing
// ends included. Pairs of roots inside one cell (near a caustic's fold) are found by following the residual's
// dips. With them 25 points do as well as 97: 400 of 400 fold pairs of the test (13 points: 399), and on
// cornell-spheres 256² at 64 spp path tracing made 3 paths that the search did not find with 13, 25, 49 or 97
// points (all three lay within rounding of a fold: the residual's dip bottoms out 6e-7 to 2e-6 above zero, so
// the float path exists and the exact one does not; SphereChainRoots::near now reports them).
inline constexpr int kSphereChainGrid = 25;
inline constexpr double kSphereChainDipDepth = 0.1;  // |residual| at a grid point below which a dip is followed
inline constexpr double kSphereChainNearRoot = 1e-5;  // |residual| (sin of the miss angle) of a near root

namespace manifold_detail {
// sin θ_k of the grid's angles of incidence θ_k, from −90° to 90° (a hair inside: at grazing the chain's entry
// is ill-conditioned).
inline const std::array<double, kSphereChainGrid>& incidence_grid() {
  static const std::array<double, kSphereChainGrid> grid = [] {
    std::array<double, kSphereChainGrid> g{};
    const double half = 0.5 * 3.14159265358979323846 * (1.0 - 1e-7);
    for (int k = 0; k < kSphereChainGrid; ++k) g[k] = std::sin(-half + 2.0 * half * k / (kSphereChainGrid - 1));
    return g;
  }();
  return grid;
}

// The search's plane (through x, y and the centre) in its own coordinates: x at the origin, the centre at
// (dc, 0), y at (y_u, y_v) with y_v > 0, a direction of sin α = sa at (√(1 − sa²), sa). In the plane the chain
// is two-dimensional: trace_sphere_chain's steps with two coordinates instead of three.
struct ChainPlane {
  double dc, radius, ior;
  bool refracts;
  double y_u, y_v;
};

// max(0, a), 0 for NaN (as std::max(0.0, a)).
template <class T>
T positive_part(const T& a) {
  return select(a > T(0.0), a, T(0.0));
}

PT_SIMD_SQRT_WARNINGS_OFF  // through solve_sphere_chain, which inlines the lanes' residual
// solve_sphere_chain's residual for the direction of sin α = sa: a monotone stand-in for the signed angle φ
// from the chain's outgoing ray to the direction towards y, sin φ while the ray heads towards y, ±(2 − |sin φ|)
// while it heads away, so that its only zero is at φ = 0 and its only jump at φ = ±π. NaN where the direction
// misses the sphere or total internal reflection stops it. Written once for doubles (the refinement) and for
// SIMD lanes of doubles (the grid, 8 directions per step with AVX-512; Mitsuba 3 templates its math over the
// number type likewise): the same operations in either, so the same bits.
template <class T>
T plane_residual(const ChainPlane& P, const T& sa) {
  using std::sqrt;
  const double r2 = P.radius * P.radius;
  const T ca = sqrt(positive_part(T(1.0) - sa * sa));
  // Entry: the nearer root of |t w − c|² = R², without cancellation (trace_sphere_chain).
  const T disc = T(r2) - (P.dc * P.dc) * (sa * sa);
  auto ok = disc > T(0.0);
  const T t = T(P.dc * P.dc - r2) / (P.dc * ca + sqrt(disc));
  T pu = t * ca, pv = t * sa;
  T nu = (pu - P.dc) / P.radius, nv = pv / P.radius;
  T out_u, out_v;
  if (!P.refracts) {
    const T dn = ca * nu + sa * nv;
    out_u = ca - 2.0 * dn * nu;
    out_v = sa - 2.0 * dn * nv;
  } else {
    // Snell in (manifold_detail::refract_travel), along the chord, Snell out; the directions stay unit to
    // rounding without renormalising.
    const double eta = 1.0 / P.ior;
    const T cos_i = -(ca * nu + sa * nv);
    const T sin2 = (eta * eta) * positive_part(T(1.0) - cos_i * cos_i);
    ok = ok && sin2 < T(1.0);
    const T k = eta * cos_i - sqrt(T(1.0) - sin2);
    const T in_u = eta * ca + k * nu, in_v = eta * sa + k * nv;
    const T chord = -2.0 * ((pu - P.dc) * in_u + pv * in_v);
    ok = ok && chord > T(0.0);
    pu = pu + chord * in_u;
    pv = pv + chord * in_v;
    nu = (pu - P.dc) / P.radius;
    nv = pv / P.radius;
    const T cos_o = in_u * nu + in_v * nv;
    const T sin2_o = (P.ior * P.ior) * positive_part(T(1.0) - cos_o * cos_o);
    ok = ok && sin2_o < T(1.0);
    const T k_o = P.ior * cos_o - sqrt(T(1.0) - sin2_o);
    out_u = P.ior * in_u - k_o * nu;
    out_v = P.ior * in_v - k_o * nv;
  }
  const T e_u = P.y_u - pu, e_v = P.y_v - pv;
  const T sin_phi = (out_u * e_v - out_v * e_u) / sqrt(e_u * e_u + e_v * e_v);
  const T away = select(sin_phi < T(0.0), T(-2.0) - sin_phi, T(2.0) - sin_phi);
  const T g = select(out_u * e_u + out_v * e_v >= T(0.0), sin_phi, away);
  return select(ok, g, T(std::numeric_limits<double>::quiet_NaN()));
}
}  // namespace manifold_detail

inline SphereChainRoots solve_sphere_chain(const SpecularSphere& s, DVec3 x, DVec3 y) {
  SphereChainRoots roots;
  const DVec3 to_c = s.center - x;
  const double dc2 = glm::dot(to_c, to_c), r2 = s.radius * s.radius;
  if (!(dc2 > r2)) return roots;
  const double dc = std::sqrt(dc2);
  const DVec3 u = to_c / dc;
  const DVec3 to_y = y - x;
  const DVec3 side = to_y - glm::dot(to_y, u) * u;
  const double side_len = glm::length(side);
  // y on the line through x and the centre: a ring of solutions (measure zero), none taken.
  if (!(side_len > 1e-12 * glm::length(to_y))) return roots;
  const DVec3 v = side / side_len;
  // The unknown: sin α of the direction w = cos α u + sin α v; the angle of incidence θ has sin θ = sin α dc/R.
  const double sin_alpha_max = s.radius / dc;
  const manifold_detail::ChainPlane plane{dc, s.radius, s.ior, s.refracts, glm::dot(to_y, u), side_len};
  const auto direction = [&](double sa) { return std::sqrt(std::max(0.0, 1.0 - sa * sa)) * u + sa * v; };
  const auto residual = [&](double sa) {
    ++roots.evaluations;
    return manifold_detail::plane_residual(plane, sa);
  };
  // Regula falsi with the Illinois modification (superlinear, and bracketed: it cannot leave [lo, hi]), for a
  // bracket whose ends' residuals differ in sign.
  const auto refine = [&](double lo, double hi, double g_lo, double g_hi) {
    int side_kept = 0;
    double root = hi, g_root = g_hi;
    for (int k = 0; k < 40; ++k) {
      root = (lo * g_hi - hi * g_lo) / (g_hi - g_lo);
      g_root = residual(root);
      if (!std::isfinite(g_root) || std::abs(g_root) < 1e-13 || hi - lo < 1e-14 * sin_alpha_max) break;
      if ((g_root < 0.0) == (g_lo < 0.0)) {
        lo = root, g_lo = g_root;
        if (side_kept == -1) g_hi *= 0.5;
        side_kept = -1;
      } else {
        hi = root, g_hi = g_root;
        if (side_kept == 1) g_lo *= 0.5;
        side_kept = 1;
      }
    }
    if (std::abs(g_root) < 1e-9 && roots.count < kMaxSphereChainRoots) roots.w[roots.count++] = direction(root);
  };
  // Two roots inside one cell (a caustic's fold, where the chain's image of the directions folds back over y):
  // the residual dips towards zero and back with no sign change at the grid points. At a grid point where |g|
  // is a local minimum near zero, successive parabolic interpolation (Brent 1973, ch. 5) follows the dip to its
  // bottom; if the bottom crosses zero, each side of it brackets one root. Missed pairs were the brightest
  // fireflies left: path tracing finds those paths, and with no root to match it keeps their whole weight.
  const auto dip = [&](double l, double m, double r, double g_l, double g_m, double g_r) {
    const double sign = g_m < 0.0 ? -1.0 : 1.0;
    for (int k = 0; k < 8; ++k) {
      const double p = (m - l) * (g_m - g_r), q = (m - r) * (g_m - g_l);
      const double den = 2.0 * (p - q);
      if (!(std::abs(den) > 0.0)) break;
      const double x = m - ((m - l) * p - (m - r) * q) / den;
      if (!(x > l && x < r) || x == m) break;
      const double g_x = residual(x);
      if (!std::isfinite(g_x)) break;
      if (sign * g_x <= 0.0) {
        refine(l, x, g_l, g_x);
        refine(x, r, g_x, g_r);
        return;
      }
      if (sign * g_x < sign * g_m) {
        const bool settled = sign * (g_m - g_x) < 1e-3 * sign * g_m;  // the bottom, above zero
        (x < m ? r : l) = m, (x < m ? g_r : g_l) = g_m;
        m = x, g_m = g_x;
        if (settled) break;
      } else {
        (x < m ? l : r) = x, (x < m ? g_l : g_r) = g_x;
      }
    }
    // No crossing, but a bottom within kSphereChainNearRoot of zero: no exact path, though a path traced in float
    // near the fold may end here (SphereChainRoots::near).
    if (std::abs(g_m) < kSphereChainNearRoot && roots.near_count < kMaxSphereChainRoots)
      roots.near[roots.near_count++] = direction(m);
  };
  // The grid's residuals first, a SIMD vector of directions at a time (the last vector padded with the last
  // direction), then the scan for sign changes and dips.
  using vdouble = stdx::native_simd<double>;
  constexpr int kW = static_cast<int>(vdouble::size());
  constexpr int kPadded = (kSphereChainGrid + kW - 1) / kW * kW;
  const auto& grid = manifold_detail::incidence_grid();
  const auto grid_a = [&](int i) { return sin_alpha_max * grid[std::min(i, kSphereChainGrid - 1)]; };
  alignas(64) std::array<double, kPadded> grid_g;
  for (int i = 0; i < kPadded; i += kW)
    manifold_detail::plane_residual(plane, vdouble([&](int l) { return grid_a(i + l); }))
        .copy_to(&grid_g[i], stdx::element_aligned);
  roots.evaluations += kSphereChainGrid;
  double a_pp = 0.0, g_pp = std::numeric_limits<double>::quiet_NaN();
  double a_prev = grid_a(0), g_prev = grid_g[0];
  for (int i = 1; i < kSphereChainGrid && roots.count < kMaxSphereChainRoots; ++i) {
    const double a = grid_a(i), g = grid_g[i];
    if (std::isfinite(g_prev) && std::isfinite(g)) {
      if ((g_prev < 0.0) != (g < 0.0)) {
        // The stand-in is monotone in φ ∈ (−π, π), so across a cell φ turns the shorter way round: through 0 (a
        // root) when |g_prev| + |g| < 2, else through ±π (the jump, no root). Refining a jump ran regula falsi
        // to its 40-step limit: on cornell-spheres 77 of every 132 brackets were jumps (none held a root), and
        // the search evaluated 60 residuals per call instead of 29.
        if (std::abs(g_prev) + std::abs(g) < 2.0) refine(a_prev, a, g_prev, g);
      } else if (std::isfinite(g_pp) && (g_pp < 0.0) == (g < 0.0) && std::abs(g_prev) < kSphereChainDipDepth &&
                 std::abs(g_prev) < std::abs(g_pp) && std::abs(g_prev) < std::abs(g)) {
        dip(a_pp, a_prev, a, g_pp, g_prev, g);
      }
    }
    a_pp = a_prev, g_pp = g_prev;
    a_prev = a, g_prev = g;
  }
  return roots;
}
PT_SIMD_SQRT_WARNINGS_ON

// dA/dω: the area swept on the plane through y with unit normal n_y per unit solid angle of directions at x,
// for the chain leaving x along w (central differences; 0 when the chain is lost within the step).
inline double sphere_chain_area_per_solid_angle(const SpecularSphere& s, DVec3 x, DVec3 w, DVec3 y, DVec3 n_y) {
  constexpr double h = 1e-6;
  const DVec3 a = std::abs(w.x) > 0.9 ? DVec3(0, 1, 0) : DVec3(1, 0, 0);
  const DVec3 t1 = glm::normalize(glm::cross(w, a)), t2 = glm::cross(w, t1);
  const auto land = [&](DVec3 dir, DVec3& p) {
    SphereChain ch;
    if (!trace_sphere_chain(s, x, glm::normalize(dir), ch)) return false;
    const double den = glm::dot(ch.out, n_y);
    if (den == 0.0) return false;
    p = ch.p2 + (glm::dot(y - ch.p2, n_y) / den) * ch.out;
    return true;
  };
  DVec3 a1, b1, a2, b2;
  if (!land(w + h * t1, a1) || !land(w - h * t1, b1) || !land(w + h * t2, a2) || !land(w - h * t2, b2)) return 0.0;
  // Directions w ± h·t normalised are h(1 − h²/3…) apart in angle: a relative 1e-12, below the differences' own.
  return std::abs(glm::dot(glm::cross(a1 - b1, a2 - b2), n_y)) / (4.0 * h * h);
}

}  // namespace pt
