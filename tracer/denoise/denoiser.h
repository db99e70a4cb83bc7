// The denoisers (docs/denoising.md gives the equations, the parameters, the measurements and where each fails):
// - final frames: a weighted first-order regression of the radiance on the feature buffers over a window, with
//   non-local-means weights on the colour (regression.cpp; Moon et al. 2014, Bitterli et al. 2016 "NFOR" §4–5);
// - the viewer: a feature-guided, variance-aware edge-avoiding à-trous wavelet filter (atrous.cpp; Dammertz et al.
//   2010, "Edge-Avoiding À-Trous Wavelet Transform for fast Global Illumination Filtering"), with the luminance
//   edge-stopping function scaled by the filtered per-pixel standard deviation as in SVGF (Schied et al. 2017,
//   "Spatiotemporal Variance-Guided Filtering", §4.3–4.4).
//
// Both leave the emission seen directly (or through mirrors and glass) aside. The à-trous filter works on the
// illumination: the rest is divided by the denoising albedo first and multiplied by it afterwards, so lights,
// texture and material edges stay as sharp as the feature buffers, and only the smooth irradiance is blurred; the
// film's variance of each pixel's mean decides how different a neighbour's illumination may be before it is
// treated as another feature (a shadow edge, a caustic) rather than noise. The regression fits the radiance with
// the albedo among its regressors.
#pragma once
#include <atomic>
#include <cmath>
#include <memory>
#include <vector>

#include "core/enum_table.h"
#include "core/thread_pool.h"
#include "denoise/fireflies.h"

namespace pt {

class Film;

// The inputs, row-major planes of the film (Film::*_image): 3 floats per pixel except depth (1).
struct DenoiseInput {
  int width = 0, height = 0;
  const std::vector<float>* color = nullptr;     // mean radiance
  const std::vector<float>* variance = nullptr;  // variance of each pixel's mean, per channel
  const std::vector<float>* albedo = nullptr;    // denoising albedo (integrators/features.h)
  const std::vector<float>* normal = nullptr;    // world-space normal, towards the viewer
  const std::vector<float>* depth = nullptr;     // distance to the first hit
  const std::vector<float>* emission = nullptr;  // emission seen directly, per channel (features.h); null = none
};

// The albedo a channel of the illumination is divided by (and multiplied by again): below 1e-2 it is treated as 1,
// since black and absent surfaces (escaped rays) have no texture to protect, and dividing by ~0 would amplify
// their noise. The à-trous filter and the preview's upsampling share it.
inline constexpr float kMinDemodulateAlbedo = 1e-2f;
inline float demodulation(float albedo) { return albedo >= kMinDemodulateAlbedo ? albedo : 1.f; }

// Throws std::invalid_argument when an input is missing or of the wrong size (both filters check first).
void check_denoise_input(const DenoiseInput& input);
// 1/|n| of a film's normal (averaged normals are shorter than 1), 0 where there is none.
inline float inverse_normal_length(const float* n) {
  const float len2 = n[0] * n[0] + n[1] * n[1] + n[2] * n[2];
  return len2 > 1e-12f ? 1.f / std::sqrt(len2) : 0.f;
}

struct DenoiseSettings {
  int iterations = 5;          // à-trous levels: the footprint is 4·(2^iterations − 1) + 1 pixels wide
  float sigma_luminance = 4.f; // σ_l: luminance differences up to ~σ_l standard deviations count as noise
  float sigma_depth = 1.f;     // σ_z: depth differences in units of the local depth gradient × distance
  float sigma_albedo = 0.1f;   // σ_a: albedo differences (Euclidean, RGB)
  FireflySettings fireflies;   // the firefly step before filtering (fireflies.h; ratio 0: off)

  // The viewer's mode: four levels (61-pixel footprint) instead of five. Measured at 512², 16 spp, 2 threads
  // (docs/denoising.md): ≈20 % less time, and relMSE within 0.3 % of five levels on cornell-spheres and materials
  // (10 % lower on cornell).
  static DenoiseSettings viewer() {
    DenoiseSettings s;
    s.iterations = 4;
    return s;
  }
};

// The final-frame filter (regression.cpp): per pixel, a weighted first-order regression of the radiance on the
// features over a (2·radius + 1)² window, weights from non-local means on the colour with a (2·patch + 1)² patch.
// The defaults were chosen on cornell, cornell-spheres and materials at 16 spp against converged references
// (docs/denoising.md has the sweep): larger windows and ridges help the glossy scenes, smaller ones cornell.
struct RegressionSettings {
  int radius = 7;       // window radius R: 15×15 neighbours (17×17 before the coarse scale: docs/denoising.md)
  int patch = 2;        // patch radius P of the colour distance: 5×5 (3×3 with k 0.9: same relMSE on cornell and
                        // materials, 2 % more on cornell-spheres, more blocks off: docs/denoising.md)
  float k = 0.7f;       // k of the distance: larger accepts more dissimilar neighbours
  float ridge = 0.05f;  // λ: ridge on the feature slopes, relative to the sum of the weights
  // Feature kernels multiplied into the weights, exp(−|Δn|²/σ_n² − |Δa|²/σ_a²) (0: none): a neighbour across a
  // crease or a material edge leaves the fit even where the colour noise hides the difference.
  float sigma_normal = 0.3f;
  float sigma_albedo = 0.3f;
  // Fireflies: a pixel brighter than firefly_ratio × the (upper) median of its 8 neighbours whose mean's
  // standard deviation exceeds firefly_deviation × its mean has the excess spread over firefly_radius (twice the
  // window's; fireflies.h; ratio 0: off). The coarse scale spreads over the same area (half the radius in its
  // pixels), so that the two scales do not differ by the spread's shape.
  float firefly_ratio = 1.5f;
  float firefly_deviation = 0.5f;
  int firefly_radius = 14;
  // The coarse scale (two_scale.h): the same regression over the image's 2×2 means with this window radius (0:
  // none), whose difference from the fine output's 2×2 means, limited to coarse_limit × the standard deviation of
  // the 2×2 mean, is upsampled and added: the low frequencies the fine window leaves as blotches.
  int coarse_radius = 6;
  float coarse_limit = 0.2f;
};
// Returns an empty vector if `cancel` was set before it finished (polled per 16×16 tile).
std::vector<float> denoise_regression(const DenoiseInput& input, const RegressionSettings& settings, ThreadPool& pool,
                                      const std::atomic<bool>* cancel = nullptr);

// Which filter: the regression for final frames (≈0.16 s at 512², 2 threads), the à-trous filter where time is
// short (the viewer: ≈50 ms).
enum class DenoiseMethod { Regression, Atrous };
template <>
struct EnumTable<DenoiseMethod> {
  static constexpr std::array<EnumEntry<DenoiseMethod>, 2> kEntries{{
      {DenoiseMethod::Regression, "regression", "First-order regression (final frames)"},
      {DenoiseMethod::Atrous, "atrous", "À-trous wavelet (fast)"},
  }};
};

// The filter with its working planes (~30 float planes of the image's size), kept from one call to the next:
// an interactive front end that denoises every few passes allocates them once.
class Denoiser {
 public:
  Denoiser();
  ~Denoiser();
  Denoiser(Denoiser&&) noexcept;
  Denoiser& operator=(Denoiser&&) noexcept;
  // Writes the denoised RGB image (3 floats per pixel) to `out`. Runs its rows on `pool`. Throws
  // std::invalid_argument when an input is missing or of the wrong size. If `cancel` becomes true it stops
  // within a few rows (polled between its passes and per task of 8 rows), leaves `out` as it was and returns
  // false: the viewer's edits do not wait for a denoise of an image they made stale.
  bool run(const DenoiseInput& input, const DenoiseSettings& settings, ThreadPool& pool, std::vector<float>& out,
           const std::atomic<bool>* cancel = nullptr);

 private:
  struct Scratch;
  std::unique_ptr<Scratch> scratch_;
};

// One call with fresh working planes.
std::vector<float> denoise(const DenoiseInput& input, const DenoiseSettings& settings, ThreadPool& pool);

// A film's planes as the denoiser reads them, copied out of a film with features (Film::enable_features).
struct FilmPlanes {
  int width = 0, height = 0;
  std::vector<float> color, variance, albedo, normal, depth, emission;
  // Reuses the planes' capacity. Without `with_variance` the variance plane is sized but not filled.
  void copy_from(const Film& film, bool with_variance = true);
  DenoiseInput input() const { return {width, height, &color, &variance, &albedo, &normal, &depth, &emission}; }
};

// Denoises a film with features in one call (fresh planes).
std::vector<float> denoise_film(const Film& film, const DenoiseSettings& settings, ThreadPool& pool);
// The same with either filter at its default settings.
std::vector<float> denoise_film(const Film& film, DenoiseMethod method, ThreadPool& pool);

}  // namespace pt
