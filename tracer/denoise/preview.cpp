#include "denoise/preview.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "denoise/exp_neg.h"
#include "film/film.h"

namespace pt {

namespace {

// Depth differences up to this fraction of the depth count as the same surface in the small image (its pixels
// are far apart on screen, so the guide's own gradient says little there).
constexpr float kSmallDepthTolerance = 0.1f;

void for_rows(ThreadPool& pool, int h, const std::function<void(int y)>& row) {
  constexpr int kRowsPerTask = 8;
  pool.parallel_for((h + kRowsPerTask - 1) / kRowsPerTask, [&](int task, int) {
    for (int y = task * kRowsPerTask, end = std::min(h, y + kRowsPerTask); y < end; ++y) row(y);
  });
}

// A small pixel as the upsampling reads it: its illumination, depth, unit normal and whether it has a surface,
// in one 32-byte record (a tap is one cache line at most).
struct SmallSample {
  float e[3];
  float z;
  float n[3];
  float has_surface;  // 1 or 0
};

// surface_weight for a guide pixel (unit normal np, or none) against a small sample, without square roots or
// divisions: the guide's normal is a single ray's (unit), the small one was normalised once.
inline float tap_weight(const float* np, bool p_surface, float zp, float inv_tolerance, const SmallSample& q) {
  if (!p_surface || q.has_surface == 0.f) return p_surface == (q.has_surface != 0.f) ? 1.f : 0.f;
  float c = std::max(0.f, np[0] * q.n[0] + np[1] * q.n[1] + np[2] * q.n[2]);
  c *= c, c *= c, c *= c;
  return c * exp_neg(std::abs(zp - q.z) * inv_tolerance);
}

// A 2×2 quad of small samples (upsample_joint_bilateral says what it is for).
struct Quad {
  float z_lo, z_hi;  // the depth range a guide pixel must fall in (2 % margin)
  bool smooth;
};

}  // namespace

// Working planes kept from call to call: a drag runs the preview every frame, and fresh vectors of these sizes
// come from the system each time (page faults) instead of the allocator's free lists.
struct PreviewScratch {
  std::vector<float> planes;  // prepare_preview_planes' eight working planes
  std::vector<SmallSample> small;
  std::vector<Quad> quads;
};

void prepare_preview_planes(FilmPlanes& planes, ThreadPool& pool, PreviewScratch& scratch) {
  // Plain 3×3 statistics, without asking which neighbours share the pixel's surface: where they do not (an edge)
  // the range only widens (less clamping) and the variance grows (the filter's own normal, depth and albedo
  // weights still stop at the edge). Per channel plane, separably: row-wise minima, maxima and sums over 3
  // (and over the 2 neighbours without the pixel itself), then combined over 3 rows; contiguous loops the
  // compiler vectorises.
  const int w = planes.width, h = planes.height;
  const size_t n = static_cast<size_t>(w) * h;
  scratch.planes.resize(24 * n);
  // Eight planes per channel; three passes over all channels (each pass reads its neighbours' rows of the one
  // before).
  struct Planes {
    float *e, *row_min3, *row_max3, *row_min2, *row_max2, *clamped, *row_sum, *row_sum2;
  };
  auto channel = [&](int c) {
    float* base = &scratch.planes[8 * n * static_cast<size_t>(c)];
    // e: the channel's illumination; min3/max3 over x − 1, x, x + 1, min2/max2 over x − 1 and x + 1; sums over
    // x − 1, x, x + 1 of the clamped illumination and of its square.
    return Planes{base, base + n, base + 2 * n, base + 3 * n, base + 4 * n, base + 5 * n, base + 6 * n, base + 7 * n};
  };
  auto row_start = [&](int y) { return static_cast<size_t>(std::clamp(y, 0, h - 1)) * w; };  // clamped
  auto for_channels = [&](const std::function<void(int y, int c, const Planes&)>& row) {
    for_rows(pool, h, [&](int y) {
      for (int c = 0; c < 3; ++c) row(y, c, channel(c));
    });
  };
  // Illumination, and its row statistics.
    for_channels([&](int y, int c, const Planes& P) {
      auto [e, row_min3, row_max3, row_min2, row_max2, clamped, row_sum, row_sum2] = P;
      const size_t r = static_cast<size_t>(y) * w;
      for (int x = 0; x < w; ++x) {
        const size_t p = r + x;
        e[p] = (planes.color[3 * p + c] - planes.emission[3 * p + c]) / demodulation(planes.albedo[3 * p + c]);
      }
      for (int x = 0; x < w; ++x) {
        const float left = x > 0 ? e[r + x - 1] : kInfinity, right = x + 1 < w ? e[r + x + 1] : kInfinity;
        const float left_hi = x > 0 ? e[r + x - 1] : -kInfinity, right_hi = x + 1 < w ? e[r + x + 1] : -kInfinity;
        row_min2[r + x] = std::min(left, right);
        row_max2[r + x] = std::max(left_hi, right_hi);
        row_min3[r + x] = std::min(row_min2[r + x], e[r + x]);
        row_max3[r + x] = std::max(row_max2[r + x], e[r + x]);
      }
    });
    // Outliers: the channel clamped into the range of the pixel's 8 neighbours, up to twice their maximum (a 1×1
    // image stays as it is).
    for_channels([&](int y, int, const Planes& P) {
      auto [e, row_min3, row_max3, row_min2, row_max2, clamped, row_sum, row_sum2] = P;
      const size_t r = static_cast<size_t>(y) * w;
      const size_t up = row_start(y - 1), down = row_start(y + 1);
      const bool has_up = y > 0, has_down = y + 1 < h;
      for (int x = 0; x < w; ++x) {
        float lo = row_min2[r + x], hi = row_max2[r + x];
        if (has_up) lo = std::min(lo, row_min3[up + x]), hi = std::max(hi, row_max3[up + x]);
        if (has_down) lo = std::min(lo, row_min3[down + x]), hi = std::max(hi, row_max3[down + x]);
        const float v = lo <= hi ? std::min(std::max(e[r + x], lo), 2.f * hi) : e[r + x];
        clamped[r + x] = v;
      }
      for (int x = 0; x < w; ++x) {
        const float left = x > 0 ? clamped[r + x - 1] : 0.f, right = x + 1 < w ? clamped[r + x + 1] : 0.f;
        row_sum[r + x] = left + clamped[r + x] + right;
        row_sum2[r + x] = left * left + clamped[r + x] * clamped[r + x] + right * right;
      }
    });
    // The colour from the clamped illumination, and the variance of each pixel's (single) sample: the unbiased
    // 3×3 spread of the clamped illumination, in the colour's units (the filter divides the albedo out again).
    for_channels([&](int y, int c, const Planes& P) {
      auto [e, row_min3, row_max3, row_min2, row_max2, clamped, row_sum, row_sum2] = P;
      const size_t r = static_cast<size_t>(y) * w;
      const size_t up = row_start(y - 1), down = row_start(y + 1);
      const float rows = static_cast<float>(1 + (y > 0) + (y + 1 < h));
      const float wu = y > 0 ? 1.f : 0.f, wd = y + 1 < h ? 1.f : 0.f;
      for (int x = 0; x < w; ++x) {
        const size_t p = r + x;
        const float count = rows * static_cast<float>(1 + (x > 0) + (x + 1 < w));
        const float sum = row_sum[p] + wu * row_sum[up + x] + wd * row_sum[down + x];
        const float sum2 = row_sum2[p] + wu * row_sum2[up + x] + wd * row_sum2[down + x];
        const float var = count > 1.f ? std::max(0.f, (sum2 - sum * sum / count) / (count - 1.f)) : 0.f;
        const float m = demodulation(planes.albedo[3 * p + c]);
        planes.variance[3 * p + c] = var * m * m;
        planes.color[3 * p + c] = clamped[p] * m + planes.emission[3 * p + c];
      }
    });
}

void upsample_joint_bilateral(const FilmPlanes& low, const std::vector<float>& low_rgb, const FeatureImage& guide,
                              ThreadPool& pool, std::vector<float>& out, PreviewScratch& scratch) {
  const int lw = low.width, lh = low.height, W = guide.width, H = guide.height;
  std::vector<SmallSample>& small = scratch.small;
  small.resize(static_cast<size_t>(lw) * lh);
  // The small sample at (i, j), clamped into the image.
  auto small_at = [&](int i, int j) -> const SmallSample& {
    return small[static_cast<size_t>(std::clamp(j, 0, lh - 1)) * lw + static_cast<size_t>(std::clamp(i, 0, lw - 1))];
  };
  for (size_t q = 0; q < small.size(); ++q) {
    SmallSample& s = small[q];
    for (int c = 0; c < 3; ++c)
      s.e[c] = (low_rgb[3 * q + c] - low.emission[3 * q + c]) / demodulation(low.albedo[3 * q + c]);
    s.z = low.depth[q];
    const float inv = inverse_normal_length(&low.normal[3 * q]);
    for (int c = 0; c < 3; ++c) s.n[c] = low.normal[3 * q + c] * inv;
    s.has_surface = inv > 0.f && inv < 2.f ? 1.f : 0.f;  // averaged normals are shorter than 1, never this short
  }
  // Most guide pixels lie between four small samples of one surface, and there the joint bilateral weights are
  // all about 1: such a 2×2 quad (normals within ~18°, depths within kSmallDepthTolerance) is marked smooth, and
  // a guide pixel inside it that agrees with it (normal within ~25°, depth within the tolerance below) takes the
  // plain bilinear mean: measured on cornell, 512² from 128², 2 threads, 4.4 → 2.9 ms for the whole upsampling.
  // Quad (i, j) has the clamped samples i, i + 1 and j, j + 1; index (i + 1, j + 1).
  const int qw = lw + 1, qh = lh + 1;
  std::vector<Quad>& quads = scratch.quads;
  quads.resize(static_cast<size_t>(qw) * qh);
  for (int j = -1; j < lh; ++j)
    for (int i = -1; i < lw; ++i) {
      const SmallSample* t[4] = {&small_at(i, j), &small_at(i + 1, j), &small_at(i, j + 1), &small_at(i + 1, j + 1)};
      bool alike = true;
      float z_lo = t[0]->z, z_hi = t[0]->z;
      for (int k = 1; k < 4 && alike; ++k) {
        if (t[k]->has_surface != t[0]->has_surface) alike = false;
        else if (t[0]->has_surface != 0.f)
          alike = t[0]->n[0] * t[k]->n[0] + t[0]->n[1] * t[k]->n[1] + t[0]->n[2] * t[k]->n[2] > 0.95f &&
                  std::abs(t[k]->z - t[0]->z) <= kSmallDepthTolerance * t[0]->z;
        z_lo = std::min(z_lo, t[k]->z);
        z_hi = std::max(z_hi, t[k]->z);
      }
      quads[static_cast<size_t>(j + 1) * qw + (i + 1)] = {0.98f * z_lo, 1.02f * z_hi, alike};
    }

  out.resize(3 * guide.pixel_count());
  const float sx = static_cast<float>(lw) / static_cast<float>(W), sy = static_cast<float>(lh) / static_cast<float>(H);
  const float footprint = std::max(1.f / sx, 1.f / sy);  // guide pixels per small pixel
  for_rows(pool, H, [&](int y) {
    const float v = (static_cast<float>(y) + 0.5f) * sy - 0.5f;
    const int j0 = static_cast<int>(std::floor(v));
    const float fv = v - static_cast<float>(j0);
    const SmallSample* rows[2] = {&small_at(0, j0), &small_at(0, j0 + 1)};
    const Quad* quad_row = &quads[static_cast<size_t>(j0 + 1) * qw + 1];
    for (int x = 0; x < W; ++x) {
      const size_t p = static_cast<size_t>(y) * W + x;
      const float* np = &guide.normal[3 * p];
      const bool p_surface = np[0] * np[0] + np[1] * np[1] + np[2] * np[2] > 0.25f;
      const float zp = guide.depth[p];
      const float u = (static_cast<float>(x) + 0.5f) * sx - 0.5f;
      const int i0 = static_cast<int>(std::floor(u));
      const float fu = u - static_cast<float>(i0);
      const int ia = std::clamp(i0, 0, lw - 1), ib = std::clamp(i0 + 1, 0, lw - 1);
      const SmallSample* taps[4] = {&rows[0][ia], &rows[0][ib], &rows[1][ia], &rows[1][ib]};
      const float bilinear[4] = {(1.f - fu) * (1.f - fv), fu * (1.f - fv), (1.f - fu) * fv, fu * fv};
      float acc[3] = {0.f, 0.f, 0.f}, wsum = 0.f;
      // Inside a smooth quad, agreeing with it: normal within ~25°, depth within the quad's range.
      const Quad& quad = quad_row[i0];
      const SmallSample& q0 = *taps[0];
      const bool plain = quad.smooth && p_surface == (q0.has_surface != 0.f) &&
                         (!p_surface || (np[0] * q0.n[0] + np[1] * q0.n[1] + np[2] * q0.n[2] > 0.9f &&
                                         zp >= quad.z_lo && zp <= quad.z_hi));
      if (plain) {
        for (int k = 0; k < 4; ++k)
          for (int c = 0; c < 3; ++c) acc[c] += bilinear[k] * taps[k]->e[c];
        wsum = 1.f;
      } else {
        // The guide's depth slope (the smaller one-sided difference, so a silhouette is not a slope) over a small
        // pixel's footprint, plus 2 % of the depth: how far a tap on the same surface may lie.
        float gx = 1e30f, gy = 1e30f;
        if (x > 0) gx = std::abs(zp - guide.depth[p - 1]);
        if (x + 1 < W) gx = std::min(gx, std::abs(guide.depth[p + 1] - zp));
        if (y > 0) gy = std::abs(zp - guide.depth[p - W]);
        if (y + 1 < H) gy = std::min(gy, std::abs(guide.depth[p + W] - zp));
        const float slope = std::max(gx < 1e30f ? gx : 0.f, gy < 1e30f ? gy : 0.f);
        const float inv_tolerance = 1.f / (2.f * footprint * slope + 0.02f * zp + 1e-6f);
        for (int k = 0; k < 4; ++k) {
          const float wq = bilinear[k] * tap_weight(np, p_surface, zp, inv_tolerance, *taps[k]);
          for (int c = 0; c < 3; ++c) acc[c] += wq * taps[k]->e[c];
          wsum += wq;
        }
        if (wsum < 1e-3f) {  // no neighbour on this surface: the 4×4 around, on the features alone
          acc[0] = acc[1] = acc[2] = wsum = 0.f;
          for (int j = j0 - 1; j <= j0 + 2; ++j)
            for (int i = i0 - 1; i <= i0 + 2; ++i) {
              const SmallSample& q = small_at(i, j);
              const float wq = tap_weight(np, p_surface, zp, inv_tolerance, q);
              for (int c = 0; c < 3; ++c) acc[c] += wq * q.e[c];
              wsum += wq;
            }
          if (wsum < 1e-6f) {  // nothing alike at all: plain bilinear
            acc[0] = acc[1] = acc[2] = 0.f;
            for (int k = 0; k < 4; ++k)
              for (int c = 0; c < 3; ++c) acc[c] += bilinear[k] * taps[k]->e[c];
            wsum = 1.f;
          }
        }
      }
      const float inv = 1.f / wsum;
      for (int c = 0; c < 3; ++c)
        out[3 * p + c] = acc[c] * inv * demodulation(guide.albedo[3 * p + c]) + guide.emission[3 * p + c];
    }
  });
}

void prepare_preview_planes(FilmPlanes& planes, ThreadPool& pool) {
  PreviewScratch scratch;
  prepare_preview_planes(planes, pool, scratch);
}

void upsample_joint_bilateral(const FilmPlanes& low, const std::vector<float>& low_rgb, const FeatureImage& guide,
                              ThreadPool& pool, std::vector<float>& out) {
  PreviewScratch scratch;
  upsample_joint_bilateral(low, low_rgb, guide, pool, out, scratch);
}

void copy_viewer_planes(const Film& film, FilmPlanes& planes, ThreadPool& pool) {
  const bool estimated = film.min_count() >= 2;
  planes.copy_from(film, estimated);
  if (!estimated) prepare_preview_planes(planes, pool);
}

PreviewDenoiser::PreviewDenoiser() : scratch_(std::make_unique<PreviewScratch>()) {}
PreviewDenoiser::~PreviewDenoiser() = default;

PreviewFilterTimes PreviewDenoiser::run(const Film& film, const FeatureImage& guide, ThreadPool& pool,
                                        std::vector<float>& out) {
  using Clock = std::chrono::steady_clock;
  PreviewFilterTimes times;
  Clock::time_point t = Clock::now();
  auto lap = [&](double& into) {
    const Clock::time_point now = Clock::now();
    into = std::chrono::duration<double, std::milli>(now - t).count();
    t = now;
  };
  planes_.copy_from(film, /*with_variance=*/false);  // step 1 estimates it
  prepare_preview_planes(planes_, pool, *scratch_);
  lap(times.variance);
  // Three levels: a 29-pixel footprint, 60-120 guide pixels at the divisors the preview uses (2-4).
  DenoiseSettings settings = DenoiseSettings::viewer();
  settings.iterations = 3;
  denoiser_.run(planes_.input(), settings, pool, small_);
  lap(times.filter);
  upsample_joint_bilateral(planes_, small_, guide, pool, out, *scratch_);
  lap(times.upsample);
  return times;
}

}  // namespace pt
