#include "render/metrics.h"

#include <cmath>
#include <limits>

namespace pt {

namespace {
void check_same_size(const Image& a, const Image& b) {
  if (a.width != b.width || a.height != b.height) throw ImageError("images differ in size");
}
}  // namespace

double rmse(const Image& x, const Image& ref) {
  check_same_size(x, ref);
  double s = 0;
  for (size_t i = 0; i < x.rgb.size(); ++i) s += sqr(x.rgb[i] - ref.rgb[i]);
  return std::sqrt(s / static_cast<double>(x.rgb.size()));
}

double relmse(const Image& x, const Image& ref) {
  check_same_size(x, ref);
  double s = 0;
  for (size_t i = 0; i < x.rgb.size(); ++i) {
    const double d = static_cast<double>(x.rgb[i]) - ref.rgb[i];
    s += d * d / (static_cast<double>(ref.rgb[i]) * ref.rgb[i] + 0.01);
  }
  return s / static_cast<double>(x.rgb.size());
}

glm::dvec3 mean_rgb(const Image& img) {
  glm::dvec3 s(0.0);
  for (size_t i = 0; i < img.rgb.size(); i += 3) s += glm::dvec3(img.rgb[i], img.rgb[i + 1], img.rgb[i + 2]);
  return s / static_cast<double>(img.rgb.size() / 3);
}

BlockErrors block_errors(const Image& x, const Image& ref, int block, double tolerance) {
  check_same_size(x, ref);
  if (block < 1) throw ImageError("block_errors: block size must be positive");
  BlockErrors e;
  const auto luminance = [](glm::vec3 c) {
    return kLuminanceWeights[0] * double{c.x} + kLuminanceWeights[1] * double{c.y} + kLuminanceWeights[2] * double{c.z};
  };
  for (int by = 0; by + block <= x.height; by += block)
    for (int bx = 0; bx + block <= x.width; bx += block) {
      double sx = 0, sr = 0;
      for (int y = by; y < by + block; ++y)
        for (int px = bx; px < bx + block; ++px) {
          sx += luminance(x.at(px, y));
          sr += luminance(ref.at(px, y));
        }
      ++e.blocks;
      if (sr == 0.0 && sx != 0.0) {
        ++e.off;
        ++e.black_off;
        e.black_worst = std::max(e.black_worst, sx / (block * block));
        continue;
      }
      const double rel = sr > 0 ? (sx - sr) / sr : 0.0;
      if (!(std::abs(rel) <= tolerance)) ++e.off;  // NaN (non-finite input) counts as off
      if (!(std::abs(rel) <= std::abs(e.worst))) {
        e.worst = rel;
        e.worst_x = bx;
        e.worst_y = by;
      }
    }
  return e;
}

Image block_average(const Image& img, int f) {
  if (f < 1 || img.width % f || img.height % f) throw ImageError("block_average: size not divisible by factor");
  Image out{img.width / f, img.height / f, {}};
  out.rgb.assign(3 * static_cast<size_t>(out.width) * out.height, 0.f);
  for (int y = 0; y < out.height; ++y)
    for (int x = 0; x < out.width; ++x) {
      glm::dvec3 s(0.0);
      for (int dy = 0; dy < f; ++dy)
        for (int dx = 0; dx < f; ++dx) s += glm::dvec3(img.at(x * f + dx, y * f + dy));
      s /= static_cast<double>(f * f);
      for (int c = 0; c < 3; ++c) out.rgb[3 * (static_cast<size_t>(y) * out.width + x) + c] = static_cast<float>(s[c]);
    }
  return out;
}

}  // namespace pt
