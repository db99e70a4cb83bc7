#include "film/film.h"

#include <stdexcept>
#include <string>

#include <limits>

namespace pt {

void Film::reset(int width, int height) {
  width_ = width;
  height_ = height;
  const size_t n = static_cast<size_t>(width) * static_cast<size_t>(height);
  count_.assign(n, 0);
  attempts_.assign(n, 0);
  sum_.assign(6 * n, 0.0);
  m2_.assign(3 * n, 0.0);
  feature_.assign(features_enabled_ ? kFeatureStride * n : 0, 0.0);
  half_count_.assign(features_enabled_ ? n : 0, 0);
  half_mean_.assign(features_enabled_ ? 3 * n : 0, 0.0);
  rejected_.store(0);
}

void Film::enable_features(bool on) {
  if (on == features_enabled_) return;
  features_enabled_ = on;
  reset(width_, height_);
}

void Film::start_at(uint32_t first) { attempts_.assign(count_.size(), first); }

void Film::merge(const Film& o) {
  if (o.width_ != width_ || o.height_ != height_)
    throw std::invalid_argument("films of different sizes (" + std::to_string(width_) + "x" + std::to_string(height_) +
                                " and " + std::to_string(o.width_) + "x" + std::to_string(o.height_) + ")");
  if (o.features_enabled_ != features_enabled_) throw std::invalid_argument("one film has feature buffers, the other not");
  for (size_t i = 0; i < count_.size(); ++i) {
    const uint32_t nb = o.count_[i];
    attempts_[i] = std::max(attempts_[i], o.attempts_[i]);
    if (nb == 0) continue;
    const uint32_t na = count_[i];
    const double n = static_cast<double>(na) + nb;
    const double wb = nb / n, cross = static_cast<double>(na) * nb / n;
    for (int c = 0; c < 3; ++c) {
      const double delta = o.mean_channel(i, c) - mean_channel(i, c);
      m2_[3 * i + c] += o.m2_[3 * i + c] + delta * delta * cross;
      add_pair(sum_[6 * i + 2 * c], sum_[6 * i + 2 * c + 1], o.sum_[6 * i + 2 * c], o.sum_[6 * i + 2 * c + 1]);
    }
    count_[i] = na + nb;
    if (features_enabled_) {
      for (size_t c = 0; c < kFeatureStride; ++c) {
        double& x = feature_[kFeatureStride * i + c];
        x += (o.feature_[kFeatureStride * i + c] - x) * wb;
      }
      const uint32_t ha = half_count_[i], hb = o.half_count_[i];
      if (hb > 0) {
        const double hw = static_cast<double>(hb) / (static_cast<double>(ha) + hb);
        for (int c = 0; c < 3; ++c) half_mean_[3 * i + c] += (o.half_mean_[3 * i + c] - half_mean_[3 * i + c]) * hw;
        half_count_[i] = ha + hb;
      }
    }
  }
  rejected_.fetch_add(o.rejected());
}

glm::dvec3 Film::variance_of_mean(size_t i) const {
  const double n = count_[i];
  if (n < 2) return glm::dvec3(std::numeric_limits<double>::infinity());
  return glm::dvec3(m2_[3 * i], m2_[3 * i + 1], m2_[3 * i + 2]) / ((n - 1.0) * n);
}

double Film::estimated_relmse() const { return estimated_relmse(full_rect(width_, height_)); }

double Film::estimated_relmse(const PixelRect& region) const {
  const PixelRect r = region.clipped(width_, height_);
  if (r.empty()) return std::numeric_limits<double>::infinity();
  double sum = 0.0;
  for (int y = r.y0; y < r.y1; ++y)
    for (int x = r.x0; x < r.x1; ++x) {
      const size_t i = static_cast<size_t>(y) * static_cast<size_t>(width_) + static_cast<size_t>(x);
      const double n = count_[i];
      if (n < 2) return std::numeric_limits<double>::infinity();
      const double inv = 1.0 / ((n - 1.0) * n);
      for (int c = 0; c < 3; ++c) {
        const double m = mean_channel(i, c);
        sum += m2_[3 * i + c] * inv / (m * m + 0.01);
      }
    }
  return sum / (3.0 * static_cast<double>(r.area()));
}

uint32_t Film::min_count(const PixelRect& region) const {
  const PixelRect r = region.clipped(width_, height_);
  if (r.empty()) return 0;
  uint32_t m = std::numeric_limits<uint32_t>::max();
  for (int y = r.y0; y < r.y1; ++y)
    for (int x = r.x0; x < r.x1; ++x) m = std::min(m, count_[static_cast<size_t>(y) * static_cast<size_t>(width_) + static_cast<size_t>(x)]);
  return m;
}

uint32_t Film::min_count() const { return min_count(full_rect(width_, height_)); }

uint64_t Film::total_count() const {
  uint64_t t = 0;
  for (uint32_t c : count_) t += c;
  return t;
}

std::vector<float> Film::mean_image() const {
  std::vector<float> img;
  mean_image(img);
  return img;
}

void Film::mean_image(std::vector<float>& img) const {
  img.resize(3 * count_.size());
  for (size_t i = 0; i < count_.size(); ++i)
    for (int c = 0; c < 3; ++c) img[3 * i + c] = static_cast<float>(mean_channel(i, c));
}

std::vector<float> Film::feature_image(size_t first, size_t channels) const {
  std::vector<float> img;
  feature_image(first, channels, img);
  return img;
}

void Film::feature_image(size_t first, size_t channels, std::vector<float>& img) const {
  img.assign(channels * count_.size(), 0.f);
  if (!features_enabled_) return;
  for (size_t i = 0; i < count_.size(); ++i)
    for (size_t c = 0; c < channels; ++c) img[channels * i + c] = static_cast<float>(feature_[kFeatureStride * i + first + c]);
}

std::vector<float> Film::variance_image() const {
  std::vector<float> img;
  variance_image(img);
  return img;
}

void Film::variance_image(std::vector<float>& img) const {
  img.resize(3 * count_.size());
  for (size_t i = 0; i < count_.size(); ++i) {
    const glm::dvec3 v = variance_of_mean(i);
    for (int c = 0; c < 3; ++c) img[3 * i + c] = static_cast<float>(v[c]);
  }
}

std::vector<float> Film::count_image() const {
  std::vector<float> img(count_.size());
  for (size_t i = 0; i < count_.size(); ++i) img[i] = static_cast<float>(count_[i]);
  return img;
}

std::vector<float> Film::half_image(int half) const {
  std::vector<float> img(3 * count_.size(), 0.f);
  if (!features_enabled_) return img;
  for (size_t i = 0; i < count_.size(); ++i) {
    const double n = count_[i], na = half_count_[i];
    for (int c = 0; c < 3; ++c) {
      const double a = half_mean_[3 * i + c];
      // Half B's mean from the total: (n·mean − n_A·mean_A)/(n − n_A).
      const double value = half == 0 ? (na > 0 ? a : 0.0) : (n > na ? (n * mean_channel(i, c) - na * a) / (n - na) : 0.0);
      img[3 * i + c] = static_cast<float>(value);
    }
  }
  return img;
}

}  // namespace pt
