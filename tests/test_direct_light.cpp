// An exact reference for direct light: the built-in `cornell` scene with max_bounces = 1 against Lambert's
// closed-form irradiance of its polygonal light (analytic_irradiance.h).
//
// With max_bounces = 1 a pixel is the emission seen directly plus the direct light of the first hit, nothing
// else (mis: one light sample and the MIS-weighted emission found by the BSDF sample; nee: the light sample;
// cosine: the emission found by the BSDF sample). Two regions have exact values:
// - the upper back wall (z = 559.2, white, ρ = (0.725, 0.71, 0.68)): every point above the tall block's top
//   (y = 330) sees the whole light, so its outgoing radiance is ρ·E(x)/π with E = Le·(projected solid angle of
//   the light), Le = (17, 12, 4). A pixel's value is the mean of that over its footprint (box filter one pixel
//   wide), computed in double on 16×16 sub-positions of the pixel, each mapped to the wall through the scene's
//   own camera. Pixels are kept only when their whole footprint is on the wall above y = 347, where the camera's
//   view clears the tall block too (a ray to height y on the wall passes the block's nearest face, z = 247, at
//   273 + 0.7703·(y − 273) > 330). Every sub-position's ray is traced through the scene to confirm it.
// - the ceiling (y = 548.8): the light faces down and is one-sided, so the ceiling's direct light is exactly 0
//   (its pixels, away from the light's own, must be exactly 0).
//
// Statistics (as in test_accuracy.cpp): independent sampler and fixed seed, so each verdict is deterministic;
// tolerances from the film's own per-pixel variance of the mean, false-alarm probability kAlpha = 1e-5 per
// verdict: max |z| below the Bonferroni bound over all z-scores, mean z² below the χ² bound counting one degree
// of freedom per pixel (the three channels of a direct-light sample are proportional: one degree of freedom),
// the region mean within the two-sided 1e-5 quantile (4.42) of its standard error and within 0.1 %.
#include <doctest/doctest.h>

#include <cmath>
#include <map>
#include <numbers>
#include <vector>

#include "analytic_irradiance.h"
#include "cli/stress_scenes.h"
#include "render/renderer.h"
#include "scene/scene_json.h"

using namespace pt;

namespace {

constexpr int kSize = 128;  // image width and height
constexpr int kSub = 16;    // sub-positions per pixel side for the expected values
const glm::dvec3 kWhite(0.725, 0.71, 0.68), kLe(17.0, 12.0, 4.0);
const pt::test::Polygon kLight = {{343, 548.7, 227}, {343, 548.7, 332}, {213, 548.7, 332}, {213, 548.7, 227}};
constexpr double kBackZ = 559.2, kCeilingY = 548.8;
constexpr double kClearY = 347.0;  // above this the camera sees the back wall past the tall block (see above)

SceneDesc direct_light_scene(Estimator est, uint64_t seed) {
  SceneDesc s = load_scene("cornell");
  s.width = s.height = kSize;
  s.render.max_bounces = 1;
  s.render.estimator = est;
  s.render.sampler = SamplerType::Independent;  // the film's variance is valid for independent samples only
  s.render.seed = seed;
  return s;
}

// The world point where the camera ray through image position (x, y) meets the plane p[axis] = value.
glm::dvec3 on_plane(const Scene& s, double x, double y, int axis, double value) {
  const glm::dvec3 d(s.camera.generate_ray(static_cast<float>(x), static_cast<float>(y)).d);
  return s.world_origin + d * ((value - s.world_origin[axis]) / d[axis]);
}

// The camera ray through (x, y) hits `p` first (its closest hit in the scene is at p's distance).
bool sees_first(const Scene& s, double x, double y, glm::dvec3 p) {
  const Ray r = s.camera.generate_ray(static_cast<float>(x), static_cast<float>(y));
  Hit h;
  if (!s.intersect(r, kInfinity, ~0u, h)) return false;
  const double t = glm::length(p - s.world_origin);
  return std::abs(h.t - t) <= 1e-4 * t;
}

struct Reference {
  std::vector<size_t> wall;             // pixel indices whose footprint is on the lit upper back wall
  std::vector<glm::dvec3> expected;     // their exact values, per channel
  std::vector<size_t> ceiling;          // pixel indices whose footprint is on the ceiling, away from the light
};

const Reference& reference() {
  static const Reference ref = [] {
    Reference r;
    const auto scene = compile_scene(direct_light_scene(Estimator::Mis, 0));
    const Scene& s = *scene;
    const glm::dvec3 n_wall(0, 0, -1);
    int bad = 0;  // sub-positions whose camera ray does not hit the plane first (or a wall point below the light)
    for (int y = 0; y < kSize; ++y)
      for (int x = 0; x < kSize; ++x) {
        const size_t i = static_cast<size_t>(y) * kSize + x;
        // The footprint's corners on each plane (the back wall is parallel to the image plane, so the footprint
        // there is a square; on the ceiling a convex quadrilateral: corners suffice for both).
        bool on_wall = true, on_ceiling = true;
        for (int cy = 0; cy <= 1; ++cy)
          for (int cx = 0; cx <= 1; ++cx) {
            const glm::dvec3 w = on_plane(s, x + cx, y + cy, 2, kBackZ);
            on_wall = on_wall && w.x > 0.0 && w.x < 549.6 && w.y > kClearY && w.y < kCeilingY;
            const glm::dvec3 c = on_plane(s, x + cx, y + cy, 1, kCeilingY);
            const double dy = c.y - s.world_origin.y, dz = c.z - s.world_origin.z;
            on_ceiling = on_ceiling && dy > 0.0 && dz > 0.0 && c.x > 10.0 && c.x < 546.0 && c.z > 10.0 &&
                         c.z < 549.0;
          }
        // Away from the light (x 213…343, z 227…332) by 2 units: a ray to the ceiling crosses the light's plane,
        // 0.1 lower, at most 0.5 units from where it meets the ceiling. The footprint's bounding box must clear it.
        if (on_ceiling) {
          double x0 = 1e30, x1 = -1e30, z0 = 1e30, z1 = -1e30;
          for (int cy = 0; cy <= 1; ++cy)
            for (int cx = 0; cx <= 1; ++cx) {
              const glm::dvec3 c = on_plane(s, x + cx, y + cy, 1, kCeilingY);
              x0 = std::min(x0, c.x), x1 = std::max(x1, c.x), z0 = std::min(z0, c.z), z1 = std::max(z1, c.z);
            }
          on_ceiling = x1 < 211.0 || x0 > 345.0 || z1 < 225.0 || z0 > 334.0;
        }
        if (on_wall) {
          double g = 0.0;  // mean projected solid angle of the light over the footprint
          for (int sy = 0; sy < kSub; ++sy)
            for (int sx = 0; sx < kSub; ++sx) {
              const double px = x + (sx + 0.5) / kSub, py = y + (sy + 0.5) / kSub;
              const glm::dvec3 p = on_plane(s, px, py, 2, kBackZ);
              if (!sees_first(s, px, py, p) || !pt::test::polygon_above_tangent_plane(kLight, p, n_wall)) ++bad;
              g += pt::test::polygon_irradiance(kLight, p, n_wall, 1.0);
            }
          g /= kSub * kSub;
          r.wall.push_back(i);
          r.expected.push_back(kWhite * kLe * (g / std::numbers::pi));
        }
        if (on_ceiling) {
          for (int sy = 0; sy < kSub; sy += kSub - 1)
            for (int sx = 0; sx < kSub; sx += kSub - 1) {
              const double px = x + (sx + 0.5) / kSub, py = y + (sy + 0.5) / kSub;
              if (!sees_first(s, px, py, on_plane(s, px, py, 1, kCeilingY))) ++bad;
            }
          r.ceiling.push_back(i);
        }
      }
    REQUIRE(bad == 0);
    return r;
  }();
  return ref;
}

struct Comparison {
  int n = 0;                      // z-scores per channel (pixels or blocks)
  double max_abs_z = 0.0, mean_z2 = 0.0;
  glm::dvec3 mean{0.0}, expected{0.0}, se{0.0};  // region means and the standard error of ours
};

// Film against the reference on the wall region: z-scores per b×b block of region pixels (b = 1: per pixel;
// blocks only where all b² pixels are in the region), and the region's mean. `scale` multiplies the expected
// values (1 in the tests; a sensitivity check uses 1.005).
Comparison compare(const Film& f, const Reference& r, int b, double scale = 1.0) {
  Comparison c;
  std::map<size_t, std::vector<size_t>> blocks;  // block key → positions in r.wall
  for (size_t k = 0; k < r.wall.size(); ++k) {
    const size_t i = r.wall[k];
    const glm::dvec3 m(f.mean(i)), e = r.expected[k] * scale;
    c.mean += m;
    c.expected += e;
    c.se += f.variance_of_mean(i);
    blocks[(i / kSize / b) * kSize + (i % kSize) / b].push_back(k);
  }
  const double n = static_cast<double>(r.wall.size());
  c.mean /= n;
  c.expected /= n;
  c.se = glm::sqrt(c.se) / n;
  double z2 = 0.0;
  for (const auto& [key, ks] : blocks) {
    if (ks.size() != static_cast<size_t>(b * b)) continue;
    glm::dvec3 m(0.0), e(0.0), v(0.0);
    for (const size_t k : ks) {
      m += glm::dvec3(f.mean(r.wall[k]));
      e += r.expected[k] * scale;
      v += f.variance_of_mean(r.wall[k]);
    }
    for (int ch = 0; ch < 3; ++ch) {
      // v = 0 (no sample varied) gives ±∞ unless the value is exact
      const double z = m[ch] == e[ch] ? 0.0 : (m[ch] - e[ch]) / std::sqrt(v[ch]);
      c.max_abs_z = std::max(c.max_abs_z, std::abs(z));
      z2 += z * z;
    }
    ++c.n;
  }
  c.mean_z2 = z2 / (3.0 * c.n);
  return c;
}

// Renders `spp` samples per pixel in the image tiles that hold wall pixels (18 of the 64) and 8 elsewhere (enough
// for the ceiling, which must be 0 in every sample): the wall's precision at a quarter of the full image's cost.
Film render_wall(Estimator est, int spp, uint64_t seed) {
  const Reference& r = reference();
  const SceneDesc desc = direct_light_scene(est, seed);
  const auto scene = compile_scene(desc);
  constexpr int t = Renderer::kTileSize, tiles = (kSize + t - 1) / t;
  std::vector<int> tile_spp(tiles * tiles, 8);
  for (const size_t i : r.wall) tile_spp[(i / kSize / t) * tiles + (i % kSize) / t] = spp;
  Film film(kSize, kSize);
  Renderer(0).render_pass(*scene, desc.render, film, tile_spp);
  return film;
}

// Renders the scene with one estimator and checks it against the exact values: z-scores per b×b block (b = 1:
// per pixel), the region mean within 4.42 standard errors and within `mean_tol` relative, a standard error of
// at most `max_rel_se` (so the check has the power it claims), and the ceiling exactly 0. sees_half_percent: the
// film is precise enough that values 0.5 % off fail the region-mean check (required of mis and nee).
void check_estimator(Estimator est, int spp, int b, double mean_tol, double max_rel_se, uint64_t seed,
                     bool sees_half_percent) {
  const Reference& r = reference();
  REQUIRE(r.wall.size() > 1000);
  REQUIRE(r.ceiling.size() > 500);
  const Film f = render_wall(est, spp, seed);
  CHECK(f.rejected() == 0);
  CHECK(stress::nonfinite_pixels(f) == 0);

  const Comparison c = compare(f, r, b);
  const double z_bound = stress::bonferroni_z(stress::kAlpha, 3 * c.n),
               z2_bound = stress::chi2_mean_bound(stress::kAlpha, c.n),
               z_one = stress::normal_upper_quantile(stress::kAlpha / 2);
  MESSAGE(std::string(to_string(est)) << ", " << spp << " spp, " << r.wall.size() << " wall pixels, " << c.n << " "
                                      << b << "x" << b << " blocks: max |z| " << c.max_abs_z << " (bound " << z_bound
                                      << "), mean z² " << c.mean_z2 << " (bound " << z2_bound << ")");
  CHECK(c.max_abs_z < z_bound);
  CHECK(c.mean_z2 < z2_bound);
  for (int ch = 0; ch < 3; ++ch) {
    const double ratio = c.mean[ch] / c.expected[ch], rel_se = c.se[ch] / c.expected[ch];
    MESSAGE("  channel " << ch << ": region mean " << c.mean[ch] << ", exact " << c.expected[ch] << ", ratio "
                         << ratio << " ± " << rel_se);
    CHECK(std::abs(c.mean[ch] - c.expected[ch]) < z_one * c.se[ch]);
    CHECK(std::abs(ratio - 1.0) < mean_tol);
    CHECK(rel_se < max_rel_se);
  }
  // Sensitivity: the same film against values 0.5 % higher must fail the checks above.
  const Comparison off = compare(f, r, b, 1.005);
  MESSAGE("  against exact × 1.005: max |z| " << off.max_abs_z << ", mean z² " << off.mean_z2 << ", region z "
                                              << (off.mean[0] - off.expected[0]) / off.se[0]);
  if (sees_half_percent) CHECK(std::abs(off.mean[0] - off.expected[0]) > z_one * off.se[0]);

  // The ceiling: the one-sided light faces away from it, so exactly 0.
  int lit = 0;
  for (const size_t i : r.ceiling)
    if (f.mean(i) != Rgb(0.f)) ++lit;
  MESSAGE("  " << r.ceiling.size() << " ceiling pixels, " << lit << " not exactly 0");
  CHECK(lit == 0);
}

}  // namespace

TEST_CASE("analytic irradiance: cornell, 1 bounce, mis equals Lambert's formula on the upper back wall per pixel "
          "and in the mean (0.1 %), the ceiling is exactly 0") {
  check_estimator(Estimator::Mis, 2048, 1, 1e-3, 2e-4, 20261123, true);
}

TEST_CASE("analytic irradiance: cornell, 1 bounce, nee equals Lambert's formula on the upper back wall") {
  check_estimator(Estimator::Nee, 1536, 1, 1e-3, 2e-4, 20261124, true);
}

TEST_CASE("analytic irradiance: cornell, 1 bounce, cosine (BSDF sampling only) equals Lambert's formula on the upper "
          "back wall (4x4 blocks, 3 %)") {
  check_estimator(Estimator::Cosine, 4096, 4, 3e-2, 5e-3, 20261125, false);
}
