// The final-frame filter of denoiser.h: a weighted first-order regression on the feature buffers.
//
// Each pixel p's radiance (minus the emission seen directly, which is added back unfiltered) is fitted over the
// (2R+1)² window around it by weighted least squares against the features, and the fit's value at p is the output
// (locally weighted regression as in Moon et al. 2014, "Adaptive Rendering Based on Weighted Local Regression";
// Bitterli et al. 2016, "Nonlinearly Weighted First-order Regression for Denoising Monte Carlo Renderings", §4):
//   minimise Σ_q w(p, q) ‖y_q − βᵀ x_q‖² + Σ_{k≥1} λ_k β_k² (Σ_q w),  output β₀,
//   x_q = (1, (q − p)/R, a_q − a_p, n_q − n_p, (z_q − z_p)/z_p)   (10 regressors: screen offset, albedo, normal,
//                                                                   relative depth; a first-order Taylor model)
// with the ridge λ_k = λ on the feature slopes (noisy features, e.g. seen through glossy surfaces, should not
// carry the fit) and 1e-4 on the offset slopes.
// A first-order fit follows the radiance across texture, normal and depth edges and along smooth gradients, where
// a weighted mean (the à-trous filter) averages across them; and the weighted residuals of a fit with an
// intercept sum to zero, so the window's energy stays where it was.
//
// The weights are non-local means on the colour, with the per-pixel variance of the mean (Rousselle, Knaus and
// Zwicker 2012, "Adaptive Rendering with Non-Local Means Filtering", eq. 6–7; the distance NFOR uses, §5.1):
//   d²_c(s, t) = ((u_s − u_t)² − (v_s + min(v_s, v_t))) / (ε + k²(v_s + v_t))  per channel,
//   D²(p, q) = mean over channels and over the (2P+1)² patch offsets s of d²_c(p + s, q + s),
//   w(p, q) = exp(−max(0, D²)).
// Subtracting the variances makes the expected distance of two pixels of the same mean 0 whatever their noise.
//
// Layout: padded planes (no bounds checks); the image is cut into 16×16 tiles. Per tile and window offset, the pixel distances of the tile and its
// patch margin are computed once and box-filtered, then every pixel of the tile adds its neighbour's row to its
// normal equations (55 + 30 sums per pixel, kept for the tile: ~90 KB, in L2). Loops over the tile's pixels are
// plain arrays of 256 floats, which the compiler vectorises. Then each pixel's 10×10 system is solved by Cholesky
// in double.
#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "denoise/denoiser.h"
#include "denoise/exp_neg.h"

namespace pt {

namespace {

constexpr int kTile = 16;
constexpr int kTilePixels = kTile * kTile;
constexpr int kDims = 10;                           // regressors
constexpr int kPairs = kDims * (kDims + 1) / 2;     // entries of the symmetric normal matrix
constexpr float kDistanceEpsilon = 1e-10f;          // ε of the distance: keeps noiseless pixels comparable
constexpr float kMinDepth = 1e-6f;
constexpr double kOffsetRidge = 1e-4;

// The inputs as planes, one float per pixel per channel, padded by pixels that repeat the nearest edge pixel, so a
// window or patch offset never needs a bounds check (a clamped coordinate reads the same value): `margin` = R + P
// on the left and top, margin + kTile − 1 on the right and bottom, where the last tiles reach past the image.
struct Planes {
  int w = 0, h = 0, margin = 0;
  int width_padded() const { return w + 2 * margin + kTile - 1; }
  int height_padded() const { return h + 2 * margin + kTile - 1; }
  size_t stride = 0;
  std::array<std::vector<float>, 3> color, variance;
  std::array<std::vector<float>, 7> feature;  // albedo r, g, b, normal x, y, z, depth
  size_t at(int x, int y) const { return static_cast<size_t>(y + margin) * stride + static_cast<size_t>(x + margin); }
};

// The work of one tile: pixel distances over the tile and its margin, their box sums, the normal equations.
struct TileScratch {
  std::vector<float> distance, row_sum;
  std::array<std::array<float, kTilePixels>, kPairs> matrix;
  std::array<std::array<float, kTilePixels>, 3 * kDims> rhs;
};

void regress_tile(const Planes& in, const RegressionSettings& st, int tx, int ty, TileScratch& sc,
                  std::vector<float>& out) {
  const int R = st.radius, P = st.patch, side = kTile + 2 * P;
  const int x0 = tx * kTile, y0 = ty * kTile;
  const float k2 = st.k * st.k;
  const float inv_patch = 1.f / (3.f * static_cast<float>((2 * P + 1) * (2 * P + 1)));
  const ptrdiff_t stride = static_cast<ptrdiff_t>(in.stride);
  sc.distance.resize(static_cast<size_t>(side) * side);
  sc.row_sum.resize(static_cast<size_t>(side) * kTile);
  for (auto& m : sc.matrix) m.fill(0.f);
  for (auto& r : sc.rhs) r.fill(0.f);

  // The tile's own features (pixels beyond the image read the pads; they are not written out).
  alignas(64) float own[7][kTilePixels], inv_depth[kTilePixels];
  for (int j = 0; j < kTilePixels; ++j) {
    const size_t i = in.at(std::min(x0 + j % kTile, in.w - 1), std::min(y0 + j / kTile, in.h - 1));
    for (int f = 0; f < 7; ++f) own[f][j] = in.feature[f][i];
    inv_depth[j] = 1.f / std::max(own[6][j], kMinDepth);
  }
  alignas(64) float x[kDims][kTilePixels], wgt[kTilePixels], y[3][kTilePixels];
  for (int j = 0; j < kTilePixels; ++j) x[0][j] = 1.f;

  for (int oy = -R; oy <= R; ++oy)
    for (int ox = -R; ox <= R; ++ox) {
      const ptrdiff_t shift = oy * stride + ox;
      // Pixel distances between s and s + (ox, oy) over the tile and its patch margin.
      for (int ey = 0; ey < side; ++ey) {
        const size_t row = in.at(x0 - P, y0 - P + ey);
        float* d = &sc.distance[static_cast<size_t>(ey) * side];
        for (int ex = 0; ex < side; ++ex) d[ex] = 0.f;
        for (int c = 0; c < 3; ++c) {
          const float* u = &in.color[c][row];
          const float* v = &in.variance[c][row];
          for (int ex = 0; ex < side; ++ex) {
            const float vs = v[ex], vq = v[ex + shift];
            const float diff = u[ex] - u[ex + shift];
            d[ex] += (diff * diff - (vs + std::min(vs, vq))) / (kDistanceEpsilon + k2 * (vs + vq));
          }
        }
      }
      // Box sums over the patch: along rows, then down the columns.
      for (int ey = 0; ey < side; ++ey) {
        const float* d = &sc.distance[static_cast<size_t>(ey) * side];
        float* r = &sc.row_sum[static_cast<size_t>(ey) * kTile];
        for (int px = 0; px < kTile; ++px) r[px] = d[px];
        for (int k = 1; k <= 2 * P; ++k)
          for (int px = 0; px < kTile; ++px) r[px] += d[px + k];
      }
      for (int py = 0; py < kTile; ++py) {
        float* w = &wgt[py * kTile];
        for (int px = 0; px < kTile; ++px) w[px] = sc.row_sum[static_cast<size_t>(py) * kTile + px];
        for (int k = 1; k <= 2 * P; ++k)
          for (int px = 0; px < kTile; ++px) w[px] += sc.row_sum[static_cast<size_t>(py + k) * kTile + px];
        // Neighbours outside the image weigh nothing (their pads only repeat the edge).
        const int qy = y0 + py + oy;
        const bool row_inside = qy >= 0 && qy < in.h;
        for (int px = 0; px < kTile; ++px) {
          const int qx = x0 + px + ox;
          const float keep = row_inside && qx >= 0 && qx < in.w ? 1.f : 0.f;
          w[px] = keep * exp_neg(std::max(0.f, w[px] * inv_patch));
        }
      }
      // The neighbours' regressors and values.
      const float off_x = static_cast<float>(ox) / static_cast<float>(R);
      const float off_y = static_cast<float>(oy) / static_cast<float>(R);
      for (int py = 0; py < kTile; ++py) {
        const size_t q = static_cast<size_t>(static_cast<ptrdiff_t>(in.at(x0, y0 + py)) + shift);
        const int j0 = py * kTile;
        for (int px = 0; px < kTile; ++px) {
          x[1][j0 + px] = off_x;
          x[2][j0 + px] = off_y;
        }
        for (int f = 0; f < 6; ++f) {
          const float* src = &in.feature[f][q];
          for (int px = 0; px < kTile; ++px) x[3 + f][j0 + px] = src[px] - own[f][j0 + px];
        }
        const float* depth = &in.feature[6][q];
        for (int px = 0; px < kTile; ++px) x[9][j0 + px] = (depth[px] - own[6][j0 + px]) * inv_depth[j0 + px];
        for (int c = 0; c < 3; ++c) {
          const float* src = &in.color[c][q];
          for (int px = 0; px < kTile; ++px) y[c][j0 + px] = src[px];
        }
      }
      // Normal equations: Σ w x xᵀ (upper triangle) and Σ w x yᵀ.
      int e = 0;
      for (int a = 0; a < kDims; ++a) {
        alignas(64) float wx[kTilePixels];
        for (int j = 0; j < kTilePixels; ++j) wx[j] = wgt[j] * x[a][j];
        for (int b = a; b < kDims; ++b, ++e) {
          float* m = sc.matrix[e].data();
          for (int j = 0; j < kTilePixels; ++j) m[j] += wx[j] * x[b][j];
        }
        for (int c = 0; c < 3; ++c) {
          float* r = sc.rhs[3 * a + c].data();
          for (int j = 0; j < kTilePixels; ++j) r[j] += wx[j] * y[c][j];
        }
      }
    }

  // Solve each pixel's system (Cholesky, in double) and keep the intercept.
  for (int j = 0; j < kTilePixels; ++j) {
    const int px = x0 + j % kTile, py = y0 + j / kTile;
    if (px >= in.w || py >= in.h) continue;
    double A[kDims][kDims], B[kDims][3];
    int e = 0;
    for (int a = 0; a < kDims; ++a)
      for (int b = a; b < kDims; ++b, ++e) A[a][b] = A[b][a] = sc.matrix[e][j];
    const double total = A[0][0];
    const size_t i = in.at(px, py);
    double result[3] = {in.color[0][i], in.color[1][i], in.color[2][i]};
    if (total > 0.0) {
      // The feature slopes get the ridge; the screen-offset slopes only a trace of it (kOffsetRidge) to keep the
      // system solvable: shrinking them would bend ramps at the image border, where the window is one-sided.
      for (int a = 1; a < kDims; ++a) A[a][a] += (a < 3 ? kOffsetRidge : st.ridge) * total;
      for (int a = 0; a < kDims; ++a)
        for (int c = 0; c < 3; ++c) B[a][c] = sc.rhs[3 * a + c][j];
      // A = L Lᵀ in place (lower triangle).
      bool ok = true;
      for (int a = 0; a < kDims && ok; ++a) {
        for (int b = 0; b <= a; ++b) {
          double v = A[a][b];
          for (int k = 0; k < b; ++k) v -= A[a][k] * A[b][k];
          if (a == b) {
            if (!(v > 0.0)) ok = false;
            else A[a][a] = std::sqrt(v);
          } else {
            A[a][b] = v / A[b][b];
          }
        }
      }
      if (ok) {
        for (int c = 0; c < 3; ++c) {
          double z[kDims];
          for (int a = 0; a < kDims; ++a) {
            double v = B[a][c];
            for (int k = 0; k < a; ++k) v -= A[a][k] * z[k];
            z[a] = v / A[a][a];
          }
          for (int a = kDims - 1; a >= 0; --a) {
            double v = z[a];
            for (int k = a + 1; k < kDims; ++k) v -= A[k][a] * z[k];
            z[a] = v / A[a][a];
          }
          result[c] = z[0];
        }
      } else {
        for (int c = 0; c < 3; ++c) result[c] = B[0][c] / total;  // the weighted mean
      }
    }
    const size_t o = static_cast<size_t>(py) * in.w + px;
    for (int c = 0; c < 3; ++c) {
      const double v = std::isfinite(result[c]) ? std::max(0.0, result[c]) : static_cast<double>(in.color[c][i]);
      out[3 * o + c] = static_cast<float>(v);
    }
  }
}

}  // namespace

std::vector<float> denoise_regression(const DenoiseInput& input, const RegressionSettings& st, ThreadPool& pool,
                                      const std::atomic<bool>* cancel) {
  const int w = input.width, h = input.height;
  const size_t n = static_cast<size_t>(w) * static_cast<size_t>(h);
  check_denoise_input(input);
  if (st.radius < 1 || st.patch < 0 || !(st.k > 0.f) || !(st.ridge >= 0.f))
    throw std::invalid_argument("denoise: bad regression settings");

  Planes in;
  in.w = w, in.h = h, in.margin = st.radius + st.patch;
  in.stride = static_cast<size_t>(in.width_padded());
  const size_t padded = in.stride * static_cast<size_t>(in.height_padded());
  for (auto& p : in.color) p.resize(padded);
  for (auto& p : in.variance) p.resize(padded);
  for (auto& p : in.feature) p.resize(padded);
  pool.parallel_for(in.height_padded(), [&](int row, int) {
    const int y = std::clamp(row - in.margin, 0, h - 1);
    for (int col = 0; col < in.width_padded(); ++col) {
      const size_t i = static_cast<size_t>(y) * w + static_cast<size_t>(std::clamp(col - in.margin, 0, w - 1));
      const size_t j = static_cast<size_t>(row) * in.stride + static_cast<size_t>(col);
      const float* nrm = &(*input.normal)[3 * i];
      const float inv = inverse_normal_length(nrm);
      for (int c = 0; c < 3; ++c) {
        const float emitted = input.emission ? (*input.emission)[3 * i + c] : 0.f;
        in.color[c][j] = (*input.color)[3 * i + c] - emitted;
        const float v = (*input.variance)[3 * i + c];
        in.variance[c][j] = std::isfinite(v) ? v : 0.f;  // below 2 samples: no estimate
        in.feature[c][j] = (*input.albedo)[3 * i + c];
        in.feature[3 + c][j] = nrm[c] * inv;
      }
      in.feature[6][j] = (*input.depth)[i];
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
  for (size_t i = 0; i < 3 * n; ++i) out[i] += input.emission ? (*input.emission)[i] : 0.f;
  return out;
}

}  // namespace pt
