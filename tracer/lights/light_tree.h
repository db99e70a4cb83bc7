// Choosing one of many lights by how much each can give a receiving point: a hierarchy of light bounds (pbrt-v4's
// BVHLightSampler, Pharr, Jakob & Humphreys, "Physically Based Rendering" 4th ed., §12.6.3, after Conty Estevez and
// Kulla 2018, "Importance Sampling of Many Lights with Adaptive Tree Splitting").
//
// Power alone (Scene::light_pmf) picks every light of a scene in proportion to its power wherever the receiver is:
// with many lights, most samples go to lights that are far away, facing away or behind the receiver. Here each node
// bounds its lights' positions (a box), power (phi), and the directions they emit in (a cone of normals about w of
// half-angle θo, widened by θe, the spread of emission about a normal: π/2 for surfaces). At a receiver p with
// normal n a node's importance is phi · cos θ' / d² · cos θ'_i (pbrt-v4 LightBounds::Importance): d the distance to
// the box's centre (at least half its diagonal), θ' the smallest angle between the emission cone and the direction
// to p allowed by the box's extent seen from p, θ'_i the same for the receiver's normal. Sampling descends from the
// root choosing each child with probability ∝ its importance; the probability of a light is the product along its
// path, which pmf() recomputes from the light's stored path (the same arithmetic, so sampling and MIS agree bit for
// bit). The bounds are conservative: a light that can reach p never has importance 0 there.
//
// The tree is built binary (median splits, as pbrt-v4's) and stored 8 wide: each node holds the bounds of its
// binary node's descendants three levels down (fewer where leaves come sooner), one SIMD lane each, so one
// evaluation weighs eight (Embree's wide BVH nodes, applied to lights). Measured against the binary tree
// (docs/performance.md, session 39): a third of the levels, and a choice among eight tighter bounds at once
// instead of two loose unions: on 64 lamps 44 % lower relMSE at equal samples and faster; on a mesh of 70k
// emitting triangles 1.6x the samples per second.
//
// Only bounded lights go into the tree (area lights, spheres, points and spots); infinite and directional lights
// keep their power share (Scene::light_pmf), and the tree as a whole gets the bounded lights' share.
#pragma once
#include <cstdint>
#include <vector>

#include "core/math.h"

namespace pt {

// What a light (or a node's lights) can emit, and where.
struct LightBounds {
  Vec3 lo{0.f}, hi{0.f};  // box around the emitting points
  float phi = 0.f;        // emitted power (any consistent unit: only ratios matter)
  Vec3 w{0.f, 0.f, 1.f};  // axis of the cone of emission normals
  float cos_theta_o = 1.f;  // its half-angle θo (1: one normal; −1: every direction)
  float cos_theta_e = 0.f;  // the spread of emission about a normal, θe (π/2 for a surface)
  bool two_sided = false;   // emits on both sides of each normal
};

// Up to kTreeWidth light bounds side by side (structure of arrays, one SIMD lane each), with what the importance
// derives from the bounds alone computed once: a tree node's children, whose importances are evaluated together
// (the importance is most of the time a many-light scene spends choosing). Unused lanes have phi 0.
inline constexpr int kTreeWidth = 8;
inline constexpr int kLaneBits = 3;  // log2(kTreeWidth)
static_assert(1 << kLaneBits == kTreeWidth);
struct alignas(64) ImportanceLanes {
  float cx[kTreeWidth]{}, cy[kTreeWidth]{}, cz[kTreeWidth]{};  // the box's centre
  float d2_floor[kTreeWidth]{};  // the smallest d²: half the box's diagonal, at least 1e-20 (a point)
  float wx[kTreeWidth]{}, wy[kTreeWidth]{}, wz[kTreeWidth]{};
  float r2[kTreeWidth]{};  // the box's bounding sphere's radius², about its centre
  float phi[kTreeWidth]{};
  float cos_theta_o[kTreeWidth]{}, sin_theta_o[kTreeWidth]{}, cos_theta_e[kTreeWidth]{};
  float two_sided[kTreeWidth]{};  // 0 or 1
  void set(int lane, const LightBounds& b);
  // The importance of each lane's bounds (the formula at the top) for a receiver at p with normal n (n = 0 for
  // a point without a surface), into out[0 .. kTreeWidth).
  void importance(Vec3 p, Vec3 n, float out[kTreeWidth]) const;
};

// The union of two bounds (box, power, cone of normals, widest spread).
LightBounds light_bounds_union(const LightBounds& a, const LightBounds& b);

class LightTree {
 public:
  // Minimum number of bounded lights for which the scene uses a tree (below it, power alone: a scene of one lamp
  // gains nothing from importance and keeps its images).
  static constexpr size_t kMinLights = 8;

  LightTree() = default;
  // `bounds[i]` of light `lights[i]` (an index into Scene::lights); `light_pmf` every light's power share
  // (Scene::light_pmf). The tree as a whole is chosen with its lights' total share, every other light with its own.
  LightTree(const std::vector<LightBounds>& bounds, const std::vector<uint32_t>& lights,
            const std::vector<float>& light_pmf);

  bool empty() const { return nodes_.empty(); }
  float share() const { return share_; }
  // Whether Scene::lights[li] is chosen through the tree.
  bool contains(int li) const { return li >= 0 && static_cast<size_t>(li) < trail_.size() && trail_[li].depth >= 0; }

  // A light for the receiver (p, n) with u ∈ [0,1): a light outside the tree by its power share (light_pmf[li]
  // in `pmf`), else one of the tree's (sample()). −1 (pmf 0) when the tree was chosen and none of its lights can
  // reach the receiver.
  int choose(Vec3 p, Vec3 n, float u, const std::vector<float>& light_pmf, float& pmf) const;
  // One of the tree's lights: its index into Scene::lights and, in `pmf`, the probability of that choice
  // including share(); −1 (pmf 0) when none can reach the receiver.
  int sample(Vec3 p, Vec3 n, float u, float& pmf) const;
  // The probability that sample() gives light li (a light of the tree) at (p, n), share() included.
  float pmf(Vec3 p, Vec3 n, int li) const;

 private:
  // A node of up to kTreeWidth children: the binary tree of median splits with three levels folded into one
  // (a node's children are its binary node's descendants three levels down), weighed by one SIMD evaluation.
  struct Node {
    ImportanceLanes bounds;
    int32_t child[kTreeWidth] = {};  // ≥ 0: a node's index; < 0: the leaf of light −child − 1 (Scene::lights)
  };
  struct Trail {
    uint64_t lanes = 0;  // bits kLaneBits·k and up: the child taken at depth k
    int32_t depth = -1;  // −1: not a light of the tree
  };
  // The binary tree the build makes before folding it.
  struct BinaryNode {
    LightBounds bounds;
    uint32_t second = 0;  // inner node: index of the second child (the first is the next node)
    int32_t light = -1;   // leaf: its light, else −1
  };
  // The probabilities of node i's children for the receiver (p, n), from their importances (false: none can
  // reach it). In double, so that huge importances neither overflow nor lose the smaller ones. sample() and
  // pmf() both take them from here, so they multiply the same floats.
  bool child_probabilities(uint32_t i, Vec3 p, Vec3 n, float prob[kTreeWidth]) const;
  static uint32_t build(std::vector<BinaryNode>& nodes, std::vector<uint32_t>& order, size_t first, size_t last,
                        const std::vector<LightBounds>& bounds, const std::vector<uint32_t>& lights);
  // Folds the binary subtree at b into a node (appended) and returns its index.
  uint32_t fold(const std::vector<BinaryNode>& binary, uint32_t b, uint64_t lanes, int depth);

  std::vector<Node> nodes_;
  std::vector<Trail> trail_;  // per Scene::lights index
  float share_ = 0.f;
  // The first choice: the lights outside the tree and the tree itself (light −1), cumulative probabilities.
  std::vector<float> top_cdf_;
  std::vector<int32_t> top_light_;
};

}  // namespace pt
