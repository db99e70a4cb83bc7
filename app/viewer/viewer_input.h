// Pointer and keys → camera moves, picks and shortcuts, honouring what ImGui claims. ImGui only, no GLFW calls:
// the GL tests drive it with synthetic ImGuiIO input exactly as the window does. (ImGui 1.86 indexes keys by
// the platform backend's key codes, so the key constants are GLFW's.)
#pragma once
#include <imgui.h>

#include <optional>
#include <vector>

#include "viewer/viewer_model.h"

namespace pt {

struct DisplayFrame;

// Where the image is drawn, in ImGui (window) units, top-left origin, and its size in pixels.
struct ImageArea {
  float x = 0, y = 0, w = 0, h = 0;
  int image_width = 0, image_height = 0;
  float pixel_ratio = 1;  // framebuffer pixels per window unit (HiDPI)
  bool contains(ImVec2 p) const { return p.x >= x && p.y >= y && p.x < x + w && p.y < y + h; }
  // The image point (pixel units, (0,0) = top-left) under window point p.
  ImVec2 to_image(ImVec2 p) const {
    return ImVec2((p.x - x) / w * static_cast<float>(image_width), (p.y - y) / h * static_cast<float>(image_height));
  }
};

inline constexpr float kMinZoom = 1.f / 32.f, kMaxZoom = 64.f;

// The image's place in an area of aw × ah window units at (ax, ay), whole framebuffer pixels.
ImageArea place_image(const ImageZoom& zoom, int image_width, int image_height, float ax, float ay, float aw, float ah,
                      float pixel_ratio);
// Zooms by `factor` keeping the image point under `cursor` where it is.
void zoom_image(ImageZoom& zoom, const ImageArea& now, ImVec2 cursor, float factor);

// One UI frame's input, between ImGui::NewFrame() and drawing the panels. `seconds` is the time since the
// last frame (fly speed).
void handle_viewer_input(const ImGuiIO& io, ViewerModel& model, double seconds, const ImageArea& image);

// The render region a left drag is drawing now (ViewerModel::drawing_region), corner to corner in image pixels.
std::optional<PixelRect> region_being_drawn(const ImGuiIO& io, const ViewerModel& model, const ImageArea& image);
// The render region's outline over the image (the one being drawn, else the model's), under the panels.
void draw_region_overlay(const ImGuiIO& io, const ViewerModel& model, const ImageArea& image);

// The pixel under the last click: its mean, error, sample count and the material and object there, in a
// tooltip while the pointer rests near the click. Call after handle_viewer_input, within the ImGui frame.
void draw_pixel_probe(ViewerModel& model, const DisplayFrame& frame, const ImageArea& image);

// Key presses from the platform's event callbacks, so that none is lost. ImGui 1.86 reads keys as the state
// io.KeysDown holds when a frame starts: a key pressed and released between two frames (a quick tap, or a slow
// frame on a software GL) was never seen, and Ctrl+Z or Enter in a field were sometimes lost. Here every key
// pressed since the last frame reads as down for one frame, with the modifiers pressed with it; a key released
// meanwhile is released after that frame (as ImGui 1.87's input queue does).
class KeyEvents {
 public:
  static constexpr int kPress = 1, kRelease = 0;  // GLFW_PRESS, GLFW_RELEASE (GLFW_REPEAT = 2 is ignored)
  // From the key callback, in event order, after or before the backend updated io.KeysDown.
  void on_key(int key, int action);
  // Just before ImGui::NewFrame().
  void before_frame(ImGuiIO& io);
  // Just after the frame's input was handled (after ImGui::Render()).
  void after_frame(ImGuiIO& io);

 private:
  std::vector<int> pressed_;        // since the last frame
  std::vector<int> release_after_;  // held down for the current frame only
};

// Keys and buttons whose holding keeps the view changing without new events (GLFW repeats keys only after a
// delay), so the window keeps drawing.
bool viewer_input_held(const ImGuiIO& io);

}  // namespace pt
