#include "render/renderer.h"

#include "integrators/integrator.h"
#include "integrators/wavefront.h"
#include "scene/estimator_choice.h"
#include "sampling/sample_dimensions.h"
#include "sampling/sampler.h"
#include "sampling/sobol_batch.h"

namespace pt {

Renderer::Renderer(int threads) : pool_(threads > 0 ? threads : hardware_threads()) {}

namespace {

// Tile `tile` (row-major tiles of kTileSize, tiles_x per row) within `area`, a part of the film.
PixelRect tile_rect(int tile, int tiles_x, const PixelRect& area) {
  const int x0 = (tile % tiles_x) * Renderer::kTileSize, y0 = (tile / tiles_x) * Renderer::kTileSize;
  return PixelRect{x0, y0, x0 + Renderer::kTileSize, y0 + Renderer::kTileSize}.intersected(area);
}

// The camera ray of pixel (x, y) for the sample `sampler` draws: jittered within the pixel (and through a point
// of the lens, with a thin lens: 2D dimension `lens_dimension`, which the estimator's layout names).
template <class Sampler>
Ray camera_ray(const Scene& scene, const Sampler& sampler, int x, int y, uint32_t lens_dimension) {
  static_assert(SampleDimensions::kCameraJitter == BdptDimensions::kCameraJitter);
  const Vec2 jitter = sampler.get_2d(SampleDimensions::kCameraJitter);
  const Vec2 lens = scene.camera.thin_lens() ? sampler.get_2d(lens_dimension) : Vec2(0.5f);
  return scene.camera.generate_ray(static_cast<float>(x) + jitter.x, static_cast<float>(y) + jitter.y, lens);
}

// One tile: every pixel gets `spp` more samples, numbered after those it already has. Returns false when
// cancelled: a set `cancel` stops the tile at once and the samples in flight are dropped (they may have been cut
// short), so every pixel keeps an unbiased mean of the samples it has, and the same sample indices are traced
// again later.
template <class Sampler>
bool render_tile_scalar(RadianceKernel<Sampler> radiance, const Scene& scene, const RenderSettings& settings,
                        Film& film, int x0, int y0, int x1, int y1, int spp, RayCount& count, uint64_t& samples,
                        const std::atomic<bool>* cancel) {
  const int w = film.width();
  const bool features = film.has_features();
  for (int y = y0; y < y1; ++y) {
    for (int x = x0; x < x1; ++x) {
      const size_t pixel = static_cast<size_t>(y) * w + x;
      for (int s = 0; s < spp; ++s) {
        const uint32_t index = film.next_sample_index(pixel);
        Sampler sampler(pixel, index, settings.seed);
        PixelFeatures f;
        const Rgb L = radiance(scene, settings, camera_ray(scene, sampler, x, y, SampleDimensions::kLens), sampler, count,
                               features ? &f : nullptr, cancel);
        if (cancel && cancel->load(std::memory_order_relaxed)) return false;
        film.note_attempt(pixel);
        if (features) film.add_sample(pixel, L, f, index);
        else film.add_sample(pixel, L);
        ++samples;
      }
    }
  }
  return true;
}

// The same through the wavefront loop: one batch per sample index, every pixel of the tile in it. Each pixel
// receives its samples in the same order as above, so the film's means are bit-identical.
template <class Sampler>
bool render_tile_wavefront(BatchKernel<Sampler> batch, const Scene& scene, const RenderSettings& settings,
                           Film& film, int x0, int y0, int x1, int y1, int spp, RayCount& count, uint64_t& samples,
                           const std::atomic<bool>* cancel) {
  static_assert(Renderer::kTileSize * Renderer::kTileSize <= kWavefrontBatch);
  Sampler samplers[kWavefrontBatch];
  Ray rays[kWavefrontBatch];
  Rgb L[kWavefrontBatch];
  PixelFeatures f[kWavefrontBatch];
  uint32_t index[kWavefrontBatch];
  const int w = film.width();
  const bool features = film.has_features();
  for (int s = 0; s < spp; ++s) {
    int n = 0;
    for (int y = y0; y < y1; ++y) {
      for (int x = x0; x < x1; ++x, ++n) {
        const size_t pixel = static_cast<size_t>(y) * w + x;
        index[n] = film.next_sample_index(pixel);
        samplers[n] = Sampler(pixel, index[n], settings.seed);
        if (features) f[n] = PixelFeatures{};
      }
    }
    // The camera jitters of the whole tile at once where the sampler can (sampling/sobol_batch.h).
    if constexpr (std::is_same_v<Sampler, SobolSampler>) {
      Vec2 jitter[kWavefrontBatch];
      SobolBatch::get_2d(samplers, nullptr, n, SampleDimensions::kCameraJitter, jitter);
      for (int j = 0, y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x, ++j)
          rays[j] = camera_ray(scene, SamplerWithPoints<Sampler>{samplers[j], SampleDimensions::kCameraJitter,
                                                                 jitter[j]}, x, y, SampleDimensions::kLens);
    } else {
      for (int j = 0, y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x, ++j) rays[j] = camera_ray(scene, samplers[j], x, y, SampleDimensions::kLens);
    }
    if (!batch(scene, settings, samplers, rays, n, L, features ? f : nullptr, count, cancel)) return false;
    n = 0;
    for (int y = y0; y < y1; ++y) {
      for (int x = x0; x < x1; ++x, ++n) {
        const size_t pixel = static_cast<size_t>(y) * w + x;
        film.note_attempt(pixel);
        if (features) film.add_sample(pixel, L[n], f[n], index[n]);
        else film.add_sample(pixel, L[n]);
      }
    }
    samples += static_cast<uint64_t>(n);
  }
  return true;
}

// The kernels compiled for the scene's feature set, resolved once per tile.
template <class Sampler>
bool render_tile(const Scene& scene, const RenderSettings& settings, Film& film, int x0, int y0, int x1, int y1,
                 int spp, RayCount& count, uint64_t& samples, const std::atomic<bool>* cancel) {
  if (const BatchKernel<Sampler> batch = select_batch_kernel<Sampler>(scene, settings))
    return render_tile_wavefront(batch, scene, settings, film, x0, y0, x1, y1, spp, count, samples, cancel);
  return render_tile_scalar(select_kernel<Sampler>(scene, settings.generic_kernel), scene, settings, film, x0, y0,
                            x1, y1, spp, count, samples, cancel);
}

// One BDPT round over a tile: each pixel's camera estimate into `estimate`, its light subpath's splats into
// `splats`. False when cancelled.
template <class Sampler>
bool render_tile_bdpt(const Scene& scene, const RenderSettings& settings, const Film& film, int x0, int y0, int x1,
                      int y1, BdptScratch& scratch, std::vector<glm::dvec3>& estimate,
                      std::vector<PixelFeatures>& features, std::vector<Splat>& splats, RayCount& count,
                      const std::atomic<bool>* cancel) {
  const BdptKernel<Sampler> kernel = select_bdpt_kernel<Sampler>(scene, settings);
  const int w = film.width();
  const bool gather = film.has_features();
  for (int y = y0; y < y1; ++y) {
    for (int x = x0; x < x1; ++x) {
      const size_t pixel = static_cast<size_t>(y) * w + x;
      const Sampler sampler(pixel, film.next_sample_index(pixel), settings.seed);
      Rgb L;
      PixelFeatures* f = nullptr;
      if (gather) *(f = &features[pixel]) = PixelFeatures{};
      if (!kernel(scene, settings, sampler, camera_ray(scene, sampler, x, y, BdptDimensions::kCameraLens), scratch, splats, L, f,
                  count, cancel))
        return false;
      estimate[pixel] = glm::dvec3(L);
    }
  }
  return true;
}

}  // namespace

PassStats Renderer::render_pass(const Scene& scene, const RenderSettings& settings, Film& film, int spp,
                                const std::atomic<bool>* cancel, const PixelRect* region) {
  const int tiles = ((film.width() + kTileSize - 1) / kTileSize) * ((film.height() + kTileSize - 1) / kTileSize);
  return render_pass(scene, settings, film, std::vector<int>(tiles, spp), cancel, region);
}

PassStats Renderer::render_bdpt_rounds(const Scene& scene, const RenderSettings& settings, Film& film, int rounds,
                                       const std::atomic<bool>* cancel, const PixelRect& region) {
  const int w = film.width(), h = film.height();
  const int tiles_x = (w + kTileSize - 1) / kTileSize, tiles_y = (h + kTileSize - 1) / kTileSize;
  round_estimate_.resize(film.pixel_count());
  round_features_.resize(film.has_features() ? film.pixel_count() : 0);
  tile_splats_.resize(static_cast<size_t>(tiles_x) * tiles_y);
  bdpt_scratch_.resize(static_cast<size_t>(pool_.size()));
  const bool whole = region == full_rect(w, h);
  const double splat_scale = whole ? 1.0 : static_cast<double>(film.pixel_count()) / static_cast<double>(region.area());
  PassStats stats;
  for (int round = 0; round < rounds; ++round) {
    std::atomic<uint64_t> rays{0};
    std::atomic<bool> cancelled{false};
    pool_.parallel_for(tiles_x * tiles_y, [&](int tile, int thread) {
      if (cancelled.load(std::memory_order_relaxed) || (cancel && cancel->load(std::memory_order_relaxed))) {
        cancelled.store(true, std::memory_order_relaxed);
        return;
      }
      const PixelRect t = tile_rect(tile, tiles_x, region);
      const int x0 = t.x0, y0 = t.y0, x1 = t.x1, y1 = t.y1;
      std::vector<Splat>& splats = tile_splats_[tile];
      splats.clear();
      if (t.empty()) return;
      RayCount count;
      const bool complete =
          settings.sampler == SamplerType::Sobol
              ? render_tile_bdpt<SobolSampler>(scene, settings, film, x0, y0, x1, y1, bdpt_scratch_[thread],
                                               round_estimate_, round_features_, splats, count, cancel)
              : render_tile_bdpt<IndependentSampler>(scene, settings, film, x0, y0, x1, y1, bdpt_scratch_[thread],
                                                     round_estimate_, round_features_, splats, count, cancel);
      if (!complete) cancelled.store(true, std::memory_order_relaxed);
      rays.fetch_add(count.rays, std::memory_order_relaxed);
    });
    stats.rays += rays.load();
    if (cancelled.load()) {
      stats.cancelled = true;
      break;
    }
    for (const std::vector<Splat>& splats : tile_splats_) {
      for (const Splat& sp : splats) {
        if (!whole && !region.contains(static_cast<int>(sp.pixel % static_cast<uint32_t>(w)),
                                       static_cast<int>(sp.pixel / static_cast<uint32_t>(w))))
          continue;
        if (is_finite(sp.value)) round_estimate_[sp.pixel] += splat_scale * glm::dvec3(sp.value);
        else film.note_rejected();
      }
    }
    for (int y = region.y0; y < region.y1; ++y)
      for (int x = region.x0; x < region.x1; ++x) {
        const size_t pixel = static_cast<size_t>(y) * static_cast<size_t>(w) + static_cast<size_t>(x);
        const uint32_t index = film.next_sample_index(pixel);
        film.note_attempt(pixel);
        if (film.has_features()) film.add_sample(pixel, Rgb(round_estimate_[pixel]), round_features_[pixel], index);
        else film.add_sample(pixel, Rgb(round_estimate_[pixel]));
      }
    stats.samples += region.area();
  }
  return stats;
}

std::string Renderer::describe_path(const Scene& scene, const RenderSettings& settings) {
  const RenderSettings s = resolved_render_settings(scene, settings);
  if (s.estimator == Estimator::Bdpt) return "bdpt rounds";
  const bool wavefront = runs_wavefront(s);
  const uint32_t f = selected_kernel_features(scene, s.generic_kernel);
  std::string out = wavefront ? "wavefront loop, " : "scalar loop, ";
  if (f == kAllFeatures) {
    out += "generic kernel (every feature)";
  } else {
    const bool polygons = f & kFeaturePolygons, spheres = f & kFeatureSpheres;
    out += std::string("kernel for ") + (polygons && spheres ? "polygons and spheres" : polygons ? "polygons" : "spheres") +
           ((f & kFeatureGeneralMaterials) ? " with any material" : " with Lambert materials");
  }
  const bool light_sampling = s.estimator == Estimator::Nee || s.estimator == Estimator::Mis;
  if (wavefront && light_sampling && shading_lanes_apply(scene, f)) out += ", SIMD shading lanes";
  return out;
}

PassStats Renderer::render_pass(const Scene& scene, const RenderSettings& settings, Film& film,
                                const std::vector<int>& tile_spp, const std::atomic<bool>* cancel,
                                const PixelRect* region) {
  if (settings.estimator == Estimator::Auto)  // mis or bdpt for the scene as it is now (materials edited since)
    return render_pass(scene, resolved_render_settings(scene, settings), film, tile_spp, cancel, region);
  const int w = film.width(), h = film.height();
  const PixelRect area = region ? region->clipped(w, h) : full_rect(w, h);
  if (area.empty()) return {};
  if (settings.estimator == Estimator::Bdpt) {
    int rounds = 0;
    for (const int n : tile_spp) rounds = std::max(rounds, n);
    return render_bdpt_rounds(scene, settings, film, rounds, cancel, area);
  }
  const int tiles_x = (w + kTileSize - 1) / kTileSize, tiles_y = (h + kTileSize - 1) / kTileSize;
  std::atomic<uint64_t> samples{0}, rays{0};
  std::atomic<bool> cancelled{false};

  pool_.parallel_for(tiles_x * tiles_y, [&](int tile, int /*thread*/) {
    if (cancel && cancel->load(std::memory_order_relaxed)) {
      cancelled.store(true, std::memory_order_relaxed);
      return;
    }
    const PixelRect t = tile_rect(tile, tiles_x, area);
    const int x0 = t.x0, y0 = t.y0, x1 = t.x1, y1 = t.y1;
    RayCount count;
    uint64_t tile_samples = 0;
    const int spp = tile_spp[tile];
    if (spp <= 0 || t.empty()) return;
    const bool complete =
        settings.sampler == SamplerType::Sobol
            ? render_tile<SobolSampler>(scene, settings, film, x0, y0, x1, y1, spp, count, tile_samples, cancel)
            : render_tile<IndependentSampler>(scene, settings, film, x0, y0, x1, y1, spp, count, tile_samples, cancel);
    if (!complete) cancelled.store(true, std::memory_order_relaxed);
    samples.fetch_add(tile_samples, std::memory_order_relaxed);
    rays.fetch_add(count.rays, std::memory_order_relaxed);
  });
  return {samples.load(), rays.load(), cancelled.load()};
}

}  // namespace pt
