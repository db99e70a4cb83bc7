#include "viewer/output_files.h"

#include <cstdio>
#include <filesystem>

#include "io/image_io.h"

namespace pt {

std::string unique_output_stem(const std::string& dir, const std::string& base, const std::vector<std::string>& extensions) {
  namespace fs = std::filesystem;
  for (int n = 1;; ++n) {
    char suffix[16];
    std::snprintf(suffix, sizeof suffix, "-%04d", n);
    const std::string stem = (fs::path(dir) / (base + suffix)).string();
    bool taken = false;
    for (const std::string& ext : extensions) taken = taken || fs::exists(stem + ext);
    if (!taken) return stem;
  }
}

void write_png_rgba8(const std::string& path, int width, int height, const std::vector<uint8_t>& rgba) {
  if (width <= 0 || height <= 0 || rgba.size() != 4ull * width * height)
    throw ImageError(path + ": image has inconsistent size");
  std::vector<uint8_t> rgb(3ull * width * height);
  for (size_t i = 0, n = static_cast<size_t>(width) * height; i < n; ++i)
    for (int c = 0; c < 3; ++c) rgb[3 * i + c] = rgba[4 * i + c];
  write_png_rgb8(path, width, height, rgb);
}

std::string scene_short_name(const std::string& spec) {
  const std::filesystem::path p(spec);
  return p.has_extension() || spec.find('/') != std::string::npos ? p.stem().string() : spec;
}

}  // namespace pt
