// The progressive film: per pixel a sample count, the running mean and the running sum of squared deviations
// (Welford 1962) per channel, in double.
//
// Why double Welford rather than the Shadertoy blend mix(old, new, 1/(n+1)) in float: the float blend stops
// moving once (x − mean)/n falls below half an ulp of the mean (after ~10^7 samples at typical contrast), and
// its rounding errors accumulate as a random walk. A double mean updated by mean += (x − mean)/n keeps ~16
// digits, so 10^8 samples still leave the mean exact to ~1e-12 relative. The second moment gives the
// per-pixel variance of the mean, from which the image's relMSE is estimated without a reference.
#pragma once
#include <atomic>
#include <cstdint>
#include <vector>

#include "core/math.h"

namespace pt {

class Film {
 public:
  // Memory per pixel (counts, mean and second moment): what a film of w×h costs, to check before allocating.
  static constexpr size_t kBytesPerPixel = 2 * sizeof(uint32_t) + 6 * sizeof(double);

  Film() = default;
  Film(int width, int height) { reset(width, height); }
  Film(Film&& o) noexcept { *this = std::move(o); }
  Film& operator=(Film&& o) noexcept {
    width_ = o.width_;
    height_ = o.height_;
    count_ = std::move(o.count_);
    attempts_ = std::move(o.attempts_);
    mean_ = std::move(o.mean_);
    m2_ = std::move(o.m2_);
    rejected_.store(o.rejected_.load());
    return *this;
  }

  void reset(int width, int height);
  void clear() { reset(width_, height_); }

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
    const double n = static_cast<double>(++count_[i]);
    double* mean = &mean_[3 * i];
    double* m2 = &m2_[3 * i];
    for (int c = 0; c < 3; ++c) {
      const double x = v[c];
      const double delta = x - mean[c];
      mean[c] += delta / n;
      m2[c] += delta * (x - mean[c]);
    }
    return true;
  }

  uint32_t count(size_t i) const { return count_[i]; }
  Rgb mean(size_t i) const { return Rgb(mean_[3 * i], mean_[3 * i + 1], mean_[3 * i + 2]); }
  double mean_channel(size_t i, int c) const { return mean_[3 * i + c]; }
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
  // Minimum and total sample counts.
  uint32_t min_count() const;
  uint64_t total_count() const;

  // Row-major RGB float image of the means (3 floats per pixel, top row first).
  std::vector<float> mean_image() const;

 private:
  int width_ = 0, height_ = 0;
  std::vector<uint32_t> count_, attempts_;
  std::vector<double> mean_, m2_;
  std::atomic<uint64_t> rejected_{0};
};

}  // namespace pt
