// Accuracy and numerical stability (docs/accuracy.md): agreement with an independent renderer, invariance under
// translation and scale, huge and tiny spheres, light-tightness, energy conservation (furnaces), NaN/Inf
// hardening, rejection of degenerate input, and drift-free accumulation.
//
// Statistics: every render uses the independent sampler and a fixed seed, so each verdict is deterministic.
// Tolerances come from the film's own variance estimates. A check on one z-score allows |z| up to the two-sided
// 1e-5 quantile (4.42): a correct tracer fails it with probability 1e-5 for a given seed. A check on many
// z-scores allows max |z| up to the Bonferroni bound for 1e-5 over all of them, and a mean z² up to the 1e-5 χ²
// quantile (stress::compare_blocks). The scenes and statistics are shared with `pathtracer stress`
// (app/cli/stress_scenes.h).
#include <doctest/doctest.h>

#include <cmath>
#include <limits>

#include "io/image_io.h"
#include "integrators/integrator.h"
#include "render/metrics.h"
#include "core/rng.h"
#include "scene/scene_json.h"
#include "cli/stress_scenes.h"

using namespace pt;
using namespace pt::stress;

namespace {

const Estimator kAll[] = {Estimator::Uniform, Estimator::Cosine, Estimator::Nee, Estimator::Mis, Estimator::Bdpt};

// The two-sided 1e-5 quantile of one z-score.
double z_one() { return normal_upper_quantile(kAlpha / 2); }

// |m − expected| within z_one() standard errors plus a float-rounding allowance, the standard error itself capped
// (as test_direct_light.cpp caps its own): a bug that inflates the noise must fail, not widen its own band
// (uncapped, ±3.5 % passed at ρ = 0.999). Every call's relative standard error is below 1 % at its sample count.
constexpr double kMaxRelSe = 0.01;
bool agrees(double m, double se, double expected, double float_tol) {
  const bool se_ok = se <= kMaxRelSe * std::abs(expected) + float_tol * std::abs(expected);
  if (!se_ok) MESSAGE("standard error " << se << " above " << kMaxRelSe << " of " << expected);
  return se_ok && std::isfinite(m) && std::abs(m - expected) <= z_one() * se + float_tol * std::abs(expected);
}

struct Transform {
  const char* name;
  double scale;
  DVec3 offset;
};

// The transforms of the issue: the largest translation along each axis and the extremes of the scale range
// (the stress command's full matrix runs every decade in between, and beyond).
const Transform kTransforms[] = {
    {"translate x 1e6", 1.0, {1e6, 0, 0}}, {"translate y 1e6", 1.0, {0, 1e6, 0}},
    {"translate z 1e6", 1.0, {0, 0, 1e6}}, {"scale 1e-4", 1e-4, DVec3(0.0)},
    {"scale 1e4", 1e4, DVec3(0.0)},
};

}  // namespace

// --------------------------------------------------------------------------------- 1. independent reference

namespace {

// The Cycles reference of `cornell` (shared/reference/cornell_512_cycles.pfm) block-averaged 4×4 to 128×128. A
// 128×128 render with a box filter one pixel wide integrates exactly what the 4×4 block average of a 512×512
// image integrates, so the two are compared pixel for pixel. 1024 spp at 128² costs what 64 spp at 512² costs.
struct ReferenceComparison {
  Image ref;
  Film film;
  // The reference's own noise: relMSE ≈ 1.6e-5 per 512-pixel (shared/reference/README.md), so ≈ 1.6e-5/16 per
  // 128-pixel (a mean of 16 independent pixels). Its distribution over pixels is modelled as proportional to our
  // per-sample variance (both are path tracers with light sampling and MIS on the same integrand):
  // Var_ref(i,c) = κ·σ²(i,c), κ set so that mean Var_ref/(R²+0.01) = 1e-6. At 1024 spp our own noise is ~200×
  // larger, so the model's details hardly matter; it is accounted for all the same.
  double ref_relmse = 1.6e-5 / 16.0, kappa = 0.0;
  double ref_var(size_t i, int c) const { return kappa * film.variance_of_mean(i)[c] * film.count(i); }
};

const ReferenceComparison& cornell_vs_cycles() {
  static const ReferenceComparison r = [] {
    ReferenceComparison r;
    r.ref = read_pfm(std::string(PT_TEST_DATA_DIR) + "/cornell_128_cycles.pfm");
    REQUIRE(r.ref.width == 128);
    REQUIRE(r.ref.height == 128);
    SceneDesc desc = builtin_at("cornell", 128, 128);
    desc.render.seed = 20260101;
    r.film = render(desc, 1024);
    double mean_rel_sigma2 = 0.0;
    const size_t n = r.film.pixel_count();
    for (size_t i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c) {
        const double R = r.ref.rgb[3 * i + c];
        mean_rel_sigma2 += r.film.variance_of_mean(i)[c] * r.film.count(i) / (R * R + 0.01);
      }
    r.kappa = r.ref_relmse / (mean_rel_sigma2 / (3.0 * n));
    return r;
  }();
  return r;
}

}  // namespace

TEST_CASE("reference: cornell agrees with Cycles in image mean (0.5 %) and in relMSE explained by noise (1.5x)") {
  const ReferenceComparison& r = cornell_vs_cycles();
  CHECK(r.film.rejected() == 0);
  // (a) Image mean per channel within 0.5 % (our standard error of it is ~0.05 %).
  const MeanSE m = film_mean(r.film);
  const glm::dvec3 mr = mean_rgb(r.ref);
  for (int c = 0; c < 3; ++c) {
    MESSAGE("channel " << c << ": image mean " << m.mean[c] << " ± " << m.se[c] << ", Cycles " << mr[c]
                       << ", ratio " << m.mean[c] / mr[c]);
    CHECK(std::abs(m.mean[c] / mr[c] - 1.0) < 0.005);
  }
  // (c) relMSE against the reference within 1.5× of what the two images' noise explains: E[(x−R)²] = Var_ours +
  // Var_ref per pixel, divided by R² + 0.01 as the metric does. A bias of about 0.7 of our noise everywhere would
  // push the ratio past 1.5; an overestimated variance would pull it below 1/1.5.
  const size_t n = r.film.pixel_count();
  const double measured = relmse(Image{128, 128, r.film.mean_image()}, r.ref);
  double explained = 0.0;
  for (size_t i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c) {
      const double R = r.ref.rgb[3 * i + c];
      explained += (r.film.variance_of_mean(i)[c] + r.ref_var(i, c)) / (R * R + 0.01);
    }
  explained /= 3.0 * n;
  MESSAGE("relMSE vs Cycles " << measured << ", explained by noise " << explained << " (ours "
                              << explained - r.ref_relmse << " + reference " << r.ref_relmse << "), ratio "
                              << measured / explained);
  CHECK(measured < 1.5 * explained);
  CHECK(measured > explained / 1.5);
}

// Skipped: the reference is off here, not this tracer (docs/accuracy.md, "Agreement with Cycles"). In the upper
// third of the image this tracer is 0.5–0.7 % brighter than tests/data/cornell_128_cycles.pfm. The exact
// direct-light test (test_direct_light.cpp) puts our direct light within 0.01 % of Lambert's formula there, while
// Cycles 3.4, given the scene in millimetres, samples the light triangles by solid angle in float with fast_acosf
// and loses ~1 % near the light's plane; the same scene in metres renders within 0.07 % of ours. Unskip once the
// reference is re-rendered in metres.
TEST_CASE("reference: every 8x8 block of cornell agrees with Cycles within its statistical tolerance" *
          doctest::skip()) {
  const ReferenceComparison& r = cornell_vs_cycles();
  const int b = 8, bw = 128 / b;  // 8×8 blocks of the 128 image = 32×32 pixels of the 512 reference
  const Blocks ours = blocks_of(r.film, b);
  std::vector<glm::dvec3> ref_mean(ours.mean.size(), glm::dvec3(0.0)), ref_bvar(ours.mean.size(), glm::dvec3(0.0));
  for (int y = 0; y < 128; ++y)
    for (int x = 0; x < 128; ++x) {
      const size_t i = static_cast<size_t>(y) * 128 + x, k = static_cast<size_t>(y / b) * bw + x / b;
      for (int c = 0; c < 3; ++c) {
        ref_mean[k][c] += r.ref.rgb[3 * i + c] / double(b * b);
        ref_bvar[k][c] += r.ref_var(i, c) / double(b * b * b * b);
      }
    }
  double zmax = 0.0, z2 = 0.0;
  int nz = 0;
  for (size_t k = 0; k < ours.mean.size(); ++k)
    for (int c = 0; c < 3; ++c) {
      const double z = (ours.mean[k][c] - ref_mean[k][c]) / std::sqrt(ours.var[k][c] + ref_bvar[k][c]);
      zmax = std::max(zmax, std::abs(z));
      z2 += z * z;
      ++nz;
    }
  const double zbound = bonferroni_z(kAlpha, nz), z2bound = chi2_mean_bound(kAlpha, static_cast<int>(ours.mean.size()));
  MESSAGE("8x8 blocks: max |z| " << zmax << " (bound " << zbound << "), mean z² " << z2 / nz << " (bound " << z2bound
                                 << ") over " << nz);
  CHECK(zmax < zbound);
  CHECK(z2 / nz < z2bound);
}

// ------------------------------------------------------------------------------------------------ 2. invariance

TEST_CASE("invariance: cornell and cornell-spheres translated by 1e6 or scaled by 1e-4 and 1e4 give the same image") {
  for (const char* name : {"cornell", "cornell-spheres"}) {
    SceneDesc base = builtin_at(name, 32, 32);
    base.render.seed = 0;
    const Film ref = render(base, 1024);  // 4× the samples of each copy
    for (const Transform& t : kTransforms) {
      SceneDesc s = transformed(base, t.scale, t.offset);
      s.render.seed = 1;  // independent samples
      const Film f = render(s, 256);
      const Agreement g = compare_blocks(f, ref, 8);
      INFO(std::string(name) << " " << std::string(t.name) << ": max |z| " << g.max_abs_z << " (bound " << g.z_bound << "), mean z² "
                << g.mean_z2 << " (bound " << g.z2_bound << ")");
      CHECK(g.pass);
      CHECK(f.rejected() == 0);
      CHECK(nonfinite_pixels(f) == 0);
    }
  }
}

TEST_CASE("invariance: the transform helper moves camera and geometry together") {
  const SceneDesc base = builtin_at("cornell-spheres", 8, 8);
  // A power-of-two scale: p · scale is then exact, so p · scale + offset rounds once however the compiler evaluates
  // it. (With 1e-3, GCC 12 at -O3 -march=native on an Intel Xeon fused the test's own p · 1e-3 + offset into one
  // FMA despite -ffp-contract=off, and the expected eye point differed from the helper's in its last bit.)
  constexpr double kScale = 0x1p-10;
  const SceneDesc t = transformed(base, kScale, DVec3(5, -7, 1e6));
  CHECK(t.camera.position == base.camera.position * kScale + DVec3(5, -7, 1e6));
  CHECK(t.camera.look_at == base.camera.look_at * kScale + DVec3(5, -7, 1e6));
  CHECK(t.camera.up == base.camera.up);
  for (size_t i = 0; i < base.shapes.size(); ++i) {
    if (base.shapes[i].type == ShapeType::Sphere) {
      CHECK(t.shapes[i].radius == base.shapes[i].radius * kScale);
      CHECK(t.shapes[i].center == base.shapes[i].center * kScale + DVec3(5, -7, 1e6));
    } else {
      CHECK(t.shapes[i].vertices[2] == base.shapes[i].vertices[2] * kScale + DVec3(5, -7, 1e6));
    }
  }
}

// The full matrix's scale probes reach copies the tracer refuses (cornell at scale 1e9 has a vertex 1.41e12 from
// the camera): a refusal must become a row with its reason. The exception used to escape and end the whole run
// at the first such probe.
TEST_CASE("invariance: a copy beyond the representable range is refused with its reason, not rendered") {
  const SceneDesc base = builtin_at("cornell", 8, 8);
  std::string refusal;
  CHECK_FALSE(render_unless_refused(transformed(base, 1e9, DVec3(0.0)), 1, 1, refusal).has_value());
  CHECK(refusal.find("beyond the 1e+12 the tracer represents") != std::string::npos);
  refusal.clear();
  const std::optional<Film> f = render_unless_refused(base, 1, 1, refusal);
  REQUIRE(f.has_value());
  CHECK(f->total_count() == 64);
  CHECK(refusal.empty());
}

// ---------------------------------------------------------------------------------------- 3. huge and tiny spheres

TEST_CASE("huge spheres: a room of six spheres of radius 1e5 renders like the room of quads, without holes") {
  SceneDesc quads = wall_room(false);
  quads.render.seed = 0;
  SceneDesc spheres = wall_room(true, 1e5);
  spheres.render.seed = 1;
  const Film a = render(quads, 1024), b = render(spheres, 512);
  const Agreement g = compare_blocks(b, a, 4);
  INFO("max |z| " << g.max_abs_z << " (bound " << g.z_bound << "), mean z² " << g.mean_z2 << " (bound " << g.z2_bound << ")");
  CHECK(g.pass);
  CHECK(b.rejected() == 0);
  // Emitting walls seen directly: every camera ray hits a wall, so every pixel is exactly Le (a hole would be 0).
  const Film direct = render(wall_room_furnace(true, 1e5, 1.0, 0.5, 0, -1, Estimator::Cosine), 64);
  for (size_t i = 0; i < direct.pixel_count(); ++i) CHECK(direct.mean(i) == Rgb(1.f));
}

TEST_CASE("huge spheres: the closed room of six 1e5-radius spheres is a furnace for cosine, uniform and MIS") {
  // Five bounces, albedo 0.5, emission 1: Le·(1−ρ⁶)/(1−ρ) = 1.96875 per sample for cosine (no randomness in the
  // value), on average for the others.
  const double e = furnace_expected(1.0, 0.5, 5, false);
  for (Estimator est : {Estimator::Uniform, Estimator::Cosine, Estimator::Mis}) {
    const Film f = render(wall_room_furnace(true, 1e5, 1.0, 0.5, 5, -1, est), 64);
    const MeanSE m = film_mean(f);
    INFO(std::string(to_string(est)) << ": " << m.mean.x << " ± " << m.se.x << " vs " << e);
    CHECK(agrees(m.mean.x, m.se.x, e, 1e-5));
    CHECK(f.rejected() == 0);
  }
}

// NEE must find huge emitting spheres: the cone/area choice of sample_li() is tied to the receiver's rounding
// error, not to the sphere's radius (with a margin relative to r, NEE returned Le instead of 1.96875 here).
// bdpt in the same room: its light subpaths start anywhere on the spheres, mostly far outside the room, and a
// vertex on a sphere's inner face sees the eye through the sphere's interior and the wall behind the camera.
// The eye connection's shadow ray, shortened by a relative 2^-12 (49 units of a 2e5-long ray), missed that
// wall, and the splats made the mean 3.1e-4 high (24 standard errors: 1.96906 ± 1.3e-5). With bdpt nearly
// every weight falls on the camera's cosine samples here, so its estimate is almost exact: a tight bound too.
TEST_CASE("huge spheres: NEE and bdpt's light tracing in the furnace room of huge emitting spheres") {
  const double e = furnace_expected(1.0, 0.5, 5, false);
  for (Estimator est : {Estimator::Nee, Estimator::Bdpt}) {
    const Film f = render(wall_room_furnace(true, 1e5, 1.0, 0.5, 5, -1, est), 64);
    const MeanSE m = film_mean(f);
    INFO(std::string(to_string(est)) << ": " << m.mean.x << " ± " << m.se.x << " vs " << e);
    CHECK(agrees(m.mean.x, m.se.x, e, 1e-5));
    if (est == Estimator::Bdpt) CHECK(std::abs(m.mean.x - e) < 2e-5);
    CHECK(f.rejected() == 0);
  }
}

// The same room of six two-sided emitting quads (the stress matrix's control): a receiver on a wall is a hair to
// either side of its own wall's plane, and the spherical rectangle of its own wall seen from there fills a
// hemisphere; NEE samples of it carried that hemisphere's radiance. Before the fix (256 spp, seed 0): nee
// 1.5248 ± 0.0021 for one bounce (z 11.8) and 2.0159 ± 0.0025 for five (z 19); mis 1.97158 ± 0.00065 (z 4.4).
TEST_CASE("furnace: NEE and MIS in the room of two-sided emitting quads (a light does not light itself)") {
  for (const int k : {1, 5}) {
    const double e = furnace_expected(1.0, 0.5, k, false);
    for (Estimator est : {Estimator::Nee, Estimator::Mis, Estimator::Bdpt}) {
      const Film f = render(wall_room_furnace(false, 0, 1.0, 0.5, k, -1, est), 256);
      const MeanSE m = film_mean(f);
      INFO(std::string(to_string(est)) << ", " << k << " bounces: " << m.mean.x << " ± " << m.se.x << " vs " << e);
      CHECK(agrees(m.mean.x, m.se.x, e, 1e-5));
      CHECK(f.rejected() == 0);
    }
  }
}

TEST_CASE("tiny spheres: radius 1e-4 spheres cover exactly their projected area and never hit themselves") {
  // Emitting, no bounce: every sample is 0 or 1, the image mean is the covered fraction of the image plane.
  const SceneDesc lamps = tiny_spheres(1e-4, true);
  const Film f = render(lamps, 256);
  const MeanSE m = film_mean(f);
  const double cover = tiny_spheres_coverage(lamps);
  INFO("coverage " << m.mean.x << " ± " << m.se.x << " vs " << cover);
  CHECK(agrees(m.mean.x, m.se.x, cover, 1e-6));
  CHECK(cover > 0.05);  // the cluster is resolved: this is not a test of an empty image
  // Lit by a uniform background: 0.5 on the sphere, 1 beside it; a self-hit would give 0.25.
  for (Estimator est : kAll) {
    const SceneDesc lit = tiny_spheres(1e-4, false, est);
    const Film g = render(lit, 256);
    const MeanSE ml = film_mean(g);
    const double expected = 1.0 - 0.5 * tiny_spheres_coverage(lit);
    INFO(std::string(to_string(est)) << ": " << ml.mean.x << " ± " << ml.se.x << " vs " << expected);
    CHECK(agrees(ml.mean.x, ml.se.x, expected, 1e-5));
    CHECK(g.rejected() == 0);
  }
}

TEST_CASE("tiny spheres: the projected-area formula matches a direct count") {
  // Independent check of tiny_spheres_coverage(): count image-plane grid points inside each sphere's cone in
  // double (a 2048² grid over the plane: the count's error is ~perimeter/spacing, well below 0.5 %).
  const SceneDesc s = tiny_spheres(1e-4, true);
  const double th = std::tan(glm::radians(s.camera.fov_deg) * 0.5);
  const int N = 2048;
  long inside = 0;
  for (int j = 0; j < N; ++j)
    for (int i = 0; i < N; ++i) {
      const DVec3 d = glm::normalize(DVec3((2.0 * (i + 0.5) / N - 1.0) * th, (2.0 * (j + 0.5) / N - 1.0) * th, -1.0));
      for (const ShapeDesc& sh : s.shapes) {
        const DVec3 c = sh.center - s.camera.position;
        const double along = glm::dot(c, d);
        if (along > 0 && glm::dot(c, c) - along * along <= sh.radius * sh.radius) {
          ++inside;
          break;
        }
      }
    }
  CHECK(double(inside) / (double(N) * N) == doctest::Approx(tiny_spheres_coverage(s)).epsilon(0.005));
}

// ------------------------------------------------------------------------------------------- 4. light-tightness

namespace {

// Renders about `paths` camera paths of a light-tight scene; returns the number of pixels with any light.
int lit_pixels(const SceneDesc& s, int paths, uint64_t& rejected) {
  const Film f = render(s, std::max(2, paths / (s.width * s.height)));
  rejected = f.rejected();
  return nonzero_pixels(f);
}

}  // namespace

// Bright emitters outside (background 1, a quad and a sphere of radiance 1e4): any leak lights a pixel. 1e5 paths
// per case here (2e4 for cosine, which has no shadow rays); `pathtracer stress` traces 1e7.
TEST_CASE("light-tight: a camera in a closed sphere sees no light from outside, at every translation and scale") {
  for (View v : {View::Interior, View::Grazing})
    for (Estimator est : {Estimator::Cosine, Estimator::Mis})
      for (const Transform& t : kTransforms) {
        const SceneDesc s = transformed(light_tight(Enclosure::Sphere, v, est), t.scale, t.offset);
        uint64_t rejected = 0;
        const int lit = lit_pixels(s, est == Estimator::Mis ? 100000 : 20000, rejected);
        INFO((std::string("sphere, ") + to_string(v) + " view, " + to_string(est) + ", " + t.name));
        CHECK(lit == 0);
        CHECK(rejected == 0);
      }
}

// A polygon hit point within its rounding error of a shared edge could land just outside the neighbouring face's
// plane, and the next ray then started behind it and escaped the box (about half the pixels of the vertex and
// edge views leaked). make_interaction() now keeps hit points inside the polygon by more than their error.
TEST_CASE("light-tight: a camera in a closed box (12 triangles, 6 parallelograms) sees no light from outside") {
  for (Enclosure e : {Enclosure::Box12, Enclosure::Box6})
    for (View v : {View::Interior, View::Vertex, View::Edge, View::Diagonal, View::Grazing})
      for (Estimator est : {Estimator::Cosine, Estimator::Mis})
        for (const Transform& t : kTransforms) {
          const SceneDesc s = transformed(light_tight(e, v, est), t.scale, t.offset);
          uint64_t rejected = 0;
          const int lit = lit_pixels(s, est == Estimator::Mis ? 100000 : 20000, rejected);
          INFO((std::string(to_string(e)) + ", " + to_string(v) + " view, " + to_string(est) + ", " + t.name));
          CHECK(lit == 0);
          CHECK(rejected == 0);
        }
}

// --------------------------------------------------------------------------------------------------- 5. energy

TEST_CASE("furnace: Le·(1−ρ^(k+1))/(1−ρ) and Le/(1−ρ) for every estimator, translated and scaled") {
  // The closed emitting sphere; ρ ∈ {0.5, 0.9, 0.99} with 5 bounces; ρ ∈ {0.5, 0.9} with Russian roulette and no
  // bounce limit (ρ = 0.99 with roulette: see the skipped test below). Float tolerance 1e-5 relative (cosine has
  // zero variance).
  std::vector<Transform> transforms = {{"identity", 1.0, DVec3(0.0)}};
  transforms.insert(transforms.end(), std::begin(kTransforms), std::end(kTransforms));
  for (const Transform& t : transforms)
    for (Estimator est : kAll) {
      for (float rho : {0.5f, 0.9f, 0.99f}) {
        const Film f = render(transformed(furnace(Rgb(1.f), Rgb(rho), 5, -1, est), t.scale, t.offset), 256);
        const MeanSE m = film_mean(f);
        const double e = furnace_expected(1.0, rho, 5, false);
        INFO(std::string(t.name) << ", " << std::string(to_string(est)) << ", ρ " << rho << ", 5 bounces: " << m.mean.x << " ± " << m.se.x << " vs " << e);
        CHECK(agrees(m.mean.x, m.se.x, e, 1e-5));
        CHECK(f.rejected() == 0);
      }
      for (float rho : {0.5f, 0.9f}) {
        // The uniform estimator's bounce weight 2ρ·cos θ has second moment (4/3)ρ²: without a bounce limit its
        // variance is infinite for ρ > √(3/4) whatever the roulette, so the film's standard error means nothing.
        if (est == Estimator::Uniform && rho > 0.866f) continue;
        const Film f = render(transformed(furnace(Rgb(1.f), Rgb(rho), unlimited_bounces(est), 0, est), t.scale, t.offset), 256);
        const MeanSE m = film_mean(f);
        const double e = furnace_expected(1.0, rho, 0, true);
        INFO(std::string(t.name) << ", " << std::string(to_string(est)) << ", ρ " << rho << ", roulette: " << m.mean.x << " ± " << m.se.x << " vs " << e);
        CHECK(m.se.x > 0.0);
        CHECK(agrees(m.mean.x, m.se.x, e, 1e-5));
      }
    }
}

// With survival capped at c, the second moment Σ_k c^k·(ρ/c)^(2k) diverges once ρ² > c: a cap of 0.95 gave
// ~250 instead of 1000 at ρ = 0.999. The cap is now 1 − 2^-10.
TEST_CASE("furnace: Russian roulette stays unbiased for ρ just below 1") {
  for (float rho : {0.99f, 0.999f})
    for (Estimator est : {Estimator::Cosine, Estimator::Nee, Estimator::Mis}) {  // uniform: infinite variance here
      const Film f = render(furnace(Rgb(1.f), Rgb(rho), 1 << 30, 0, est), 256);
      const MeanSE m = film_mean(f);
      const double e = furnace_expected(1.0, rho, 0, true);
      INFO(std::string(to_string(est)) << ", ρ " << rho << ": " << m.mean.x << " ± " << m.se.x << " vs " << e);
      CHECK(agrees(m.mean.x, m.se.x, e, 1e-5));
    }
}

TEST_CASE("furnace: Russian roulette ends every path of an albedo-1 closed room") {
  // No bounce limit: only roulette can end these paths. Every one must end, after a finite number of rays.
  const SceneDesc s = furnace(Rgb(1.f), Rgb(1.f), 1 << 30, 0, Estimator::Cosine);
  const auto scene = compile_scene(s);
  uint64_t total = 0, longest = 0;
  const int paths = 20000;
  for (int i = 0; i < paths; ++i) {
    IndependentSampler sampler(static_cast<uint64_t>(i), 0, 3);
    RayCount count;
    const Vec2 u = sampler.get_2d(SampleDimensions::kCameraJitter);
    const Rgb L = estimate_radiance(*scene, s.render, scene->camera.generate_ray(u.x * 8, u.y * 8), sampler, count);
    CHECK(is_finite(L));
    total += count.rays;
    longest = std::max<uint64_t>(longest, count.rays);
  }
  MESSAGE("albedo-1 room: mean path length " << double(total) / paths << " rays, longest " << longest);
  CHECK(longest < 100000u);
}

TEST_CASE("white furnace: albedo 1 under background 1, every estimator and material, translated and scaled") {
  std::vector<Transform> transforms = {{"identity", 1.0, DVec3(0.0)}};
  transforms.insert(transforms.end(), std::begin(kTransforms), std::end(kTransforms));
  for (const Transform& t : transforms)
    for (MaterialType type : {MaterialType::Diffuse, MaterialType::Mirror, MaterialType::Dielectric})
      for (Estimator est : kAll) {
        const Film f = render(transformed(white_furnace(type, est), t.scale, t.offset), 64);
        const MeanSE m = film_mean(f);
        INFO(std::string(t.name) << ", " << std::string(to_string(type)) << ", " << std::string(to_string(est)) << ": " << m.mean.x << " ± " << m.se.x);
        // Dielectric: paths still inside after 1000 bounces lose their share (< 1e-4).
        CHECK(agrees(m.mean.x, m.se.x, 1.0, type == MaterialType::Dielectric ? 1e-4 : 1e-5));
        CHECK(f.rejected() == 0);
        // Exactly 1 per sample: the albedo-1 mirror (any estimator) and the diffuse sphere with `cosine` (a
        // cosine sample ends the path only for a random number exactly 0, probability 2^-23: not at this seed).
        if (type == MaterialType::Mirror || (type == MaterialType::Diffuse && est == Estimator::Cosine))
          for (size_t i = 0; i < f.pixel_count(); ++i) CHECK(f.mean(i) == Rgb(1.f));
      }
}

// ---------------------------------------------------------------------------------------------- 6. NaN and Inf

TEST_CASE("nan hardening: scenes that invite NaN and Inf never put a non-finite value into the film") {
  for (const NamedScene& h : hazard_scenes(16))
    for (Estimator est : kAll) {
      SceneDesc s = h.scene;
      s.render.estimator = est;
      if (est == Estimator::Bdpt) s.render.max_bounces = std::min(s.render.max_bounces, kMaxBdptBounces);
      const Film f = render(s, 32);
      INFO(h.name << ", " << std::string(to_string(est)));
      CHECK(f.rejected() == 0);
      CHECK(nonfinite_pixels(f) == 0);
      CHECK(f.min_count() == 32u);
    }
}

TEST_CASE("nan hardening: emission 1e30 scales the image exactly and a dielectric of index 1 is invisible") {
  {
    // Same seed, same paths: the image is the emission-17 image times 1e30/17 to float rounding.
    SceneDesc base = builtin_at("cornell", 16, 16), big = base;
    for (MaterialDesc& m : big.materials)
      if (m.name == "light") m.emission = Rgb(1e30f, 12e30f / 17.f, 4e30f / 17.f);
    const Film a = render(base, 64), b = render(big, 64);
    CHECK(b.rejected() == 0);
    double worst = 0.0;
    for (size_t i = 0; i < a.pixel_count(); ++i)
      for (int c = 0; c < 3; ++c) {
        const double x = a.mean_channel(i, c) * (1e30 / 17.0), y = b.mean_channel(i, c);
        if (x != y) worst = std::max(worst, std::abs(y - x) / std::abs(x));
      }
    INFO("max relative deviation " << worst);
    CHECK(worst <= 1e-5);
  }
  {
    SceneDesc with = builtin_at("cornell-spheres", 32, 32), without = with;
    for (MaterialDesc& m : with.materials)
      if (m.type == MaterialType::Dielectric) m.ior = 1.f;
    std::erase_if(without.shapes,
                  [&](const ShapeDesc& sh) { return without.materials[sh.material].type == MaterialType::Dielectric; });
    REQUIRE(without.shapes.size() + 1 == with.shapes.size());
    with.render.seed = 1;
    const Agreement g = compare_blocks(render(with, 256), render(without, 256), 8);
    INFO("max |z| " << g.max_abs_z << " (bound " << g.z_bound << "), mean z² " << g.mean_z2 << " (bound " << g.z2_bound << ")");
    CHECK(g.pass);
  }
}

TEST_CASE("degenerate input: zero-area polygons and NaN coordinates are rejected with the path and the reason") {
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  auto scene_with = [](ShapeDesc sh) {
    SceneDesc s = builtin_at("cornell", 8, 8);
    s.shapes.push_back(sh);
    return s;
  };
  const size_t idx = builtin_at("cornell", 8, 8).shapes.size();
  const std::string p = "shapes[" + std::to_string(idx) + "]";
  auto tri = [](DVec3 a, DVec3 b, DVec3 c) {
    ShapeDesc sh;
    sh.type = ShapeType::Triangle;
    sh.vertices = {a, b, c, DVec3(0.0)};
    return sh;
  };
  struct Case {
    const char* what;
    SceneDesc scene;
    std::string message;
  };
  ShapeDesc zero_quad;
  zero_quad.type = ShapeType::Quad;
  zero_quad.vertices = {DVec3(0, 0, 0), DVec3(1, 0, 0), DVec3(2, 0, 0), DVec3(3, 0, 0)};
  ShapeDesc nan_sphere;
  nan_sphere.type = ShapeType::Sphere;
  nan_sphere.center = DVec3(0, nan, 0);
  nan_sphere.radius = 1;
  ShapeDesc nan_radius = nan_sphere;
  nan_radius.center = DVec3(0.0);
  nan_radius.radius = nan;
  SceneDesc nan_camera = builtin_at("cornell", 8, 8);
  nan_camera.camera.position.z = nan;
  SceneDesc nan_emission = builtin_at("cornell", 8, 8);
  nan_emission.materials[0].emission = Rgb(std::numeric_limits<float>::quiet_NaN());
  const Case cases[] = {
      {"repeated vertex", scene_with(tri({0, 0, 0}, {0, 0, 0}, {1, 0, 0})), p + ".vertices: degenerate polygon"},
      {"collinear vertices", scene_with(tri({0, 0, 0}, {1, 1, 1}, {2, 2, 2})), p + ".vertices: degenerate polygon"},
      {"1e-13 sliver", scene_with(tri({0, 0, 0}, {1, 0, 0}, {0.5, 1e-13, 0})), p + ".vertices: degenerate polygon"},
      {"zero-area quad", scene_with(zero_quad), p + ".vertices: degenerate polygon"},
      {"NaN vertex", scene_with(tri({0, 0, 0}, {1, nan, 0}, {0, 1, 0})), p + ".vertices[1]: must be finite"},
      {"infinite vertex", scene_with(tri({inf, 0, 0}, {1, 0, 0}, {0, 1, 0})), p + ".vertices[0]: must be finite"},
      {"NaN sphere centre", scene_with(nan_sphere), p + ".center: must be finite"},
      {"NaN radius", scene_with(nan_radius), p + ".radius: must be finite and > 0"},
      {"NaN camera", nan_camera, "camera.position: must be finite"},
      {"NaN emission", nan_emission, "emission: components must be finite"},
  };
  for (const Case& c : cases) {
    INFO(std::string(c.what));
    const std::string err = validate_scene(c.scene);
    CHECK(err.find(c.message) != std::string::npos);
    CHECK_THROWS_AS(compile_scene(c.scene), std::invalid_argument);
    // Through the file path: scene_to_json writes NaN and Inf as null, and parse_scene rejects the file naming the
    // JSON path; a degenerate polygon is rejected by the same validation.
    std::string text;
    try {
      text = scene_to_json(c.scene);
    } catch (const std::exception&) {
    }
    if (!text.empty()) {
      std::string load_error;
      try {
        parse_scene(text, "bad.json");
      } catch (const SceneError& e) {
        load_error = e.what();
      }
      INFO("parse_scene: " << load_error);
      CHECK(load_error.rfind("bad.json: ", 0) == 0);
    }
  }
  // A sliver 1e-7 thin (sine 2e-7) is legitimate geometry, not degenerate.
  CHECK(validate_scene(scene_with(tri({0, 0, 0}, {1, 0, 0}, {0.5, 1e-7, 0}))) == "");
  // JSON has no NaN; the literal is a syntax error naming the line and column.
  std::string nan_text = scene_to_json(scene_with(tri({0, 0, 0}, {1, 0, 0}, {0, 1, 0})));
  nan_text.replace(nan_text.rfind("[1, 0, 0]"), 9, "[1, NaN, 0]");
  CHECK_THROWS_WITH_AS(parse_scene(nan_text, "nan.json"), doctest::Contains("nan.json: line"), SceneError);
}

// ------------------------------------------------------------------------------------------- 7. accumulation

TEST_CASE("film: over 1e8 samples the plain float running average drifts, the Film stays exact to 1e-9") {
  // Fireflies: x = 101 with probability 1 %, else 1 (mean 2). The samples are integers, so the exact mean of the
  // samples drawn is 1 + 100·hits/n, computed without rounding. The float blend mean += (x − mean)/(n+1) stops
  // following the 1s once 1/n is below half an ulp of the mean (n ≈ 8e6) but keeps adding the 100/n of the
  // fireflies: it drifts upwards by ~ln(n/8e6) (tens of per cent), where the Film's double Welford update stays
  // exact to ~1e-13.
  const uint64_t n = 100000000ull;
  Film film(1, 1);
  float blend = 0.f;
  uint64_t hits = 0;
  Pcg32 rng(2026, 1);
  for (uint64_t i = 0; i < n; ++i) {
    const bool hit = rng.next_u32() < 42949673u;  // ≈ 2^32/100
    hits += hit;
    const float x = hit ? 101.f : 1.f;
    film.add_sample(0, Rgb(x));
    blend += (x - blend) / static_cast<float>(i + 1);
  }
  const double exact = 1.0 + 100.0 * static_cast<double>(hits) / static_cast<double>(n);
  const double film_err = std::abs(film.mean_channel(0, 0) - exact) / exact;
  const double blend_err = std::abs(static_cast<double>(blend) - exact) / exact;
  MESSAGE("1e8 samples: exact mean " << exact << ", Film " << film.mean_channel(0, 0) << " (relative error "
                                     << film_err << "), float blend " << blend << " (relative error " << blend_err << ")");
  CHECK(film.count(0) == static_cast<uint32_t>(n));
  CHECK(film_err <= 1e-9);
  CHECK(blend_err > 1e-2);
}
