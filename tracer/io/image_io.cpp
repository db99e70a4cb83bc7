#include "io/image_io.h"

#include "core/memory_budget.h"
#include "io/safe_file.h"

#include <algorithm>
#include <bit>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <ImfStdIO.h>
#include <half.h>
#include <stb_image.h>
#include <stb_image_write.h>

namespace pt {

namespace {

void check_size(const Image& img, const std::string& path) {
  if (img.width <= 0 || img.height <= 0 || img.rgb.size() != 3ull * img.width * img.height)
    throw ImageError(path + ": image has inconsistent size");
}

// Images are encoded in memory, then written by write_file_safely (io/safe_file.h): complete or not at all.
void commit_file(const std::string& path, std::string_view bytes) {
  try {
    write_file_safely(path, bytes);
  } catch (const FileError& e) {
    throw ImageError(e.what());
  }
}

}  // namespace

void write_pfm(const std::string& path, const Image& img) {
  check_size(img, path);
  std::string bytes = "PF\n" + std::to_string(img.width) + " " + std::to_string(img.height) + "\n-1.0\n";
  std::vector<float> row(3 * static_cast<size_t>(img.width));
  for (int y = img.height - 1; y >= 0; --y) {
    std::memcpy(row.data(), &img.rgb[3 * static_cast<size_t>(y) * img.width], row.size() * sizeof(float));
    if constexpr (std::endian::native == std::endian::big)
      for (float& f : row) f = std::bit_cast<float>(__builtin_bswap32(std::bit_cast<uint32_t>(f)));
    bytes.append(reinterpret_cast<const char*>(row.data()), row.size() * sizeof(float));
  }
  commit_file(path, bytes);
}

Image read_pfm(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw ImageError(path + ": cannot open");
  std::string magic;
  int w = 0, h = 0;
  double scale = 0;
  in >> magic >> w >> h >> scale;
  if (!in || (magic != "PF" && magic != "Pf")) throw ImageError(path + ": not a PFM file");
  if (w <= 0 || h <= 0 || w > 65536 || h > 65536 || scale == 0.0 || !std::isfinite(scale))
    throw ImageError(path + ": bad PFM header");
  in.get();  // the single whitespace byte after the scale
  const int channels = magic == "PF" ? 3 : 1;
  const bool file_little = scale < 0;
  const size_t count = static_cast<size_t>(w) * h * channels;
  // Check the data is there before allocating for it: a corrupt header must not ask for gigabytes.
  const std::streampos data_start = in.tellg();
  in.seekg(0, std::ios::end);
  const std::streampos file_end = in.tellg();
  if (!in || data_start < 0 || static_cast<unsigned long long>(file_end - data_start) < count * sizeof(float))
    throw ImageError(path + ": truncated PFM data");
  in.seekg(data_start);
  // The file's floats plus the RGB image (three times the file for a grey "Pf"): refused with the figure when
  // the machine cannot hold them, rather than an abort in the allocator.
  const uint64_t need = (count + 3ull * w * h) * sizeof(float), budget = memory_budget_bytes();
  if (need > budget)
    throw ImageError(path + ": reading this " + std::to_string(w) + "x" + std::to_string(h) + " image needs about " +
                     format_bytes(need) + "; this machine allows " + format_bytes(budget));
  std::vector<float> data(count);
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
  write_png_rgb8(path, img.width, img.height, px);
}

void write_png_rgb8(const std::string& path, int width, int height, const std::vector<uint8_t>& px) {
  if (width <= 0 || height <= 0 || px.size() != 3ull * width * height)
    throw ImageError(path + ": image has inconsistent size");
  std::string bytes;
  auto append = [](void* context, void* data, int size) {
    static_cast<std::string*>(context)->append(static_cast<const char*>(data), static_cast<size_t>(size));
  };
  if (!stbi_write_png_to_func(append, &bytes, width, height, 3, px.data(), width * 3))
    throw ImageError(path + ": cannot encode PNG");
  commit_file(path, bytes);
}

namespace {

std::string lower_extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

Image read_exr(const std::string& path) {
  Imf::InputFile file(path.c_str());
  const Imf::Header& header = file.header();
  const Imath::Box2i dw = header.dataWindow();
  const long long w = static_cast<long long>(dw.max.x) - dw.min.x + 1;
  const long long h = static_cast<long long>(dw.max.y) - dw.min.y + 1;
  if (w <= 0 || h <= 0) throw ImageError(path + ": empty EXR data window");
  if (w * h > kMaxHdrImagePixels)
    throw ImageError(path + ": EXR image too large (" + std::to_string(w) + "x" + std::to_string(h) + ")");
  const Imf::ChannelList& channels = header.channels();
  const bool rgb = channels.findChannel("R") && channels.findChannel("G") && channels.findChannel("B");
  const bool grey = !rgb && channels.findChannel("Y");
  if (!rgb && !grey) throw ImageError(path + ": EXR file has no R, G, B (or Y) channels");
  for (const char* name : {"R", "G", "B", "Y"}) {
    const Imf::Channel* c = channels.findChannel(name);
    if (c && (c->xSampling != 1 || c->ySampling != 1))
      throw ImageError(path + ": EXR channel " + name + " is subsampled (not supported)");
  }
  Image img{static_cast<int>(w), static_cast<int>(h), std::vector<float>(3 * static_cast<size_t>(w * h))};
  Imf::FrameBuffer fb;
  const size_t xs = 3 * sizeof(float), ys = xs * static_cast<size_t>(w);
  if (rgb) {
    fb.insert("R", Imf::Slice::Make(Imf::FLOAT, &img.rgb[0], dw, xs, ys));
    fb.insert("G", Imf::Slice::Make(Imf::FLOAT, &img.rgb[1], dw, xs, ys));
    fb.insert("B", Imf::Slice::Make(Imf::FLOAT, &img.rgb[2], dw, xs, ys));
  } else {
    fb.insert("Y", Imf::Slice::Make(Imf::FLOAT, &img.rgb[0], dw, xs, ys));
  }
  file.setFrameBuffer(fb);
  file.readPixels(dw.min.y, dw.max.y);
  if (grey)
    for (size_t i = 0; i < img.rgb.size(); i += 3) img.rgb[i + 1] = img.rgb[i + 2] = img.rgb[i];
  return img;
}

// stb_image decodes Radiance files but reads past the end of a truncated file as zeros. This walks the pixel
// data's structure (the same flat / new-style RLE decision as stb) without decoding it, so that a truncated or
// malformed file is an error. Returns an empty string when the data is complete, else the reason.
std::string check_radiance_data(const std::string& bytes, int w, int h) {
  // Header: lines up to an empty line, then the resolution line.
  size_t pos = bytes.find("\n\n");
  if (pos == std::string::npos) return "no end of header";
  pos = bytes.find('\n', pos + 2);
  if (pos == std::string::npos) return "no resolution line";
  size_t p = pos + 1;
  const size_t n = bytes.size();
  auto byte = [&](size_t i) { return static_cast<unsigned char>(bytes[i]); };
  const size_t flat = 4 * static_cast<size_t>(w) * static_cast<size_t>(h);
  if (w < 8 || w >= 32768) return n - p >= flat ? "" : "truncated pixel data";
  for (int y = 0; y < h; ++y) {
    if (n - p < 4) return "truncated pixel data";
    const bool rle = byte(p) == 2 && byte(p + 1) == 2 && (byte(p + 2) & 0x80) == 0;
    if (!rle) {
      if (y == 0) return n - p >= flat ? "" : "truncated pixel data";  // the whole image is uncompressed
      return "scanline " + std::to_string(y) + " is not run-length encoded";
    }
    if (((byte(p + 2) << 8) | byte(p + 3)) != w) return "bad scanline length";
    p += 4;
    for (int c = 0; c < 4; ++c)
      for (int x = 0; x < w;) {
        if (p >= n) return "truncated pixel data";
        int count = byte(p++);
        size_t payload = 1;
        if (count > 128) {
          count -= 128;
        } else {
          payload = static_cast<size_t>(count);
        }
        if (count == 0 || count > w - x) return "bad run-length data";
        if (n - p < payload) return "truncated pixel data";
        p += payload;
        x += count;
      }
  }
  return "";
}

Image read_radiance_hdr(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw ImageError(path + ": cannot open");
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  if (size < 0 || size > 4 * kMaxHdrImagePixels + (1 << 20)) throw ImageError(path + ": HDR file too large");
  in.seekg(0);
  std::string bytes(static_cast<size_t>(size), '\0');
  in.read(bytes.data(), size);
  if (!in) throw ImageError(path + ": read error");
  const auto* data = reinterpret_cast<const stbi_uc*>(bytes.data());
  const int len = static_cast<int>(bytes.size());
  int w = 0, h = 0, n = 0;
  if (!stbi_is_hdr_from_memory(data, len)) throw ImageError(path + ": not a Radiance HDR file");
  if (!stbi_info_from_memory(data, len, &w, &h, &n)) {
    const char* why = stbi_failure_reason();
    throw ImageError(path + ": bad Radiance HDR header (" + (why ? why : "unknown error") + ")");
  }
  if (w <= 0 || h <= 0 || static_cast<long long>(w) * h > kMaxHdrImagePixels)
    throw ImageError(path + ": HDR image too large (" + std::to_string(w) + "x" + std::to_string(h) + ")");
  if (const std::string why = check_radiance_data(bytes, w, h); !why.empty())
    throw ImageError(path + ": bad Radiance HDR data (" + why + ")");
  float* px = stbi_loadf_from_memory(data, len, &w, &h, &n, 3);
  if (!px) {
    const char* why = stbi_failure_reason();
    throw ImageError(path + ": cannot read Radiance HDR data (" + (why ? why : "unknown error") + ")");
  }
  Image img{w, h, std::vector<float>(px, px + 3 * static_cast<size_t>(w) * h)};
  stbi_image_free(px);
  return img;
}

}  // namespace

void write_exr_channels(const std::string& path, int width, int height, const std::vector<ExrChannel>& channels,
                        bool half_float) {
  if (width <= 0 || height <= 0 || channels.empty()) throw ImageError(path + ": nothing to write (empty image)");
  std::string encoded;
  try {
    Imf::Header header(width, height);
    header.compression() = Imf::ZIP_COMPRESSION;
    const Imf::PixelType type = half_float ? Imf::HALF : Imf::FLOAT;
    // OpenEXR converts pixel types when reading but not when writing: each channel gets a plane of the file's
    // type (and of its own, so channels of different strides need no common layout).
    const size_t n = static_cast<size_t>(width) * height;
    std::vector<std::vector<float>> f32(channels.size());
    std::vector<std::vector<half>> f16(channels.size());
    Imf::FrameBuffer fb;
    for (size_t k = 0; k < channels.size(); ++k) {
      const ExrChannel& ch = channels[k];
      header.channels().insert(ch.name, Imf::Channel(type));
      char* base;
      size_t bytes;
      if (half_float) {
        f16[k].resize(n);
        for (size_t i = 0; i < n; ++i) f16[k][i] = half(ch.data[i * ch.stride]);
        base = reinterpret_cast<char*>(f16[k].data());
        bytes = sizeof(half);
      } else {
        f32[k].resize(n);
        for (size_t i = 0; i < n; ++i) f32[k][i] = ch.data[i * ch.stride];
        base = reinterpret_cast<char*>(f32[k].data());
        bytes = sizeof(float);
      }
      fb.insert(ch.name, Imf::Slice(type, base, bytes, bytes * static_cast<size_t>(width)));
    }
    Imf::StdOSStream stream;
    {
      Imf::OutputFile file(stream, header);
      file.setFrameBuffer(fb);
      file.writePixels(height);
    }  // the file is complete once closed
    encoded = stream.str();
  } catch (const std::exception& e) {
    throw ImageError(path + ": cannot encode EXR (" + e.what() + ")");
  }
  commit_file(path, encoded);
}

void write_exr(const std::string& path, const Image& img, const ExrWriteOptions& options) {
  check_size(img, path);
  std::vector<ExrChannel> channels = {{"R", &img.rgb[0], 3}, {"G", &img.rgb[1], 3}, {"B", &img.rgb[2], 3}};
  const std::vector<float> ones(options.alpha ? static_cast<size_t>(img.width) * img.height : 0, 1.f);
  if (options.alpha) channels.push_back({"A", ones.data(), 1});
  write_exr_channels(path, img.width, img.height, channels, options.half_float);
}

Image read_image(const std::string& path) {
  if (lower_extension(path) != ".exr") return read_pfm(path);
  try {
    return read_exr(path);
  } catch (const ImageError&) {
    throw;
  } catch (const std::bad_alloc&) {
    throw;
  } catch (const std::exception& e) {
    throw ImageError(path + ": cannot read EXR (" + e.what() + ")");
  }
}

HdrImageResult read_hdr_image(const std::string& path) noexcept {
  HdrImageResult result;
  try {
    const std::string ext = lower_extension(path);
    {
      std::error_code ec;
      if (!std::filesystem::is_regular_file(path, ec)) {
        result.error = path + ": cannot open (no such file)";
        return result;
      }
    }
    if (ext == ".exr")
      result.image = read_exr(path);
    else if (ext == ".hdr")
      result.image = read_radiance_hdr(path);
    else if (ext == ".pfm")
      result.image = read_pfm(path);
    else {
      result.error = path + ": unsupported HDR image extension '" + ext + "' (expected .exr, .hdr or .pfm)";
      return result;
    }
    const Image& img = result.image;
    if (img.width <= 0 || img.height <= 0 || img.rgb.size() != 3ull * img.width * img.height)
      throw ImageError(path + ": image has inconsistent size");
    if (static_cast<long long>(img.width) * img.height > kMaxHdrImagePixels)
      throw ImageError(path + ": image too large");
    for (size_t i = 0; i < img.rgb.size(); ++i) {
      const float v = img.rgb[i];
      if (std::isfinite(v) && v >= 0.f) continue;
      const size_t texel = i / 3;
      std::ostringstream msg;
      msg << path << ": " << (std::isfinite(v) ? "negative" : "non-finite") << " value " << v << " in channel "
          << "RGB"[i % 3] << " of texel (x " << texel % static_cast<size_t>(img.width) << ", y "
          << texel / static_cast<size_t>(img.width) << ", from the top)";
      throw ImageError(msg.str());
    }
  } catch (const std::exception& e) {
    result.image = Image{};
    result.error = e.what();
    // ImageError messages already start with the path; OpenEXR's and the standard library's do not.
    if (result.error.rfind(path, 0) != 0) result.error = path + ": " + result.error;
  } catch (...) {
    result.image = Image{};
    result.error = path + ": unknown error while reading";
  }
  return result;
}

}  // namespace pt
