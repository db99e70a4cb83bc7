// Piecewise-constant 1D and 2D distributions over [0,1) and [0,1)² (pbrt-v4, Pharr, Jakob & Humphreys,
// "Physically Based Rendering" 4th ed., §A.4.1 PiecewiseConstant1D and §A.5.2 PiecewiseConstant2D).
//
// A distribution is built from n non-negative weights w[i], one per equal-width cell [i/n, (i+1)/n). Its density
// with respect to the unit interval is f(x) = w[i]/I with I = (1/n)·Σ w (the integral of the step function over
// [0,1)), so cells of weight 0 are never sampled. Weights that are negative or not finite are treated as 0.
// If every weight is 0 (I = 0) the distribution falls back to uniform: sampling still works and pdf ≡ 1.
// Sampling inverts the cumulative distribution and never allocates. The cell is found from a guide table (the
// cutpoint method: Chen and Asau 1974; Devroye, "Non-Uniform Random Variate Generation", 1986, §III.2.4): n
// entries, entry k the cell holding k/n, from which a short walk finds the cell of u, about two steps on average
// whatever the weights, where a binary search takes log2 n unpredictable branches (an environment map's rows of
// 512 texels: 9, each a likely cache miss). The walk returns the cell the binary search would.
#pragma once
#include <algorithm>
#include <cmath>
#include <span>
#include <vector>

#include "core/math.h"

namespace pt {

class Distribution1D {
 public:
  Distribution1D() = default;
  explicit Distribution1D(std::span<const float> weights) : func_(weights.begin(), weights.end()) {
    const size_t n = func_.size();
    for (float& w : func_)
      if (!(w > 0.f) || !std::isfinite(w)) w = 0.f;
    cdf_.assign(n + 1, 0.f);
    // Accumulate in double: a row of a few thousand texels spanning many orders of magnitude keeps its tail.
    std::vector<double> acc(n + 1, 0.0);
    for (size_t i = 0; i < n; ++i) acc[i + 1] = acc[i] + func_[i];
    const double sum = n ? acc[n] : 0.0;
    integral_ = n ? static_cast<float>(sum / static_cast<double>(n)) : 0.f;
    if (!(sum > 0.0) || !(integral_ > 0.f)) {
      integral_ = 0.f;
      for (size_t i = 0; i <= n; ++i) cdf_[i] = n ? static_cast<float>(static_cast<double>(i) / n) : 0.f;
    } else {
      for (size_t i = 0; i <= n; ++i) cdf_[i] = static_cast<float>(acc[i] / sum);
    }
    if (n) cdf_[n] = 1.f;
    guide_.resize(n);
    for (size_t k = 0; k < n; ++k)
      guide_[k] = search_cell(static_cast<float>(static_cast<double>(k) / static_cast<double>(n)));
  }

  int size() const { return static_cast<int>(func_.size()); }
  // ∫₀¹ of the step function (mean weight); 0 when all weights are 0 (the uniform fallback).
  float integral() const { return integral_; }
  float weight(int i) const { return func_[static_cast<size_t>(i)]; }
  bool uniform_fallback() const { return integral_ == 0.f; }

  // Continuous sample x ∈ [0,1) for u ∈ [0,1); *pdf = f(x) w.r.t. the unit interval; *offset = the cell index.
  float sample_continuous(float u, float* pdf = nullptr, int* offset = nullptr) const {
    const int o = find_cell(u);
    const float c0 = cdf_[static_cast<size_t>(o)], c1 = cdf_[static_cast<size_t>(o) + 1];
    float du = u - c0;
    if (c1 - c0 > 0.f) du /= c1 - c0;
    du = std::clamp(du, 0.f, 1.f);
    const int n = size();
    float x = (static_cast<float>(o) + du) / static_cast<float>(n);
    x = std::min(x, kOneMinusEpsilon);
    if (pdf) *pdf = cell_pdf(o);
    if (offset) *offset = o;
    return x;
  }

  // Discrete sample: cell index with probability w[i]/Σw (pmf in *pmf); *u_remapped is u rescaled within the
  // cell's cdf interval back to [0,1), reusable as a fresh uniform number.
  int sample_discrete(float u, float* pmf = nullptr, float* u_remapped = nullptr) const {
    const int o = find_cell(u);
    const float c0 = cdf_[static_cast<size_t>(o)], c1 = cdf_[static_cast<size_t>(o) + 1];
    if (pmf) *pmf = c1 - c0;
    if (u_remapped) *u_remapped = c1 - c0 > 0.f ? std::min((u - c0) / (c1 - c0), kOneMinusEpsilon) : 0.f;
    return o;
  }

  // Density at x ∈ [0,1) w.r.t. the unit interval (x outside is clamped to the first/last cell).
  float pdf(float x) const { return cell_pdf(cell_of(x, size())); }
  // Density on cell i (w[i]/I, or 1 in the uniform fallback).
  float cell_pdf(int i) const { return integral_ > 0.f ? func_[static_cast<size_t>(i)] / integral_ : 1.f; }

  // The cell sampling picks for u by binary search: the largest i in [0, n−1] with cdf[i] <= u. Cells of zero
  // weight have zero cdf width and are never returned for u ∈ [0,1) unless the whole distribution is the uniform
  // fallback. Sampling finds it through the guide table (find_cell); the tests hold that to this.
  int search_cell(float u) const {
    const auto it = std::upper_bound(cdf_.begin(), cdf_.end(), u);
    const int i = static_cast<int>(it - cdf_.begin()) - 1;
    return std::clamp(i, 0, size() - 1);
  }

  // Cell of x ∈ [0,1) among n equal cells, clamped to [0, n−1]; NaN maps to 0.
  static int cell_of(float x, int n) {
    const float f = x * static_cast<float>(n);
    if (!(f >= 0.f)) return 0;
    return f < static_cast<float>(n) ? std::min(static_cast<int>(f), n - 1) : n - 1;
  }

 private:
  // The same cell from the guide table: start at the cell holding the lower end of u's guide interval, step back
  // while that start is past u (u·n may round up into the next interval), then forward to the last cell whose cdf
  // is ≤ u (the cdf is non-decreasing, so this is search_cell's answer). u outside [0, 1) or NaN: the search.
  int find_cell(float u) const {
    const int n = size();
    if (!(u >= 0.f) || !(u < 1.f) || n == 0) return search_cell(u);
    int i = guide_[static_cast<size_t>(std::min(static_cast<int>(u * static_cast<float>(n)), n - 1))];
    while (i > 0 && cdf_[static_cast<size_t>(i)] > u) --i;
    while (i + 1 < n && cdf_[static_cast<size_t>(i) + 1] <= u) ++i;
    return i;
  }

  std::vector<float> func_, cdf_;
  std::vector<int> guide_;  // guide_[k] = search_cell(k/n)
  float integral_ = 0.f;
};

// Over [0,1)²: weights w[v·nu + u] row-major, nv rows (second coordinate) of nu cells (first coordinate).
// Sampling draws the row from the marginal (u.y), then the column from that row's conditional (u.x).
// Density w.r.t. the unit square: f(x, y) = w[cell]/I, I = mean weight; uniform (≡ 1) if every weight is 0.
class Distribution2D {
 public:
  Distribution2D() = default;
  Distribution2D(std::span<const float> weights, int nu, int nv) : nu_(nu), nv_(nv) {
    conditional_.reserve(static_cast<size_t>(nv));
    std::vector<float> row_integrals(static_cast<size_t>(nv));
    for (int v = 0; v < nv; ++v) {
      conditional_.emplace_back(weights.subspan(static_cast<size_t>(v) * nu, static_cast<size_t>(nu)));
      row_integrals[static_cast<size_t>(v)] = conditional_.back().integral();
    }
    marginal_ = Distribution1D(row_integrals);
  }

  int width() const { return nu_; }
  int height() const { return nv_; }
  float integral() const { return marginal_.integral(); }
  bool uniform_fallback() const { return marginal_.uniform_fallback(); }

  // Returns the point in [0,1)²; *pdf w.r.t. the unit square; *iu, *iv the cell.
  Vec2 sample_continuous(Vec2 u, float* pdf = nullptr, int* iu = nullptr, int* iv = nullptr) const {
    int v = 0, c = 0;
    const float y = marginal_.sample_continuous(u.y, nullptr, &v);
    const float x = conditional_[static_cast<size_t>(v)].sample_continuous(u.x, nullptr, &c);
    if (pdf) *pdf = cell_pdf(c, v);
    if (iu) *iu = c;
    if (iv) *iv = v;
    return {x, y};
  }

  float pdf(Vec2 p) const { return cell_pdf(Distribution1D::cell_of(p.x, nu_), Distribution1D::cell_of(p.y, nv_)); }
  // w[iv][iu]/I, computed from the weight itself (not conditional × marginal) so that a zero cell has density 0
  // even in a row whose conditional fell back to uniform.
  float cell_pdf(int iu, int iv) const {
    const float total = marginal_.integral();
    return total > 0.f ? conditional_[static_cast<size_t>(iv)].weight(iu) / total : 1.f;
  }

 private:
  int nu_ = 0, nv_ = 0;
  std::vector<Distribution1D> conditional_;
  Distribution1D marginal_;
};

}  // namespace pt
