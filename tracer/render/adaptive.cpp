#include "render/adaptive.h"

#include <cmath>

namespace pt {

std::vector<int> plan_adaptive_pass(const Film& film, int tile_size, int mean_spp, uint64_t pass_index,
                                    const AdaptiveSettings& settings) {
  const int w = film.width(), h = film.height();
  const int tiles_x = (w + tile_size - 1) / tile_size, tiles_y = (h + tile_size - 1) / tile_size;
  const int tiles = tiles_x * tiles_y;
  std::vector<int> spp(tiles, mean_spp);
  if (settings.uniform_every <= 1 || pass_index % settings.uniform_every == 0 || film.min_count() < settings.min_spp)
    return spp;

  std::vector<double> error(tiles, 0.0);
  std::vector<int> pixels(tiles, 0);
  double total_error = 0.0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const size_t i = static_cast<size_t>(y) * w + x;
      const int t = (y / tile_size) * tiles_x + x / tile_size;
      const glm::dvec3 var = film.variance_of_mean(i);
      const Rgb m = film.mean(i);
      double e = 0.0;
      for (int c = 0; c < 3; ++c) e += var[c] / (static_cast<double>(m[c]) * m[c] + 0.01);
      error[t] += e;
      ++pixels[t];
      total_error += e;
    }
  if (!(total_error > 0.0) || !std::isfinite(total_error)) return spp;

  // Budget in pixel-samples, distributed by error share; rounding carried over so the total is kept.
  const double budget = static_cast<double>(mean_spp) * static_cast<double>(w) * h;
  double carry = 0.0;
  for (int t = 0; t < tiles; ++t) {
    const double want = budget * error[t] / total_error / pixels[t] + carry;
    const int n = std::min(static_cast<int>(std::floor(want)), settings.max_factor * mean_spp);
    carry = want - n > 1.0 ? 1.0 : want - n;
    spp[t] = std::max(0, n);
  }
  return spp;
}

}  // namespace pt
