// Latitude-longitude (equirectangular) environment light: radiance arriving from infinitely far away, looked up
// in an RGB image, importance-sampled in proportion to luminance × solid angle.
//
// Convention (world: right-handed, +y up; the camera's default view is −z with +x to its right):
//   Texel (i, j) of a W×H image (column i, row j, row 0 = top row of the file) covers
//     u ∈ [i/W, (i+1)/W),  v ∈ [j/H, (j+1)/H).
//   Polar angle from straight up: θ = π·v, so row 0 touches +y (zenith), the bottom row −y (nadir).
//   Azimuth: φ = 2π·u, and the map-space direction is
//     d(u, v) = (−sin θ · sin φ,  cos θ,  sin θ · cos φ).
//   Cardinal columns: u = 0 (left edge) → +z (behind the default camera), u = 0.25 → −x, u = 0.5 (centre column)
//   → −z (straight ahead), u = 0.75 → +x. Seen from inside, looking down −z with +y up, u increases to the right:
//   the panorama appears unmirrored, exactly as a photograph of it would.
//   Inverse: u = atan2(−d.x, d.z)/(2π) wrapped into [0, 1), v = acos(d.y)/π.
//   Rotation: rotation_deg = α turns the whole map by the right-handed (counter-clockwise seen from above)
//   rotation R_y(α) about +y: world = R_y(α)·map, R_y(α)(x, y, z) = (x cos α + z sin α, y, −x sin α + z cos α).
//   E.g. α = +90° moves the centre column from −z to −x; the camera looking down −z then sees u = 0.75. In u
//   terms, a world direction of azimuth column u_w shows the map's column u_w + α/360.
//
// Lookup: nearest texel (no filtering), so eval() is piecewise constant exactly like the sampling density.
// Sampling: a cell of k×k texels (k = block(): 1, 2 or 4, below) is chosen with probability ∝ its luminance ×
// solid angle (Σ over its texels), then a direction uniformly within the cell's solid angle (φ uniform, cos θ
// uniform between the cell's row bounds). The density per unit solid angle is therefore constant on each cell:
//     pdf(ω) = pdf_uv / (2π · (H/k) · (cos θ_{kJ} − cos θ_{k(J+1)}))   for ω in block row J,
// which is the usual pdf_uv / (2π² sin θ) with sin θ replaced by its exact average over the block row. For a
// constant map this is exactly the uniform sphere density 1/(4π) (up to float rounding).
// Cells larger than a texel: a smooth map (the tabulated sky: 512×256) gains nothing from a density that follows
// each texel, and its per-texel tables (the rows' cumulative distributions and guides, 1.5 MB for the sky, twice
// with compensation) miss the cache on every sample; 4×4 cells take 1/16 of that. The cell is chosen per map: the
// largest k ∈ {4, 2} that divides both sides and whose density samples the map's own luminance with a second
// moment within kBlockTolerance (1 %) of the texels' density's (which estimates the map's integral with no
// variance at all), else texels (k = 1): any sharp feature, a photographed sun or lamp, keeps the texels. Measured:
// docs/performance.md, session 41.
// sample() returns the sampled texel's record without looking the direction up again where the direction is at
// least kEdgeMargin (2⁻¹⁵ rad, and 2⁻¹⁵ in cos θ) from the texel's edges; only nearer an edge does it take eval()'s
// lookup (atan2, acos), which rounding may carry into the neighbour. Why the margin suffices: the row is decided by
// y = cos θ, which the rotation about +y carries unrounded, and acos, ·1/π and ·H round θ by under 10⁻⁶ rad; the
// column by atan2 of x and z, which sin, cos, the product with sin θ, the two rotations, atan2, ·1/2π and ·W round
// by under 2·10⁻⁶ rad (each a few ulps relative to sin θ, or of an angle ≤ 2π): 15× below 2⁻¹⁵ ≈ 3·10⁻⁵. On a
// 512×256 map it skips the lookup for 99 % of the samples (tests: sample() agrees with eval() and pdf() bit for
// bit on maps up to 16384 rows).
// Black texels are never sampled where the cells are texels; an all-black map samples uniformly (pdf 1/(4π)) and
// returns Le = 0.
//
// A second, compensated density for multiple importance sampling (Karlík, Šik, Vévoda, Skřivan and Křivánek,
// "MIS Compensation: Optimizing Sampling Techniques in Multiple Importance Sampling", SIGGRAPH Asia 2019;
// pbrt-v4's ImageInfiniteLight with allowIncompletePDF): ∝ max(0, luminance − L̄) × sin θ, L̄ the map's mean
// luminance over the sphere. Where the map is dimmer than its mean the light strategy takes no samples and
// BSDF sampling, whose MIS weight is then 1, covers it alone; the light samples go where the map stands out.
// Only a caller that combines the light with BSDF sampling by MIS may ask for it (`compensated`): alone it misses
// the dim directions. A map within a thousandth of constant (its compensated mass below 1e-3 of its mass) keeps
// the full density for both, since there is nothing to compensate.
#pragma once
#include <vector>

#include "core/math.h"
#include "io/image_io.h"
#include "sampling/distribution.h"

namespace pt {

struct EnvironmentMap {
  // Throws std::invalid_argument for an empty/inconsistent image, a negative or non-finite texel, a negative or
  // non-finite scale, or a non-finite rotation. `scale` multiplies every radiance value (eval, sample, power).
  EnvironmentMap(const Image& image, float scale = 1.f, float rotation_deg = 0.f);

  // Radiance arriving from world direction `dir` (unit; the radiance travels along −dir).
  Rgb eval(Vec3 dir) const;
  // Importance-samples a world direction from u ∈ [0,1)². On success dir is unit, pdf > 0 is per unit solid
  // angle and equals pdf(dir, compensated), Le equals eval(dir). False (nothing usable) only in rare float edge
  // cases. `compensated`: from the compensated density (above; for MIS only).
  bool sample(Vec2 u, Vec3& dir, float& pdf, Rgb& Le, bool compensated = false) const;
  // Solid-angle density with which sample() produces world direction `dir`.
  float pdf(Vec3 dir, bool compensated = false) const;
  // eval(dir), with pdf(dir, compensated) in `pdf`: one texel lookup (its atan2 and acos) for both.
  Rgb eval(Vec3 dir, float& pdf, bool compensated = false) const;
  // The sampling cells' side in texels (1, 2 or 4; header).
  int block() const { return block_; }
  // Whether the compensated density differs from the full one (false for a nearly constant map).
  bool compensates() const { return !texel_compensated_.empty(); }
  // ∫ luminance(eval(ω)) dω over the sphere (radiance units × sr), scale included: exact for the nearest-texel
  // lookup. For choosing among lights by power.
  double power_weight() const { return power_; }

  int width() const { return width_; }
  int height() const { return height_; }
  float scale() const { return scale_; }
  float rotation_deg() const { return rotation_deg_; }

  Vec3 world_to_map(Vec3 d) const { return {d.x * cos_rot_ - d.z * sin_rot_, d.y, d.x * sin_rot_ + d.z * cos_rot_}; }
  Vec3 map_to_world(Vec3 d) const { return {d.x * cos_rot_ + d.z * sin_rot_, d.y, -d.x * sin_rot_ + d.z * cos_rot_}; }

  // The convention above, in map space (no rotation).
  static Vec3 direction_from_uv(Vec2 uv) {
    const float theta = kPi * uv.y, phi = 2.f * kPi * uv.x;
    const float s = std::sin(theta);
    return {-s * std::sin(phi), std::cos(theta), s * std::cos(phi)};
  }
  static Vec2 uv_from_direction(Vec3 d) {
    float u = std::atan2(-d.x, d.z) * kInv2Pi;
    if (u < 0.f) u += 1.f;
    return {u, std::acos(std::clamp(d.y, -1.f, 1.f)) * kInvPi};
  }

 private:
  // Texel (column, row) hit by map-space direction d.
  void texel_of(Vec3 d, int& i, int& j) const;
  // The record of `records` (texel_ or texel_compensated_) for world direction dir.
  const Vec4& texel(Vec3 dir, const std::vector<Vec4>& records) const;
  // The block size for texel weights (luminance × row width) of a map W wide with rows of widths row_width
  // (cos θ_j − cos θ_{j+1}): the header's rule.
  static int sampling_block(const std::vector<float>& weights, const std::vector<double>& row_width, int W);
  const std::vector<Vec4>& records(bool compensated) const {
    return compensated && compensates() ? texel_compensated_ : texel_;
  }

  // The image itself is not kept: texel_ holds its scaled radiance.
  int width_ = 0, height_ = 0;
  static constexpr float kEdgeMargin = 0x1p-15f;
  float scale_ = 1.f, rotation_deg_ = 0.f, cos_rot_ = 1.f, sin_rot_ = 0.f;
  float column_margin_ = 0.f;  // kEdgeMargin in columns: kEdgeMargin·W/2π
  std::vector<float> row_cos_;            // cos θ_j at the row boundaries, H + 1 entries (1 … −1)
  int block_ = 1;                         // the sampling cells' side in texels
  float block_rows_ = 0.f;                // H / block_, the cells' rows
  std::vector<float> block_cos_width_;    // cos θ_{kJ} − cos θ_{k(J+1)} (from a cancellation-free product)
  Distribution2D distribution_;           // over the cells
  static constexpr double kBlockTolerance = 0.01;
  // Per texel, row-major: the scaled radiance (scale × texel) and the solid-angle density (its cell's density ×
  // the block row's Jacobian 1/(2π · (H/k) · (cos θ_{kJ} − cos θ_{k(J+1)}))), the products eval() and pdf() return,
  // computed once: a lookup reads one 16-byte record instead of the image, the row's distribution and the
  // Jacobian (four cache lines).
  std::vector<Vec4> texel_;
  // The compensated density and its records (the same radiance, its density in w): empty when compensates() is
  // false. A caller uses one set, so a lookup still reads one record. Per texel the map holds 32 bytes of
  // records, and the two distributions 24 bytes per cell: 56 bytes a texel with texel cells, 33.5 with 4×4 cells.
  Distribution2D compensated_;
  std::vector<Vec4> texel_compensated_;
  double power_ = 0.0;
};

}  // namespace pt
