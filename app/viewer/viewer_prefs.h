// What the viewer remembers between sessions besides the recent files: the side panel's width and whether the
// render follows the window's size (and at which scale). One `key=value` per line in
// $XDG_CONFIG_HOME/pathtracer/viewer.conf (else ~/.config/...). A missing file gives the defaults; an unknown key
// or a value out of range is ignored with a warning (the default stands); writing goes through
// write_file_safely, and a failure to write is reported, never fatal.
#pragma once
#include <string>
#include <vector>

namespace pt {

// $XDG_CONFIG_HOME/pathtracer/NAME, else $HOME/.config/pathtracer/NAME; "" when neither variable is set.
std::string viewer_config_path(const std::string& name);

// The resolution choices of "follow the window": render pixels per framebuffer pixel.
inline constexpr float kFollowScales[] = {1.f, 0.5f, 0.25f};

struct ViewerPrefs {
  float panel_width = 380.f;  // ImGui units at a content scale of 1
  bool follow_window = true;  // the render's size follows the image area (else the scene's film size)
  float follow_scale = 1.f;   // one of kFollowScales
  static constexpr float kMinPanelWidth = 260.f, kMaxPanelWidth = 900.f;
};

// Reads `path` ("" = none: the defaults). Warnings (a bad line) are appended to `warnings`.
ViewerPrefs read_viewer_prefs(const std::string& path, std::vector<std::string>& warnings);
// Returns "" or why the file could not be written.
std::string write_viewer_prefs(const std::string& path, const ViewerPrefs& prefs);

}  // namespace pt
