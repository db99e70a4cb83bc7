// The vertical axis of the viewer's relMSE plot: whole decades (log10) around the history's values. Pure
// arithmetic, so a test can give it any history: every value the film can produce (0 for a black image, +inf
// before every pixel has two samples, 1e-300, 1e300) gives a finite axis with a bounded number of lines.
#pragma once
#include <span>

#include "render/render_session.h"

namespace pt {

struct RelMseAxis {
  int lo = -3, hi = -2;      // decades at the bottom and top; hi > lo, hi - lo <= kMaxDecades
  bool any_positive = false;  // some finite value > 0 was seen (else the plot says why it is flat)
  bool any_zero = false;      // some value was exactly 0: a black (exact) image
  static constexpr int kLowest = -40, kHighest = 10, kMaxDecades = 12;
  // Where `relmse` lies between the bottom (0) and the top (1). Values at or below 10^lo (0 included) sit at
  // the bottom, values above 10^hi or not finite at the top.
  double fraction(double relmse) const;
};

RelMseAxis relmse_axis(std::span<const RelMsePoint> history);

}  // namespace pt
