#include "lights/environment_map.h"

#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

namespace pt {

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
  column_margin_ = static_cast<float>(kEdgeMargin * W / (2.0 * std::numbers::pi));
  sin_rot_ = static_cast<float>(std::sin(alpha));

  // Row bounds. cos θ_j − cos θ_{j+1} = 2 sin((θ_j + θ_{j+1})/2) sin(Δθ/2): no cancellation near the poles.
  const double dtheta = std::numbers::pi / H;
  row_cos_.resize(static_cast<size_t>(H) + 1);
  row_cos_width_.resize(static_cast<size_t>(H));
  // 1/(2π · H · (cos θ_j − cos θ_{j+1})): a row's pdf_uv → pdf per sr, folded into texel_ below.
  std::vector<float> row_inv_jacobian(static_cast<size_t>(H));
  std::vector<double> width(static_cast<size_t>(H));
  for (int j = 0; j <= H; ++j) row_cos_[static_cast<size_t>(j)] = static_cast<float>(std::cos(j * dtheta));
  row_cos_.front() = 1.f;
  row_cos_.back() = -1.f;
  for (int j = 0; j < H; ++j) {
    const double w = 2.0 * std::sin((j + 0.5) * dtheta) * std::sin(0.5 * dtheta);
    width[static_cast<size_t>(j)] = w;
    row_cos_width_[static_cast<size_t>(j)] = static_cast<float>(w);
    row_inv_jacobian[static_cast<size_t>(j)] = static_cast<float>(1.0 / (2.0 * std::numbers::pi * H * w));
  }

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
  distribution_ = Distribution2D(weights, W, H);
  texel_.resize(static_cast<size_t>(W) * H);
  for (int j = 0; j < H; ++j)
    for (int i = 0; i < W; ++i)
      texel_[static_cast<size_t>(j) * W + i] =
          Vec4(scale_ * image.at(i, j), distribution_.cell_pdf(i, j) * row_inv_jacobian[static_cast<size_t>(j)]);

  // The compensated density (header): luminance less the mean luminance over the sphere (Σ over rows of the
  // row's solid angle 2π·width_j is 4π), clamped at 0, times the same row factor.
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
    compensated_ = Distribution2D(weights, W, H);
    texel_compensated_.resize(texel_.size());
    for (int j = 0; j < H; ++j)
      for (int i = 0; i < W; ++i) {
        const size_t t = static_cast<size_t>(j) * W + i;
        texel_compensated_[t] = Vec4(Rgb(texel_[t]), compensated_.cell_pdf(i, j) * row_inv_jacobian[static_cast<size_t>(j)]);
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
  int i = 0, j = 0;
  compensated = compensated && compensates();
  const Vec2 uv = (compensated ? compensated_ : distribution_).sample_continuous(u, nullptr, &i, &j);
  // The sampled texel's record, read before the direction is computed so that its cache miss overlaps that work.
  const Vec4 record = records(compensated)[static_cast<size_t>(j) * static_cast<size_t>(width_) + static_cast<size_t>(i)];
  // Position within the row, remapped linearly to cos θ so the direction is uniform in the texel's solid angle.
  const float H = static_cast<float>(height_);
  const float frac = std::clamp(uv.y * H - static_cast<float>(j), 0.f, 1.f);
  const float cos_theta = std::clamp(row_cos_[static_cast<size_t>(j)] - frac * row_cos_width_[static_cast<size_t>(j)],
                                     -1.f, 1.f);
  const float sin_theta = safe_sqrt((1.f - cos_theta) * (1.f + cos_theta));
  const float phi = 2.f * kPi * uv.x;
  dir = map_to_world(Vec3(-sin_theta * std::sin(phi), cos_theta, sin_theta * std::cos(phi)));
  // Le and pdf must be what eval() and pdf() give for dir (MIS needs the same density from both sides). A
  // direction at least kEdgeMargin from its texel's edges maps back to that texel (header), so its record is the
  // one read above; one nearer an edge, which rounding could carry across it, takes the lookup itself and may see
  // the neighbour's values.
  const float column = uv.x * static_cast<float>(width_) - static_cast<float>(i);
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
