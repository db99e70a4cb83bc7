// `pathtracer view`: the interactive viewer (GLFW window, OpenGL display, Dear ImGui panels). docs/viewer.md.
#pragma once
#include <optional>
#include <string>

namespace CLI {
class App;
}

namespace pt {

struct ViewOptions {
  std::string scene = "cornell";
  int threads = 0;
  std::optional<long long> spp;
  std::optional<double> time_seconds, target_relmse;
  float exposure = 0.f;
  std::string tonemap = "clamp";
  std::string mode = "colour";
  std::string output_dir = ".";
  int preview_divisor = 0;
  std::string size;          // "window" (follow it) or "scene" (the film size); "" = as last time (preferences)
  bool raw_preview = false;  // show the raw 1-spp preview instead of the clean (denoised, upsampled) one
  bool denoise = true;           // denoising on (--no-denoise: off)
  std::string denoise_view = "denoised";
  // Scripted and measured runs.
  long long frames = 0;     // quit after this many UI frames, drawn continuously (0: run until closed)
  double seconds = 0.0;     // quit after this many seconds (0: run until closed)
  std::string screenshot;   // write the window's last frame here (PNG)
  bool stats = false;       // print frame-time and edit-latency figures at exit
  double bench_edits = 0.0; // every this many seconds, make an edit (camera nudge / albedo change) to time it
  std::string script;       // timed actions (viewer_script.h), read before the window opens
  double max_fps = 120.0;   // UI frame cap when the display does not sync (0: none)
  bool hide_ui = false;
  bool continuous = false;  // redraw every frame even when nothing changed (measuring; as during a drag)
};

void add_view_command(CLI::App& app, ViewOptions& options);
// Exit status: 0 closed normally, 1 the screenshot could not be written, 2 bad scene/options or no display.
int run_view(const ViewOptions& options);

}  // namespace pt
