#include "render/render_session.h"

#include <cmath>
#include <limits>
#include <stdexcept>

#if defined(__linux__)
#include <sys/resource.h>
#include <unistd.h>
#endif

#include "denoise/denoiser.h"
#include "denoise/preview.h"
#include "integrators/feature_pass.h"
#include "film/film.h"
#include "render/renderer.h"
#include "scene/scene.h"

namespace pt {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Linux gives each thread its own nice value and new threads inherit their creator's, so lowering the session
// thread before it creates the Renderer lowers the whole pool. The owner (UI) thread keeps its priority and gets
// the CPU as soon as it wants it, whatever the pass costs.
void lower_this_thread_priority() {
#if defined(__linux__)
  const id_t tid = static_cast<id_t>(::gettid());
  errno = 0;
  const int nice = getpriority(PRIO_PROCESS, tid);
  if (errno == 0) setpriority(PRIO_PROCESS, tid, std::min(nice + 5, 19));
#endif
}

// Pass length grows with the accumulation: short passes while the image is noisy (frequent updates), up to half
// a second later (less per-pass overhead, and pause/edits still cancel within one tile).
double target_pass_seconds(double seconds_so_far) { return std::clamp(0.25 * seconds_so_far, 0.05, 0.5); }

int auto_preview_divisor(double full_seconds_per_spp) {
  if (full_seconds_per_spp <= 0.0) return 4;        // unknown cost: be safe
  if (full_seconds_per_spp < 0.02) return 1;        // a full pass is already fluid
  return std::clamp(static_cast<int>(std::ceil(std::sqrt(full_seconds_per_spp / 0.01))), 2, 16);
}

}  // namespace

// State only the render thread touches.
struct RenderSession::Worker {
  SessionSettings settings;
  SceneDesc desc;
  uint64_t generation = 0;
  bool scene_ok = false;
  bool full_dirty = true, preview_dirty = true;  // the compiled scenes must be rebuilt
  // Edits that keep the geometry (camera, materials, environment, render settings) are applied to the compiled
  // scenes in place (update_scene_appearance): `appearance_from` is the description they show.
  bool appearance_dirty = false;
  SceneDesc appearance_from;
  std::vector<SceneEdit> edits;  // typed edits taken since the compiled scenes were last brought up to date
  std::shared_ptr<Scene> full, preview;
  int preview_divisor = 1;  // of this accumulation; 1 = none
  bool need_preview = false;
  Film film, preview_film;
  std::unique_ptr<Renderer> renderer;
  int renderer_threads = -1;
  double full_seconds_per_spp = 0.0;  // measured cost of one full-resolution spp (kept across restarts)
  uint64_t film_spp = 0;
  DisplayFrame back;  // the triple buffer's render-side slot
  // The last denoised image, reused for the frames in between (SessionSettings::denoise).
  std::vector<float> denoised;
  uint64_t denoised_generation = 0;
  Clock::time_point next_denoise;
  FilmPlanes planes;             // film planes handed to the denoiser
  Denoiser denoiser;             // keeps its working planes between denoises
  bool republish_now = false;    // denoising was just turned on, or the region changed: publish the film anew
  // The clean preview (SessionSettings::preview_denoise): the full-resolution guide, the filter's working
  // planes, its output (RGB at full resolution) and where the time went.
  FeatureImage guide;
  PreviewDenoiser preview_denoiser;
  std::vector<float> clean_preview;
  PreviewTimes preview_times;
};

RenderSession::RenderSession(const SceneDesc& scene, const SessionSettings& settings) {
  settings_ = settings;
  settings_changed_ = true;
  pending_scene_ = scene;
  request_restart_locked();  // no other thread yet
  thread_ = std::thread([this] { run(); });
}

RenderSession::~RenderSession() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    quit_ = true;
    cancel_.store(true);
  }
  wake_.notify_all();
  thread_.join();
}

uint64_t RenderSession::request_restart_locked() {
  const uint64_t generation = ++requested_generation_;
  pending_restart_ = true;
  // The stats restart at once, so the UI never shows the old accumulation's numbers after an edit.
  SessionStats fresh;
  fresh.generation = generation;
  fresh.paused = paused_;
  fresh.threads = stats_.threads;
  fresh.estimated_relmse = kInf;
  stats_ = std::move(fresh);
  history_.clear();
  fresh_ = false;  // an unread frame of the old accumulation is stale now
  if (!preview_running_) cancel_.store(true);
  return generation;
}

// Every edit request: apply `change` to the pending requests under the lock, restart, wake the render thread.
template <class Change>
uint64_t RenderSession::request(Change&& change) {
  uint64_t g;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    change();
    g = request_restart_locked();
  }
  wake_.notify_all();
  changed_.notify_all();
  return g;
}

uint64_t RenderSession::set_scene(const SceneDesc& scene) {
  return request([&] {
    pending_scene_ = scene;
    pending_edits_.clear();  // the new scene replaces whatever they changed
    pending_render_.reset();
  });
}

uint64_t RenderSession::edit(const SceneEdit& edit) {
  return request([&] {
    if (pending_scene_) apply_edit(*pending_scene_, edit);
    else pending_edits_.push_back(edit);
  });
}

uint64_t RenderSession::set_render(const RenderSettings& render) {
  return request([&] {
    if (pending_scene_) pending_scene_->render = render;
    else pending_render_ = render;
  });
}

uint64_t RenderSession::restart() {
  return request([] {});
}

void RenderSession::set_settings(const SessionSettings& settings) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    settings_ = settings;
    settings_changed_ = true;
  }
  wake_.notify_all();
}

SessionSettings RenderSession::settings() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return settings_;
}

void RenderSession::set_paused(bool paused) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (paused_ == paused) return;
    paused_ = paused;
    stats_.paused = paused;
    if (paused && !preview_running_) cancel_.store(true);  // stop within a tile: 0 % CPU promptly
  }
  wake_.notify_all();
  changed_.notify_all();
}

SessionStats RenderSession::stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return stats_locked();
}

SessionStats RenderSession::stats_locked() const {
  SessionStats s = stats_;
  s.rendering = pass_running_;
  if (pass_running_ && pass_generation_ == stats_.generation) s.seconds = seconds_before_pass_ + std::chrono::duration<double>(Clock::now() - pass_start_).count();
  return s;
}

void RenderSession::copy_history(std::vector<RelMsePoint>& out) const {
  std::lock_guard<std::mutex> lock(mutex_);
  out.assign(history_.begin(), history_.end());
}

bool RenderSession::take_frame(DisplayFrame& frame) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!fresh_) return false;
  std::swap(frame, middle_);
  fresh_ = false;
  return true;
}

std::future<std::string> RenderSession::with_film(std::function<std::string(const Film&)> task) {
  std::future<std::string> result;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    film_tasks_.push_back({std::move(task), {}});
    result = film_tasks_.back().result.get_future();
  }
  wake_.notify_all();
  return result;
}

// Between passes: the tasks given to with_film, once the film has samples of the current accumulation.
void RenderSession::run_film_tasks(Worker& w) {
  std::vector<FilmTask> tasks;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (film_tasks_.empty() || w.film_spp == 0 || w.generation != requested_generation_) return;
    tasks.swap(film_tasks_);
  }
  for (FilmTask& t : tasks) {  // outside the lock: readers never wait for them
    try {
      t.result.set_value(t.run(w.film));
    } catch (...) {
      t.result.set_exception(std::current_exception());
    }
  }
}

bool RenderSession::wait_for(const std::function<bool(const SessionStats&)>& pred, double timeout_seconds) const {
  std::unique_lock<std::mutex> lock(mutex_);
  const auto deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                           std::chrono::duration<double>(timeout_seconds));
  return changed_.wait_until(lock, deadline, [&] { return pred(stats_locked()); });
}

bool RenderSession::stop_met_locked(std::string& reason) const {
  const char* r = stop_reason(settings_.stop, stats_.spp, stats_.seconds, stats_.estimated_relmse);
  if (!r) return false;
  reason = r;
  return true;
}

// The settings' render region on the current film; nullopt when it is unset, empty or the whole film.
std::optional<PixelRect> RenderSession::render_region(const Worker& w) {
  if (!w.settings.region) return std::nullopt;
  const PixelRect r = w.settings.region->clipped(w.film.width(), w.film.height());
  if (r.empty() || r == full_rect(w.film.width(), w.film.height())) return std::nullopt;
  return r;
}

void RenderSession::run() {
  Worker w;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (settings_.background_priority) lower_this_thread_priority();
  }
  for (;;) {
    bool restart = false;
    if (!take_requests(w, restart)) return;
    if (!prepare(w, restart)) continue;
    if (w.republish_now) republish(w);
    run_film_tasks(w);
    const bool preview = w.need_preview;
    int spp = 1;
    if (!begin_pass(w, preview, spp)) continue;
    const auto start = Clock::now();
    // Preview passes are never cancelled (see the header); full passes stop within a tile on any request.
    const std::optional<PixelRect> region = render_region(w);
    const PassStats ps = preview ? w.renderer->render_pass(*w.preview, w.desc.render, w.preview_film, 1, nullptr)
                                 : w.renderer->render_pass(*w.full, w.desc.render, w.film, spp, &cancel_,
                                                           region ? &*region : nullptr);
    const double pass_seconds = std::chrono::duration<double>(Clock::now() - start).count();
    if (preview && w.preview_film.has_features()) make_clean_preview(w, pass_seconds);
    if (!ps.cancelled)
      w.full_seconds_per_spp = preview ? pass_seconds * w.preview_divisor * w.preview_divisor : pass_seconds / spp;
    w.need_preview = false;
    publish(w, preview, start, ps.samples, ps.rays);
    run_film_tasks(w);
  }
}

// Sleeps until there is something to do, then adopts every pending request. False when the session ends.
bool RenderSession::take_requests(Worker& w, bool& restart) {
  std::unique_lock<std::mutex> lock(mutex_);
  wake_.wait(lock, [&] {
    return quit_ || pending_scene_ || pending_restart_ || settings_changed_ || (!paused_ && !stats_.done && w.scene_ok) ||
           (!film_tasks_.empty() && w.film_spp > 0);
  });
  if (quit_) return false;
  if (settings_changed_) {
    w.republish_now = w.republish_now || (settings_.denoise && !w.settings.denoise) || settings_.region != w.settings.region;
    w.settings = settings_;
    settings_changed_ = false;
    std::string reason;
    stats_.done = stop_met_locked(reason);  // a raised limit resumes, a lowered one stops
    stats_.stop_reason = stats_.done ? reason : "";
    changed_.notify_all();
  }
  if (pending_scene_) {
    if (w.scene_ok && same_shapes(w.desc, *pending_scene_)) {  // a new film size is set in place (prepare)
      if (!w.appearance_dirty) w.appearance_from = std::move(w.desc);  // what the compiled scenes show
      w.appearance_dirty = true;
    } else {
      w.full_dirty = w.preview_dirty = true;
      w.appearance_dirty = false;
    }
    w.desc = std::move(*pending_scene_);
    pending_scene_.reset();
    w.scene_ok = true;
    w.edits.clear();  // the new description includes them
  }
  for (SceneEdit& e : pending_edits_) {
    if (std::string err = validate_edit(w.desc, e); !err.empty()) {
      stats_.error = "edit not applied: " + err;  // the owner broke the contract: say so, render on
      continue;
    }
    apply_edit(w.desc, e);
    w.edits.push_back(std::move(e));
  }
  pending_edits_.clear();
  if (pending_render_) {
    w.desc.render = *pending_render_;
    pending_render_.reset();
  }
  if (pending_restart_) {
    pending_restart_ = false;
    w.generation = requested_generation_;
    restart = true;
  }
  cancel_.store(false);  // every request that set it has been consumed above
  return true;
}

// Renderer for the thread count, films and compiled scenes for the next pass. False (error reported) if the
// scene cannot be compiled.
bool RenderSession::prepare(Worker& w, bool restart) {
  try {
    if (w.renderer_threads != w.settings.threads) {
      w.renderer = std::make_unique<Renderer>(w.settings.threads);
      w.renderer_threads = w.settings.threads;
      std::lock_guard<std::mutex> lock(mutex_);
      stats_.threads = w.renderer->threads();
    }
    // A scene not compiled yet, or due for a rebuild anyway, needs no update. A camera moved far from where the
    // geometry was compiled: recompile instead.
    if (w.appearance_dirty && w.scene_ok) {
      // A description with the same shapes (set_scene): update from the difference, which covers the typed edits
      // taken since (they are in w.desc too).
      if (w.full && !w.full_dirty && !update_scene_appearance(*w.full, w.appearance_from, w.desc)) w.full_dirty = true;
      if (w.preview && !w.preview_dirty && !update_scene_appearance(*w.preview, w.appearance_from, w.desc))
        w.preview_dirty = true;
      w.appearance_dirty = false;
      w.edits.clear();
    }
    for (const SceneEdit& e : w.edits) {
      if (std::holds_alternative<FilmSize>(e)) continue;  // below: the compiled scenes take the new size in place
      if (w.full && !w.full_dirty && !apply_edit(*w.full, e)) w.full_dirty = true;
      if (w.preview && !w.preview_dirty && !apply_edit(*w.preview, e)) w.preview_dirty = true;
    }
    w.edits.clear();
    // The film size follows the description without rebuilding geometry (the viewer following its window).
    if (w.full && !w.full_dirty && (w.full->width != w.desc.width || w.full->height != w.desc.height))
      set_scene_resolution(*w.full, w.desc.width, w.desc.height, w.desc.camera);
    if (restart && w.scene_ok) {
      w.film.enable_features(true);  // always: denoising can be turned on at any time without a restart
      w.film.reset(w.desc.width, w.desc.height);
      w.film_spp = 0;
      const int divisor = w.settings.preview_divisor > 0 ? w.settings.preview_divisor
                                                          : auto_preview_divisor(w.full_seconds_per_spp);
      if (divisor != w.preview_divisor) w.preview_dirty = true;
      w.preview_divisor = divisor;
      w.need_preview = divisor > 1 && (w.desc.width >= 2 * divisor || w.desc.height >= 2 * divisor);
      const int small_width = std::max(1, w.desc.width / divisor), small_height = std::max(1, w.desc.height / divisor);
      if (w.need_preview && w.preview_dirty) {
        SceneDesc small = w.desc;
        small.width = small_width;
        small.height = small_height;
        w.preview = compile_scene(small);
        w.preview_dirty = false;
      } else if (w.need_preview && (w.preview->width != small_width || w.preview->height != small_height)) {
        set_scene_resolution(*w.preview, small_width, small_height, w.desc.camera);
      }
      if (w.need_preview) {
        w.preview_film.enable_features(w.settings.preview_denoise);
        w.preview_film.reset(w.preview->width, w.preview->height);
      }
    }
    // The full scene is compiled only once a full pass is next (a camera drag compiles just the previews), or for
    // a clean preview's guide.
    const bool guide_next = w.need_preview && w.settings.preview_denoise;
    if ((!w.need_preview || guide_next) && w.full_dirty && w.scene_ok) {
      w.full = compile_scene(w.desc);
      w.full_dirty = false;
    }
  } catch (const std::exception& e) {
    std::lock_guard<std::mutex> lock(mutex_);
    w.scene_ok = false;
    if (w.generation == requested_generation_) stats_.error = e.what();
    changed_.notify_all();
    return false;
  }
  return true;
}

// Sizes the next pass and marks it running; false if it should not run (paused, done, or a newer request).
// Settings changed since take_requests are a newer request too: stats_.done is judged by settings_, the pass
// sized by the worker's copy, and the two must agree (a limit raised while a region change republished the film
// let a pass run unbounded past it).
bool RenderSession::begin_pass(Worker& w, bool preview, int& spp) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!w.scene_ok || paused_ || stats_.done || pending_scene_ || pending_restart_ || settings_changed_) return false;
  spp = preview ? 1
                : next_pass_spp(w.full_seconds_per_spp, target_pass_seconds(stats_.seconds), w.settings.stop, w.film_spp,
                                stats_.seconds, stats_.estimated_relmse);
  pass_running_ = true;
  pass_generation_ = w.generation;
  preview_running_ = preview;
  pass_start_ = Clock::now();
  seconds_before_pass_ = stats_.seconds;
  return true;
}

// The clean preview of the small film just rendered: the full-resolution guide, then denoise/preview.h's filter
// into w.clean_preview, with the time of each step.
void RenderSession::make_clean_preview(Worker& w, double pass_seconds) {
  const Clock::time_point start = Clock::now();
  trace_feature_image(*w.full, w.desc.render, w.renderer->pool(), w.guide);
  const double guide_ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
  const PreviewFilterTimes t = w.preview_denoiser.run(w.preview_film, w.guide, w.renderer->pool(), w.clean_preview);
  w.preview_times = {pass_seconds * 1e3, guide_ms, t.variance, t.filter, t.upsample};
}

// Converts the film just rendered into the back frame (outside the lock: the reader never waits for this), then,
// unless a restart was requested meanwhile, publishes it.
void RenderSession::publish(Worker& w, bool preview, Clock::time_point pass_start, uint64_t samples, uint64_t rays) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    // Stale already (an edit came during the pass): skip the conversion and restart sooner, except for a preview,
    // which is still the newest image there is. During a drag, edits come faster than previews (60-120 a second
    // against one per 5-15 ms of preview): dropping stale previews showed a few images a second.
    if (w.generation != requested_generation_ && !preview) {
      pass_running_ = preview_running_ = false;
      changed_.notify_all();
      return;
    }
  }
  const Film& film = preview ? w.preview_film : w.film;
  DisplayFrame& f = w.back;
  const size_t n = film.pixel_count();
  f.generation = w.generation;
  f.preview = preview;
  f.preview_times = PreviewTimes{};
  uint32_t min_count = n ? std::numeric_limits<uint32_t>::max() : 0, max_count = 0;
  const bool clean = preview && film.has_features() && w.clean_preview.size() == 3 * w.guide.pixel_count();
  if (clean) {  // the full-resolution clean preview: a mean, no error estimate, no samples of its own
    f.width = w.guide.width;
    f.height = w.guide.height;
    const size_t m = w.guide.pixel_count();
    f.rgba.resize(4 * m);
    f.count.assign(m, 0.f);
    for (size_t i = 0; i < m; ++i) {
      float* px = &f.rgba[4 * i];
      px[0] = w.clean_preview[3 * i];
      px[1] = w.clean_preview[3 * i + 1];
      px[2] = w.clean_preview[3 * i + 2];
      px[3] = DisplayFrame::kUnknownError;
    }
    f.preview_times = w.preview_times;
    for (size_t i = 0; i < n; ++i) min_count = std::min(min_count, film.count(i)), max_count = std::max(max_count, film.count(i));
  } else {
    f.width = film.width();
    f.height = film.height();
    f.rgba.resize(4 * n);
    f.count.resize(n);
    for (size_t i = 0; i < n; ++i) {
      const uint32_t c = film.count(i);
      min_count = std::min(min_count, c);
      max_count = std::max(max_count, c);
      const Rgb m = film.mean(i);
      float rel = DisplayFrame::kUnknownError;
      if (c >= 2) {
        const glm::dvec3 var = film.variance_of_mean(i);
        double sum = 0.0;
        for (int k = 0; k < 3; ++k) {
          const double mk = film.mean_channel(i, k);
          sum += var[k] / (mk * mk + 0.01);
        }
        rel = static_cast<float>(std::sqrt(sum / 3.0));
      }
      float* px = &f.rgba[4 * i];
      px[0] = m.x;
      px[1] = m.y;
      px[2] = m.z;
      px[3] = rel;
      f.count[i] = static_cast<float>(c);
    }
  }
  const std::optional<PixelRect> region = preview ? std::nullopt : render_region(w);
  if (region) min_count = film.min_count(*region);
  f.spp = min_count;
  f.max_count = static_cast<float>(max_count);
  const double relmse = preview ? kInf : region ? film.estimated_relmse(*region) : film.estimated_relmse();
  if (!preview) w.film_spp = min_count;
  const double seconds = std::chrono::duration<double>(Clock::now() - pass_start).count();
  f.denoised.clear();
  if (!preview && w.settings.denoise && film.has_features() && !denoise_frame(w, f, relmse, seconds)) {
    std::lock_guard<std::mutex> lock(mutex_);  // stale: dropped, as above
    pass_running_ = preview_running_ = false;
    changed_.notify_all();
    return;
  }

  {
    std::lock_guard<std::mutex> lock(mutex_);
    pass_running_ = false;
    preview_running_ = false;
    if (w.generation == requested_generation_) {
      publish_locked(w, preview, min_count, relmse, seconds, samples, rays);
    } else if (preview) {  // shown, but accounted to no accumulation (the stats belong to the newer one)
      std::swap(w.back, middle_);
      fresh_ = true;
    }
    // else: an edit arrived meanwhile and this image is already stale.
  }
  changed_.notify_all();
}

// Denoising was turned on, or the render region changed: the current film (if it has samples) is published now,
// denoised, with its spp, relMSE and stop conditions over the new region, not after the next pass, which may be
// half a second away or never come (a finished render sleeps).
void RenderSession::republish(Worker& w) {
  w.republish_now = false;
  if (!w.scene_ok || w.need_preview || w.film_spp == 0 || w.film.width() != w.desc.width) return;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (w.generation != requested_generation_ || stats_.generation != w.generation) return;
  }
  publish(w, false, Clock::now(), 0, 0);
}

// Fills f.denoised: a fresh denoise of the film when the last one is old enough, when it belongs to an earlier
// accumulation, or when this pass meets a stop condition (the last image must be the film's own, and gets the
// final-frame filter); else the last denoised image (the fast filter's) again. Runs on the render thread, off the
// UI thread, using the render threads' pool. False when an edit (or the session's end) made the frame stale
// meanwhile: the denoise stops within a few rows and the frame is dropped, so that the edit's first image does not
// wait for it (the fast filter takes ~50 ms at 512² on 2 threads and runs every few passes).
bool RenderSession::denoise_frame(Worker& w, DisplayFrame& f, double relmse, double pass_seconds) {
  bool final_pass;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    final_pass = stop_reason(settings_.stop, f.spp, stats_.seconds + pass_seconds, relmse) != nullptr;
  }
  const Clock::time_point now = Clock::now();
  bool copied = false;
  if (final_pass) {
    // The image the session stops on gets the final-frame filter (≈0.7 s at 512², 2 threads); an edit or a
    // pause meanwhile cancels it, and the fast filter below serves instead (from the same planes).
    w.planes.copy_from(w.film);
    copied = true;
    std::vector<float> final_image = denoise_regression(w.planes.input(), RegressionSettings{}, w.renderer->pool(),
                                                        &cancel_);
    if (!final_image.empty()) {
      w.denoised = std::move(final_image);
      w.denoised_generation = w.generation;
      f.denoised = w.denoised;
      return true;
    }
  }
  if (final_pass || w.denoised_generation != w.generation || now >= w.next_denoise) {
    if (!copied) copy_viewer_planes(w.film, w.planes, w.renderer->pool());
    if (!w.denoiser.run(w.planes.input(), DenoiseSettings::viewer(), w.renderer->pool(), w.denoised, &cancel_)) {
      {
        std::lock_guard<std::mutex> lock(mutex_);
        if (quit_ || w.generation != requested_generation_) return false;
      }
      // A pause cancels too, but the frame is current: it is finished and shown.
      w.denoiser.run(w.planes.input(), DenoiseSettings::viewer(), w.renderer->pool(), w.denoised);
    }
    w.denoised_generation = w.generation;
    const Clock::time_point done = Clock::now();
    w.next_denoise = done + 2 * (done - now);
  }
  f.denoised = w.denoised;
  return true;
}

// Makes the converted frame current and accounts for its pass (mutex_ held, generation current).
void RenderSession::publish_locked(Worker& w, bool preview, uint32_t min_count, double relmse, double seconds,
                                   uint64_t samples, uint64_t rays) {
  std::swap(w.back, middle_);
  fresh_ = true;
  SessionStats& s = stats_;
  s.seconds += seconds;
  s.samples += samples;
  s.rays += rays;
  s.samples_per_second = s.seconds > 0.0 ? static_cast<double>(s.samples) / s.seconds : 0.0;
  s.rays_per_second = s.seconds > 0.0 ? static_cast<double>(s.rays) / s.seconds : 0.0;
  if (preview) return;  // a preview is not the accumulation: no spp, error or stop condition
  s.spp = min_count;
  s.estimated_relmse = relmse;
  s.rejected = w.film.rejected();
  if (std::isfinite(relmse)) {
    if (history_.size() >= 4096) {  // keep the plot bounded: drop every other point
      size_t k = 0;
      for (size_t j = 0; j < history_.size(); j += 2) history_[k++] = history_[j];
      history_.resize(k);
    }
    history_.push_back({s.seconds, relmse, min_count});
  }
  // Both ways: a republished film over a larger region may have fewer samples than the stop asks for.
  std::string reason;
  s.done = stop_met_locked(reason);
  s.stop_reason = s.done ? reason : "";
}

}  // namespace pt
