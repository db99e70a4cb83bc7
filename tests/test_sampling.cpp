// Every sampling routine against its pdf: chi-square tests at fixed seeds (significance 1 % per test; the
// seeds are fixed, so a pass is reproducible and a real mismatch of pdf and sampler fails with p ≪ 1e-6), and
// numerical integration showing each pdf integrates to 1.
#include <doctest/doctest.h>

#include <functional>

#include "chi2.h"
#include "lights/light_sampling.h"
#include "core/rng.h"
#include "sampling/sampling.h"

#include "test_helpers.h"

using namespace pt;
using pt::test::chi2_test;

namespace {

constexpr int kThetaBins = 24, kPhiBins = 48;
constexpr double kAlpha = 0.01;

using DirSampler = std::function<bool(Vec2 u, Vec3& dir)>;  // false = no sample
using DirPdf = std::function<double(Vec3 dir)>;

int bin_of(Vec3 d) {
  const double z = std::clamp(static_cast<double>(d.z), -1.0, 1.0);
  int ti = static_cast<int>((z + 1.0) * 0.5 * kThetaBins);
  double phi = std::atan2(static_cast<double>(d.y), static_cast<double>(d.x));
  if (phi < 0) phi += 2 * M_PI;
  int pi = static_cast<int>(phi / (2 * M_PI) * kPhiBins);
  ti = std::clamp(ti, 0, kThetaBins - 1);
  pi = std::clamp(pi, 0, kPhiBins - 1);
  return ti * kPhiBins + pi;
}

Vec3 dir_of(double z, double phi) {
  const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
  return Vec3(static_cast<float>(r * std::cos(phi)), static_cast<float>(r * std::sin(phi)), static_cast<float>(z));
}

// Expected counts: N·∫bin pdf dω with dω = dz dφ, by an 8×8 midpoint rule inside each bin.
std::vector<double> expected_counts(const DirPdf& pdf, double n, double* total_integral) {
  std::vector<double> e(kThetaBins * kPhiBins, 0.0);
  const int sub = 32;
  const double dz = 2.0 / kThetaBins, dphi = 2 * M_PI / kPhiBins;
  double total = 0;
  for (int ti = 0; ti < kThetaBins; ++ti)
    for (int pi = 0; pi < kPhiBins; ++pi) {
      // Midpoint rule; cells the pdf's support boundary crosses (some sub-samples zero, some not) are
      // integrated again 4 times finer (128×128 points), so boundary cells' expectations are accurate to well
      // under 1 %.
      auto integrate = [&](int k, bool& mixed) {
        double sum = 0;
        int zeros = 0;
        for (int a = 0; a < k; ++a)
          for (int b = 0; b < k; ++b) {
            const double z = -1.0 + (ti + (a + 0.5) / k) * dz;
            const double phi = (pi + (b + 0.5) / k) * dphi;
            const double v = pdf(dir_of(z, phi));
            sum += v;
            zeros += v == 0.0;
          }
        mixed = zeros > 0 && zeros < k * k;
        return sum * dz * dphi / (k * k);
      };
      bool mixed = false;
      double s = integrate(sub, mixed);
      if (mixed) s = integrate(sub * 4, mixed);
      total += s;
      e[ti * kPhiBins + pi] = n * s;
    }
  if (total_integral) *total_integral = total;
  return e;
}

void check_direction_sampler(const char* name, const DirSampler& sample, const DirPdf& pdf, double expected_mass = 1.0) {
  const int n = 1000000;
  Pcg32 rng(1234, 99);
  std::vector<double> obs(kThetaBins * kPhiBins, 0.0);
  int produced = 0;
  for (int i = 0; i < n; ++i) {
    Vec3 d;
    const Vec2 u(rng.next_float(), rng.next_float());
    if (!sample(u, d)) continue;
    ++produced;
    obs[bin_of(d)] += 1;
  }
  double integral = 0;
  const auto exp = expected_counts(pdf, produced, &integral);
  const auto r = chi2_test(obs, exp);
  INFO(std::string(name) << ": chi2 = " << r.statistic << ", dof = " << r.dof << ", p = " << r.p_value << ", pdf integral = " << integral);
  // Samples in cells whose integrated pdf is 0: only a support boundary slipping between the 32×32 integration
  // points can cause that, which holds a negligible share of the mass.
  CHECK(r.unexpected <= 2e-5 * produced);
  CHECK(r.p_value > kAlpha);
  CHECK(integral == doctest::Approx(expected_mass).epsilon(2e-3));
}

}  // namespace

TEST_CASE("sampling: uniform hemisphere") {
  check_direction_sampler(
      "uniform hemisphere", [](Vec2 u, Vec3& d) { d = sample_uniform_hemisphere(u); return true; },
      [](Vec3 d) { return d.z >= 0 ? uniform_hemisphere_pdf() : 0.0; });
}

TEST_CASE("sampling: cosine hemisphere") {
  check_direction_sampler(
      "cosine hemisphere", [](Vec2 u, Vec3& d) { d = sample_cosine_hemisphere(u); return true; },
      [](Vec3 d) { return cosine_hemisphere_pdf(d.z); });
}

TEST_CASE("sampling: uniform sphere") {
  check_direction_sampler(
      "uniform sphere", [](Vec2 u, Vec3& d) { d = sample_uniform_sphere(u); return true; },
      [](Vec3) { return uniform_sphere_pdf(); });
}

TEST_CASE("sampling: uniform cone") {
  for (float omc : {0.35f, 0.9f}) {
    check_direction_sampler(
        "uniform cone", [omc](Vec2 u, Vec3& d) { d = sample_uniform_cone(u, omc); return true; },
        [omc](Vec3 d) { return d.z >= 1.f - omc ? uniform_cone_pdf(omc) : 0.0; });
  }
}

TEST_CASE("sampling: the quarter-turn sine and cosine are within 2 ulp of the true values on [-pi/4, pi/4]") {
  // Against double-precision libm, on 2^20 + 1 evenly spaced angles and the end points.
  const double limit = M_PI / 4;
  double worst_ulps = 0;
  for (int i = 0; i <= (1 << 20); ++i) {
    const float x = static_cast<float>(-limit + 2 * limit * i / (1 << 20));
    const Vec2 cs = cos_sin_quarter_turn(x);
    const double c = std::cos(static_cast<double>(x)), s = std::sin(static_cast<double>(x));
    // One ulp of a float of magnitude |v|: 2^(exponent − 23).
    const auto ulps = [](double got, double want) {
      const double ulp = std::ldexp(1.0, std::ilogb(std::max(std::abs(want), 0x1p-126)) - 23);
      return std::abs(got - want) / ulp;
    };
    worst_ulps = std::max({worst_ulps, ulps(cs.x, c), ulps(cs.y, s)});
  }
  INFO("worst error " << worst_ulps << " ulp");
  CHECK(worst_ulps <= 2.0);
}

TEST_CASE("sampling: concentric disk and triangle are uniform by area") {
  const int n = 1000000, bins = 40;
  Pcg32 rng(77, 5);
  std::vector<double> disk(bins * bins, 0.0), triangle(bins * bins, 0.0);
  for (int i = 0; i < n; ++i) {
    const Vec2 u(rng.next_float(), rng.next_float());
    const Vec2 p = sample_uniform_disk_concentric(u);  // in [−1,1]²
    CHECK_LE(glm::dot(p, p), 1.0f + 1e-6f);
    disk[std::clamp(static_cast<int>((p.y + 1) / 2 * bins), 0, bins - 1) * bins +
         std::clamp(static_cast<int>((p.x + 1) / 2 * bins), 0, bins - 1)] += 1;
    const Vec2 b = sample_uniform_triangle(u);  // (b0, b1) in the unit right triangle
    REQUIRE(b.x >= 0.f);
    REQUIRE(b.y >= 0.f);
    REQUIRE(b.x + b.y <= 1.f + 1e-6f);
    triangle[std::clamp(static_cast<int>(b.y * bins), 0, bins - 1) * bins + std::clamp(static_cast<int>(b.x * bins), 0, bins - 1)] += 1;
  }
  // Expected: N · (area of cell ∩ domain) / (domain area), areas by a 16×16 sub-grid count.
  std::vector<double> e_disk(bins * bins), e_tri(bins * bins);
  const int sub = 64;
  for (int y = 0; y < bins; ++y)
    for (int x = 0; x < bins; ++x) {
      int in_disk = 0, in_tri = 0;
      for (int a = 0; a < sub; ++a)
        for (int b = 0; b < sub; ++b) {
          const double fx = (x + (b + 0.5) / sub) / bins, fy = (y + (a + 0.5) / sub) / bins;
          const double dx = 2 * fx - 1, dy = 2 * fy - 1;
          in_disk += dx * dx + dy * dy <= 1.0;
          in_tri += fx + fy <= 1.0;
        }
      const double cell = 1.0 / (bins * bins * sub * sub);
      e_disk[y * bins + x] = n * (in_disk * cell * 4.0) / M_PI;  // disk area π in a square of area 4
      e_tri[y * bins + x] = n * (in_tri * cell) / 0.5;
    }
  // Boundary cells' areas come from a 64×64 sub-grid count: accurate to ~1/64 of the boundary's share.
  const auto rd = chi2_test(disk, e_disk), rt = chi2_test(triangle, e_tri);
  INFO("disk chi2 " << rd.statistic << " dof " << rd.dof << " p " << rd.p_value);
  INFO("triangle chi2 " << rt.statistic << " dof " << rt.dof << " p " << rt.p_value);
  CHECK(rd.p_value > kAlpha);
  CHECK(rt.p_value > kAlpha);
}

TEST_CASE("light sampling: sampled directions follow the strategy's pdf (rectangle, quad, triangle, sphere outside)") {
  // A receiver at the origin; a parallelogram light, a triangle light and a sphere light around it.
  SceneDesc s;
  s.camera.position = {0, 0, 0};
  s.camera.look_at = {0, 0, -1};
  const MaterialDesc a = test::diffuse_material("a", Rgb(0.f), Rgb(4.f, 3.f, 2.f), false);
  const MaterialDesc b = test::diffuse_material("b", Rgb(0.f), Rgb(1.f, 1.f, 1.f), true);
  s.materials = {a, b};
  ShapeDesc quad;  // above, facing down (its front normal −y)
  quad.type = ShapeType::Quad;
  quad.vertices = {DVec3(-0.7, 1, -0.5), DVec3(0.8, 1, -0.5), DVec3(0.8, 1, 0.6), DVec3(-0.7, 1, 0.6)};
  quad.material = 0;
  ShapeDesc trig;  // to the side, two-sided emitter
  trig.type = ShapeType::Triangle;
  trig.vertices = {DVec3(2, -1, -1), DVec3(2, 1, 0), DVec3(2, -0.5, 1.5), DVec3(0)};
  trig.material = 1;
  ShapeDesc ball;
  ball.type = ShapeType::Sphere;
  ball.center = {-1, -1.2, 0.4};
  ball.radius = 0.6;
  ball.material = 1;
  ShapeDesc skew;  // below, facing up: a parallelogram that is no rectangle (sampled by area)
  skew.type = ShapeType::Quad;
  skew.vertices = {DVec3(-0.5, -1.5, -1.5), DVec3(0.2, -1.5, -0.7), DVec3(1.2, -1.5, -0.7), DVec3(0.5, -1.5, -1.5)};
  skew.material = 0;
  s.shapes = {quad, trig, ball, skew};
  const auto scene = compile_scene(s);
  REQUIRE(scene->lights.size() == 4);
  CHECK(scene->lights[0].kind == LightKind::Rectangle);
  CHECK(scene->lights[1].kind == LightKind::Polygon);
  CHECK(scene->lights[2].kind == LightKind::Polygon);
  CHECK(scene->lights[3].kind == LightKind::Sphere);
  for (int k : {0, 2}) CHECK(glm::dot(scene->polygons.normal[scene->lights[k].prim], Vec3(0.f) - scene->polygons.v[0][scene->lights[k].prim]) > 0.f);
  const Vec3 ref(0.f);

  // Density of the whole light-sampling strategy in direction d: the light it would hit first.
  auto pdf = [&](Vec3 d) -> double {
    Hit h;
    const Ray ray{ref, glm::normalize(d)};
    if (!scene->intersect(ray, kInfinity, ~0u, h)) return 0.0;
    const Interaction it = make_interaction(*scene, ray, h);
    return lights_pdf_area(*scene, scene->light_of_prim[h.prim], ref, Vec3(0, 1, 0), it.p, it.ng);
  };
  Pcg32 choice(9, 9);
  check_direction_sampler(
      "lights",
      [&](Vec2 u, Vec3& d) {
        LightSample ls;
        int li;
        if (!sample_lights(*scene, {ref, Vec3(0, 1, 0)}, choice.next_float(), u, ls, li, false)) return false;
        d = ls.wi;
        return true;
      },
      pdf);
}

TEST_CASE("light sampling: inside an emitting sphere, area sampling matches its pdf") {
  SceneDesc s;
  s.camera.position = {0, 0, 0};
  s.camera.look_at = {0, 0, -1};
  s.materials = {test::diffuse_material("e", Rgb(0.5f), Rgb(1.f), true)};
  ShapeDesc ball;
  ball.type = ShapeType::Sphere;
  ball.center = {0.3, -0.2, 0.1};
  ball.radius = 1.0;
  s.shapes = {ball};
  const auto scene = compile_scene(s);
  const Vec3 ref(0.f);
  auto pdf = [&](Vec3 d) -> double {
    Hit h;
    const Ray ray{ref, glm::normalize(d)};
    if (!scene->intersect(ray, kInfinity, ~0u, h)) return 0.0;
    const Interaction it = make_interaction(*scene, ray, h);
    return lights_pdf_area(*scene, 0, ref, Vec3(0, 1, 0), it.p, it.ng);
  };
  check_direction_sampler(
      "inside sphere",
      [&](Vec2 u, Vec3& d) {
        LightSample ls;
        int li;
        if (!sample_lights(*scene, {ref, Vec3(0, 1, 0)}, 0.5f, u, ls, li, false)) return false;
        d = ls.wi;
        return true;
      },
      pdf);
}

TEST_CASE("rng: PCG32 streams are reproducible and distinct") {
  Pcg32 a(10, 3), b(10, 3), c(10, 4), d(11, 3);
  const uint32_t x = a.next_u32();
  CHECK(x == b.next_u32());
  CHECK(x != c.next_u32());
  CHECK(x != d.next_u32());
  // next_float stays in [0,1) and its mean is 1/2 (1e6 draws: standard error 2.9e-4, tolerance 5 SE).
  Pcg32 r(1, 2);
  double sum = 0;
  for (int i = 0; i < 1000000; ++i) {
    const float f = r.next_float();
    REQUIRE(f >= 0.f);
    REQUIRE(f < 1.f);
    sum += f;
  }
  CHECK(sum / 1e6 == doctest::Approx(0.5).epsilon(0.003));
}

TEST_CASE("light sampling: the background as a light, mixed with an area light") {
  SceneDesc s;
  s.camera.position = {0, 0, 0};
  s.camera.look_at = {0, 0, -1};
  s.environment.radiance = Rgb(0.2f, 0.3f, 0.4f);
  s.materials = {test::diffuse_material("e", Rgb(0.f), Rgb(5.f), false)};
  ShapeDesc quad;  // above the receiver, facing down
  quad.type = ShapeType::Quad;
  quad.vertices = {DVec3(-0.5, 1, -0.5), DVec3(0.5, 1, -0.5), DVec3(0.5, 1, 0.5), DVec3(-0.5, 1, 0.5)};
  s.shapes = {quad};
  const auto scene = compile_scene(s);
  REQUIRE(scene->infinite_lights == std::vector<uint32_t>{1});
  const Vec3 ref(0.f), n = glm::normalize(Vec3(0.3f, 1.f, 0.2f));
  // The environment strategy samples all directions above the receiver, including those the quad covers;
  // the combined density in those directions is the sum of both strategies' densities.
  auto total_pdf = [&](Vec3 d) -> double {
    d = glm::normalize(d);
    Hit h;
    const Ray ray{ref, d};
    double p = lights_pdf_infinite(*scene, n, d, false);
    if (scene->intersect(ray, kInfinity, ~0u, h)) {
      const Interaction it = make_interaction(*scene, ray, h);
      p += lights_pdf_area(*scene, scene->light_of_prim[h.prim], ref, n, it.p, it.ng);
    }
    return p;
  };
  Pcg32 choice(3, 3);
  check_direction_sampler(
      "background + quad",
      [&](Vec2 u, Vec3& d) {
        LightSample ls;
        int li;
        if (!sample_lights(*scene, {ref, n}, choice.next_float(), u, ls, li, false)) return false;
        d = ls.wi;
        return true;
      },
      total_pdf);
}
