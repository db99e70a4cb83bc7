// The viewer's panels and input mapping driven by synthetic ImGui input (mouse, keys, typed characters), as a
// user drives them: the bugs a new user met (Esc quitting from an open combo box, numbers applied per keystroke,
// invalid values silently clamped, scene files silently replaced). No GL: ImGui builds its draw lists only.
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>  // key codes (ImGui 1.86's key indices in the viewer)
#include <doctest/doctest.h>
#include <imgui.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "io/image_io.h"
#include "scene/scene_json.h"
#include "viewer/viewer_input.h"
#include "viewer/viewer_model.h"
#include "viewer/viewer_panels.h"
#include "viewer/viewer_prefs.h"

using namespace pt;

namespace {

SceneDesc small(const std::string& name) {
  SceneDesc d = load_scene(name);
  d.width = d.height = 24;
  d.render.max_bounces = 2;
  return d;
}

SessionSettings few_samples() {
  SessionSettings s;
  s.stop.spp = 2;
  s.preview_divisor = 1;
  s.threads = 1;
  return s;
}

// One ImGui context with the viewer's panels on a tall display (every section open and on screen), and helpers
// that click, type and press keys over whole frames.
struct Ui {
  ViewerModel& model;
  PanelState state;
  ShownImage shown;
  ImageArea area;

  explicit Ui(ViewerModel& m) : model(m) {
    ImGui::CreateContext();
    ImGuiIO& io = ImGui::GetIO();
    io.IniFilename = nullptr;
    io.DisplaySize = ImVec2(1200.f, 9000.f);
    unsigned char* pixels = nullptr;
    int w = 0, h = 0;
    io.Fonts->GetTexDataAsRGBA32(&pixels, &w, &h);  // builds the font atlas (no renderer here)
    io.KeyMap[ImGuiKey_Enter] = GLFW_KEY_ENTER;
    io.KeyMap[ImGuiKey_Escape] = GLFW_KEY_ESCAPE;
    io.KeyMap[ImGuiKey_Tab] = GLFW_KEY_TAB;
    io.KeyMap[ImGuiKey_Backspace] = GLFW_KEY_BACKSPACE;
    // As the GLFW backend declares: window edges resize (ImGui turns that off for good at the first frame without).
    io.BackendFlags |= ImGuiBackendFlags_HasMouseCursors;
    state.record_items = true;
    state.expand_all = true;
    shown.width = shown.height = 24;
    frame();
  }
  ~Ui() { ImGui::DestroyContext(); }

  void frame() {
    ImGuiIO& io = ImGui::GetIO();
    io.DeltaTime = 1.f / 60.f;
    ImGui::NewFrame();
    handle_viewer_input(io, model, 1.0 / 60.0, area);
    draw_viewer_panels(model, state, shown);
    popup_open = ImGui::IsPopupOpen("", ImGuiPopupFlags_AnyPopupId | ImGuiPopupFlags_AnyPopupLevel);
    ImGui::Render();
  }
  bool popup_open = false;  // after the last frame
  // A point of a widget: fraction `fx` of the way across it, halfway down.
  ImVec2 point(const std::string& item, float fx) {
    const auto it = state.item_rects.find(item);
    REQUIRE_MESSAGE(it != state.item_rects.end(), "no widget " << item);
    const auto& r = it->second;
    return ImVec2(r[0] + fx * (r[2] - r[0]), 0.5f * (r[1] + r[3]));
  }
  void click(const std::string& item, bool ctrl = false, float fx = 0.5f) {
    ImGuiIO& io = ImGui::GetIO();
    io.MousePos = point(item, fx);
    frame();
    io.KeyCtrl = ctrl;
    io.MouseDown[0] = true;
    frame();
    io.MouseDown[0] = false;
    frame();
    io.KeyCtrl = false;
    frame();
  }
  void type(const std::string& text) {
    for (char c : text) {
      ImGui::GetIO().AddInputCharacter(static_cast<unsigned>(c));
      frame();
    }
  }
  void press(int key) {
    ImGuiIO& io = ImGui::GetIO();
    io.KeysDown[key] = true;
    frame();
    io.KeysDown[key] = false;
    frame();
  }
  bool any_popup_open() const { return popup_open; }
};

size_t material_index(const ViewerModel& m, const std::string& name) {
  for (size_t i = 0; i < m.scene().materials.size(); ++i)
    if (m.scene().materials[i].name == name) return i;
  FAIL("no material " << name);
  return 0;
}

std::string read_text(const std::string& path) {
  std::ifstream f(path);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

}  // namespace

TEST_CASE("viewer input: Esc with a combo box open closes the list and does not quit, a second Esc quits") {
  ViewerModel model(small("cornell"), "cornell", few_samples());
  Ui ui(model);
  ui.click("estimator");
  REQUIRE(ui.any_popup_open());
  ui.press(GLFW_KEY_ESCAPE);
  CHECK_FALSE(model.quit_requested);  // before: Esc quit the application with the list open
  CHECK_FALSE(model.confirm_quit);
  CHECK_FALSE(ui.any_popup_open());
  ui.press(GLFW_KEY_ESCAPE);
  CHECK(model.quit_requested);  // nothing edited: no question
}

TEST_CASE("viewer input: Esc with unsaved scene edits asks first, Esc again cancels, the answer can quit") {
  ViewerModel model(small("cornell"), "cornell", few_samples());
  Ui ui(model);
  // Camera moves are views: no question.
  model.set_fov(50.0);
  CHECK_FALSE(model.has_unsaved_edits());
  MaterialDesc m = model.scene().materials[0];
  m.albedo = m.albedo * 0.5f;
  REQUIRE(model.set_material(0, m));
  CHECK(model.has_unsaved_edits());

  ui.press(GLFW_KEY_ESCAPE);
  CHECK_FALSE(model.quit_requested);
  CHECK(model.confirm_quit);
  ui.frame();
  CHECK(ui.any_popup_open());
  ui.press(GLFW_KEY_ESCAPE);  // Esc on the question: cancel
  CHECK_FALSE(model.quit_requested);
  CHECK_FALSE(model.confirm_quit);
  CHECK_FALSE(ui.any_popup_open());

  ui.press(GLFW_KEY_ESCAPE);
  REQUIRE(model.confirm_quit);
  ui.frame();
  ui.click("Discard");
  CHECK(model.quit_requested);
}

TEST_CASE("viewer input: a typed IOR applies once, on Enter, an invalid one is refused in red and nothing else reverts") {
  ViewerModel model(small("materials"), "materials", few_samples());
  Ui ui(model);
  const size_t plastic = material_index(model, "red plastic");
  // Another edit first: it must survive the refused value below.
  MaterialDesc m = model.scene().materials[plastic];
  m.roughness = 0.3f;
  REQUIRE(model.set_material(plastic, m));
  ui.frame();

  const uint64_t before = model.last_edit_generation();
  ui.click("red plastic/IOR", /*ctrl=*/true);  // Ctrl+click turns the drag into a text field
  ui.type("1.75");
  CHECK(model.scene().materials[plastic].ior == 1.5f);  // before: "1" was applied at the first keystroke
  CHECK(model.last_edit_generation() == before);
  ui.press(GLFW_KEY_ENTER);
  CHECK(model.scene().materials[plastic].ior == 1.75f);
  CHECK(model.last_edit_generation() == before + 1);  // exactly one restart

  ui.click("red plastic/IOR", /*ctrl=*/true);
  ui.type("-2");
  ui.press(GLFW_KEY_ENTER);
  CHECK(model.scene().materials[plastic].ior == 1.75f);  // refused, not clamped (before: silently 1.0)
  CHECK(model.scene().materials[plastic].roughness == 0.3f);
  REQUIRE(ui.state.refused.size() == 1);
  CHECK(ui.state.refused[0].error.find("ior") != std::string::npos);
  float shown = 0.f;
  std::memcpy(&shown, ui.state.refused[0].bytes.data(), sizeof shown);
  CHECK(shown == -2.f);  // the field keeps what the user typed, in red
  ui.frame();
  CHECK(ui.state.refused.size() == 1);

  // Typing a valid value clears the error.
  ui.click("red plastic/IOR", /*ctrl=*/true);
  ui.type("2");
  ui.press(GLFW_KEY_ENTER);
  CHECK(model.scene().materials[plastic].ior == 2.f);
  CHECK(ui.state.refused.empty());
}

TEST_CASE("viewer input: max bounces typed as 12 restarts once, with 12") {
  ViewerModel model(small("cornell"), "cornell", few_samples());
  Ui ui(model);
  const uint64_t before = model.last_edit_generation();
  ui.click("max bounces");
  ui.type("12");  // the field's text was selected on activation: typing replaces it
  CHECK(model.scene().render.max_bounces == 2);
  ui.press(GLFW_KEY_ENTER);
  CHECK(model.scene().render.max_bounces == 12);
  CHECK(model.last_edit_generation() == before + 1);
}

TEST_CASE("viewer input: Save never replaces an existing scene file without asking, and creates missing folders") {
  const std::filesystem::path dir = "viewer_save_" + std::to_string(getpid());
  std::filesystem::remove_all(dir);
  std::filesystem::create_directory(dir);
  const std::string path = (dir / "scene.json").string();
  { std::ofstream(path) << "precious"; }

  ViewerModel model(small("cornell"), "cornell", few_samples());
  CHECK_FALSE(model.save_scene(path));
  CHECK(model.status().find("exists") != std::string::npos);
  CHECK(read_text(path) == "precious");

  Ui ui(model);
  std::snprintf(ui.state.save_scene_path, sizeof ui.state.save_scene_path, "%s", path.c_str());
  ui.state.save_path_suggested = false;  // as typed into the field: the user chose this existing file
  ui.click("Save");
  CHECK(read_text(path) == "precious");  // before: replaced silently
  CHECK(ui.any_popup_open());
  ui.frame();
  ui.click("Replace");
  CHECK(read_text(path).find("\"materials\"") != std::string::npos);
  CHECK_FALSE(model.has_unsaved_edits());

  const std::string nested = (dir / "new" / "folder" / "scene.json").string();
  CHECK(model.save_scene(nested));
  CHECK(std::filesystem::exists(nested));
  std::filesystem::remove_all(dir);
}

TEST_CASE("viewer: the window title shows the scene, unsaved edits, spp, time and (once meaningful) relMSE") {
  ViewerModel model(small("cornell"), "cornell", few_samples());
  SessionStats st;
  st.spp = 8;
  st.seconds = 1.25;
  st.estimated_relmse = 0.02;
  CHECK(model.window_title(st) == "cornell - 8 spp, 1.2 s - pathtracer");  // relMSE not shown below 16 spp
  st.spp = 64;
  st.done = true;
  MaterialDesc m = model.scene().materials[0];
  m.albedo = m.albedo * 0.5f;
  REQUIRE(model.set_material(0, m));
  CHECK(model.window_title(st) == "cornell* - 64 spp, 1.2 s, relMSE 2.0e-02, done - pathtracer");
}

TEST_CASE("viewer: the style scales with the monitor's content scale, popups are opaque") {
  ImGui::CreateContext();
  setup_viewer_style(2.f);
  CHECK(panel_width() == doctest::Approx(2.f * kPanelWidth));
  CHECK(ImGui::GetStyle().Colors[ImGuiCol_PopupBg].w == 1.f);
  REQUIRE(ImGui::GetIO().Fonts->ConfigData.Size == 1);
  CHECK(ImGui::GetIO().Fonts->ConfigData[0].SizePixels == 26.f);
  CHECK(ImGui::GetStyle().FramePadding.y == doctest::Approx(2.f * ImGuiStyle().FramePadding.y));
  setup_viewer_style(1.f);
  CHECK(panel_width() == doctest::Approx(kPanelWidth));
  ImGui::DestroyContext();
}

TEST_CASE("viewer: undo and redo scene edits (a slider drag is one step), revert to the file, camera moves are not edits") {
  ViewerModel model(small("cornell"), "cornell", few_samples());
  const SceneDesc loaded = model.scene();
  CHECK_FALSE(model.can_undo());
  MaterialDesc m = model.scene().materials[0];
  const Rgb original = m.albedo;
  for (float f : {0.9f, 0.8f, 0.7f}) {  // a drag: three edits of one material within a second
    m.albedo = original * f;
    REQUIRE(model.set_material(0, m));
  }
  RenderSettings r = model.scene().render;
  r.max_bounces = 5;
  REQUIRE(model.set_render(r));
  model.set_fov(30.0);  // a view: not recorded
  const uint64_t generation = model.last_edit_generation();

  REQUIRE(model.undo());  // the render settings
  CHECK(model.scene().render.max_bounces == loaded.render.max_bounces);
  CHECK(model.scene().materials[0].albedo == original * 0.7f);
  CHECK(model.last_edit_generation() > generation);  // undo restarts the accumulation
  REQUIRE(model.undo());  // the whole drag
  CHECK(model.scene().materials[0].albedo == original);
  CHECK_FALSE(model.can_undo());
  CHECK(model.camera().camera().fov_deg == 30.0);  // the view stays
  REQUIRE(model.redo());
  CHECK(model.scene().materials[0].albedo == original * 0.7f);
  REQUIRE(model.redo());
  CHECK(model.scene().render.max_bounces == 5);
  CHECK_FALSE(model.can_redo());

  // Geometry: a moved shape comes back.
  const DVec3 v0 = model.scene().shapes[3].vertices[0];
  REQUIRE(model.move_shape(3, DVec3(0, 10, 0)));
  CHECK(model.scene().shapes[3].vertices[0].y == v0.y + 10);
  REQUIRE(model.undo());
  CHECK(model.scene().shapes[3].vertices[0] == v0);
  REQUIRE(model.redo());

  model.revert();
  CHECK(model.scene().materials[0].albedo == original);
  CHECK(model.scene().render.max_bounces == loaded.render.max_bounces);
  CHECK(model.scene().shapes[3].vertices[0] == v0);
  CHECK(model.camera().camera().fov_deg == loaded.camera.fov_deg);
  CHECK_FALSE(model.has_unsaved_edits());
  REQUIRE(model.undo());  // revert is a step too
  CHECK(model.scene().render.max_bounces == 5);
}

TEST_CASE("viewer input: a click on the image selects the material and object there, Ctrl+Z undoes an edit") {
  ViewerModel model(small("cornell"), "cornell", few_samples());
  Ui ui(model);
  ui.area.w = ui.area.h = 240.f;  // the 24 × 24 image drawn 10× at the top-left
  ui.area.image_width = ui.area.image_height = 24;
  ImGuiIO& io = ImGui::GetIO();
  io.MousePos = ImVec2(4.f, 120.f);  // the red wall, at the left edge
  ui.frame();
  io.MouseDown[0] = true;
  ui.frame();
  io.MouseDown[0] = false;
  ui.frame();
  REQUIRE(model.selection());
  CHECK(model.scene().materials[model.selection()->material].name == "red");
  CHECK(model.scene().shapes[model.selection()->shape].material == static_cast<int>(model.selection()->material));
  ui.frame();
  CHECK(ui.state.item_rects.count("position##object") == 1);  // the Object section shows the clicked shape

  // Move it with the Object section's position field, then Ctrl+Z.
  const DVec3 v0 = model.scene().shapes[model.selection()->shape].vertices[0];
  ui.click("position##object", false, 0.05f);  // the x component
  ui.press(GLFW_KEY_BACKSPACE);
  ui.type("600");
  ui.press(GLFW_KEY_ENTER);
  CHECK(model.scene().shapes[model.selection()->shape].vertices[0].x == 600.0);
  CHECK(model.scene().shapes[model.selection()->shape].vertices[0].y == v0.y);
  io.KeyCtrl = true;
  ui.press(GLFW_KEY_Z);
  io.KeyCtrl = false;
  ui.frame();
  CHECK(model.scene().shapes[model.selection()->shape].vertices[0] == v0);
}

TEST_CASE("viewer: the render resolution is set independently of the window, invalid sizes are refused") {
  ViewerModel model(small("cornell"), "cornell", few_samples());
  REQUIRE(model.set_resolution(32, 16));
  REQUIRE(model.session().wait_for([](const SessionStats& s) { return s.done; }, 60.0));
  DisplayFrame f;
  for (int i = 0; i < 100 && !(f.width == 32 && !f.preview); ++i) {
    model.session().take_frame(f);
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  CHECK(f.width == 32);
  CHECK(f.height == 16);
  CHECK_FALSE(model.set_resolution(0, 16));
  CHECK(model.status().find("resolution") != std::string::npos);
  CHECK_FALSE(model.set_resolution(32, kMaxViewerResolution + 1));
  CHECK(model.scene().width == 32);
}

TEST_CASE("viewer: the image fits the area by default, Ctrl+wheel zooms about the cursor, Ctrl+drag pans, F fits, 1 is 1:1") {
  ImageZoom fit;
  ImageArea a = place_image(fit, 24, 24, 0.f, 0.f, 500.f, 300.f, 1.f);
  CHECK(a.w == 288.f);  // integer magnification 12 (300 / 24 = 12.5)
  CHECK(a.h == 288.f);
  CHECK(a.x == 106.f);
  CHECK(a.y == 6.f);
  a = place_image(fit, 1000, 500, 0.f, 0.f, 500.f, 300.f, 2.f);  // HiDPI: 2 framebuffer pixels per unit
  CHECK(a.w == 500.f);  // scaled down to the width: 1000 framebuffer pixels
  CHECK(a.h == 250.f);

  ViewerModel model(small("cornell"), "cornell", few_samples());
  Ui ui(model);
  ImGuiIO& io = ImGui::GetIO();
  const auto area = [&] { return place_image(model.zoom, 24, 24, 0.f, 0.f, 600.f, 600.f, 1.f); };
  ui.area = area();
  REQUIRE(ui.area.w == 600.f);
  const ImVec2 cursor(150.f, 450.f);
  const ImVec2 under = ui.area.to_image(cursor);
  const CameraDesc camera = model.camera().camera();
  io.MousePos = cursor;
  io.KeyCtrl = true;
  io.MouseWheel = 2.f;  // ×1.25²
  ui.frame();
  io.MouseWheel = 0.f;
  io.KeyCtrl = false;
  CHECK_FALSE(model.zoom.fit);
  CHECK(model.zoom.scale == doctest::Approx(25.f * 1.5625f));
  ui.area = area();
  CHECK(ui.area.w == doctest::Approx(24.f * 25.f * 1.5625f).epsilon(1e-3));
  const ImVec2 still = ui.area.to_image(cursor);
  CHECK(still.x == doctest::Approx(under.x).epsilon(0.01));  // the same image point stays under the cursor
  CHECK(still.y == doctest::Approx(under.y).epsilon(0.01));
  CHECK(model.camera().camera().position == camera.position);  // the camera did not dolly

  // Ctrl+drag pans by the pointer's movement.
  const float x0 = ui.area.x;
  io.KeyCtrl = true;
  io.MouseDown[0] = true;
  ui.frame();
  io.MousePos = ImVec2(cursor.x + 30.f, cursor.y);
  ui.frame();
  io.MouseDown[0] = false;
  io.KeyCtrl = false;
  ui.frame();
  ui.area = area();
  CHECK(ui.area.x == doctest::Approx(x0 + 30.f).epsilon(1e-3));
  CHECK(model.camera().camera().position == camera.position);  // no orbit

  io.MousePos = ImVec2(-10.f, -10.f);
  ui.press(GLFW_KEY_1);
  CHECK(area().w == 24.f);
  ui.press(GLFW_KEY_F);
  CHECK(model.zoom.fit);
  CHECK(area().w == 600.f);
}

TEST_CASE("viewer input: K asks the window for an A/B snapshot, B flips to it only while it fits the image") {
  ViewerModel model(small("cornell"), "cornell", few_samples());
  Ui ui(model);
  ImGui::GetIO().MousePos = ImVec2(-10.f, -10.f);
  ui.press(GLFW_KEY_B);
  CHECK(model.present.snapshot_view == SnapshotView::Off);  // nothing kept yet
  ui.press(GLFW_KEY_K);
  CHECK(model.snapshot_requested);
  model.snapshot = SnapshotInfo{24, 24, 2};  // what the window records when it kept the frame
  model.snapshot_requested = false;
  ui.press(GLFW_KEY_B);
  CHECK(model.present.snapshot_view == SnapshotView::Snapshot);
  ui.press(GLFW_KEY_B);
  CHECK(model.present.snapshot_view == SnapshotView::Off);
  REQUIRE(model.set_resolution(32, 24));  // the snapshot no longer fits: the panel turns the A/B view off
  model.present.snapshot_view = SnapshotView::Split;
  ui.frame();
  CHECK(model.present.snapshot_view == SnapshotView::Off);
  CHECK_FALSE(model.snapshot_usable());
}

TEST_CASE("viewer: recent scene files persist, most recent first, without duplicates, at most 10") {
  const std::filesystem::path dir = "viewer_recent_" + std::to_string(getpid());
  std::filesystem::remove_all(dir);
  const std::string store = (dir / "config" / "recent-scenes.txt").string();
  {
    RecentFiles r(store);
    CHECK(r.paths().empty());
    CHECK(r.add("a.json").empty());
    CHECK(r.add("b.json").empty());
    CHECK(r.add("a.json").empty());
    REQUIRE(r.paths().size() == 2);
    CHECK(r.paths()[0] == std::filesystem::absolute("a.json").lexically_normal().string());
  }
  RecentFiles again(store);
  REQUIRE(again.paths().size() == 2);
  CHECK(std::filesystem::path(again.paths()[0]).filename() == "a.json");
  CHECK(std::filesystem::path(again.paths()[1]).filename() == "b.json");
  for (int i = 0; i < 15; ++i) {
    char name[32];  // (GCC 12 warns falsely, -Wrestrict, on "s" + std::to_string(i))
    std::snprintf(name, sizeof name, "s%d.json", i);
    again.add(name);
  }
  CHECK(again.paths().size() == kMaxRecentFiles);
  CHECK(std::filesystem::path(again.paths()[0]).filename() == "s14.json");
  std::filesystem::remove_all(dir);
}

TEST_CASE("viewer: a dropped scene loads (asking first over unsaved edits), a dropped map becomes the environment") {
  const std::filesystem::path dir = "viewer_drop_" + std::to_string(getpid());
  std::filesystem::remove_all(dir);
  std::filesystem::create_directory(dir);
  const std::string scene_file = (dir / "spheres.json").string();
  { std::ofstream(scene_file) << scene_to_json(small("cornell-spheres")); }
  const std::string map_file = (dir / "sky.pfm").string();
  write_pfm(map_file, Image{4, 2, std::vector<float>(24, 0.5f)});

  ViewerModel model(small("cornell"), "cornell", few_samples());
  RecentFiles recent((dir / "recent.txt").string());
  model.files.recent = &recent;
  CHECK(model.open_file(map_file));
  CHECK(model.scene().environment.type == EnvironmentType::Map);
  CHECK(model.has_unsaved_edits());
  model.open_file((dir / "bunny.obj").string());  // a model that is not there: said, nothing loaded
  CHECK(model.status_is_error());
  CHECK(model.status().find("bunny.obj") != std::string::npos);
  CHECK_FALSE(model.open_file((dir / "notes.txt").string()));
  CHECK(model.status_is_error());

  // The environment edit is unsaved: the scene is not replaced until the user answers.
  const size_t shapes = model.scene().shapes.size();
  CHECK(model.open_file(scene_file));
  REQUIRE(model.confirm_load);
  CHECK(model.scene().shapes.size() == shapes);
  Ui ui(model);
  ui.frame();
  ui.click("Discard");
  CHECK(model.scene_name() == "spheres");
  CHECK(model.scene().shapes.size() != shapes);
  REQUIRE(recent.paths().size() == 1);
  CHECK(std::filesystem::path(recent.paths()[0]).filename() == "spheres.json");
  std::filesystem::remove_all(dir);
}

TEST_CASE("viewer: a saved scene joins the recent files, and a built-in scene's save goes into the output folder") {
  const std::filesystem::path dir = std::filesystem::absolute("viewer_folder_" + std::to_string(getpid()));
  std::filesystem::remove_all(dir);
  const std::string store = (dir / "recent.txt").string();
  {
    ViewerModel model(small("cornell"), "cornell", few_samples());
    RecentFiles recent(store);
    model.files.recent = &recent;
    REQUIRE(model.save_scene((dir / "work" / "mine.json").string()));
    REQUIRE(recent.paths().size() == 1);
  }
  ViewerModel next(small("shadertoy"), "shadertoy", few_samples());  // a later session, a built-in scene
  RecentFiles recent(store);
  next.files.recent = &recent;
  next.files.output_dir = (dir / "out").string();
  Ui ui(next);
  CHECK(std::string(ui.state.save_scene_path) == (dir / "out" / "shadertoy.json").string());
  // A suggested name that appears meanwhile (another program, another viewer) is never offered for replacement.
  std::filesystem::create_directories(dir / "out");
  { std::ofstream(dir / "out" / "shadertoy.json") << "written by someone else"; }
  ui.frame();
  CHECK(std::string(ui.state.save_scene_path) == (dir / "out" / "shadertoy-0001.json").string());
  std::filesystem::remove_all(dir);
}

TEST_CASE("viewer input: after a scene file, a built-in scene's save-as and quit question offer a new file in the "
          "output folder, never a file the user did not open") {
  // Before: with scenes/cornell-bunny.json opened and then the built-in `materials` loaded, the save-as field
  // and the quit question named scenes/materials.json, and "Replace and quit" replaced it.
  const std::filesystem::path dir = std::filesystem::absolute("viewer_saveas_" + std::to_string(getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir / "scenes");
  std::filesystem::create_directories(dir / "out");
  const std::string opened = (dir / "scenes" / "mine.json").string();
  const std::string bystander = (dir / "scenes" / "materials.json").string();
  { std::ofstream(opened) << scene_to_json(small("cornell")); }
  { std::ofstream(bystander) << "the repository's materials scene"; }
  { std::ofstream(dir / "out" / "materials.json") << "an earlier save"; }

  ViewerModel model(small("cornell"), "cornell", few_samples());
  RecentFiles recent((dir / "recent.txt").string());
  model.files.recent = &recent;
  model.files.output_dir = (dir / "out").string();
  Ui ui(model);
  REQUIRE(model.load(opened));
  ui.frame();
  CHECK(std::string(ui.state.save_scene_path) == opened);  // the file the user opened is offered (it asks first)

  REQUIRE(model.load("materials"));  // a built-in scene: it has no file
  ui.frame();
  const std::filesystem::path offered = ui.state.save_scene_path;
  CHECK(offered.parent_path() == dir / "out");
  CHECK_FALSE(std::filesystem::exists(offered));  // never an existing file: not out/materials.json either
  CHECK(offered.filename().string().rfind("materials", 0) == 0);

  // Quitting over an edit asks; its save button writes the new file and nothing else.
  MaterialDesc m = model.scene().materials[0];
  m.albedo = m.albedo * 0.5f;
  REQUIRE(model.set_material(0, m));
  ui.press(GLFW_KEY_ESCAPE);
  REQUIRE(model.confirm_quit);
  ui.frame();
  ui.click("Save first");
  CHECK(model.quit_requested);
  CHECK(read_text(bystander) == "the repository's materials scene");
  CHECK(read_text((dir / "out" / "materials.json").string()) == "an earlier save");
  CHECK(read_text(offered.string()).find("\"materials\"") != std::string::npos);
  std::filesystem::remove_all(dir);
}

TEST_CASE("viewer input: with the light switched off live, the panels draw the black film's relMSE history in a "
          "bounded frame") {
  // Before, the relMSE plot's axis loop never ended on a history of zeros: this frame never returned.
  SessionSettings settings = few_samples();
  settings.stop.spp = 0;
  settings.stop.seconds = 1.0;  // many passes: a plot needs two points from kRelMseStopMinSpp on
  ViewerModel model(small("cornell"), "cornell", settings);
  Ui ui(model);
  REQUIRE(model.set_emission(material_index(model, "light"), Rgb(1.f), 0.f));
  REQUIRE(model.session().wait_for([](const SessionStats& s) { return s.done; }, 60.0));
  std::vector<RelMsePoint> history;
  model.session().copy_history(history);
  std::erase_if(history, [](const RelMsePoint& q) { return q.spp < kRelMseStopMinSpp; });
  REQUIRE(history.size() >= 2);
  CHECK(history.back().relmse == 0.0);
  CHECK(model.session().stats().estimated_relmse == 0.0);
  for (int i = 0; i < 3; ++i) ui.frame();
  const ImDrawData* dd = ImGui::GetDrawData();
  REQUIRE(dd != nullptr);
  MESSAGE("panel frame over a black film: " << dd->TotalVtxCount << " vertices");
  CHECK(dd->TotalVtxCount < 200000);
  CHECK(model.window_title(model.session().stats()).find("relMSE 0.0e+00") != std::string::npos);
}

TEST_CASE("viewer: undoing back to the file's state (or the last save) clears the unsaved mark, redo sets it again") {
  // Before, the `*` stayed after undoing every edit, and quitting asked about edits that were gone.
  ViewerModel model(small("cornell"), "cornell", few_samples());
  MaterialDesc m = model.scene().materials[0];
  m.albedo = m.albedo * 0.5f;
  REQUIRE(model.set_material(0, m));
  CHECK(model.has_unsaved_edits());
  CHECK(model.window_title(model.session().stats()).rfind("cornell*", 0) == 0);
  REQUIRE(model.undo());
  CHECK_FALSE(model.has_unsaved_edits());
  CHECK(model.window_title(model.session().stats()).rfind("cornell -", 0) == 0);
  model.request_quit();
  CHECK(model.quit_requested);  // nothing to ask about
  model.quit_requested = false;
  REQUIRE(model.redo());
  CHECK(model.has_unsaved_edits());

  // After a save, the saved state is the clean one: undo past it is an edit again, redo back to it is not.
  const std::filesystem::path dir = "viewer_clean_" + std::to_string(getpid());
  std::filesystem::remove_all(dir);
  RenderSettings r = model.scene().render;
  r.max_bounces = 7;
  REQUIRE(model.set_render(r));
  REQUIRE(model.save_scene((dir / "s.json").string()));
  CHECK_FALSE(model.has_unsaved_edits());
  r.max_bounces = 8;  // within a second of the last render edit, but after the save: its own step
  REQUIRE(model.set_render(r));
  CHECK(model.has_unsaved_edits());
  REQUIRE(model.undo());
  CHECK(model.scene().render.max_bounces == 7);
  CHECK_FALSE(model.has_unsaved_edits());
  REQUIRE(model.undo());
  CHECK(model.has_unsaved_edits());
  REQUIRE(model.redo());
  CHECK_FALSE(model.has_unsaved_edits());
  // Revert goes to the scene as loaded, which is not what was saved.
  model.revert();
  CHECK(model.has_unsaved_edits());
  std::filesystem::remove_all(dir);
}

TEST_CASE("viewer: stop conditions and the A/B snapshot belong to a scene: loading another starts from the "
          "command line's conditions and no snapshot") {
  SessionSettings launch = few_samples();
  launch.stop.spp = 0;
  launch.stop.seconds = 30.0;  // as `view --time 30`
  ViewerModel model(small("cornell"), "cornell", launch);
  SessionSettings edited = model.session_settings();
  edited.stop.relmse = 5e-3;
  edited.stop.seconds = 0.0;
  model.set_session_settings(edited);
  model.snapshot = SnapshotInfo{24, 24, 16};
  model.present.snapshot_view = SnapshotView::Snapshot;
  REQUIRE(model.snapshot_usable());
  REQUIRE(model.load("cornell-spheres"));
  CHECK(model.session_settings().stop.relmse == 0.0);  // before: 5e-3 carried over
  CHECK(model.session_settings().stop.seconds == 30.0);
  CHECK(model.session().settings().stop.relmse == 0.0);
  CHECK_FALSE(model.snapshot.has_value());  // before: the Cornell box's snapshot stayed, B flipped to it
  CHECK(model.present.snapshot_view == SnapshotView::Off);
  // The threads are the user's, not the scene's: they stay.
  CHECK(model.session_settings().threads == launch.threads);
}

TEST_CASE("viewer: loading a missing or broken file over unsaved edits reports the error without asking first") {
  const std::filesystem::path dir = "viewer_badload_" + std::to_string(getpid());
  std::filesystem::remove_all(dir);
  std::filesystem::create_directory(dir);
  { std::ofstream(dir / "broken.json") << "{\"shapes\": ["; }
  ViewerModel model(small("cornell"), "cornell", few_samples());
  MaterialDesc m = model.scene().materials[0];
  m.albedo = m.albedo * 0.5f;
  REQUIRE(model.set_material(0, m));
  for (const std::string& bad : {(dir / "missing.json").string(), (dir / "broken.json").string()}) {
    CAPTURE(bad);
    model.request_load(bad);
    CHECK_FALSE(model.confirm_load.has_value());  // before: "Open anyway?" first, then the error
    CHECK(model.status_is_error());
    CHECK(model.status().find(bad) != std::string::npos);
    CHECK(model.scene_name() == "cornell");
    CHECK(model.has_unsaved_edits());
  }
  model.request_load("cornell-spheres");  // a good one still asks
  CHECK(model.confirm_load.has_value());
  std::filesystem::remove_all(dir);
}

TEST_CASE("viewer input: F1 opens Help and scrolls it into view, and its text wraps inside the panel") {
  ViewerModel model(small("cornell"), "cornell", few_samples());
  Ui ui(model);
  ui.state.expand_all = false;  // the user's panel: sections as they open by default
  ImGui::GetIO().DisplaySize = ImVec2(1200.f, 700.f);
  ui.frame();
  ui.press(GLFW_KEY_F1);
  ui.frame();
  CHECK(model.help_open);
  const auto& help = ui.state.item_rects.at("Help");
  CHECK(help[1] >= 0.f);
  CHECK(help[3] <= 700.f);  // before: opened below the fold, off screen
  // Every row's text stays inside the panel (before: a fixed-fit table ran past its right edge, clipped).
  int rows = 0;
  for (const auto& [name, r] : ui.state.item_rects)
    if (name.rfind("help ", 0) == 0) {
      CAPTURE(name);
      CHECK(r[2] <= 1200.f);
      ++rows;
    }
  CHECK(rows >= 30);
}

TEST_CASE("viewer input: a key pressed and released between two frames still acts (Ctrl+Z, P, Enter in a field)") {
  // ImGui 1.86 reads io.KeysDown when a frame starts; the GLFW backend sets it from the events of the last poll.
  // A tap shorter than a frame (press and release in one poll) left it false: the key was lost.
  ViewerModel model(small("cornell"), "cornell", few_samples());
  Ui ui(model);
  ImGuiIO& io = ImGui::GetIO();
  KeyEvents keys;
  // As the backend leaves things after one poll holding press and release: the events seen, the state up.
  auto tap = [&](std::initializer_list<int> chord) {
    for (int k : chord) keys.on_key(k, KeyEvents::kPress);
    for (int k : chord) keys.on_key(k, KeyEvents::kRelease);
    keys.before_frame(io);
    ui.frame();
    keys.after_frame(io);
    ui.frame();
  };
  MaterialDesc m = model.scene().materials[0];
  const Rgb original = m.albedo;
  m.albedo = original * 0.5f;
  REQUIRE(model.set_material(0, m));
  tap({GLFW_KEY_LEFT_CONTROL, GLFW_KEY_Z});
  CHECK(model.scene().materials[0].albedo == original);  // undone
  CHECK_FALSE(io.KeyCtrl);                                // and released after the frame
  CHECK_FALSE(io.KeysDown[GLFW_KEY_Z]);
  tap({GLFW_KEY_P});
  CHECK(model.paused());
  tap({GLFW_KEY_P});
  CHECK_FALSE(model.paused());

  // Enter typed into a field as a tap applies the value.
  const uint64_t before = model.last_edit_generation();
  ui.click("max bounces");  // a numeric field selects its text when clicked: typing replaces it
  ui.type("9");
  tap({GLFW_KEY_ENTER});
  CHECK(model.scene().render.max_bounces == 9);
  CHECK(model.last_edit_generation() == before + 1);
}

TEST_CASE("viewer input: the denoise box is a view: ticking it keeps the film's samples and shows a denoised image") {
  SessionSettings s = few_samples();
  s.stop.spp = 6;
  ViewerModel model(small("cornell"), "cornell", s);
  Ui ui(model);
  REQUIRE(model.session().wait_for([](const SessionStats& st) { return st.done; }, 60.0));
  const SessionStats before = model.session().stats();
  ui.click("denoise");
  CHECK(model.present.denoise);
  CHECK(model.session_settings().denoise);
  // Before, the click restarted the accumulation: generation + 1, 0 spp.
  CHECK(model.session().stats().generation == before.generation);
  CHECK(model.session().stats().spp == before.spp);
  CHECK(model.last_edit_generation() == before.generation);
  DisplayFrame f;
  const auto start = std::chrono::steady_clock::now();
  while (f.denoised.empty() && std::chrono::steady_clock::now() - start < std::chrono::seconds(30))
    if (!model.session().take_frame(f)) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  CHECK(f.denoised.size() == 3u * 24 * 24);
  CHECK(f.spp == before.spp);
  ui.click("denoise");  // and off again: still the same accumulation
  CHECK_FALSE(model.present.denoise);
  CHECK(model.session().stats().generation == before.generation);
}

TEST_CASE("viewer: following the window, the film takes the image area's size at the chosen scale, as a view") {
  ViewerModel model(small("cornell"), "cornell", few_samples());
  CHECK(model.scene().width == 24);
  model.set_follow_window(true, 1.f);
  REQUIRE(model.note_image_area(90, 60));
  CHECK(model.scene().width == 90);
  CHECK(model.scene().height == 60);
  CHECK_FALSE(model.has_unsaved_edits());  // a view, like a camera move
  CHECK_FALSE(model.can_undo());
  CHECK_FALSE(model.note_image_area(90, 60));  // unchanged: no restart
  model.set_follow_window(true, 0.5f);
  CHECK(model.scene().width == 45);
  CHECK(model.scene().height == 30);
  CHECK_FALSE(model.set_resolution(64, 64));  // refused while following: the window decides
  CHECK(model.status_is_error());
  // The session renders at the new size, without rebuilding anything but the camera's raster.
  REQUIRE(model.session().wait_for([](const SessionStats& s) { return s.done; }, 60.0));
  DisplayFrame f;
  const auto start = std::chrono::steady_clock::now();
  while (!(f.width == 45 && !f.preview) && std::chrono::steady_clock::now() - start < std::chrono::seconds(20))
    if (!model.session().take_frame(f)) std::this_thread::sleep_for(std::chrono::milliseconds(2));
  CHECK(f.width == 45);
  CHECK(f.height == 30);
  // Off: the scene's own size again; then a fixed size is an edit.
  model.set_follow_window(false, 0.5f);
  CHECK(model.scene().width == 24);
  REQUIRE(model.set_resolution(64, 48));
  CHECK(model.has_unsaved_edits());
  REQUIRE(model.undo());
  CHECK(model.scene().width == 24);
}

TEST_CASE("viewer input: the panel's left edge is a splitter: dragging it widens the panel") {
  ViewerModel model(small("cornell"), "cornell", few_samples());
  Ui ui(model);
  ui.state.expand_all = false;
  ImGuiIO& io = ImGui::GetIO();
  io.DisplaySize = ImVec2(1200.f, 800.f);
  ui.frame();
  const float before = ui.state.width_units;
  const float edge = 1200.f - ui.state.width();
  io.MousePos = ImVec2(edge + 1.f, 400.f);  // on the left border
  ui.frame();
  io.MouseDown[0] = true;
  ui.frame();
  for (int i = 1; i <= 10; ++i) {
    io.MousePos = ImVec2(edge + 1.f - 10.f * i, 400.f);
    ui.frame();
  }
  io.MouseDown[0] = false;
  ui.frame();
  MESSAGE("panel width " << before << " -> " << ui.state.width_units);
  CHECK(ui.state.width_units == doctest::Approx(before + 100.f).epsilon(0.03));
  // The image is not orbited by a drag that began on the splitter.
  CHECK(model.camera().camera().position == model.scene().camera.position);
}

TEST_CASE("viewer: preferences read back what was written, and bad lines are ignored with a warning") {
  const std::string path = "viewer_prefs_" + std::to_string(getpid()) + ".conf";
  ViewerPrefs p;
  p.panel_width = 512.f;
  p.follow_window = false;
  p.follow_scale = 0.25f;
  REQUIRE(write_viewer_prefs(path, p) == "");
  std::vector<std::string> warnings;
  const ViewerPrefs q = read_viewer_prefs(path, warnings);
  CHECK(warnings.empty());
  CHECK(q.panel_width == 512.f);
  CHECK_FALSE(q.follow_window);
  CHECK(q.follow_scale == 0.25f);
  { std::ofstream(path) << "panel_width=5\nfollow_scale=0.3\ncolour=blue\nfollow_window=1\n"; }
  const ViewerPrefs r = read_viewer_prefs(path, warnings);
  CHECK(warnings.size() == 3);
  CHECK(r.panel_width == ViewerPrefs{}.panel_width);
  CHECK(r.follow_scale == 1.f);
  CHECK(r.follow_window);
  CHECK(read_viewer_prefs("no/such/file.conf", warnings).panel_width == ViewerPrefs{}.panel_width);
  std::filesystem::remove(path);
}

TEST_CASE("viewer input: the material search shows only the matching materials, by name or type, any case") {
  ViewerModel model(small("materials"), "materials", few_samples());
  Ui ui(model);
  ui.frame();
  CHECK(ui.state.item_rects.count("polished gold/type") == 1);
  ui.click("material filter");
  ui.type("GLASS");
  ui.state.item_rects.clear();
  ui.frame();
  CHECK(ui.state.item_rects.count("glass/type") == 1);
  CHECK(ui.state.item_rects.count("frosted glass/type") == 1);
  CHECK(ui.state.item_rects.count("polished gold/type") == 0);
  for (int i = 0; i < 5; ++i) ui.press(GLFW_KEY_BACKSPACE);
  ui.type("metal");  // by type
  ui.state.item_rects.clear();
  ui.frame();
  CHECK(ui.state.item_rects.count("copper/type") == 1);
  CHECK(ui.state.item_rects.count("glass/type") == 0);
  CHECK(ui.state.item_rects.count("wax/type") == 0);
}

TEST_CASE("viewer: a dropped .obj opens in a studio scene (ground, sky, a camera framing it)") {
  const std::filesystem::path dir = "viewer_obj_" + std::to_string(getpid());
  std::filesystem::remove_all(dir);
  std::filesystem::create_directory(dir);
  const std::string obj = (dir / "tetra.obj").string();
  { std::ofstream(obj) << "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"; }
  ViewerModel model(small("cornell"), "cornell", few_samples());
  REQUIRE(model.open_file(obj));
  INFO(model.status());
  CHECK_FALSE(model.status_is_error());
  CHECK(model.scene_name() == "tetra");
  CHECK(model.scene().shapes.size() == 5);  // 4 triangles and the ground
  CHECK(model.scene().environment.type == EnvironmentType::Sky);
  CHECK(model.pick(model.scene().width / 2.0, model.scene().height / 2.0).has_value());  // something in view
  std::filesystem::remove_all(dir);
}

TEST_CASE("viewer input: Ctrl+B and a drag draw a render region: only it accumulates, without a restart, and Ctrl+Alt+B clears it") {
  SessionSettings s = few_samples();
  s.stop.spp = 4;
  ViewerModel model(small("cornell"), "cornell", s);
  Ui ui(model);
  ui.area.w = ui.area.h = 240.f;  // the 24 × 24 image drawn 10× at the top-left
  ui.area.image_width = ui.area.image_height = 24;
  // On a timeout, the session's state says where it stopped.
  const auto wait = [&](auto pred, const char* what) {
    const bool ok = model.session().wait_for(pred, 60.0);
    const SessionStats st = model.session().stats();
    INFO(what << ": spp " << st.spp << ", done " << st.done << " (" << st.stop_reason << "), generation "
              << st.generation << ", rendering " << st.rendering << ", error '" << st.error << "'");
    REQUIRE(ok);
  };
  wait([](const SessionStats& st) { return st.done; }, "the first 4 spp");
  const SessionStats before = model.session().stats();
  const DVec3 eye = model.camera().camera().position;
  ImGuiIO& io = ImGui::GetIO();
  io.KeyCtrl = true;
  ui.press(GLFW_KEY_B);
  io.KeyCtrl = false;
  REQUIRE(model.drawing_region);
  // Drag from image point (4, 6) to (16, 20): the region, and no orbit.
  io.MousePos = ImVec2(40.f, 60.f);
  ui.frame();
  io.MouseDown[0] = true;
  ui.frame();
  for (float t : {0.25f, 0.5f, 1.f}) {
    io.MousePos = ImVec2(40.f + t * 120.f, 60.f + t * 140.f);
    ui.frame();
    if (t == 0.5f) CHECK(region_being_drawn(io, model, ui.area) == PixelRect{4, 6, 10, 13});
  }
  io.MouseDown[0] = false;
  ui.frame();
  REQUIRE(model.region());
  CHECK(*model.region() == PixelRect{4, 6, 16, 20});
  CHECK_FALSE(model.drawing_region);
  CHECK(model.camera().camera().position == eye);
  CHECK(model.session().stats().generation == before.generation);  // not a restart
  // Four more samples, in the region alone.
  SessionSettings more = model.session_settings();
  more.stop.spp = 8;
  model.set_session_settings(more);
  wait([](const SessionStats& st) { return st.done && st.spp == 8; }, "8 spp in the region");
  CHECK(model.session().stats().generation == before.generation);
  DisplayFrame f;
  const auto start = std::chrono::steady_clock::now();
  while (!(f.spp == 8 && f.generation == before.generation) && std::chrono::steady_clock::now() - start < std::chrono::seconds(30))
    if (!model.session().take_frame(f)) std::this_thread::sleep_for(std::chrono::milliseconds(2));
  REQUIRE(f.count.size() == 24u * 24u);
  size_t inside = 0, outside = 0;
  for (int y = 0; y < 24; ++y)
    for (int x = 0; x < 24; ++x) {
      const float c = f.count[static_cast<size_t>(y) * 24 + x];
      (model.region()->contains(x, y) ? inside : outside) += (c == (model.region()->contains(x, y) ? 8.f : 4.f));
    }
  CHECK(inside == 12u * 14u);
  CHECK(outside == 24u * 24u - 12u * 14u);
  // Ctrl+Alt+B clears it: the whole image counts again (4 spp < 8), so the render resumes outside.
  io.KeyCtrl = io.KeyAlt = true;
  ui.press(GLFW_KEY_B);
  io.KeyCtrl = io.KeyAlt = false;
  CHECK_FALSE(model.region());
  // Every pixel reaches 8 (the frame's spp is the whole film's minimum again), in the same accumulation.
  const auto again = std::chrono::steady_clock::now();
  while (!(f.spp == 8 && f.count[0] >= 8.f) && std::chrono::steady_clock::now() - again < std::chrono::seconds(60))
    if (!model.session().take_frame(f)) std::this_thread::sleep_for(std::chrono::milliseconds(2));
  CHECK(f.spp == 8);
  CHECK(f.count[0] >= 8.f);  // outside the old region
  CHECK(f.generation == before.generation);
}
