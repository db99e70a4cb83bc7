#include "lights/light_tree.h"

#include <algorithm>
#include <cmath>
#include <experimental/simd>
#include <limits>
#include <numbers>

#include "core/lanes.h"

namespace pt {

namespace {

namespace stdx = std::experimental;
using FW = stdx::fixed_size_simd<float, kTreeWidth>;
using MW = FW::mask_type;

[[gnu::always_inline]] inline FW load(const float* a) { return FW(a, stdx::element_aligned); }
// std::max(0, x) as the standard defines it ((a < b) ? b : a), lane by lane.
[[gnu::always_inline]] inline FW max0(const FW& x) { return select(FW(0.f) < x, x, FW(0.f)); }
// √max(0, 1 − c²): the sine of an angle from its cosine.
[[gnu::always_inline]] inline FW sin_of(const FW& c) { return stdx::sqrt(max0(1.f - c * c)); }
// cos(max(0, a − b)) and sin(max(0, a − b)) from the angles' cosines and sines (pbrt-v4 LightBounds::Importance).
[[gnu::always_inline]] inline FW cos_sub_clamped(const FW& sin_a, const FW& cos_a, const FW& sin_b, const FW& cos_b) {
  return select(cos_a > cos_b, FW(1.f), cos_a * cos_b + sin_a * sin_b);
}
[[gnu::always_inline]] inline FW sin_sub_clamped(const FW& sin_a, const FW& cos_a, const FW& sin_b, const FW& cos_b) {
  return select(cos_a > cos_b, FW(0.f), sin_a * cos_b - cos_a * sin_b);
}

}  // namespace

void ImportanceLanes::set(int lane, const LightBounds& b) {
  const Vec3 centre = 0.5f * (b.lo + b.hi);
  cx[lane] = centre.x, cy[lane] = centre.y, cz[lane] = centre.z;
  // d² is clamped below by half the box's diagonal (pbrt-v4: a receiver close to a large node is not favoured
  // without bound), and by a tiny floor for a point light at the receiver itself.
  d2_floor[lane] = std::max(0.5f * glm::length(b.hi - b.lo), 1e-20f);
  wx[lane] = b.w.x, wy[lane] = b.w.y, wz[lane] = b.w.z;
  r2[lane] = glm::dot(b.hi - centre, b.hi - centre);
  phi[lane] = b.phi;
  cos_theta_o[lane] = b.cos_theta_o;
  sin_theta_o[lane] = std::sqrt(std::max(0.f, 1.f - b.cos_theta_o * b.cos_theta_o));
  cos_theta_e[lane] = b.cos_theta_e;
  two_sided[lane] = b.two_sided ? 1.f : 0.f;
}

// pbrt-v4's LightBounds::Importance, kTreeWidth bounds at a time: phi · cos θ' / d² · cos θ'_i (light_tree.h).
void ImportanceLanes::importance(Vec3 p, Vec3 n, float out[kTreeWidth]) const {
  const FW tx = p.x - load(cx), ty = p.y - load(cy), tz = p.z - load(cz);
  const FW dist2 = (tx * tx + ty * ty) + tz * tz;
  const FW d2 = select(dist2 < load(d2_floor), load(d2_floor), dist2);
  const MW away = dist2 > 0.f;
  const FW len = stdx::sqrt(dist2);
  const FW Wx = load(wx), Wy = load(wy), Wz = load(wz);
  const FW wix = select(away, tx / len, Wx), wiy = select(away, ty / len, Wy), wiz = select(away, tz / len, Wz);
  FW cos_w = (Wx * wix + Wy * wiy) + Wz * wiz;
  cos_w = select(load(two_sided) != 0.f, stdx::abs(cos_w), cos_w);
  const FW sin_w = sin_of(cos_w);
  // The half-angle of the cone of directions from p that the box subtends, through its bounding sphere (−1 when
  // p is inside it; pbrt-v4 BoundSubtendedDirections).
  const FW R2 = load(r2);
  const FW cos_b = select(dist2 < R2 || !away, FW(-1.f), stdx::sqrt(max0(1.f - R2 / dist2)));
  const FW sin_b = sin_of(cos_b);
  const FW cos_o = load(cos_theta_o), sin_o = load(sin_theta_o);
  const FW cos_x = cos_sub_clamped(sin_w, cos_w, sin_o, cos_o);
  const FW sin_x = sin_sub_clamped(sin_w, cos_w, sin_o, cos_o);
  const FW cos_p = cos_sub_clamped(sin_x, cos_x, sin_b, cos_b);
  const FW Phi = load(phi);
  FW importance = (Phi * cos_p) / d2;
  if (n != Vec3(0.f)) {
    const FW cos_i = stdx::abs((wix * n.x + wiy * n.y) + wiz * n.z);
    importance *= cos_sub_clamped(sin_of(cos_i), cos_i, sin_b, cos_b);
  }
  const MW reaches = Phi > 0.f && cos_p > load(cos_theta_e) && importance > 0.f;
  const FW big(std::numeric_limits<float>::max());
  importance = select(big < importance, big, importance);
  select(reaches, importance, FW(0.f)).copy_to(out, stdx::element_aligned);
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
  std::vector<BinaryNode> binary;
  binary.reserve(2 * bounds.size());
  build(binary, order, 0, order.size(), bounds, lights);
  nodes_.reserve(bounds.size());
  if (binary[0].light >= 0) {  // one light: a root with one child
    nodes_.emplace_back();
    nodes_[0].bounds.set(0, binary[0].bounds);
    nodes_[0].child[0] = -binary[0].light - 1;
    trail_[static_cast<size_t>(binary[0].light)] = {0, 1};
    return;
  }
  fold(binary, 0, 0, 0);
}

uint32_t LightTree::build(std::vector<BinaryNode>& nodes, std::vector<uint32_t>& order, size_t first, size_t last,
                          const std::vector<LightBounds>& bounds, const std::vector<uint32_t>& lights) {
  const uint32_t index = static_cast<uint32_t>(nodes.size());
  nodes.emplace_back();
  if (last - first == 1) {
    const uint32_t i = order[first];
    nodes[index].bounds = bounds[i];
    nodes[index].light = static_cast<int32_t>(lights[i]);
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
  build(nodes, order, first, mid, bounds, lights);
  const uint32_t second = build(nodes, order, mid, last, bounds, lights);
  nodes[index].second = second;
  nodes[index].bounds = light_bounds_union(nodes[index + 1].bounds, nodes[second].bounds);
  return index;
}

uint32_t LightTree::fold(const std::vector<BinaryNode>& binary, uint32_t b, uint64_t lanes, int depth) {
  // The children: the binary node's descendants kTreeWidth at most, inner ones opened shallowest first (so a
  // balanced subtree gives its kTreeWidth nodes log2(kTreeWidth) levels down), leaves as they are.
  uint32_t kids[kTreeWidth] = {b + 1, binary[b].second};
  int count = 2;
  for (int k = 0; k < count && count < kTreeWidth; ++k) {
    if (binary[kids[k]].light >= 0) continue;
    const uint32_t inner = kids[k];
    for (int j = k; j + 1 < count; ++j) kids[j] = kids[j + 1];  // the inner node leaves, its children join last
    kids[count - 1] = inner + 1;
    kids[count++] = binary[inner].second;
    --k;
  }
  const uint32_t index = static_cast<uint32_t>(nodes_.size());
  nodes_.emplace_back();
  for (int k = 0; k < count; ++k) {
    const BinaryNode& kid = binary[kids[k]];
    nodes_[index].bounds.set(k, kid.bounds);
    const uint64_t path = lanes | (static_cast<uint64_t>(k) << (kLaneBits * depth));
    if (kid.light >= 0) {
      nodes_[index].child[k] = -kid.light - 1;
      trail_[static_cast<size_t>(kid.light)] = {path, depth + 1};
    } else {
      nodes_[index].child[k] = static_cast<int32_t>(fold(binary, kids[k], path, depth + 1));
    }
  }
  return index;
}

bool LightTree::child_probabilities(uint32_t i, Vec3 p, Vec3 n, float prob[kTreeWidth]) const {
  float c[kTreeWidth];
  nodes_[i].bounds.importance(p, n, c);
  double sum = 0.0;
  for (int k = 0; k < kTreeWidth; ++k) sum += double(c[k]);
  if (!(sum > 0.0)) return false;
  const double inv = 1.0 / sum;
  for (int k = 0; k < kTreeWidth; ++k) prob[k] = static_cast<float>(double(c[k]) * inv);
  return true;
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
  for (;;) {
    float pk[kTreeWidth];
    if (!child_probabilities(i, p, n, pk)) return -1;
    // The child whose interval of the running sums holds u; rounding may leave u past the last sum: then the last
    // child with a chance.
    int k = -1;
    float below = 0.f, start = 0.f;
    for (int j = 0; j < kTreeWidth; ++j) {
      if (!(pk[j] > 0.f)) continue;
      k = j;
      start = below;
      below += pk[j];
      if (u < below) break;
    }
    u = std::clamp((u - start) / pk[k], 0.f, kOneMinusEpsilon);
    prob *= pk[k];
    const int32_t child = nodes_[i].child[k];
    if (child < 0) {
      pmf = prob;
      return -child - 1;
    }
    i = static_cast<uint32_t>(child);
  }
}

float LightTree::pmf(Vec3 p, Vec3 n, int li) const {
  if (!contains(li)) return 0.f;
  const Trail& t = trail_[static_cast<size_t>(li)];
  float prob = share_;
  uint32_t i = 0;
  for (int d = 0; d < t.depth; ++d) {
    float pk[kTreeWidth];
    if (!child_probabilities(i, p, n, pk)) return 0.f;
    const int k = static_cast<int>((t.lanes >> (kLaneBits * d)) & (kTreeWidth - 1));
    if (!(pk[k] > 0.f)) return 0.f;
    prob *= pk[k];
    i = static_cast<uint32_t>(nodes_[i].child[k]);
  }
  return prob;
}

}  // namespace pt
