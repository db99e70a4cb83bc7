#include "viewer/viewer_window.h"

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_opengl3.h>
#include <imgui.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include "cli/interrupt.h"
#include "viewer/frame_stats.h"
#include "viewer/gl_api.h"
#include "viewer/gl_presenter.h"
#include "io/image_io.h"
#include "viewer/output_files.h"
#include "viewer/viewer_input.h"
#include "viewer/viewer_model.h"
#include "viewer/viewer_panels.h"
#include "viewer/viewer_prefs.h"

namespace pt {

namespace {

using Clock = std::chrono::steady_clock;

double ms_between(Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double, std::milli>(b - a).count(); }

std::string g_glfw_error;  // GLFW reports failures through a callback; kept for the error message
// Bumped by every input event (our callbacks are chained by ImGui's): an idle viewer sleeps until it changes.
std::atomic<unsigned> g_input_events{0};

void on_glfw_error(int, const char* description) { g_glfw_error = description ? description : "unknown error"; }
void on_cursor(GLFWwindow*, double, double) { ++g_input_events; }
void on_button(GLFWwindow*, int, int, int) { ++g_input_events; }
void on_scroll(GLFWwindow*, double, double) { ++g_input_events; }
// Presses are kept until a frame has seen them (KeyEvents: a quick tap between two frames is not lost).
KeyEvents g_keys;
void on_key(GLFWwindow*, int key, int, int action, int) {
  g_keys.on_key(key, action);
  ++g_input_events;
}
void on_char(GLFWwindow*, unsigned) { ++g_input_events; }
void on_size(GLFWwindow*, int, int) { ++g_input_events; }
// The window system lost the window's pixels (restored from minimised, uncovered, resized): redraw at once,
// whatever the render is doing (a finished or paused render sends no new images).
void on_refresh(GLFWwindow*) { ++g_input_events; }
void on_iconify(GLFWwindow*, int) { ++g_input_events; }
void on_focus(GLFWwindow*, int) { ++g_input_events; }
// Files dropped on the window; opened by the loop (callbacks run inside glfwPollEvents, on this thread).
std::vector<std::string> g_dropped;
void on_drop(GLFWwindow*, int count, const char** paths) {
  for (int i = 0; i < count; ++i)
    if (paths[i]) g_dropped.emplace_back(paths[i]);
  ++g_input_events;
}
// The close button asks the model, which may want to ask the user first (unsaved scene edits).
std::atomic<bool> g_close_requested{false};
void on_close(GLFWwindow* w) {
  g_close_requested = true;
  glfwSetWindowShouldClose(w, GLFW_FALSE);
  ++g_input_events;
}

struct Rect {
  int x = 0, y = 0, w = 0, h = 0;  // GL convention: y from the bottom
};

// --bench-edits: the two kinds of edit a user makes most, alternately, to time edit → image.
void scripted_edit(ViewerModel& model, int index, float image_height) {
  if (index % 2 == 0) {
    ViewInput in;
    in.orbit = true;
    in.drag = Vec2(index % 4 == 0 ? 6.f : -6.f, 0.f);
    in.viewport_height = image_height;
    model.apply_input(in, 0.0);
  } else {
    MaterialDesc m = model.scene().materials[0];
    m.albedo = index % 4 == 1 ? m.albedo * 0.9f : m.albedo / 0.9f;
    model.set_material(0, m);
  }
}

bool write_screenshot(const std::string& path, int w, int h) {
  std::vector<uint8_t> px(4ull * w * h);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadBuffer(GL_BACK);
  glReadPixels(0, 0, w, h, GL_RGBA, GL_UNSIGNED_BYTE, px.data());
  const size_t row = 4ull * w;
  std::vector<uint8_t> flipped(px.size());
  for (int y = 0; y < h; ++y) std::copy_n(&px[row * (h - 1 - y)], row, &flipped[row * y]);
  try {
    write_png_rgba8(path, w, h, flipped);
  } catch (const ImageError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return false;
  }
  std::printf("wrote %s (%dx%d)\n", path.c_str(), w, h);
  return true;
}

// What --stats reports, in milliseconds.
struct FrameTimes {
  SampleSeries interval, work, poll, upload, ui, draw, swap, latency;
  SampleSeries clean_latency;  // edit to the first full-resolution denoised image
  // Clean preview frames (SessionSettings::preview_denoise): their whole time, and the filter's share of it
  // (variance, filter and upsampling over pass, guide, variance, filter and upsampling).
  SampleSeries preview_total, preview_pass, preview_guide, preview_filter, preview_filter_share;
  void add_preview(const PreviewTimes& t) {
    if (!(t.total() > 0.0)) return;
    const double filter = t.variance + t.filter + t.upsample;
    preview_total.add(t.total());
    preview_pass.add(t.pass);
    preview_guide.add(t.guide);
    preview_filter.add(filter);
    preview_filter_share.add(100.0 * filter / t.total());
  }
  void reserve(size_t n) {
    interval.reserve(n);
    work.reserve(n);
    poll.reserve(n);
    ui.reserve(n);
    draw.reserve(n);
    swap.reserve(n);
  }
  void print() const {
    std::printf("frame interval ms (between consecutive drawn frames): %s\n", interval.summary().c_str());
    std::printf("frame work ms (poll, upload, UI, draw, swap): %s\n", work.summary().c_str());
    std::printf("  of which event polling ms: %s\n", poll.summary().c_str());
    std::printf("  of which image upload ms: %s\n", upload.summary().c_str());
    std::printf("  of which ImGui frame ms: %s\n", ui.summary().c_str());
    std::printf("  of which GL draw calls ms (image and panels, recorded): %s\n", draw.summary().c_str());
    std::printf("  of which swap ms (the GL finishes drawing here; includes any vsync wait): %s\n",
                swap.summary().c_str());
    std::printf("edit to first updated image ms: %s\n", latency.summary().c_str());
    if (clean_latency.size() > 0)
      std::printf("edit to first full-resolution denoised image ms: %s\n", clean_latency.summary().c_str());
    if (preview_total.size() > 0) {
      std::printf("clean preview frame ms (pass, guide, filter and upsampling): %s\n", preview_total.summary().c_str());
      std::printf("  of which the small 1-spp pass ms: %s\n", preview_pass.summary().c_str());
      std::printf("  of which the full-resolution guide ms: %s\n", preview_guide.summary().c_str());
      std::printf("  of which filter and upsampling ms: %s\n", preview_filter.summary().c_str());
      std::printf("  filter and upsampling, %% of the preview frame: %s\n", preview_filter_share.summary().c_str());
    }
  }
};

// One UI frame: ImGui's frame with the input handled, the image placed (where this frame's input left it: a
// zoom applies at once) and the panels drawn; nothing is on screen yet.
struct UiFrame {
  int fb_w = 0, fb_h = 0;  // the framebuffer
  Rect image;              // where the image goes, in framebuffer pixels counted from the bottom (GL)
  double image_height = 1; // its height in window units (drag scaling of scripted edits)
  bool held = false;       // a key or button is held: keep drawing
};
UiFrame build_ui_frame(GLFWwindow* window, ImGuiIO& io, ViewerModel& model, PanelState& panels, ShownImage& shown,
                       const DisplayFrame& front, double dt) {
  UiFrame ui;
  ImGui_ImplOpenGL3_NewFrame();
  ImGui_ImplGlfw_NewFrame();
  g_keys.before_frame(io);
  ImGui::NewFrame();
  glfwGetFramebufferSize(window, &ui.fb_w, &ui.fb_h);
  const float scale = io.DisplaySize.x > 0.f ? static_cast<float>(ui.fb_w) / io.DisplaySize.x : 1.f;
  const float panel = model.ui_visible ? std::min(panels.width(), io.DisplaySize.x) : 0.f;
  // Following the window, the film takes the image area's size (framebuffer pixels).
  model.note_image_area(static_cast<int>(std::lround((io.DisplaySize.x - panel) * scale)),
                        static_cast<int>(std::lround(io.DisplaySize.y * scale)));
  const ImageArea area = place_image(model.zoom, model.scene().width, model.scene().height, 0.f, 0.f,
                                     io.DisplaySize.x - panel, io.DisplaySize.y, scale);
  ui.image_height = area.h;
  handle_viewer_input(io, model, dt, area);
  draw_pixel_probe(model, front, area);
  const ImageArea shown_area = place_image(model.zoom, model.scene().width, model.scene().height, 0.f, 0.f,
                                           io.DisplaySize.x - panel, io.DisplaySize.y, scale);
  draw_region_overlay(io, model, shown_area);
  ui.image.x = static_cast<int>(std::lround(shown_area.x * scale));
  ui.image.w = static_cast<int>(std::lround(shown_area.w * scale));
  ui.image.h = static_cast<int>(std::lround(shown_area.h * scale));
  ui.image.y = ui.fb_h - static_cast<int>(std::lround(shown_area.y * scale)) - ui.image.h;
  ui.held = viewer_input_held(io);
  draw_viewer_panels(model, panels, shown);
  ImGui::Render();
  g_keys.after_frame(io);
  return ui;
}

// The preferences at exit: written back only if the user changed them here (the command line's --size counts
// for this run only).
void save_prefs_if_changed(const std::string& prefs_path, const ViewerPrefs& prefs, const PanelState& panels,
                           const ViewerModel& model, const ViewOptions& o) {
  ViewerPrefs now = prefs;
  now.panel_width = std::clamp(panels.width_units, ViewerPrefs::kMinPanelWidth, ViewerPrefs::kMaxPanelWidth);
  now.follow_scale = model.follow_scale();
  if (o.size.empty() || (o.size == "window") != model.follow_window()) now.follow_window = model.follow_window();
  if (now.panel_width != prefs.panel_width || now.follow_window != prefs.follow_window ||
      now.follow_scale != prefs.follow_scale)
    if (const std::string err = write_viewer_prefs(prefs_path, now); !err.empty())
      std::fprintf(stderr, "warning: %s\n", err.c_str());
}

// --stats at exit.
void print_stats(ViewerModel& model, const ViewOptions& o, const FrameTimes& times, long long frames, double seconds) {
  std::printf("frames drawn: %lld in %.2f s%s\n", frames, seconds,
              o.continuous || o.frames > 0 ? " (continuous)" : " (on demand)");
  times.print();
  const SessionStats st = model.session().stats();
  std::printf("render: %llu spp, %.2f Msamples/s, %.2f Mrays/s, %d threads\n", static_cast<unsigned long long>(st.spp),
              st.samples_per_second * 1e-6, st.rays_per_second * 1e-6, st.threads);
}

// Ctrl-C / SIGTERM: save the image so far (as the S key does), then close the window normally, so --stats still
// prints and the session stops cleanly. A second signal exits at once (InterruptScope).
int run_loop(GLFWwindow* window, ViewerModel& model, const ViewOptions& o, const InterruptScope& interrupts,
             ViewerScript script) {
  GlPresenter presenter;  // throws GlError
  ImGuiIO& io = ImGui::GetIO();
  DisplayFrame front;
  PanelState panels;
  // The preferences (panel width, following the window); the command line's --size wins for this run. Written
  // back at exit only if the user changed them here.
  const std::string prefs_path = viewer_config_path("viewer.conf");
  std::vector<std::string> prefs_warnings;
  const ViewerPrefs prefs = read_viewer_prefs(prefs_path, prefs_warnings);
  for (const std::string& w : prefs_warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
  panels.width_units = prefs.panel_width;
  model.set_follow_window(o.size.empty() ? prefs.follow_window : o.size == "window", prefs.follow_scale);
  ShownImage shown;
  FrameTimes times;
  times.reserve(o.frames > 0 ? static_cast<size_t>(o.frames) : 4096);
  std::vector<uint8_t> save_pixels;

  const Clock::time_point t0 = Clock::now();
  Clock::time_point last_draw = t0, last_title = t0 - std::chrono::seconds(1);
  std::string title;
  bool drew_last_iteration = false, held = false;
  unsigned seen_events = g_input_events.load();
  int active_frames = 3;  // ImGui settles hover/focus state over a few frames after any input
  long long frame = 0;
  int bench_index = 0;
  double smoothed_ms = 0.0, image_height = 1.0;
  int rc = 0;
  bool saving_on_signal = false;
  std::vector<std::string> scripted_shots;  // --script screenshots, written when the next frame is drawn

  for (;;) {
    const Clock::time_point start = Clock::now();
    glfwPollEvents();
    const double poll_ms = ms_between(start, Clock::now());
    if (g_close_requested.exchange(false)) model.request_quit();
    for (const std::string& path : g_dropped) model.open_file(path);
    g_dropped.clear();
    // Quitting draws one last frame when a screenshot is wanted (the back buffer is undefined after a swap).
    const int sig = interrupts.signal_received();
    if (sig != 0 && !saving_on_signal) {
      saving_on_signal = true;
      model.save_requested = true;
      std::fprintf(stderr, "interrupted by %s: saving the image so far, then quitting\n", InterruptScope::signal_name(sig));
    }
    const bool quitting = glfwWindowShouldClose(window) || model.quit_requested || sig != 0 ||
                          (o.seconds > 0.0 && ms_between(t0, start) >= o.seconds * 1e3);
    if (quitting && o.screenshot.empty() && !model.save_requested) break;
    const unsigned events = g_input_events.load();
    if (events != seen_events) active_frames = 3;
    seen_events = events;
    if (o.bench_edits > 0.0 && ms_between(t0, start) * 1e-3 >= o.bench_edits * (bench_index + 1))
      scripted_edit(model, bench_index++, static_cast<float>(image_height));
    script.run_due(ms_between(t0, start) * 1e-3, [&](const ScriptAction& a) {
      if (a.verb == ScriptVerb::Screenshot) scripted_shots.push_back(a.name);
      if (const std::string err = apply_script_action(model, a); !err.empty())
        std::fprintf(stderr, "warning: --script line %d (%s): %s\n", a.line, enum_name(a.verb), err.c_str());
    });

    if (model.poll_saves()) active_frames = 3;  // show its message
    const Clock::time_point upload_start = Clock::now();
    const bool new_image = model.session().take_frame(front);  // never waits for a pass
    if (model.snapshot_requested && front.width > 0 && !front.preview) {  // A/B: keep the newest full frame
      model.snapshot_requested = false;
      presenter.upload_snapshot(front);
      model.snapshot = SnapshotInfo{front.width, front.height, front.spp};
    }
    if (new_image) {
      if (front.preview) times.add_preview(front.preview_times);
      presenter.upload(front);
      times.upload.add(ms_between(upload_start, Clock::now()));
      shown.width = front.width;
      shown.height = front.height;
      shown.preview = front.preview;
      shown.spp = front.spp;
      shown.max_count = front.max_count;
    }

    // Redraw on demand: a new image, input (or a held key/button), a pending save, or, while rendering, the
    // stats read-outs 10 times a second. Under a software GL (llvmpipe, Xvfb, remote X) every redraw costs CPU
    // the render threads would otherwise use; on a GPU it saves power. --continuous redraws every frame.
    const SessionStats st = model.session().stats();
    const bool rendering = !st.paused && !st.done && st.error.empty();
    if (ms_between(last_title, start) >= 250.0) {  // the title follows spp, time and relMSE
      last_title = start;
      std::string t = model.window_title(st);
      if (t != title) glfwSetWindowTitle(window, (title = std::move(t)).c_str());
    }
    const bool draw = quitting || o.continuous || o.frames > 0 || frame == 0 || new_image || held || active_frames > 0 ||
                      model.save_requested || !scripted_shots.empty() ||
                      (rendering && ms_between(last_draw, start) >= 100.0);
    if (draw) {
      if (drew_last_iteration) times.interval.add(ms_between(last_draw, start));
      // Camera motion uses the time since the last drawn frame, bounded so the first frame after a pause in
      // drawing does not jump.
      const double dt = std::min(ms_between(last_draw, start) * 1e-3, 0.05);
      last_draw = start;
      if (active_frames > 0) --active_frames;

      const Clock::time_point ui_start = Clock::now();
      shown.frame_ms = smoothed_ms;
      const UiFrame ui = build_ui_frame(window, io, model, panels, shown, front, dt);
      const int fb_w = ui.fb_w, fb_h = ui.fb_h;
      const Rect& r = ui.image;
      image_height = ui.image_height;
      held = ui.held;
      times.ui.add(ms_between(ui_start, Clock::now()));

      const Clock::time_point draw_start = Clock::now();
      glViewport(0, 0, fb_w, fb_h);
      glClearColor(0.08f, 0.08f, 0.09f, 1.f);
      glClear(GL_COLOR_BUFFER_BIT);
      presenter.draw(r.x, r.y, r.w, r.h, model.present);
      ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
      times.draw.add(ms_between(draw_start, Clock::now()));

      if (model.save_requested) {
        model.save_requested = false;
        presenter.read_image(model.present, save_pixels);
        if (auto stem = model.save_image(save_pixels, front)) {
          std::printf("wrote %s.png and %s.pfm\n", stem->c_str(), stem->c_str());
        } else if (saving_on_signal) {
          std::fprintf(stderr, "error: %s\n", model.status().c_str());
          rc = 1;
        }
      }

      ++frame;
      // With --screenshot, the last frame is no earlier than the first full-resolution image (or 30 s later).
      const bool image_ready = shown.width > 0 && !shown.preview;
      const bool last = quitting || (o.frames > 0 && frame >= o.frames &&
                                     (o.screenshot.empty() || image_ready || ms_between(t0, start) > 30e3));
      if (last && !o.screenshot.empty() && !write_screenshot(o.screenshot, fb_w, fb_h)) rc = 1;
      for (const std::string& shot : scripted_shots)
        if (!write_screenshot(shot, fb_w, fb_h)) rc = 1;
      scripted_shots.clear();
      const Clock::time_point swap_start = Clock::now();
      glfwSwapBuffers(window);
      const Clock::time_point end = Clock::now();
      times.swap.add(ms_between(swap_start, end));
      const double frame_ms = ms_between(start, end);
      times.work.add(frame_ms);
      times.poll.add(poll_ms);
      smoothed_ms = smoothed_ms == 0.0 ? frame_ms : 0.9 * smoothed_ms + 0.1 * frame_ms;
      if (new_image) {
        if (auto latency = model.note_frame_shown(front.generation, end)) {
          times.latency.add(*latency);
          shown.edit_latency_ms = *latency;
        }
        const bool clean = !front.preview && !front.denoised.empty() && model.present.denoise;
        if (auto latency = model.note_clean_frame_shown(front.generation, clean, end)) times.clean_latency.add(*latency);
      }
      if (last) break;
    }
    drew_last_iteration = draw;

    // Pacing: poll at most max_fps times a second (new images arrive without a window event); with nothing to
    // wait for (paused, done, broken scene, no input), sleep until input, checking 4 times a second.
    const bool sleepy = !rendering && !draw && !held && o.bench_edits <= 0.0;
    const double budget_ms = sleepy ? 250.0 : (o.max_fps > 0.0 ? 1e3 / o.max_fps : 0.0);
    const double remaining_ms = budget_ms - ms_between(start, Clock::now());
    if (remaining_ms > 0.0) glfwWaitEventsTimeout(remaining_ms * 1e-3);
  }

  save_prefs_if_changed(prefs_path, prefs, panels, model, o);
  if (o.stats) print_stats(model, o, times, frame, ms_between(t0, Clock::now()) * 1e-3);
  return rc;
}

}  // namespace

int run_viewer_window(const ViewOptions& o, const SceneDesc& scene, const SessionSettings& settings,
                      std::vector<ScriptAction> script) {
  glfwSetErrorCallback(on_glfw_error);
  const InterruptScope interrupts;
  if (!glfwInit()) {
    std::fprintf(stderr,
                 "error: `view` needs a display and none is available (%s).\n"
                 "       Render without a window instead: pathtracer render --scene %s\n",
                 g_glfw_error.c_str(), o.scene.c_str());
    return 2;
  }
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
  // The default window holds the image at 1:1 beside the panel, with a margin, and is at least 800 high (the
  // panel is long), within 90 % of the monitor's work area. The panel grows with the monitor's content scale.
  float content_scale = 1.f;
  GLFWmonitor* monitor = glfwGetPrimaryMonitor();
  if (monitor) {
    float sx = 1.f, sy = 1.f;
    glfwGetMonitorContentScale(monitor, &sx, &sy);
    content_scale = std::max(sx, sy);
  }
  constexpr int kMargin = 16;
  int width = scene.width + 2 * kMargin + static_cast<int>(kPanelWidth * content_scale);
  int height = std::max(scene.height + 2 * kMargin, static_cast<int>(800 * content_scale));
  if (monitor) {
    int mx = 0, my = 0, mw = 0, mh = 0;
    glfwGetMonitorWorkarea(monitor, &mx, &my, &mw, &mh);
    if (mw > 0 && mh > 0) {
      width = std::min(width, mw * 9 / 10);
      height = std::min(height, mh * 9 / 10);
    }
  }
  const std::string title = scene_short_name(o.scene) + " - pathtracer";
  GLFWwindow* window = glfwCreateWindow(width, height, title.c_str(), nullptr, nullptr);
  if (!window) {
    std::fprintf(stderr, "error: cannot open a window with an OpenGL 3.3 core context (%s)\n", g_glfw_error.c_str());
    glfwTerminate();
    return 2;
  }
  glfwMakeContextCurrent(window);
  glfwSwapInterval(1);
  // Installed before ImGui's, which chain to them.
  glfwSetCursorPosCallback(window, on_cursor);
  glfwSetMouseButtonCallback(window, on_button);
  glfwSetScrollCallback(window, on_scroll);
  glfwSetKeyCallback(window, on_key);
  glfwSetCharCallback(window, on_char);
  glfwSetFramebufferSizeCallback(window, on_size);
  glfwSetWindowRefreshCallback(window, on_refresh);
  glfwSetWindowIconifyCallback(window, on_iconify);
  glfwSetWindowFocusCallback(window, on_focus);
  glfwSetWindowCloseCallback(window, on_close);
  glfwSetDropCallback(window, on_drop);

  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;  // no imgui.ini dropped into the user's directory
  {
    float sx = 1.f, sy = 1.f;
    glfwGetWindowContentScale(window, &sx, &sy);  // HiDPI: fonts and widgets follow the monitor's scale
    setup_viewer_style(std::max(sx, sy));
  }
  int rc = 2;
  const bool glfw_backend = ImGui_ImplGlfw_InitForOpenGL(window, true);
  const bool gl_backend = glfw_backend && ImGui_ImplOpenGL3_Init("#version 330 core");
  if (!gl_backend) {
    std::fprintf(stderr, "error: cannot initialise the ImGui GLFW/OpenGL3 backends\n");
  } else {
    try {
      ViewerModel model(scene, scene_short_name(o.scene), settings);
      model.present.display.exposure_ev = o.exposure;
      // The command line checked the names against the same tables.
      parse_enum(o.tonemap, model.present.display.tone_map);
      parse_enum(o.mode, model.present.mode);
      parse_enum(o.denoise_view, model.present.denoise_view);
      model.files.output_dir = o.output_dir;
      RecentFiles recent;  // ~/.config/pathtracer/recent-scenes.txt
      model.files.recent = &recent;
      if (std::filesystem::is_regular_file(o.scene)) recent.add(o.scene);
      model.ui_visible = !o.hide_ui;
      rc = run_loop(window, model, o, interrupts, ViewerScript(std::move(script)));
    } catch (const GlError& e) {
      std::fprintf(stderr, "error: %s\n", e.what());
      rc = 2;
    }
    ImGui_ImplOpenGL3_Shutdown();
  }
  if (glfw_backend) ImGui_ImplGlfw_Shutdown();
  ImGui::DestroyContext();
  glfwDestroyWindow(window);
  glfwTerminate();
  return rc;
}

}  // namespace pt
