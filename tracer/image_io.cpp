#include "image_io.h"

#include <bit>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <stb_image_write.h>

namespace pt {

namespace {

void check_size(const Image& img, const std::string& path) {
  if (img.width <= 0 || img.height <= 0 || img.rgb.size() != 3ull * img.width * img.height)
    throw ImageError(path + ": image has inconsistent size");
}

// Write to a temporary file next to the target, then rename, so a reader never sees a half-written image.
void commit_file(const std::string& tmp, const std::string& path) {
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::filesystem::remove(tmp, ec);
    throw ImageError(path + ": cannot write (" + ec.message() + ")");
  }
}

}  // namespace

void write_pfm(const std::string& path, const Image& img) {
  check_size(img, path);
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary);
    if (!out) throw ImageError(path + ": cannot open for writing");
    out << "PF\n" << img.width << " " << img.height << "\n-1.0\n";
    std::vector<float> row(3 * static_cast<size_t>(img.width));
    for (int y = img.height - 1; y >= 0; --y) {
      std::memcpy(row.data(), &img.rgb[3 * static_cast<size_t>(y) * img.width], row.size() * sizeof(float));
      if constexpr (std::endian::native == std::endian::big)
        for (float& f : row) f = std::bit_cast<float>(__builtin_bswap32(std::bit_cast<uint32_t>(f)));
      out.write(reinterpret_cast<const char*>(row.data()), static_cast<std::streamsize>(row.size() * sizeof(float)));
    }
    if (!out) throw ImageError(path + ": write failed");
  }
  commit_file(tmp, path);
}

Image read_pfm(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw ImageError(path + ": cannot open");
  std::string magic;
  int w = 0, h = 0;
  double scale = 0;
  in >> magic >> w >> h >> scale;
  if (!in || (magic != "PF" && magic != "Pf")) throw ImageError(path + ": not a PFM file");
  if (w <= 0 || h <= 0 || w > 65536 || h > 65536 || scale == 0.0) throw ImageError(path + ": bad PFM header");
  in.get();  // the single whitespace byte after the scale
  const int channels = magic == "PF" ? 3 : 1;
  const bool file_little = scale < 0;
  std::vector<float> data(static_cast<size_t>(w) * h * channels);
  in.read(reinterpret_cast<char*>(data.data()), static_cast<std::streamsize>(data.size() * sizeof(float)));
  if (!in) throw ImageError(path + ": truncated PFM data");
  if (file_little != (std::endian::native == std::endian::little))
    for (float& f : data) f = std::bit_cast<float>(__builtin_bswap32(std::bit_cast<uint32_t>(f)));
  Image img{w, h, std::vector<float>(3 * static_cast<size_t>(w) * h)};
  for (int y = 0; y < h; ++y) {
    const size_t src_row = static_cast<size_t>(h - 1 - y) * w;
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c)
        img.rgb[3 * (static_cast<size_t>(y) * w + x) + c] = data[(src_row + x) * channels + (channels == 3 ? c : 0)];
  }
  return img;
}

void write_png(const std::string& path, const Image& img, const DisplaySettings& display) {
  check_size(img, path);
  std::vector<uint8_t> px(img.rgb.size());
  for (size_t i = 0; i < img.rgb.size(); i += 3) {
    const Rgb c = tone_map(Rgb(img.rgb[i], img.rgb[i + 1], img.rgb[i + 2]), display);
    for (int k = 0; k < 3; ++k) px[i + k] = to_srgb8(c[k]);
  }
  const std::string tmp = path + ".tmp";
  if (!stbi_write_png(tmp.c_str(), img.width, img.height, 3, px.data(), img.width * 3))
    throw ImageError(path + ": cannot write PNG");
  commit_file(tmp, path);
}

}  // namespace pt
