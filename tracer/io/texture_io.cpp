#include "io/texture_io.h"

#include <stb_image.h>

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <limits>

#include "io/safe_file.h"

namespace pt {

namespace {

// The image's texels at 8 bits per channel, `channels` of them per texel (stb converts), after checking its
// announced size. 8 bits whatever the file holds (stb rounds 16-bit images): its 16-bit loader was found by
// fuzzing to return an 8-bit buffer for some inputs it calls 16-bit (fuzz_texture), and textures gain nothing
// visible from the extra bits. The decoded size must be the one announced.
struct Decoded {
  int width = 0, height = 0;
  std::vector<stbi_uc> texels;
};
Decoded decode_texels(const std::string& bytes, int channels, const std::string& what) {
  const auto* data = reinterpret_cast<const stbi_uc*>(bytes.data());
  if (bytes.size() > static_cast<size_t>(std::numeric_limits<int>::max())) throw ImageError(what + ": the image is too large");
  const int len = static_cast<int>(bytes.size());
  int w = 0, h = 0, n = 0;
  if (!stbi_info_from_memory(data, len, &w, &h, &n)) {
    const char* why = stbi_failure_reason();
    throw ImageError(what + ": not a decodable image (" + (why ? why : "unknown format") + ")");
  }
  if (w <= 0 || h <= 0 || static_cast<long long>(w) * h > kMaxTextureTexels)
    throw ImageError(what + ": " + std::to_string(w) + " × " + std::to_string(h) + " texels (at most " +
                     std::to_string(kMaxTextureTexels) + ")");
  // stb's binary PNM reader trusts its header: a P5/P6 file shorter than the texels it announces made Debian's
  // stb read far outside the buffer (fuzz_texture, tests/data/pgm_16bit_short.pgm). Such a file is refused here.
  if (bytes.size() >= 2 && bytes[0] == 'P' && (bytes[1] == '5' || bytes[1] == '6')) {
    const long long sample_bytes = stbi_is_16_bit_from_memory(data, len) ? 2 : 1;
    if (static_cast<long long>(w) * h * n * sample_bytes > static_cast<long long>(bytes.size()))
      throw ImageError(what + ": truncated (its header announces " + std::to_string(w) + " x " + std::to_string(h) +
                       " texels, more than the file holds)");
  }
  int dw = 0, dh = 0, dn = 0;
  stbi_uc* px = stbi_load_from_memory(data, len, &dw, &dh, &dn, channels);
  if (!px) throw ImageError(what + ": cannot decode (" + std::string(stbi_failure_reason() ? stbi_failure_reason() : "?") + ")");
  if (dw != w || dh != h) {
    stbi_image_free(px);
    throw ImageError(what + ": decoded as " + std::to_string(dw) + " x " + std::to_string(dh) + ", announced as " +
                     std::to_string(w) + " x " + std::to_string(h));
  }
  Decoded d;
  d.width = w;
  d.height = h;
  d.texels.assign(px, px + static_cast<size_t>(w) * h * channels);
  stbi_image_free(px);
  return d;
}

}  // namespace

Image decode_image(const std::string& bytes, bool srgb, const std::string& what) {
  const Decoded d = decode_texels(bytes, 3, what);
  Image img;
  img.width = d.width;
  img.height = d.height;
  img.rgb.resize(d.texels.size());
  float table[256];
  for (int i = 0; i < 256; ++i) table[i] = srgb ? srgb_to_linear(i / 255.f) : i / 255.f;
  for (size_t i = 0; i < img.rgb.size(); ++i) img.rgb[i] = table[d.texels[i]];
  return img;
}

AlphaImage decode_alpha(const std::string& bytes, const std::string& what, bool grey_without_alpha) {
  int w = 0, h = 0, n = 0;
  const bool has_alpha = stbi_info_from_memory(reinterpret_cast<const stbi_uc*>(bytes.data()),
                                               static_cast<int>(std::min<size_t>(bytes.size(), std::numeric_limits<int>::max())),
                                               &w, &h, &n) &&
                         (n == 2 || n == 4);
  const bool grey = grey_without_alpha && !has_alpha;
  const Decoded d = decode_texels(bytes, grey ? 1 : 4, what);
  AlphaImage a;
  a.width = d.width;
  a.height = d.height;
  a.alpha.resize(static_cast<size_t>(d.width) * d.height);
  for (size_t i = 0; i < a.alpha.size(); ++i) a.alpha[i] = (grey ? d.texels[i] : d.texels[4 * i + 3]) / 255.f;
  return a;
}

Image alpha_as_image(const AlphaImage& a) {
  Image img;
  img.width = a.width;
  img.height = a.height;
  img.rgb.reserve(3 * a.alpha.size());
  for (float v : a.alpha) img.rgb.insert(img.rgb.end(), {v, v, v});
  return img;
}

std::shared_ptr<const Texture> load_texture_file(const std::string& path, bool srgb) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  const std::string name = std::filesystem::path(path).filename().string();
  if (ext == ".exr" || ext == ".hdr" || ext == ".pfm") {
    HdrImageResult r = read_hdr_image(path);
    if (!r.ok()) throw ImageError(r.error);
    return make_texture(r.image, TextureWrap::Repeat, TextureWrap::Repeat, name);
  }
  std::string bytes;
  try {
    bytes = read_file_limited(path, kMaxTextureFileBytes);
  } catch (const FileError& e) {
    throw ImageError(e.what());
  }
  return make_texture(decode_image(bytes, srgb, path), TextureWrap::Repeat, TextureWrap::Repeat, name);
}

}  // namespace pt
