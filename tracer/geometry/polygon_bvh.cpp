#include "geometry/polygon_bvh.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <future>
#include <numeric>
#include <span>
#include <stdexcept>
#include <system_error>

namespace pt {

namespace {

struct Box {
  Vec3 lo{kInfinity}, hi{-kInfinity};
  bool empty() const { return !(lo.x <= hi.x && lo.y <= hi.y && lo.z <= hi.z); }
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

Box intersection(const Box& a, const Box& b) {
  Box c;
  c.lo = glm::max(a.lo, b.lo);
  c.hi = glm::min(a.hi, b.hi);
  return c.empty() ? Box{} : c;
}

Box united(Box a, const Box& b) {
  a.grow(b);
  return a;
}

// A float box around a point given in double: its nearest floats widened by one ulp or more either way (|f|·2⁻²³
// is at least f's ulp; the smallest subnormal covers a point that rounds to 0), so that it contains the point.
Box outward_box(const DVec3& p) {
  const Vec3 f(p);
  const Vec3 slack = glm::abs(f) * 0x1p-23f + std::numeric_limits<float>::denorm_min();
  return Box{f - slack, f + slack};
}

// A polygon as the builder places it: its box, or (after spatial splits) the box of its part in one region.
struct Ref {
  Box box;
  uint32_t prim = 0;
  Vec3 centroid() const { return 0.5f * (box.lo + box.hi); }
};

// The binary tree the SAH builds, collapsed afterwards. A leaf names leaf_prims[first, first + count).
struct BinaryNode {
  Box box;
  uint32_t left = 0, right = 0;  // children (inner nodes)
  uint32_t first = 0, count = 0;  // count > 0: a leaf
};

constexpr int kBins = 32;
// Spatial splits are priced on fewer bins, as in Embree's spatial SAH: each bin a reference spans costs a clip.
constexpr int kSpatialBins = 16;
// Leaves this small are never split: up to 8 polygons are one 4- or 8-lane block test, which costs about one box
// test (bench rays on cornell-bunny: +4 % closest hit against splitting down to 4 by the SAH, session 30).
constexpr uint32_t kLeafAlways = kBvhMaxLeaf;
// Below this many references a subtree is built on the calling thread; above, its two halves run concurrently.
constexpr uint32_t kParallelSubtree = 1u << 15;
// Spatial splits (measured in docs/performance.md, session 31):
// - tried only where the best object split's children overlap by at least these fractions of the root's area
//   (Stich et al. 2009, section 4.4, α) and of the node's (Embree's spatial SAH takes 5·10⁻⁶ and 0.1), and in
//   nodes of at least kSpatialMinRefs references: at 128 the engine's rays were no faster and a million-triangle
//   sphere loaded in 0.87 s instead of 0.75 s (0.45 s without spatial splits);
// - taken only when they cost less than kSpatialGain times the best object split. Embree takes 0.99; at 0.99 and
//   0.95 the walls of cornell-bunny's closed box were cut near the root and its rays, which all start inside the
//   box, got 17 % (closest hit) and 28 % (shadow) slower; at 0.9 nothing there is split, and 2CylinderEngine.glb's
//   triangles, alone in one tree, are still 20 % faster to trace;
// - at most kSpatialBudget more references per polygon (Embree allows 1; the engine took 0.13 at a gain of 0.99):
//   the room they may take is reserved with the references, and the node array is sized for it.
constexpr double kSpatialOverlapOfRoot = 5e-6, kSpatialOverlapOfNode = 0.1, kSpatialGain = 0.9;
constexpr double kSpatialBudget = 0.25;
constexpr size_t kSpatialMinRefs = 512;

// The bin of a coordinate along one axis, among `bins` equal bins from lo.
struct Binning {
  float lo, scale;
  int axis, bins;
  Binning(float lo_, float extent, int axis_, int bins_)
      : lo(lo_), scale(static_cast<float>(bins_) * (1.f - 1e-6f) / extent), axis(axis_), bins(bins_) {}
  int bin(float x) const { return std::clamp(static_cast<int>((x - lo) * scale), 0, bins - 1); }
  int bin(const Vec3& c) const { return bin(c[axis]); }
};

struct SpatialSplit {
  double cost = std::numeric_limits<double>::infinity();
  int axis = -1;
  float position = 0.f;
};

// The SAH sweep over N bins along one axis: for the plane after bin b, A(bins ≤ b)·(references entering at or
// before b) + A(bins > b)·(references leaving after b); the cheapest plane with references on both sides (bin
// -1 if none). An object split's references enter and leave in the same bin.
struct Sweep {
  double cost = std::numeric_limits<double>::infinity();
  int bin = -1;
  Box left, right;
};
template <size_t N>
Sweep sah_sweep(const std::array<Box, N>& box, const std::array<uint32_t, N>& enter,
                const std::array<uint32_t, N>& leave) {
  std::array<Box, N> right_box;
  std::array<size_t, N> right_n{};
  Box acc;
  size_t n = 0;
  for (size_t b = N - 1; b > 0; --b) {
    acc.grow(box[b]);
    n += leave[b];
    right_box[b] = acc;
    right_n[b] = n;
  }
  Sweep best;
  acc = Box{};
  n = 0;
  for (size_t b = 0; b + 1 < N; ++b) {
    acc.grow(box[b]);
    n += enter[b];
    if (n == 0 || right_n[b + 1] == 0) continue;
    const double cost =
        acc.half_area() * static_cast<double>(n) + right_box[b + 1].half_area() * static_cast<double>(right_n[b + 1]);
    if (cost < best.cost) best = {cost, static_cast<int>(b), acc, right_box[b + 1]};
  }
  return best;
}

// The best sweep over the centroids' bins of one axis, and that axis.
struct ObjectSplit : Sweep {
  int axis = -1;
};

// The SBVH build (Stich, Friedrich and Dietrich, "Spatial splits in bounding volume hierarchies", HPG 2009): at
// each node the best binned object split (Wald 2007: centroids in 32 bins per axis) and, where its two children
// overlap, the best spatial split (a plane cutting the node's box; a polygon across it is clipped into both
// sides, its two parts bounded separately), whichever has the lower SAH cost. A polygon may so sit in several
// leaves, each bounding only its part there: long, thin triangles no longer give every ray a large box to enter.
// Each leaf still tests the whole polygon, so answers are those of the brute-force loop.
template <class Vertex>
class BinaryBuilder {
 public:
  // refs: the polygons' references, followed by `room` unused ones for the copies spatial splits make.
  BinaryBuilder(const Vertex& vertex, std::vector<Ref>& refs, size_t room, double root_area)
      : vertex_(vertex), overlap_limit_(kSpatialOverlapOfRoot * root_area), refs_(refs),
        nodes_(2 * std::max<size_t>(refs.size() + room, 1)) {
    refs_.resize(refs_.size() + room);
  }

  // Builds the subtree over refs[begin, end), which may grow into refs[end, room_end) through spatial splits (the
  // spare room of Embree's spatial builder: its references stay in one array, partitioned in place).
  uint32_t build(size_t begin, size_t end, size_t room_end, int depth) {
    const uint32_t index = next_node_++;
    Box box, centroid_box;
    for (size_t i = begin; i < end; ++i) {
      box.grow(refs_[i].box);
      centroid_box.grow(refs_[i].centroid());
    }
    nodes_[index].box = box;
    const size_t count = end - begin;
    if (count <= kLeafAlways) {  // final: no later split moves these references
      nodes_[index].first = static_cast<uint32_t>(begin);
      nodes_[index].count = static_cast<uint32_t>(count);
      return index;
    }
    size_t mid = 0;
    end = split(begin, end, room_end, box, centroid_box, depth, mid);
    // The room left is shared in proportion to the children's sizes (as Embree shares it), so the tree does not
    // depend on which subtree a thread reaches first; the right part moves up to make the left one's room.
    const size_t rest = room_end - end;
    const size_t left_room = static_cast<size_t>(static_cast<double>(rest) * static_cast<double>(mid - begin) /
                                                 static_cast<double>(end - begin));
    if (left_room > 0) {
      if (left_room < end - mid) std::copy(refs_.begin() + static_cast<std::ptrdiff_t>(mid),
                                           refs_.begin() + static_cast<std::ptrdiff_t>(mid + left_room),
                                           refs_.begin() + static_cast<std::ptrdiff_t>(end));
      else std::copy_backward(refs_.begin() + static_cast<std::ptrdiff_t>(mid),
                              refs_.begin() + static_cast<std::ptrdiff_t>(end),
                              refs_.begin() + static_cast<std::ptrdiff_t>(end + left_room));
    }
    const size_t right_begin = mid + left_room, right_end = end + left_room;
    uint32_t l = 0, r = 0;
    std::future<uint32_t> pending;
    if (count >= kParallelSubtree) {
      try {
        pending = std::async(std::launch::async, [=, this] { return build(begin, mid, right_begin, depth + 1); });
      } catch (const std::system_error&) {
        // No thread to be had (a process or memory limit): the subtree is built here. Found under ulimit -v,
        // where the render failed with "Resource temporarily unavailable" instead of finishing.
      }
    }
    if (pending.valid()) {
      r = build(right_begin, right_end, room_end, depth + 1);
      l = pending.get();
    } else {
      l = build(begin, mid, right_begin, depth + 1);
      r = build(right_begin, right_end, room_end, depth + 1);
    }
    nodes_[index].left = l;
    nodes_[index].right = r;
    return index;
  }

  std::vector<BinaryNode>& nodes() { return nodes_; }

 private:
  // Splits refs[begin, end) (more than a leaf's worth) into two non-empty parts, [begin, mid) and [mid, new end),
  // and returns the new end (beyond end by the copies a spatial split made, within room_end).
  size_t split(size_t begin, size_t end, size_t room_end, const Box& box, const Box& centroid_box, int depth,
               size_t& mid) {
    const Vec3 extent = centroid_box.hi - centroid_box.lo;
    const std::span<Ref> refs(refs_.data() + begin, end - begin);
    // All centroids in one point (or a runaway depth): halve by index, which bounds the depth by log2(n).
    if (!(std::max({extent.x, extent.y, extent.z}) > 0.f) || depth > kBvhSahMaxDepth) {
      mid = begin + refs.size() / 2;
      return end;
    }
    const ObjectSplit object = best_object_split(refs, centroid_box);
    const double overlap = intersection(object.left, object.right).half_area();
    if (refs.size() >= kSpatialMinRefs && room_end > end && overlap >= overlap_limit_ &&
        overlap >= kSpatialOverlapOfNode * box.half_area()) {
      const SpatialSplit spatial = best_spatial_split(refs, box);
      if (spatial.cost < kSpatialGain * object.cost) {
        const size_t new_end = split_spatially(begin, end, room_end, spatial, mid);
        if (new_end != 0) return new_end;
      }
    }
    if (object.axis < 0) {
      mid = begin + refs.size() / 2;
      return end;
    }
    const Binning binning(centroid_box.lo[object.axis], extent[object.axis], object.axis, kBins);
    const auto middle =
        std::partition(refs.begin(), refs.end(), [&](const Ref& r) { return binning.bin(r.centroid()) <= object.bin; });
    mid = begin + static_cast<size_t>(middle - refs.begin());
    return end;
  }

  // Binned SAH over the centroids on every axis (Wald 2007): the split of least A(left)·n(left) + A(right)·n(right).
  // (Counting leaf tests of 8 polygons instead of polygons was tried: the bunny's shadow rays 7 % slower, session
  // 30.)
  static ObjectSplit best_object_split(std::span<const Ref> refs, const Box& centroid_box) {
    ObjectSplit best;
    const Vec3 extent = centroid_box.hi - centroid_box.lo;
    for (int axis = 0; axis < 3; ++axis) {
      if (!(extent[axis] > 0.f)) continue;
      std::array<Box, kBins> bin_box;
      std::array<uint32_t, kBins> bin_count{};
      const Binning binning(centroid_box.lo[axis], extent[axis], axis, kBins);
      for (const Ref& r : refs) {
        const int b = binning.bin(r.centroid());
        bin_box[b].grow(r.box);
        ++bin_count[b];
      }
      const Sweep sweep = sah_sweep(bin_box, bin_count, bin_count);
      if (sweep.cost < best.cost) best = {sweep, axis};
    }
    return best;
  }

  // The boxes of the parts of ref's polygon on either side of the plane x[axis] = position, within ref's box;
  // an empty box where there is no such part. The edges' crossings are computed in double and rounded outwards,
  // so each box contains its part: a ray that hits the polygon enters the box of the part it hits.
  std::pair<Box, Box> clip(const Ref& ref, int axis, float position) const {
    Box below, above;
    for (int k = 0; k < 4; ++k) {  // a triangle repeats its corner 0 as 3: its fourth edge has no length
      const Vec3 a = vertex_(ref.prim, k), b = vertex_(ref.prim, (k + 1) % 4);
      if (a[axis] <= position) below.grow(a);
      if (a[axis] >= position) above.grow(a);
      if ((a[axis] < position && position < b[axis]) || (b[axis] < position && position < a[axis])) {
        const double t = (static_cast<double>(position) - a[axis]) / (static_cast<double>(b[axis]) - a[axis]);
        Box crossing = outward_box(DVec3(a) + t * (DVec3(b) - DVec3(a)));
        crossing.lo[axis] = crossing.hi[axis] = position;
        below.grow(crossing);
        above.grow(crossing);
      }
    }
    return {intersection(below, ref.box), intersection(above, ref.box)};
  }

  // The plane of least SAH cost among kSpatialBins − 1 equally spaced ones per axis across the node's box; a
  // reference in several bins is clipped into each (its entering and leaving bin counted).
  SpatialSplit best_spatial_split(std::span<const Ref> refs, const Box& box) const {
    SpatialSplit best;
    for (int axis = 0; axis < 3; ++axis) {
      const float lo = box.lo[axis], extent = box.hi[axis] - lo;
      if (!(extent > 0.f)) continue;
      const Binning binning(lo, extent, axis, kSpatialBins);
      std::array<float, kSpatialBins> plane{};  // plane[b]: the bins' boundary below bin b (b ≥ 1)
      for (int b = 1; b < kSpatialBins; ++b) plane[b] = lo + extent * static_cast<float>(b) / kSpatialBins;
      std::array<Box, kSpatialBins> bin_box;
      std::array<uint32_t, kSpatialBins> entries{}, exits{};
      for (const Ref& r : refs) {
        const int first = binning.bin(r.box.lo[axis]), last = std::max(first, binning.bin(r.box.hi[axis]));
        Ref rest = r;
        for (int b = first; b < last; ++b) {
          const auto [below, above] = clip(rest, axis, plane[b + 1]);
          bin_box[b].grow(below);
          rest.box = above;
        }
        bin_box[last].grow(rest.box);
        ++entries[first];
        ++exits[last];
      }
      const Sweep sweep = sah_sweep(bin_box, entries, exits);
      if (sweep.cost < best.cost) best = {sweep.cost, axis, plane[static_cast<size_t>(sweep.bin) + 1]};
    }
    return best;
  }

  // Partitions refs[begin, end) by the plane, clipping the references across it (the part above the plane goes to
  // a copy in the spare room), except where keeping one whole on one side costs less (Stich 2009, section 4.3,
  // "reference unsplitting"). Returns the new end, with the left part [begin, mid); or 0, changing nothing, if a
  // side would be empty or the copies would not fit before room_end.
  size_t split_spatially(size_t begin, size_t end, size_t room_end, const SpatialSplit& s, size_t& mid) {
    enum Side : uint8_t { kLeft, kRight, kBoth };
    struct Straddler {
      size_t ref;
      Box below, above;
      Side side;
    };
    std::vector<Straddler> across;
    Box left_box, right_box;
    size_t n_left_only = 0, n_right_only = 0;
    for (size_t i = begin; i < end; ++i) {
      const Ref& r = refs_[i];
      if (r.box.hi[s.axis] <= s.position) {
        ++n_left_only;
        left_box.grow(r.box);
      } else if (r.box.lo[s.axis] >= s.position) {
        ++n_right_only;
        right_box.grow(r.box);
      } else {
        const auto [below, above] = clip(r, s.axis, s.position);
        across.push_back({i, below, above, kBoth});
        left_box.grow(below);
        right_box.grow(above);
      }
    }
    double n_left = static_cast<double>(n_left_only + across.size());
    double n_right = static_cast<double>(n_right_only + across.size());
    size_t copies = 0;
    for (Straddler& c : across) {
      const Box& b = refs_[c.ref].box;
      if (c.above.empty() || c.below.empty()) {  // rounding put the whole part on one side
        c.side = c.above.empty() ? kLeft : kRight;
        (c.above.empty() ? n_right : n_left) -= 1.0;
        continue;
      }
      const double both = left_box.half_area() * n_left + right_box.half_area() * n_right;
      const double only_left = united(left_box, b).half_area() * n_left + right_box.half_area() * (n_right - 1.0);
      const double only_right = left_box.half_area() * (n_left - 1.0) + united(right_box, b).half_area() * n_right;
      if (only_left <= both && only_left <= only_right) {
        c.side = kLeft;
        left_box.grow(b);
        n_right -= 1.0;
      } else if (only_right <= both) {
        c.side = kRight;
        right_box.grow(b);
        n_left -= 1.0;
      } else {
        ++copies;
      }
    }
    if (n_left < 1.0 || n_right < 1.0 || copies > room_end - end) return 0;
    // Apply: a reference split in two keeps its lower part and gives its upper part to a copy at the end; one kept
    // whole on the other side than its box says is marked, and the range is partitioned by side.
    std::vector<uint8_t> goes_left(end + copies - begin);
    for (size_t i = begin; i < end; ++i) goes_left[i - begin] = refs_[i].box.hi[s.axis] <= s.position;
    size_t next = end;
    for (const Straddler& c : across) {
      Ref& r = refs_[c.ref];
      if (c.side == kBoth) {
        refs_[next] = {c.above, r.prim};
        goes_left[next++ - begin] = 0;
        r.box = c.below;
        goes_left[c.ref - begin] = 1;
      } else {
        if (c.side == kLeft ? c.above.empty() : c.below.empty()) r.box = c.side == kLeft ? c.below : c.above;
        goes_left[c.ref - begin] = c.side == kLeft;
      }
    }
    size_t lo = begin, hi = next;
    for (;;) {  // Hoare partition of refs and their marks together
      while (lo < hi && goes_left[lo - begin]) ++lo;
      while (lo < hi && !goes_left[hi - 1 - begin]) --hi;
      if (lo >= hi) break;
      std::swap(refs_[lo], refs_[hi - 1]);
      std::swap(goes_left[lo - begin], goes_left[hi - 1 - begin]);
    }
    mid = lo;
    return next;
  }

  const Vertex& vertex_;
  const double overlap_limit_;
  std::vector<Ref>& refs_;
  std::vector<BinaryNode> nodes_;
  std::atomic<uint32_t> next_node_{0};
};

// Collapses the binary tree into 8-wide nodes and lays the leaves' polygons out in lanes.
class Collapser {
 public:
  Collapser(const std::vector<BinaryNode>& binary, const std::vector<uint32_t>& leaf_prims,
            const std::vector<uint8_t>& is_triangle, PolygonBvh& out)
      : binary_(binary), leaf_prims_(leaf_prims), is_triangle_(is_triangle), out_(out) {}

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
        for (uint32_t i = 0; i < c.count; ++i) triangles = triangles && is_triangle_[leaf_prims_[c.first + i]] != 0;
        n.child[k] = leaf_ref(static_cast<uint32_t>(out_.lane_polygon.size()), lanes, triangles);
        for (uint32_t i = 0; i < lanes; ++i)
          out_.lane_polygon.push_back(i < c.count ? leaf_prims_[c.first + i] : kNoLanePolygon);
      } else {
        const uint32_t child = wide_node({c.left, c.right});
        out_.nodes[index].child[k] = inner_ref(child);
      }
    }
    return index;
  }

  const std::vector<BinaryNode>& binary_;
  const std::vector<uint32_t>& leaf_prims_;
  const std::vector<uint8_t>& is_triangle_;
  PolygonBvh& out_;
};

}  // namespace

namespace {

// The build over n polygons whose vertex k is vertex(i, k) (k < 4; a triangle repeats vertex 0 as 3) and
// which are triangles where triangle(i).
template <class Vertex, class IsTriangle>
PolygonBvh build(size_t n, const Vertex& vertex, const IsTriangle& triangle, BvhSplits splits) {
  PolygonBvh bvh;
  if (n == 0) return bvh;
  std::vector<Ref> refs(n);
  Box root;
  for (size_t i = 0; i < n; ++i) {
    for (int k = 0; k < 4; ++k) refs[i].box.grow(vertex(i, k));
    refs[i].prim = static_cast<uint32_t>(i);
    root.grow(refs[i].box);
  }
  const size_t room = splits == BvhSplits::Spatial ? static_cast<size_t>(kSpatialBudget * static_cast<double>(n)) : 0;
  BinaryBuilder<Vertex> builder(vertex, refs, room, root.half_area());
  builder.build(0, n, n + room, 0);
  std::vector<uint32_t> leaf_prims(refs.size());
  for (size_t i = 0; i < refs.size(); ++i) leaf_prims[i] = refs[i].prim;
  std::vector<Ref>().swap(refs);
  std::vector<uint8_t> is_triangle(n);
  for (size_t i = 0; i < n; ++i) is_triangle[i] = triangle(i) ? 1 : 0;
  bvh.nodes.reserve(n / 4 + 1);
  bvh.lane_polygon.reserve(n * 2);
  Collapser(builder.nodes(), leaf_prims, is_triangle, bvh).run();

  // The leaves' polygons, leaf by leaf (kLeafFloatsPerLane), each leaf found through its reference in a node;
  // padding lanes hold NaN (they never hit).
  const size_t lanes = bvh.lane_polygon.size();
  bvh.leaf_data.assign(lanes * kLeafFloatsPerLane, std::numeric_limits<float>::quiet_NaN());
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
      }
    }
  }
  return bvh;
}

}  // namespace

PolygonBvh build_polygon_bvh(const std::vector<Vec3> (&v)[4], const std::vector<uint8_t>& is_triangle,
                             BvhSplits splits) {
  return build(
      is_triangle.size(), [&v](size_t i, int k) { return v[k][i]; },
      [&is_triangle](size_t i) { return is_triangle[i] != 0; }, splits);
}

PolygonBvh build_mesh_bvh(const TriangleMesh& mesh) {
  return build(
      mesh.size(), [&mesh](size_t i, int k) { return mesh.vertex(i, k == 3 ? 0 : k); }, [](size_t) { return true; },
      BvhSplits::Spatial);
}

}  // namespace pt
