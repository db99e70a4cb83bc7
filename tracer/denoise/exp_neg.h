// exp(−x) for x ≥ 0 to ~1e-3 relative error, for filter weights, which need no more: plain arithmetic, so it
// runs on SIMD lanes (std::experimental::simd) as on scalars, and loops over arrays of it vectorise.
#pragma once
#include <algorithm>
#include <experimental/simd>

namespace pt {

// exp(−x) = exp(−x/64)^64 with x clamped to 40 (e^−40 ≈ 4e−18 is as good as 0), a degree-5 Taylor polynomial
// for exp(−y) on y ∈ [0, 0.625] (error ≤ y⁶/720 ≈ 1e-4 there) and six squarings.
template <class V>
inline V exp_neg(V x) {
  using std::min;
  using std::experimental::min;
  const V y = min(x, V(40.f)) * (1.f / 64.f);
  V r = 1.f - y * (1.f - y * (0.5f - y * (1.f / 6.f - y * (1.f / 24.f - y * (1.f / 120.f)))));
  r *= r, r *= r, r *= r, r *= r, r *= r, r *= r;
  return r;
}

}  // namespace pt
