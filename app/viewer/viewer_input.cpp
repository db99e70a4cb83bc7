#include "viewer/viewer_input.h"

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>  // key codes only
#include <imgui_internal.h>

#include "viewer/viewer_model.h"

namespace pt {

namespace {

// Esc cancels what is under way before it ever quits: an open popup (a combo's list, a menu, the quit
// question) closes; a field being typed into reverts (ImGui does that itself); only then does Esc ask to quit.
void escape(ViewerModel& model) {
  if (ImGui::IsPopupOpen("", ImGuiPopupFlags_AnyPopupId)) {
    ImGui::ClosePopupToLevel(0, true);
    model.confirm_quit = false;  // Esc on the quit question answers "cancel"
    return;
  }
  if (ImGui::IsAnyItemActive()) return;
  model.shortcut(Shortcut::Quit);
}

}  // namespace

void handle_viewer_input(const ImGuiIO& io, ViewerModel& model, double seconds, const ImageArea& image) {
  ViewInput in;
  in.viewport_height = image.h;
  const bool right = io.MouseDown[1];
  if (!io.WantCaptureMouse) {
    const bool left = io.MouseDown[0], middle = io.MouseDown[2];
    in.drag = Vec2(io.MouseDelta.x, io.MouseDelta.y);
    in.look = right;
    in.pan = middle || (left && io.KeyShift);
    in.orbit = left && !io.KeyShift;
    in.wheel = io.MouseWheel;
    // Double-click on a surface: it becomes the orbit pivot (the camera turns to look at it).
    if (io.MouseDoubleClicked[0] && image.contains(io.MousePos)) {
      const ImVec2 p = image.to_image(io.MousePos);
      model.set_pivot_at(p.x, p.y);
    }
  }
  // The fly keys WASD/QE act only while the right button is held, so S alone stays "save".
  if (!io.WantCaptureKeyboard) {
    if (in.look) {
      auto key = [&](int k) { return io.KeysDown[k] ? 1.0 : 0.0; };
      in.fly = DVec3(key(GLFW_KEY_D) - key(GLFW_KEY_A), key(GLFW_KEY_E) - key(GLFW_KEY_Q),
                     key(GLFW_KEY_W) - key(GLFW_KEY_S));
      in.fast = io.KeyShift;
    } else if (!right) {
      if (ImGui::IsKeyPressed(GLFW_KEY_R, false)) model.shortcut(Shortcut::Reset);
      if (ImGui::IsKeyPressed(GLFW_KEY_P, false)) model.shortcut(Shortcut::Pause);
      if (ImGui::IsKeyPressed(GLFW_KEY_S, false)) model.shortcut(Shortcut::Save);
      if (ImGui::IsKeyPressed(GLFW_KEY_TAB, false)) model.shortcut(Shortcut::ToggleUi);
    }
  }
  if (ImGui::IsKeyPressed(GLFW_KEY_ESCAPE, false)) escape(model);
  if (ImGui::IsKeyPressed(GLFW_KEY_F1, false)) model.shortcut(Shortcut::Help);
  model.apply_input(in, seconds);
}

bool viewer_input_held(const ImGuiIO& io) {
  for (bool down : io.MouseDown)
    if (down) return true;
  for (int k : {GLFW_KEY_W, GLFW_KEY_A, GLFW_KEY_S, GLFW_KEY_D, GLFW_KEY_Q, GLFW_KEY_E})
    if (io.KeysDown[k]) return true;
  return false;
}

}  // namespace pt
