// Light-sampling building blocks against independent references:
//  * spherical rectangle sampling (lights/spherical_rectangle.h): its solid angle against Van Oosterom–Strackee
//    triangle sums, its samples against the uniform-in-solid-angle density (Pearson χ²), its samples lying on the
//    rectangle, and its behaviour in degenerate placements;
//  * Lambert's exact polygon irradiance (analytic_irradiance.h) against numerical quadrature and closed forms.
//
// χ² significance: 0.01 for the whole file, split evenly over its kChi2Tests χ² tests (Bonferroni), so each test
// rejects at p < 0.01/kChi2Tests. The seeds are fixed, so a pass is reproducible; a real mismatch between sampler
// and density at these sample counts gives p far below 1e-6.
#include <doctest/doctest.h>

#include <cmath>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include "analytic_irradiance.h"
#include "chi2.h"
#include "core/rng.h"
#include "lights/spherical_rectangle.h"
#include "sampling/quadrature.h"

using namespace pt;
using pt::test::chi2_test;

namespace {

constexpr int kChi2Tests = 11;
constexpr double kAlpha = 0.01 / kChi2Tests;

// ---------------------------------------------------------------------------------------------------------------
// Independent solid angles: Van Oosterom & Strackee (1983), tan(Ω/2) = |A·(B×C)| / (abc + (A·B)c + (A·C)b + (B·C)a)
// with A, B, C the vertices relative to o. The triple product is evaluated as A·((b−a)×(c−a)) (equal in exact
// arithmetic) so that tiny, distant triangles keep full relative precision.
double vos_triangle(DVec3 o, DVec3 a, DVec3 b, DVec3 c) {
  const DVec3 A = a - o, B = b - o, C = c - o;
  const double det = std::abs(glm::dot(A, glm::cross(b - a, c - a)));
  const double la = glm::length(A), lb = glm::length(B), lc = glm::length(C);
  const double den = la * lb * lc + glm::dot(A, B) * lc + glm::dot(A, C) * lb + glm::dot(B, C) * la;
  return 2.0 * std::atan2(det, den);
}

// Rectangle (corner s, edges ex, ey) as four triangles fanned from its centre; from a point off the plane all
// four are seen from the same side, so their unsigned solid angles add.
double vos_rectangle(DVec3 o, DVec3 s, DVec3 ex, DVec3 ey) {
  const DVec3 c = s + 0.5 * ex + 0.5 * ey;
  const DVec3 p[4] = {s, s + ex, s + ex + ey, s + ey};
  double sum = 0;
  for (int i = 0; i < 4; ++i) sum += vos_triangle(o, c, p[i], p[(i + 1) % 4]);
  return sum;
}

// ---------------------------------------------------------------------------------------------------------------
// Test configurations. The rotated frame is built from integer vectors with integer lengths, e1 = (3,4,0) (5),
// e2 = (−4,3,12) (13), e3 = e1×e2 = (48,−36,25) (65), scaled by powers of two, so the float edge vectors are
// exactly perpendicular and the reference and the sampler see the same rectangle.
struct RectCase {
  std::string name;
  Vec3 o, s, ex, ey;
};

// o = s + a·ex + b·ey + z·(unit normal): (a, b) in units of the edges, z in world units (negative = back side).
RectCase rotated_case(const char* name, double a, double b, double z, double ex_scale = 0.25,
                      double ey_scale = 1.0 / 16) {
  const DVec3 s(0.5, -1.0, 2.0);
  const DVec3 ex = DVec3(3, 4, 0) * ex_scale, ey = DVec3(-4, 3, 12) * ey_scale, n = DVec3(48, -36, 25) / 65.0;
  return {name, Vec3(s + a * ex + b * ey + z * n), Vec3(s), Vec3(ex), Vec3(ey)};
}

std::vector<RectCase> chi2_cases() {
  return {
      rotated_case("near, 5 cm above the inside", 0.3, 0.6, 0.05),
      rotated_case("moderate, 1 above the centre", 0.5, 0.5, 1.0),
      rotated_case("above a corner", 0.0, 0.0, 0.3),
      rotated_case("far, S ~ 1e-6", 0.2, 0.7, 1000.0),
      rotated_case("far off-axis, S ~ 1e-9", 3000.0, -2000.0, 20000.0),
      rotated_case("grazing, off the side", 2.5, 0.5, 0.01),
      rotated_case("grazing, off a corner", -1.0, -2.0, 0.003),
      rotated_case("behind (back side)", 0.7, 0.2, -0.4),
      // 2048 × 2048 square 1 unit away: S ≈ 2π − 0.006.
      {"huge, S near 2pi", Vec3(0.3f, 0.2f, 0.f), Vec3(-1024.f, -1024.f, -1.f), Vec3(2048.f, 0.f, 0.f),
       Vec3(0.f, 2048.f, 0.f)},
  };
}

// Parameters (a, b) of p = s + a·ex + b·ey + (off-plane part), in double.
struct RectCoords {
  double a, b, off_plane;
};
RectCoords rect_coords(const RectCase& c, Vec3 p) {
  const DVec3 d = DVec3(p) - DVec3(c.s), ex(c.ex), ey(c.ey);
  const DVec3 n = glm::normalize(glm::cross(ex, ey));
  return {glm::dot(d, ex) / glm::dot(ex, ex), glm::dot(d, ey) / glm::dot(ey, ey), glm::dot(d, n)};
}

// Float rounding of a sample point, in units of the edges (a, b) and in world units (off-plane): a few ulps of
// the coordinates' magnitude.
double position_tolerance(const RectCase& c) {
  return 8.0 * 0x1p-24 * (glm::length(DVec3(c.s)) + glm::length(DVec3(c.ex)) + glm::length(DVec3(c.ey)));
}

// χ² of sampled points over a kGrid × kGrid grid of rectangles in the (a, b) parametrisation, adapted to the
// viewpoint: with (xf, yf) the foot of o on the plane and h its distance, the cell edges sit at x = xf + h·tan φ for
// φ evenly spaced over the rectangle's range of atan((x − xf)/h) (likewise y). Cells are then of similar solid
// angle whether o is near (fine cells under it), far (nearly uniform) or grazing (fine towards the near edge).
// Expected counts are N·Ω_cell/Ω with each Ω_cell by Van Oosterom–Strackee. Also checks that every sample is
// finite and on the rectangle. Returns the p-value.
constexpr int kGrid = 24;

struct AxisBins {
  double foot, h, len, phi0, phi1;  // world units along the edge
  explicit AxisBins(double foot_, double h_, double len_)
      : foot(foot_), h(h_), len(len_), phi0(std::atan2(-foot_, h_)), phi1(std::atan2(len_ - foot_, h_)) {}
  double edge(int i) const {  // cell edge i in [0, kGrid], as a fraction of the edge
    if (i == 0) return 0.0;
    if (i == kGrid) return 1.0;
    return (foot + h * std::tan(phi0 + (phi1 - phi0) * i / kGrid)) / len;
  }
  int bin(double frac) const {
    const double phi = std::atan2(frac * len - foot, h);
    return std::clamp(static_cast<int>((phi - phi0) / (phi1 - phi0) * kGrid), 0, kGrid - 1);
  }
};

template <class Sampler>
double chi2_rectangle(const RectCase& c, Sampler&& sample_point, double solid_angle, uint64_t seed) {
  const int n = 400000;
  const DVec3 o(c.o), s(c.s), ex(c.ex), ey(c.ey);
  const RectCoords foot = rect_coords(c, c.o);
  const AxisBins bx(foot.a * glm::length(ex), std::abs(foot.off_plane), glm::length(ex));
  const AxisBins by(foot.b * glm::length(ey), std::abs(foot.off_plane), glm::length(ey));
  std::vector<double> expected(kGrid * kGrid), observed(kGrid * kGrid, 0.0);
  double total = 0;
  for (int j = 0; j < kGrid; ++j)
    for (int i = 0; i < kGrid; ++i) {
      const double a0 = bx.edge(i), a1 = bx.edge(i + 1), b0 = by.edge(j), b1 = by.edge(j + 1);
      const double w = vos_rectangle(o, s + a0 * ex + b0 * ey, (a1 - a0) * ex, (b1 - b0) * ey);
      expected[j * kGrid + i] = w;
      total += w;
    }
  CHECK(total == doctest::Approx(solid_angle).epsilon(1e-6));
  for (double& e : expected) e *= n / total;

  const double tol = position_tolerance(c);
  const double tol_a = tol / glm::length(ex), tol_b = tol / glm::length(ey);
  int off_rectangle = 0, non_finite = 0;
  Pcg32 rng(seed, 7);
  for (int k = 0; k < n; ++k) {
    const Vec2 u(rng.next_float(), rng.next_float());
    const Vec3 p = sample_point(u);
    if (!is_finite(p)) {
      ++non_finite;
      continue;
    }
    const RectCoords rc = rect_coords(c, p);
    if (rc.a < -tol_a || rc.a > 1 + tol_a || rc.b < -tol_b || rc.b > 1 + tol_b || std::abs(rc.off_plane) > tol)
      ++off_rectangle;
    observed[by.bin(rc.b) * kGrid + bx.bin(rc.a)] += 1;
  }
  CHECK(non_finite == 0);
  CHECK(off_rectangle == 0);
  const auto r = chi2_test(observed, expected);
  double min_expected = n;
  for (double e : expected) min_expected = std::min(min_expected, e);
  MESSAGE("spherical rectangle χ², " << c.name << ": S = " << solid_angle << ", chi2 = " << r.statistic
                                     << ", dof = " << r.dof << ", p = " << r.p_value
                                     << ", smallest expected count = " << min_expected);
  CHECK(r.unexpected == 0);
  return r.p_value;
}

}  // namespace

// ===============================================================================================================
TEST_CASE("spherical rectangle: solid angle matches Van Oosterom-Strackee") {
  auto cases = chi2_cases();
  cases.push_back(rotated_case("very near the inside", 0.5, 0.25, 1e-4));
  cases.push_back(rotated_case("very near, off the side", 1.5, 0.25, 1e-4));
  cases.push_back(rotated_case("long thin strip", 0.5, 0.5, 1.0, 4.0, 1.0 / 1024));
  for (const RectCase& c : cases) {
    const SphericalRect r = make_spherical_rect(c.o, c.s, c.ex, c.ey);
    const double ref = vos_rectangle(DVec3(c.o), DVec3(c.s), DVec3(c.ex), DVec3(c.ey));
    // Double evaluation: relative error up to ~1e-16·(π/2)/S off-axis (see the header); these cases reach 2e-9
    // at S = 2e-9, so 1e-12 holds with margin.
    INFO(c.name << ": S = " << r.solid_angle << ", reference " << ref);
    CHECK(r.solid_angle == doctest::Approx(ref).epsilon(1e-12));
    CHECK(spherical_rect_pdf(r) == doctest::Approx(1.0 / ref).epsilon(1e-6));
    // The float instantiation of the same code is only good for moderate solid angles (rounding ~1e-7/S).
    const auto rf = make_spherical_rect_t<float>(c.o, c.s, c.ex, c.ey);
    if (ref > 1e-2) CHECK(rf.solid_angle == doctest::Approx(ref).epsilon(1e-4));
  }
}

TEST_CASE("spherical rectangle: samples are uniform in solid angle (chi-square)") {
  uint64_t seed = 1001;
  for (const RectCase& c : chi2_cases()) {
    const SphericalRect r = make_spherical_rect(c.o, c.s, c.ex, c.ey);
    REQUIRE(r.solid_angle > 0);
    const double p = chi2_rectangle(c, [&](Vec2 u) { return sample(r, u); }, r.solid_angle, seed++);
    CHECK(p > kAlpha);
  }
}

TEST_CASE("spherical rectangle: float instantiation is uniform in solid angle (chi-square)") {
  // The same code over T = float, at moderate solid angles where float suffices.
  uint64_t seed = 2001;
  for (const RectCase& c : {rotated_case("float, moderate", 0.5, 0.5, 1.0), rotated_case("float, behind", 0.7, 0.2, -0.4)}) {
    const auto r = make_spherical_rect_t<float>(c.o, c.s, c.ex, c.ey);
    REQUIRE(r.solid_angle > 0);
    const double p = chi2_rectangle(c, [&](Vec2 u) { return sample_t<float>(r, u.x, u.y); }, r.solid_angle, seed++);
    CHECK(p > kAlpha);
  }
}

TEST_CASE("spherical rectangle: samples lie on the rectangle, corners of the unit square map to corners") {
  auto cases = chi2_cases();
  cases.push_back(rotated_case("very near the inside", 0.5, 0.25, 1e-6));
  cases.push_back(rotated_case("very far", 0.5, 0.5, 1e7));
  for (const RectCase& c : cases) {
    const SphericalRect r = make_spherical_rect(c.o, c.s, c.ex, c.ey);
    REQUIRE(r.solid_angle > 0);
    const double tol = position_tolerance(c);
    const double tol_a = tol / glm::length(DVec3(c.ex)), tol_b = tol / glm::length(DVec3(c.ey));
    const float us[] = {0.f, 1e-7f, 0.25f, 0.5f, 0.75f, 1.f - 1e-7f, kOneMinusEpsilon, 1.f};
    for (float ux : us)
      for (float uy : us) {
        const Vec3 p = sample(r, Vec2(ux, uy));
        INFO(c.name << ": u = (" << ux << ", " << uy << ")");
        REQUIRE(is_finite(p));
        const RectCoords rc = rect_coords(c, p);
        CHECK(rc.a >= -tol_a);
        CHECK(rc.a <= 1 + tol_a);
        CHECK(rc.b >= -tol_b);
        CHECK(rc.b <= 1 + tol_b);
        CHECK(std::abs(rc.off_plane) <= tol);
      }
    // u = (0, 0) and (1, 1) are the corners (x0, y0) and (x1, y1) of the parametrisation. Far away the
    // parametrisation loses relative precision (see the header), so this is checked only for S > 1e-7.
    if (r.solid_angle > 1e-7) {
      const RectCoords c00 = rect_coords(c, sample(r, Vec2(0.f, 0.f))), c11 = rect_coords(c, sample(r, Vec2(1.f, 1.f)));
      INFO("case: " << c.name);
      CHECK(std::abs(c00.a) < 1e-4);
      CHECK(std::abs(c00.b) < 1e-4);
      CHECK(c11.a == doctest::Approx(1.0).epsilon(1e-4));
      CHECK(c11.b == doctest::Approx(1.0).epsilon(1e-4));
    }
  }
}

TEST_CASE("spherical rectangle: degenerate placements give no sample or finite samples, never NaN") {
  const Vec3 s(-0.5f, -0.25f, 0.f), ex(1.f, 0.f, 0.f), ey(0.f, 0.5f, 0.f);  // in the plane z = 0
  const float us[] = {0.f, 0.5f, kOneMinusEpsilon, 1.f};
  auto all_finite = [&](const SphericalRect& r) {
    for (float a : us)
      for (float b : us)
        if (!is_finite(sample(r, Vec2(a, b)))) return false;
    return true;
  };
  // o on the rectangle's plane: inside, on an edge, at a corner, outside; also on the plane of a rotated one
  // (where d·z is rounding noise).
  for (Vec3 o : {Vec3(0.1f, 0.1f, 0.f), Vec3(0.5f, 0.f, 0.f), Vec3(-0.5f, -0.25f, 0.f), Vec3(3.f, -2.f, 0.f),
                 Vec3(0.5f, 0.25f, 0.f), Vec3(0.f, 0.f, -0.f)}) {
    const SphericalRect r = make_spherical_rect(o, s, ex, ey);
    CHECK(r.solid_angle == 0.0);
    CHECK(spherical_rect_pdf(r) == 0.f);
    CHECK(all_finite(r));
  }
  {
    const RectCase c = rotated_case("on the rotated plane", 0.5, 0.25, 0.0);
    const SphericalRect r = make_spherical_rect(c.o, c.s, c.ex, c.ey);
    CHECK(r.solid_angle == 0.0);
    CHECK(all_finite(r));
  }
  // Zero-length or parallel edges.
  for (auto [a, b] : {std::pair{Vec3(0.f), ey}, std::pair{ex, Vec3(0.f)}, std::pair{ex, 2.f * ex}}) {
    const SphericalRect r = make_spherical_rect(Vec3(0.f, 0.f, 1.f), s, a, b);
    CHECK(r.solid_angle == 0.0);
    CHECK(all_finite(r));
  }
  // A hair off the plane: below the rounding noise of d·z (8ε·|s − o| ≈ 1e-15 here) counts as on the plane.
  for (Vec3 o : {Vec3(0.1f, 0.1f, 1e-30f), Vec3(0.1f, 0.1f, -1e-20f), Vec3(0.5f, 0.25f, 1e-20f)}) {
    const SphericalRect r = make_spherical_rect(o, s, ex, ey);
    CHECK(r.solid_angle == 0.0);
    CHECK(all_finite(r));
  }
  // Extremes that are still valid, or nearly so: just above the inside (S → 2π) and outside (S → 0), very far
  // (S ~ 1e-61, pdf overflows float: far outside the sampler's useful range), far off to the side at height 1
  // (within the noise: S = 0).
  for (Vec3 o : {Vec3(0.1f, 0.1f, 1e-12f), Vec3(0.1f, 0.1f, -1e-12f), Vec3(2.f, 0.1f, 1e-12f), Vec3(0.f, 0.f, 1e30f),
                 Vec3(1e30f, 1e30f, 1.f)}) {
    const SphericalRect r = make_spherical_rect(o, s, ex, ey);
    INFO("o = (" << o.x << ", " << o.y << ", " << o.z << "), S = " << r.solid_angle);
    CHECK(std::isfinite(r.solid_angle));
    CHECK(r.solid_angle >= 0.0);
    CHECK(r.solid_angle <= 2 * std::numbers::pi);
    CHECK(all_finite(r));
    if (o.x == 0.1f) CHECK(r.solid_angle == doctest::Approx(2 * std::numbers::pi).epsilon(1e-10));
    if (o.x == 2.f) CHECK(r.solid_angle < 1e-10);
  }
}

// ===============================================================================================================
namespace {

using pt::test::Polygon;

// Brute-force E = ∫ L·max(cos θx, 0)·|cos θl|/r² dA over the parallelogram s + a·ex + b·ey, (a, b) ∈ [0,1]²:
// panels × panels composite 10-point Gauss–Legendre. The max() makes it valid for any placement; splitting the
// panels at an a or b where the horizon crosses keeps it accurate then too.
double quadrature_irradiance(DVec3 s, DVec3 ex, DVec3 ey, DVec3 x, DVec3 n, double radiance, int panels) {
  static const GaussLegendreRule g = gauss_legendre(10);
  const DVec3 nl_area = glm::cross(ex, ey);  // area element times the light's normal
  double sum = 0;
  for (int pa = 0; pa < panels; ++pa)
    for (int pb = 0; pb < panels; ++pb)
      for (size_t i = 0; i < g.x.size(); ++i)
        for (size_t j = 0; j < g.x.size(); ++j) {
          const double a = (pa + g.x[i]) / panels, b = (pb + g.x[j]) / panels;
          const DVec3 d = s + a * ex + b * ey - x;
          const double r2 = glm::dot(d, d), r = std::sqrt(r2);
          const double cos_x = std::max(glm::dot(d, n) / r, 0.0);
          const double cos_l_area = std::abs(glm::dot(d, nl_area)) / r;
          sum += g.w[i] * g.w[j] * cos_x * cos_l_area / r2;
        }
  return radiance * sum / (double(panels) * panels);
}

Polygon parallelogram(DVec3 s, DVec3 ex, DVec3 ey) { return {s, s + ex, s + ex + ey, s + ey}; }

DVec3 rotate_x(DVec3 v, double angle) {
  const double c = std::cos(angle), s = std::sin(angle);
  return {v.x, c * v.y - s * v.z, s * v.y + c * v.z};
}

// Differential area to a parallel rectangle a × b at distance c, normal through one corner: the form factor
// F = 1/(2π)·[X/√(1+X²)·atan(Y/√(1+X²)) + Y/√(1+Y²)·atan(X/√(1+Y²))], X = a/c, Y = b/c
// (Howell, "A Catalog of Radiation Heat Transfer Configuration Factors", B-3); irradiance E = π·L·F.
double corner_form_factor(double a, double b, double c) {
  const double X = a / c, Y = b / c, sx = std::sqrt(1 + X * X), sy = std::sqrt(1 + Y * Y);
  return (X / sx * std::atan(Y / sx) + Y / sy * std::atan(X / sy)) / (2 * std::numbers::pi);
}

}  // namespace

TEST_CASE("analytic irradiance: unit square light against quadrature at offsets and tilts") {
  const double L = 2.5;
  int checked = 0;
  for (double tilt_light : {0.0, 0.4, -0.9})
    for (DVec3 offset : {DVec3(0, 0, 0), DVec3(0.3, -0.2, 0), DVec3(1.7, 0.4, 0), DVec3(-2.0, -1.5, 0)})
      for (DVec3 n : {DVec3(0, 0, 1), glm::normalize(DVec3(0.3, -0.2, 1)), glm::normalize(DVec3(-1, 0.5, 0.8))}) {
        // Unit square centred 1 above the origin, tilted about x; receiver at the offset below.
        const DVec3 c(0, 0, 1);
        const DVec3 ex(1, 0, 0), ey = rotate_x(DVec3(0, 1, 0), tilt_light);
        const DVec3 s = c - 0.5 * ex - 0.5 * ey;
        const Polygon poly = parallelogram(s, ex, ey);
        if (!pt::test::polygon_above_tangent_plane(poly, offset, n)) continue;  // outside the formula's domain
        const double exact = pt::test::polygon_irradiance(poly, offset, n, L);
        const double quad = quadrature_irradiance(s, ex, ey, offset, n, L, 12);
        INFO("tilt " << tilt_light << ", offset (" << offset.x << ", " << offset.y << "), n (" << n.x << ", " << n.y
                     << ", " << n.z << "): Lambert " << exact << ", quadrature " << quad);
        CHECK(exact == doctest::Approx(quad).epsilon(1e-6));
        ++checked;
      }
  CHECK(checked >= 25);
}

TEST_CASE("analytic irradiance: sign convention, vertex order and a non-convex polygon") {
  const DVec3 x(0.1, 0.2, 0), n(0, 0, 1);
  // Right-hand normal (v1−v0)×(v2−v0) = +z, away from x below: positive sum; reversed order: negative.
  const Polygon ccw_from_above = {DVec3(-0.5, -0.5, 1), DVec3(0.5, -0.5, 1), DVec3(0.5, 0.5, 1), DVec3(-0.5, 0.5, 1)};
  const Polygon reversed(ccw_from_above.rbegin(), ccw_from_above.rend());
  const double a = pt::test::lambert_signed_projected_solid_angle(ccw_from_above, x, n);
  const double b = pt::test::lambert_signed_projected_solid_angle(reversed, x, n);
  CHECK(a > 0);
  CHECK(b == doctest::Approx(-a).epsilon(1e-14));
  // An L-shaped (non-convex) light = two rectangles.
  const Polygon ell = {DVec3(0, 0, 1), DVec3(2, 0, 1), DVec3(2, 1, 1), DVec3(1, 1, 1), DVec3(1, 2, 1), DVec3(0, 2, 1)};
  const double parts = quadrature_irradiance(DVec3(0, 0, 1), DVec3(2, 0, 0), DVec3(0, 1, 0), x, n, 1.0, 16) +
                       quadrature_irradiance(DVec3(0, 1, 1), DVec3(1, 0, 0), DVec3(0, 1, 0), x, n, 1.0, 16);
  CHECK(pt::test::polygon_irradiance(ell, x, n, 1.0) == doctest::Approx(parts).epsilon(1e-6));
}

TEST_CASE("analytic irradiance: closed forms (square under its centre and corner, disk, full hemisphere)") {
  const double L = 1.5, pi = std::numbers::pi;
  const DVec3 n(0, 0, 1);
  for (double c : {0.1, 1.0, 7.0}) {
    // Rectangle 0.8 × 1.3 at height c, receiver under a corner / under the centre of a 2a × 2a square.
    const double corner = pt::test::polygon_irradiance(parallelogram(DVec3(0, 0, c), DVec3(0.8, 0, 0), DVec3(0, 1.3, 0)),
                                                       DVec3(0), n, L);
    CHECK(corner == doctest::Approx(pi * L * corner_form_factor(0.8, 1.3, c)).epsilon(1e-12));
    const double a = 0.6;
    const double centre = pt::test::polygon_irradiance(
        parallelogram(DVec3(-a, -a, c), DVec3(2 * a, 0, 0), DVec3(0, 2 * a, 0)), DVec3(0), n, L);
    CHECK(centre == doctest::Approx(4 * pi * L * corner_form_factor(a, a, c)).epsilon(1e-12));
    // Disk of radius R at height c: E = π·L·R²/(R² + c²), bracketed by inscribed and circumscribed 4096-gons.
    const double R = 0.9, disk = pi * L * R * R / (R * R + c * c);
    const int sides = 4096;
    Polygon in, out;
    for (int k = 0; k < sides; ++k) {
      const double phi = 2 * pi * k / sides;
      in.push_back(DVec3(R * std::cos(phi), R * std::sin(phi), c));
      out.push_back(DVec3(R / std::cos(pi / sides) * std::cos(phi), R / std::cos(pi / sides) * std::sin(phi), c));
    }
    const double e_in = pt::test::polygon_irradiance(in, DVec3(0), n, L),
                 e_out = pt::test::polygon_irradiance(out, DVec3(0), n, L);
    CHECK(e_in < disk);
    CHECK(disk < e_out);
    CHECK(e_in == doctest::Approx(disk).epsilon(1e-6));
    CHECK(e_out == doctest::Approx(disk).epsilon(1e-6));
  }
  // A 2e6 × 2e6 square 1 above: nearly the whole hemisphere, E → π·L (to ~1e-6).
  const double huge = pt::test::polygon_irradiance(
      parallelogram(DVec3(-1e6, -1e6, 1), DVec3(2e6, 0, 0), DVec3(0, 2e6, 0)), DVec3(0), n, L);
  CHECK(huge == doctest::Approx(pi * L * 4 * corner_form_factor(1e6, 1e6, 1.0)).epsilon(1e-12));
  CHECK(huge == doctest::Approx(pi * L).epsilon(2e-6));
}

TEST_CASE("analytic irradiance: horizon clipping against quadrature") {
  // A vertical unit square (in the plane y = 1) straddling the receiver's tangent plane z = 0 from z = −0.5 to 0.5;
  // the quadrature panels split at z = 0, where max(cos θx, 0) has its kink.
  const DVec3 x(0.2, 0, 0), n(0, 0, 1);
  const DVec3 s(-0.5, 1, -0.5), ex(1, 0, 0), ey(0, 0, 1);
  const Polygon poly = parallelogram(s, ex, ey);
  CHECK_FALSE(pt::test::polygon_above_tangent_plane(poly, x, n));
  const Polygon clipped = pt::test::clip_polygon_to_hemisphere(poly, x, n);
  CHECK(clipped.size() == 4);
  CHECK(pt::test::polygon_above_tangent_plane(clipped, x, n));
  const double exact = pt::test::polygon_irradiance_clipped(poly, x, n, 1.0);
  const double quad = quadrature_irradiance(s, ex, ey, x, n, 1.0, 16);  // 16 panels: a boundary at b = 0.5
  CHECK(exact == doctest::Approx(quad).epsilon(1e-6));
  // The unclipped formula integrates the signed cosine, so it is wrong here (it cancels the part below).
  CHECK(pt::test::polygon_irradiance(poly, x, n, 1.0) < 0.9 * exact);
  // Tilted receiver normal, the horizon crossing the square diagonally (no panel split: looser agreement).
  const DVec3 nt = glm::normalize(DVec3(0.3, 0, 1));
  CHECK(pt::test::polygon_irradiance_clipped(poly, x, nt, 1.0) ==
        doctest::Approx(quadrature_irradiance(s, ex, ey, x, nt, 1.0, 64)).epsilon(1e-4));
  // Entirely below: nothing.
  CHECK(pt::test::polygon_irradiance_clipped(poly, DVec3(0, 0, 1), n, 1.0) == 0.0);
}

TEST_CASE("analytic irradiance: Lambertian receiver radiance") {
  // ρ·E/π; under an (almost) infinite emitter of radiance L a white receiver reflects L.
  const double L = 3.0, rho = 0.7;
  const double e = pt::test::polygon_irradiance(parallelogram(DVec3(-1e6, -1e6, 1), DVec3(2e6, 0, 0), DVec3(0, 2e6, 0)),
                                                DVec3(0), DVec3(0, 0, 1), L);
  CHECK(pt::test::lambertian_outgoing_radiance(rho, e) == doctest::Approx(rho * L).epsilon(2e-6));
  CHECK(pt::test::lambertian_outgoing_radiance(1.0, std::numbers::pi) == doctest::Approx(1.0).epsilon(1e-15));
}
