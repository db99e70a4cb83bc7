// The progressive film: per pixel a sample count, the sum of the samples and the running sum of squared
// deviations (Welford 1962) per channel, in double.
//
// Why not the Shadertoy blend mix(old, new, 1/(n+1)) in float: it stops moving once (x − mean)/n falls below half
// an ulp of the mean (after ~10^7 samples at typical contrast), and its rounding errors accumulate as a random
// walk. The sum is kept as an unevaluated pair of doubles (hi + lo, Knuth's TwoSum: Knuth, TAOCP vol. 2,
// §4.2.2; Ogita, Rump & Oishi 2005): about 106 bits, so every sum of up to 2^32 float samples whose dynamic
// range is below ~2^50 is exact, and the mean (hi + lo)/n is the correctly rounded double of the exact mean in
// practice. That makes the order of accumulation irrelevant: a film merged from sample ranges rendered apart
// (another process, another machine, a resumed run; docs/scale-out.md) has the bits of the film that rendered
// them in one go. The second moment (Welford's update against that mean) gives the per-pixel variance of the
// mean, from which the image's relMSE is estimated without a reference.
//
// With features enabled (enable_features) the film also keeps, per pixel and with the same running mean, the
// feature buffers of film/pixel_features.h (albedo, normal, depth, emission) and the mean of "half A", one of two halves
// into which the samples are split (the other half's mean follows from the total), for denoisers that estimate
// their own error from two independent half images (Bitterli et al. 2016, §4).
#pragma once
#include <atomic>
#include <cstdint>
#include <vector>

#include "core/math.h"
#include "core/rng.h"
#include "film/pixel_features.h"
#include "film/pixel_rect.h"

namespace pt {

class Film {
 public:
  // Memory per pixel (counts, sum and second moment): what a film of w×h costs, to check before allocating.
  static constexpr size_t kBytesPerPixel = 2 * sizeof(uint32_t) + 9 * sizeof(double);
  // What the feature buffers and the half buffer add per pixel when enabled.
  static constexpr size_t kFeatureBytesPerPixel = sizeof(uint32_t) + 13 * sizeof(double);

  Film() = default;
  Film(int width, int height) { reset(width, height); }
  Film(Film&& o) noexcept { *this = std::move(o); }
  Film& operator=(Film&& o) noexcept {
    width_ = o.width_;
    height_ = o.height_;
    count_ = std::move(o.count_);
    attempts_ = std::move(o.attempts_);
    sum_ = std::move(o.sum_);
    m2_ = std::move(o.m2_);
    features_enabled_ = o.features_enabled_;
    feature_ = std::move(o.feature_);
    half_count_ = std::move(o.half_count_);
    half_mean_ = std::move(o.half_mean_);
    rejected_.store(o.rejected_.load());
    return *this;
  }

  void reset(int width, int height);  // keeps whether features are enabled
  void clear() { reset(width_, height_); }

  // Keep the feature buffers and the half buffer from now on (clears the film when the setting changes).
  void enable_features(bool on);
  bool has_features() const { return features_enabled_; }

  int width() const { return width_; }
  int height() const { return height_; }
  size_t pixel_count() const { return count_.size(); }

  // Adds one sample to pixel index i (= y·width + x). A sample with a NaN or infinite component never enters
  // the film: it is counted and false is returned. Not thread-safe per pixel: one thread owns a pixel at a time.
  bool add_sample(size_t i, Rgb v) {
    if (!is_finite(v)) {
      rejected_.fetch_add(1, std::memory_order_relaxed);
      return false;
    }
    const double previous = static_cast<double>(count_[i]);
    const double n = static_cast<double>(++count_[i]);
    double* sum = &sum_[6 * i];
    double* m2 = &m2_[3 * i];
    for (int c = 0; c < 3; ++c) {
      const double x = v[c];
      double& hi = sum[2 * c];
      double& lo = sum[2 * c + 1];
      const double mean_before = previous > 0.0 ? (hi + lo) / previous : 0.0;
      add_pair(hi, lo, x, 0.0);
      m2[c] += (x - mean_before) * (x - (hi + lo) / n);
    }
    return true;
  }
  // The same with the sample's features, for a film with features enabled. `sample_index` (the pixel's
  // next_sample_index before note_attempt) decides which half the sample belongs to (in_half_a).
  bool add_sample(size_t i, Rgb v, const PixelFeatures& f, uint32_t sample_index) {
    if (!add_sample(i, v)) return false;
    const double n = static_cast<double>(count_[i]);
    double* x = &feature_[kFeatureStride * i];
    const float values[kFeatureStride] = {f.albedo.x, f.albedo.y, f.albedo.z, f.normal.x,   f.normal.y,
                                          f.normal.z, f.depth,    f.emission.x, f.emission.y, f.emission.z};
    for (size_t c = 0; c < kFeatureStride; ++c) x[c] += (values[c] - x[c]) / n;
    if (in_half_a(i, sample_index)) {
      const double na = static_cast<double>(++half_count_[i]);
      double* h = &half_mean_[3 * i];
      for (int c = 0; c < 3; ++c) h[c] += (v[c] - h[c]) / na;
    }
    return true;
  }
  // Which half a sample belongs to: one member of each pair (2k, 2k+1), chosen by a hash of (pixel, k), so the
  // halves' counts differ by at most one. Not simply by parity: in an unshuffled Sobol sequence 2k and 2k+1 are
  // a stratified pair (the second is the first with the leading bit of each coordinate flipped), and the even
  // samples alone would cover only half of the pixel; the hash keeps each half spread over the whole domain
  // whatever order a sampler gives its points in.
  static bool in_half_a(size_t pixel, uint32_t sample_index) {
    const uint64_t pair = sample_index >> 1;
    const uint32_t bit = static_cast<uint32_t>(mix64(pixel * 0x9e3779b97f4a7c15ULL ^ (pair + 0x7f4a7c15ULL))) & 1u;
    return (sample_index & 1u) == bit;
  }

  uint32_t count(size_t i) const { return count_[i]; }
  Rgb mean(size_t i) const { return Rgb(mean_channel(i, 0), mean_channel(i, 1), mean_channel(i, 2)); }
  double mean_channel(size_t i, int c) const {
    return count_[i] > 0 ? (sum_[6 * i + 2 * c] + sum_[6 * i + 2 * c + 1]) / static_cast<double>(count_[i]) : 0.0;
  }
  // Unbiased estimate of the variance of pixel i's mean, per channel: s²/n with s² = M2/(n−1). Infinite below 2 samples.
  glm::dvec3 variance_of_mean(size_t i) const;
  uint64_t rejected() const { return rejected_.load(std::memory_order_relaxed); }
  // Counts a non-finite value dropped before it reached add_sample (a light-traced splat).
  void note_rejected() { rejected_.fetch_add(1, std::memory_order_relaxed); }
  // Samples attempted in pixel i (accepted + rejected): the index of the pixel's next sample.
  uint32_t next_sample_index(size_t i) const { return attempts_[i]; }
  void note_attempt(size_t i) { ++attempts_[i]; }

  // The image's relMSE estimated from the film's own variance: mean over pixels and channels of
  // Var[mean]/(mean² + 0.01), the expected relMSE against the converged image (docs/estimators.md). Infinite
  // while any pixel has fewer than 2 samples.
  double estimated_relmse() const;
  // The same over the pixels of `region` only (clipped to the film; an empty one gives +inf).
  double estimated_relmse(const PixelRect& region) const;
  // Minimum and total sample counts.
  uint32_t min_count() const;
  uint32_t min_count(const PixelRect& region) const;  // over the region's pixels (0 for an empty one)
  uint64_t total_count() const;

  // Row-major RGB float image of the means (3 floats per pixel, top row first). The forms taking `out` fill it,
  // reusing its capacity (interactive callers convert a film per frame).
  std::vector<float> mean_image() const;
  void mean_image(std::vector<float>& out) const;

  // Feature buffers (features enabled), row-major: albedo, normal and emission 3 floats per pixel, depth 1.
  std::vector<float> albedo_image() const { return feature_image(0, 3); }
  std::vector<float> normal_image() const { return feature_image(3, 3); }
  std::vector<float> depth_image() const { return feature_image(6, 1); }
  std::vector<float> emission_image() const { return feature_image(7, 3); }
  void albedo_image(std::vector<float>& out) const { feature_image(0, 3, out); }
  void normal_image(std::vector<float>& out) const { feature_image(3, 3, out); }
  void depth_image(std::vector<float>& out) const { feature_image(6, 1, out); }
  void emission_image(std::vector<float>& out) const { feature_image(7, 3, out); }
  // Variance of each pixel's mean per channel (variance_of_mean; infinite below 2 samples), 3 floats per pixel.
  std::vector<float> variance_image() const;
  void variance_image(std::vector<float>& out) const;
  // Sample count per pixel, 1 float per pixel.
  std::vector<float> count_image() const;
  // Mean of half A (half = 0) or half B (1), 3 floats per pixel; 0 where the half has no sample.
  std::vector<float> half_image(int half) const;
  uint32_t half_a_count(size_t i) const { return half_count_[i]; }

  // --- Scale-out (io/film_state.h, docs/scale-out.md).
  // Starts an empty film's sample indices at `first` for every pixel: the film renders the sample range
  // [first, first + n) of a longer render (`render --sample-range`).
  void start_at(uint32_t first);
  // Adds another film of the same size and features (its samples disjoint from this one's, or drawn with another
  // seed): counts add, the sums add as double-double pairs (so the mean has the bits of one film holding all
  // the samples), the second moments by the parallel form of Welford's update (Chan, Golub & LeVeque 1979:
  // M2 = M2_a + M2_b + δ²·na·nb/n, δ = mean_b − mean_a; equal to the sequential one up to rounding);
  // features and half means are count-weighted, rejected counts add, and the next sample index is the larger.
  // Throws std::invalid_argument on a size or feature mismatch.
  void merge(const Film& other);
  // The raw accumulation state, for io/film_state (saving and loading a film exactly): U and D are the count and
  // the double vectors, const or not.
  template <class U, class D>
  struct ArraysOf {
    U* count;
    U* attempts;
    D* sum;  // (hi, lo) per channel
    D* m2;
    D* feature;  // empty without features
    U* half_count;
    D* half_mean;
  };
  using Arrays = ArraysOf<std::vector<uint32_t>, std::vector<double>>;
  using ConstArrays = ArraysOf<const std::vector<uint32_t>, const std::vector<double>>;
  Arrays arrays() { return {&count_, &attempts_, &sum_, &m2_, &feature_, &half_count_, &half_mean_}; }
  ConstArrays arrays() const { return {&count_, &attempts_, &sum_, &m2_, &feature_, &half_count_, &half_mean_}; }
  void set_rejected(uint64_t n) { rejected_.store(n); }

 private:
  static constexpr size_t kFeatureStride = 10;  // albedo rgb, normal xyz, depth, emission rgb
  // (hi, lo) += (xh, xl), double-double: TwoSum gives hi + xh exactly as s + e; the low parts join e, and a second
  // TwoSum renormalises so |lo| stays below half an ulp of hi (the pair then holds ~106 bits).
  static void add_pair(double& hi, double& lo, double xh, double xl) {
    const double s = hi + xh, sb = s - hi, e = (hi - (s - sb)) + (xh - sb);
    const double t = lo + xl + e;
    const double h = s + t, hb = h - s;
    lo = (s - (h - hb)) + (t - hb);
    hi = h;
  }
  std::vector<float> feature_image(size_t first, size_t channels) const;
  void feature_image(size_t first, size_t channels, std::vector<float>& out) const;

  int width_ = 0, height_ = 0;
  bool features_enabled_ = false;
  std::vector<double> feature_;      // kFeatureStride per pixel (features enabled)
  std::vector<uint32_t> half_count_;  // samples in half A
  std::vector<double> half_mean_;    // mean of half A, 3 per pixel
  std::vector<uint32_t> count_, attempts_;
  std::vector<double> sum_;  // per pixel and channel the pair (hi, lo): 6 doubles a pixel
  std::vector<double> m2_;
  std::atomic<uint64_t> rejected_{0};
};

}  // namespace pt
