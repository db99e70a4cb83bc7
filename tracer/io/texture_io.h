// Image files as textures (materials/texture.h): decoding PNG, JPEG, BMP, TGA, … through stb_image, sRGB to
// linear for colour, and reading a texture file under the scene's file rules.
#pragma once
#include <cstddef>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "io/image_io.h"
#include "materials/texture.h"

namespace pt {

// The pyramid of a linear image (materials/texture.h).
inline std::shared_ptr<const Texture> make_texture(const Image& linear, TextureWrap wrap_u, TextureWrap wrap_v,
                                                   std::string source) {
  return make_texture(linear.width, linear.height, linear.rgb, wrap_u, wrap_v, std::move(source));
}

// The largest texture file read.
inline constexpr size_t kMaxTextureFileBytes = size_t{1} << 30;

// Decodes an image file's bytes (PNG, JPEG, BMP, TGA, … through stb_image, at 8 bits per channel: 16-bit files
// are rounded) to linear RGB: colour (sRGB-decoded) when `srgb`, else taken as linear data; alpha is dropped. Throws ImageError naming
// `what` and the reason (undecodable, empty, more than kMaxTextureTexels texels).
Image decode_image(const std::string& bytes, bool srgb, const std::string& what);

// The alpha channel of an image file's bytes (decoded as decode_image does), linear in [0, 1]: for an image
// without one, 1 everywhere, or with `grey_without_alpha` its grey level (stb's luminance of a colour image),
// as an .mtl map_d's scalar image is read. For cut-outs (geometry/alpha_mask.h).
struct AlphaImage {
  int width = 0, height = 0;
  std::vector<float> alpha;  // rows top first
};
AlphaImage decode_alpha(const std::string& bytes, const std::string& what, bool grey_without_alpha = false);
// The alpha as a linear image with it in every channel (what a cut-out's Texture holds).
Image alpha_as_image(const AlphaImage& a);

// An image file as a texture: .exr, .hdr and .pfm through read_hdr_image (linear), anything else through
// decode_image (read under the scene's file rules). Throws ImageError naming the file.
std::shared_ptr<const Texture> load_texture_file(const std::string& path, bool srgb);

}  // namespace pt
