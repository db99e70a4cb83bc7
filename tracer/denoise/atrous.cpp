// The edge-avoiding à-trous filter of denoiser.h.
//
// Level i (step s = 2^i) replaces each pixel's illumination by a weighted mean over the 5×5 taps q = p + s·(dx, dy),
// dx, dy ∈ {−2, …, 2} (Dammertz et al. 2010, eq. 2–3):
//   w(p, q) = h(dx)·h(dy) · w_l · w_z · w_n · w_a,  h = (1, 4, 6, 4, 1)/16 (the B3 spline)
//   w_l = exp(−|l_p − l_q| / (σ_l·σ̂_l(p) + ε))        luminance, σ̂_l the 3×3-blurred standard deviation of
//                                                         l_p (SVGF, Schied et al. 2017, eq. 3–5)
//   w_z = exp(−|z_p − z_q| / (σ_z·|∇z_p·(q − p)| + ε_z)) depth, with the local depth gradient (SVGF eq. 4)
//   w_n = max(0, n_p·n_q)^128                            normals (SVGF eq. 5, σ_n = 128: seven squarings)
//   w_a = exp(−‖a_p − a_q‖² / σ_a²)                     denoising albedo
// and the variance of the result is propagated as Var = Σ w² Var_q / (Σ w)² (SVGF eq. 6), so the next level's
// luminance weight knows how much noise is left. The five weights are one exponential of a sum.
//
// Data layout: one plane per channel, and the taps in the outer loop: for a fixed tap the loop over a row's
// pixels is straight-line float arithmetic the compiler vectorises (the exponential is a polynomial, below).
#include "denoise/denoiser.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <experimental/simd>
#include <stdexcept>

namespace pt {

namespace {

namespace stdx = std::experimental;

// exp(−x) for x ≥ 0, to ~1e-3 relative error (weights need no more), in plain arithmetic so that it runs on SIMD
// lanes as on scalars: exp(−x) = exp(−x/64)^64 with x clamped to 40 (e^−40 ≈ 4e−18 is as good as 0), a degree-5
// Taylor polynomial for exp(−y) on y ∈ [0, 0.625] (error ≤ y⁶/720 ≈ 1e-4 there) and six squarings.
template <class V>
inline V exp_neg(V x) {
  using std::min;
  using stdx::min;
  const V y = min(x, V(40.f)) * (1.f / 64.f);
  V r = 1.f - y * (1.f - y * (0.5f - y * (1.f / 6.f - y * (1.f / 24.f - y * (1.f / 120.f)))));
  r *= r, r *= r, r *= r, r *= r, r *= r, r *= r;
  return r;
}

constexpr float kB3[5] = {1.f / 16, 1.f / 4, 3.f / 8, 1.f / 4, 1.f / 16};
constexpr float kLuma[3] = {0.2126f, 0.7152f, 0.0722f};
// An albedo below this is treated as 1 when dividing it out: black and absent surfaces (escaped rays) have no
// texture to protect, and dividing by ~0 would amplify their noise.
constexpr float kMinDemodulateAlbedo = 1e-2f;

struct Plane3 {
  std::vector<float> c[3];
  void resize(size_t n) {
    for (auto& p : c) p.assign(n, 0.f);
  }
};

// What stays fixed across levels: the guides, pre-arranged as planes.
struct Guides {
  Plane3 normal, albedo, modulation;
  std::vector<float> depth, grad_x, grad_y;
};

void check_input(const DenoiseInput& in) {
  const size_t n = static_cast<size_t>(in.width) * static_cast<size_t>(in.height);
  if (in.width <= 0 || in.height <= 0) throw std::invalid_argument("denoise: empty image");
  for (const auto* p : {in.color, in.variance, in.albedo, in.normal})
    if (!p || p->size() != 3 * n) throw std::invalid_argument("denoise: a 3-channel input is missing or mis-sized");
  if (!in.depth || in.depth->size() != n) throw std::invalid_argument("denoise: depth is missing or mis-sized");
  if (in.emission && in.emission->size() != 3 * n) throw std::invalid_argument("denoise: emission is mis-sized");
}

// One tap (dx, dy) for a run of n pixels of a row: pixel p + k meets neighbour q + k. Straight-line float code
// over restrict pointers, so the loop vectorises.
struct TapRow {
  float kernel, zx, zy, inv_sigma_a2;
};

[[gnu::noinline]] void accumulate_tap_row(const TapRow& t, const Guides& g, const Plane3& e, const Plane3& v, const float* luma,
                        const float* inv_sd, size_t p, size_t q, int n, float* acc, size_t stride) {
  const float* __restrict lp = luma + p;
  const float* __restrict lq = luma + q;
  const float* __restrict sp = inv_sd + p;
  const float* __restrict zp = g.depth.data() + p;
  const float* __restrict zq = g.depth.data() + q;
  const float* __restrict gx = g.grad_x.data() + p;
  const float* __restrict gy = g.grad_y.data() + p;
  const float* __restrict a0p = g.albedo.c[0].data() + p;
  const float* __restrict a1p = g.albedo.c[1].data() + p;
  const float* __restrict a2p = g.albedo.c[2].data() + p;
  const float* __restrict a0q = g.albedo.c[0].data() + q;
  const float* __restrict a1q = g.albedo.c[1].data() + q;
  const float* __restrict a2q = g.albedo.c[2].data() + q;
  const float* __restrict n0p = g.normal.c[0].data() + p;
  const float* __restrict n1p = g.normal.c[1].data() + p;
  const float* __restrict n2p = g.normal.c[2].data() + p;
  const float* __restrict n0q = g.normal.c[0].data() + q;
  const float* __restrict n1q = g.normal.c[1].data() + q;
  const float* __restrict n2q = g.normal.c[2].data() + q;
  const float* __restrict e0 = e.c[0].data() + q;
  const float* __restrict e1 = e.c[1].data() + q;
  const float* __restrict e2 = e.c[2].data() + q;
  const float* __restrict v0 = v.c[0].data() + q;
  const float* __restrict v1 = v.c[1].data() + q;
  const float* __restrict v2 = v.c[2].data() + q;
  float* __restrict ae0 = acc;
  float* __restrict ae1 = acc + stride;
  float* __restrict ae2 = acc + 2 * stride;
  float* __restrict av0 = acc + 3 * stride;
  float* __restrict av1 = acc + 4 * stride;
  float* __restrict av2 = acc + 5 * stride;
  float* __restrict aw = acc + 6 * stride;
  const float kernel = t.kernel, zx = t.zx, zy = t.zy, inv_sigma_a2 = t.inv_sigma_a2;
  // The same body on native SIMD lanes, then on one lane for the tail.
  auto body = [&]<class V>(int k, V) {
    using stdx::abs, stdx::max, std::abs, std::max;
    auto ld = [k](const float* ptr) { return V(ptr + k, stdx::element_aligned); };
    auto acc_add = [k](float* ptr, V x) { (V(ptr + k, stdx::element_aligned) + x).copy_to(ptr + k, stdx::element_aligned); };
    const V dl = abs(ld(lp) - ld(lq)) * ld(sp);
    const V z = ld(zp);
    const V dz = abs(z - ld(zq)) / (zx * ld(gx) + zy * ld(gy) + 1e-3f * z + 1e-8f);
    const V da0 = ld(a0p) - ld(a0q), da1 = ld(a1p) - ld(a1q), da2 = ld(a2p) - ld(a2q);
    const V da = (da0 * da0 + da1 * da1 + da2 * da2) * inv_sigma_a2;
    const V p0 = ld(n0p), p1 = ld(n1p), p2 = ld(n2p), q0 = ld(n0q), q1 = ld(n1q), q2 = ld(n2q);
    V wn = max(V(0.f), p0 * q0 + p1 * q1 + p2 * q2);
    wn *= wn, wn *= wn, wn *= wn, wn *= wn, wn *= wn, wn *= wn, wn *= wn;  // σ_n = 128 = 2^7
    // Both without a surface (escaped rays): alike.
    const V both_empty = p0 * p0 + p1 * p1 + p2 * p2 + q0 * q0 + q1 * q1 + q2 * q2;
    where(both_empty < 0.5f, wn) = V(1.f);
    const V wt = kernel * wn * exp_neg(dl + dz + da);
    acc_add(ae0, wt * ld(e0));
    acc_add(ae1, wt * ld(e1));
    acc_add(ae2, wt * ld(e2));
    const V wt2 = wt * wt;
    acc_add(av0, wt2 * ld(v0));
    acc_add(av1, wt2 * ld(v1));
    acc_add(av2, wt2 * ld(v2));
    acc_add(aw, wt);
  };
  using Wide = stdx::native_simd<float>;
  using One = stdx::simd<float, stdx::simd_abi::scalar>;
  constexpr int kWide = static_cast<int>(Wide::size());
  int k = 0;
  for (; k + kWide <= n; k += kWide) body(k, Wide());
  for (; k < n; ++k) body(k, One());
}

}  // namespace

std::vector<float> denoise(const DenoiseInput& in, const DenoiseSettings& st, ThreadPool& pool) {
  check_input(in);
  const int w = in.width, h = in.height;
  const size_t n = static_cast<size_t>(w) * h;

  // Demodulate and arrange the guides.
  Guides g;
  g.normal.resize(n);
  g.albedo.resize(n);
  g.modulation.resize(n);
  g.depth.assign(in.depth->begin(), in.depth->end());
  g.grad_x.assign(n, 0.f);
  g.grad_y.assign(n, 0.f);
  Plane3 e, v, e_next, v_next;
  e.resize(n), v.resize(n), e_next.resize(n), v_next.resize(n);
  for (size_t i = 0; i < n; ++i) {
    const float* nrm = &(*in.normal)[3 * i];
    const float len2 = nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2];
    const float inv = len2 > 1e-12f ? 1.f / std::sqrt(len2) : 0.f;  // averaged normals are shorter than 1
    for (int c = 0; c < 3; ++c) {
      g.normal.c[c][i] = nrm[c] * inv;
      const float a = (*in.albedo)[3 * i + c];
      g.albedo.c[c][i] = a;
      const float m = a >= kMinDemodulateAlbedo ? a : 1.f;
      g.modulation.c[c][i] = m;
      const float emitted = in.emission ? (*in.emission)[3 * i + c] : 0.f;
      e.c[c][i] = ((*in.color)[3 * i + c] - emitted) / m;
      v.c[c][i] = (*in.variance)[3 * i + c] / (m * m);
      if (!std::isfinite(v.c[c][i])) v.c[c][i] = 0.f;  // fewer than 2 samples: no estimate, no filtering by it
    }
  }
  // Depth gradient: the smaller one-sided difference, so that a silhouette does not look like a steep slope.
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const size_t i = static_cast<size_t>(y) * w + x;
      const float z = g.depth[i];
      float gx = 1e30f, gy = 1e30f;
      if (x > 0) gx = std::min(gx, std::abs(z - g.depth[i - 1]));
      if (x + 1 < w) gx = std::min(gx, std::abs(g.depth[i + 1] - z));
      if (y > 0) gy = std::min(gy, std::abs(z - g.depth[i - w]));
      if (y + 1 < h) gy = std::min(gy, std::abs(g.depth[i + w] - z));
      g.grad_x[i] = gx < 1e30f ? gx : 0.f;
      g.grad_y[i] = gy < 1e30f ? gy : 0.f;
    }

  std::vector<float> luma(n), inv_sd(n), sd_raw(n);
  const float inv_sigma_a2 = 1.f / (st.sigma_albedo * st.sigma_albedo);
  const int rows_per_task = 8;
  const int tasks = (h + rows_per_task - 1) / rows_per_task;
  for (int level = 0; level < st.iterations; ++level) {
    const int step = 1 << level;
    // Luminance and its standard deviation (channels of one path are correlated: the deviations add), then the
    // 3×3 binomial blur of the variance that makes σ̂_l usable at a few samples per pixel.
    for (size_t i = 0; i < n; ++i) {
      luma[i] = kLuma[0] * e.c[0][i] + kLuma[1] * e.c[1][i] + kLuma[2] * e.c[2][i];
      sd_raw[i] = kLuma[0] * std::sqrt(v.c[0][i]) + kLuma[1] * std::sqrt(v.c[1][i]) + kLuma[2] * std::sqrt(v.c[2][i]);
    }
    pool.parallel_for(tasks, [&](int task, int) {
      const int y_end = std::min(h, (task + 1) * rows_per_task);
      for (int y = task * rows_per_task; y < y_end; ++y)
        for (int x = 0; x < w; ++x) {
          float sum = 0.f, wsum = 0.f;
          for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx) {
              const int qx = x + dx, qy = y + dy;
              if (qx < 0 || qy < 0 || qx >= w || qy >= h) continue;
              const float k = (dx == 0 ? 0.5f : 0.25f) * (dy == 0 ? 0.5f : 0.25f);
              const float s = sd_raw[static_cast<size_t>(qy) * w + qx];
              sum += k * s * s;
              wsum += k;
            }
          inv_sd[static_cast<size_t>(y) * w + x] = 1.f / (st.sigma_luminance * std::sqrt(sum / wsum) + 1e-6f);
        }
    });

    pool.parallel_for(tasks, [&](int task, int) {
      std::vector<float> acc(7 * static_cast<size_t>(w));
      const int y_end = std::min(h, (task + 1) * rows_per_task);
      for (int y = task * rows_per_task; y < y_end; ++y) {
        std::fill(acc.begin(), acc.end(), 0.f);
        const size_t row = static_cast<size_t>(y) * w;
        for (int dy = -2; dy <= 2; ++dy) {
          const int qy = y + dy * step;
          if (qy < 0 || qy >= h) continue;
          for (int dx = -2; dx <= 2; ++dx) {
            const int off = dx * step;
            const int x_begin = std::max(0, -off), x_end = std::min(w, w - off);
            if (x_begin >= x_end) continue;
            TapRow t;
            t.kernel = kB3[dx + 2] * kB3[dy + 2];
            t.zx = st.sigma_depth * static_cast<float>(std::abs(off));
            t.zy = st.sigma_depth * static_cast<float>(std::abs(dy * step));
            t.inv_sigma_a2 = inv_sigma_a2;
            const size_t p = row + x_begin, q = static_cast<size_t>(qy) * w + static_cast<size_t>(x_begin + off);
            accumulate_tap_row(t, g, e, v, luma.data(), inv_sd.data(), p, q, x_end - x_begin, &acc[x_begin],
                               static_cast<size_t>(w));
          }
        }
        for (int x = 0; x < w; ++x) {
          // The centre tap always has weight ≥ 9/64 · w_n(p, p) = 9/64, so the sum is positive.
          const float inv = 1.f / acc[6 * static_cast<size_t>(w) + x];
          for (int c = 0; c < 3; ++c) {
            e_next.c[c][row + x] = acc[c * static_cast<size_t>(w) + x] * inv;
            v_next.c[c][row + x] = acc[(3 + c) * static_cast<size_t>(w) + x] * inv * inv;
          }
        }
      }
    });
    std::swap(e, e_next);
    std::swap(v, v_next);
  }

  std::vector<float> out(3 * n);
  for (size_t i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c)
      out[3 * i + c] = e.c[c][i] * g.modulation.c[c][i] + (in.emission ? (*in.emission)[3 * i + c] : 0.f);
  return out;
}

}  // namespace pt
