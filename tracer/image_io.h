// Image files. PFM holds the exact linear mean radiance (no tone map, no clamp); PNG is for eyes.
// Images in memory are row-major RGB float, top row first.
#pragma once
#include <stdexcept>
#include <string>
#include <vector>

#include "tonemap.h"

namespace pt {

struct Image {
  int width = 0, height = 0;
  std::vector<float> rgb;  // 3·width·height
  Rgb at(int x, int y) const {
    const size_t i = 3 * (static_cast<size_t>(y) * width + x);
    return {rgb[i], rgb[i + 1], rgb[i + 2]};
  }
};

struct ImageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// PFM ("PF", 3 channels, little-endian: scale −1, rows stored bottom to top). Written atomically (temp + rename).
void write_pfm(const std::string& path, const Image& img);
Image read_pfm(const std::string& path);  // accepts either endianness and 1- or 3-channel files
// 8-bit sRGB PNG through the display transform.
void write_png(const std::string& path, const Image& img, const DisplaySettings& display = {});

}  // namespace pt
