// Smooth-interface optics: Fresnel limits, Snell's law, the Lambertian albedo. The BSDFs themselves are tested
// in test_materials.cpp (the smooth dielectric's sampling there too).
#include <doctest/doctest.h>

#include "core/rng.h"
#include "materials/diffuse.h"
#include "materials/fresnel.h"
#include "sampling/sampling.h"

using namespace pt;

TEST_CASE("fresnel: normal incidence, grazing, index 1, total internal reflection") {
  for (float n : {1.33f, 1.5f, 2.4f, 10.f}) {
    const float r0 = sqr((n - 1) / (n + 1));
    CHECK(fresnel_dielectric(1.f, n) == doctest::Approx(r0).epsilon(1e-5));
    CHECK(fresnel_dielectric(1.f, 1.f / n) == doctest::Approx(r0).epsilon(1e-5));  // same from inside
    CHECK(fresnel_dielectric(0.f, n) == doctest::Approx(1.f));                      // grazing: total reflection
  }
  CHECK(fresnel_dielectric(0.3f, 1.f) == doctest::Approx(0.f));  // no interface
  // Inside glass (η = 1/1.5), beyond the critical angle sin θc = 1/1.5: everything reflects.
  const float cos_c = std::sqrt(1.f - sqr(1.f / 1.5f));
  CHECK(fresnel_dielectric(cos_c * 0.99f, 1.f / 1.5f) == 1.f);
  CHECK(fresnel_dielectric(cos_c * 1.01f, 1.f / 1.5f) < 1.f);
  // Monotone in angle from outside.
  float prev = 0.f;
  for (int i = 100; i >= 0; --i) {
    const float f = fresnel_dielectric(i / 100.f, 1.5f);
    CHECK(f >= prev - 1e-6f);
    prev = f;
  }
}

TEST_CASE("fresnel reciprocity: F(θi, η) = F(θt, 1/η)") {
  for (float n : {1.2f, 1.5f, 2.0f}) {
    for (int i = 1; i < 100; ++i) {
      const float cos_i = i / 100.f;
      const float sin_t = std::sqrt(1 - cos_i * cos_i) / n;
      const float cos_t = std::sqrt(1 - sin_t * sin_t);
      CHECK(fresnel_dielectric(cos_i, n) == doctest::Approx(fresnel_dielectric(cos_t, 1.f / n)).epsilon(1e-4));
    }
  }
}

TEST_CASE("refraction obeys Snell's law and reflection the mirror law") {
  Pcg32 rng(4, 4);
  const Vec3 n(0, 0, 1);
  for (int i = 0; i < 1000; ++i) {
    const Vec3 wo = sample_uniform_hemisphere({rng.next_float(), rng.next_float()});
    if (wo.z < 1e-3f) continue;
    const float eta = 1.5f;
    Vec3 wt;
    REQUIRE(refract(wo, n, eta, wt));
    CHECK(glm::length(wt) == doctest::Approx(1.f).epsilon(1e-5));
    CHECK(wt.z < 0.f);
    const float sin_i = std::sqrt(std::max(0.f, 1 - wo.z * wo.z)), sin_t = std::sqrt(std::max(0.f, 1 - wt.z * wt.z));
    CHECK(sin_i == doctest::Approx(eta * sin_t).epsilon(1e-3));
    // The refracted direction stays in the plane of incidence, on the far side of the normal.
    CHECK(glm::dot(glm::cross(n, wo), wt) == doctest::Approx(0.f).scale(1.f).epsilon(1e-4));
    const Vec3 r = reflect(-wo, n);
    CHECK(r.z == doctest::Approx(wo.z).epsilon(1e-5));
    CHECK(r.x == doctest::Approx(-wo.x).scale(1.f).epsilon(1e-5));
  }
}

TEST_CASE("energy: the Lambertian albedo integrates to ρ (≤ 1), and f is reciprocal") {
  // ∫ f cos dω over the hemisphere by a 512×512 midpoint rule in (cos θ, φ).
  const Rgb rho(0.725f, 0.71f, 0.68f);
  const int n = 512;
  double integral = 0;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const double z = (i + 0.5) / n;
      integral += diffuse_f(rho).x * z * (1.0 / n) * (2 * M_PI / n);
    }
  CHECK(integral == doctest::Approx(rho.x).epsilon(1e-5));
  CHECK(integral <= 1.0);
  // Reciprocity holds trivially for Lambert (f independent of direction); the mirror's weight is its tint.
  CHECK(diffuse_f(rho).y == doctest::Approx(rho.y / kPi));
}
