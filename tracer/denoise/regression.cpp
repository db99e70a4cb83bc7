// The final-frame filter of denoiser.h: a weighted first-order regression on the feature buffers.
//
// Each pixel p's radiance (minus the emission seen directly, which is added back unfiltered) is fitted over the
// (2R+1)² window around it by weighted least squares against the features, and the fit's value at p is the output
// (locally weighted regression as in Moon et al. 2014, "Adaptive Rendering Based on Weighted Local Regression";
// Bitterli et al. 2016, "Nonlinearly Weighted First-order Regression for Denoising Monte Carlo Renderings", §4):
//   minimise Σ_q w(p, q) ‖y_q − βᵀ x_q‖² + Σ_{k≥1} λ_k β_k² (Σ_q w),  output β₀,
//   x_q = (1, (q − p)/R, a_q − a_p, n_q − n_p)   (9 regressors: screen offset, albedo, normal; a first-order
//                                                  Taylor model)
// with the ridge λ_k = λ on the feature slopes (noisy features, e.g. seen through glossy surfaces, should not
// carry the fit) and 1e-4 on the offset slopes. (A relative-depth regressor was dropped: with the others it
// changed relMSE by < 0.1 % on cornell, cornell-spheres and materials and cost 15 % of the sums.)
// A first-order fit follows the radiance across texture and normal edges and along smooth gradients, where a
// weighted mean (the à-trous filter) averages across them; and the weighted residuals of a fit with an intercept
// sum to zero, so the window's energy stays where it was.
//
// The weights are non-local means on the colour, with the per-pixel variance of the mean (Rousselle, Knaus and
// Zwicker 2012, "Adaptive Rendering with Non-Local Means Filtering", eq. 6–7; the distance NFOR uses, §5.1):
//   d²_c(s, t) = ((u_s − u_t)² − (v_s + min(v_s, v_t))) / (ε + k²(v_s + v_t))  per channel,
//   D²(p, q) = mean over channels and over the (2P+1)² patch offsets s of d²_c(p + s, q + s),
//   w(p, q) = exp(−max(0, D²) − |n_q − n_p|²/σ_n² − |a_q − a_p|²/σ_a²)
// (the feature kernels are the cross-bilateral part of Moon et al. 2014's weights).
// Subtracting the variances makes the expected distance of two pixels of the same mean 0 whatever their noise.
//
// Layout: padded planes (no bounds checks); the image is cut into 16×16 tiles. Per tile, phase 1 computes the patch
// distance of every pixel to its neighbour at every window offset; phase 2 takes one row of 16 pixels through all
// offsets, adding each neighbour to the row's normal equations (45 + 27 sums per pixel, 4.6 KB: in L1), and solves
// the row's 9×9 systems side by side by Cholesky in double. Both phases work on 16-lane SIMD values
// (std::experimental::fixed_size_simd); the solver's loops over 16 pixels are plain arrays the compiler vectorises.
#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <experimental/simd>
#include <stdexcept>
#include <vector>

#include "denoise/denoiser.h"
#include "denoise/exp_neg.h"
#include "denoise/fireflies.h"
#include "denoise/two_scale.h"

namespace pt {

namespace {

namespace stdx = std::experimental;

constexpr int kTile = 16;
constexpr int kTilePixels = kTile * kTile;
constexpr int kDims = 9;                            // regressors
constexpr int kPairs = kDims * (kDims + 1) / 2;     // entries of the symmetric normal matrix
// Entry (a, b), a ≤ b, of the normal matrix's upper triangle stored row by row.
constexpr int pair_index(int a, int b) { return a * kDims - a * (a - 1) / 2 + (b - a); }
constexpr float kDistanceEpsilon = 1e-10f;          // ε of the distance: keeps noiseless pixels comparable
constexpr double kOffsetRidge = 1e-4;

// The inputs as planes, one float per pixel per channel, padded by pixels that repeat the nearest edge pixel, so a
// window or patch offset never needs a bounds check (a clamped coordinate reads the same value): `margin` = R + P
// on the left and top, margin + kTile − 1 at the bottom, where the last tiles reach past the image, and margin +
// 2·kTile − 1 on the right, where the patch distances are computed over whole blocks of 16 columns.
struct Planes {
  int w = 0, h = 0, margin = 0;
  int width_padded() const { return w + 2 * margin + 2 * kTile - 1; }
  int height_padded() const { return h + 2 * margin + kTile - 1; }
  size_t stride = 0;
  std::array<std::vector<float>, 3> color, variance;
  std::array<std::vector<float>, 6> feature;  // albedo r, g, b, normal x, y, z
  size_t at(int x, int y) const { return static_cast<size_t>(y + margin) * stride + static_cast<size_t>(x + margin); }
};

// The work of one tile. Phase 1 keeps, for every window offset, the patch distance of each of the tile's pixels to
// its neighbour at that offset (~300 KB for R = 8: written once, read once, in L2); phase 2 then takes the tile a
// row of 16 pixels at a time through every offset, so that row's normal equations (72 sums × 16 pixels, 4.6 KB)
// stay in L1 instead of streaming the whole tile's (74 KB) through L2 at every offset.
struct TileScratch {
  std::vector<float> distance, row_sum, patch_distance;
};

// A row of 16 pixels as a plain array (the solver's loops over it vectorise).
using Row = float[kTile];

float inverse_square(float sigma) { return sigma > 0.f ? 1.f / (sigma * sigma) : 0.f; }

constexpr float kOutside = 1e30f;  // patch distance of a neighbour outside the image: weight 0

// Phase 1: D(p, p + o) for the tile's pixels p and every window offset o, into sc.patch_distance[o][p]. The pixel
// distances are computed over whole blocks of 16 columns (the patch margin makes 18 columns of which 2 would be a
// scalar tail; the extra columns read the right pad and are not used), and a neighbour outside the image gets
// kOutside through the range of columns that have one, so every loop runs on full SIMD lanes.
void tile_patch_distances(const Planes& in, const RegressionSettings& st, int x0, int y0, TileScratch& sc) {
  using Lanes = stdx::fixed_size_simd<float, kTile>;
  const int R = st.radius, P = st.patch, side = kTile + 2 * P, width = 2 * R + 1;
  const int blocks = (side + kTile - 1) / kTile, side_padded = blocks * kTile;
  const float k2 = st.k * st.k;
  const float inv_patch = 1.f / (3.f * static_cast<float>((2 * P + 1) * (2 * P + 1)));
  const ptrdiff_t stride = static_cast<ptrdiff_t>(in.stride);
  sc.distance.resize(static_cast<size_t>(side) * side_padded);
  sc.row_sum.resize(static_cast<size_t>(side) * kTile);
  sc.patch_distance.resize(static_cast<size_t>(width) * width * kTilePixels);
  for (int oy = -R; oy <= R; ++oy)
    for (int ox = -R; ox <= R; ++ox) {
      const ptrdiff_t shift = oy * stride + ox;
      // Pixel distances between s and s + (ox, oy) over the tile and its patch margin.
      for (int ey = 0; ey < side; ++ey) {
        const size_t row = in.at(x0 - P, y0 - P + ey);
        float* d = &sc.distance[static_cast<size_t>(ey) * side_padded];
        for (int b = 0; b < side_padded; b += kTile) {
          Lanes acc = 0.f;
          for (int c = 0; c < 3; ++c) {
            const float* u = &in.color[c][row + static_cast<size_t>(b)];
            const float* v = &in.variance[c][row + static_cast<size_t>(b)];
            const Lanes vs(v, stdx::element_aligned), vq(v + shift, stdx::element_aligned);
            const Lanes diff = Lanes(u, stdx::element_aligned) - Lanes(u + shift, stdx::element_aligned);
            acc += (diff * diff - (vs + stdx::min(vs, vq))) / (kDistanceEpsilon + k2 * (vs + vq));
          }
          acc.copy_to(d + b, stdx::element_aligned);
        }
      }
      // Box sums over the patch: along rows, then down the columns.
      for (int ey = 0; ey < side; ++ey) {
        const float* d = &sc.distance[static_cast<size_t>(ey) * side_padded];
        Lanes r(d, stdx::element_aligned);
        for (int k = 1; k <= 2 * P; ++k) r += Lanes(d + k, stdx::element_aligned);
        r.copy_to(&sc.row_sum[static_cast<size_t>(ey) * kTile], stdx::element_aligned);
      }
      // Columns whose neighbour is inside the image: x0 + px + ox ∈ [0, w).
      const int inside_lo = std::clamp(-x0 - ox, 0, kTile), inside_hi = std::clamp(in.w - x0 - ox, 0, kTile);
      float* out = &sc.patch_distance[static_cast<size_t>((oy + R) * width + (ox + R)) * kTilePixels];
      for (int py = 0; py < kTile; ++py) {
        float* w = &out[py * kTile];
        Lanes sum(&sc.row_sum[static_cast<size_t>(py) * kTile], stdx::element_aligned);
        for (int k = 1; k <= 2 * P; ++k) sum += Lanes(&sc.row_sum[static_cast<size_t>(py + k) * kTile], stdx::element_aligned);
        stdx::max(Lanes(0.f), sum * inv_patch).copy_to(w, stdx::element_aligned);
        // Neighbours outside the image weigh nothing (their pads only repeat the edge).
        const int qy = y0 + py + oy;
        if (qy < 0 || qy >= in.h) {
          for (int px = 0; px < kTile; ++px) w[px] = kOutside;
          continue;
        }
        for (int px = 0; px < inside_lo; ++px) w[px] = kOutside;
        for (int px = inside_hi; px < kTile; ++px) w[px] = kOutside;
      }
    }
}

// Solves the row's 16 systems (Cholesky, in double, the 16 pixels side by side so the loops vectorise) from their
// sums (upper triangle of Σ w x xᵀ in `matrix`, Σ w x yᵀ in `rhs`) and writes each intercept, clamped to ≥ 0. A
// pixel whose system is not positive definite gets the weighted mean; one whose result is not finite keeps its
// own value.
void solve_row(const Planes& in, const RegressionSettings& st, const Row* matrix, const Row* rhs, int x0, int y,
               std::vector<float>& out) {
  using DRow = double[kTile];
  alignas(64) DRow L[kDims][kDims], z[3][kDims], total;
  alignas(64) bool ok[kTile];
  int e = 0;
  for (int a = 0; a < kDims; ++a)
    for (int b = a; b < kDims; ++b, ++e)
      for (int px = 0; px < kTile; ++px) L[b][a][px] = matrix[e][px];  // lower triangle: L[row][col]
  for (int px = 0; px < kTile; ++px) {
    total[px] = L[0][0][px];
    ok[px] = total[px] > 0.0;
  }
  // The feature slopes get the ridge; the screen-offset slopes only a trace of it (kOffsetRidge) to keep the
  // system solvable: shrinking them would bend ramps at the image border, where the window is one-sided.
  for (int a = 1; a < kDims; ++a) {
    const double ridge = a < 3 ? kOffsetRidge : static_cast<double>(st.ridge);
    for (int px = 0; px < kTile; ++px) L[a][a][px] += ridge * total[px];
  }
  // A = L Lᵀ in place.
  for (int a = 0; a < kDims; ++a)
    for (int b = 0; b <= a; ++b) {
      alignas(64) DRow v;
      for (int px = 0; px < kTile; ++px) v[px] = L[a][b][px];
      for (int k = 0; k < b; ++k)
        for (int px = 0; px < kTile; ++px) v[px] -= L[a][k][px] * L[b][k][px];
      if (a == b) {
        for (int px = 0; px < kTile; ++px) {
          ok[px] = ok[px] && v[px] > 0.0;
          L[a][a][px] = ok[px] ? std::sqrt(v[px]) : 1.0;
        }
      } else {
        for (int px = 0; px < kTile; ++px) L[a][b][px] = v[px] / L[b][b][px];
      }
    }
  for (int c = 0; c < 3; ++c) {
    for (int a = 0; a < kDims; ++a) {
      alignas(64) DRow v;
      for (int px = 0; px < kTile; ++px) v[px] = rhs[3 * a + c][px];
      for (int k = 0; k < a; ++k)
        for (int px = 0; px < kTile; ++px) v[px] -= L[a][k][px] * z[c][k][px];
      for (int px = 0; px < kTile; ++px) z[c][a][px] = v[px] / L[a][a][px];
    }
    for (int a = kDims - 1; a >= 0; --a) {
      alignas(64) DRow v;
      for (int px = 0; px < kTile; ++px) v[px] = z[c][a][px];
      for (int k = a + 1; k < kDims; ++k)
        for (int px = 0; px < kTile; ++px) v[px] -= L[k][a][px] * z[c][k][px];
      for (int px = 0; px < kTile; ++px) z[c][a][px] = v[px] / L[a][a][px];
    }
  }
  for (int px = 0; px < kTile && x0 + px < in.w; ++px) {
    const size_t i = in.at(x0 + px, y);
    const size_t o = static_cast<size_t>(y) * static_cast<size_t>(in.w) + static_cast<size_t>(x0 + px);
    for (int c = 0; c < 3; ++c) {
      double r = in.color[c][i];
      if (total[px] > 0.0) r = ok[px] ? z[c][0][px] : static_cast<double>(rhs[c][px]) / total[px];
      const double v = std::isfinite(r) ? std::max(0.0, r) : static_cast<double>(in.color[c][i]);
      out[3 * o + c] = static_cast<float>(v);
    }
  }
}

// Phase 2 for one row of 16 pixels: every offset's neighbour adds w · x xᵀ and w · x yᵀ to the row's sums. The row
// is one SIMD value of 16 lanes (one AVX-512 register, two AVX2 ones), written out so that each statement is a
// vector operation whatever the auto-vectoriser makes of the triangle's loops.
void regress_row(const Planes& in, const RegressionSettings& st, const TileScratch& sc, int x0, int y, int py,
                 std::vector<float>& out) {
  using Lanes = stdx::fixed_size_simd<float, kTile>;
  const int R = st.radius, width = 2 * R + 1;
  const ptrdiff_t stride = static_cast<ptrdiff_t>(in.stride);
  Lanes own[6];
  for (int f = 0; f < 6; ++f) {
    alignas(64) Row values;
    for (int px = 0; px < kTile; ++px)
      values[px] = in.feature[f][in.at(std::min(x0 + px, in.w - 1), std::min(y, in.h - 1))];
    own[f].copy_from(values, stdx::vector_aligned);
  }
  Lanes matrix[kPairs], rhs[3 * kDims];
  for (auto& m : matrix) m = 0.f;
  for (auto& r : rhs) r = 0.f;
  const size_t base = in.at(x0, y);
  const float inv_sn2 = inverse_square(st.sigma_normal), inv_sa2 = inverse_square(st.sigma_albedo);
  // Along one line of the window (fixed oy) the regressor x₂ = oy/R is a constant s, so every sum with x₂ in it is
  // s × a sum without it: the line keeps T_b = Σ w x_b and Σ w y, and row 2 of the normal equations is added once
  // per line instead of once per neighbour (8 % fewer vector operations per neighbour).
  for (int oy = -R; oy <= R; ++oy) {
    const float s = static_cast<float>(oy) / static_cast<float>(R);
    Lanes line[kDims], line_y[3];
    for (auto& t : line) t = 0.f;
    for (auto& t : line_y) t = 0.f;
    for (int ox = -R; ox <= R; ++ox) {
      const size_t q = static_cast<size_t>(static_cast<ptrdiff_t>(base) + oy * stride + ox);
      const float* dist = &sc.patch_distance[static_cast<size_t>((oy + R) * width + (ox + R)) * kTilePixels +
                                             static_cast<size_t>(py) * kTile];
      Lanes x[kDims], y3[3];
      x[1] = static_cast<float>(ox) / static_cast<float>(R);
      for (int f = 0; f < 6; ++f) x[3 + f] = Lanes(&in.feature[f][q], stdx::element_aligned) - own[f];
      for (int c = 0; c < 3; ++c) y3[c] = Lanes(&in.color[c][q], stdx::element_aligned);
      // The weight: non-local means on the colour times the feature kernels.
      const Lanes d(dist, stdx::element_aligned);
      const Lanes da = x[3] * x[3] + x[4] * x[4] + x[5] * x[5];
      const Lanes dn = x[6] * x[6] + x[7] * x[7] + x[8] * x[8];
      Lanes wgt = exp_neg(d + dn * inv_sn2 + da * inv_sa2);
      stdx::where(d >= kOutside, wgt) = 0.f;
      // Row 0 (x₀ = 1) into the line's sums; rows 1 and 3..8 of Σ w x xᵀ (upper triangle) and Σ w x yᵀ directly,
      // leaving out column 2.
      line[0] += wgt;
      for (int b = 1; b < kDims; ++b)
        if (b != 2) line[b] += wgt * x[b];
      for (int c = 0; c < 3; ++c) line_y[c] += wgt * y3[c];
      for (int a = 1; a < kDims; ++a) {
        if (a == 2) continue;
        const Lanes wx = wgt * x[a];
        for (int b = a; b < kDims; ++b)
          if (b != 2) matrix[pair_index(a, b)] += wx * x[b];
        for (int c = 0; c < 3; ++c) rhs[3 * a + c] += wx * y3[c];
      }
    }
    for (int b = 0; b < kDims; ++b)
      if (b != 2) matrix[pair_index(0, b)] += line[b];
    matrix[pair_index(0, 2)] += s * line[0];
    matrix[pair_index(1, 2)] += s * line[1];
    matrix[pair_index(2, 2)] += (s * s) * line[0];
    for (int b = 3; b < kDims; ++b) matrix[pair_index(2, b)] += s * line[b];
    for (int c = 0; c < 3; ++c) {
      rhs[c] += line_y[c];
      rhs[6 + c] += s * line_y[c];
    }
  }
  alignas(64) Row matrix_rows[kPairs], rhs_rows[3 * kDims];
  for (int e = 0; e < kPairs; ++e) matrix[e].copy_to(matrix_rows[e], stdx::vector_aligned);
  for (int e = 0; e < 3 * kDims; ++e) rhs[e].copy_to(rhs_rows[e], stdx::vector_aligned);
  solve_row(in, st, matrix_rows, rhs_rows, x0, y, out);
}

void regress_tile(const Planes& in, const RegressionSettings& st, int tx, int ty, TileScratch& sc,
                  std::vector<float>& out) {
  const int x0 = tx * kTile, y0 = ty * kTile;
  tile_patch_distances(in, st, x0, y0, sc);
  for (int py = 0; py < kTile && y0 + py < in.h; ++py) regress_row(in, st, sc, x0, y0 + py, py, out);
}

// The regression at the input's own resolution.
std::vector<float> regress(const DenoiseInput& input, const RegressionSettings& st, ThreadPool& pool,
                           const std::atomic<bool>* cancel) {
  const int w = input.width, h = input.height;
  const size_t n = static_cast<size_t>(w) * static_cast<size_t>(h);

  Planes in;
  in.w = w, in.h = h, in.margin = st.radius + st.patch;
  in.stride = static_cast<size_t>(in.width_padded());
  const size_t padded = in.stride * static_cast<size_t>(in.height_padded());
  for (auto& p : in.color) p.resize(padded);
  for (auto& p : in.variance) p.resize(padded);
  for (auto& p : in.feature) p.resize(padded);
  std::vector<float> radiance(3 * n);
  for (size_t i = 0; i < 3 * n; ++i) radiance[i] = (*input.color)[i] - (input.emission ? (*input.emission)[i] : 0.f);
  const std::vector<float> excess =
      spread_fireflies(w, h, {st.firefly_ratio, st.firefly_deviation, st.firefly_radius}, radiance, *input.variance, pool);
  pool.parallel_for(in.height_padded(), [&](int row, int) {
    const int y = std::clamp(row - in.margin, 0, h - 1);
    for (int col = 0; col < in.width_padded(); ++col) {
      const size_t i = static_cast<size_t>(y) * w + static_cast<size_t>(std::clamp(col - in.margin, 0, w - 1));
      const size_t j = static_cast<size_t>(row) * in.stride + static_cast<size_t>(col);
      const float* nrm = &(*input.normal)[3 * i];
      const float inv = inverse_normal_length(nrm);
      for (int c = 0; c < 3; ++c) {
        in.color[c][j] = radiance[3 * i + c];
        const float v = (*input.variance)[3 * i + c];
        in.variance[c][j] = std::isfinite(v) ? v : 0.f;  // below 2 samples: no estimate
        in.feature[c][j] = (*input.albedo)[3 * i + c];
        in.feature[3 + c][j] = nrm[c] * inv;
      }
    }
  });

  std::vector<float> out(3 * n);
  const int tiles_x = (w + kTile - 1) / kTile, tiles_y = (h + kTile - 1) / kTile;
  std::vector<TileScratch> scratch(static_cast<size_t>(pool.size()));
  pool.parallel_for(tiles_x * tiles_y, [&](int task, int thread) {
    if (cancel && cancel->load(std::memory_order_relaxed)) return;
    regress_tile(in, st, task % tiles_x, task / tiles_x, scratch[static_cast<size_t>(thread)], out);
  });
  if (cancel && cancel->load(std::memory_order_relaxed)) return {};
  for (size_t i = 0; i < 3 * n; ++i)
    out[i] += (excess.empty() ? 0.f : excess[i]) + (input.emission ? (*input.emission)[i] : 0.f);
  return out;
}

}  // namespace

std::vector<float> denoise_regression(const DenoiseInput& input, const RegressionSettings& st, ThreadPool& pool,
                                      const std::atomic<bool>* cancel) {
  check_denoise_input(input);
  if (st.radius < 1 || st.patch < 0 || !(st.k > 0.f) || !(st.ridge >= 0.f) || !(st.sigma_normal >= 0.f) ||
      !(st.sigma_albedo >= 0.f) || !(st.firefly_ratio >= 0.f) || !(st.firefly_deviation >= 0.f) ||
      st.coarse_radius < 0 || !(st.coarse_limit >= 0.f) || st.firefly_radius < 0)
    throw std::invalid_argument("denoise: bad regression settings");
  std::vector<float> out = regress(input, st, pool, cancel);
  if (out.empty() || st.coarse_radius == 0) return out;
  // The coarse scale (two_scale.h): the same regression over 2×2 means, its low frequencies added.
  const HalfScale half = half_scale(input, out, pool);
  RegressionSettings coarse_settings = st;
  coarse_settings.radius = st.coarse_radius;
  coarse_settings.firefly_radius = (st.firefly_radius + 1) / 2;
  const std::vector<float> coarse = regress(half.planes.input(), coarse_settings, pool, cancel);
  if (coarse.empty()) return {};
  add_coarse_correction(half, coarse, st.coarse_limit, input.width, input.height, out, pool);
  return out;
}

}  // namespace pt
