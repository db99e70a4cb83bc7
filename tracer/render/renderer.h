// Progressive rendering: a pass adds `spp` samples to every pixel of the film, tiles handed out dynamically to
// a persistent thread pool. Each sample's random numbers come from (pixel, sample index, seed) alone, so the
// image is bit-identical for any thread count, tile order or pass split.
#pragma once
#include <atomic>
#include <memory>
#include <vector>

#include "render/film.h"
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

  // Adds spp samples to each pixel of `film` (which must match the scene's size), traced with `settings`
  // (estimator, sampler, bounces, seed: not part of the compiled scene, so changing them rebuilds nothing). If
  // `cancel` becomes true the pass stops within a sample, whatever the path length (every pixel keeps a
  // consistent mean of whole samples; some have fewer), and the result says `cancelled`.
  PassStats render_pass(const Scene& scene, const RenderSettings& settings, Film& film, int spp,
                        const std::atomic<bool>* cancel = nullptr);
  // The same with a sample count per tile (row-major tiles of kTileSize, as plan_adaptive_pass gives them).
  PassStats render_pass(const Scene& scene, const RenderSettings& settings, Film& film,
                        const std::vector<int>& tile_spp, const std::atomic<bool>* cancel = nullptr);

  static constexpr int kTileSize = 16;

 private:
  ThreadPool pool_;
};

}  // namespace pt
