// The edge-avoiding à-trous filter of denoiser.h.
//
// Level i (step s = 2^i) replaces each pixel's illumination by a weighted mean over the 5×5 taps q = p + s·(dx, dy),
// dx, dy ∈ {−2, …, 2} (Dammertz et al. 2010, eq. 2–3):
//   w(p, q) = h(dx)·h(dy) · w_l · w_z · w_n · w_a,  h = (1, 4, 6, 4, 1)/16 (the B3 spline)
//   w_l = exp(−|l_p − l_q| / (σ_l·√(σ̂²_p + σ̂²_q) + ε)) luminance, σ̂² the 3×3-blurred variance of l (SVGF,
//                                                         Schied et al. 2017, eq. 3–5, made symmetric: below)
//   w_z = exp(−|z_p − z_q| / (σ_z·|∇z_p·(q − p)| + ε_z)) depth, with the local depth gradient (SVGF eq. 4)
//   w_n = max(0, n_p·n_q)^128                            normals (SVGF eq. 5, σ_n = 128: seven squarings)
//   w_a = exp(−‖a_p − a_q‖² / σ_a²)                     denoising albedo
// SVGF scales the luminance difference by p's deviation alone. Then a bright outlier (large variance) accepts its
// dark neighbours while they refuse it, and its energy disappears: 3.7 % of cornell-spheres' mean at 16 spp (its
// caustic), 1.5 % of materials'. With both pixels' variances the pair judges itself alike (w_l is symmetric),
// and the means stay within 1 % (docs/denoising.md).
// The variance of the result is propagated as Var = Σ w² Var_q / (Σ w)² (SVGF eq. 6), so the next level's
// luminance weight knows how much noise is left. The five weights are one exponential of a sum.
//
// Data layout: one plane per channel, each row padded on both sides by the widest tap offset (pads have
// valid = 0, so they weigh nothing and every load is in bounds). A row is processed in chunks of SIMD lanes: a
// chunk's own guides and its seven sums stay in registers while its 25 taps stream past.
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

// Row-padded planes: pixel (x, y) at y·stride + pad + x.
struct Layout {
  int w, h, pad;
  size_t stride;
  size_t at(int x, int y) const { return static_cast<size_t>(y) * stride + static_cast<size_t>(pad + x); }
  size_t size() const { return stride * static_cast<size_t>(h); }
};

struct Planes {
  // Guides (fixed over the levels) and the illumination with its variance (per level).
  std::vector<float> n0, n1, n2, a0, a1, a2, z, gx, gy, valid, e0, e1, e2, v0, v1, v2, luma, var_l;
};

void check_input(const DenoiseInput& in) {
  const size_t n = static_cast<size_t>(in.width) * static_cast<size_t>(in.height);
  if (in.width <= 0 || in.height <= 0) throw std::invalid_argument("denoise: empty image");
  for (const auto* p : {in.color, in.variance, in.albedo, in.normal})
    if (!p || p->size() != 3 * n) throw std::invalid_argument("denoise: a 3-channel input is missing or mis-sized");
  if (!in.depth || in.depth->size() != n) throw std::invalid_argument("denoise: depth is missing or mis-sized");
  if (in.emission && in.emission->size() != 3 * n) throw std::invalid_argument("denoise: emission is mis-sized");
}

// One chunk of V::size() pixels starting at padded index p, all 25 taps of level `step`; writes the filtered
// illumination and variance of the lanes inside the image (lane_ok) to the output planes.
// GCC 12's AVX-512 square root (avx512fintrin.h) passes an uninitialised vector as the masked-off source and
// warns about it from inside the header; the lanes are all active here.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
template <class V>
void filter_chunk(const Planes& in, Planes& out, const Layout& L, int x, int y, int step, float inv_sigma_a2,
                  float sigma_depth, float sigma_l) {
  using stdx::abs, stdx::max, std::abs, std::max;
  const size_t p = L.at(x, y);
  auto ld = [](const std::vector<float>& plane, size_t i) { return V(plane.data() + i, stdx::element_aligned); };
  const V lp = ld(in.luma, p), vp = ld(in.var_l, p), zp = ld(in.z, p), gxp = ld(in.gx, p), gyp = ld(in.gy, p);
  const V a0 = ld(in.a0, p), a1 = ld(in.a1, p), a2 = ld(in.a2, p);
  const V p0 = ld(in.n0, p), p1 = ld(in.n1, p), p2 = ld(in.n2, p);
  const V p_empty = p0 * p0 + p1 * p1 + p2 * p2;
  const V z_eps = 1e-3f * zp + 1e-8f;
  V s0(0.f), s1(0.f), s2(0.f), t0(0.f), t1(0.f), t2(0.f), sw(0.f);
  for (int dy = -2; dy <= 2; ++dy) {
    const int qy = y + dy * step;
    if (qy < 0 || qy >= L.h) continue;
    const V zy = sigma_depth * static_cast<float>(std::abs(dy * step)) * gyp;
    for (int dx = -2; dx <= 2; ++dx) {
      const int off = dx * step;
      const size_t q = L.at(x + off, qy);
      const V dl = abs(lp - ld(in.luma, q)) / (sigma_l * stdx::sqrt(vp + ld(in.var_l, q)) + 1e-6f);
      const V dz = abs(zp - ld(in.z, q)) / (sigma_depth * static_cast<float>(std::abs(off)) * gxp + zy + z_eps);
      const V da0 = a0 - ld(in.a0, q), da1 = a1 - ld(in.a1, q), da2 = a2 - ld(in.a2, q);
      const V da = (da0 * da0 + da1 * da1 + da2 * da2) * inv_sigma_a2;
      const V q0 = ld(in.n0, q), q1 = ld(in.n1, q), q2 = ld(in.n2, q);
      V wn = max(V(0.f), p0 * q0 + p1 * q1 + p2 * q2);
      wn *= wn, wn *= wn, wn *= wn, wn *= wn, wn *= wn, wn *= wn, wn *= wn;  // σ_n = 128 = 2^7
      // Both without a surface (escaped rays): alike.
      where(p_empty + q0 * q0 + q1 * q1 + q2 * q2 < 0.5f, wn) = V(1.f);
      const V wt = (kB3[dx + 2] * kB3[dy + 2]) * ld(in.valid, q) * wn * exp_neg(dl + dz + da);
      const V wt2 = wt * wt;
      s0 += wt * ld(in.e0, q), s1 += wt * ld(in.e1, q), s2 += wt * ld(in.e2, q);
      t0 += wt2 * ld(in.v0, q), t1 += wt2 * ld(in.v1, q), t2 += wt2 * ld(in.v2, q);
      sw += wt;
    }
  }
  // The centre tap always has weight 9/64 · w_n(p, p) = 9/64 inside the image, so the sum is positive there.
  V lane_x([x](int i) { return static_cast<float>(x + i); });
  const auto inside = lane_x < static_cast<float>(L.w);
  const V inv = 1.f / sw;
  auto store = [&](std::vector<float>& plane, V value) { where(inside, value).copy_to(plane.data() + p, stdx::element_aligned); };
  store(out.e0, s0 * inv), store(out.e1, s1 * inv), store(out.e2, s2 * inv);
  store(out.v0, t0 * inv * inv), store(out.v1, t1 * inv * inv), store(out.v2, t2 * inv * inv);
}
#pragma GCC diagnostic pop

}  // namespace

std::vector<float> denoise(const DenoiseInput& in, const DenoiseSettings& st, ThreadPool& pool) {
  check_input(in);
  using Wide = stdx::native_simd<float>;
  constexpr int kWide = static_cast<int>(Wide::size());
  const int w = in.width, h = in.height;
  // Padding: the widest tap offset, 2·2^(levels−1), plus a chunk's overhang past the right edge.
  const int reach = st.iterations > 0 ? 2 << (st.iterations - 1) : 0;
  Layout L{w, h, reach, static_cast<size_t>(w + 2 * reach + kWide)};
  Planes a, b;
  for (std::vector<float>* plane : {&a.n0, &a.n1, &a.n2, &a.a0, &a.a1, &a.a2, &a.z, &a.gx, &a.gy, &a.valid, &a.e0,
                                    &a.e1, &a.e2, &a.v0, &a.v1, &a.v2, &a.luma, &a.var_l})
    plane->assign(L.size(), 0.f);
  std::vector<float> modulation(3 * static_cast<size_t>(w) * h);

  // Demodulate and arrange the guides.
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const size_t i = static_cast<size_t>(y) * w + x, j = L.at(x, y);
      const float* nrm = &(*in.normal)[3 * i];
      const float len2 = nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2];
      const float inv = len2 > 1e-12f ? 1.f / std::sqrt(len2) : 0.f;  // averaged normals are shorter than 1
      a.n0[j] = nrm[0] * inv, a.n1[j] = nrm[1] * inv, a.n2[j] = nrm[2] * inv;
      a.z[j] = (*in.depth)[i];
      a.valid[j] = 1.f;
      std::vector<float>* albedo[3] = {&a.a0, &a.a1, &a.a2};
      std::vector<float>* illum[3] = {&a.e0, &a.e1, &a.e2};
      std::vector<float>* var[3] = {&a.v0, &a.v1, &a.v2};
      for (int c = 0; c < 3; ++c) {
        const float alb = (*in.albedo)[3 * i + c];
        (*albedo[c])[j] = alb;
        const float m = alb >= kMinDemodulateAlbedo ? alb : 1.f;
        modulation[3 * i + c] = m;
        const float emitted = in.emission ? (*in.emission)[3 * i + c] : 0.f;
        (*illum[c])[j] = ((*in.color)[3 * i + c] - emitted) / m;
        const float vv = (*in.variance)[3 * i + c] / (m * m);
        (*var[c])[j] = std::isfinite(vv) ? vv : 0.f;  // fewer than 2 samples: no estimate, no filtering by it
      }
    }
  // Depth gradient: the smaller one-sided difference, so that a silhouette does not look like a steep slope.
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const size_t j = L.at(x, y);
      const float z = a.z[j];
      float gx = 1e30f, gy = 1e30f;
      if (x > 0) gx = std::min(gx, std::abs(z - a.z[j - 1]));
      if (x + 1 < w) gx = std::min(gx, std::abs(a.z[j + 1] - z));
      if (y > 0) gy = std::min(gy, std::abs(z - a.z[j - L.stride]));
      if (y + 1 < h) gy = std::min(gy, std::abs(a.z[j + L.stride] - z));
      a.gx[j] = gx < 1e30f ? gx : 0.f;
      a.gy[j] = gy < 1e30f ? gy : 0.f;
    }
  b = a;  // the guides, and output planes of the right size

  std::vector<float> sd_raw(L.size(), 0.f);
  const float inv_sigma_a2 = 1.f / (st.sigma_albedo * st.sigma_albedo);
  const int rows_per_task = 8;
  const int tasks = (h + rows_per_task - 1) / rows_per_task;
  Planes* cur = &a;
  Planes* next = &b;
  for (int level = 0; level < st.iterations; ++level) {
    const int step = 1 << level;
    Planes& c = *cur;
    // Luminance and its standard deviation (channels of one path are correlated: the deviations add), then the
    // 3×3 binomial blur of the variance that makes σ̂_l usable at a few samples per pixel.
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const size_t j = L.at(x, y);
        c.luma[j] = kLuma[0] * c.e0[j] + kLuma[1] * c.e1[j] + kLuma[2] * c.e2[j];
        sd_raw[j] = kLuma[0] * std::sqrt(c.v0[j]) + kLuma[1] * std::sqrt(c.v1[j]) + kLuma[2] * std::sqrt(c.v2[j]);
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
              const float sd = sd_raw[L.at(qx, qy)];
              sum += k * sd * sd;
              wsum += k;
            }
          c.var_l[L.at(x, y)] = sum / wsum;
        }
    });
    pool.parallel_for(tasks, [&](int task, int) {
      const int y_end = std::min(h, (task + 1) * rows_per_task);
      for (int y = task * rows_per_task; y < y_end; ++y)
        for (int x = 0; x < w; x += kWide) filter_chunk<Wide>(c, *next, L, x, y, step, inv_sigma_a2, st.sigma_depth, st.sigma_luminance);
    });
    std::swap(cur, next);
  }

  std::vector<float> out(3 * static_cast<size_t>(w) * h);
  const Planes& r = *cur;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const size_t i = static_cast<size_t>(y) * w + x, j = L.at(x, y);
      const float e[3] = {r.e0[j], r.e1[j], r.e2[j]};
      for (int c = 0; c < 3; ++c)
        out[3 * i + c] = e[c] * modulation[3 * i + c] + (in.emission ? (*in.emission)[3 * i + c] : 0.f);
    }
  return out;
}

}  // namespace pt
