// Russian roulette, the one rule of the scalar path loop (path_tracer.h), the SIMD shading lanes
// (shading_lanes.h, with the same function over SIMD lanes) and both subpaths of bdpt (bdpt_kernels.h).
//
// From scattering event rr_depth on, a path survives with probability q and is then re-weighted by 1/q, which
// keeps the estimate unbiased (pbrt-v4 PathIntegrator::Li). q follows the path's worth (its throughput's
// largest channel, refraction's 1/η² undone so that glass does not look like a loss), so paths through dark
// materials end early. q ≤ 1 − 2^-10 so even albedo-1 rooms terminate (mean length ~1000 bounces) while rooms of
// albedo ρ < 1 keep finite variance under cosine sampling (a cap c needs ρ² < c: 0.95 would not do for
// ρ = 0.999).
#pragma once
#include <algorithm>

#include "core/lanes.h"
#include "core/math.h"
#include "scene/scene_desc.h"

namespace pt {

inline constexpr float kMaxRouletteSurvival = 1.f - 0x1p-10f;

// The first roulette bounce `auto` (kRouletteDepthAuto, scene/scene_desc.h) stands for, each estimator's
// measured best in same-time error (docs/performance.md, "Russian roulette's first depth"):
// - 5 for the path tracers (under mis 9–23 % lower error than 3 on cornell, cornell-bunny and shadertoy, equal on
//   materials and torus-and-gem, 2–5 % higher on cornell-gltf; Mitsuba 3's default too);
// - 1 for bdpt in a closed scene: its two subpaths are long already, and from bounce 1 on the roulette's
//   albedo-like survival costs less than it saves (cornell-spheres 10–14 %, materials 16–17 %, cornell 10 % lower
//   error than from 3; from 0 cornell loses that gain);
// - 3 for bdpt under an infinite light (environment, sky, sun): there paths that bounce off the ground into the
//   sky or the sun carry most of the image, and `sky` had 2.3–2.6× the error from bounce 1.
inline constexpr int kPathRouletteDepth = 5, kBdptRouletteDepth = 1, kBdptRouletteDepthInfinite = 3;
inline int roulette_depth(int setting, bool bidirectional, bool infinite_light) {
  if (setting != kRouletteDepthAuto) return setting;
  if (!bidirectional) return kPathRouletteDepth;
  return infinite_light ? kBdptRouletteDepthInfinite : kBdptRouletteDepth;
}

// Whether roulette is played at scattering event `depth` (rr_depth < 0: never).
inline bool roulette_applies(int depth, int rr_depth) { return rr_depth >= 0 && depth >= rr_depth; }

// The survival probability of a path of worth `worth`, over T = float or vfloat (core/lanes.h).
template <class T>
[[gnu::always_inline]] inline T roulette_survival(const T& worth) {
  return lanes::std_min(T(kMaxRouletteSurvival), worth);
}

// Plays the roulette with the uniform number u: false when the path ends, else true with beta re-weighted.
inline bool survives_roulette(Rgb& beta, float worth, float u) {
  const float q = roulette_survival(worth);
  if (!(u < q)) return false;
  beta /= q;
  return true;
}

}  // namespace pt
