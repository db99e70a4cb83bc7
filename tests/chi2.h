// Pearson's chi-square goodness-of-fit test as used by Mitsuba's and pbrt-v4's sampling tests: cells whose
// expected count is below 5 are pooled, and the statistic's p-value comes from the chi-square distribution.
#pragma once
#include <algorithm>
#include <cmath>
#include <numeric>
#include <vector>

namespace pt::test {

// Regularised upper incomplete gamma Q(a, x) = Γ(a, x)/Γ(a): series for x < a+1, Lentz continued fraction else
// (Press et al., Numerical Recipes §6.2, written out from the formulas).
inline double gamma_q(double a, double x) {
  if (x <= 0.0) return 1.0;
  const double log_prefix = -x + a * std::log(x) - std::lgamma(a);
  if (x < a + 1.0) {
    double term = 1.0 / a, sum = term;
    for (int n = 1; n < 100000 && std::abs(term) > std::abs(sum) * 1e-16; ++n) {
      term *= x / (a + n);
      sum += term;
    }
    return 1.0 - sum * std::exp(log_prefix);
  }
  const double tiny = 1e-300;
  double b = x + 1.0 - a, c = 1.0 / tiny, d = 1.0 / b, h = d;
  for (int i = 1; i < 100000; ++i) {
    const double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::abs(d) < tiny) d = tiny;
    c = b + an / c;
    if (std::abs(c) < tiny) c = tiny;
    d = 1.0 / d;
    const double delta = d * c;
    h *= delta;
    if (std::abs(delta - 1.0) < 1e-16) break;
  }
  return std::exp(log_prefix) * h;
}

struct Chi2Result {
  double statistic = 0, p_value = 0;
  int dof = 0;
  double unexpected = 0;  // samples that fell in cells of expected count 0 (must be none)
};

inline Chi2Result chi2_test(const std::vector<double>& observed, const std::vector<double>& expected) {
  Chi2Result r;
  std::vector<size_t> order(observed.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return expected[a] < expected[b]; });
  double pooled_obs = 0, pooled_exp = 0;
  int cells = 0;
  for (size_t k : order) {
    if (expected[k] == 0.0) {
      r.unexpected += observed[k];
      continue;
    }
    if (expected[k] < 5.0) {
      pooled_obs += observed[k];
      pooled_exp += expected[k];
      continue;
    }
    r.statistic += (observed[k] - expected[k]) * (observed[k] - expected[k]) / expected[k];
    ++cells;
  }
  if (pooled_exp > 0) {
    r.statistic += (pooled_obs - pooled_exp) * (pooled_obs - pooled_exp) / pooled_exp;
    ++cells;
  }
  r.dof = cells - 1;
  r.p_value = r.dof > 0 ? gamma_q(0.5 * r.dof, 0.5 * r.statistic) : 1.0;
  return r;
}

}  // namespace pt::test
