// A rectangle of film pixels, half-open: x0 ≤ x < x1, y0 ≤ y < y1, (0, 0) the top-left pixel. The render region
// (Blender's render border): passes trace only its pixels, and the film's statistics cover only them.
#pragma once
#include <algorithm>
#include <cstddef>

namespace pt {

struct PixelRect {
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;

  bool empty() const { return x1 <= x0 || y1 <= y0; }
  size_t area() const { return empty() ? 0 : static_cast<size_t>(x1 - x0) * static_cast<size_t>(y1 - y0); }
  bool contains(int x, int y) const { return x >= x0 && x < x1 && y >= y0 && y < y1; }
  // The pixels in both (empty when they do not overlap).
  PixelRect intersected(const PixelRect& o) const {
    return {std::max(x0, o.x0), std::max(y0, o.y0), std::min(x1, o.x1), std::min(y1, o.y1)};
  }
  PixelRect clipped(int width, int height) const { return intersected({0, 0, width, height}); }
  // The rectangle with corners (ax, ay) and (bx, by), given in any order (a drag's start and end).
  static PixelRect spanning(int ax, int ay, int bx, int by) {
    return {std::min(ax, bx), std::min(ay, by), std::max(ax, bx), std::max(ay, by)};
  }
  bool operator==(const PixelRect&) const = default;
};

// The whole of a width × height film.
inline PixelRect full_rect(int width, int height) { return {0, 0, width, height}; }

}  // namespace pt
