// A progressive render running on its own thread, for interactive front ends (the viewer) and scripted tests.
//
// The owner edits through set_scene()/set_settings()/restart()/set_paused(); the session picks the newest request
// up at the next pass boundary, and cancels the running pass (through Renderer's cancel flag) so that boundary
// comes within one tile. After every pass it converts the film into a DisplayFrame (mean, per-pixel relative
// standard error, sample count) and publishes it through a triple buffer: the render thread never waits for the
// reader and the reader never waits for a pass. No GL here: the window thread uploads the frames.
//
// After each restart the first pass is a 1-spp pass on a film `preview_divisor` times smaller (when a full pass
// is expected to be slow), so a moving camera keeps a fluid, coarse image; preview passes are never cancelled,
// otherwise a stream of camera edits faster than one preview pass would never show anything.
#pragma once
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <future>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "film/film.h"
#include "render/progressive.h"
#include "scene/scene.h"

namespace pt {

struct SessionSettings {
  int threads = 0;  // render threads; 0 = all hardware threads
  StopConditions stop;
  // Preview pass resolution divisor after a restart: 0 = automatic (only when a full 1-spp pass is expected to
  // exceed ~20 ms, divisor chosen to make the preview take ~10 ms), 1 = never, N ≥ 2 = always 1/N.
  int preview_divisor = 0;
  // Clean preview (denoise/preview.h): the preview pass gathers features, a full-resolution guide pass traces
  // one ray per pixel, and the 1-spp preview is filtered and upsampled along the guide's edges into a smooth,
  // sharp full-resolution frame; otherwise the preview frame is the small raw film, magnified by the display.
  bool preview_denoise = false;
  bool background_priority = true;  // render threads at a lower OS priority than the (UI) owner thread
  // Denoise the published frames (denoise/denoiser.h): after a pass the render thread fills
  // DisplayFrame::denoised, at most about a third of its time (a newer denoise waits until twice the last one's
  // duration has passed; the last pass before a stop condition is always denoised, with the final-frame filter,
  // denoise_regression, where the passes get the viewer's à-trous filter). The session's film always keeps its
  // feature buffers (about 3 % of a sample's time), so turning this on does not restart the accumulation: the
  // current film is denoised and published at once, and turning it off only stops denoising.
  bool denoise = false;
  // A render region (Blender's render border): full passes trace only its pixels (clipped to the film; empty or
  // unset = the whole film), the others keep what they have, and the frame's spp, the relMSE estimate and the
  // stop conditions count only the region. Setting it does not restart the accumulation. Preview passes after an
  // edit still cover the whole image.
  std::optional<PixelRect> region;
};

// Where a clean preview frame's time went, in milliseconds (0 for other frames).
struct PreviewTimes {
  double pass = 0.0;      // the small 1-spp pass
  double guide = 0.0;     // the full-resolution feature pass (integrators/feature_pass.h)
  double variance = 0.0;  // denoise/preview.h, steps 1-3
  double filter = 0.0;
  double upsample = 0.0;
  double total() const { return pass + guide + variance + filter + upsample; }
};

// One published image. Buffers are reused: take_frame() swaps, so steady state allocates nothing.
struct DisplayFrame {
  int width = 0, height = 0;
  uint64_t generation = 0;  // the accumulation (restart) it belongs to
  uint64_t spp = 0;         // minimum samples per pixel of this film
  float max_count = 0;      // maximum samples per pixel of this film
  bool preview = false;     // a preview: a reduced-resolution film (see preview_divisor), or its clean
                            // full-resolution version (preview_denoise: no error estimate, count 0)
  PreviewTimes preview_times;  // a clean preview's
  // Per pixel, top row first: mean R, G, B and the relative standard error of the mean,
  // sqrt(mean over channels of Var[mean_c] / (mean_c² + 0.01)): its square averaged over the image is the film's
  // estimated relMSE. Pixels with fewer than 2 samples have an unknown error, stored as kUnknownError.
  std::vector<float> rgba;
  std::vector<float> count;  // samples per pixel
  // With SessionSettings::denoise, full-resolution frames: the denoised mean, R, G, B per pixel (empty otherwise).
  // `rgba` stays the raw estimate.
  std::vector<float> denoised;
  static constexpr float kUnknownError = 1e30f;
};

struct SessionStats {
  uint64_t generation = 0;  // accumulations started so far (1 = the first)
  uint64_t spp = 0;         // full-resolution samples in every pixel (0 while only a preview exists)
  double seconds = 0.0;     // render time of this accumulation, pauses excluded, live during a pass
  uint64_t samples = 0, rays = 0;  // traced in this accumulation (preview included)
  double samples_per_second = 0.0, rays_per_second = 0.0;
  double estimated_relmse = 0.0;  // +inf until every pixel has 2 samples
  uint64_t rejected = 0;          // non-finite samples kept out of the film
  int threads = 0;                // render threads in use
  bool paused = false;
  bool rendering = false;   // a pass is running right now
  bool done = false;        // a stop condition was met; the thread sleeps until something changes
  std::string stop_reason;  // which one ("target spp", "time limit", "target relMSE")
  std::string error;        // the scene could not be compiled: nothing renders until the next set_scene
};

class RenderSession {
 public:
  explicit RenderSession(const SceneDesc& scene, const SessionSettings& settings = {});
  ~RenderSession();
  RenderSession(const RenderSession&) = delete;
  RenderSession& operator=(const RenderSession&) = delete;

  // All thread-safe. The edits below cancel the running pass and restart accumulation; stats() shows 0 spp at
  // once. They return the generation whose frames will show the edit. The scene should be valid
  // (validate_scene); an invalid one is reported in stats().error.
  uint64_t set_scene(const SceneDesc& scene);
  // Typed edits (the viewer's): applied to the compiled scene in place, without copying or comparing its shapes.
  // The edit must be valid for the current scene (validate_edit).
  uint64_t edit(const SceneEdit& edit);
  // Estimator, sampler, bounces, seed: nothing is recompiled.
  uint64_t set_render(const RenderSettings& render);
  uint64_t restart();
  // Threads and stop conditions apply to the running accumulation without restarting it (the image does not
  // depend on the thread count). Raising a met stop condition resumes rendering.
  void set_settings(const SessionSettings& settings);
  SessionSettings settings() const;
  void set_paused(bool paused);

  SessionStats stats() const;
  // Copies estimated relMSE against render time of the current accumulation into `out` (reusing its capacity).
  void copy_history(std::vector<RelMsePoint>& out) const;
  // If a frame newer than the last one taken exists, swaps it into `frame` and returns true.
  bool take_frame(DisplayFrame& frame);
  // Runs `task` on the render thread between two passes with the accumulation's film (every sample so far, the
  // feature buffers) and returns its result: the viewer saves the film's layers as an EXR this way, without a
  // copy of the film. A task given before the current accumulation has a full-resolution pass waits for it.
  std::future<std::string> with_film(std::function<std::string(const Film&)> task);
  // Blocks until pred(stats()) holds after a pass or a state change, or the timeout; returns pred's last value.
  // For tests and scripted runs.
  bool wait_for(const std::function<bool(const SessionStats&)>& pred, double timeout_seconds) const;

 private:
  using Clock = std::chrono::steady_clock;
  struct Worker;  // the render thread's private state (renderer, compiled scenes, films)

  void run();
  static std::optional<PixelRect> render_region(const Worker& w);
  bool take_requests(Worker& w, bool& restart);
  bool prepare(Worker& w, bool restart);
  bool begin_pass(Worker& w, bool preview, int& spp);
  uint64_t request_restart_locked();
  template <class Change>
  uint64_t request(Change&& change);
  void publish(Worker& w, bool preview, Clock::time_point pass_start, uint64_t samples, uint64_t rays);
  void republish(Worker& w);
  void run_film_tasks(Worker& w);
  void make_clean_preview(Worker& w, double pass_seconds);
  bool denoise_frame(Worker& w, DisplayFrame& f, double relmse, double pass_seconds);
  void publish_locked(Worker& w, bool preview, uint32_t min_count, double relmse, double seconds, uint64_t samples,
                      uint64_t rays);
  bool stop_met_locked(std::string& reason) const;
  SessionStats stats_locked() const;

  mutable std::mutex mutex_;
  mutable std::condition_variable wake_;     // the render thread: something to do
  mutable std::condition_variable changed_;  // waiters of wait_for(): stats changed
  std::atomic<bool> cancel_{false};

  // Requests (guarded by mutex_).
  std::optional<SceneDesc> pending_scene_;
  std::vector<SceneEdit> pending_edits_;  // after pending_scene_ (which absorbs them while it is pending)
  std::optional<RenderSettings> pending_render_;
  bool pending_restart_ = false;
  bool settings_changed_ = false;
  struct FilmTask {
    std::function<std::string(const Film&)> run;
    std::promise<std::string> result;
  };
  std::vector<FilmTask> film_tasks_;
  SessionSettings settings_;
  bool paused_ = false;
  bool quit_ = false;
  uint64_t requested_generation_ = 0;

  // Published state (guarded by mutex_).
  SessionStats stats_;
  std::vector<RelMsePoint> history_;
  DisplayFrame middle_;  // the triple buffer's shared slot
  bool fresh_ = false;
  bool pass_running_ = false;
  bool preview_running_ = false;  // requests do not cancel a preview pass
  uint64_t pass_generation_ = 0;  // the accumulation the running pass belongs to
  Clock::time_point pass_start_;
  double seconds_before_pass_ = 0.0;

  std::thread thread_;
};

}  // namespace pt
