// Error metrics of docs/estimators.md, against a reference image R (same size):
//   RMSE   = sqrt(mean over pixels and channels of (x − R)²)
//   relMSE = mean over pixels and channels of (x − R)² / (R² + 0.01)
// and the block test of docs/denoising.md: the mean luminance of each block of pixels against the reference's.
#pragma once
#include "io/image_io.h"

namespace pt {

double rmse(const Image& x, const Image& ref);
double relmse(const Image& x, const Image& ref);
glm::dvec3 mean_rgb(const Image& img);
// Blocks of block × block pixels (whole blocks only, tiled from the top-left corner) whose mean luminance
// (Rec. 709 weights) differs from the reference block's by more than `tolerance` × the reference's: where a
// denoiser moves energy between regions, or noise is still visible at that scale. A reference block of mean 0
// counts as off unless the image's is 0 too; having no relative difference, it is reported apart (`black_off`,
// `black_worst`) and the worst relative difference is that of the other blocks.
struct BlockErrors {
  int blocks = 0;       // whole blocks compared
  int off = 0;          // of those, off by more than the tolerance (black ones included)
  double worst = 0;     // the largest signed relative difference (image − reference)/reference, by magnitude
  int worst_x = 0, worst_y = 0;  // its block's top-left pixel
  int black_off = 0;       // blocks black in the reference but not in the image
  double black_worst = 0;  // the largest mean luminance the image has in such a block
};
BlockErrors block_errors(const Image& x, const Image& ref, int block, double tolerance);

// Box-filter downsampling by an integer factor (width and height must be divisible by it).
Image block_average(const Image& img, int factor);

}  // namespace pt
