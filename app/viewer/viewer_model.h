// The viewer's state and actions, free of GL, GLFW and ImGui so tests drive them exactly as the UI does.
//
// The model owns the editable scene (SceneDesc: what `save scene` writes), the camera controller, the display
// settings and the RenderSession. Every edit goes through an action here: it updates the scene model, validates
// it, and hands a snapshot to the session, which restarts accumulation at its next pass boundary. The UI never
// touches render buffers.
#pragma once
#include <chrono>
#include <cstdint>
#include <future>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "scene/camera_controller.h"
#include "scene/estimator_choice.h"
#include "viewer/display_transform.h"
#include "viewer/edit_history.h"
#include "viewer/scene_files.h"
#include "render/render_session.h"

namespace pt {

// One UI frame of pointer and key input over the image, already filtered by the UI's capture rules (input that
// ImGui wants never gets here). Mouse units are window pixels.
struct ViewInput {
  Vec2 drag{0.f};             // pointer movement this frame
  bool orbit = false;         // left button held
  bool pan = false;           // middle button, or shift + left
  bool look = false;          // right button held: mouse look, and WASD/QE fly
  float wheel = 0.f;          // scroll steps, > 0 towards the target
  DVec3 fly{0.0};             // x: D − A, y: E − Q, z: W − S (used while `look`)
  bool fast = false;          // shift while flying: 4× speed
  float viewport_height = 1;  // height of the image on screen (drag scaling: one height = half a turn)
};

enum class Shortcut { Reset, Pause, Save, SaveExr, Help, Quit, ToggleUi, Undo, Redo, KeepSnapshot, FlipSnapshot };

// The A/B snapshot the window keeps (its pixels live in the presenter's texture).
struct SnapshotInfo {
  int width = 0, height = 0;
  uint64_t spp = 0;
};

inline constexpr int kMaxViewerResolution = 16384;

// How the image sits in the area beside the panel: fitted (the default), or zoomed and panned by the user
// (Ctrl+wheel about the cursor, Ctrl+drag; F fits, 1 shows 1:1).
struct ImageZoom {
  bool fit = true;       // fit the area: integer magnification when the image fits (crisp), else scaled down
  float scale = 1.f;     // otherwise: framebuffer pixels per image pixel (1 = 1:1)
  float pan_x = 0.f, pan_y = 0.f;  // the image centre's offset from the area's centre, window units
};
// What lies under a point of the image (ViewerModel::pick).
struct PickResult {
  DVec3 point{0.0};     // world position of the hit
  double distance = 0;  // from the camera
  size_t material = 0;  // index into SceneDesc::materials
  size_t shape = 0;     // index into SceneDesc::shapes
  std::optional<size_t> object;  // index into SceneDesc::objects; none for a shape standing alone
};

// What the user clicked last: the panels open that material and show that object.
struct Selection {
  size_t material = 0, shape = 0;
  std::optional<size_t> object;  // the object holding the shape (a click picks the whole object)
  double x = 0, y = 0;  // image point clicked (pixel units)
  uint64_t serial = 0;  // bumped by every click, so the panels can scroll to it once
};

class ViewerModel {
 public:
  ViewerModel(const SceneDesc& scene, const std::string& scene_name, const SessionSettings& settings = {});

  RenderSession& session() { return *session_; }
  const SceneDesc& scene() const { return scene_; }
  // What the `auto` estimator picks for the scene as edited, and why (scene/estimator_choice.h). Cached: the rule
  // reads every shape's material, so it runs again only after an edit of the scene (not of the camera).
  const EstimatorChoice& estimator_choice() const;
  const std::string& scene_name() const { return scene_name_; }

  // --- Scene edits: validate, update the model, restart accumulation. False (and an error status) if invalid.
  bool set_material(size_t index, const MaterialDesc& material);
  // Gives material `index` the image `file` (read as sRGB colour; relative to the working directory) as its
  // albedo texture, or removes its texture for an empty name. False, with a status line, when the file cannot be
  // read or the material takes no texture.
  bool set_albedo_texture(size_t index, const std::string& file);
  // Emission as a colour (max component 1) times a strength; remembered separately so strength 0 keeps the colour.
  bool set_emission(size_t index, Rgb colour, float strength);
  Rgb emission_colour(size_t index) const { return emission_[index].colour; }
  float emission_strength(size_t index) const { return emission_[index].strength; }
  bool set_render(const RenderSettings& render);
  // The environment; a map whose file changed is read here (errors go to status(), the old map stays).
  bool set_environment(const EnvironmentDesc& environment);

  // --- Camera.
  const CameraController& camera() const { return camera_; }
  void apply_input(const ViewInput& input, double seconds);
  void set_fov(double fov_deg);
  // Depth of field (a view, like the camera's moves): the lens radius and the focus distance along the view
  // direction (0: the target's). A negative or non-finite radius is refused with a status.
  bool set_lens(double aperture_radius, double focus_distance);
  // Focuses on the surface under image point (x, y) (Alt+click): its distance along the view direction.
  bool focus_at(double x, double y);
  void set_camera_position(DVec3 position);
  void set_camera_target(DVec3 target);
  void reset_camera();  // back to the loaded scene's camera
  // The surface under image point (x, y) (pixel units, (0,0) = top-left) as the current camera sees it; nullopt
  // where the ray escapes. The first pick after a load compiles the scene's geometry for it.
  std::optional<PickResult> pick(double x, double y);
  // Makes the surface under image point (x, y) the orbit pivot: the camera turns to look at it (double-click).
  bool set_pivot_at(double x, double y);
  // A click on the image: selects the material and the object under (x, y); nothing there clears it.
  bool select_at(double x, double y);
  const std::optional<Selection>& selection() const { return selection_; }

  // --- Geometry (a full recompile of the scene; refused with a status message when invalid).
  // A shape standing alone; one inside an object moves, or changes material, with its object.
  bool move_shape(size_t index, DVec3 offset);  // translates a triangle, quad or sphere
  bool set_sphere_radius(size_t index, double radius);
  bool set_shape_material(size_t index, size_t material);
  // An object (SceneDesc::objects): its transform applies to all of its shapes (those are mapped back into the
  // object's coordinates by the old transform and out by the new one); its material is one for all.
  bool set_object_transform(size_t object, const ObjectTransform& transform);
  bool set_object_material(size_t object, size_t material);
  // The film size (the render, not the window): 1 … kMaxViewerResolution per side. An edit (undoable, saved);
  // refused while the render follows the window.
  bool set_resolution(int width, int height);
  // "Follow the window": the film's size is the image area's (framebuffer pixels, so HiDPI counts) times `scale`
  // (kFollowScales), set by note_image_area as the window changes: a view, like a camera move (not undone, not
  // an unsaved edit). Off: the scene's own film size again, as last set.
  void set_follow_window(bool on, float scale);
  bool follow_window() const { return follow_window_; }
  float follow_scale() const { return follow_scale_; }
  // The window reports the area the image is shown in, each frame; returns true when the film size changed.
  bool note_image_area(int framebuffer_width, int framebuffer_height);

  // --- Undo / redo of scene edits (materials, emission, environment, render settings, geometry, resolution;
  // camera moves are views and are not recorded). Consecutive edits of one thing within a second (a slider
  // drag) are one step. revert() goes back to the scene as loaded (itself undoable).
  bool can_undo() const { return history_.can_undo(); }
  bool can_redo() const { return history_.can_redo(); }
  bool undo();
  bool redo();
  void revert();

  // --- Session control (threads and stop conditions do not restart accumulation).
  const SessionSettings& session_settings() const { return settings_; }
  void set_session_settings(const SessionSettings& settings);
  void restart();
  void set_paused(bool paused);
  // The render region (Blender's render border, render_session.h): only its pixels accumulate, the rest keep
  // what they have; the spp, relMSE and stop conditions count the region. A view of the session like the
  // denoiser (no restart, not undone, not saved); corners in any order, clipped to the film. nullopt, or the
  // whole image, clears it; so do a new film size and a new scene. False (and a status) when it holds no pixel.
  bool set_region(std::optional<PixelRect> region);
  const std::optional<PixelRect>& region() const { return settings_.region; }
  bool drawing_region = false;  // the next left drag on the image draws the region (Ctrl+B), not an orbit
  // Denoising is a view: the colour view shows the denoised image and the session denoises its film, without
  // restarting the accumulation (present.denoise and the session's setting change together).
  void set_denoise(bool on);
  bool paused() const { return paused_; }

  // --- Files. Errors land in status(), never in an exception.
  bool load(const std::string& spec);  // a built-in name or a .json path
  // Reads the scene, then loads it, unless the scene has unsaved edits: then asks first (confirm_load holds the
  // spec while the panels ask, and load() takes the scene already read). A file that cannot be read never asks.
  void request_load(const std::string& spec);
  std::optional<std::string> confirm_load;
  // A file dropped on the window (or opened by name): a scene (.json) loads (asking first as above); an
  // environment map (.exr, .hdr, .pfm) becomes the environment; anything else is refused with a message.
  bool open_file(const std::string& path);
  // The files (viewer/scene_files.h): the output folder, the recent list, the scene file Save offers.
  SceneFiles files;
  // The file the scene was loaded from ("" for a built-in scene), or last saved to: Save offers it again.
  const std::string& scene_file() const { return files.scene_file(); }
  // What Save offers: the file the user opened or saved to (replacing it asks first), else a new name in the
  // output folder. Never another existing file: only one the user chose may be offered for replacement.
  std::string suggested_save_path() const { return files.suggested_save_path(scene_name_); }
  // Never replaces an existing file unless `replace` (the panels ask the user first); creates missing folders.
  bool save_scene(const std::string& path, bool replace = false);
  // Writes the displayed image under new names in the output folder: NAME-NNNN.png (the RGBA8 pixels as shown)
  // and NAME-NNNN.pfm (the frame's linear mean). Returns the stem written, or nullopt on error.
  std::optional<std::string> save_image(const std::vector<uint8_t>& rgba8, const DisplayFrame& frame);
  // The accumulation's film as one multi-layer OpenEXR, NAME-NNNN.exr in the output folder (io/film_exr.h: the
  // beauty and every layer `render --exr` writes, and the denoised image when denoising is on), written on the
  // render thread between two passes; poll_saves() reports when done.
  void save_exr();
  bool poll_saves();      // each UI frame: a finished save's message goes to status() (true: redraw)
  bool exr_saving() const { return files.exr_saving(); }

  // --- Display and UI flags.
  PresentSettings present;
  ImageZoom zoom;
  bool help_open = false, ui_visible = true, quit_requested = false;
  bool scroll_to_help = false;  // F1 opened Help: the panels scroll it into view once
  bool save_requested = false;  // the window saves (it alone can read the displayed pixels back)
  bool snapshot_requested = false;  // the window keeps the next full-resolution frame as the A/B snapshot
  std::optional<SnapshotInfo> snapshot;  // set by the window when it kept one
  // A snapshot of the image's current size exists (the A/B views are offered).
  bool snapshot_usable() const {
    return snapshot && snapshot->width == scene_.width && snapshot->height == scene_.height;
  }
  void shortcut(Shortcut s);
  // Esc, the window's close button: quits at once, or asks first (confirm_quit) when the scene has edits that
  // were not saved. Camera moves are views, not edits: they never make the viewer ask.
  void request_quit();
  bool confirm_quit = false;  // the panels show "quit without saving?" while this is set
  // The scene differs from the state last loaded or saved (undoing back to that state clears it).
  bool has_unsaved_edits() const { return history_.unsaved(); }

  // "NAME[*] - 128 spp, 12.3 s, relMSE 1.2e-03 - pathtracer" (* = unsaved edits; relMSE from
  // kRelMseStopMinSpp on): the window title, so the render's state shows in the task bar.
  std::string window_title(const SessionStats& stats) const;

  const std::string& status() const { return status_; }
  bool status_is_error() const { return status_error_; }

  // Edit-to-image latency: the window reports each frame it shows; returns the milliseconds since the edit the
  // first time a frame of the edit's generation (or later) is shown.
  std::optional<double> note_frame_shown(uint64_t generation, std::chrono::steady_clock::time_point when);
  // The same for the first full-resolution, denoised image of the edit's generation (`clean`: the frame is one).
  std::optional<double> note_clean_frame_shown(uint64_t generation, bool clean,
                                               std::chrono::steady_clock::time_point when);
  uint64_t last_edit_generation() const { return last_edit_generation_; }

 private:
  // Records the state before an edit of `what` in the history (edit_history.h), unless undo is restoring one.
  void remember(const std::string& what, bool geometry);
  SceneState current_state(bool geometry) const;
  void restore(const SceneState& s);
  bool set_geometry(SceneDesc edited, const std::string& what);
  void adopt(const SceneDesc& scene, const std::string& name);  // a newly loaded scene
  void reset_camera_controller();  // to the loaded camera, with a pivot the orbit can use
  bool commit(const SceneEdit& edit);  // validate, apply to the model, send to the session
  void note_edit(uint64_t generation);
  void camera_changed();
  void set_status(std::string text, bool error);

  SceneDesc scene_, loaded_;  // the edited scene, and the scene as loaded (for "reset camera")
  std::string scene_name_;
  std::vector<EmissionSetting> emission_;
  CameraController camera_;
  SessionSettings settings_;
  bool paused_ = false;
  EditHistory history_;  // undo, redo, and which state was last loaded or saved
  uint64_t loads_ = 0;  // scenes adopted so far
  mutable std::optional<std::pair<std::pair<uint64_t, uint64_t>, EstimatorChoice>> choice_;  // keyed (loads_, state id)
  SessionSettings launch_settings_;  // the command line's: each scene loaded starts from its stop conditions
  bool follow_window_ = false;
  float follow_scale_ = 1.f;
  int fixed_width_ = 0, fixed_height_ = 0;  // the film size as an edit last set it (follow off restores it)
  int area_width_ = 0, area_height_ = 0;    // the image area last reported (framebuffer pixels)
  bool apply_film_size(int width, int height);  // in the scene and the session, without undo
  int followed_side(int framebuffer_pixels) const;  // a film side following the window: × follow_scale_, clamped
  std::shared_ptr<const Scene> pick_scene_;  // compiled on the first pick after a load or geometry edit
  std::vector<uint32_t> pick_shapes_;        // primitive id → shape index of pick_scene_
  std::optional<Selection> selection_;
  bool restoring_ = false;
  std::unique_ptr<RenderSession> session_;
  std::string status_;
  bool status_error_ = false;
  uint64_t last_edit_generation_ = 0;
  std::chrono::steady_clock::time_point last_edit_time_;
  bool latency_pending_ = false;
  bool clean_latency_pending_ = false;
};

}  // namespace pt
