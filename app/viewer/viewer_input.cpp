#include "viewer/viewer_input.h"

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>  // key codes only
#include <imgui_internal.h>

#include "viewer/viewer_model.h"

#include <algorithm>
#include <array>
#include <cmath>

namespace pt {

namespace {

// Esc cancels what is under way before it ever quits: an open popup (a combo's list, a menu, the quit
// question) closes; a field being typed into reverts (ImGui does that itself); only then does Esc ask to quit.
void escape(ViewerModel& model) {
  if (ImGui::IsPopupOpen("", ImGuiPopupFlags_AnyPopupId)) {
    ImGui::ClosePopupToLevel(0, true);
    model.confirm_quit = false;  // Esc on the unsaved-edits question answers "cancel"
    model.confirm_load.reset();
    return;
  }
  if (ImGui::IsAnyItemActive()) return;
  model.shortcut(Shortcut::Quit);
}

// The image pixel under window point p, rounded to the nearest pixel corner (a region's edge), within the image.
std::array<int, 2> pixel_corner(const ImageArea& image, ImVec2 p) {
  const ImVec2 q = image.to_image(p);
  return {std::clamp(static_cast<int>(std::lround(q.x)), 0, image.image_width),
          std::clamp(static_cast<int>(std::lround(q.y)), 0, image.image_height)};
}

}  // namespace

std::optional<PixelRect> region_being_drawn(const ImGuiIO& io, const ViewerModel& model, const ImageArea& image) {
  if (!model.drawing_region || !(io.MouseDown[0] || io.MouseReleased[0]) || !image.contains(io.MouseClickedPos[0]))
    return std::nullopt;
  const std::array<int, 2> a = pixel_corner(image, io.MouseClickedPos[0]), b = pixel_corner(image, io.MousePos);
  return PixelRect::spanning(a[0], a[1], b[0], b[1]);
}

void draw_region_overlay(const ImGuiIO& io, const ViewerModel& model, const ImageArea& image) {
  if (image.w <= 0.f || image.image_width <= 0 || image.image_height <= 0) return;
  const auto to_window = [&](int x, int y) {
    return ImVec2(image.x + image.w * static_cast<float>(x) / static_cast<float>(image.image_width),
                  image.y + image.h * static_cast<float>(y) / static_cast<float>(image.image_height));
  };
  ImDrawList* dl = ImGui::GetBackgroundDrawList();  // over the image, under the panels
  const std::optional<PixelRect> drawn = region_being_drawn(io, model, image);
  const std::optional<PixelRect>& region = drawn ? drawn : model.region();
  if (!region) return;
  const ImVec2 a = to_window(region->x0, region->y0), b = to_window(region->x1, region->y1);
  dl->AddRect(ImVec2(a.x - 1.f, a.y - 1.f), ImVec2(b.x + 1.f, b.y + 1.f), IM_COL32(0, 0, 0, 160), 0.f, 0, 3.f);
  dl->AddRect(a, b, drawn ? IM_COL32(255, 255, 255, 255) : IM_COL32(255, 170, 40, 255), 0.f, 0, 1.5f);
}

ImageArea place_image(const ImageZoom& zoom, int image_width, int image_height, float ax, float ay, float aw, float ah,
                      float pixel_ratio) {
  ImageArea a;
  a.image_width = image_width;
  a.image_height = image_height;
  a.pixel_ratio = pixel_ratio > 0.f ? pixel_ratio : 1.f;
  const float r = a.pixel_ratio;
  if (image_width <= 0 || image_height <= 0 || aw <= 0.f || ah <= 0.f) return a;
  float s = zoom.scale;  // framebuffer pixels per image pixel
  if (zoom.fit) {
    s = std::min(aw * r / image_width, ah * r / image_height);
    if (s >= 1.f) s = std::floor(s);
  }
  const float w = std::max(1.f, std::floor(image_width * s)), h = std::max(1.f, std::floor(image_height * s));
  const float pan_x = zoom.fit ? 0.f : zoom.pan_x * r, pan_y = zoom.fit ? 0.f : zoom.pan_y * r;
  a.x = ax + std::floor((aw * r - w) * 0.5f + pan_x) / r;
  a.y = ay + std::floor((ah * r - h) * 0.5f + pan_y) / r;
  a.w = w / r;
  a.h = h / r;
  return a;
}

void zoom_image(ImageZoom& zoom, const ImageArea& now, ImVec2 cursor, float factor) {
  if (now.w <= 0.f || now.image_width <= 0) return;
  const float r = now.pixel_ratio;
  const float scale = now.w * r / now.image_width;
  const float centre_x = now.x + 0.5f * now.w - (zoom.fit ? 0.f : zoom.pan_x);  // the area's centre
  const float centre_y = now.y + 0.5f * now.h - (zoom.fit ? 0.f : zoom.pan_y);
  const float s = std::clamp(scale * factor, kMinZoom, kMaxZoom);
  const float u = (cursor.x - now.x) / now.w, v = (cursor.y - now.y) / now.h;  // stays under the cursor
  const float w = now.image_width * s / r, h = now.image_height * s / r;
  zoom.fit = false;
  zoom.scale = s;
  zoom.pan_x = cursor.x - u * w + 0.5f * w - centre_x;
  zoom.pan_y = cursor.y - v * h + 0.5f * h - centre_y;
}

void handle_viewer_input(const ImGuiIO& io, ViewerModel& model, double seconds, const ImageArea& image) {
  ViewInput in;
  in.viewport_height = image.h;
  const bool right = io.MouseDown[1];
  // Ctrl + wheel / Ctrl + left drag move the image on screen, not the camera.
  if (!io.WantCaptureMouse && io.KeyCtrl) {
    if (io.MouseWheel != 0.f) zoom_image(model.zoom, image, io.MousePos, std::pow(1.25f, io.MouseWheel));
    if (io.MouseDown[0] && (io.MouseDelta.x != 0.f || io.MouseDelta.y != 0.f)) {
      if (model.zoom.fit) zoom_image(model.zoom, image, io.MousePos, 1.f);  // the fitted scale, made explicit
      model.zoom.pan_x += io.MouseDelta.x;
      model.zoom.pan_y += io.MouseDelta.y;
    }
  } else if (!io.WantCaptureMouse && model.drawing_region) {
    // Drawing the render region: a left drag spans it (released, it applies); nothing orbits meanwhile.
    if (io.MouseReleased[0])
      if (const std::optional<PixelRect> r = region_being_drawn(io, model, image)) model.set_region(*r);
    in.wheel = io.MouseWheel;
  } else if (!io.WantCaptureMouse) {
    const bool left = io.MouseDown[0], middle = io.MouseDown[2];
    in.drag = Vec2(io.MouseDelta.x, io.MouseDelta.y);
    in.look = right;
    in.pan = middle || (left && io.KeyShift);
    in.orbit = left && !io.KeyShift;
    in.wheel = io.MouseWheel;
    // Double-click on a surface: it becomes the orbit pivot (the camera turns to look at it). A click (released
    // where it was pressed: not an orbit) selects the material and object under the pointer.
    if (io.MouseDoubleClicked[0] && image.contains(io.MousePos)) {
      const ImVec2 p = image.to_image(io.MousePos);
      model.set_pivot_at(p.x, p.y);
    } else if (io.MouseReleased[0] && io.MouseDragMaxDistanceSqr[0] < 9.f && image.contains(io.MousePos)) {
      const ImVec2 p = image.to_image(io.MousePos);
      if (io.KeyAlt) model.focus_at(p.x, p.y);  // Alt+click: focus the thin lens there
      else model.select_at(p.x, p.y);
    }
  }
  // The fly keys WASD/QE act only while the right button is held, so S alone stays "save".
  if (!io.WantCaptureKeyboard) {
    if (in.look) {
      auto key = [&](int k) { return io.KeysDown[k] ? 1.0 : 0.0; };
      in.fly = DVec3(key(GLFW_KEY_D) - key(GLFW_KEY_A), key(GLFW_KEY_E) - key(GLFW_KEY_Q),
                     key(GLFW_KEY_W) - key(GLFW_KEY_S));
      in.fast = io.KeyShift;
    } else if (!right && !io.KeyCtrl) {
      if (ImGui::IsKeyPressed(GLFW_KEY_R, false)) model.shortcut(Shortcut::Reset);
      if (ImGui::IsKeyPressed(GLFW_KEY_P, false)) model.shortcut(Shortcut::Pause);
      if (ImGui::IsKeyPressed(GLFW_KEY_S, false)) model.shortcut(Shortcut::Save);
      if (ImGui::IsKeyPressed(GLFW_KEY_E, false)) model.shortcut(Shortcut::SaveExr);
      if (ImGui::IsKeyPressed(GLFW_KEY_TAB, false)) model.shortcut(Shortcut::ToggleUi);
      if (ImGui::IsKeyPressed(GLFW_KEY_F, false)) model.zoom = ImageZoom{};
      if (ImGui::IsKeyPressed(GLFW_KEY_K, false)) model.shortcut(Shortcut::KeepSnapshot);
      if (ImGui::IsKeyPressed(GLFW_KEY_B, false)) model.shortcut(Shortcut::FlipSnapshot);
      if (ImGui::IsKeyPressed(GLFW_KEY_1, false)) model.zoom = ImageZoom{false, 1.f, 0.f, 0.f};
    }
  }
  // Undo / redo: Ctrl+Z, Ctrl+Shift+Z or Ctrl+Y, unless a text field has the keys (it has its own undo).
  if (io.KeyCtrl && !io.WantTextInput) {
    if (ImGui::IsKeyPressed(GLFW_KEY_Z, true)) model.shortcut(io.KeyShift ? Shortcut::Redo : Shortcut::Undo);
    if (ImGui::IsKeyPressed(GLFW_KEY_Y, true)) model.shortcut(Shortcut::Redo);
    // Blender's keys for the render border: Ctrl+B draws one, Ctrl+Alt+B clears it.
    if (ImGui::IsKeyPressed(GLFW_KEY_B, false)) {
      if (io.KeyAlt) model.set_region(std::nullopt);
      else model.drawing_region = !model.drawing_region;
    }
  }
  if (ImGui::IsKeyPressed(GLFW_KEY_ESCAPE, false)) escape(model);
  if (ImGui::IsKeyPressed(GLFW_KEY_F1, false)) model.shortcut(Shortcut::Help);
  model.apply_input(in, seconds);
}

void draw_pixel_probe(ViewerModel& model, const DisplayFrame& frame, const ImageArea& image) {
  const std::optional<Selection>& sel = model.selection();
  if (!sel || frame.width <= 0 || image.w <= 0.f || image.image_width <= 0) return;
  const ImGuiIO& io = ImGui::GetIO();
  // The tooltip stays while the pointer rests near the click (a few pixels), and goes when it moves on.
  const ImVec2 at(image.x + static_cast<float>(sel->x) / image.image_width * image.w,
                  image.y + static_cast<float>(sel->y) / image.image_height * image.h);
  const float dx = io.MousePos.x - at.x, dy = io.MousePos.y - at.y;
  if (dx * dx + dy * dy > 36.f || io.WantCaptureMouse) return;
  // The frame may be a reduced-resolution preview: scale the point to it.
  const int px = std::clamp(static_cast<int>(sel->x * frame.width / image.image_width), 0, frame.width - 1);
  const int py = std::clamp(static_cast<int>(sel->y * frame.height / image.image_height), 0, frame.height - 1);
  const size_t i = static_cast<size_t>(py) * frame.width + px;
  const float* m = &frame.rgba[4 * i];
  ImGui::BeginTooltip();
  ImGui::Text("pixel %d, %d%s", px, py, frame.preview ? " (preview)" : "");
  ImGui::Text("mean  %.4g  %.4g  %.4g", m[0], m[1], m[2]);
  if (m[3] < DisplayFrame::kUnknownError) ImGui::Text("rel. std. error  %.3g", m[3]);
  ImGui::Text("samples  %.0f", frame.count[i]);
  const SceneDesc& scene = model.scene();
  if (sel->material < scene.materials.size() && sel->shape < scene.shapes.size())
    ImGui::Text("%s, shape %zu (%s)", scene.materials[sel->material].name.c_str(), sel->shape,
                enum_label(scene.shapes[sel->shape].type));
  ImGui::EndTooltip();
}

namespace {

bool valid_key(int key) { return key >= 0 && key < static_cast<int>(IM_ARRAYSIZE(ImGuiIO{}.KeysDown)); }

// The modifier flags from the key state, as the GLFW backend computes them.
void update_modifiers(ImGuiIO& io) {
  io.KeyCtrl = io.KeysDown[GLFW_KEY_LEFT_CONTROL] || io.KeysDown[GLFW_KEY_RIGHT_CONTROL];
  io.KeyShift = io.KeysDown[GLFW_KEY_LEFT_SHIFT] || io.KeysDown[GLFW_KEY_RIGHT_SHIFT];
  io.KeyAlt = io.KeysDown[GLFW_KEY_LEFT_ALT] || io.KeysDown[GLFW_KEY_RIGHT_ALT];
  io.KeySuper = io.KeysDown[GLFW_KEY_LEFT_SUPER] || io.KeysDown[GLFW_KEY_RIGHT_SUPER];
}

}  // namespace

static_assert(KeyEvents::kPress == GLFW_PRESS && KeyEvents::kRelease == GLFW_RELEASE);

void KeyEvents::on_key(int key, int action) {
  if (action == kPress && valid_key(key)) pressed_.push_back(key);
}

void KeyEvents::before_frame(ImGuiIO& io) {
  for (int key : pressed_)
    if (!io.KeysDown[key]) {  // pressed and already released: down for this frame
      io.KeysDown[key] = true;
      release_after_.push_back(key);
    }
  pressed_.clear();
  if (!release_after_.empty()) update_modifiers(io);
}

void KeyEvents::after_frame(ImGuiIO& io) {
  if (release_after_.empty()) return;
  for (int key : release_after_) io.KeysDown[key] = false;
  release_after_.clear();
  update_modifiers(io);
}

bool viewer_input_held(const ImGuiIO& io) {
  for (bool down : io.MouseDown)
    if (down) return true;
  for (int k : {GLFW_KEY_W, GLFW_KEY_A, GLFW_KEY_S, GLFW_KEY_D, GLFW_KEY_Q, GLFW_KEY_E})
    if (io.KeysDown[k]) return true;
  return false;
}

}  // namespace pt
