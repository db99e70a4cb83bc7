// Fireflies before a denoiser filters: a pixel far brighter than its neighbours whose brightness rests on a few
// samples (its mean's standard deviation is a large part of the mean) would stay a spike, or, spread by a filter's
// weights, a blotch. Its excess over `ratio` × the median of its 8 neighbours (the upper of the two middle values,
// so that clusters of up to three fireflies are caught) is taken out of the radiance to be filtered and spread
// over the (2·radius + 1)² window around it instead, with a smooth bump (fireflies.cpp): the image keeps its
// energy and the spike becomes a faint wash. Measured on both filters in docs/denoising.md.
#pragma once
#include <vector>

#include "core/thread_pool.h"

namespace pt {

struct FireflySettings {
  float ratio = 1.5f;      // bound: ratio × the neighbours' median luminance (0: the step is off)
  float deviation = 0.5f;  // only pixels whose mean's standard deviation exceeds deviation × their mean
  int radius = 16;         // the excess is spread over the (2·radius + 1)² window (twice the filters' own)
};

// `radiance` and `variance`: 3 floats per pixel, row-major, w × h (the variance of each pixel's mean; a pixel
// whose variance is not finite, below 2 samples, is never cut). Lowers `radiance` where it cuts and returns the spread excess (3 floats per pixel),
// or an empty vector when no pixel was cut. Rows and columns run on `pool`.
std::vector<float> spread_fireflies(int w, int h, const FireflySettings& settings, std::vector<float>& radiance,
                                   const std::vector<float>& variance, ThreadPool& pool);

}  // namespace pt
