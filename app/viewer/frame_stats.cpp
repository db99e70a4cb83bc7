#include "viewer/frame_stats.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace pt {

double SampleSeries::quantile(double q) const {
  if (values_.empty()) return 0.0;
  std::vector<double> v = values_;
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(std::lround(q * static_cast<double>(v.size() - 1))));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

std::string SampleSeries::summary() const {
  char buf[128];
  std::snprintf(buf, sizeof buf, "median %.2f (p95 %.2f, max %.2f) over %zu", quantile(0.5), quantile(0.95),
                quantile(1.0), values_.size());
  return buf;
}

}  // namespace pt
