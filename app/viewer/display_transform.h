// What the viewer's display shader does, stated once on the CPU: the view modes, their settings and the false
// colour map. Colour mode is tracer/tonemap.h's transform (exposure → tone map → sRGB); the diagnostic modes map
// a scalar through kFalseColour. shaders/present.frag mirrors this file; tests/gl compares the two pixel by pixel.
#pragma once
#include <array>
#include <cmath>
#include <cstdint>

#include "core/enum_table.h"
#include "film/tonemap.h"

namespace pt {

// Difference: the live film against a kept snapshot (A/B), as a heat map of relative_difference on the error
// view's log scale.
enum class ViewMode { Colour, RelativeError, SampleCount, Difference };

// Which estimate the colour view shows when the frame has a denoised image: the raw film mean, the denoised one,
// or raw on the left half and denoised on the right.
enum class DenoiseView { Raw, Denoised, Split };

// A/B compare in the colour view: the live image, the kept snapshot, or the snapshot left and live right.
enum class SnapshotView { Off, Snapshot, Split };

// Names for `view --mode` and `--denoise-view`, labels for the Display section. The difference view needs a kept
// snapshot, so the command line does not offer it (kStartupViewModes).
template <>
struct EnumTable<ViewMode> {
  static constexpr std::array<EnumEntry<ViewMode>, 4> kEntries{{
      {ViewMode::Colour, "colour", "colour"},
      {ViewMode::RelativeError, "error", "rel. error"},
      {ViewMode::SampleCount, "samples", "samples"},
      {ViewMode::Difference, "difference", "A/B diff"},
  }};
};
inline constexpr size_t kStartupViewModes = 3;  // the table's first three
template <>
struct EnumTable<DenoiseView> {
  static constexpr std::array<EnumEntry<DenoiseView>, 3> kEntries{{
      {DenoiseView::Raw, "raw", "raw"},
      {DenoiseView::Denoised, "denoised", "denoised"},
      {DenoiseView::Split, "split", "split"},
  }};
};
template <>
struct EnumTable<SnapshotView> {
  static constexpr std::array<EnumEntry<SnapshotView>, 3> kEntries{{
      {SnapshotView::Off, "live", "live"},
      {SnapshotView::Snapshot, "snapshot", "snapshot [B]"},
      {SnapshotView::Split, "split", "A|B"},
  }};
};

struct PresentSettings {
  DisplaySettings display;        // exposure and tone map of the colour view
  ViewMode mode = ViewMode::Colour;
  bool denoise = false;  // the colour view shows the denoised image (denoise_view) where the frame has one
  DenoiseView denoise_view = DenoiseView::Denoised;
  SnapshotView snapshot_view = SnapshotView::Off;
  // Relative standard errors from 10^error_log10_min to 10^error_log10_max span the colour map (clamped beyond).
  float error_log10_min = -3.f, error_log10_max = 0.f;
};

// Viridis (van der Walt & Smith, matplotlib), 11 stops at t = 0, 0.1, …, 1, already sRGB-encoded display values:
// perceptually uniform and readable with colour-vision deficiencies. Dark = small, yellow = large.
inline constexpr std::array<std::array<uint8_t, 3>, 11> kFalseColour = {{
    {68, 1, 84}, {72, 36, 117}, {65, 68, 135}, {53, 95, 141}, {42, 120, 142}, {33, 145, 140},
    {34, 168, 132}, {68, 191, 112}, {122, 209, 81}, {189, 223, 38}, {253, 231, 37}}};

// Display colour (sRGB-encoded, [0,1]) of t ∈ [0,1], piecewise linear between the stops.
inline Rgb false_colour(float t) {
  t = std::clamp(t, 0.f, 1.f) * static_cast<float>(kFalseColour.size() - 1);
  const int i = std::min(static_cast<int>(t), static_cast<int>(kFalseColour.size()) - 2);
  const float f = t - static_cast<float>(i);
  Rgb out;
  for (int c = 0; c < 3; ++c)
    out[c] = (static_cast<float>(kFalseColour[i][c]) * (1.f - f) + static_cast<float>(kFalseColour[i + 1][c]) * f) / 255.f;
  return out;
}

// Colour-map coordinate of a relative standard error (unknown errors, DisplayFrame::kUnknownError, map to 1).
inline float error_coordinate(float rel_error, const PresentSettings& s) {
  const float l = std::log2(std::max(rel_error, 1e-30f)) * 0.30102999566f;  // log10, as GLSL computes it
  return std::clamp((l - s.error_log10_min) / (s.error_log10_max - s.error_log10_min), 0.f, 1.f);
}

// Colour-map coordinate of a sample count, linear from 0 to the image's maximum.
inline float count_coordinate(float count, float max_count) { return std::clamp(count / std::max(max_count, 1.f), 0.f, 1.f); }

// The colour view shows the denoised image at texture coordinates u ≥ this (u ∈ [0, 1) over the image's width);
// above 1: nowhere. Only where the frame has a denoised image.
inline float denoised_from_u(DenoiseView v) {
  return v == DenoiseView::Denoised ? 0.f : v == DenoiseView::Split ? 0.5f : 2.f;
}

// The colour view shows the snapshot at texture coordinates u < this (u ∈ [0, 1)); below 0: nowhere.
inline float snapshot_until_u(SnapshotView v) {
  return v == SnapshotView::Snapshot ? 2.f : v == SnapshotView::Split ? 0.5f : -1.f;
}

// Relative difference of a live mean against a snapshot's, the relative error's form:
// sqrt(mean over channels of (live_c − snapshot_c)² / (snapshot_c² + 0.01)).
inline float relative_difference(Rgb live, Rgb snapshot) {
  float sum = 0.f;
  for (int c = 0; c < 3; ++c) {
    const float d = live[c] - snapshot[c];
    sum += d * d / (snapshot[c] * snapshot[c] + 0.01f);
  }
  return std::sqrt(sum * (1.f / 3.f));
}

// The 8-bit display value the shader must produce for one pixel (the reference of the GL tests); `mean` is
// whichever estimate the pixel shows (denoised_from_u).
// `snapshot` is the kept snapshot's mean at the pixel (the Difference view).
inline std::array<uint8_t, 3> present_pixel(Rgb mean, float rel_error, float count, float max_count,
                                           const PresentSettings& s, Rgb snapshot = Rgb(0.f)) {
  std::array<uint8_t, 3> out{};
  if (s.mode == ViewMode::Colour) {
    const Rgb c = tone_map(mean, s.display);
    for (int k = 0; k < 3; ++k) out[k] = to_srgb8(c[k]);
    return out;
  }
  const float t = s.mode == ViewMode::RelativeError ? error_coordinate(rel_error, s)
                  : s.mode == ViewMode::Difference  ? error_coordinate(relative_difference(mean, snapshot), s)
                                                    : count_coordinate(count, max_count);
  const Rgb c = false_colour(t);
  for (int k = 0; k < 3; ++k) out[k] = static_cast<uint8_t>(std::lround(c[k] * 255.f));
  return out;
}

}  // namespace pt
