#include "denoise/two_scale.h"

#include <algorithm>
#include <cmath>

namespace pt {

HalfScale half_scale(const DenoiseInput& in, const std::vector<float>& fine, ThreadPool& pool) {
  const int w = in.width, h = in.height, hw = (w + 1) / 2, hh = (h + 1) / 2;
  const size_t hn = static_cast<size_t>(hw) * static_cast<size_t>(hh);
  HalfScale half;
  FilmPlanes& p = half.planes;
  p.width = hw;
  p.height = hh;
  for (auto* plane : {&p.color, &p.variance, &p.albedo, &p.normal, &p.emission, &half.fine}) plane->resize(3 * hn);
  p.depth.resize(hn);
  pool.parallel_for(hh, [&](int y, int) {
    for (int x = 0; x < hw; ++x) {
      const size_t o = static_cast<size_t>(y) * static_cast<size_t>(hw) + static_cast<size_t>(x);
      float color[3] = {}, variance[3] = {}, albedo[3] = {}, normal[3] = {}, emission[3] = {}, out[3] = {};
      float depth = 0.f;
      bool variance_known = true;
      int count = 0;
      for (int Y = 2 * y; Y < std::min(2 * y + 2, h); ++Y)
        for (int X = 2 * x; X < std::min(2 * x + 2, w); ++X) {
          const size_t i = static_cast<size_t>(Y) * static_cast<size_t>(w) + static_cast<size_t>(X);
          ++count;
          depth += (*in.depth)[i];
          for (int c = 0; c < 3; ++c) {
            color[c] += (*in.color)[3 * i + c];
            const float v = (*in.variance)[3 * i + c];
            variance_known = variance_known && std::isfinite(v);
            variance[c] += v;
            albedo[c] += (*in.albedo)[3 * i + c];
            normal[c] += (*in.normal)[3 * i + c];
            if (in.emission) emission[c] += (*in.emission)[3 * i + c];
            out[c] += fine[3 * i + c];
          }
        }
      const float inv = 1.f / static_cast<float>(count);
      p.depth[o] = depth * inv;
      for (int c = 0; c < 3; ++c) {
        p.color[3 * o + c] = color[c] * inv;
        // The variance of a mean of `count` independent pixel means; unknown (0, as the regression reads it)
        // where one of them has none.
        p.variance[3 * o + c] = variance_known ? variance[c] * inv * inv : 0.f;
        p.albedo[3 * o + c] = albedo[c] * inv;
        p.normal[3 * o + c] = normal[c] * inv;  // the regression normalises it
        p.emission[3 * o + c] = emission[c] * inv;
        half.fine[3 * o + c] = out[c] * inv;
      }
    }
  });
  return half;
}

void add_coarse_correction(const HalfScale& half, const std::vector<float>& coarse, float limit, int width,
                           int height, std::vector<float>& fine, ThreadPool& pool) {
  const int hw = half.planes.width, hh = half.planes.height;
  std::vector<float> delta(coarse.size());
  for (size_t i = 0; i < delta.size(); ++i) {
    const float bound = limit * std::sqrt(half.planes.variance[i]);
    delta[i] = std::clamp(coarse[i] - half.fine[i], -bound, bound);
  }
  // Bilinear upsampling: pixel x's centre (x + ½) lies at (x + ½)/2 − ½ in half-resolution pixel coordinates.
  const auto source = [](int x, int n, int& x0, int& x1, float& t) {
    const float f = std::clamp((static_cast<float>(x) + 0.5f) * 0.5f - 0.5f, 0.f, static_cast<float>(n - 1));
    x0 = static_cast<int>(f);
    x1 = std::min(x0 + 1, n - 1);
    t = f - static_cast<float>(x0);
  };
  pool.parallel_for(height, [&](int y, int) {
    int y0, y1;
    float ty;
    source(y, hh, y0, y1, ty);
    for (int x = 0; x < width; ++x) {
      int x0, x1;
      float tx;
      source(x, hw, x0, x1, tx);
      const auto at = [&](int X, int Y, int c) {
        return delta[3 * (static_cast<size_t>(Y) * static_cast<size_t>(hw) + static_cast<size_t>(X)) + c];
      };
      const size_t i = static_cast<size_t>(y) * static_cast<size_t>(width) + static_cast<size_t>(x);
      for (int c = 0; c < 3; ++c) {
        const float up = (1.f - ty) * ((1.f - tx) * at(x0, y0, c) + tx * at(x1, y0, c)) +
                         ty * ((1.f - tx) * at(x0, y1, c) + tx * at(x1, y1, c));
        fine[3 * i + c] = std::max(0.f, fine[3 * i + c] + up);
      }
    }
  });
}

}  // namespace pt
