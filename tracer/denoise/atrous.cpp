// The edge-avoiding à-trous filter of denoiser.h.
//
// Level i (step s = 2^i) replaces each pixel's illumination by a weighted mean over the 5×5 taps q = p + s·(dx, dy),
// dx, dy ∈ {−2, …, 2} (Dammertz et al. 2010, eq. 2–3):
//   w(p, q) = h(dx)·h(dy) · w_l · w_z · w_n · w_a,  h = (1, 4, 6, 4, 1)/16 (the B3 spline)
//   w_l = exp(−|l_p − l_q| / (σ_l·σ̂_l(p) + ε))        luminance, σ̂_l the 3×3-blurred standard deviation of
//                                                         l_p (SVGF, Schied et al. 2017, eq. 3–5)
//   w_z = exp(−|z_p − z_q| / (σ_z·|∇z_p·(q − p)| + ε_z)) depth, with the local depth gradient (SVGF eq. 4)
//   w_n = max(0, n_p·n_q)^σ_n                            normals (SVGF eq. 5)
//   w_a = exp(−‖a_p − a_q‖² / σ_a²)                     denoising albedo
// and the variance of the result is propagated as Var = Σ w² Var_q / (Σ w)² (SVGF eq. 6), so the next level's
// luminance weight knows how much noise is left. The five weights are one exponential of a sum.
//
// Data layout: one plane per channel, and the taps in the outer loop: for a fixed tap the loop over a row's
// pixels is straight-line float arithmetic the compiler vectorises (the exponential is a polynomial, below).
#include "denoise/denoiser.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <stdexcept>

namespace pt {

namespace {

// exp(−x) for x ≥ 0 to ~2e-4 relative error: 2^t = 2^⌊t⌋·2^f with a degree-4 polynomial for 2^f on [0, 1)
// (a least-squares fit; weights need no more). Clamped below 2^−126.
inline float exp_neg(float x) {
  const float t = std::max(-x * 1.44269504f, -126.f);
  const float fl = std::floor(t);
  const float f = t - fl;
  const float p = 1.f + f * (0.69314718f + f * (0.24022652f + f * (0.05550411f + f * 0.00961813f)));
  const int32_t e = static_cast<int32_t>(fl) + 127;
  return p * std::bit_cast<float>(e << 23);
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
        float* acc_e[3] = {&acc[0], &acc[w], &acc[2 * static_cast<size_t>(w)]};
        float* acc_v[3] = {&acc[3 * static_cast<size_t>(w)], &acc[4 * static_cast<size_t>(w)],
                           &acc[5 * static_cast<size_t>(w)]};
        float* acc_w = &acc[6 * static_cast<size_t>(w)];
        const size_t row = static_cast<size_t>(y) * w;
        for (int dy = -2; dy <= 2; ++dy) {
          const int qy = y + dy * step;
          if (qy < 0 || qy >= h) continue;
          for (int dx = -2; dx <= 2; ++dx) {
            const int off = dx * step;
            const int x_begin = std::max(0, -off), x_end = std::min(w, w - off);
            if (x_begin >= x_end) continue;
            const float kernel = kB3[dx + 2] * kB3[dy + 2];
            const float zx = st.sigma_depth * static_cast<float>(std::abs(off)),
                        zy = st.sigma_depth * static_cast<float>(std::abs(dy * step));
            const size_t qrow = static_cast<size_t>(qy) * w + static_cast<size_t>(off);
            for (int x = x_begin; x < x_end; ++x) {
              const size_t p = row + x, q = qrow + x;
              const float dl = std::abs(luma[p] - luma[q]) * inv_sd[p];
              const float zp = g.depth[p];
              const float dz = std::abs(zp - g.depth[q]) / (zx * g.grad_x[p] + zy * g.grad_y[p] + 1e-3f * zp + 1e-8f);
              const float da0 = g.albedo.c[0][p] - g.albedo.c[0][q], da1 = g.albedo.c[1][p] - g.albedo.c[1][q],
                          da2 = g.albedo.c[2][p] - g.albedo.c[2][q];
              const float da = (da0 * da0 + da1 * da1 + da2 * da2) * inv_sigma_a2;
              const float np0 = g.normal.c[0][p], np1 = g.normal.c[1][p], np2 = g.normal.c[2][p];
              const float nq0 = g.normal.c[0][q], nq1 = g.normal.c[1][q], nq2 = g.normal.c[2][q];
              float wn = std::max(0.f, np0 * nq0 + np1 * nq1 + np2 * nq2);
              // σ_n = 128 = 2^7 by default: repeated squaring; other exponents through pow.
              if (st.sigma_normal == 128.f) {
                for (int k = 0; k < 7; ++k) wn *= wn;
              } else {
                wn = std::pow(wn, st.sigma_normal);
              }
              // Both without a surface (escaped rays): alike.
              const bool no_p = np0 * np0 + np1 * np1 + np2 * np2 < 0.25f;
              const bool no_q = nq0 * nq0 + nq1 * nq1 + nq2 * nq2 < 0.25f;
              wn = no_p && no_q ? 1.f : wn;
              const float wt = kernel * wn * exp_neg(dl + dz + da);
              for (int c = 0; c < 3; ++c) {
                acc_e[c][x] += wt * e.c[c][q];
                acc_v[c][x] += wt * wt * v.c[c][q];
              }
              acc_w[x] += wt;
            }
          }
        }
        for (int x = 0; x < w; ++x) {
          // The centre tap always has weight ≥ 9/64 · w_n(p, p) = 9/64, so the sum is positive.
          const float inv = 1.f / acc_w[x];
          for (int c = 0; c < 3; ++c) {
            e_next.c[c][row + x] = acc_e[c][x] * inv;
            v_next.c[c][row + x] = acc_v[c][x] * inv * inv;
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
