// The firefly step of the denoisers (fireflies.h).
#include "denoise/fireflies.h"

#include <algorithm>
#include <cmath>

#include "core/math.h"

namespace pt {

namespace {

// Sorts 8 values with Batcher's odd–even merge network (19 compare-exchanges, branch-free; checked on all 2^8
// zero-one inputs, which suffices by the 0-1 principle, Knuth TAOCP vol. 3, §5.3.4).
inline void sort8(float (&v)[8]) {
  constexpr int kNet[19][2] = {{0, 1}, {2, 3}, {4, 5}, {6, 7}, {0, 2}, {1, 3}, {4, 6}, {5, 7}, {1, 2}, {5, 6},
                               {0, 4}, {1, 5}, {2, 6}, {3, 7}, {2, 4}, {3, 5}, {1, 2}, {3, 4}, {5, 6}};
  for (const auto& [a, b] : kNet) {
    const float lo = std::min(v[a], v[b]), hi = std::max(v[a], v[b]);
    v[a] = lo, v[b] = hi;
  }
}

}  // namespace

std::vector<float> spread_fireflies(int w, int h, const FireflySettings& st, std::vector<float>& radiance,
                                   const std::vector<float>& variance, ThreadPool& pool) {
  if (!(st.ratio > 0.f)) return {};
  const size_t n = static_cast<size_t>(w) * static_cast<size_t>(h);
  const auto at = [w](int x, int y) { return static_cast<size_t>(y) * static_cast<size_t>(w) + static_cast<size_t>(x); };
  std::vector<float> lum(n);
  pool.parallel_for(h, [&](int y, int) {
    for (size_t i = at(0, y); i < at(0, y) + static_cast<size_t>(w); ++i)
      lum[i] = luminance(Rgb(radiance[3 * i], radiance[3 * i + 1], radiance[3 * i + 2]));
  });
  // The cuts, row by row (each row's task writes only its own list and its own pixels).
  struct Cut {
    int x;
    float excess[3];  // divided by the bump's sum over the cut's in-image window (its normalisation, once)
  };
  // The spread's bump (below) and its sum over the part of a window around p that lies in [0, size).
  const int R = st.radius;
  std::vector<float> bump(static_cast<size_t>(2 * R + 1));
  for (int d = -R; d <= R; ++d) {
    const float t = static_cast<float>(d) / static_cast<float>(R + 1);
    bump[static_cast<size_t>(d + R)] = sqr(1.f - t * t);
  }
  const auto bump_sum = [&](int p, int size) {
    float sum = 0.f;
    for (int q = std::max(p - R, 0); q <= std::min(p + R, size - 1); ++q) sum += bump[static_cast<size_t>(q - p + R)];
    return sum;
  };
  std::vector<std::vector<Cut>> cuts(static_cast<size_t>(h));
  pool.parallel_for(h, [&](int y, int) {
    for (int x = 0; x < w; ++x) {
      const size_t i = at(x, y);
      const float l = lum[i];
      // A rough deviation of the luminance (the channels' variances weighted like the channels): the test only
      // asks whether a few samples carry the pixel. Below 2 samples (no finite variance) it cannot tell: no cut.
      // It comes first because it rejects most pixels without the neighbours' median.
      const float v = luminance(Rgb(variance[3 * i], variance[3 * i + 1], variance[3 * i + 2]));
      if (!(std::isfinite(v) && std::sqrt(std::max(0.f, v)) > st.deviation * l)) continue;
      float around[8];
      int k = 0;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx)
          if (dx != 0 || dy != 0) around[k++] = lum[at(std::clamp(x + dx, 0, w - 1), std::clamp(y + dy, 0, h - 1))];
      sort8(around);
      const float limit = st.ratio * around[4];  // the upper median
      if (!(l > limit)) continue;
      const float keep = limit / l;
      Cut cut{x, {}};
      const float norm = 1.f / (bump_sum(x, w) * bump_sum(y, h));
      for (int c = 0; c < 3; ++c) {
        cut.excess[c] = radiance[3 * i + c] * (1.f - keep) * norm;
        radiance[3 * i + c] *= keep;
      }
      cuts[static_cast<size_t>(y)].push_back(cut);
    }
  });
  size_t count = 0;
  for (const auto& row : cuts) count += row.size();
  if (count == 0) return {};
  // Each cut's excess is spread with the smooth bump k(dx)·k(dy) over the (2R+1)² window, k(d) = (1 − (d/(R+1))²)²
  // (the biweight), normalised over the window's in-image pixels. A box over half that radius (the first version)
  // drew each cut as a square: where fireflies are dense (a glass mesh's light-traced caustics on the walls at a
  // few samples per pixel) the viewer showed a mosaic of squares; the bump over the same half radius, distinct
  // round spots (docs/denoising.md). Output rows run in parallel, each gathering the cuts of the rows within R of
  // it (a firefly is rare: a few thousand at 512², 16 spp, against 2.6·10⁵ pixels).
  std::vector<float> spread(3 * n, 0.f);
  pool.parallel_for(h, [&](int y, int) {
    float* out = &spread[3 * at(0, y)];
    for (int sy = std::max(y - R, 0); sy <= std::min(y + R, h - 1); ++sy)
      for (const Cut& cut : cuts[static_cast<size_t>(sy)]) {
        const float row_share = bump[static_cast<size_t>(y - sy + R)];
        for (int x = std::max(cut.x - R, 0); x <= std::min(cut.x + R, w - 1); ++x) {
          const float share = row_share * bump[static_cast<size_t>(x - cut.x + R)];
          for (int c = 0; c < 3; ++c) out[3 * x + c] += cut.excess[c] * share;
        }
      }
  });
  return spread;
}

}  // namespace pt
