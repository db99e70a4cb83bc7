#include "viewer/view_command.h"

#include <CLI/CLI.hpp>
#include <cstdio>

#include "cli/option_checks.h"
#include "cli/scene_arg.h"
#include "viewer/display_transform.h"
#include "viewer/viewer_script.h"
#include "viewer/viewer_window.h"

namespace pt {

void add_view_command(CLI::App& app, ViewOptions& o) {
  CLI::App* v = app.add_subcommand("view", "Interactive viewer: progressive rendering in a window with live controls");
  v->add_option("scene", o.scene, scene_arg_help())
      ->capture_default_str();
  v->add_option("--threads", o.threads, "Render threads; 0 = all hardware threads")
      ->check(whole_in(0, 1024))
      ->capture_default_str();
  v->add_option("--spp", o.spp, "Stop accumulating at N samples per pixel")->check(whole_in(1, 1LL << 31));
  v->add_option("--time", o.time_seconds, "Stop accumulating after this many seconds")->check(finite_in(1e-3, 1e7));
  v->add_option("--target-relmse", o.target_relmse, "Stop when the film's estimated relMSE falls to E (from 16 spp on)")
      ->check(finite_in(1e-12, 1e6));
  v->add_option("--exposure", o.exposure, "Display exposure in EV stops")->check(finite_in(-64, 64))->capture_default_str();
  v->add_option("--tonemap", o.tonemap, "Display tone map: " + enum_names_joined<ToneMap>(" | "))
      ->check(CLI::IsMember(enum_name_list<ToneMap>()))
      ->capture_default_str();
  std::vector<std::string> modes = enum_name_list<ViewMode>();
  modes.resize(kStartupViewModes);  // the difference view needs a kept snapshot
  v->add_option("--mode", o.mode, "View: colour | error (relative standard error heat map) | samples")
      ->check(CLI::IsMember(modes))
      ->capture_default_str();
  v->add_flag("--denoise,!--no-denoise", o.denoise,
              "Denoise the display (default; feature-guided filters on the render thread, docs/denoising.md); "
              "--no-denoise shows the raw film")
      ->capture_default_str();
  v->add_option("--denoise-view", o.denoise_view,
                "While denoising: " + enum_names_joined<DenoiseView>(" | ") + " (split: raw left, denoised right)")
      ->check(CLI::IsMember(enum_name_list<DenoiseView>()))
      ->capture_default_str();
  v->add_option("--output-dir", o.output_dir, "Folder for saved images (S key)")->capture_default_str();
  v->add_option("--preview-divisor", o.preview_divisor,
                "Resolution divisor of the first pass after each change; 0 = automatic, 1 = off")
      ->check(whole_in(0, 64))
      ->capture_default_str();
  v->add_option("--size", o.size,
                "Render size: window (follow the image area, HiDPI-aware; the Scene panel sets a scale) or scene "
                "(the scene's film size); default: as last time, else window")
      ->check(CLI::IsMember({"window", "scene"}));
  v->add_flag("--raw-preview", o.raw_preview,
              "While the view changes, show the raw 1-spp preview (magnified) instead of the clean one (denoised and "
              "upsampled along a full-resolution guide; docs/viewer.md)");
  v->add_option("--seconds", o.seconds, "Quit after S seconds (0 = when the window is closed)")
      ->check(finite_in(0, 1e7));
  v->add_option("--frames", o.frames, "Quit after N UI frames, drawn continuously (0 = when the window is closed)")
      ->check(whole_in(0, 1LL << 40))
      ->capture_default_str();
  v->add_option("--screenshot", o.screenshot,
                "Write the window's last frame (panels included) to this PNG when quitting; with --frames, no "
                "earlier than the first full-resolution image");
  v->add_flag("--stats", o.stats, "At exit, print UI frame times and edit-to-image latencies (median, p95, max)");
  v->add_option("--bench-edits", o.bench_edits,
                "Every S seconds make an edit (orbit the camera / change the first material's albedo) to time "
                "edit-to-image latency")
      ->check(finite_in(0, 1e6));
  v->add_option("--script", o.script,
                "Timed actions, one per line: SECONDS ACTION [ARGS] (orbit DX DY, emission MATERIAL STRENGTH, "
                "screenshot FILE, quit); docs/viewer.md");
  v->add_option("--max-fps", o.max_fps, "UI frame cap when the display does not sync; 0 = none")
      ->check(finite_in(0, 1e4))
      ->capture_default_str();
  v->add_flag("--hide-ui", o.hide_ui, "Start with the panels hidden (Tab shows them)");
  v->add_flag("--continuous", o.continuous,
              "Redraw every frame (up to --max-fps) even when nothing changed; default: redraw on input, new "
              "images and 10 times a second while rendering");
  v->footer(
      "Mouse: left drag orbit, middle or shift+left drag pan, wheel dolly, right drag look; right held + WASD/QE\n"
      "fly. Keys: R reset, P pause, S save PNG+PFM, Tab panels, F1 help, Esc quit. See docs/viewer.md.\n"
      "Ctrl-C or SIGTERM saves the image as S does, then quits; a second one quits at once without saving.\n"
      "Exit status: 0 ok, 1 cannot write the screenshot (or, on Ctrl-C, the image), 2 invalid scene or options, or\n"
      "no display.");
}

int run_view(const ViewOptions& o) {
  const std::optional<SceneDesc> desc = load_scene_arg(o.scene);
  if (!desc) return 2;
  std::vector<ScriptAction> script;
  if (!o.script.empty()) {
    try {
      script = read_viewer_script(o.script);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "error: --script: %s\n", e.what());
      return 2;
    }
  }
  SessionSettings settings;
  settings.threads = o.threads;
  settings.preview_divisor = o.preview_divisor;
  settings.preview_denoise = !o.raw_preview;
  settings.denoise = o.denoise;
  if (o.spp) settings.stop.spp = static_cast<uint64_t>(*o.spp);
  if (o.time_seconds) settings.stop.seconds = *o.time_seconds;
  if (o.target_relmse) settings.stop.relmse = *o.target_relmse;
  return run_viewer_window(o, *desc, settings, std::move(script));
}

}  // namespace pt
