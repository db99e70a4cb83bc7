#include "geometry/polygon_bvh.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <future>
#include <numeric>
#include <stdexcept>
#include <system_error>

namespace pt {

namespace {

struct Box {
  Vec3 lo{kInfinity}, hi{-kInfinity};
  void grow(const Box& b) {
    lo = glm::min(lo, b.lo);
    hi = glm::max(hi, b.hi);
  }
  void grow(Vec3 p) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  // Half the surface area (the SAH only compares areas); 0 for an empty box.
  double half_area() const {
    if (!(lo.x <= hi.x)) return 0.0;
    const DVec3 e = DVec3(hi) - DVec3(lo);
    return e.x * e.y + e.y * e.z + e.z * e.x;
  }
};

// The binary tree the SAH builds, collapsed afterwards. A leaf covers order[first, first + count).
struct BinaryNode {
  Box box;
  uint32_t left = 0, right = 0;  // children (inner nodes)
  uint32_t first = 0, count = 0;  // count > 0: a leaf
};

constexpr int kBins = 32;
// Leaves this small are never split: up to 8 polygons are one 4- or 8-lane block test, which costs about one box
// test (bench rays on cornell-bunny: +4 % closest hit against splitting down to 4 by the SAH, session 30).
constexpr uint32_t kLeafAlways = kBvhMaxLeaf;
// Below this many polygons a subtree is built on the calling thread; above, its two halves run concurrently.
constexpr uint32_t kParallelSubtree = 1u << 15;

class BinaryBuilder {
 public:
  BinaryBuilder(const std::vector<Box>& boxes, const std::vector<Vec3>& centroids, std::vector<uint32_t>& order)
      : boxes_(boxes), centroids_(centroids), order_(order), nodes_(2 * std::max<size_t>(order.size(), 1)) {}

  uint32_t build(uint32_t first, uint32_t count, int depth) {
    const uint32_t index = next_node_++;
    BinaryNode& node = nodes_[index];
    Box box, centroid_box;
    for (uint32_t i = first; i < first + count; ++i) {
      box.grow(boxes_[order_[i]]);
      centroid_box.grow(centroids_[order_[i]]);
    }
    node.box = box;
    const uint32_t split = choose_split(first, count, centroid_box, depth);
    if (split == 0) {
      node.first = first;
      node.count = count;
      return index;
    }
    uint32_t left, right;
    std::future<uint32_t> l;
    if (count >= kParallelSubtree) {
      try {
        l = std::async(std::launch::async, [&] { return build(first, split, depth + 1); });
      } catch (const std::system_error&) {
        // No thread to be had (a process or memory limit): the subtree is built here. Found under ulimit -v,
        // where the render failed with "Resource temporarily unavailable" instead of finishing.
      }
    }
    if (l.valid()) {
      right = build(first + split, count - split, depth + 1);
      left = l.get();
    } else {
      left = build(first, split, depth + 1);
      right = build(first + split, count - split, depth + 1);
    }
    node.left = left;
    node.right = right;
    return index;
  }

  std::vector<BinaryNode>& nodes() { return nodes_; }

 private:
  // Partitions order[first, first + count) and returns the size of the left part, or 0 for a leaf.
  uint32_t choose_split(uint32_t first, uint32_t count, const Box& centroid_box, int depth) {
    if (count <= kLeafAlways) return 0;
    const Vec3 extent = centroid_box.hi - centroid_box.lo;
    uint32_t* begin = order_.data() + first;
    uint32_t* end = begin + count;
    // All centroids in one point (or a runaway depth): halve by index, which bounds the depth by log2(n).
    if (!(std::max({extent.x, extent.y, extent.z}) > 0.f) || depth > kBvhSahMaxDepth) return count / 2;
    // Binned SAH on every axis (Wald 2007), the best split of the three.
    double best_cost = std::numeric_limits<double>::infinity();
    int best_axis = -1, best_bin = -1;
    for (int axis = 0; axis < 3; ++axis) {
      if (!(extent[axis] > 0.f)) continue;
      std::array<Box, kBins> bin_box;
      std::array<uint32_t, kBins> bin_count{};
      const Binning binning(centroid_box.lo[axis], extent[axis], axis);
      for (const uint32_t* p = begin; p != end; ++p) {
        const int b = binning.bin(centroids_[*p]);
        bin_box[b].grow(boxes_[*p]);
        ++bin_count[b];
      }
      // Sweep: cost of splitting after bin b = A(left)·n(left) + A(right)·n(right), relative to A(node). (Counting
      // leaf tests of 8 polygons instead of polygons was tried: the bunny's shadow rays 7 % slower, session 30.)
      std::array<double, kBins> right_cost{};
      Box acc;
      uint32_t n = 0;
      for (int b = kBins - 1; b > 0; --b) {
        acc.grow(bin_box[b]);
        n += bin_count[b];
        right_cost[b] = acc.half_area() * n;
      }
      acc = Box{};
      n = 0;
      for (int b = 0; b < kBins - 1; ++b) {
        acc.grow(bin_box[b]);
        n += bin_count[b];
        if (n == 0 || n == count) continue;
        const double cost = acc.half_area() * n + right_cost[b + 1];
        if (cost < best_cost) {
          best_cost = cost;
          best_axis = axis;
          best_bin = b;
        }
      }
    }
    if (best_axis < 0) return count / 2;
    const Binning binning(centroid_box.lo[best_axis], extent[best_axis], best_axis);
    uint32_t* mid = std::partition(begin, end, [&](uint32_t p) { return binning.bin(centroids_[p]) <= best_bin; });
    return static_cast<uint32_t>(mid - begin);
  }

  // The bin of a centroid along one axis.
  struct Binning {
    float lo, scale;
    int axis;
    Binning(float lo_, float extent, int axis_) : lo(lo_), scale(kBins * (1.f - 1e-6f) / extent), axis(axis_) {}
    int bin(const Vec3& c) const { return std::min(kBins - 1, static_cast<int>((c[axis] - lo) * scale)); }
  };

  const std::vector<Box>& boxes_;
  const std::vector<Vec3>& centroids_;
  std::vector<uint32_t>& order_;
  std::vector<BinaryNode> nodes_;
  std::atomic<uint32_t> next_node_{0};
};

// Collapses the binary tree into 8-wide nodes and lays the leaves' polygons out in lanes.
class Collapser {
 public:
  Collapser(const std::vector<BinaryNode>& binary, const std::vector<uint32_t>& order,
            const std::vector<uint8_t>& is_triangle, PolygonBvh& out)
      : binary_(binary), order_(order), is_triangle_(is_triangle), out_(out) {}

  // The root: a lone leaf still goes below a node, so traversal always starts at a node.
  void run() {
    if (binary_[0].count > 0) {
      wide_node({0});
      return;
    }
    wide_node({binary_[0].left, binary_[0].right});
  }

 private:
  uint32_t wide_node(std::vector<uint32_t> children) {
    // Open the inner child of largest area until 8 children.
    while (children.size() < static_cast<size_t>(kBvhWidth)) {
      int best = -1;
      double best_area = -1.0;
      for (size_t k = 0; k < children.size(); ++k) {
        const BinaryNode& c = binary_[children[k]];
        if (c.count == 0 && c.box.half_area() > best_area) {
          best_area = c.box.half_area();
          best = static_cast<int>(k);
        }
      }
      if (best < 0) break;
      const BinaryNode& c = binary_[children[best]];
      children[best] = c.left;
      children.push_back(c.right);
    }
    if (out_.nodes.size() >= kBvhMaxNodes)  // a node's reference keeps its index in 30 bits
      throw std::length_error("polygon hierarchy: more than 2^30 nodes");
    const uint32_t index = static_cast<uint32_t>(out_.nodes.size());
    out_.nodes.emplace_back();
    for (int k = 0; k < kBvhWidth; ++k) {
      // Written through the index: the recursion below may reallocate the node array.
      BvhNode& n = out_.nodes[index];
      if (k >= static_cast<int>(children.size())) {
        for (int a = 0; a < 3; ++a) n.lo[a][k] = n.hi[a][k] = kInfinity;
        n.child[k] = inner_ref(0);
        continue;
      }
      const BinaryNode& c = binary_[children[k]];
      for (int a = 0; a < 3; ++a) {
        n.lo[a][k] = c.box.lo[a];
        n.hi[a][k] = c.box.hi[a];
      }
      if (c.count > 0) {
        const uint8_t lanes = c.count <= 4 ? 4 : 8;
        if (out_.lane_polygon.size() + lanes > kBvhMaxLanes)  // a leaf's reference keeps its first lane in 31 bits
          throw std::length_error("polygon hierarchy: more than 2^31 lanes");
        bool triangles = true;
        for (uint32_t i = 0; i < c.count; ++i) triangles = triangles && is_triangle_[order_[c.first + i]] != 0;
        n.child[k] = leaf_ref(static_cast<uint32_t>(out_.lane_polygon.size()), lanes, triangles);
        for (uint32_t i = 0; i < lanes; ++i)
          out_.lane_polygon.push_back(i < c.count ? order_[c.first + i] : kNoLanePolygon);
      } else {
        const uint32_t child = wide_node({c.left, c.right});
        out_.nodes[index].child[k] = inner_ref(child);
      }
    }
    return index;
  }

  const std::vector<BinaryNode>& binary_;
  const std::vector<uint32_t>& order_;
  const std::vector<uint8_t>& is_triangle_;
  PolygonBvh& out_;
};

}  // namespace

namespace {

// The build over n polygons whose vertex k is vertex(i, k) (k < 4; a triangle repeats vertex 0 as 3) and
// which are triangles where triangle(i).
template <class Vertex, class IsTriangle>
PolygonBvh build(size_t n, const Vertex& vertex, const IsTriangle& triangle) {
  PolygonBvh bvh;
  if (n == 0) return bvh;
  std::vector<Box> boxes(n);
  std::vector<Vec3> centroids(n);
  for (size_t i = 0; i < n; ++i) {
    for (int k = 0; k < 4; ++k) boxes[i].grow(vertex(i, k));
    centroids[i] = 0.5f * (boxes[i].lo + boxes[i].hi);
  }
  std::vector<uint32_t> order(n);
  std::iota(order.begin(), order.end(), 0u);
  BinaryBuilder builder(boxes, centroids, order);
  builder.build(0, static_cast<uint32_t>(n), 0);
  std::vector<uint8_t> is_triangle(n);
  for (size_t i = 0; i < n; ++i) is_triangle[i] = triangle(i) ? 1 : 0;
  bvh.nodes.reserve(n / 4 + 1);
  bvh.lane_polygon.reserve(n * 2);
  Collapser(builder.nodes(), order, is_triangle, bvh).run();

  // The leaves' polygons, leaf by leaf (kLeafFloatsPerLane), each leaf found through its reference in a node;
  // padding lanes hold NaN (they never hit).
  const size_t lanes = bvh.lane_polygon.size();
  bvh.leaf_data.assign(lanes * kLeafFloatsPerLane, std::numeric_limits<float>::quiet_NaN());
  bvh.polygon_lane.assign(n, kNoLanePolygon);
  for (const BvhNode& node : bvh.nodes) {
    for (int k = 0; k < kBvhWidth; ++k) {
      if (!is_leaf_ref(node.child[k])) continue;  // an inner child, or an unused slot (inner_ref(0))
      const uint32_t first = ref_first_lane(node.child[k]);
      const int width = ref_lanes(node.child[k]);
      float* block = bvh.leaf_data.data() + static_cast<size_t>(first) * kLeafFloatsPerLane;
      for (int lane = 0; lane < width; ++lane) {
        const uint32_t p = bvh.lane_polygon[first + lane];
        block[12 * width + lane] = 0.f;
        if (p == kNoLanePolygon) continue;
        for (int c = 0; c < 4; ++c) {
          const Vec3 q = vertex(p, c);
          for (int a = 0; a < 3; ++a) block[(3 * c + a) * width + lane] = q[a];
        }
        block[12 * width + lane] = is_triangle[p] ? 1.f : 0.f;
        bvh.polygon_lane[p] = first + static_cast<uint32_t>(lane);
      }
    }
  }
  return bvh;
}

}  // namespace

PolygonBvh build_polygon_bvh(const std::vector<Vec3> (&v)[4], const std::vector<uint8_t>& is_triangle) {
  return build(
      is_triangle.size(), [&v](size_t i, int k) { return v[k][i]; }, [&is_triangle](size_t i) { return is_triangle[i] != 0; });
}

PolygonBvh build_mesh_bvh(const TriangleMesh& mesh) {
  return build(
      mesh.size(), [&mesh](size_t i, int k) { return mesh.vertex(i, k == 3 ? 0 : k); }, [](size_t) { return true; });
}

}  // namespace pt
