#include "lights/environment_map.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

namespace pt {

namespace {

// cos θ_a − cos θ_b for the rows a = first … b = first + rows of a map with row height dtheta, as
// 2 sin((θ_a + θ_b)/2) sin((θ_b − θ_a)/2): no cancellation near the poles.
double rows_cos_width(int first, int rows, double dtheta) {
  return 2.0 * std::sin((first + 0.5 * rows) * dtheta) * std::sin(0.5 * rows * dtheta);
}

// The weights summed over k×k blocks (in double, then rounded once: for k = 1 the weights themselves).
std::vector<float> block_sums(const std::vector<float>& w, int W, int H, int k) {
  const int BW = W / k;
  std::vector<double> acc(static_cast<size_t>(BW) * static_cast<size_t>(H / k), 0.0);
  for (int j = 0; j < H; ++j)
    for (int i = 0; i < W; ++i)
      acc[static_cast<size_t>(j / k) * BW + static_cast<size_t>(i / k)] += w[static_cast<size_t>(j) * W + i];
  return std::vector<float>(acc.begin(), acc.end());
}

}  // namespace

// The largest block k ∈ {4, 2} that divides both sides and whose density, constant on each block, samples the
// map's own luminance with a second moment within kBlockTolerance of the texels' (whose estimate of the map's
// integral has no variance: second moment I²). With m_t a texel's mass (luminance × solid angle, the weight) and
// Ω_t its solid angle (∝ its row's width `row_width`), a block B of mass M_B and solid angle Ω_B has density M_B/(I·Ω_B), so
// the estimator m_t/Ω_t over that density has second moment Σ_B (I·Ω_B/M_B) Σ_{t∈B} m_t²/Ω_t.
int EnvironmentMap::sampling_block(const std::vector<float>& weights, const std::vector<double>& row_width, int W) {
  const int H = static_cast<int>(row_width.size());
  double total = 0.0;
  for (float w : weights) total += w;
  if (!(total > 0.0)) return 1;
  for (const int k : {4, 2}) {
    if (W % k != 0 || H % k != 0) continue;
    // One block row at a time (memory for one row of cells, whatever the map's size).
    const int BW = W / k;
    std::vector<double> mass(static_cast<size_t>(BW)), omega(mass.size()), m2(mass.size());
    double second = 0.0;
    for (int J = 0; J < H / k; ++J) {
      std::fill(mass.begin(), mass.end(), 0.0);
      std::fill(omega.begin(), omega.end(), 0.0);
      std::fill(m2.begin(), m2.end(), 0.0);
      for (int j = k * J; j < k * (J + 1); ++j) {
        const double o = row_width[static_cast<size_t>(j)];
        for (int i = 0; i < W; ++i) {
          const size_t b = static_cast<size_t>(i / k);
          const double m = weights[static_cast<size_t>(j) * W + i];
          mass[b] += m, omega[b] += o, m2[b] += m * m / o;
        }
      }
      for (size_t b = 0; b < mass.size(); ++b)
        if (mass[b] > 0.0) second += total * omega[b] / mass[b] * m2[b];
    }
    if (second <= (1.0 + kBlockTolerance) * total * total) return k;
  }
  return 1;
}

EnvironmentMap::EnvironmentMap(const Image& image, float scale, float rotation_deg)
    : width_(image.width), height_(image.height), scale_(scale), rotation_deg_(rotation_deg) {
  const int W = image.width, H = image.height;
  if (W <= 0 || H <= 0 || image.rgb.size() != 3ull * W * H)
    throw std::invalid_argument("environment map: empty or inconsistent image");
  if (!std::isfinite(scale) || scale < 0.f)
    throw std::invalid_argument("environment map: scale must be finite and >= 0 (got " + std::to_string(scale) + ")");
  if (!std::isfinite(rotation_deg))
    throw std::invalid_argument("environment map: rotation must be finite");
  for (float v : image.rgb)
    if (!std::isfinite(v) || v < 0.f)
      throw std::invalid_argument("environment map: texels must be finite and >= 0");

  const double alpha = static_cast<double>(rotation_deg) * std::numbers::pi / 180.0;
  cos_rot_ = static_cast<float>(std::cos(alpha));
  sin_rot_ = static_cast<float>(std::sin(alpha));
  column_margin_ = static_cast<float>(kEdgeMargin * W / (2.0 * std::numbers::pi));

  // Row bounds, and each row's cos θ_j − cos θ_{j+1} (∝ its texels' solid angle).
  const double dtheta = std::numbers::pi / H;
  row_cos_.resize(static_cast<size_t>(H) + 1);
  std::vector<double> width(static_cast<size_t>(H));
  for (int j = 0; j <= H; ++j) row_cos_[static_cast<size_t>(j)] = static_cast<float>(std::cos(j * dtheta));
  row_cos_.front() = 1.f;
  row_cos_.back() = -1.f;
  for (int j = 0; j < H; ++j) width[static_cast<size_t>(j)] = rows_cos_width(j, 1, dtheta);

  // Sampling weights: luminance × the row's exact solid-angle factor (scaled by H/2 to keep them near the
  // luminance; the scale cancels in the normalised density). Power: Σ luminance × texel solid angle.
  std::vector<float> weights(static_cast<size_t>(W) * H);
  double power = 0.0;
  for (int j = 0; j < H; ++j) {
    double row_sum = 0.0;
    for (int i = 0; i < W; ++i) {
      const double lum = std::max(0.f, luminance(image.at(i, j)));
      row_sum += lum;
      weights[static_cast<size_t>(j) * W + i] = static_cast<float>(lum * width[static_cast<size_t>(j)] * 0.5 * H);
    }
    power += row_sum * width[static_cast<size_t>(j)] * (2.0 * std::numbers::pi / W);
  }
  power_ = power * scale;

  // The sampling cells: blocks of k×k texels (header), each block row J spanning cos θ_{kJ} … cos θ_{k(J+1)}; a
  // cell's density per unit solid angle is its density on the unit square over 2π · (H/k) · (that span).
  block_ = sampling_block(weights, width, W);
  const int k = block_, BH = H / k;
  block_rows_ = static_cast<float>(BH);
  block_cos_width_.resize(static_cast<size_t>(BH));
  std::vector<float> block_inv_jacobian(static_cast<size_t>(BH));
  for (int J = 0; J < BH; ++J) {
    const double w = rows_cos_width(k * J, k, dtheta);
    block_cos_width_[static_cast<size_t>(J)] = static_cast<float>(w);
    block_inv_jacobian[static_cast<size_t>(J)] = static_cast<float>(1.0 / (2.0 * std::numbers::pi * BH * w));
  }
  distribution_ = Distribution2D(block_sums(weights, W, H, k), W / k, BH);
  texel_.resize(static_cast<size_t>(W) * H);
  for (int j = 0; j < H; ++j)
    for (int i = 0; i < W; ++i)
      texel_[static_cast<size_t>(j) * W + i] =
          Vec4(scale_ * image.at(i, j), distribution_.cell_pdf(i / k, j / k) * block_inv_jacobian[static_cast<size_t>(j / k)]);

  // The compensated density (header): luminance less the mean luminance over the sphere (Σ over rows of the
  // row's solid angle 2π·width_j is 4π), clamped at 0, times the same row factor, on the same cells.
  // Both masses in power's units (Σ luminance × texel solid angle, unscaled).
  const double mean = power / (4.0 * std::numbers::pi);
  double compensated_mass = 0.0;
  for (int j = 0; j < H; ++j)
    for (int i = 0; i < W; ++i) {
      const double above = std::max(0.0, std::max(0.f, luminance(image.at(i, j))) - mean);
      compensated_mass += above * width[static_cast<size_t>(j)] * (2.0 * std::numbers::pi / W);
      weights[static_cast<size_t>(j) * W + i] = static_cast<float>(above * width[static_cast<size_t>(j)] * 0.5 * H);
    }
  if (compensated_mass > 1e-3 * power) {
    compensated_ = Distribution2D(block_sums(weights, W, H, k), W / k, BH);
    texel_compensated_.resize(texel_.size());
    for (int j = 0; j < H; ++j)
      for (int i = 0; i < W; ++i) {
        const size_t t = static_cast<size_t>(j) * W + i;
        texel_compensated_[t] =
            Vec4(Rgb(texel_[t]), compensated_.cell_pdf(i / k, j / k) * block_inv_jacobian[static_cast<size_t>(j / k)]);
      }
  }
}

void EnvironmentMap::texel_of(Vec3 d, int& i, int& j) const {
  const Vec2 uv = uv_from_direction(d);
  i = Distribution1D::cell_of(uv.x, width_);
  j = Distribution1D::cell_of(uv.y, height_);
}

const Vec4& EnvironmentMap::texel(Vec3 dir, const std::vector<Vec4>& records) const {
  int i, j;
  texel_of(world_to_map(dir), i, j);
  return records[static_cast<size_t>(j) * static_cast<size_t>(width_) + static_cast<size_t>(i)];
}

Rgb EnvironmentMap::eval(Vec3 dir) const { return Rgb(texel(dir, texel_)); }

float EnvironmentMap::pdf(Vec3 dir, bool compensated) const { return texel(dir, records(compensated)).w; }

Rgb EnvironmentMap::eval(Vec3 dir, float& pdf_out, bool compensated) const {
  const Vec4& t = texel(dir, records(compensated));
  pdf_out = t.w;
  return Rgb(t);
}

bool EnvironmentMap::sample(Vec2 u, Vec3& dir, float& pdf_out, Rgb& Le, bool compensated) const {
  int bi = 0, bj = 0;
  compensated = compensated && compensates();
  const Vec2 uv = (compensated ? compensated_ : distribution_).sample_continuous(u, nullptr, &bi, &bj);
  // Position within the block row, remapped linearly to cos θ so the direction is uniform in the cell's solid
  // angle; then the texel row it falls in (the last whose upper bound is ≥ cos θ) and the texel column.
  const int k = block_;
  const float frac = std::clamp(uv.y * block_rows_ - static_cast<float>(bj), 0.f, 1.f);
  const float cos_theta = std::clamp(
      row_cos_[static_cast<size_t>(k * bj)] - frac * block_cos_width_[static_cast<size_t>(bj)], -1.f, 1.f);
  int j = k * bj;
  while (j + 1 < k * (bj + 1) && row_cos_[static_cast<size_t>(j) + 1] >= cos_theta) ++j;
  const float fx = uv.x * static_cast<float>(width_);
  const int i = std::clamp(static_cast<int>(fx), k * bi, k * bi + k - 1);
  // The texel's record, read before the direction is computed so that its cache miss overlaps that work.
  const Vec4 record = records(compensated)[static_cast<size_t>(j) * static_cast<size_t>(width_) + static_cast<size_t>(i)];
  const float sin_theta = safe_sqrt((1.f - cos_theta) * (1.f + cos_theta));
  const float phi = 2.f * kPi * uv.x;
  dir = map_to_world(Vec3(-sin_theta * std::sin(phi), cos_theta, sin_theta * std::cos(phi)));
  // Le and pdf must be what eval() and pdf() give for dir (MIS needs the same density from both sides). A
  // direction at least kEdgeMargin from its texel's edges maps back to that texel (header), so its record is the
  // one read above; one nearer an edge, which rounding could carry across it, takes the lookup itself and may see
  // the neighbour's values.
  const float column = fx - static_cast<float>(i);
  const bool inside = row_cos_[static_cast<size_t>(j)] - cos_theta >= kEdgeMargin &&
                      cos_theta - row_cos_[static_cast<size_t>(j) + 1] >= kEdgeMargin && column >= column_margin_ &&
                      1.f - column >= column_margin_;
  if (inside) {
    pdf_out = record.w;
    Le = Rgb(record);
  } else {
    Le = eval(dir, pdf_out, compensated);
  }
  return pdf_out > 0.f && std::isfinite(pdf_out);
}

}  // namespace pt
