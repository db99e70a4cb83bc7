// The coarse scale of the final-frame regression (denoiser.h, RegressionSettings::coarse_radius; measured in
// docs/denoising.md, "Two scales").
//
// A window of (2R+1)² pixels averages the noise of a few hundred neighbours, so what the fine regression leaves
// is noise at the window's own scale: faint blotches on flat walls, the blocks that end up a few per cent off. The
// same regression on the image averaged over 2×2 pixels covers four times the area with the same window, and so
// estimates those low frequencies with a quarter of their variance. The output is
//   fine + upsample(clamp(coarse − down(fine), ±limit·σ))
// (down: the 2×2 mean, upsample: bilinear, σ: the standard deviation of the 2×2 mean of the raw pixels, per
// channel): the fine image keeps its detail and takes its low frequencies from the coarse one. The clamp keeps
// the coarse image out where the two disagree by more than residual noise can explain (the coarse fit's own
// blur at glossy highlights and through glass, where the difference is bias, not noise). The combination is the
// scale compositing of Vogels et al. 2018, "Denoising with Kernel Prediction and Asymmetric Loss Functions", §4.2
// (there with a learned per-pixel blend instead of the clamp, which is this project's choice).
#pragma once
#include <vector>

#include "core/thread_pool.h"
#include "denoise/denoiser.h"

namespace pt {

// The input and the fine output at half resolution ((w + 1)/2 × (h + 1)/2; a last odd row or column averages the
// pixels it has): colour, albedo, normal, depth, emission and the fine output are 2×2 means; the variance is that
// of the 2×2 mean (the sum of the four variances over 16), 0 where a pixel has no finite variance.
struct HalfScale {
  FilmPlanes planes;
  std::vector<float> fine;
};
HalfScale half_scale(const DenoiseInput& input, const std::vector<float>& fine, ThreadPool& pool);

// Adds the upsampled, clamped difference between the coarse output and the fine output's 2×2 means to `fine`
// (width × height, 3 floats per pixel); negative results become 0, as the regression's own do.
void add_coarse_correction(const HalfScale& half, const std::vector<float>& coarse, float limit, int width,
                           int height, std::vector<float>& fine, ThreadPool& pool);

}  // namespace pt
