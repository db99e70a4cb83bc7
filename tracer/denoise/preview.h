// The viewer's clean preview: while the camera moves, a 1-spp pass at a fraction of the resolution is denoised
// and brought to full resolution along the edges of a full-resolution guide (integrators/feature_pass.h), so a
// drag shows a smooth, sharp-edged image instead of a blocky, grainy one.
//
// 1. Outliers and variance. A 1-spp pixel far above or below the range of its 8 neighbours is a firefly (a
//    caustic path, a rare bright bounce) or a hole that no filter spreads out at this sample count: each channel of
//    the illumination is clamped into its neighbours' range (up to twice their maximum), as temporal anti-aliasing
//    clamps history to a neighbourhood (Karis 2014, "High Quality Temporal Supersampling"). This biases the
//    preview, never the accumulated film: on cornell at 1 spp and a third of the resolution, the clean preview's
//    mean is 0.92 of the converged one and its relMSE 0.026 against the raw preview's 6.8 (tests/test_preview.cpp);
//    twice the maximum rather than the maximum gives 0.92 instead of 0.89 of the mean, for the same relMSE. One
//    sample per pixel also says nothing about its own variance, which the à-trous filter's luminance weight needs:
//    it is estimated spatially, over the same 3×3 neighbours, as SVGF does where its temporal history is short
//    (Schied et al. 2017, §4.2: a 7×7 bilateral estimate; 3×3 here, which the filter's own 3×3 variance blur widens
//    to 5×5). Neither step asks which neighbours share the pixel's surface: at an edge the range only widens and
//    the variance grows, and the filter's normal, depth and albedo weights still stop there.
// 2. Filter. The à-trous filter of denoiser.h, three levels, on the small image (illumination = radiance ÷ albedo).
// 3. Upsample. Joint bilateral upsampling (Kopf, Cohen, Lischinski and Uyttendaele 2007, "Joint Bilateral
//    Upsampling", eq. 2): each full-resolution pixel takes the bilinear taps of the 2×2 small pixels around it,
//    each weighted by how alike their surfaces are (normal, depth) as the full-resolution guide sees that pixel;
//    where none of the four is alike (a thin object smaller than a small pixel) the 4×4 neighbourhood is searched
//    on the features alone. Most pixels lie inside a quad of four small samples of one surface and agree with it:
//    they take the plain bilinear mean (the weights would all be about 1 there). The illumination is upsampled,
//    then multiplied by the guide's own albedo, and the guide's directly seen emission is added: texture, material
//    edges and lights stay at full resolution.
#pragma once
#include <memory>
#include <vector>

#include "core/thread_pool.h"
#include "denoise/denoiser.h"
#include "film/pixel_features.h"

namespace pt {

class Film;
struct PreviewScratch;

// Step 1 on a 1-spp film's planes: clamps planes.color's outliers and replaces planes.variance (the variance of
// each pixel's mean, per channel) with the spatial estimate.
void prepare_preview_planes(FilmPlanes& planes, ThreadPool& pool);

// The planes the viewer denoises a full-resolution film from: the film's own variance of each pixel's mean, or,
// below 2 samples per pixel (where the film has no variance and the à-trous filter leaves every pixel as it is:
// the first full-resolution frame after every edit came out raw), step 1's outlier clamp and spatial estimate,
// so that frame is as clean as the preview before it.
void copy_viewer_planes(const Film& film, FilmPlanes& planes, ThreadPool& pool);

// Step 3: `low_rgb` (3 floats per pixel of `low`) upsampled to the guide's resolution into `out` (3 floats per
// pixel). `low` supplies the small image's features (albedo, normal, depth, emission).
void upsample_joint_bilateral(const FilmPlanes& low, const std::vector<float>& low_rgb, const FeatureImage& guide,
                              ThreadPool& pool, std::vector<float>& out);

// Where a preview's filtering time went, in milliseconds (view --stats reports them against the pass's).
struct PreviewFilterTimes {
  double variance = 0.0;  // copying the film's planes and step 1
  double filter = 0.0;    // step 2
  double upsample = 0.0;  // step 3
  double total() const { return variance + filter + upsample; }
};

// Steps 1–3 with working planes kept from call to call (a drag calls it every frame).
class PreviewDenoiser {
 public:
  PreviewDenoiser();
  ~PreviewDenoiser();
  // `film`: the small preview film (with features); `guide`: the full-resolution features. Writes the
  // full-resolution RGB image into `out`.
  PreviewFilterTimes run(const Film& film, const FeatureImage& guide, ThreadPool& pool, std::vector<float>& out);

 private:
  FilmPlanes planes_;
  Denoiser denoiser_;
  std::vector<float> small_;
  std::unique_ptr<PreviewScratch> scratch_;
};

}  // namespace pt
