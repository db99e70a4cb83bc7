// The camera-sample generators (sampling/sampler.h) and the dimension layout (sampling/sample_dimensions.h).
#include <doctest/doctest.h>

#include <cstring>
#include <set>
#include <vector>

#include "chi2.h"
#include "sampling/sample_dimensions.h"
#include "sampling/sampler.h"
#include "sampling/sobol_batch.h"

using namespace pt;

namespace {

// Number of distinct cells hit when n = 2^m points are binned into the 2^a × 2^(m−a) elementary intervals.
int cells_hit(const std::vector<Vec2>& pts, int a, int m) {
  std::set<uint32_t> cells;
  for (const Vec2& p : pts) {
    const uint32_t cx = static_cast<uint32_t>(p.x * static_cast<float>(1u << a));
    const uint32_t cy = static_cast<uint32_t>(p.y * static_cast<float>(1u << (m - a)));
    cells.insert(cx << (m - a) | cy);
  }
  return static_cast<int>(cells.size());
}

// Pearson's test of uniformity of values on a k×k grid (k = 1 for a 1D test on the x axis only).
template <class F>
double uniformity_p_value(int n, int kx, int ky, F&& value) {
  std::vector<double> observed(kx * ky, 0.0), expected(kx * ky, static_cast<double>(n) / (kx * ky));
  for (int i = 0; i < n; ++i) {
    const Vec2 v = value(i);
    REQUIRE(v.x >= 0.f);
    REQUIRE(v.x < 1.f);
    REQUIRE(v.y >= 0.f);
    REQUIRE(v.y < 1.f);
    observed[static_cast<int>(v.x * kx) * ky + static_cast<int>(v.y * ky)] += 1;
  }
  return test::chi2_test(observed, expected).p_value;
}

}  // namespace

TEST_CASE("sampler: every Sobol dimension of a pixel is a (0,2)-net over its first 2^m samples") {
  // Each power-of-two prefix of a (0,2)-sequence puts exactly one point in every elementary interval of area
  // 2^-m, whatever the split 2^a × 2^(m−a); Owen scrambling keeps that (Burley 2020, §3). A wrong generator
  // column, bit reversal or scramble breaks it at once.
  for (uint64_t pixel : {0ull, 7ull, 123456ull}) {
    for (uint32_t d = 0; d < SobolSampler::kSobolPairs; ++d) {
      for (int m : {4, 8}) {
        std::vector<Vec2> pts;
        for (uint64_t i = 0; i < (1u << m); ++i) pts.push_back(SobolSampler(pixel, i, 5).get_2d(d));
        for (int a = 0; a <= m; ++a) CHECK(cells_hit(pts, a, m) == (1 << m));
      }
    }
  }
  // The hashed dimensions beyond are not stratified: 256 independent points fill far fewer than 256 of 16×16
  // cells (expected 256·(1 − (1 − 1/256)^256) ≈ 162; P(≥ 250) is astronomically small).
  std::vector<Vec2> pts;
  for (uint64_t i = 0; i < 256; ++i) pts.push_back(SobolSampler(3, i, 5).get_2d(SobolSampler::kSobolPairs));
  CHECK(cells_hit(pts, 4, 8) < 200);
}

TEST_CASE("sampler: dimensions and pixels are decorrelated, values uniform") {
  // Pooled over pixels, each kind of value is uniform (Pearson's test on a 16×16 grid or 64 bins, fixed seeds;
  // each check fails with probability 1e-4 for a correct sampler).
  const int n = 1 << 16;
  for (uint32_t d : {0u, 3u, 9u}) {
    CHECK(uniformity_p_value(n, 16, 16, [&](int i) { return SobolSampler(i, 0, 1).get_2d(d); }) > 1e-4);
    CHECK(uniformity_p_value(n, 16, 16, [&](int i) { return IndependentSampler(i, 0, 1).get_2d(d); }) > 1e-4);
    // Pairs across dimensions: dimension d's x against dimension d+1's x of the same sample.
    CHECK(uniformity_p_value(n, 16, 16, [&](int i) {
            const SobolSampler s(i % 97, i / 97, 2);
            return Vec2(s.get_2d(d).x, s.get_2d(d + 1).x);
          }) > 1e-4);
    CHECK(uniformity_p_value(n, 64, 1, [&](int i) { return Vec2(SobolSampler(i, 0, 1).get_1d(d), 0.f); }) > 1e-4);
    CHECK(uniformity_p_value(n, 16, 16, [&](int i) {
            const IndependentSampler s(i % 31, i / 31, 4);
            return Vec2(s.get_1d(d), s.get_1d(d + 1));
          }) > 1e-4);
    // Neighbouring pixels at the same sample index.
    CHECK(uniformity_p_value(n, 16, 16, [&](int i) {
            return Vec2(SobolSampler(2 * i, 7, 3).get_2d(d).x, SobolSampler(2 * i + 1, 7, 3).get_2d(d).x);
          }) > 1e-4);
  }
}

TEST_CASE("sampler: a value depends on its dimension only, not on what was asked before") {
  const SobolSampler a(42, 17, 9), b(42, 17, 9);
  const Vec2 late = a.get_2d(5);
  for (uint32_t d = 0; d < 5; ++d) (void)b.get_2d(d);
  CHECK(b.get_2d(5).x == late.x);
  CHECK(b.get_2d(5).y == late.y);
  CHECK(a.get_1d(4) == b.get_1d(4));
  // Different seeds, pixels and sample indices give different values.
  CHECK(SobolSampler(42, 17, 10).get_2d(5).x != late.x);
  CHECK(SobolSampler(43, 17, 9).get_2d(5).x != late.x);
  CHECK(SobolSampler(42, 18, 9).get_2d(5).x != late.x);
}

TEST_CASE("sampler: bdpt's layout gives each decision its own dimension, a lens two more before the bounces") {
  for (bool lens : {false, true}) {
    const BdptDimensions dims(lens);
    std::set<uint32_t> two_d{BdptDimensions::kCameraJitter, BdptDimensions::kEmissionPoint,
                             BdptDimensions::kEmissionDirection};
    std::set<uint32_t> one_d{BdptDimensions::kLightChoice};
    if (lens) {
      CHECK(two_d.insert(BdptDimensions::kCameraLens).second);
      CHECK(two_d.insert(BdptDimensions::kEyeLens).second);
    }
    const BdptDimensions pinhole(false);
    CHECK(pinhole.camera_direction(0) == 3u);  // the layout bdpt's pinhole images were made with
    for (uint32_t b = 0; b < 50; ++b) {
      CHECK(dims.camera_direction(b) == pinhole.camera_direction(b) + (lens ? 2u : 0u));
      CHECK(two_d.insert(dims.camera_direction(b)).second);
      CHECK(two_d.insert(dims.connection_point(b)).second);
      CHECK(two_d.insert(dims.light_direction(b)).second);
      for (const uint32_t d : {BdptDimensions::camera_lobe(b), BdptDimensions::camera_roulette(b),
                               BdptDimensions::connection_light_choice(b), BdptDimensions::light_lobe(b),
                               BdptDimensions::light_roulette(b), BdptDimensions::manifold_chain_choice(b)})
        CHECK(one_d.insert(d).second);
    }
    CHECK(*two_d.rbegin() == two_d.size() - 1);  // dense
    CHECK(*one_d.rbegin() == one_d.size() - 1);
  }
}

TEST_CASE("sampler: the dimension layout gives each decision of each bounce its own dimension") {
  for (bool light_sampling : {false, true})
  for (bool lens : {false, true}) {
    const SampleDimensions dims(light_sampling, lens);
    std::set<uint32_t> two_d{SampleDimensions::kCameraJitter}, one_d;
    if (lens) CHECK(two_d.insert(SampleDimensions::kLens).second);
    // A thin lens moves every bounce's 2D dimensions up by exactly one; a pinhole's layout is the one before.
    const SampleDimensions pinhole(light_sampling, false);
    for (uint32_t b = 0; b < 50; ++b) {
      CHECK(dims.bsdf_direction(b) == pinhole.bsdf_direction(b) + (lens ? 1u : 0u));
      if (light_sampling) CHECK(dims.light_point(b) == pinhole.light_point(b) + (lens ? 1u : 0u));
    }
    for (uint32_t b = 0; b < 50; ++b) {
      CHECK(two_d.insert(dims.bsdf_direction(b)).second);
      if (light_sampling) CHECK(two_d.insert(dims.light_point(b)).second);
      CHECK(one_d.insert(SampleDimensions::light_choice(b)).second);
      CHECK(one_d.insert(SampleDimensions::bsdf_lobe(b)).second);
      CHECK(one_d.insert(SampleDimensions::roulette(b)).second);
    }
    // Dense: no stratified dimension is left unused.
    CHECK(*two_d.rbegin() == two_d.size() - 1);
  }
  // The stratified dimensions go to the first bounces: with light sampling, camera + 3.5 bounces.
  const SampleDimensions nee(true);
  CHECK(nee.light_point(0) == 1);
  CHECK(nee.bsdf_direction(0) == 2);
  CHECK(nee.light_point(3) == 7);
  CHECK(SampleDimensions(false).bsdf_direction(6) == 7);
}

TEST_CASE("sobol batch: points computed across lanes equal each sampler's own get_2d, bit for bit") {
  // 37 samplers (two full groups of 16 and a partial one), a permuted queue of 29 of them, every dimension
  // (batched and hashed), sample indices spanning all 32 bits.
  std::vector<SobolSampler> samplers;
  for (uint64_t i = 0; i < 37; ++i) samplers.emplace_back(1000 + 7 * i, i * 0x9e3779b97f4a7c15ULL >> 32, 3 + i % 2);
  std::vector<uint16_t> queue;
  for (uint16_t i = 0; i < 29; ++i) queue.push_back(static_cast<uint16_t>((i * 11) % 37));
  int mismatches = 0;
  for (uint32_t d = 0; d < SobolSampler::kSobolPairs + 2; ++d) {
    std::vector<Vec2> all(samplers.size()), queued(queue.size());
    SobolBatch::get_2d(samplers.data(), nullptr, static_cast<int>(samplers.size()), d, all.data());
    SobolBatch::get_2d(samplers.data(), queue.data(), static_cast<int>(queue.size()), d, queued.data());
    for (size_t j = 0; j < samplers.size(); ++j) {
      const Vec2 want = samplers[j].get_2d(d);
      mismatches += std::memcmp(&all[j], &want, sizeof(Vec2)) != 0;
    }
    for (size_t j = 0; j < queue.size(); ++j) {
      const Vec2 want = samplers[queue[j]].get_2d(d);
      mismatches += std::memcmp(&queued[j], &want, sizeof(Vec2)) != 0;
    }
  }
  INFO("SIMD batch compiled in: " << SobolBatch::batched(0));
  CHECK(mismatches == 0);
}
