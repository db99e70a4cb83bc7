// Progressive rendering: a pass adds `spp` samples to every pixel of the film, tiles handed out dynamically to
// a persistent thread pool. Each sample's random numbers come from (pixel, sample index, seed) alone, so the
// image is bit-identical for any thread count, tile order or pass split.
#pragma once
#include <atomic>
#include <memory>
#include <vector>

#include "integrators/bdpt.h"
#include "film/film.h"
#include "scene/scene.h"
#include "core/thread_pool.h"

namespace pt {

struct PassStats {
  uint64_t samples = 0;  // camera samples traced
  uint64_t rays = 0;     // camera + bounce + shadow rays
  bool cancelled = false;
};

class Renderer {
 public:
  explicit Renderer(int threads = 0);  // 0 = all hardware threads
  int threads() const { return pool_.size(); }
  const std::string& thread_start_error() const { return pool_.start_error(); }
  // The render threads, for work between passes (denoising).
  ThreadPool& pool() { return pool_; }

  // Adds spp samples to each pixel of `film` (which must match the scene's size), traced with `settings`
  // (estimator, sampler, bounces, seed: not part of the compiled scene, so changing them rebuilds nothing). If
  // `cancel` becomes true the pass stops within a sample, whatever the path length (every pixel keeps a
  // consistent mean of whole samples; some have fewer), and the result says `cancelled`.
  // With a `region` (a render region, film/pixel_rect.h), only its pixels get samples; the others keep theirs,
  // and the samples of a region's pixel are the ones it gets in a render of the whole film (the same numbers:
  // under every estimator but bdpt, the same bits).
  PassStats render_pass(const Scene& scene, const RenderSettings& settings, Film& film, int spp,
                        const std::atomic<bool>* cancel = nullptr, const PixelRect* region = nullptr);
  // The same with a sample count per tile (row-major tiles of kTileSize, as plan_adaptive_pass gives them).
  PassStats render_pass(const Scene& scene, const RenderSettings& settings, Film& film,
                        const std::vector<int>& tile_spp, const std::atomic<bool>* cancel = nullptr,
                        const PixelRect* region = nullptr);

  static constexpr int kTileSize = 16;

  // Which compiled path render_pass takes for these settings, in words, for `render`'s summary and the tests of
  // --path-loop and --generic-kernel (which change the path, not the image): "bdpt rounds", or e.g.
  // "wavefront loop, kernel for polygons with Lambert materials, SIMD shading lanes".
  static std::string describe_path(const Scene& scene, const RenderSettings& settings);

 private:
  // The bidirectional estimator's passes (integrators/bdpt.h): light-traced contributions land on any pixel, so
  // a pass runs in rounds of one sample per pixel. In a round every pixel traces one camera sample and one
  // light subpath; each tile collects its splats in a list; once all tiles are done the lists are added in
  // tile order (the same sums whatever the thread count) to the round's camera estimates, and each pixel's
  // total enters the film as one sample. A round's light subpaths (one per pixel) estimate the light-traced
  // part of every pixel, so a pixel's samples stay independent and identically distributed: the running mean
  // and the film's variance estimate keep their meaning. A cancelled round is dropped whole. Adaptive
  // per-tile counts do not apply (splats reach every tile): a pass runs the largest count for every pixel.
  // In a render region only the region's pixels trace, so a round has R light subpaths instead of one per
  // pixel (P): each splat landing in the region counts P/R times (the light-tracing estimate of a pixel is
  // P/M times the sum of the splats of M light subpaths; pbrt-v4's splat scale is the same with M = P), and splats
  // outside it are dropped.
  PassStats render_bdpt_rounds(const Scene& scene, const RenderSettings& settings, Film& film, int rounds,
                               const std::atomic<bool>* cancel, const PixelRect& region);
  ThreadPool pool_;
  std::vector<glm::dvec3> round_estimate_;           // per pixel: the round's camera-subpath estimate
  std::vector<PixelFeatures> round_features_;        // per pixel: its features this round (film with features)
  std::vector<std::vector<Splat>> tile_splats_;     // per tile: its light-traced contributions this round
  std::vector<BdptScratch> bdpt_scratch_;           // per thread: subpath vertices
};

}  // namespace pt
