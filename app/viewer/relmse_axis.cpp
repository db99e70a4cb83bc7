#include "viewer/relmse_axis.h"

#include <algorithm>
#include <cmath>

namespace pt {

RelMseAxis relmse_axis(std::span<const RelMsePoint> history) {
  RelMseAxis a;
  double lo = 0.0, hi = 0.0;
  for (const RelMsePoint& q : history) {
    if (q.relmse == 0.0) a.any_zero = true;
    if (!(q.relmse > 0.0) || !std::isfinite(q.relmse)) continue;  // 0, NaN, inf: no logarithm
    const double l = std::log10(q.relmse);
    lo = a.any_positive ? std::min(lo, l) : l;
    hi = a.any_positive ? std::max(hi, l) : l;
    a.any_positive = true;
  }
  if (!a.any_positive) return a;
  // Subnormal values give log10 near -324: the axis stops at kLowest; the newest, lowest values matter most,
  // so a span wider than kMaxDecades keeps the bottom.
  a.lo = static_cast<int>(std::clamp(std::floor(lo), double(RelMseAxis::kLowest), double(RelMseAxis::kHighest - 1)));
  a.hi = static_cast<int>(std::clamp(std::ceil(hi), double(a.lo + 1), double(RelMseAxis::kHighest)));
  a.hi = std::min(a.hi, a.lo + RelMseAxis::kMaxDecades);
  return a;
}

double RelMseAxis::fraction(double relmse) const {
  if (std::isnan(relmse) || std::isinf(relmse)) return relmse < 0.0 ? 0.0 : 1.0;
  if (!(relmse > 0.0)) return 0.0;
  return std::clamp((std::log10(relmse) - lo) / (hi - lo), 0.0, 1.0);
}

}  // namespace pt
