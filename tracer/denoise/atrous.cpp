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
// The luminance variance of the result is propagated as Var = Σ w² Var_q / (Σ w)² (SVGF eq. 6), so the next
// level's luminance weight knows how much noise is left. The weights but w_n are one exponential of a sum.
//
// Data layout: one plane per channel, each row padded on both sides by the widest tap offset (pads have depth
// kPadDepth and no normal, so they weigh nothing (≤ e^−40), and every load is in bounds). A row is processed in
// chunks of SIMD lanes: a chunk's own guides and its five sums stay in registers while its 25 taps stream past
// (12 plane loads per tap).
#include "denoise/denoiser.h"
#include "denoise/fireflies.h"

#include "core/math.h"
#include "core/simd_sqrt_warnings.h"
#include "denoise/exp_neg.h"

#include <algorithm>
#include <cmath>
#include <experimental/simd>
#include <functional>
#if defined(__SSE__)
#include <xmmintrin.h>
#endif

namespace pt {

namespace {

namespace stdx = std::experimental;

constexpr float kB3[5] = {1.f / 16, 1.f / 4, 3.f / 8, 1.f / 4, 1.f / 16};
constexpr const float (&kLuma)[3] = kLuminanceWeights;  // Rec. 709 (core/math.h)

// Row-padded planes: pixel (x, y) at y·stride + pad + x.
struct Layout {
  int w, h, pad;
  size_t stride;
  size_t at(int x, int y) const { return static_cast<size_t>(y) * stride + static_cast<size_t>(pad + x); }
  size_t size() const { return stride * static_cast<size_t>(h); }
};

// The guides, fixed over the levels.
struct Guides {
  std::vector<float> n0, n1, n2, a0, a1, a2, z, gx, gy;
};
// The illumination, the variance of its luminance (propagated from level to level) and, per level, that
// variance blurred (the luminance weight's scale).
struct Illumination {
  std::vector<float> e0, e1, e2, vl, var_l;
};

// Raw pointers for the chunk loop: loads through them need no reload of a vector's data pointer per tap.
struct ChunkInput {
  const float *n0, *n1, *n2, *a0, *a1, *a2, *z, *gx, *gy, *e0, *e1, *e2, *vl, *var_l;
};
struct ChunkOutput {
  float *e0, *e1, *e2, *vl;
};
// Depth of the pads: any real depth differs from it by ~1e30 gradients, so a pad's weight is e^−40 at most.
constexpr float kPadDepth = 1e30f;

// Rejected taps have weights far below FLT_MIN (w_n = cos^128, w², products with small variances). Arithmetic on
// such subnormal numbers takes a slow microcode path on x86 (measured: the filter ran ~4× slower), and their
// contribution is nil: flush them to zero (MXCSR FTZ and DAZ) while a task runs, restoring the caller's mode.
struct FlushDenormals {
#if defined(__SSE__)
  unsigned saved = _mm_getcsr();
  FlushDenormals() { _mm_setcsr(saved | 0x8040u); }  // FTZ (bit 15) | DAZ (bit 6)
  ~FlushDenormals() { _mm_setcsr(saved); }
#endif
};

// One chunk of V::size() pixels starting at (x, y), all 25 taps of level `step`; writes the filtered
// illumination and variance of the lanes inside the image to the output planes.
PT_SIMD_SQRT_WARNINGS_OFF  // the lanes are all active here
template <class V>
void filter_chunk(const ChunkInput& c, const ChunkOutput& out, const Layout& L, int x, int y, int step,
                  float inv_sigma_a2, float sigma_depth, float sigma_l) {
  using stdx::abs, stdx::max, std::abs, std::max;
  const ChunkInput in = c;  // pointers in registers
  const size_t p = L.at(x, y);
  auto ld = [](const float* plane, size_t i) { return V(plane + i, stdx::element_aligned); };
  const V lp = kLuma[0] * ld(in.e0, p) + kLuma[1] * ld(in.e1, p) + kLuma[2] * ld(in.e2, p);
  const V vp = ld(in.var_l, p), zp = ld(in.z, p), gxp = ld(in.gx, p), gyp = ld(in.gy, p);
  const V a0 = ld(in.a0, p), a1 = ld(in.a1, p), a2 = ld(in.a2, p);
  const V p0 = ld(in.n0, p), p1 = ld(in.n1, p), p2 = ld(in.n2, p);
  const V p_empty = p0 * p0 + p1 * p1 + p2 * p2;
  const V z_eps = 1e-3f * zp + 1e-8f;
  V s0(0.f), s1(0.f), s2(0.f), tl(0.f), sw(0.f);
  for (int dy = -2; dy <= 2; ++dy) {
    const int qy = y + dy * step;
    if (qy < 0 || qy >= L.h) continue;
    const V zy = sigma_depth * static_cast<float>(std::abs(dy * step)) * gyp + z_eps;
    const size_t row = L.at(x, qy);
    for (int dx = -2; dx <= 2; ++dx) {
      const int off = dx * step;
      const size_t q = row + static_cast<size_t>(static_cast<ptrdiff_t>(off));
      const V e0 = ld(in.e0, q), e1 = ld(in.e1, q), e2 = ld(in.e2, q);
      const V lq = kLuma[0] * e0 + kLuma[1] * e1 + kLuma[2] * e2;
      const V dl = abs(lp - lq) / (sigma_l * stdx::sqrt(vp + ld(in.var_l, q)) + 1e-6f);
      const V dz = abs(zp - ld(in.z, q)) / ((sigma_depth * static_cast<float>(std::abs(off))) * gxp + zy);
      const V da0 = a0 - ld(in.a0, q), da1 = a1 - ld(in.a1, q), da2 = a2 - ld(in.a2, q);
      const V da = (da0 * da0 + da1 * da1 + da2 * da2) * inv_sigma_a2;
      const V q0 = ld(in.n0, q), q1 = ld(in.n1, q), q2 = ld(in.n2, q);
      V wn = max(V(0.f), p0 * q0 + p1 * q1 + p2 * q2);
      wn *= wn, wn *= wn, wn *= wn, wn *= wn, wn *= wn, wn *= wn, wn *= wn;  // σ_n = 128 = 2^7
      // Both without a surface (escaped rays): alike.
      where(p_empty + q0 * q0 + q1 * q1 + q2 * q2 < 0.5f, wn) = V(1.f);
      const V wt = (kB3[dx + 2] * kB3[dy + 2]) * wn * exp_neg(dl + dz + da);
      s0 += wt * e0, s1 += wt * e1, s2 += wt * e2;
      tl += wt * wt * ld(in.vl, q);
      sw += wt;
    }
  }
  // The centre tap always has weight 9/64 · w_n(p, p) = 9/64 inside the image, so the sum is positive there.
  V lane_x([x](int i) { return static_cast<float>(x + i); });
  const auto inside = lane_x < static_cast<float>(L.w);
  const V inv = 1.f / sw;
  auto store = [&](float* plane, V value) { where(inside, value).copy_to(plane + p, stdx::element_aligned); };
  store(out.e0, s0 * inv), store(out.e1, s1 * inv), store(out.e2, s2 * inv);
  store(out.vl, tl * inv * inv);
}
PT_SIMD_SQRT_WARNINGS_ON

}  // namespace

struct Denoiser::Scratch {
  Layout layout{0, 0, 0, 0};
  Guides g;
  Illumination a, b;
  std::vector<float> modulation;
  std::vector<float> radiance;  // the image less its emission layer and its fireflies' excess (fireflies.h)
};

Denoiser::Denoiser() : scratch_(std::make_unique<Scratch>()) {}
Denoiser::~Denoiser() = default;
Denoiser::Denoiser(Denoiser&&) noexcept = default;
Denoiser& Denoiser::operator=(Denoiser&&) noexcept = default;

std::vector<float> denoise(const DenoiseInput& in, const DenoiseSettings& st, ThreadPool& pool) {
  Denoiser d;
  std::vector<float> out;
  d.run(in, st, pool, out);
  return out;
}

bool Denoiser::run(const DenoiseInput& in, const DenoiseSettings& st, ThreadPool& pool, std::vector<float>& out,
                   const std::atomic<bool>* cancel) {
  check_denoise_input(in);
  using Wide = stdx::native_simd<float>;
  constexpr int kWide = static_cast<int>(Wide::size());
  const int w = in.width, h = in.height;
  // Padding: the widest tap offset, 2·2^(levels−1), plus a chunk's overhang past the right edge.
  const int reach = st.iterations > 0 ? 2 << (st.iterations - 1) : 0;
  const Layout L{w, h, reach, static_cast<size_t>(w + 2 * reach + kWide)};
  Scratch& sc = *scratch_;
  Guides& g = sc.g;
  Illumination &a = sc.a, &b = sc.b;
  // Only the interiors are written below, so the zero pads of planes of the same layout stay valid.
  if (sc.layout.w != L.w || sc.layout.h != L.h || sc.layout.pad != L.pad || sc.layout.stride != L.stride) {
    for (std::vector<float>* plane : {&g.n0, &g.n1, &g.n2, &g.a0, &g.a1, &g.a2, &g.gx, &g.gy, &a.e0, &a.e1, &a.e2,
                                      &a.vl, &a.var_l, &b.e0, &b.e1, &b.e2, &b.vl, &b.var_l})
      plane->assign(L.size(), 0.f);
    g.z.assign(L.size(), kPadDepth);
    sc.modulation.assign(3 * static_cast<size_t>(w) * h, 0.f);
    sc.layout = L;
  }
  std::vector<float>& modulation = sc.modulation;
  const int rows_per_task = 8;
  const int tasks = (h + rows_per_task - 1) / rows_per_task;
  const auto cancelled = [&] { return cancel && cancel->load(std::memory_order_relaxed); };
  // A pass over the rows; false when cancelled (before or during it: the remaining tasks return at once). The
  // last pass, which writes `out`, is not cancellable: `out` is written whole or not at all.
  auto for_rows = [&](const std::function<void(int y)>& row, bool cancellable = true) {
    if (cancellable && cancelled()) return false;
    pool.parallel_for(tasks, [&](int task, int) {
      if (cancellable && cancelled()) return;
      const FlushDenormals flush;
      const int y_end = std::min(h, (task + 1) * rows_per_task);
      for (int y = task * rows_per_task; y < y_end; ++y) row(y);
    });
    return !cancellable || !cancelled();
  };

  // The radiance to filter: less the emission layer and, with the firefly step, less the fireflies' excess, which
  // is added back spread out at the end.
  std::vector<float>& radiance = sc.radiance;
  radiance.resize(3 * static_cast<size_t>(w) * h);
  if (!for_rows([&](int y) {
        for (size_t i = 3 * static_cast<size_t>(y) * w; i < 3 * static_cast<size_t>(y + 1) * w; ++i)
          radiance[i] = (*in.color)[i] - (in.emission ? (*in.emission)[i] : 0.f);
      }))
    return false;
  const std::vector<float> excess = spread_fireflies(w, h, st.fireflies, radiance, *in.variance, pool);
  // Demodulate and arrange the guides.
  const bool arranged = for_rows([&](int y) {
    std::vector<float>* albedo[3] = {&g.a0, &g.a1, &g.a2};
    std::vector<float>* illum[3] = {&a.e0, &a.e1, &a.e2};
    for (int x = 0; x < w; ++x) {
      const size_t i = static_cast<size_t>(y) * w + x, j = L.at(x, y);
      const float* nrm = &(*in.normal)[3 * i];
      const float inv = inverse_normal_length(nrm);
      g.n0[j] = nrm[0] * inv, g.n1[j] = nrm[1] * inv, g.n2[j] = nrm[2] * inv;
      g.z[j] = (*in.depth)[i];
      float sd_l = 0.f;  // channels of one path are correlated: their deviations add
      for (int c = 0; c < 3; ++c) {
        const float alb = (*in.albedo)[3 * i + c];
        (*albedo[c])[j] = alb;
        const float m = demodulation(alb);
        modulation[3 * i + c] = m;
        (*illum[c])[j] = radiance[3 * i + c] / m;
        const float vv = (*in.variance)[3 * i + c] / (m * m);
        sd_l += kLuma[c] * (std::isfinite(vv) ? std::sqrt(vv) : 0.f);  // below 2 samples: no estimate, no filtering
      }
      a.vl[j] = sd_l * sd_l;
    }
  });
  if (!arranged) return false;
  // Depth gradient: the smaller one-sided difference, so that a silhouette does not look like a steep slope.
  const bool gradients = for_rows([&](int y) {
    for (int x = 0; x < w; ++x) {
      const size_t j = L.at(x, y);
      const float z = g.z[j];
      float gx = 1e30f, gy = 1e30f;
      if (x > 0) gx = std::min(gx, std::abs(z - g.z[j - 1]));
      if (x + 1 < w) gx = std::min(gx, std::abs(g.z[j + 1] - z));
      if (y > 0) gy = std::min(gy, std::abs(z - g.z[j - L.stride]));
      if (y + 1 < h) gy = std::min(gy, std::abs(g.z[j + L.stride] - z));
      g.gx[j] = gx < 1e30f ? gx : 0.f;
      g.gy[j] = gy < 1e30f ? gy : 0.f;
    }
  });
  if (!gradients) return false;

  const float inv_sigma_a2 = 1.f / (st.sigma_albedo * st.sigma_albedo);
  Illumination* cur = &a;
  Illumination* next = &b;
  for (int level = 0; level < st.iterations; ++level) {
    const int step = 1 << level;
    Illumination& c = *cur;
    // The 3×3 binomial blur of the luminance variance that makes σ̂_l usable at a few samples per pixel.
    const bool blurred = for_rows([&](int y) {
      for (int x = 0; x < w; ++x) {
        float sum = 0.f, wsum = 0.f;
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            const int qx = x + dx, qy = y + dy;
            if (qx < 0 || qy < 0 || qx >= w || qy >= h) continue;
            const float k = (dx == 0 ? 0.5f : 0.25f) * (dy == 0 ? 0.5f : 0.25f);
            sum += k * c.vl[L.at(qx, qy)];
            wsum += k;
          }
        c.var_l[L.at(x, y)] = sum / wsum;
      }
    });
    if (!blurred) return false;
    const ChunkInput ci{g.n0.data(), g.n1.data(), g.n2.data(), g.a0.data(), g.a1.data(),
                        g.a2.data(), g.z.data(),  g.gx.data(), g.gy.data(), c.e0.data(),
                        c.e1.data(), c.e2.data(), c.vl.data(), c.var_l.data()};
    const ChunkOutput co{next->e0.data(), next->e1.data(), next->e2.data(), next->vl.data()};
    const bool filtered = for_rows([&](int y) {
      for (int x = 0; x < w; x += kWide)
        filter_chunk<Wide>(ci, co, L, x, y, step, inv_sigma_a2, st.sigma_depth, st.sigma_luminance);
    });
    if (!filtered) return false;
    std::swap(cur, next);
  }

  if (cancelled()) return false;  // `out` untouched
  out.resize(3 * static_cast<size_t>(w) * h);
  const Illumination& r = *cur;
  for_rows(
      [&](int y) {
        for (int x = 0; x < w; ++x) {
          const size_t i = static_cast<size_t>(y) * w + x, j = L.at(x, y);
          const float e[3] = {r.e0[j], r.e1[j], r.e2[j]};
          for (int c = 0; c < 3; ++c)
            out[3 * i + c] = e[c] * modulation[3 * i + c] + (in.emission ? (*in.emission)[3 * i + c] : 0.f) +
                             (excess.empty() ? 0.f : excess[3 * i + c]);
        }
      },
      false);
  return true;
}

}  // namespace pt
