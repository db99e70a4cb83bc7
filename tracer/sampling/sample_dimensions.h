// Which sampler dimension each random decision of a path uses: dimension = f(bounce, purpose), fixed before the
// path starts (pbrt-v4 draws a RaySamples struct per bounce the same way). Numbering by call order would shift
// every later dimension whenever a vertex skips a decision (no light sample at a specular vertex), so the same
// dimension would serve a light sample in one path and a BSDF direction in the next, and batches of paths of
// different lengths would not share a layout; explicit numbers keep each dimension to one purpose.
//
// 2D: dimension 0 is the camera jitter, 1 the lens point when the camera has a thin lens (scene/camera.h); then
// per bounce the light point (only when the estimator samples lights) and the BSDF direction (a pinhole camera's
// layout is unchanged by the lens, so its images are too). Only the first SobolSampler::kSobolPairs 2D dimensions are stratified, so the layout
// spends none on light points when no light is sampled. 1D: three per bounce (light choice, BSDF lobe, roulette).
#pragma once
#include <cstdint>

namespace pt {

class SampleDimensions {
 public:
  explicit SampleDimensions(bool light_sampling, bool thin_lens = false)
      : pairs_per_bounce_(light_sampling ? 2u : 1u), first_bounce_pair_(thin_lens ? 2u : 1u) {}

  static constexpr uint32_t kCameraJitter = 0;
  static constexpr uint32_t kLens = 1;  // only with a thin lens
  // 2D dimensions of bounce b (b = 0 at the camera ray's first hit). light_point is meaningful only with light
  // sampling. Unsigned arithmetic: paths of 10^9 bounces reuse dimensions rather than overflow.
  uint32_t light_point(uint32_t bounce) const { return first_bounce_pair_ + pairs_per_bounce_ * bounce; }
  uint32_t bsdf_direction(uint32_t bounce) const {
    return first_bounce_pair_ + pairs_per_bounce_ * bounce + (pairs_per_bounce_ - 1);
  }
  // 1D dimensions of bounce b.
  static uint32_t light_choice(uint32_t bounce) { return 3 * bounce; }
  static uint32_t bsdf_lobe(uint32_t bounce) { return 3 * bounce + 1; }
  static uint32_t roulette(uint32_t bounce) { return 3 * bounce + 2; }

 private:
  uint32_t pairs_per_bounce_, first_bounce_pair_;
};

// The bidirectional estimator's layout (integrators/bdpt.h). 2D: 0 the camera jitter, 1 and 2 the light path's
// origin (point, direction); with a thin lens, 3 the camera ray's lens point and 4 the lens point that light
// tracing (t = 1) connects to; then per bounce b three: the camera path's BSDF direction, the light point of the
// light-sampling connection (s = 1) at camera vertex b, and the light path's BSDF direction (a pinhole's layout
// is the one it had before the lens, so its images are too). 1D: 0 the light path's light choice; then per bounce
// six: the camera path's lobe and roulette, the s = 1 light choice, the light path's lobe and roulette, and the
// manifold strategy's choice of a specular sphere (bdpt_manifold.h; it shares the s = 1 light sample). The lens
// points and the first bounces' directions fall in the Sobol-stratified dimensions.
class BdptDimensions {
 public:
  explicit BdptDimensions(bool thin_lens = false) : first_bounce_pair_(thin_lens ? 5u : 3u) {}

  static constexpr uint32_t kCameraJitter = 0;
  static constexpr uint32_t kEmissionPoint = 1;
  static constexpr uint32_t kEmissionDirection = 2;
  static constexpr uint32_t kCameraLens = 3;  // only with a thin lens
  static constexpr uint32_t kEyeLens = 4;     // only with a thin lens
  static constexpr uint32_t kLightChoice = 0;
  uint32_t camera_direction(uint32_t bounce) const { return first_bounce_pair_ + 3 * bounce; }
  uint32_t connection_point(uint32_t bounce) const { return first_bounce_pair_ + 1 + 3 * bounce; }
  uint32_t light_direction(uint32_t bounce) const { return first_bounce_pair_ + 2 + 3 * bounce; }
  static uint32_t camera_lobe(uint32_t bounce) { return 1 + 6 * bounce; }
  static uint32_t camera_roulette(uint32_t bounce) { return 2 + 6 * bounce; }
  static uint32_t connection_light_choice(uint32_t bounce) { return 3 + 6 * bounce; }
  static uint32_t light_lobe(uint32_t bounce) { return 4 + 6 * bounce; }
  static uint32_t light_roulette(uint32_t bounce) { return 5 + 6 * bounce; }
  static uint32_t manifold_chain_choice(uint32_t bounce) { return 6 + 6 * bounce; }

 private:
  uint32_t first_bounce_pair_;
};

}  // namespace pt
