// The viewer's Dear ImGui panels: Render, Display, Camera, Materials, Scene, Output, Help. Pure ImGui calls on
// the ViewerModel (no GL, no GLFW), so the GL tests render them offscreen exactly as the window does.
#pragma once
#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "render/render_session.h"

namespace pt {

class ViewerModel;

// What the window shows right now, for the panels' read-outs.
struct ShownImage {
  int width = 0, height = 0;
  bool preview = false;
  uint64_t spp = 0;
  float max_count = 0;
  double frame_ms = 0.0;       // UI frame time (smoothed)
  double edit_latency_ms = -1;  // last edit → first updated image; < 0 unknown
};

// A numeric field whose typed value is not applied yet (being typed), or was refused (shown red with the reason).
struct FieldMemory {
  unsigned id = 0;  // ImGuiID of the widget
  std::array<unsigned char, 32> bytes{};  // the value, as the widget's T[N]
  std::string error;  // why it was refused ("" while typing)
};

inline constexpr float kPanelWidth = 380.f;  // the default, in ImGui (window) units at a content scale of 1

// UI-only state: text buffers and scratch vectors reused from frame to frame.
struct PanelState {
  char scene_path[512] = "";
  char save_scene_path[512] = "scene.json";
  char output_dir[512] = ".";
  char material_filter[64] = "";  // the Materials section's search text
  int builtin = 0;
  bool expand_all = false;  // open every section and material (tests render all of the UI this way)
  bool confirm_replace = false;
  uint64_t shown_selection = 0;
  std::string known_scene;  // scene name + file the save path was last chosen for
  bool save_path_suggested = true;
  bool help_was_open = false;  // the Help section was open last frame (opening it scrolls to it)  // save_scene_path is the model's suggestion, not typed by the user
  FieldMemory typing;               // the field being typed into
  std::vector<FieldMemory> refused;  // fields whose value the model refused
  // Tests: with record_items, the screen rectangle (min x, min y, max x, max y) of each named widget, by
  // "section/label" (materials: "material name/label"), so scripted input can click on it.
  bool record_items = false;
  std::map<std::string, std::array<float, 4>> item_rects;
  std::string scope;
  std::vector<RelMsePoint> history;
  std::vector<std::string> builtin_names;
  // The panel's width in ImGui units at a content scale of 1: the user drags its left edge (a splitter); the
  // window keeps it in the viewer's preferences.
  float width_units = kPanelWidth;
  float width() const;  // in ImGui units at the style's scale
};


// The viewer's ImGui style at a monitor content scale (HiDPI: glfwGetWindowContentScale): the default font
// rasterised at 13·scale pixels, every size scaled, opaque popups (a translucent combo list over the image
// was hard to read), thin slider grabs (the handle no longer covers the value). Call once, after
// ImGui::CreateContext() and before the renderer backend builds the font texture.
void setup_viewer_style(float content_scale);
// The default panel's width in ImGui units at the style's scale.
float panel_width();
// The style's scale (the monitor's content scale, clamped).
float ui_scale();

// Draws the side panel at the right edge of the display. Call between ImGui::NewFrame() and ImGui::Render().
// Returns the width it covers (0 when model.ui_visible is false).
float draw_viewer_panels(ViewerModel& model, PanelState& state, const ShownImage& shown);

}  // namespace pt
