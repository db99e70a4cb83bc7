// Helpers on displayed frames shared by the session tests and the GL viewer tests.
#pragma once
#include "render/render_session.h"

namespace pt::test {

// Mean red/green/blue over the block of pixels [x0, x1) × [y0, y1) of a frame.
inline glm::dvec3 block_mean(const DisplayFrame& f, int x0, int y0, int x1, int y1) {
  glm::dvec3 sum(0.0);
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x)
      for (int c = 0; c < 3; ++c) sum[c] += f.rgba[4 * (static_cast<size_t>(y) * f.width + x) + c];
  return sum / static_cast<double>((x1 - x0) * (y1 - y0));
}

}  // namespace pt::test
