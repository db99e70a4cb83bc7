#include "lights/light_tree.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace pt {

namespace {

// cos(max(0, a − b)) and sin(max(0, a − b)) from the angles' cosines and sines (pbrt-v4 LightBounds::Importance).
float cos_sub_clamped(float sin_a, float cos_a, float sin_b, float cos_b) {
  return cos_a > cos_b ? 1.f : cos_a * cos_b + sin_a * sin_b;
}
float sin_sub_clamped(float sin_a, float cos_a, float sin_b, float cos_b) {
  return cos_a > cos_b ? 0.f : sin_a * cos_b - cos_a * sin_b;
}
float sin_of(float c) { return std::sqrt(std::max(0.f, 1.f - c * c)); }

// The cosine of the half-angle of the cone of directions from p that the box subtends (through its bounding
// sphere; −1 when p is inside that sphere). pbrt-v4 BoundSubtendedDirections.
float cos_subtended(Vec3 lo, Vec3 hi, Vec3 p) {
  const Vec3 centre = 0.5f * (lo + hi);
  const float r2 = glm::dot(hi - centre, hi - centre);
  const Vec3 d = p - centre;
  const float d2 = glm::dot(d, d);
  if (d2 < r2 || !(d2 > 0.f)) return -1.f;
  return std::sqrt(std::max(0.f, 1.f - r2 / d2));
}

}  // namespace

float light_importance(const LightBounds& b, Vec3 p, Vec3 n) {
  if (!(b.phi > 0.f)) return 0.f;
  const Vec3 centre = 0.5f * (b.lo + b.hi);
  const Vec3 to_p = p - centre;
  const float dist2 = glm::dot(to_p, to_p);
  // Clamped below by half the box's diagonal (pbrt-v4: a receiver close to a large node is not favoured without
  // bound), and by a tiny floor for a point light at the receiver itself.
  const float d2 = std::max({dist2, 0.5f * glm::length(b.hi - b.lo), 1e-20f});
  const Vec3 wi = dist2 > 0.f ? to_p / std::sqrt(dist2) : b.w;
  float cos_w = glm::dot(b.w, wi);
  if (b.two_sided) cos_w = std::abs(cos_w);
  const float sin_w = sin_of(cos_w);
  const float cos_b = cos_subtended(b.lo, b.hi, p), sin_b = sin_of(cos_b);
  const float sin_o = sin_of(b.cos_theta_o);
  const float cos_x = cos_sub_clamped(sin_w, cos_w, sin_o, b.cos_theta_o);
  const float sin_x = sin_sub_clamped(sin_w, cos_w, sin_o, b.cos_theta_o);
  const float cos_p = cos_sub_clamped(sin_x, cos_x, sin_b, cos_b);
  if (!(cos_p > b.cos_theta_e)) return 0.f;
  float importance = b.phi * cos_p / d2;
  if (n != Vec3(0.f)) {
    const float cos_i = std::abs(glm::dot(wi, n));
    importance *= cos_sub_clamped(sin_of(cos_i), cos_i, sin_b, cos_b);
  }
  if (!(importance > 0.f)) return 0.f;
  return std::min(importance, std::numeric_limits<float>::max());
}

LightBounds light_bounds_union(const LightBounds& a, const LightBounds& b) {
  if (!(a.phi > 0.f)) return b;
  if (!(b.phi > 0.f)) return a;
  LightBounds u;
  u.lo = glm::min(a.lo, b.lo);
  u.hi = glm::max(a.hi, b.hi);
  u.phi = a.phi + b.phi;
  u.cos_theta_e = std::min(a.cos_theta_e, b.cos_theta_e);
  u.two_sided = a.two_sided || b.two_sided;
  // The union of the two cones of normals (pbrt-v4 Union(DirectionCone, DirectionCone)), in double.
  const double pi = std::numbers::pi;
  const double theta_a = std::acos(std::clamp(double(a.cos_theta_o), -1.0, 1.0));
  const double theta_b = std::acos(std::clamp(double(b.cos_theta_o), -1.0, 1.0));
  const DVec3 wa = glm::normalize(DVec3(a.w)), wb = glm::normalize(DVec3(b.w));
  const double theta_d = std::acos(std::clamp(glm::dot(wa, wb), -1.0, 1.0));
  u.w = a.w;
  u.cos_theta_o = -1.f;  // the whole sphere, unless a narrower cone holds both
  if (std::min(theta_d + theta_b, pi) <= theta_a) {
    u.cos_theta_o = a.cos_theta_o;
  } else if (std::min(theta_d + theta_a, pi) <= theta_b) {
    u.w = b.w;
    u.cos_theta_o = b.cos_theta_o;
  } else {
    const double theta_o = 0.5 * (theta_a + theta_d + theta_b);
    const DVec3 axis = glm::cross(wa, wb);
    if (theta_o < pi && glm::dot(axis, axis) > 0.0) {
      // wa turned by theta_o − theta_a about the axis towards wb (Rodrigues' rotation formula).
      const DVec3 k = glm::normalize(axis);
      const double r = theta_o - theta_a;
      const DVec3 w = wa * std::cos(r) + glm::cross(k, wa) * std::sin(r) + k * glm::dot(k, wa) * (1.0 - std::cos(r));
      u.w = Vec3(glm::normalize(w));
      // Rounded outwards, so that float arithmetic never makes the cone narrower than its lights.
      u.cos_theta_o = std::max(-1.f, static_cast<float>(std::cos(theta_o)) - 1e-5f);
    }
  }
  return u;
}

LightTree::LightTree(const std::vector<LightBounds>& bounds, const std::vector<uint32_t>& lights,
                     const std::vector<float>& light_pmf)
    : trail_(light_pmf.size()) {
  if (bounds.empty()) return;
  std::vector<char> in_tree(light_pmf.size(), 0);
  double share = 0.0;
  for (uint32_t li : lights) {
    in_tree[li] = 1;
    share += light_pmf[li];
  }
  share_ = static_cast<float>(share);
  double total = 0.0;
  std::vector<double> cumulative;
  for (size_t li = 0; li < light_pmf.size(); ++li) {
    if (in_tree[li] || !(light_pmf[li] > 0.f)) continue;
    total += light_pmf[li];
    cumulative.push_back(total);
    top_light_.push_back(static_cast<int32_t>(li));
  }
  total += share;
  cumulative.push_back(total);
  top_light_.push_back(-1);
  for (double c : cumulative) top_cdf_.push_back(static_cast<float>(c / total));
  top_cdf_.back() = 1.f;
  std::vector<uint32_t> order(bounds.size());
  for (uint32_t i = 0; i < order.size(); ++i) order[i] = i;
  nodes_.reserve(2 * bounds.size());
  build(order, 0, order.size(), bounds, lights, 0, 0);
}

uint32_t LightTree::build(std::vector<uint32_t>& order, size_t first, size_t last,
                          const std::vector<LightBounds>& bounds, const std::vector<uint32_t>& lights, uint64_t bits,
                          int depth) {
  const uint32_t index = static_cast<uint32_t>(nodes_.size());
  nodes_.emplace_back();
  if (last - first == 1) {
    const uint32_t i = order[first];
    nodes_[index].bounds = bounds[i];
    nodes_[index].light = static_cast<int32_t>(lights[i]);
    trail_[lights[i]] = {bits, depth};
    return index;
  }
  // Split at the median of the box centres along their widest axis.
  Vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
  for (size_t k = first; k < last; ++k) {
    const Vec3 c = 0.5f * (bounds[order[k]].lo + bounds[order[k]].hi);
    lo = glm::min(lo, c);
    hi = glm::max(hi, c);
  }
  const Vec3 extent = hi - lo;
  const int axis = extent.x >= extent.y && extent.x >= extent.z ? 0 : extent.y >= extent.z ? 1 : 2;
  const size_t mid = first + (last - first) / 2;
  std::nth_element(order.begin() + static_cast<std::ptrdiff_t>(first), order.begin() + static_cast<std::ptrdiff_t>(mid),
                   order.begin() + static_cast<std::ptrdiff_t>(last), [&](uint32_t a, uint32_t b) {
                     const float ca = bounds[a].lo[axis] + bounds[a].hi[axis];
                     const float cb = bounds[b].lo[axis] + bounds[b].hi[axis];
                     return ca < cb || (ca == cb && a < b);
                   });
  build(order, first, mid, bounds, lights, bits, depth + 1);
  const uint32_t second = build(order, mid, last, bounds, lights, bits | (uint64_t{1} << depth), depth + 1);
  nodes_[index].second = second;
  nodes_[index].bounds = light_bounds_union(nodes_[index + 1].bounds, nodes_[second].bounds);
  return index;
}

// The probability of inner node i's first child for the receiver (p, n), from the two children's importances
// (−1: neither can reach it). In double, so that huge importances neither overflow nor lose the smaller one.
// sample() and pmf() both descend through it, so they multiply the same floats.
float LightTree::first_child_probability(uint32_t i, Vec3 p, Vec3 n) const {
  const float c0 = light_importance(nodes_[i + 1].bounds, p, n);
  const float c1 = light_importance(nodes_[nodes_[i].second].bounds, p, n);
  if (!(c0 > 0.f) && !(c1 > 0.f)) return -1.f;
  return static_cast<float>(double(c0) / (double(c0) + double(c1)));
}

int LightTree::choose(Vec3 p, Vec3 n, float u, const std::vector<float>& light_pmf, float& pmf) const {
  const size_t k = std::min<size_t>(
      static_cast<size_t>(std::upper_bound(top_cdf_.begin(), top_cdf_.end(), u) - top_cdf_.begin()), top_cdf_.size() - 1);
  if (top_light_[k] >= 0) {
    pmf = light_pmf[static_cast<size_t>(top_light_[k])];
    return top_light_[k];
  }
  // u rescaled within the tree's interval: a fresh uniform number for the descent.
  const float c0 = k > 0 ? top_cdf_[k - 1] : 0.f, c1 = top_cdf_[k];
  const float v = c1 > c0 ? std::clamp((u - c0) / (c1 - c0), 0.f, kOneMinusEpsilon) : 0.f;
  return sample(p, n, v, pmf);
}

int LightTree::sample(Vec3 p, Vec3 n, float u, float& pmf) const {
  pmf = 0.f;
  if (nodes_.empty()) return -1;
  float prob = share_;
  uint32_t i = 0;
  while (nodes_[i].light < 0) {
    const Node& node = nodes_[i];
    const float p0 = first_child_probability(i, p, n);
    if (p0 < 0.f) return -1;
    if (u < p0) {
      u = std::min(u / p0, kOneMinusEpsilon);
      prob *= p0;
      i = i + 1;
    } else {
      u = std::min((u - p0) / (1.f - p0), kOneMinusEpsilon);
      prob *= 1.f - p0;
      i = node.second;
    }
  }
  // A tree of one light: its own importance decides whether it can reach the receiver.
  if (i == 0 && !(light_importance(nodes_[0].bounds, p, n) > 0.f)) return -1;
  pmf = prob;
  return nodes_[i].light;
}

float LightTree::pmf(Vec3 p, Vec3 n, int li) const {
  if (!contains(li)) return 0.f;
  const Trail& t = trail_[static_cast<size_t>(li)];
  float prob = share_;
  uint32_t i = 0;
  for (int k = 0; k < t.depth; ++k) {
    const Node& node = nodes_[i];
    const float p0 = first_child_probability(i, p, n);
    if (p0 < 0.f) return 0.f;
    if ((t.bits >> k) & 1u) {
      prob *= 1.f - p0;
      i = node.second;
    } else {
      prob *= p0;
      i = i + 1;
    }
  }
  if (i == 0 && !(light_importance(nodes_[0].bounds, p, n) > 0.f)) return 0.f;
  return prob;
}

}  // namespace pt
