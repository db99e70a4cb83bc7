// Image textures: a linear RGB mip-map pyramid (reading image files into one: io/texture_io.h) with a wrap mode per axis, looked up bilinearly within a level and
// linearly between the two levels around the ray cone's footprint (trilinear filtering; after pbrt-v4's
// util/mipmap.h, with the level chosen by Akenine-Möller et al. 2021, "Improved Shader and Texture Level of
// Detail Using Ray Cones", JCGT 10(1): the cone's width where it meets the surface, over the cosine of the
// angle it meets it at, in texels of the triangle's own uv mapping).
//
// Conventions (docs/scene-format.md, "Textures"): texture coordinates (u, v) have their origin at the image's
// top-left corner and v growing downwards, glTF's convention (OBJ's vt, whose v grows upwards, is flipped when
// read); texel (i, j) covers [i, i+1) × [j, j+1) in pixel units, its centre at (i + ½, j + ½). Colour images
// (8 bits per channel; 16-bit files are rounded) are decoded from sRGB to linear with the exact sRGB transfer
// function (IEC 61966-2-1); float images (EXR, HDR, PFM) are linear already.
#pragma once
#include <array>
#include <memory>
#include <string>
#include <vector>

#include "core/enum_table.h"
#include "core/math.h"

namespace pt {

// What happens outside [0, 1]: the image repeats, its edge texels extend, or it repeats mirrored (glTF's
// REPEAT, CLAMP_TO_EDGE, MIRRORED_REPEAT).
enum class TextureWrap { Repeat, Clamp, Mirror };
template <>
struct EnumTable<TextureWrap> {
  static constexpr std::array<EnumEntry<TextureWrap>, 3> kEntries{{
      {TextureWrap::Repeat, "repeat", "Repeat"},
      {TextureWrap::Clamp, "clamp", "Clamp to edge"},
      {TextureWrap::Mirror, "mirror", "Mirrored repeat"},
  }};
};

struct TextureLevel {
  int width = 0, height = 0;
  std::vector<Rgb> texels;  // rows top to bottom
  Rgb at(int x, int y) const { return texels[static_cast<size_t>(y) * width + x]; }
};

struct Texture {
  std::vector<TextureLevel> levels;  // levels[0]: the image; each next one half the size (at least 1), box-filtered
  TextureWrap wrap_u = TextureWrap::Repeat, wrap_v = TextureWrap::Repeat;
  std::string source;  // what it was read from, for messages and the viewer ("wood.png", "model.glb images[2]")
  int width() const { return levels[0].width; }
  int height() const { return levels[0].height; }
};

// Texels a texture may hold (level 0): larger images are refused before decoding (io/texture_io.h).
inline constexpr long long kMaxTextureTexels = 1ll << 26;

// The pyramid of a linear RGB image of width × height texels (rgb: 3 floats per texel, rows top first).
std::shared_ptr<const Texture> make_texture(int width, int height, const std::vector<float>& rgb, TextureWrap wrap_u,
                                            TextureWrap wrap_v, std::string source);

// The sRGB transfer function's inverse: a stored value in [0, 1] to linear (IEC 61966-2-1).
float srgb_to_linear(float v);

// The filtered texture at (u, v) for a footprint `texels` texels of level 0 wide: trilinear between the levels
// around log2(texels) (level 0 bilinear for a footprint of a texel or less; the last level beyond).
Rgb texture_lookup(const Texture& t, Vec2 uv, float texels);

// The texture at full resolution (level 0, bilinear) at the surface's uv mapped by `uv_transform` (surface uv →
// texture uv): where one function must be read wherever it is read (a cut-out's alpha, an emitter's image for
// both the rays that hit it and the light samples that land on it).
inline Rgb texture_at(const Texture& t, const glm::mat3& uv_transform, Vec2 uv) {
  return texture_lookup(t, Vec2(uv_transform * glm::vec3(uv, 1.f)), 0.f);
}

// The same over an elliptical footprint with axes `major` and `minor` (full widths, in uv units): up to
// kMaxAnisotropy trilinear lookups spread along the major axis, each as wide as the minor one (or as the
// major one's share, where the ellipse is longer than that), averaged: the anisotropic filtering of GPUs, which
// keeps a surface seen at a grazing angle sharp across the view where one isotropic lookup blurs it.
inline constexpr int kMaxAnisotropy = 8;
Rgb texture_lookup(const Texture& t, Vec2 uv, Vec2 major, Vec2 minor);

}  // namespace pt
