// Frame-time and latency figures of a viewer run (`pathtracer view --stats`): medians and tails, not averages,
// since one slow frame is what a user notices.
#pragma once
#include <string>
#include <vector>

namespace pt {

class SampleSeries {
 public:
  void reserve(size_t n) { values_.reserve(n); }
  void add(double v) { values_.push_back(v); }
  size_t size() const { return values_.size(); }
  // q-quantile (0 = min, 0.5 = median, 1 = max) by nearest rank; 0 when empty.
  double quantile(double q) const;
  // "median M (p95 P, max X) over N" with the values formatted by %.2f.
  std::string summary() const;

 private:
  std::vector<double> values_;
};

}  // namespace pt
