// Error metrics of docs/estimators.md, against a reference image R (same size):
//   RMSE   = sqrt(mean over pixels and channels of (x − R)²)
//   relMSE = mean over pixels and channels of (x − R)² / (R² + 0.01)
#pragma once
#include "io/image_io.h"

namespace pt {

double rmse(const Image& x, const Image& ref);
double relmse(const Image& x, const Image& ref);
glm::dvec3 mean_rgb(const Image& img);
// Box-filter downsampling by an integer factor (width and height must be divisible by it).
Image block_average(const Image& img, int factor);

}  // namespace pt
