// Image files. PFM holds the exact linear mean radiance (no tone map, no clamp); PNG is for eyes.
// Images in memory are row-major RGB float, top row first.
#pragma once
#include <stdexcept>
#include <cstdint>
#include <string>
#include <vector>

#include "film/tonemap.h"

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

// Writers encode in memory, then write through write_file_safely (io/safe_file.h): the file is complete, or on
// any failure (ImageError naming the reason) the earlier file is left as it was.
// PFM ("PF", 3 channels, little-endian: scale −1, rows stored bottom to top).
void write_pfm(const std::string& path, const Image& img);
Image read_pfm(const std::string& path);  // accepts either endianness and 1- or 3-channel files
// 8-bit sRGB PNG through the display transform.
void write_png(const std::string& path, const Image& img, const DisplaySettings& display = {});
// 8-bit RGB pixels as they are (3 bytes per pixel, top row first).
void write_png_rgb8(const std::string& path, int width, int height, const std::vector<uint8_t>& rgb);

// OpenEXR scan-line file with R, G, B (and, if `alpha`, A = 1) channels, stored as 16-bit half (`half_float`)
// or 32-bit float, ZIP-compressed, data window = display window = the image.
struct ExrWriteOptions {
  bool half_float = false;
  bool alpha = false;
};
void write_exr(const std::string& path, const Image& img, const ExrWriteOptions& options = {});

// One channel of a multi-channel OpenEXR file: its name as stored ("R", "albedo.R", "depth.Z": layer.channel,
// the convention Blender, Nuke and OpenImageIO read as layers) and pixel i's value at data[i·stride].
struct ExrChannel {
  std::string name;
  const float* data;
  size_t stride;
};
// A scan-line file with these channels (ZIP-compressed, data window = display window = width×height), stored as
// 16-bit half or 32-bit float; written like every output (complete or not at all).
void write_exr_channels(const std::string& path, int width, int height, const std::vector<ExrChannel>& channels,
                        bool half_float);

// A linear RGB image by extension: .exr (the R, G, B channels of the first part: a multi-layer file's beauty,
// read_hdr_image's rules) or else PFM. Throws ImageError naming the file and the reason.
Image read_image(const std::string& path);

// Largest HDR image read_hdr_image accepts (texels); larger headers are rejected before any allocation.
inline constexpr long long kMaxHdrImagePixels = 1ll << 28;

// Result of read_hdr_image: on success `error` is empty and `image` holds the texels; on failure `error` names
// the file and the reason and `image` is empty.
struct HdrImageResult {
  Image image;
  std::string error;
  bool ok() const { return error.empty(); }
};

// Reads a linear float RGB image for lighting (environment maps), chosen by the file's extension (any case):
//   .exr  OpenEXR (the first part; scan-line or tiled; half, float or uint channels): R, G, B — or a single Y
//         (luminance) channel, copied to all three; A and any other channels are ignored. The data window is
//         the image (the display window is not consulted).
//   .hdr  Radiance RGBE, "-Y h +X w" orientation, flat or new-style run-length encoded (decoded by stb_image;
//         the data's structure is checked first, since stb reads a truncated file's missing pixels as black).
//   .pfm  portable float map (read_pfm).
// Rows come out top to bottom. Fails (never throws, never crashes on a corrupt file) on: unreadable, truncated
// or malformed files; images with more than kMaxHdrImagePixels texels; and any texel that is negative or not
// finite (the message gives its position and value).
HdrImageResult read_hdr_image(const std::string& path) noexcept;

}  // namespace pt
