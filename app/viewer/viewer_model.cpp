#include "viewer/viewer_model.h"

#include "io/texture_io.h"

#include <cctype>
#include <cmath>
#include <filesystem>

#include "viewer/output_files.h"
#include "scene/scene.h"
#include "scene/scene_json.h"
#include "scene/studio.h"

namespace pt {

namespace {

constexpr double kHalfTurn = glm::pi<double>();  // radians

}  // namespace

ViewerModel::ViewerModel(const SceneDesc& scene, const std::string& scene_name, const SessionSettings& settings)
    : settings_(settings), launch_settings_(settings) {
  adopt(scene, scene_name);
  session_ = std::make_unique<RenderSession>(scene_, settings_);
  present.denoise = settings_.denoise;
  last_edit_generation_ = session_->stats().generation;
  last_edit_time_ = std::chrono::steady_clock::now();
  latency_pending_ = clean_latency_pending_ = true;  // the first image counts as the answer to "open the scene"
}

void ViewerModel::adopt(const SceneDesc& scene, const std::string& name) {
  scene_ = loaded_ = scene;
  fixed_width_ = scene.width;
  fixed_height_ = scene.height;
  if (follow_window_ && area_width_ > 0) {  // a scene loaded while following the window takes the window's size
    scene_.width = followed_side(area_width_);
    scene_.height = followed_side(area_height_);
  }
  scene_name_ = name;
  history_.clear();
  ++loads_;
  pick_scene_.reset();
  selection_.reset();
  emission_ = emission_settings_of(scene_.materials);
  reset_camera_controller();
}

const EstimatorChoice& ViewerModel::estimator_choice() const {
  const std::pair<uint64_t, uint64_t> key{loads_, history_.current_id()};
  if (!choice_ || choice_->first != key) choice_.emplace(key, choose_estimator(scene_));
  return choice_->second;
}

// Scenes written for a fly-through camera give a look-at point just ahead of the eye (shadertoy's is 1 unit
// ahead in a room 25 wide): orbiting that point barely moves the camera. When the look-at point is closer than
// a tenth of the scene's radius, the pivot moves along the view ray to the depth of the scene's bounding-box
// centre (the view itself does not change).
void ViewerModel::reset_camera_controller() {
  const SceneBounds b = scene_bounds(scene_);
  const CameraDesc& c = loaded_.camera;
  camera_.reset(c, b.radius, static_cast<double>(scene_.width) / scene_.height);
  const double look = glm::length(c.look_at - c.position);
  if (look < 0.1 * b.radius) {
    const double depth = glm::dot(b.center - c.position, (c.look_at - c.position) / look);
    if (depth > look) camera_.set_pivot_distance(depth);
  }
}

void ViewerModel::set_status(std::string text, bool error) {
  status_ = std::move(text);
  status_error_ = error;
}

// Every edit is typed: the model and the session each change their copy in place (no scene copy per edit, and
// the session updates the compiled scene without rebuilding geometry).
bool ViewerModel::commit(const SceneEdit& edit) {
  if (std::string err = validate_edit(scene_, edit); !err.empty()) {
    set_status("not applied: " + err, true);
    return false;
  }
  if (const auto* m = std::get_if<MaterialEdit>(&edit)) remember("material " + std::to_string(m->index), false);
  else if (std::holds_alternative<EnvironmentDesc>(edit)) remember("environment", false);
  apply_edit(scene_, edit);
  note_edit(session_->edit(edit));
  return true;
}

void ViewerModel::note_edit(uint64_t generation) {
  last_edit_generation_ = generation;
  last_edit_time_ = std::chrono::steady_clock::now();
  latency_pending_ = clean_latency_pending_ = true;
  if (status_error_) set_status("", false);
}

bool ViewerModel::set_material(size_t index, const MaterialDesc& material) {
  if (index >= scene_.materials.size()) return false;
  if (!commit(MaterialEdit{index, material})) return false;
  const float s = max_component(material.emission);
  if (s > 0.f) emission_[index] = {material.emission / s, s};
  else emission_[index].strength = 0.f;
  return true;
}

bool ViewerModel::set_albedo_texture(size_t index, const std::string& file) {
  if (index >= scene_.materials.size()) return false;
  MaterialDesc m = scene_.materials[index];
  m.albedo_texture = m.resolved_albedo_texture = file;
  m.albedo_map.reset();
  if (!file.empty()) {
    try {
      m.albedo_map = load_texture_file(file, true);
    } catch (const ImageError& e) {
      set_status(std::string("albedo texture: ") + e.what(), true);
      return false;
    }
  }
  if (std::string err = validate_material(m); !err.empty()) {
    set_status("not applied: " + err, true);
    return false;
  }
  return set_material(index, m);
}

bool ViewerModel::set_emission(size_t index, Rgb colour, float strength) {
  if (index >= scene_.materials.size()) return false;
  MaterialDesc m = scene_.materials[index];
  m.emission = colour * strength;
  if (!commit(MaterialEdit{index, m})) return false;
  emission_[index] = {colour, strength};
  return true;
}

bool ViewerModel::set_render(const RenderSettings& render) {
  std::string err = validate_render_settings(render);
  if (err.empty()) err = validate_punctual_for_estimator(scene_, render);
  if (!err.empty()) {
    set_status("not applied: " + err, true);
    return false;
  }
  remember("render", false);
  scene_.render = render;
  note_edit(session_->set_render(render));
  return true;
}

bool ViewerModel::set_environment(const EnvironmentDesc& environment) {
  EnvironmentDesc e = environment;
  if (e.type == EnvironmentType::Map && (!e.image || e.file != scene_.environment.file)) {
    if (e.file.empty()) {
      set_status("environment map: enter a file name (.exr, .hdr or .pfm)", true);
      return false;
    }
    e.resolved_file = e.file;
    HdrImageResult read = read_hdr_image(e.file);
    if (!read.ok()) {
      set_status("environment map: " + read.error, true);
      return false;
    }
    e.image = std::make_shared<Image>(std::move(read.image));
  }
  return commit(e);
}

void ViewerModel::camera_changed() { commit(camera_.camera()); }

void ViewerModel::apply_input(const ViewInput& in, double seconds) {
  const double per_height = 1.0 / std::max(in.viewport_height, 1.f);
  const double dx = in.drag.x * per_height, dy = in.drag.y * per_height;
  const bool dragged = in.drag.x != 0.f || in.drag.y != 0.f;
  bool moved = false;
  if (in.look) {
    if (dragged) {
      camera_.look(-dx * 0.5 * kHalfTurn, -dy * 0.5 * kHalfTurn);  // a viewport height of travel turns the view 90°
      moved = true;
    }
    if (in.fly != DVec3(0.0) && seconds > 0.0) {
      camera_.fly(in.fly, seconds, in.fast ? 4.0 : 1.0);
      moved = true;
    }
  } else if (in.pan && dragged) {
    camera_.pan(dx, dy);
    moved = true;
  } else if (in.orbit && dragged) {
    camera_.orbit(-dx * kHalfTurn, dy * kHalfTurn);  // "grab" the scene: it turns with the pointer
    moved = true;
  }
  if (in.wheel != 0.f) {
    camera_.dolly(in.wheel);
    moved = true;
  }
  if (moved) camera_changed();
}

void ViewerModel::set_fov(double fov_deg) {
  camera_.set_fov(fov_deg);
  camera_changed();
}

bool ViewerModel::set_lens(double aperture_radius, double focus_distance) {
  CameraDesc candidate = camera_.camera();
  candidate.aperture_radius = aperture_radius;
  candidate.focus_distance = focus_distance;
  if (std::string err = validate_edit(scene_, candidate); !err.empty()) {
    set_status("not applied: " + err, true);
    return false;
  }
  camera_.set_lens(aperture_radius, focus_distance);
  camera_changed();
  return true;
}

bool ViewerModel::focus_at(double x, double y) {
  const std::optional<PickResult> p = pick(x, y);
  if (!p) {
    set_status("no surface under the cursor: the focus stays", false);
    return false;
  }
  const CameraDesc& c = camera_.camera();
  const double d = glm::dot(p->point - c.position, glm::normalize(c.look_at - c.position));
  if (!(d > 0.0)) return false;
  if (!set_lens(c.aperture_radius, d)) return false;
  char text[96];
  std::snprintf(text, sizeof text, "focus at %.4g on %s", d, scene_.materials[p->material].name.c_str());
  set_status(text, false);
  return true;
}

void ViewerModel::set_camera_position(DVec3 position) {
  camera_.set_position(position);
  camera_changed();
}

void ViewerModel::set_camera_target(DVec3 target) {
  camera_.set_target(target);
  camera_changed();
}

void ViewerModel::reset_camera() {
  reset_camera_controller();
  camera_changed();
}

std::optional<PickResult> ViewerModel::pick(double x, double y) {
  if (!(x >= 0.0 && y >= 0.0 && x < scene_.width && y < scene_.height)) return std::nullopt;
  if (!pick_scene_) {
    try {
      pick_scene_ = compile_scene(scene_);
      pick_shapes_ = primitive_shapes(scene_);
    } catch (const std::exception& e) {
      set_status(std::string("cannot pick: ") + e.what(), true);
      return std::nullopt;
    }
  }
  const Scene& s = *pick_scene_;
  const CameraDesc& c = camera_.camera();
  const DVec3 forward = glm::normalize(c.look_at - c.position);
  Camera cam = Camera::make(forward, c.up, c.fov_deg, c.fov_axis == FovAxis::Horizontal, scene_.width, scene_.height);
  cam.origin = Vec3(c.position - s.world_origin);  // the compiled geometry is relative to its own camera
  const Ray ray = cam.generate_ray(static_cast<float>(x), static_cast<float>(y));
  Hit hit;
  if (!s.intersect(ray, kInfinity, kNoPrimitive, hit)) return std::nullopt;
  PickResult r;
  r.distance = hit.t;
  r.point = c.position + static_cast<double>(hit.t) * DVec3(ray.d);
  r.material = s.material_of(hit.prim);
  const bool placed = hit.prim < s.polygon_instance.size() && s.polygon_instance[hit.prim] != Scene::kNoInstance;
  if (s.instances.holds(hit.prim) || placed) {
    // An instanced mesh (or its triangles placed as polygons, instances_as_polygons): the object that places
    // it (its shapes, if it has any, stand for it).
    const uint32_t instance = placed ? s.polygon_instance[hit.prim] : s.instances.instance_of(hit.prim).desc;
    const int o = scene_.instances[instance].object;
    if (o >= 0) r.object = static_cast<size_t>(o);
    r.shape = o >= 0 && scene_.objects[o].shape_count > 0 ? scene_.objects[o].first_shape : scene_.shapes.size();
    return r;
  }
  r.shape = hit.prim < pick_shapes_.size() ? pick_shapes_[hit.prim] : 0;
  r.object = object_containing(scene_, r.shape);
  return r;
}

bool ViewerModel::select_at(double x, double y) {
  const std::optional<PickResult> p = pick(x, y);
  if (!p) {
    selection_.reset();
    return false;
  }
  const uint64_t serial = selection_ ? selection_->serial + 1 : 1;
  selection_ = Selection{p->material, p->shape, p->object, x, y, serial};
  return true;
}

bool ViewerModel::set_pivot_at(double x, double y) {
  const std::optional<PickResult> p = pick(x, y);
  if (!p) {
    set_status("no surface under the cursor: the pivot stays", false);
    return false;
  }
  set_camera_target(p->point);
  set_status("pivot on " + scene_.materials[p->material].name, false);
  return true;
}

// --- Geometry ---------------------------------------------------------------------------------------------------

bool ViewerModel::set_geometry(SceneDesc edited, const std::string& what) {
  if (std::string err = validate_scene(edited); !err.empty()) {
    set_status("not applied: " + err, true);
    return false;
  }
  remember(what, true);
  scene_ = std::move(edited);
  pick_scene_.reset();
  camera_.set_aspect(static_cast<double>(scene_.width) / scene_.height);
  note_edit(session_->set_scene(scene_));
  return true;
}

bool ViewerModel::move_shape(size_t index, DVec3 offset) {
  if (index >= scene_.shapes.size()) return false;
  if (!std::isfinite(offset.x + offset.y + offset.z)) {
    set_status("not applied: the offset must be finite", true);
    return false;
  }
  if (const std::optional<size_t> o = object_containing(scene_, index)) {
    ObjectTransform t = scene_.objects[*o].transform;
    t.translate += offset;
    return set_object_transform(*o, t);
  }
  SceneDesc edited = scene_;
  ShapeDesc& sh = edited.shapes[index];
  if (sh.type == ShapeType::Sphere) sh.center += offset;
  else
    for (DVec3& v : sh.vertices) v += offset;
  return set_geometry(std::move(edited), "shape " + std::to_string(index));
}

bool ViewerModel::set_sphere_radius(size_t index, double radius) {
  if (index >= scene_.shapes.size() || scene_.shapes[index].type != ShapeType::Sphere) return false;
  if (object_containing(scene_, index)) {
    set_status("not applied: the sphere is part of an object (scale the object)", true);
    return false;
  }
  SceneDesc edited = scene_;
  edited.shapes[index].radius = radius;
  return set_geometry(std::move(edited), "shape " + std::to_string(index));
}

bool ViewerModel::set_shape_material(size_t index, size_t material) {
  if (index >= scene_.shapes.size() || material >= scene_.materials.size()) return false;
  if (const std::optional<size_t> o = object_containing(scene_, index)) return set_object_material(*o, material);
  SceneDesc edited = scene_;
  edited.shapes[index].material = static_cast<int>(material);
  return set_geometry(std::move(edited), "shape " + std::to_string(index));
}

bool ViewerModel::set_object_transform(size_t object, const ObjectTransform& transform) {
  if (object >= scene_.objects.size()) return false;
  if (std::string err = transform_error(transform); !err.empty()) {
    set_status("not applied: " + err, true);
    return false;
  }
  SceneDesc edited = scene_;
  ObjectDesc& o = edited.objects[object];
  for (size_t k = o.first_shape; k < o.first_shape + o.shape_count; ++k) {
    ShapeDesc& sh = edited.shapes[k];
    if (!transform_shape(sh, o.transform, false) || !transform_shape(sh, transform, true)) {
      set_status("not applied: " + o.name + " holds a sphere, which takes the same scale on every axis", true);
      return false;
    }
  }
  o.transform = transform;
  return set_geometry(std::move(edited), "object " + std::to_string(object));
}

bool ViewerModel::set_object_material(size_t object, size_t material) {
  if (object >= scene_.objects.size() || material >= scene_.materials.size()) return false;
  SceneDesc edited = scene_;
  const ObjectDesc& o = edited.objects[object];
  for (size_t k = o.first_shape; k < o.first_shape + o.shape_count; ++k)
    edited.shapes[k].material = static_cast<int>(material);
  for (InstanceDesc& in : edited.instances)  // and its instanced meshes
    if (in.object == static_cast<int>(object)) std::fill(in.materials.begin(), in.materials.end(), static_cast<int>(material));
  return set_geometry(std::move(edited), "object " + std::to_string(object));
}

bool ViewerModel::set_resolution(int width, int height) {
  if (width < 1 || height < 1 || width > kMaxViewerResolution || height > kMaxViewerResolution) {
    set_status("not applied: the resolution must be 1 to " + std::to_string(kMaxViewerResolution) + " per side", true);
    return false;
  }
  if (follow_window_) {
    set_status("not applied: the render follows the window (turn \"follow the window\" off for a fixed size)", true);
    return false;
  }
  if (width == scene_.width && height == scene_.height) return true;
  remember("resolution", false);
  fixed_width_ = width;
  fixed_height_ = height;
  return apply_film_size(width, height);
}

bool ViewerModel::apply_film_size(int width, int height) {
  if (width == scene_.width && height == scene_.height) return false;
  const FilmSize size{width, height};
  if (std::string err = validate_edit(scene_, size); !err.empty()) {
    set_status("not applied: " + err, true);
    return false;
  }
  apply_edit(scene_, size);
  if (settings_.region) {  // a region of the old size means nothing at the new one
    settings_.region.reset();
    session_->set_settings(settings_);
  }
  camera_.set_aspect(static_cast<double>(width) / height);
  note_edit(session_->edit(size));
  return true;
}

void ViewerModel::set_follow_window(bool on, float scale) {
  follow_window_ = on;
  follow_scale_ = scale;
  if (!on) apply_film_size(fixed_width_, fixed_height_);
  else if (area_width_ > 0) note_image_area(area_width_, area_height_);
}

bool ViewerModel::note_image_area(int framebuffer_width, int framebuffer_height) {
  area_width_ = framebuffer_width;
  area_height_ = framebuffer_height;
  if (!follow_window_ || framebuffer_width < 1 || framebuffer_height < 1) return false;
  return apply_film_size(followed_side(framebuffer_width), followed_side(framebuffer_height));
}

int ViewerModel::followed_side(int framebuffer_pixels) const {
  return std::clamp(static_cast<int>(std::lround(framebuffer_pixels * static_cast<double>(follow_scale_))), 1,
                    kMaxViewerResolution);
}

// --- Undo ---------------------------------------------------------------------------------------------------------

SceneState ViewerModel::current_state(bool geometry) const {
  return scene_state(scene_, emission_, geometry, history_.current_id());
}

void ViewerModel::remember(const std::string& what, bool geometry) {
  if (restoring_) return;
  history_.record(what, geometry, [&] { return current_state(geometry); }, std::chrono::steady_clock::now());
}

void ViewerModel::restore(const SceneState& s) {
  restoring_ = true;
  scene_.materials = s.materials;
  emission_ = s.emission;
  scene_.environment = s.environment;
  scene_.render = s.render;
  if (!follow_window_) {  // following the window, the size is the window's, not the step's
    scene_.width = s.width;
    scene_.height = s.height;
  }
  fixed_width_ = s.width;
  fixed_height_ = s.height;
  if (s.shapes) {
    scene_.shapes = *s.shapes;
    scene_.objects = s.objects;
    scene_.instances = s.instances;
    pick_scene_.reset();
  }
  camera_.set_aspect(static_cast<double>(scene_.width) / scene_.height);
  note_edit(session_->set_scene(scene_));
  restoring_ = false;
}

bool ViewerModel::undo() {
  if (!history_.can_undo()) return false;
  restore(*history_.undo(current_state(history_.undo_has_shapes())));
  set_status("undone", false);
  return true;
}

bool ViewerModel::redo() {
  if (!history_.can_redo()) return false;
  restore(*history_.redo(current_state(history_.redo_has_shapes())));
  set_status("redone", false);
  return true;
}

void ViewerModel::revert() {
  restore(history_.revert(current_state(true), scene_state(loaded_, emission_settings_of(loaded_.materials), true,
                                                           0)));  // the loaded state: id 0
  reset_camera();
  set_status("reverted to the scene as loaded", false);
}

void ViewerModel::set_session_settings(const SessionSettings& settings) {
  settings_ = settings;
  session_->set_settings(settings_);
}

bool ViewerModel::set_region(std::optional<PixelRect> region) {
  drawing_region = false;
  if (region) {
    // Corners in any order, clipped to the film.
    const PixelRect r = PixelRect::spanning(region->x0, region->y0, region->x1, region->y1).clipped(scene_.width, scene_.height);
    if (r.empty()) {
      set_status("render region not set: it holds no pixel of the image", true);
      return false;
    }
    region = r == full_rect(scene_.width, scene_.height) ? std::nullopt : std::optional<PixelRect>(r);
  }
  if (region == settings_.region) return true;
  settings_.region = region;
  session_->set_settings(settings_);
  if (region)
    set_status("render region " + std::to_string(region->x1 - region->x0) + " x " + std::to_string(region->y1 - region->y0) +
                   " at (" + std::to_string(region->x0) + ", " + std::to_string(region->y0) + ")",
               false);
  else
    set_status("render region cleared: the whole image renders", false);
  return true;
}

void ViewerModel::set_denoise(bool on) {
  present.denoise = on;
  settings_.denoise = on;
  session_->set_settings(settings_);
}

void ViewerModel::restart() {
  last_edit_generation_ = session_->restart();
  last_edit_time_ = std::chrono::steady_clock::now();
  latency_pending_ = clean_latency_pending_ = true;
}

void ViewerModel::set_paused(bool paused) {
  paused_ = paused;
  session_->set_paused(paused);
}

bool ViewerModel::load(const std::string& spec) {
  std::optional<SceneDesc> loaded = files.take_read_ahead(spec);
  if (!loaded) {
    if (const FileOutcome read = files.read_ahead(spec); !read.ok) {
      set_status(read.message, true);
      return false;
    }
    loaded = files.take_read_ahead(spec);
  }
  adopt(*loaded, scene_short_name(spec));  // load_scene validated it
  // Stop conditions and the A/B snapshot belong to a scene: a new one starts from the command line's conditions
  // (threads and the preview stay the user's).
  settings_.stop = launch_settings_.stop;
  settings_.region.reset();  // so does a render region
  drawing_region = false;
  session_->set_settings(settings_);
  snapshot.reset();
  snapshot_requested = false;
  present.snapshot_view = SnapshotView::Off;
  note_edit(session_->set_scene(scene_));
  set_status("loaded " + spec, false);
  if (std::string err = files.note_loaded(spec); !err.empty()) set_status(err, true);
  return true;
}

void ViewerModel::request_load(const std::string& spec) {
  // Read first: a missing or broken file is reported at once, without asking about the edits it would replace.
  if (const FileOutcome read = files.read_ahead(spec); !read.ok) {
    set_status(read.message, true);
    return;
  }
  if (has_unsaved_edits()) confirm_load = spec;
  else load(spec);
}

bool ViewerModel::open_file(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ext == ".json" || is_model_file(path)) {  // a scene, or a model placed in a studio (scene/studio.h)
    request_load(path);
    return true;
  }
  if (ext == ".exr" || ext == ".hdr" || ext == ".pfm") {
    EnvironmentDesc e = scene_.environment;
    e.type = EnvironmentType::Map;
    e.file = path;
    e.image.reset();
    if (!set_environment(e)) return false;
    set_status("environment map " + path, false);
    return true;
  }
  set_status("cannot open " + path + ": drop a scene (.json), a model (.obj) or an environment map (.exr, .hdr, .pfm)",
             true);
  return false;
}

bool ViewerModel::save_scene(const std::string& path, bool replace) {
  const FileOutcome saved = files.save_scene(path, replace, scene_);
  if (saved.ok) history_.mark_saved();  // and the next edit is a step of its own, even within a drag's second
  set_status(saved.message, saved.error);
  return saved.ok;
}

std::optional<std::string> ViewerModel::save_image(const std::vector<uint8_t>& rgba8, const DisplayFrame& frame) {
  const FileOutcome saved = files.save_image(scene_name_, rgba8, frame);
  if (!saved.ok) {
    set_status(saved.message, true);
    return std::nullopt;
  }
  set_status("saved " + saved.message + ".png and .pfm (" + std::to_string(frame.spp) + " spp)", false);
  return saved.message;
}

void ViewerModel::save_exr() {
  const FileOutcome started = files.start_exr(*session_, scene_name_, present.denoise);
  set_status(started.message, started.error);
}

bool ViewerModel::poll_saves() {
  const std::optional<FileOutcome> done = files.poll_exr();
  if (!done) return false;
  set_status(done->message, done->error);
  return true;
}

void ViewerModel::shortcut(Shortcut s) {
  switch (s) {
    case Shortcut::Reset: restart(); break;
    case Shortcut::Pause: set_paused(!paused_); break;
    case Shortcut::Save: save_requested = true; break;
    case Shortcut::SaveExr: save_exr(); break;
    case Shortcut::Help:
      help_open = !help_open;
      scroll_to_help = help_open;
      break;
    case Shortcut::Quit: request_quit(); break;
    case Shortcut::ToggleUi: ui_visible = !ui_visible; break;
    case Shortcut::KeepSnapshot: snapshot_requested = true; break;
    case Shortcut::FlipSnapshot:
      if (snapshot_usable())
        present.snapshot_view = present.snapshot_view == SnapshotView::Snapshot ? SnapshotView::Off : SnapshotView::Snapshot;
      break;
    case Shortcut::Undo: undo(); break;
    case Shortcut::Redo: redo(); break;
  }
}

std::string ViewerModel::window_title(const SessionStats& st) const {
  char buf[160];
  int n = std::snprintf(buf, sizeof buf, "%s%s - %llu spp, %.1f s", scene_name_.c_str(), has_unsaved_edits() ? "*" : "",
                        static_cast<unsigned long long>(st.spp), st.seconds);
  if (st.spp >= kRelMseStopMinSpp && std::isfinite(st.estimated_relmse) && n > 0 && n < static_cast<int>(sizeof buf))
    n += std::snprintf(buf + n, sizeof buf - n, ", relMSE %.1e", st.estimated_relmse);
  const char* state = !st.error.empty() ? ", scene error" : st.paused ? ", paused" : st.done ? ", done" : "";
  return std::string(buf) + state + " - pathtracer";
}

void ViewerModel::request_quit() {
  if (has_unsaved_edits()) confirm_quit = true;
  else quit_requested = true;
}

std::optional<double> ViewerModel::note_frame_shown(uint64_t generation, std::chrono::steady_clock::time_point when) {
  if (!latency_pending_ || generation < last_edit_generation_) return std::nullopt;
  latency_pending_ = false;
  return std::chrono::duration<double, std::milli>(when - last_edit_time_).count();
}

std::optional<double> ViewerModel::note_clean_frame_shown(uint64_t generation, bool clean,
                                                          std::chrono::steady_clock::time_point when) {
  if (!clean_latency_pending_ || !clean || generation < last_edit_generation_) return std::nullopt;
  clean_latency_pending_ = false;
  return std::chrono::duration<double, std::milli>(when - last_edit_time_).count();
}

}  // namespace pt
