// The progressive loop's rules, in one place for `render`, `bench` and the viewer's RenderSession: when to stop,
// how many samples per pixel the next pass gets, and how a pass is run (uniform or adaptive). Each caller keeps
// only what is its own (progress output, error checkpoints, threads and restarts).
#pragma once
#include <atomic>
#include <cstdint>
#include <span>

#include "film/film.h"
#include "render/renderer.h"
#include "scene/estimator_choice.h"

namespace pt {

// The film's relMSE estimate is trusted as a stop condition from this many samples per pixel on.
inline constexpr uint64_t kRelMseStopMinSpp = 16;
// A pass never adds more samples per pixel than this (progress, cancellation and stop checks stay timely).
inline constexpr int kMaxPassSpp = 1024;

struct StopConditions {
  uint64_t spp = 0;      // stop once every pixel has this many samples; 0 = no limit
  double seconds = 0.0;  // stop after this much render time (pauses excluded); 0 = no limit
  double relmse = 0.0;   // stop when the film's estimated relMSE falls to this (from kRelMseStopMinSpp on); 0 = off
  bool any() const { return spp > 0 || seconds > 0.0 || relmse > 0.0; }
};

// The first stop condition met ("target spp", "time limit", "target relMSE"), or nullptr.
const char* stop_reason(const StopConditions& stop, uint64_t spp, double seconds, double estimated_relmse);

// The film's estimated relMSE after a pass, against the accumulation's render time.
struct RelMsePoint {
  double seconds, relmse;
  uint64_t spp;  // full-resolution samples per pixel when it was estimated
};

// When the film's relMSE estimate will reach a target, from its measured fall. An unbiased estimate's relMSE
// falls as 1/time in the long run, but the film's *estimate* of it falls more slowly at first wherever rare
// bright paths (caustics, fireflies) are still being discovered: each one raises a pixel's variance estimate.
// So no exponent is assumed: log relMSE is fitted against log time by least squares over the latest half of the
// render time (points from kRelMseStopMinSpp spp on), and the fitted line is followed to the target. As the rare
// paths are found, the decay speeds up towards 1/time: the forecast is the geometric mean of the fitted line's
// finish and the 1/time rule's, and the range spans both (and the slope's ± 2 standard errors). With fewer than
// 3 such points, or a history spanning too short a time to fit, the 1/time rule from the newest point alone
// (low = high = seconds).
struct RelMseForecast {
  double seconds = -1.0;            // render seconds until the target (0: already there); < 0 unknown
  double low = -1.0, high = -1.0;   // the range
  double exponent = 1.0;            // relMSE ∝ time^−exponent, as fitted (1 for the 1/time rule)
  bool fitted = false;
};
RelMseForecast forecast_relmse(std::span<const RelMsePoint> history, double target);

// How far an accumulation is towards the stop condition it will meet first, and when, at its current rate.
struct StopProgress {
  double fraction = -1.0;       // in [0, 1]; < 0 when no condition is set or none can be estimated yet
  double eta_seconds = -1.0;    // render seconds left; < 0 unknown
  double eta_low = -1.0, eta_high = -1.0;  // the range of eta_seconds (equal to it but for a fitted relMSE)
  const char* condition = "";   // stop_reason's name of that condition
};
// spp grows linearly in render time. For a target relMSE: forecast_relmse over `history` when it has one, else
// the 1/time rule from the newest estimate (a film at relMSE r after t seconds reaches r* after t·r/r*); the
// fraction is then the share of the predicted total time already spent. The relMSE estimate counts from
// kRelMseStopMinSpp on (before, its variance estimates are too noisy: it rises at first on noisy scenes).
StopProgress stop_progress(const StopConditions& stop, uint64_t spp, double seconds, double estimated_relmse,
                           std::span<const RelMsePoint> history = {});

// Samples per pixel of the next pass: about `target_seconds` of work at the measured cost per spp (1 before any
// measurement), never past the time or spp limit, at most kMaxPassSpp. With a relMSE target, never past where
// the film's `estimated_relmse` (of spp_done samples; 0 = unknown) reaches it at the 1/spp rate, nor past
// kRelMseStopMinSpp before that (the first spp the estimate is read at): a small image otherwise ran a whole
// half-second pass past its target (cornell 64²: target 5e-3, stopped at 565 spp and 4.5e-4).
int next_pass_spp(double seconds_per_spp, double target_seconds, const StopConditions& stop, uint64_t spp_done,
                  double seconds_done, double estimated_relmse = 0.0);

// One accumulation's passes, the progressive run shared by `render` and `bench`: it renders each pass (uniform,
// or adaptive: plan_adaptive_pass, every 4th pass uniform) and carries what the loop needs from pass to pass: the
// measured cost per spp that sizes the next pass, the render time, and the sample and ray counts. The caller keeps
// its own clock for the stop conditions (render: wall time; bench: render time only), its output and its
// cancellation. The viewer's RenderSession runs its own loop (restarts, previews) over the same rules.
class ProgressivePasses {
 public:
  // Adaptive passes do not apply under bdpt, whose light subpaths splat into every tile (Renderer::render_pass
  // runs a per-tile plan's largest count everywhere, so a planned pass of mean M spp ran up to 8M and the
  // measured cost per spp came out 8x too high): its passes stay uniform.
  ProgressivePasses(Renderer& renderer, const Scene& scene, const RenderSettings& settings, Film& film,
                    bool adaptive)
      : renderer_(renderer), scene_(scene), settings_(settings), film_(film),
        adaptive_(adaptive && resolved_render_settings(scene, settings).estimator != Estimator::Bdpt) {}

  // next_pass_spp at this run's measured cost.
  int next_spp(double target_seconds, const StopConditions& stop, uint64_t spp_done, double seconds_done,
               double estimated_relmse = 0.0) const {
    return next_pass_spp(seconds_per_spp_, target_seconds, stop, spp_done, seconds_done, estimated_relmse);
  }
  // Renders one pass of `spp` samples per pixel (on average, when adaptive). A cancelled pass counts its samples
  // and time but leaves the measured cost per spp as it was.
  PassStats render(int spp, const std::atomic<bool>* cancel = nullptr);

  double seconds_per_spp() const { return seconds_per_spp_; }  // 0 before the first whole pass
  double busy_seconds() const { return busy_seconds_; }        // time spent in passes
  uint64_t samples() const { return samples_; }
  uint64_t rays() const { return rays_; }
  uint64_t passes_spp() const { return passes_spp_; }  // the passes' spp summed (cancelled ones included)

 private:
  Renderer& renderer_;
  const Scene& scene_;
  const RenderSettings& settings_;
  Film& film_;
  bool adaptive_;
  uint64_t adaptive_pass_index_ = 0;
  double seconds_per_spp_ = 0.0, busy_seconds_ = 0.0;
  uint64_t samples_ = 0, rays_ = 0, passes_spp_ = 0;
};

}  // namespace pt
