// Gauss–Legendre quadrature on [0, 1]: nodes x and weights w with Σ w_i f(x_i) ≈ ∫₀¹ f, exact for polynomials
// of degree < 2n. Nodes by Newton iteration on the Legendre polynomial P_n (Numerical Recipes §4.6).
#pragma once
#include <cmath>
#include <numbers>
#include <vector>

namespace pt {

struct GaussLegendreRule {
  std::vector<double> x, w;
};

inline GaussLegendreRule gauss_legendre(int n) {
  GaussLegendreRule r;
  for (int i = 0; i < n; ++i) {
    double x = std::cos(std::numbers::pi * (i + 0.75) / (n + 0.5)), dp = 1.0;
    for (int iter = 0; iter < 100; ++iter) {
      double p0 = 1.0, p1 = x;
      for (int k = 2; k <= n; ++k) {
        const double p2 = ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k;
        p0 = p1;
        p1 = p2;
      }
      dp = n * (x * p1 - p0) / (x * x - 1.0);
      const double dx = p1 / dp;
      x -= dx;
      if (std::abs(dx) < 1e-15) break;
    }
    r.x.push_back(0.5 * (1.0 - x));
    r.w.push_back(1.0 / ((1.0 - x * x) * dp * dp));  // 2/((1 − x²) P_n'²) halved for [0, 1]
  }
  return r;
}

}  // namespace pt
