// Environment lighting: piecewise-constant distributions, the lat-long environment map (convention, sampling
// density, χ² of its sampler), the Preetham sky and sun, and HDR image reading.
//
// Statistics: every random stream has a fixed seed, so each run is the same run. The seven χ² tests in this file
// (1D distribution, 2D distribution, environment map 64×32 unrotated and rotated, 12×6 rotated — the coarse map
// makes the within-texel distribution visible —, the compensated density, and a smooth 64×32 map on 4×4 cells)
// use significance 0.01 with a Bonferroni correction: each must have p > 0.01/7, so a correct implementation fails the file with probability < 1 % over seeds. Monte Carlo integral checks use ±5 standard errors (false alarm < 1e-6 each).
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <set>
#include <string>
#include <tuple>
#include <unistd.h>
#include <utility>
#include <vector>

#include "chi2.h"
#include "core/rng.h"
#include "io/image_io.h"
#include "lights/environment_map.h"
#include "lights/sky_preetham.h"
#include "sampling/distribution.h"
#include "sampling/sampling.h"

using namespace pt;
using pt::test::chi2_test;

namespace {

constexpr double kChi2Alpha = 0.01 / 7.0;  // Bonferroni over the seven χ² tests in this file
constexpr double kPiD = std::numbers::pi;

// Purely relative comparison (doctest's Approx alone adds an absolute slack of epsilon).
doctest::Approx rel(double value, double eps) { return doctest::Approx(value).epsilon(eps).scale(0.0); }

Vec2 next2(Pcg32& rng) {
  const float a = rng.next_float();
  return {a, rng.next_float()};
}

// World azimuth in EnvironmentMap's convention: φ = atan2(−x, z) ∈ [0, 2π).
double azimuth(Vec3 d) {
  double phi = std::atan2(-static_cast<double>(d.x), static_cast<double>(d.z));
  return phi < 0 ? phi + 2 * kPiD : phi;
}

Vec3 dir_from(double cos_theta, double phi) {
  const double s = std::sqrt(std::max(0.0, 1 - cos_theta * cos_theta));
  return Vec3(static_cast<float>(-s * std::sin(phi)), static_cast<float>(cos_theta), static_cast<float>(s * std::cos(phi)));
}

// A non-trivial map (64×32 by default): an azimuthal gradient, a bright coloured spot, and (from 32 rows up) two
// black rows, never sampled.
Image test_map(int W = 64, int H = 32) {
  Image img{W, H, std::vector<float>(3 * static_cast<size_t>(W) * H)};
  for (int j = 0; j < H; ++j)
    for (int i = 0; i < W; ++i) {
      const float u = (i + 0.5f) / W, v = (j + 0.5f) / H;
      const float g = 0.05f + 0.5f * u;
      const float spot = 40.f * std::exp(-(sqr(u - 0.3f) / 0.002f + sqr(v - 0.35f) / 0.004f));
      Rgb c(g + spot, 0.5f * g + 0.8f * spot, 0.2f + 0.3f * v);
      if (H >= 32 && (j == 20 || j == 21)) c = Rgb(0.f);
      float* p = &img.rgb[3 * (static_cast<size_t>(j) * W + i)];
      p[0] = c.x, p[1] = c.y, p[2] = c.z;
    }
  return img;
}

// A smooth map (no spot, no black rows): an azimuthal and polar gradient, as a tabulated sky is smooth.
Image smooth_map(int W, int H) {
  Image img{W, H, std::vector<float>(3 * static_cast<size_t>(W) * H)};
  for (int j = 0; j < H; ++j)
    for (int i = 0; i < W; ++i) {
      const float u = (i + 0.5f) / W, v = (j + 0.5f) / H;
      const float g = 1.f + 0.3f * std::cos(2.f * kPi * u) + 0.4f * v;
      float* p = &img.rgb[3 * (static_cast<size_t>(j) * W + i)];
      p[0] = g, p[1] = 0.8f * g, p[2] = 0.6f + 0.2f * v;
    }
  return img;
}

// χ² of EnvironmentMap::sample against EnvironmentMap::pdf over nc × np cells in (cos θ, world φ). Expected
// counts integrate pdf() exactly: the cell grid and the texel grid (rows: cos(πj/H); columns: world azimuth
// 2πi/W − rotation) are merged, and pdf() — constant per texel — is evaluated at the centre of every piece.
test::Chi2Result env_chi2(const EnvironmentMap& env, int samples, uint64_t seed, double* pdf_integral,
                          bool compensated = false) {
  const int nc = 64, np = 64, W = env.width(), H = env.height();
  std::vector<double> cos_breaks, phi_breaks;
  for (int k = 0; k <= nc; ++k) cos_breaks.push_back(-1.0 + 2.0 * k / nc);
  for (int j = 0; j <= H; ++j) cos_breaks.push_back(std::cos(kPiD * j / H));
  const double rot = env.rotation_deg() * kPiD / 180.0;
  for (int k = 0; k <= np; ++k) phi_breaks.push_back(2 * kPiD * k / np);
  for (int i = 0; i < W; ++i) phi_breaks.push_back(std::fmod(std::fmod(2 * kPiD * i / W - rot, 2 * kPiD) + 2 * kPiD, 2 * kPiD));
  for (auto* b : {&cos_breaks, &phi_breaks}) {
    std::sort(b->begin(), b->end());
    b->erase(std::unique(b->begin(), b->end(), [](double x, double y) { return y - x < 1e-9; }), b->end());
  }
  auto cell = [&](double c, double phi) {
    const int ic = std::clamp(static_cast<int>((c + 1.0) * 0.5 * nc), 0, nc - 1);
    const int ip = std::clamp(static_cast<int>(phi / (2 * kPiD) * np), 0, np - 1);
    return ic * np + ip;
  };
  std::vector<double> expected(static_cast<size_t>(nc) * np, 0.0), observed(expected.size(), 0.0);
  double total = 0;
  for (size_t a = 0; a + 1 < cos_breaks.size(); ++a)
    for (size_t b = 0; b + 1 < phi_breaks.size(); ++b) {
      const double c = 0.5 * (cos_breaks[a] + cos_breaks[a + 1]), phi = 0.5 * (phi_breaks[b] + phi_breaks[b + 1]);
      const double mass = env.pdf(dir_from(c, phi), compensated) * (cos_breaks[a + 1] - cos_breaks[a]) *
                          (phi_breaks[b + 1] - phi_breaks[b]);
      expected[static_cast<size_t>(cell(c, phi))] += mass;
      total += mass;
    }
  *pdf_integral = total;
  for (double& e : expected) e *= samples;
  Pcg32 rng(seed, 7);
  for (int s = 0; s < samples; ++s) {
    Vec3 d;
    float pdf;
    Rgb Le;
    if (!env.sample(next2(rng), d, pdf, Le, compensated)) continue;
    observed[static_cast<size_t>(cell(d.y, azimuth(d)))] += 1;
  }
  return chi2_test(observed, expected);
}

}  // namespace

// ------------------------------------------------------------------------------------------------------------
// Distributions

TEST_CASE("environment: Distribution1D samples its weights (chi-square) and never zero cells") {
  const std::vector<float> w = {0.f, 1.f, 3.f, 0.f, 0.f, 2.f, 5.f, 0.5f, 0.f};
  const Distribution1D d(w);
  const int n = static_cast<int>(w.size()), sub = 8, N = 200000;
  double sum = 0;
  for (float x : w) sum += x;
  CHECK(d.integral() == rel(sum / n, 1e-6));
  std::vector<double> obs(static_cast<size_t>(n * sub), 0.0), exp(obs.size(), 0.0);
  for (int i = 0; i < n * sub; ++i) exp[static_cast<size_t>(i)] = N * w[static_cast<size_t>(i / sub)] / sum / sub;
  Pcg32 rng(11, 1);
  int bad_pdf = 0, in_zero = 0, out_of_range = 0;
  for (int s = 0; s < N; ++s) {
    float pdf;
    int off;
    const float x = d.sample_continuous(rng.next_float(), &pdf, &off);
    if (!(x >= 0.f && x < 1.f)) ++out_of_range;
    if (w[static_cast<size_t>(off)] == 0.f) ++in_zero;
    if (pdf != d.pdf(x) || std::abs(pdf - w[static_cast<size_t>(off)] / (sum / n)) > 1e-6 * pdf) ++bad_pdf;
    obs[static_cast<size_t>(std::min(static_cast<int>(x * n * sub), n * sub - 1))] += 1;
  }
  CHECK(out_of_range == 0);
  CHECK(in_zero == 0);
  CHECK(bad_pdf <= 2);  // float rounding exactly at a cell edge may pick the neighbour's pdf
  const auto r = chi2_test(obs, exp);
  MESSAGE("Distribution1D chi2 " << r.statistic << " dof " << r.dof << " p " << r.p_value);
  CHECK(r.unexpected == 0);
  CHECK(r.p_value > kChi2Alpha);
  // Extreme u: leading/trailing zero cells are skipped.
  int off = -1;
  CHECK(d.sample_continuous(0.f, nullptr, &off) >= 1.f / n);
  CHECK(off == 1);
  CHECK(d.sample_continuous(kOneMinusEpsilon, nullptr, &off) < 8.f / n);
  CHECK(off == 7);
  float pmf, ur;
  CHECK(d.sample_discrete(0.5f, &pmf, &ur) == 5);  // cdf: 0, 0, 1/11.5, 4/11.5, 4/11.5, 4/11.5, 6/11.5, ...
  CHECK(pmf == doctest::Approx(2.0 / 11.5));
  CHECK(ur == rel((0.5 - 4.0 / 11.5) / (2.0 / 11.5), 1e-5));
}

TEST_CASE("environment: Distribution1D falls back to uniform for all-zero or invalid weights") {
  for (const std::vector<float>& w : {std::vector<float>{0.f, 0.f, 0.f, 0.f}, std::vector<float>{-1.f, NAN, INFINITY, 0.f}}) {
    const Distribution1D d(w);
    CHECK(d.uniform_fallback());
    CHECK(d.integral() == 0.f);
    for (float u : {0.f, 0.1f, 0.37f, 0.5f, 0.99f, kOneMinusEpsilon}) {
      float pdf;
      const float x = d.sample_continuous(u, &pdf);
      CHECK(x == doctest::Approx(u).epsilon(1e-6));
      CHECK(x < 1.f);
      CHECK(pdf == 1.f);
      CHECK(d.pdf(x) == 1.f);
    }
  }
  const Distribution1D one(std::vector<float>{2.f});
  float pdf;
  CHECK(one.sample_continuous(0.25f, &pdf) == 0.25f);
  CHECK(pdf == 1.f);
}

// The guide table (distribution.h) must find the binary search's cell for every u, also at the guide's interval
// edges k/n, where u·n rounds up into the next interval for the u just below (32 of the 299 inner edges for n =
// 300; uniform weights put cdf edges exactly there: without the step back the walk returns the next cell), and
// across runs of zero-weight cells
// and weights 30 orders of magnitude apart (a long forward walk).
TEST_CASE("environment: Distribution1D's guide table picks the binary search's cell for every u") {
  std::vector<std::vector<float>> cases = {
      {1.f}, {1.f, 1.f}, {1.f, 1.f, 1.f}, std::vector<float>(100, 1.f), std::vector<float>(300, 1.f),
      std::vector<float>(512, 1.f), std::vector<float>(300, 0.f),
      {0.f, 1.f, 3.f, 0.f, 0.f, 2.f, 5.f, 0.5f, 0.f}, {1e-30f, 1e-30f, 1.f, 1e-30f, 0.f, 0.f, 0.f, 1e-30f}};
  Pcg32 gen(3, 7);
  std::vector<float> random(300);
  for (float& w : random) w = gen.next_float() < 0.3f ? 0.f : std::exp(30.f * gen.next_float() - 15.f);
  cases.push_back(random);
  int checked = 0, differ = 0;
  for (const auto& w : cases) {
    const Distribution1D d(w);
    const int n = static_cast<int>(w.size());
    std::vector<float> us = {0.f, kOneMinusEpsilon};
    for (int k = 0; k <= n; ++k) {
      const float edge = static_cast<float>(static_cast<double>(k) / n);
      for (float u = std::nextafter(edge, 0.f), i = 0; i < 3; ++i, u = std::nextafter(u, 1.f)) us.push_back(u);
    }
    for (int i = 0; i < 20000; ++i) us.push_back(gen.next_float());
    for (const float u : us) {
      if (!(u >= 0.f && u < 1.f)) continue;
      ++checked;
      if (d.sample_discrete(u) != d.search_cell(u)) ++differ;
    }
  }
  CHECK(checked > 160000);
  CHECK(differ == 0);
}

TEST_CASE("environment: Distribution2D samples its weights (chi-square), skips zero rows and columns") {
  const int nu = 7, nv = 5, sub = 2, N = 300000;
  std::vector<float> w(static_cast<size_t>(nu * nv));
  double sum = 0;
  for (int v = 0; v < nv; ++v)
    for (int u = 0; u < nu; ++u) {
      float x = 1.f + static_cast<float>((u * 3 + v * 5) % 7);
      if (v == 2 || u == 4) x = 0.f;  // a zero row and a zero column
      if (u == 1 && v == 3) x = 30.f;
      w[static_cast<size_t>(v * nu + u)] = x;
      sum += x;
    }
  const Distribution2D d(w, nu, nv);
  CHECK(d.integral() == rel(sum / (nu * nv), 1e-6));
  const int cu = nu * sub, cv = nv * sub;
  std::vector<double> obs(static_cast<size_t>(cu * cv), 0.0), exp(obs.size(), 0.0);
  for (int y = 0; y < cv; ++y)
    for (int x = 0; x < cu; ++x)
      exp[static_cast<size_t>(y * cu + x)] = N * w[static_cast<size_t>((y / sub) * nu + x / sub)] / sum / (sub * sub);
  Pcg32 rng(12, 3);
  int bad = 0;
  for (int s = 0; s < N; ++s) {
    float pdf;
    int iu, iv;
    const Vec2 p = d.sample_continuous(next2(rng), &pdf, &iu, &iv);
    if (!(p.x >= 0.f && p.x < 1.f && p.y >= 0.f && p.y < 1.f) || w[static_cast<size_t>(iv * nu + iu)] == 0.f) ++bad;
    if (std::abs(pdf - w[static_cast<size_t>(iv * nu + iu)] / (sum / (nu * nv))) > 1e-5 * pdf) ++bad;
    const int x = std::min(static_cast<int>(p.x * cu), cu - 1), y = std::min(static_cast<int>(p.y * cv), cv - 1);
    obs[static_cast<size_t>(y * cu + x)] += 1;
  }
  CHECK(bad == 0);
  const auto r = chi2_test(obs, exp);
  MESSAGE("Distribution2D chi2 " << r.statistic << " dof " << r.dof << " p " << r.p_value);
  CHECK(r.unexpected == 0);
  CHECK(r.p_value > kChi2Alpha);
  CHECK(d.pdf({0.5f / nu, 2.5f / nv}) == 0.f);  // zero row
  CHECK(d.pdf({4.5f / nu, 0.5f / nv}) == 0.f);  // zero column
  // All zero: uniform over the square.
  const Distribution2D z(std::vector<float>(12, 0.f), 4, 3);
  float pdf;
  const Vec2 p = z.sample_continuous({0.3f, 0.8f}, &pdf);
  CHECK(pdf == 1.f);
  CHECK(z.pdf(p) == 1.f);
  CHECK(p.x == doctest::Approx(0.3f).epsilon(1e-6));
  CHECK(p.y == doctest::Approx(0.8f).epsilon(1e-6));
}

// ------------------------------------------------------------------------------------------------------------
// Environment map

TEST_CASE("environment: lat-long convention (rows from +y down, centre column faces -z) and rotation") {
  // 8×4 map whose texel (i, j) has radiance (i, j, 1).
  const int W = 8, H = 4;
  Image img{W, H, {}};
  for (int j = 0; j < H; ++j)
    for (int i = 0; i < W; ++i) img.rgb.insert(img.rgb.end(), {static_cast<float>(i), static_cast<float>(j), 1.f});
  const EnvironmentMap env(img, 2.f, 0.f);
  auto texel = [&](const EnvironmentMap& e, Vec3 d) {
    const Rgb c = e.eval(glm::normalize(d)) / 2.f;
    return std::pair<int, int>(static_cast<int>(c.x), static_cast<int>(c.y));
  };
  using P = std::pair<int, int>;
  CHECK(texel(env, {0.1f, 1.f, 0.05f}).second == 0);    // straight up: top row
  CHECK(texel(env, {0.1f, -1.f, 0.05f}).second == 3);   // straight down: bottom row
  CHECK(texel(env, {0.01f, 0.2f, -1.f}) == P(4, 1));    // ahead (−z), a little right and up: centre column
  CHECK(texel(env, {-0.01f, 0.2f, -1.f}) == P(3, 1));   // a little left of −z
  CHECK(texel(env, {1.f, -0.2f, 0.01f}) == P(6, 2));    // +x (u = 0.75), a little towards +z: u > 0.75
  CHECK(texel(env, {1.f, -0.2f, -0.01f}) == P(5, 2));   // +x, a little towards −z: u < 0.75
  CHECK(texel(env, {-1.f, -0.2f, -0.01f}) == P(2, 2));  // −x (u = 0.25), a little towards −z: u > 0.25
  CHECK(texel(env, {0.01f, 0.2f, 1.f}) == P(7, 1));     // +z, slightly right of the seam: u just below 1
  CHECK(texel(env, {-0.01f, 0.2f, 1.f}) == P(0, 1));    // +z, slightly left: u just above 0
  // direction_from_uv / uv_from_direction: the cardinal directions and a round trip.
  auto near = [](Vec3 a, Vec3 b) { return glm::length(a - b) < 1e-6f; };
  CHECK(near(EnvironmentMap::direction_from_uv({0.5f, 0.5f}), {0.f, 0.f, -1.f}));
  CHECK(near(EnvironmentMap::direction_from_uv({0.75f, 0.5f}), {1.f, 0.f, 0.f}));
  CHECK(near(EnvironmentMap::direction_from_uv({0.25f, 0.5f}), {-1.f, 0.f, 0.f}));
  CHECK(near(EnvironmentMap::direction_from_uv({0.f, 0.5f}), {0.f, 0.f, 1.f}));
  CHECK(near(EnvironmentMap::direction_from_uv({0.3f, 0.f}), {0.f, 1.f, 0.f}));
  Pcg32 rng(5, 5);
  float worst = 0.f;
  for (int k = 0; k < 1000; ++k) {
    const Vec2 uv(rng.next_float(), 0.01f + 0.98f * rng.next_float());
    const Vec2 back = EnvironmentMap::uv_from_direction(EnvironmentMap::direction_from_uv(uv));
    worst = std::max({worst, std::abs(back.y - uv.y), std::min(std::abs(back.x - uv.x), 1.f - std::abs(back.x - uv.x))});
  }
  CHECK(worst < 1e-5f);
  // Rotation +90° (counter-clockwise seen from above): the map's centre column moves from −z to −x, and the
  // camera looking down −z sees the map's u = 0.75 column (world u 0.5 + 90/360).
  const EnvironmentMap rot(img, 2.f, 90.f);
  CHECK(texel(rot, {-1.f, 0.2f, -0.01f}) == P(4, 1));
  CHECK(texel(rot, {0.01f, 0.2f, -1.f}) == P(6, 1));
  CHECK(near(rot.map_to_world({0.f, 0.f, -1.f}), {-1.f, 0.f, 0.f}));
  CHECK(near(rot.world_to_map(rot.map_to_world({0.3f, 0.5f, -0.8f})), {0.3f, 0.5f, -0.8f}));
}

TEST_CASE("environment: a constant map has pdf 1/(4 pi) and its samples integrate exactly") {
  const Rgb c(0.5f, 1.f, 2.f);
  for (const auto& [W_, H_, rot_] : {std::tuple{64, 32, 0.f}, std::tuple{7, 3, 33.f}, std::tuple{1, 1, 0.f}}) {
    const auto& W = W_; const auto& H = H_; const auto& rot = rot_;  // clang 14: lambdas cannot capture bindings
    Image img{W, H, {}};
    for (int k = 0; k < W * H; ++k) img.rgb.insert(img.rgb.end(), {c.x, c.y, c.z});
    const float scale = 3.f;
    const EnvironmentMap env(img, scale, rot);
    CAPTURE(W);
    CAPTURE(H);
    CHECK(env.power_weight() == rel(4 * kPiD * luminance(c) * scale, 1e-6));
    Pcg32 rng(21, static_cast<uint64_t>(W));
    double worst_pdf = 0, worst_sample_pdf = 0;
    DVec3 sum(0.0);
    const int N = 20000;
    for (int s = 0; s < N; ++s) {
      const Vec3 d = sample_uniform_sphere(next2(rng));
      worst_pdf = std::max(worst_pdf, std::abs(env.pdf(d) * 4 * kPiD - 1));
      Vec3 w;
      float pdf;
      Rgb Le;
      REQUIRE(env.sample(next2(rng), w, pdf, Le));
      worst_sample_pdf = std::max(worst_sample_pdf, std::abs(pdf * 4 * kPiD - 1));
      sum += DVec3(Le / pdf);
    }
    CHECK(worst_pdf < 1e-4);
    CHECK(worst_sample_pdf < 1e-4);
    const DVec3 est = sum / static_cast<double>(N), exact = 4 * kPiD * scale * DVec3(c);
    for (int k = 0; k < 3; ++k) CHECK(est[k] == rel(exact[k], 1e-4));
  }
}

TEST_CASE("environment: sample() returns eval() and pdf(), and estimates the map's integral") {
  const Image img = test_map();
  const EnvironmentMap env(img, 1.5f, 37.f);
  // Quadrature of the nearest-texel map: Σ texel × texel solid angle.
  const int W = img.width, H = img.height;
  DVec3 exact(0.0);
  for (int j = 0; j < H; ++j)
    for (int i = 0; i < W; ++i)
      exact += DVec3(img.at(i, j)) * (std::cos(kPiD * j / H) - std::cos(kPiD * (j + 1) / H)) * (2 * kPiD / W);
  exact *= 1.5;
  const double exact_lum = 0.2126 * exact.x + 0.7152 * exact.y + 0.0722 * exact.z;
  CHECK(env.power_weight() == rel(exact_lum, 1e-5));

  Pcg32 rng(31, 2);
  const int N = 200000;
  int failed = 0, mismatched = 0, zero = 0, not_unit = 0;
  DVec3 sum(0.0), sum2(0.0);
  double lum_sum = 0, lum_sum2 = 0;
  for (int s = 0; s < N; ++s) {
    Vec3 d;
    float pdf;
    Rgb Le;
    if (!env.sample(next2(rng), d, pdf, Le)) {
      ++failed;
      continue;
    }
    if (!(Le == env.eval(d)) || !(pdf == env.pdf(d))) ++mismatched;
    if (is_black(Le)) ++zero;
    if (std::abs(glm::length(d) - 1.f) > 1e-5f) ++not_unit;
    const DVec3 f = DVec3(Le) / static_cast<double>(pdf);
    sum += f;
    sum2 += f * f;
    const double l = luminance(Le) / static_cast<double>(pdf);
    lum_sum += l;
    lum_sum2 += l * l;
  }
  CHECK(failed <= 2);
  CHECK(mismatched == 0);
  CHECK(zero == 0);  // the black rows are never sampled
  CHECK(not_unit == 0);
  for (int k = 0; k < 3; ++k) {
    const double mean = sum[k] / N, se = std::sqrt(std::max(0.0, sum2[k] / N - mean * mean) / N);
    CAPTURE(k);
    CAPTURE(mean);
    CAPTURE(se);
    CHECK(std::abs(mean - exact[k]) < 5 * se + 1e-6 * exact[k]);
  }
  // Sampling ∝ luminance: luminance(Le)/pdf is the same for every sample (zero variance up to rounding).
  const double lmean = lum_sum / N, lvar = lum_sum2 / N - lmean * lmean;
  CHECK(lmean == rel(exact_lum, 1e-4));
  CHECK(std::sqrt(std::max(0.0, lvar)) < 1e-4 * lmean);

  // Independent check of pdf() and power_weight(): uniform sphere sampling (no importance) of eval() and of
  // pdf() (which must integrate to 1 over the sphere).
  double lum_u = 0, lum_u2 = 0, pdf_u = 0, pdf_u2 = 0;
  for (int s = 0; s < N; ++s) {
    const Vec3 d = sample_uniform_sphere(next2(rng));
    const double l = luminance(env.eval(d)) * 4 * kPiD, p = env.pdf(d) * 4 * kPiD;
    lum_u += l, lum_u2 += l * l, pdf_u += p, pdf_u2 += p * p;
  }
  const double lm = lum_u / N, lse = std::sqrt((lum_u2 / N - lm * lm) / N);
  const double pm = pdf_u / N, pse = std::sqrt((pdf_u2 / N - pm * pm) / N);
  CHECK(std::abs(lm - exact_lum) < 5 * lse);
  CHECK(std::abs(pm - 1.0) < 5 * pse);
}

// sample() reads the sampled texel's record without looking its direction up again where the direction is far
// enough from the texel's edges (environment_map.h): that must give eval()'s and pdf()'s very bits, on maps whose
// texels are as narrow as the format allows in either direction (rounding then crosses edges most often), rotated
// or not, for the full and the compensated density, on cells of 1, 2×2 and 4×4 texels. Taking the record for every
// sample (no margin) fails it.
TEST_CASE("environment: sample() agrees with eval() and pdf() bit for bit on maps with the narrowest texels") {
  std::set<int> blocks;
  for (const auto& [w, h, rot, smooth] :
       {std::tuple{16384, 8, 37.f, false}, std::tuple{8, 16384, -20.f, false}, std::tuple{512, 256, 0.f, false},
        std::tuple{2048, 1024, 123.f, false}, std::tuple{8, 16384, 65.f, true}, std::tuple{16384, 8, 0.f, true},
        std::tuple{512, 256, -80.f, true}}) {
    const EnvironmentMap env(smooth ? smooth_map(w, h) : test_map(w, h), 1.f, rot);
    REQUIRE(env.compensates());
    blocks.insert(env.block());
    for (const bool compensated : {false, true}) {
      Pcg32 rng(77, static_cast<uint64_t>(w) * 2 + (compensated ? 1 : 0));
      int sampled = 0, mismatched = 0;
      for (int s = 0; s < 100000; ++s) {
        Vec3 d;
        float pdf;
        Rgb Le;
        if (!env.sample(next2(rng), d, pdf, Le, compensated)) continue;
        ++sampled;
        float eval_pdf = 0.f;
        const Rgb eval_Le = env.eval(d, eval_pdf, compensated);
        if (!(Le == eval_Le) || !(pdf == eval_pdf) || !(pdf == env.pdf(d, compensated))) ++mismatched;
      }
      const int width = w, height = h;  // doctest's CAPTURE cannot name a structured binding (clang 14)
      const bool is_smooth = smooth;
      CAPTURE(width);
      CAPTURE(height);
      CAPTURE(is_smooth);
      CAPTURE(compensated);
      CHECK(sampled >= 99990);
      CHECK(mismatched == 0);
    }
  }
  CHECK(blocks == std::set<int>{1, 2, 4});  // every size of cell was tried
}

// Sampling cells (environment_map.h): the tabulated sky and smooth maps take 4×4 texels, or 2×2 where a side is
// not a multiple of 4; a map with a small bright spot (a photographed sun) or of odd sides keeps texels. On 4×4
// cells sample() draws the density pdf() states (χ², one of the file's seven), estimates the map's integral without
// bias, and still nearly in proportion to the luminance.
TEST_CASE("environment: sampling cells of 4x4 texels where the map is smooth, texels where it is not") {
  CHECK(EnvironmentMap(make_sky_image(glm::normalize(Vec3(0.3f, 0.5f, -0.4f)), 3.f, 512, 256)).block() == 4);
  CHECK(EnvironmentMap(smooth_map(64, 32)).block() == 4);
  CHECK(EnvironmentMap(smooth_map(66, 34)).block() == 2);
  CHECK(EnvironmentMap(smooth_map(63, 33)).block() == 1);
  CHECK(EnvironmentMap(test_map(64, 32)).block() == 1);
  CHECK(EnvironmentMap(Image{8, 4, std::vector<float>(96, 0.f)}).block() == 1);  // black: the uniform fallback
  // One texel b times brighter (row 16, column 40) in a constant 64×32 map. The second moments of 4×4 and 2×2 cells
  // for the map's own integral, relative to the texels' (computed apart, in Python, from the same weights with the
  // rows' solid angles): b = 1.01: 1 + 7·10⁻⁸ and 1 + 6·10⁻⁸; b = 6: 1.0135 and 1.0063; b = 20: 1.115 and 1.035.
  for (const auto& [bright, block] : {std::pair{1.01f, 4}, std::pair{6.f, 2}, std::pair{20.f, 1}}) {
    Image img{64, 32, std::vector<float>(3 * 64 * 32, 1.f)};
    for (int c = 0; c < 3; ++c) img.rgb[3 * (16 * 64 + 40) + c] = bright;
    const float brightness = bright;  // CAPTURE cannot name a structured binding (clang 14)
    CAPTURE(brightness);
    CHECK(EnvironmentMap(img).block() == block);
  }

  const EnvironmentMap env(smooth_map(64, 32), 1.f, 29.f);
  REQUIRE(env.block() == 4);
  double integral = 0;
  const auto r = env_chi2(env, 1000000, 4321, &integral);
  MESSAGE("EnvironmentMap 64x32 on 4x4 cells: chi2 " << r.statistic << " dof " << r.dof << " p " << r.p_value);
  CHECK(integral == rel(1.0, 1e-5));
  CHECK(r.unexpected == 0);
  CHECK(r.p_value > kChi2Alpha);
  // The map's integral (Σ texel × texel solid angle) from 200k samples: within 5 standard errors.
  const Image img = smooth_map(64, 32);
  DVec3 exact(0.0);
  for (int j = 0; j < 32; ++j)
    for (int i = 0; i < 64; ++i)
      exact += DVec3(img.at(i, j)) * (std::cos(kPiD * j / 32) - std::cos(kPiD * (j + 1) / 32)) * (2 * kPiD / 64);
  Pcg32 rng(5, 9);
  DVec3 sum(0.0), sum2(0.0);
  double lum_sum = 0, lum_sum2 = 0;
  const int N = 200000;
  for (int s = 0; s < N; ++s) {
    Vec3 d;
    float pdf;
    Rgb Le;
    REQUIRE(env.sample(next2(rng), d, pdf, Le));
    const DVec3 f = DVec3(Le) / static_cast<double>(pdf);
    sum += f, sum2 += f * f;
    const double l = luminance(Le) / static_cast<double>(pdf);
    lum_sum += l, lum_sum2 += l * l;
  }
  for (int c = 0; c < 3; ++c) {
    const double mean = sum[c] / N, se = std::sqrt(std::max(0.0, sum2[c] / N - mean * mean) / N);
    CAPTURE(c);
    CHECK(std::abs(mean - exact[c]) < 5 * se);
  }
  // luminance(Le)/pdf varies only within a cell (by at most 13 %): its spread is a few
  // per cent, where uniform sampling's is the map's own, 18 %.
  const double lmean = lum_sum / N, lstd = std::sqrt(std::max(0.0, lum_sum2 / N - lmean * lmean));
  MESSAGE("luminance(Le)/pdf on 4x4 cells: relative spread " << lstd / lmean);
  CHECK(lstd < 0.05 * lmean);
}

TEST_CASE("environment: chi-square of EnvironmentMap::sample against pdf (unrotated and rotated)") {
  for (const auto& [w, h, rot] : {std::tuple{64, 32, 0.f}, std::tuple{64, 32, 37.5f}, std::tuple{12, 6, -50.f}}) {
    const EnvironmentMap env(test_map(w, h), 1.f, rot);
    double integral = 0;
    const auto r = env_chi2(env, 1000000, 1234 + static_cast<uint64_t>(static_cast<int64_t>(rot)), &integral);
    MESSAGE("EnvironmentMap " << w << "x" << h << ", rotation " << rot << ": chi2 " << r.statistic << " dof " << r.dof << " p " << r.p_value
                                       << ", integral of pdf " << integral);
    CHECK(integral == rel(1.0, 1e-5));
    CHECK(r.unexpected == 0);
    CHECK(r.p_value > kChi2Alpha);
  }
}

// MIS compensation (environment_map.h; Karlík et al. 2019): the compensated density is ∝ the luminance above the
// map's mean (zero at or below it), samples as it states, and combined by MIS with cosine sampling it estimates a
// diffuse receiver's irradiance integral without bias, with less variance than the full density on this map.
TEST_CASE("environment: the compensated density is the luminance above the mean, sampled as stated, unbiased under MIS") {
  const Image img = test_map();
  const EnvironmentMap env(img, 2.f, 20.f);
  REQUIRE(env.compensates());
  const int W = img.width, H = img.height;
  auto texel_solid_angle = [&](int j) { return (std::cos(kPiD * j / H) - std::cos(kPiD * (j + 1) / H)) * (2 * kPiD / W); };
  // The mean luminance over the sphere and the mass above it, by quadrature of the nearest-texel map.
  double mean = 0;
  for (int j = 0; j < H; ++j)
    for (int i = 0; i < W; ++i) mean += luminance(img.at(i, j)) * texel_solid_angle(j);
  mean /= 4 * kPiD;
  double above_mass = 0;
  for (int j = 0; j < H; ++j)
    for (int i = 0; i < W; ++i) above_mass += std::max(0.0, luminance(img.at(i, j)) - mean) * texel_solid_angle(j);
  // Each texel's density, read at its centre (map space, unrotated by the inverse rotation).
  const double rot = 20.0 * kPiD / 180.0;
  int zero_below = 0, off = 0, positive = 0;
  for (int j = 0; j < H; ++j)
    for (int i = 0; i < W; ++i) {
      const double phi = 2 * kPiD * (i + 0.5) / W - rot, c = std::cos(kPiD * (j + 0.5) / H);
      const Vec3 d = dir_from(c, phi);
      const double above = luminance(img.at(i, j)) - mean, p = env.pdf(d, true);
      if (above <= 0) {
        zero_below += p == 0.0;
      } else {
        ++positive;
        if (std::abs(p - above / above_mass) > 1e-4 * above / above_mass) ++off;
      }
      if (above <= 0 && p != 0.0) ++off;
    }
  CHECK(positive > 50);
  CHECK(zero_below > 50);
  CHECK(off == 0);
  double integral = 0;
  const auto r = env_chi2(env, 1000000, 77, &integral, true);
  MESSAGE("compensated: chi2 " << r.statistic << " dof " << r.dof << " p " << r.p_value);
  CHECK(integral == rel(1.0, 1e-5));
  CHECK(r.unexpected == 0);
  CHECK(r.p_value > kChi2Alpha);

  // A diffuse receiver facing n: E = ∫ L(ω) max(0, n·ω)/π dω, by quadrature (8×8 points per texel), against the
  // two-sample MIS estimate (one light sample, one cosine sample, power heuristic) with each light density.
  const Vec3 n = glm::normalize(Vec3(0.4f, 0.7f, -0.3f));
  const Frame frame = Frame::from_normal(n);
  DVec3 exact(0.0);
  for (int j = 0; j < H; ++j)
    for (int i = 0; i < W; ++i)
      for (int a = 0; a < 8; ++a)
        for (int b = 0; b < 8; ++b) {
          const double c0 = std::cos(kPiD * j / H), c1 = std::cos(kPiD * (j + 1) / H);
          const double c = c0 + (c1 - c0) * (a + 0.5) / 8, phi = 2 * kPiD * (i + (b + 0.5) / 8) / W - rot;
          const Vec3 d = dir_from(c, phi);
          exact += DVec3(env.eval(d)) * std::max(0.0, static_cast<double>(glm::dot(n, d))) / kPiD *
                   (texel_solid_angle(j) / 64);
        }
  double variance[2] = {0, 0};
  for (const bool compensated : {false, true}) {
    Pcg32 rng(5, 11);
    const int N = 400000;
    DVec3 sum(0.0), sum2(0.0);
    for (int s = 0; s < N; ++s) {
      DVec3 f(0.0);
      Vec3 d;
      float pdf;
      Rgb Le;
      if (env.sample(next2(rng), d, pdf, Le, compensated)) {
        const float cos = glm::dot(n, d);
        if (cos > 0.f) f += DVec3(Le) * static_cast<double>(cos / kPi / pdf * power_heuristic(pdf, cos / kPi));
      }
      const Vec3 local = sample_cosine_hemisphere(next2(rng));
      if (local.z > 0.f) {
        const Vec3 w = frame.to_world(local);
        float light_pdf;
        const Rgb L = env.eval(w, light_pdf, compensated);
        f += DVec3(L) * static_cast<double>(power_heuristic(local.z / kPi, light_pdf));  // f·cos/pdf = 1
      }
      sum += f;
      sum2 += f * f;
    }
    for (int k = 0; k < 3; ++k) {
      const double m = sum[k] / N, se = std::sqrt(std::max(0.0, sum2[k] / N - m * m) / N);
      CAPTURE(compensated);
      CAPTURE(k);
      CHECK(std::abs(m - exact[k]) < 5 * se);
      variance[compensated] += sum2[k] / N - m * m;
    }
  }
  MESSAGE("MIS variance, full density " << variance[0] << ", compensated " << variance[1]);
  CHECK(variance[1] < 0.9 * variance[0]);

  // A constant map, and one within 1e-5 of constant, have nothing to compensate.
  Image flat{16, 8, std::vector<float>(3 * 16 * 8, 0.5f)};
  CHECK(!EnvironmentMap(flat).compensates());
  for (size_t k = 0; k < flat.rgb.size(); k += 7) flat.rgb[k] *= 1.00001f;
  CHECK(!EnvironmentMap(flat).compensates());
}

TEST_CASE("environment: invalid environment map inputs are rejected") {
  Image img{2, 1, {1.f, 1.f, 1.f, 1.f, 1.f, 1.f}};
  CHECK_THROWS_AS(EnvironmentMap(img, -1.f), std::invalid_argument);
  CHECK_THROWS_AS(EnvironmentMap(img, NAN), std::invalid_argument);
  CHECK_THROWS_AS(EnvironmentMap(img, 1.f, INFINITY), std::invalid_argument);
  CHECK_THROWS_AS(EnvironmentMap(Image{}, 1.f), std::invalid_argument);
  img.rgb[4] = -0.5f;
  CHECK_THROWS_AS(EnvironmentMap(img, 1.f), std::invalid_argument);
  // An all-black map still samples (uniformly) and returns zero radiance and power.
  const EnvironmentMap black(Image{4, 2, std::vector<float>(24, 0.f)});
  Vec3 d;
  float pdf;
  Rgb Le;
  REQUIRE(black.sample({0.3f, 0.6f}, d, pdf, Le));
  CHECK(pdf == rel(1.0 / (4 * kPiD), 1e-4));
  CHECK(is_black(Le));
  CHECK(black.power_weight() == 0.0);
}

// ------------------------------------------------------------------------------------------------------------
// Preetham sky and sun

TEST_CASE("environment: Preetham zenith luminance and chromaticity match the paper's formulas") {
  // (T, sun zenith angle in degrees). Expected values are evaluated here from Preetham et al. 1999,
  // Appendix A.2, independently of the code under test.
  for (const auto& [T_, theta_deg_] : {std::pair{3.0, 45.0}, std::pair{6.0, 70.0}, std::pair{2.0, 10.0}}) {
    const auto& T = T_; const auto& theta_deg = theta_deg_;  // clang 14: lambdas cannot capture bindings
    CAPTURE(T);
    CAPTURE(theta_deg);
    const double ts = theta_deg * kPiD / 180.0;
    const double chi = (4.0 / 9.0 - T / 120.0) * (kPiD - 2.0 * ts);
    const double Yz = (4.0453 * T - 4.9710) * std::tan(chi) - 0.2155 * T + 2.4192;  // kcd/m²
    const double xz = T * T * (0.00166 * ts * ts * ts - 0.00375 * ts * ts + 0.00209 * ts) +
                      T * (-0.02903 * ts * ts * ts + 0.06377 * ts * ts - 0.03202 * ts + 0.00394) +
                      (0.11693 * ts * ts * ts - 0.21196 * ts * ts + 0.06052 * ts + 0.25886);
    const double yz = T * T * (0.00275 * ts * ts * ts - 0.00610 * ts * ts + 0.00317 * ts) +
                      T * (-0.04214 * ts * ts * ts + 0.08970 * ts * ts - 0.04153 * ts + 0.00516) +
                      (0.15346 * ts * ts * ts - 0.26756 * ts * ts + 0.06670 * ts + 0.26688);
    const Vec3 sun(static_cast<float>(std::sin(ts)) * 0.6f, static_cast<float>(std::cos(ts)), static_cast<float>(std::sin(ts)) * 0.8f);
    const PreethamSky sky(sun, static_cast<float>(T));
    CHECK(sky.zenith_luminance_kcd() == rel(Yz, 1e-5));
    const Rgb z = sky.radiance({0.f, 1.f, 0.f});
    REQUIRE(z.x > 0.f);
    REQUIRE(z.y > 0.f);
    REQUIRE(z.z > 0.f);
    // Back to XYZ with the sRGB (D65) matrix: Y in 10⁴ cd/m² and the chromaticity must be the paper's.
    auto check_xyY = [](Rgb c, double Y_expected, double x_expected, double y_expected) {
      const double X = 0.4124564 * c.x + 0.3575761 * c.y + 0.1804375 * c.z;
      const double Y = 0.2126729 * c.x + 0.7151522 * c.y + 0.0721750 * c.z;
      const double Z = 0.0193339 * c.x + 0.1191920 * c.y + 0.9503041 * c.z;
      CHECK(Y == rel(Y_expected, 1e-4));
      CHECK(X / (X + Y + Z) == rel(x_expected, 1e-4));
      CHECK(Y / (X + Y + Z) == rel(y_expected, 1e-4));
    };
    check_xyY(z, Yz / 10.0, xz, yz);

    // Off the zenith: Perez F(θ, γ) with the Appendix A.2 coefficients; value = zenith value × F(θ, γ)/F(0, θs).
    // Views (zenith angle, azimuth from the sun) chosen with γ far from θs so that every coefficient matters.
    for (const auto& [th_deg_, dphi_deg_] : {std::pair{80.0, 150.0}, std::pair{60.0, 100.0}, std::pair{30.0, 5.0}, std::pair{85.0, 0.0}}) {
      const auto& th_deg = th_deg_; const auto& dphi_deg = dphi_deg_;  // clang 14: lambdas cannot capture bindings
      CAPTURE(th_deg);
      CAPTURE(dphi_deg);
      const double th = th_deg * kPiD / 180.0, dphi = dphi_deg * kPiD / 180.0;
      const double cos_g = std::cos(th) * std::cos(ts) + std::sin(th) * std::sin(ts) * std::cos(dphi);
      const double g = std::acos(cos_g);
      auto F = [](double a, double b, double c, double d, double e, double cos_theta, double gamma) {
        return (1 + a * std::exp(b / cos_theta)) * (1 + c * std::exp(d * gamma) + e * std::cos(gamma) * std::cos(gamma));
      };
      auto ratio = [&](double a, double b, double c, double d, double e) {
        return F(a, b, c, d, e, std::cos(th), g) / F(a, b, c, d, e, 1.0, ts);
      };
      const double Yv = Yz * ratio(0.1787 * T - 1.4630, -0.3554 * T + 0.4275, -0.0227 * T + 5.3251, 0.1206 * T - 2.5771, -0.0670 * T + 0.3703);
      const double xv = xz * ratio(-0.0193 * T - 0.2592, -0.0665 * T + 0.0008, -0.0004 * T + 0.2125, -0.0641 * T - 0.8989, -0.0033 * T + 0.0452);
      const double yv = yz * ratio(-0.0167 * T - 0.2608, -0.0950 * T + 0.0092, -0.0079 * T + 0.2102, -0.0441 * T - 1.6537, -0.0109 * T + 0.0529);
      // The sun is at azimuth atan2(0.8, 0.6) in the x–z plane; the view direction dphi further round.
      const double sun_az = std::atan2(0.8, 0.6);
      const Vec3 view(static_cast<float>(std::sin(th) * std::cos(sun_az + dphi)), static_cast<float>(std::cos(th)),
                      static_cast<float>(std::sin(th) * std::sin(sun_az + dphi)));
      const Rgb v = sky.radiance(view);
      REQUIRE(v.x > 0.f);
      REQUIRE(v.y > 0.f);
      REQUIRE(v.z > 0.f);
      check_xyY(v, Yv / 10.0, xv, yv);
    }
  }
}

TEST_CASE("environment: Preetham sky is symmetric about the sun's vertical plane, peaks towards the sun, black below") {
  const float el = 30.f * kPi / 180.f, az = 70.f * kPi / 180.f;
  const Vec3 sun(std::cos(el) * std::cos(az), std::sin(el), std::cos(el) * std::sin(az));
  const PreethamSky sky(sun, 4.f);
  const Vec3 n = glm::normalize(glm::cross(sun, Vec3(0.f, 1.f, 0.f)));  // normal of the sun's vertical plane
  Pcg32 rng(41, 1);
  float worst = 0.f;
  int below_nonzero = 0;
  for (int k = 0; k < 20000; ++k) {
    const Vec3 d = sample_uniform_sphere(next2(rng));
    if (d.y < 0.f) {
      if (!is_black(sky.radiance(d))) ++below_nonzero;
      continue;
    }
    const Vec3 m = d - 2.f * glm::dot(d, n) * n;
    const Rgb a = sky.radiance(d), b = sky.radiance(m);
    for (int c = 0; c < 3; ++c) worst = std::max(worst, std::abs(a[c] - b[c]) / std::max(a[c], 1e-6f));
  }
  CHECK(worst < 1e-4f);
  CHECK(below_nonzero == 0);
  CHECK(is_black(sky.radiance({0.f, -1e-6f, 1.f})));
  CHECK(is_black(sky.radiance({0.f, -1.f, 0.f})));
  // Along the sun's almucantar (fixed zenith angle), luminance falls with the angle from the sun up to 90°.
  float prev = kInfinity;
  for (float dphi_deg : {3.f, 10.f, 20.f, 40.f, 60.f, 90.f}) {
    const float p = az + dphi_deg * kPi / 180.f;
    const float L = luminance(sky.radiance({std::cos(el) * std::cos(p), std::sin(el), std::cos(el) * std::sin(p)}));
    CAPTURE(dphi_deg);
    CHECK(L < prev);
    prev = L;
  }
  // Near the sun is brighter than the same elevation opposite it.
  const Rgb towards = sky.radiance(glm::normalize(sun + Vec3(0.f, 0.05f, 0.f)));
  const Rgb away = sky.radiance(glm::normalize(Vec3(-sun.x, sun.y + 0.05f, -sun.z)));
  CHECK(luminance(towards) > 2.f * luminance(away));
}

TEST_CASE("environment: Preetham sky and sun are finite over the turbidity range, sun at zenith to below horizon") {
  int bad = 0;
  for (float T : {kMinTurbidity, 2.f, 3.f, 5.f, 7.5f, kMaxTurbidity})
    for (float el_deg : {90.f, 60.f, 30.f, 5.f, 0.5f, 0.f, -10.f, -90.f}) {
      const float el = el_deg * kPi / 180.f;
      const Vec3 sun(std::cos(el) * 0.6f, std::sin(el), std::cos(el) * 0.8f);
      const PreethamSky sky(sun, T);
      for (int j = 0; j <= 30; ++j)
        for (int i = 0; i < 24; ++i) {
          const float theta = kPi / 2 * j / 30.f, phi = 2 * kPi * i / 24.f;
          const Rgb L = sky.radiance({std::sin(theta) * std::cos(phi), std::cos(theta), std::sin(theta) * std::sin(phi)});
          if (!is_finite(L) || L.x < 0.f || L.y < 0.f || L.z < 0.f) ++bad;
        }
      for (const Vec3 d : {sun, Vec3(0.f, 1.f, 0.f), Vec3(1.f, 0.f, 0.f)}) {
        const Rgb L = sky.radiance(d);
        if (!is_finite(L) || L.x < 0.f || L.y < 0.f || L.z < 0.f) ++bad;
      }
      const Rgb zen = sky.radiance({0.f, 1.f, 0.f});
      if (!(luminance(zen) > 0.f)) ++bad;
      const SunDisk s = sky.sun();
      if (!is_finite(s.radiance) || s.radiance.x < 0.f || (el_deg <= 0.f && !is_black(s.radiance)) ||
          (el_deg >= 5.f && !(s.radiance.y > 0.f)))
        ++bad;
      const Image img = make_sky_image(sun, T, 16, 8);
      for (float v : img.rgb)
        if (!std::isfinite(v) || v < 0.f) ++bad;
    }
  CHECK(bad == 0);
  CHECK_THROWS_AS(PreethamSky(Vec3(0.f, 1.f, 0.f), 1.5f), std::invalid_argument);
  CHECK_THROWS_AS(PreethamSky(Vec3(0.f, 1.f, 0.f), 10.5f), std::invalid_argument);
  CHECK_THROWS_AS(PreethamSky(Vec3(0.f, 1.f, 0.f), NAN), std::invalid_argument);
  CHECK_THROWS_AS(PreethamSky(Vec3(0.f), 3.f), std::invalid_argument);
  CHECK_THROWS_AS(make_sky_image(Vec3(0.f, 1.f, 0.f), 3.f, 0, 4), std::invalid_argument);
}

TEST_CASE("environment: Preetham sun radiance, cone and units") {
  // Appendix A.1 by hand, T = 3, sun 45° up, the green channel's wavelength 0.549 µm.
  const double T = 3.0, theta = 45.0;
  const double m = 1.0 / (std::cos(theta * kPiD / 180.0) + 0.15 * std::pow(93.885 - theta, -1.253));
  const double beta = 0.04608 * T - 0.04586;
  const double tau = std::exp(-0.008735 * std::pow(0.549, -4.08) * m) * std::exp(-beta * std::pow(0.549, -1.3) * m);
  const float e = 45.f * kPi / 180.f;
  const SunDisk s = preetham_sun({0.f, std::sin(e), -std::cos(e)}, 3.f);
  CHECK(s.radiance.y == rel(1.6e5 * tau, 1e-5));
  CHECK(s.radiance.x > s.radiance.y);  // longer wavelengths are attenuated less
  CHECK(s.radiance.y > s.radiance.z);
  CHECK(s.half_angle == rel(0.2667 * kPiD / 180.0, 1e-6));
  CHECK(s.cos_half_angle == rel(std::cos(0.2667 * kPiD / 180.0), 1e-7));
  CHECK(s.one_minus_cos == rel(1.0 - std::cos(0.2667 * kPiD / 180.0), 1e-4));
  CHECK(glm::length(s.dir - glm::normalize(Vec3(0.f, std::sin(e), -std::cos(e)))) < 1e-6f);
  // Units: a white Lambertian ground under sun + sky at 45° has radiance of order 1 (in 10⁴ cd/m²).
  const Image sky = make_sky_image(s.dir, 3.f, 128, 64);
  double E_sky = 0;
  for (int j = 0; j < 32; ++j)
    for (int i = 0; i < 128; ++i) {
      const double c0 = std::cos(kPiD * j / 64), c1 = std::cos(kPiD * (j + 1) / 64);
      E_sky += luminance(sky.at(i, j)) * 0.5 * (c0 * c0 - c1 * c1) * 2 * kPiD / 128;  // ∫ L cos θ dω per texel
    }
  const double E_sun = luminance(s.normal_irradiance()) * std::sin(e);
  const double ground = (E_sky + E_sun) / kPiD;
  MESSAGE("T=3, sun 45 deg: ground luminance " << ground << " (sun part " << E_sun / kPiD << ")");
  CHECK(ground > 0.5);
  CHECK(ground < 5.0);
  // Lower sun: dimmer and redder.
  const float e2 = 10.f * kPi / 180.f;
  const SunDisk low = preetham_sun({0.f, std::sin(e2), -std::cos(e2)}, 3.f);
  CHECK(low.radiance.y < s.radiance.y);
  CHECK(low.radiance.x / low.radiance.z > s.radiance.x / s.radiance.z);
}

TEST_CASE("environment: make_sky_image follows the lat-long convention") {
  const float el = 25.f * kPi / 180.f;
  const Vec3 sun(0.f, std::sin(el), -std::cos(el));  // ahead of the default camera: the centre column
  const int W = 64, H = 32;
  const Image img = make_sky_image(sun, 3.f, W, H);
  REQUIRE(img.width == W);
  REQUIRE(img.height == H);
  const PreethamSky sky(sun, 3.f);
  int best_i = -1, best_j = -1, bottom_nonzero = 0;
  float best = -1.f, worst = 0.f;
  for (int j = 0; j < H; ++j)
    for (int i = 0; i < W; ++i) {
      const Rgb c = img.at(i, j);
      if (j >= H / 2) {
        if (!is_black(c)) ++bottom_nonzero;
        continue;
      }
      const Rgb ref = sky.radiance(EnvironmentMap::direction_from_uv({(i + 0.5f) / W, (j + 0.5f) / H}));
      worst = std::max(worst, glm::length(c - ref) / std::max(glm::length(ref), 1e-6f));
      if (luminance(c) > best) best = luminance(c), best_i = i, best_j = j;
    }
  CHECK(bottom_nonzero == 0);
  CHECK(worst < 1e-6f);
  CHECK((best_i == W / 2 - 1 || best_i == W / 2));  // the texel columns either side of u = 0.5
  CHECK(std::abs((best_j + 0.5f) / H - (0.5f - 25.f / 180.f)) <= 1.5f / H);
}

// ------------------------------------------------------------------------------------------------------------
// HDR image reading

namespace {

struct TempDir {
  std::filesystem::path path;
  TempDir() {
    path = std::filesystem::temp_directory_path() / ("pt_env_test_" + std::to_string(::getpid()));
    std::filesystem::create_directories(path);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
  std::string file(const std::string& name) const { return (path / name).string(); }
};

void write_bytes(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

std::string read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// Radiance RGBE of one pixel (Ward's encoding: shared exponent from the largest component).
std::string rgbe(float r, float g, float b) {
  const float v = std::max({r, g, b});
  if (v < 1e-32f) return std::string(4, '\0');
  int e;
  const float scale = std::frexp(v, &e) * 256.f / v;
  return {static_cast<char>(static_cast<unsigned char>(r * scale)), static_cast<char>(static_cast<unsigned char>(g * scale)),
          static_cast<char>(static_cast<unsigned char>(b * scale)), static_cast<char>(e + 128)};
}

// 5×3 image of values exactly representable in half and in RGBE (few significant bits).
Image small_image() {
  Image img{5, 3, {}};
  for (int k = 0; k < 15; ++k)
    img.rgb.insert(img.rgb.end(), {0.125f * static_cast<float>(k + 1), 0.5f * static_cast<float>(k % 4), 2.f + static_cast<float>(k)});
  return img;
}

}  // namespace

TEST_CASE("environment: HDR images round-trip through EXR, Radiance HDR and PFM") {
  const TempDir tmp;
  const Image img = small_image();
  for (const auto& [name_, opts_] : {std::pair{"float.exr", ExrWriteOptions{false, false}},
                                   std::pair{"half_rgba.exr", ExrWriteOptions{true, true}},
                                   std::pair{"UPPER.EXR", ExrWriteOptions{true, false}}}) {
    const auto& name = name_; const auto& opts = opts_;  // clang 14: lambdas cannot capture bindings
    CAPTURE(name);
    write_exr(tmp.file(name), img, opts);
    const HdrImageResult r = read_hdr_image(tmp.file(name));
    REQUIRE_MESSAGE(r.ok(), r.error);
    CHECK(r.image.width == 5);
    CHECK(r.image.height == 3);
    CHECK(r.image.rgb == img.rgb);
  }
  // Radiance: a flat (uncompressed) 3×2 file, rows top to bottom.
  {
    std::string f = "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 2 +X 3\n";
    const float px[6][3] = {{1.f, 0.5f, 0.25f}, {2.f, 0.f, 0.f}, {0.f, 0.f, 0.f}, {0.75f, 3.f, 1.5f}, {16.f, 8.f, 4.f}, {0.125f, 0.125f, 0.0625f}};
    for (const auto& p : px) f += rgbe(p[0], p[1], p[2]);
    write_bytes(tmp.file("flat.hdr"), f);
    const HdrImageResult r = read_hdr_image(tmp.file("flat.hdr"));
    REQUIRE_MESSAGE(r.ok(), r.error);
    REQUIRE(r.image.width == 3);
    REQUIRE(r.image.height == 2);
    for (int k = 0; k < 6; ++k)
      for (int c = 0; c < 3; ++c) CHECK(r.image.rgb[static_cast<size_t>(3 * k + c)] == px[k][c]);
  }
  // Radiance: an adaptive-RLE 8×2 file (each scanline: 2 2 0 8, then per component runs/dumps).
  {
    std::string f = "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 2 +X 8\n";
    for (int row = 0; row < 2; ++row) {
      f += std::string{2, 2, 0, 8};
      // R: a run of 8 × 128; G: a dump of 8 values; B: a run of 4 × 0 then a run of 4 × 64; E: a run of 8 × (129 + row).
      f += std::string{static_cast<char>(128 + 8), static_cast<char>(128)};
      f += static_cast<char>(8);
      for (int i = 0; i < 8; ++i) f += static_cast<char>(16 * i);
      f += std::string{static_cast<char>(128 + 4), 0, static_cast<char>(128 + 4), 64};
      f += std::string{static_cast<char>(128 + 8), static_cast<char>(129 + row)};
    }
    write_bytes(tmp.file("rle.hdr"), f);
    for (size_t cut = f.size() - 40; cut < f.size(); ++cut) {  // every cut into the pixel data is an error
      write_bytes(tmp.file("rle_cut.hdr"), f.substr(0, cut));
      CAPTURE(cut);
      CHECK_FALSE(read_hdr_image(tmp.file("rle_cut.hdr")).ok());
    }
    const HdrImageResult r = read_hdr_image(tmp.file("rle.hdr"));
    REQUIRE_MESSAGE(r.ok(), r.error);
    REQUIRE(r.image.width == 8);
    REQUIRE(r.image.height == 2);
    int wrong = 0;
    for (int row = 0; row < 2; ++row)
      for (int i = 0; i < 8; ++i) {
        const float s = std::ldexp(1.f, 129 + row - 136);  // value = byte · 2^(E − 136)
        const Rgb expect(128 * s, 16 * i * s, (i < 4 ? 0 : 64) * s);
        if (r.image.at(i, row) != expect) ++wrong;
      }
    CHECK(wrong == 0);
  }
  // PFM through the same entry point.
  write_pfm(tmp.file("img.pfm"), img);
  const HdrImageResult r = read_hdr_image(tmp.file("img.pfm"));
  REQUIRE_MESSAGE(r.ok(), r.error);
  CHECK(r.image.rgb == img.rgb);
}

TEST_CASE("environment: corrupt, truncated or invalid HDR images give an error, never a crash") {
  const TempDir tmp;
  auto fails = [&](const std::string& path, const std::string& needle) {
    const HdrImageResult r = read_hdr_image(path);
    CAPTURE(path);
    CAPTURE(r.error);
    CHECK_FALSE(r.ok());
    CHECK(r.image.rgb.empty());
    CHECK(r.error.find(path) != std::string::npos);
    CHECK(r.error.find(needle) != std::string::npos);
  };
  fails(tmp.file("missing.exr"), "cannot open");
  write_bytes(tmp.file("picture.png"), "not an hdr");
  fails(tmp.file("picture.png"), "unsupported");
  write_bytes(tmp.file("empty.exr"), "");
  fails(tmp.file("empty.exr"), "");
  write_bytes(tmp.file("garbage.exr"), std::string(300, 'x'));
  fails(tmp.file("garbage.exr"), "");
  write_bytes(tmp.file("garbage.hdr"), std::string(300, 'x'));
  fails(tmp.file("garbage.hdr"), "");

  // EXR cut at many lengths, and with bytes overwritten: an error (or, for a harmless change, a valid image).
  const Image img = small_image();
  write_exr(tmp.file("good.exr"), img, {true, true});
  const std::string exr = read_bytes(tmp.file("good.exr"));
  REQUIRE(exr.size() > 100);
  int ok_truncated = 0;
  for (size_t len = 0; len < exr.size(); len += std::max<size_t>(1, exr.size() / 40)) {
    write_bytes(tmp.file("cut.exr"), exr.substr(0, len));
    if (read_hdr_image(tmp.file("cut.exr")).ok()) ++ok_truncated;
  }
  CHECK(ok_truncated == 0);
  Pcg32 rng(51, 9);
  int invalid_ok = 0;
  for (int k = 0; k < 60; ++k) {
    std::string bad = exr;
    for (int b = 0; b < 4; ++b) bad[rng.next_u32() % bad.size()] = static_cast<char>(rng.next_u32());
    write_bytes(tmp.file("flipped.exr"), bad);
    const HdrImageResult r = read_hdr_image(tmp.file("flipped.exr"));
    if (r.ok())
      for (float v : r.image.rgb)
        if (!std::isfinite(v) || v < 0.f) ++invalid_ok;
  }
  CHECK(invalid_ok == 0);

  // Radiance: truncated pixel data; absurd size in the header.
  const std::string hdr_head = "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 4 +X 4\n";
  write_bytes(tmp.file("short.hdr"), hdr_head + rgbe(1.f, 1.f, 1.f));
  fails(tmp.file("short.hdr"), "");
  write_bytes(tmp.file("huge.hdr"), "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 100000 +X 100000\n" + rgbe(1.f, 1.f, 1.f));
  fails(tmp.file("huge.hdr"), "");

  // PFM: truncated data, a header promising 2^32 texels, negative and non-finite texels.
  write_pfm(tmp.file("good.pfm"), img);
  const std::string pfm = read_bytes(tmp.file("good.pfm"));
  write_bytes(tmp.file("cut.pfm"), pfm.substr(0, pfm.size() - 7));
  fails(tmp.file("cut.pfm"), "truncated");
  write_bytes(tmp.file("huge.pfm"), "PF\n65536 65536\n-1.0\n" + std::string(64, '\0'));
  fails(tmp.file("huge.pfm"), "truncated");
  Image neg = img;
  neg.rgb[3 * 7 + 1] = -0.25f;  // texel 7 = (x 2, y 1), channel G
  write_pfm(tmp.file("neg.pfm"), neg);
  fails(tmp.file("neg.pfm"), "negative value -0.25 in channel G of texel (x 2, y 1");
  Image nan = img;
  nan.rgb[0] = NAN;
  write_pfm(tmp.file("nan.pfm"), nan);
  fails(tmp.file("nan.pfm"), "non-finite");
  Image inf = img;
  inf.rgb[5] = INFINITY;
  write_exr(tmp.file("inf.exr"), inf, {true, false});
  fails(tmp.file("inf.exr"), "non-finite");
}
