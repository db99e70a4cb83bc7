#include "materials/texture.h"

#include <algorithm>
#include <cmath>


namespace pt {

namespace {

// One level from the one above: each texel the mean of the (up to) 2 × 2 texels it covers (an odd last row or
// column is averaged with itself, so a 5-wide level's last texel is its parent's last column).
TextureLevel half_level(const TextureLevel& a) {
  TextureLevel b;
  b.width = std::max(1, a.width / 2);
  b.height = std::max(1, a.height / 2);
  b.texels.resize(static_cast<size_t>(b.width) * b.height);
  for (int y = 0; y < b.height; ++y)
    for (int x = 0; x < b.width; ++x) {
      const int x0 = std::min(2 * x, a.width - 1), x1 = std::min(2 * x + 1, a.width - 1);
      const int y0 = std::min(2 * y, a.height - 1), y1 = std::min(2 * y + 1, a.height - 1);
      b.texels[static_cast<size_t>(y) * b.width + x] = 0.25f * (a.at(x0, y0) + a.at(x1, y0) + a.at(x0, y1) + a.at(x1, y1));
    }
  return b;
}

int wrap(int i, int n, TextureWrap mode) {
  switch (mode) {
    case TextureWrap::Repeat:
      return ((i % n) + n) % n;
    case TextureWrap::Clamp:
      return std::clamp(i, 0, n - 1);
    case TextureWrap::Mirror: {
      const int m = ((i % (2 * n)) + 2 * n) % (2 * n);
      return m < n ? m : 2 * n - 1 - m;
    }
  }
  return 0;
}

Rgb bilinear(const TextureLevel& l, const Texture& t, Vec2 uv) {
  // Texel centres at (i + ½)/w: the sample point in texel units minus ½ gives the lower-left neighbour.
  const float x = uv.x * static_cast<float>(l.width) - 0.5f, y = uv.y * static_cast<float>(l.height) - 0.5f;
  const float fx0 = std::floor(x), fy0 = std::floor(y);
  const float fx = x - fx0, fy = y - fy0;
  // Far outside [0, 1] the integer part would overflow: wrap it in float first (only the position mod the
  // period matters for repeat and mirror; clamp saturates anyway).
  const auto index = [](float f, int n) {
    const float period = 2.f * static_cast<float>(n);
    if (std::abs(f) > 1e6f) f = std::fmod(f, period);
    return static_cast<int>(f);
  };
  const int x0 = index(fx0, l.width), y0 = index(fy0, l.height);
  const int xa = wrap(x0, l.width, t.wrap_u), xb = wrap(x0 + 1, l.width, t.wrap_u);
  const int ya = wrap(y0, l.height, t.wrap_v), yb = wrap(y0 + 1, l.height, t.wrap_v);
  return (1.f - fy) * ((1.f - fx) * l.at(xa, ya) + fx * l.at(xb, ya)) + fy * ((1.f - fx) * l.at(xa, yb) + fx * l.at(xb, yb));
}

}  // namespace

float srgb_to_linear(float v) {
  return v <= 0.04045f ? v / 12.92f : std::pow((v + 0.055f) / 1.055f, 2.4f);
}

std::shared_ptr<const Texture> make_texture(int width, int height, const std::vector<float>& rgb, TextureWrap wrap_u,
                                            TextureWrap wrap_v, std::string source) {
  auto t = std::make_shared<Texture>();
  t->wrap_u = wrap_u;
  t->wrap_v = wrap_v;
  t->source = std::move(source);
  TextureLevel base;
  base.width = std::max(1, width);
  base.height = std::max(1, height);
  base.texels.assign(static_cast<size_t>(base.width) * base.height, Rgb(0.f));
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const size_t i = static_cast<size_t>(y) * width + x;
      if (3 * i + 2 < rgb.size()) base.texels[static_cast<size_t>(y) * base.width + x] = Rgb(rgb[3 * i], rgb[3 * i + 1], rgb[3 * i + 2]);
    }
  t->levels.push_back(std::move(base));
  while (t->levels.back().width > 1 || t->levels.back().height > 1) t->levels.push_back(half_level(t->levels.back()));
  return t;
}

Rgb texture_lookup(const Texture& t, Vec2 uv, float texels) {
  if (!std::isfinite(uv.x) || !std::isfinite(uv.y)) uv = Vec2(0.f);
  const int last = static_cast<int>(t.levels.size()) - 1;
  const float level = std::isfinite(texels) && texels > 1.f ? std::min(std::log2(texels), static_cast<float>(last)) : 0.f;
  const int l0 = static_cast<int>(level);
  const float f = level - static_cast<float>(l0);
  const Rgb a = bilinear(t.levels[l0], t, uv);
  if (f == 0.f || l0 >= last) return a;
  return (1.f - f) * a + f * bilinear(t.levels[l0 + 1], t, uv);
}

Rgb texture_lookup(const Texture& t, Vec2 uv, Vec2 major, Vec2 minor) {
  const Vec2 size(static_cast<float>(t.width()), static_cast<float>(t.height()));
  const float a = glm::length(major * size), b = glm::length(minor * size);  // in texels of level 0
  if (!std::isfinite(a) || !std::isfinite(b)) return texture_lookup(t, uv, 0.f);
  const float ratio = b > 0.f ? a / b : static_cast<float>(kMaxAnisotropy);
  const int n = std::clamp(static_cast<int>(std::ceil(ratio)), 1, kMaxAnisotropy);
  const float width = std::max(b, a / static_cast<float>(n));
  if (n == 1) return texture_lookup(t, uv, width);
  Rgb sum(0.f);
  for (int k = 0; k < n; ++k) sum += texture_lookup(t, uv + ((static_cast<float>(k) + 0.5f) / n - 0.5f) * major, width);
  return sum / static_cast<float>(n);
}

}  // namespace pt
