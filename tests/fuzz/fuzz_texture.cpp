// libFuzzer target: the texture decoders (io/texture_io.h: decode_image and decode_alpha, stb_image's PNG, JPEG,
// BMP, TGA, GIF, PSD, PNM readers) and the pyramid built from what they give. The first byte picks sRGB or data decoding and the
// wrap modes; the rest is the file. Any input must give either an image whose size is consistent and whose
// texels are finite and in [0, 1], with a pyramid whose lookups are finite, or an error naming the input; a
// crash, a sanitizer report, a hang or an oversized allocation is a finding.
// Build and run: tools/fuzz.sh (docs/reliability.md).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>

#include <stb_image.h>

#include "fuzz_input.h"
#include "io/image_io.h"
#include "io/texture_io.h"
#include "materials/texture.h"

const char* const pt::fuzz::kTarget = "fuzz_texture";

using pt::fuzz::finding;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const bool srgb = data[0] & 1;
  const auto wrap = [](int bits) { return static_cast<pt::TextureWrap>(bits % 3); };
  const std::string bytes(reinterpret_cast<const char*>(data + 1), size - 1);
  // Images claiming over 2^20 texels are legitimate (up to kMaxTextureTexels) but only slow and large to decode:
  // the harness passes over them, as it bounds the input's length, so that time goes to the decoders' logic.
  int w = 0, h = 0, n = 0;
  if (stbi_info_from_memory(data + 1, static_cast<int>(size - 1), &w, &h, &n) && static_cast<long long>(w) * h > (1 << 20))
    return 0;
  pt::Image img;
  try {
    img = pt::decode_image(bytes, srgb, "input");
  } catch (const pt::ImageError& e) {
    if (std::string(e.what()).rfind("input: ", 0) != 0) finding("error message does not name the input", e.what());
    return 0;
  }
  if (img.width <= 0 || img.height <= 0 || img.rgb.size() != 3ull * img.width * img.height)
    finding("inconsistent image size", std::to_string(img.width) + "x" + std::to_string(img.height));
  for (float v : img.rgb)
    if (!(v >= 0.f && v <= 1.f)) finding("texel outside [0, 1]", std::to_string(v));
  // The alpha channel (cut-outs), or the grey level where there is none (.mtl map_d).
  try {
    const pt::AlphaImage a = pt::decode_alpha(bytes, "input", (data[0] & 32) != 0);
    if (a.width != img.width || a.height != img.height || a.alpha.size() != static_cast<size_t>(a.width) * a.height)
      finding("alpha size differs from the image's", std::to_string(a.width) + "x" + std::to_string(a.height));
    for (float v : a.alpha)
      if (!(v >= 0.f && v <= 1.f)) finding("alpha outside [0, 1]", std::to_string(v));
  } catch (const pt::ImageError& e) {
    finding("the alpha of a decodable image failed", e.what());
  }
  const auto t = pt::make_texture(img, wrap(data[0] >> 1), wrap(data[0] >> 3), "input");
  for (int k = 0; k < 8; ++k) {
    const pt::Vec2 uv(0.37f * k - 1.1f, 0.91f - 0.29f * k);
    const pt::Rgb a = pt::texture_lookup(*t, uv, static_cast<float>(k * k));
    const pt::Rgb b = pt::texture_lookup(*t, uv, pt::Vec2(0.3f, 0.01f * k), pt::Vec2(-0.001f, 0.02f));
    if (!std::isfinite(a.x + a.y + a.z) || !std::isfinite(b.x + b.y + b.z)) finding("lookup not finite", std::to_string(k));
  }
  return 0;
}
