// Scripted interaction through the viewer's state model, exactly as the panels and the window drive it.
#include <ImfChannelList.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <doctest/doctest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <set>
#include <cmath>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <thread>

#include "io/image_io.h"
#include "film/film.h"
#include "render/renderer.h"
#include "scene/scene.h"
#include "../frame_helpers.h"
#include "scene/scene_json.h"
#include "viewer/relmse_axis.h"
#include "viewer/viewer_model.h"
#include "viewer/viewer_script.h"

using namespace pt;
using pt::test::block_mean;

namespace {

SceneDesc small_cornell() {
  SceneDesc d = load_scene("cornell");
  d.width = d.height = 40;
  d.render.max_bounces = 4;
  return d;
}

SessionSettings stop_at(uint64_t spp) {
  SessionSettings s;
  s.stop.spp = spp;
  s.preview_divisor = 1;
  return s;
}

// The accumulation's final frame (waits for the stop condition, then takes the newest frame).
DisplayFrame final_frame(ViewerModel& model) {
  REQUIRE(model.session().wait_for([](const SessionStats& s) { return s.done; }, 60.0));
  DisplayFrame f;
  const uint64_t g = model.session().stats().generation;
  const auto start = std::chrono::steady_clock::now();
  while (!(f.generation == g && f.spp == model.session_settings().stop.spp) &&
         std::chrono::steady_clock::now() - start < std::chrono::seconds(10)) {
    if (!model.session().take_frame(f)) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  REQUIRE(f.generation == g);
  return f;
}

size_t material_index(const ViewerModel& m, const std::string& name) {
  for (size_t i = 0; i < m.scene().materials.size(); ++i)
    if (m.scene().materials[i].name == name) return i;
  FAIL("no material " << name);
  return 0;
}

}  // namespace

TEST_CASE("viewer: raising an albedo restarts accumulation at 0 spp and brightens the walls") {
  ViewerModel model(small_cornell(), "cornell", stop_at(8));
  const DisplayFrame before = final_frame(model);
  const uint64_t g0 = model.session().stats().generation;

  const size_t white = material_index(model, "white");
  MaterialDesc m = model.scene().materials[white];
  m.albedo = Rgb(0.95f);
  model.set_paused(true);  // no pass of the new generation can finish before the check below (not a race)
  REQUIRE(model.set_material(white, m));
  const SessionStats now = model.session().stats();
  model.set_paused(false);
  CHECK(now.spp == 0);
  CHECK(now.generation == g0 + 1);
  CHECK(model.last_edit_generation() == g0 + 1);
  CHECK(model.scene().materials[white].albedo == Rgb(0.95f));

  const DisplayFrame after = final_frame(model);
  // Back wall (centre top, above the blocks) and floor (bottom centre) are white: brighter in every channel.
  const glm::dvec3 wall0 = block_mean(before, 14, 6, 26, 14), wall1 = block_mean(after, 14, 6, 26, 14);
  const glm::dvec3 floor0 = block_mean(before, 14, 35, 26, 39), floor1 = block_mean(after, 14, 35, 26, 39);
  for (int c = 0; c < 3; ++c) {
    CHECK(wall1[c] > wall0[c] * 1.1);
    CHECK(floor1[c] > floor0[c] * 1.1);
  }
  // The red wall's light is its own albedo times what reaches it: it gets brighter too, but stays red.
  const glm::dvec3 red = block_mean(after, 1, 10, 5, 30);
  CHECK(red.x > 2.0 * red.y);
}

TEST_CASE("viewer: emission strength scales the light, invalid edits are refused without restarting") {
  ViewerModel model(small_cornell(), "cornell", stop_at(4));
  const DisplayFrame before = final_frame(model);
  const size_t light = material_index(model, "light");
  CHECK(model.emission_strength(light) == doctest::Approx(17.f));
  CHECK(model.emission_colour(light).x == doctest::Approx(1.f));
  REQUIRE(model.set_emission(light, model.emission_colour(light), 34.f));
  CHECK(model.scene().materials[light].emission.x == doctest::Approx(34.f));
  const DisplayFrame after = final_frame(model);
  // Same samples (same seed and sample indices), twice the light: the image doubles exactly up to rounding.
  const glm::dvec3 b = block_mean(before, 0, 0, 40, 40), a = block_mean(after, 0, 0, 40, 40);
  for (int c = 0; c < 3; ++c) CHECK(a[c] == doctest::Approx(2.0 * b[c]).epsilon(1e-4));

  const uint64_t g = model.session().stats().generation;
  MaterialDesc bad = model.scene().materials[0];
  bad.albedo = Rgb(1.5f);
  CHECK(!model.set_material(0, bad));
  CHECK(model.status_is_error());
  CHECK(model.status().find("albedo") != std::string::npos);
  CHECK(model.session().stats().generation == g);
  CHECK(model.scene().materials[0].albedo != Rgb(1.5f));
}

TEST_CASE("viewer: camera input moves the camera and restarts, reset returns to the scene camera") {
  ViewerModel model(small_cornell(), "cornell", stop_at(2));
  const CameraDesc original = model.scene().camera;
  const uint64_t g = model.session().stats().generation;
  ViewInput drag;
  drag.orbit = true;
  drag.drag = Vec2(40.f, 0.f);
  drag.viewport_height = 400.f;
  model.apply_input(drag, 1.0 / 60);
  CHECK(model.session().stats().generation == g + 1);
  CHECK(model.scene().camera.position != original.position);
  CHECK(model.scene().camera.look_at == original.look_at);

  ViewInput idle;  // no buttons, no keys: nothing happens
  idle.drag = Vec2(10.f, 10.f);
  model.apply_input(idle, 1.0 / 60);
  CHECK(model.session().stats().generation == g + 1);

  ViewInput fly;
  fly.look = true;
  fly.fly = DVec3(0, 0, 1);
  const DVec3 p = model.scene().camera.position;
  model.apply_input(fly, 0.5);
  CHECK(glm::length(model.scene().camera.position - p) == doctest::Approx(0.25 * scene_bounds(model.scene()).radius));

  model.reset_camera();
  CHECK(model.scene().camera.position == original.position);
  CHECK(model.scene().camera.look_at == original.look_at);
  CHECK(model.session().stats().generation == g + 3);
}

TEST_CASE("viewer: shortcuts pause, resume, reset and request saves") {
  ViewerModel model(small_cornell(), "cornell", stop_at(0));
  model.shortcut(Shortcut::Pause);
  CHECK(model.paused());
  CHECK(model.session().stats().paused);
  model.shortcut(Shortcut::Pause);
  CHECK(!model.paused());
  const uint64_t g = model.session().stats().generation;
  model.shortcut(Shortcut::Reset);
  CHECK(model.session().stats().generation == g + 1);
  model.shortcut(Shortcut::Save);
  CHECK(model.save_requested);
  model.shortcut(Shortcut::Help);
  CHECK(model.help_open);
  model.shortcut(Shortcut::Quit);
  CHECK(model.quit_requested);
}

TEST_CASE("viewer: a saved scene (edited material and camera) renders with `pathtracer render` to the same image") {
  ViewerModel model(small_cornell(), "cornell", stop_at(6));
  MaterialDesc red = model.scene().materials[material_index(model, "red")];
  red.albedo = Rgb(0.2f, 0.3f, 0.8f);
  REQUIRE(model.set_material(material_index(model, "red"), red));
  ViewInput drag;
  drag.orbit = true;
  drag.drag = Vec2(-25.f, 12.f);
  drag.viewport_height = 300.f;
  model.apply_input(drag, 0.0);
  model.set_fov(50.0);
  const DisplayFrame shown = final_frame(model);

  const std::string json = "viewer_saved_" + std::to_string(getpid()) + ".json";
  const std::string pfm = "viewer_saved_" + std::to_string(getpid()) + ".pfm";
  REQUIRE(model.save_scene(json));
  const SceneDesc loaded = load_scene(json);
  CHECK(loaded.camera.position == model.scene().camera.position);
  CHECK(loaded.camera.fov_deg == 50.0);
  CHECK(loaded.materials[material_index(model, "red")].albedo == red.albedo);

  const std::string cmd = std::string("\"") + PATHTRACER_EXE + "\" render -q --scene " + json + " --spp 6 --pfm " + pfm + " > /dev/null";
  const int status = std::system(cmd.c_str());
  REQUIRE(WIFEXITED(status));
  REQUIRE(WEXITSTATUS(status) == 0);
  const Image img = read_pfm(pfm);
  REQUIRE(img.width == shown.width);
  REQUIRE(img.height == shown.height);
  // The saved file reproduces the model's scene exactly: the CLI's image is, bit for bit, that of the model's
  // description compiled afresh.
  const SceneDesc& desc = model.scene();
  Film direct(desc.width, desc.height);
  Renderer(2).render_pass(*compile_scene(desc), desc.render, direct, 6);
  CHECK(direct.mean_image() == img.rgb);
  // The frame shown is that image too, up to float rounding: when the session moved the camera in place (it does
  // when the full-resolution scene was compiled before the drag, a matter of timing) the geometry is relative to
  // the old eye, so values differ in their last bits and a rare path turns elsewhere. Pixels that differ by more
  // than 0.1 % must be rare; a wrong camera or material changes nearly all of them.
  size_t differing = 0;
  const size_t pixels = static_cast<size_t>(img.width) * img.height;
  for (size_t i = 0; i < pixels; ++i) {
    bool close = true;
    for (int c = 0; c < 3; ++c) {
      const float a = img.rgb[3 * i + c], b = shown.rgba[4 * i + c];
      close = close && std::abs(a - b) <= 1e-3f * std::max(std::abs(a), 1e-3f);
    }
    differing += !close;
  }
  INFO(differing << " of " << pixels << " pixels differ by more than 0.1 %");
  CHECK(differing <= pixels / 20);
  std::filesystem::remove(json);
  std::filesystem::remove(pfm);
}

TEST_CASE("viewer: saved images never overwrite earlier ones, load errors are shown, not thrown") {
  const std::string dir = "viewer_out_" + std::to_string(getpid());
  std::filesystem::create_directory(dir);
  ViewerModel model(small_cornell(), "cornell", stop_at(2));
  model.files.output_dir = dir;
  const DisplayFrame f = final_frame(model);
  const std::vector<uint8_t> rgba(4ull * f.width * f.height, 128);
  const auto a = model.save_image(rgba, f), b = model.save_image(rgba, f);
  REQUIRE(a);
  REQUIRE(b);
  CHECK(*a != *b);
  CHECK(std::filesystem::path(*a).filename() == "cornell-0001");
  CHECK(std::filesystem::path(*b).filename() == "cornell-0002");
  for (const auto& stem : {*a, *b}) {
    CHECK(std::filesystem::exists(stem + ".png"));
    const Image pfm = read_pfm(stem + ".pfm");
    CHECK(pfm.rgb[0] == f.rgba[0]);
    CHECK(pfm.rgb[3 * 100 + 1] == f.rgba[4 * 100 + 1]);
  }
  std::filesystem::remove_all(dir);

  const std::string before = model.scene_name();
  CHECK(!model.load("no-such-dir/missing.json"));
  CHECK(model.status_is_error());
  CHECK(model.status().find("no-such-dir/missing.json") != std::string::npos);
  CHECK(model.scene_name() == before);
  CHECK(model.load("cornell-spheres"));
  CHECK(model.scene_name() == "cornell-spheres");
  CHECK(!model.status_is_error());
}

TEST_CASE("viewer: a material's type and roughness change live, a rough metal differs from a smooth one") {
  ViewerModel model(small_cornell(), "cornell", stop_at(8));
  const size_t white = material_index(model, "white");
  MaterialDesc m = model.scene().materials[white];
  m.type = MaterialType::Conductor;
  m.albedo = Rgb(0.9f);
  m.roughness = 0.f;
  REQUIRE(model.set_material(white, m));
  const DisplayFrame smooth = final_frame(model);
  m.roughness = 0.8f;
  REQUIRE(model.set_material(white, m));
  CHECK(model.scene().materials[white].roughness == 0.8f);
  const DisplayFrame rough = final_frame(model);
  // Every white surface became metal: the smooth one mirrors the light in sharp images, the rough one blurs
  // them; the centre of the back wall changes by far more than the noise of 8 spp.
  const glm::dvec3 s = block_mean(smooth, 16, 8, 24, 14), r = block_mean(rough, 16, 8, 24, 14);
  CHECK(std::abs(r.x - s.x) > 0.2 * s.x);
  // Out of range: refused, the model unchanged.
  m.roughness = 1.5f;
  CHECK(!model.set_material(white, m));
  CHECK(model.status().find("roughness") != std::string::npos);
  CHECK(model.scene().materials[white].roughness == 0.8f);
}

TEST_CASE("viewer: the environment switches between constant and sky live, a missing map is refused") {
  ViewerModel model(small_cornell(), "cornell", stop_at(4));
  const DisplayFrame closed = final_frame(model);
  // The box is closed at the back but open towards the camera (z < 0): a bright constant environment lights it.
  EnvironmentDesc e = model.scene().environment;
  e.type = EnvironmentType::Constant;
  e.radiance = Rgb(2.f);
  REQUIRE(model.set_environment(e));
  const DisplayFrame lit = final_frame(model);
  CHECK(block_mean(lit, 14, 35, 26, 39).x > block_mean(closed, 14, 35, 26, 39).x * 1.2);
  e.type = EnvironmentType::Sky;
  REQUIRE(model.set_environment(e));
  CHECK(model.scene().environment.type == EnvironmentType::Sky);
  const DisplayFrame sky = final_frame(model);
  CHECK(block_mean(sky, 0, 0, 40, 40).x > 0.0);
  const uint64_t g = model.session().stats().generation;
  e.type = EnvironmentType::Map;
  e.file = "no-such-map.exr";
  CHECK(!model.set_environment(e));
  CHECK(model.status_is_error());
  CHECK(model.status().find("no-such-map.exr") != std::string::npos);
  CHECK(model.session().stats().generation == g);
  CHECK(model.scene().environment.type == EnvironmentType::Sky);
}

TEST_CASE("viewer: a material takes an albedo texture file live, a bad file is refused, and it is removed again") {
  ViewerModel model(small_cornell(), "cornell", stop_at(4));
  size_t white = 0;
  while (model.scene().materials[white].name != "white") ++white;
  const std::string png = (std::filesystem::temp_directory_path() / ("pt_viewer_tex_" + std::to_string(::getpid()) + ".png")).string();
  write_png_rgb8(png, 1, 1, {255, 0, 0});  // pure red: the box's shapes have no uv, so they read this one texel
  const DisplayFrame before = final_frame(model);
  REQUIRE(model.set_albedo_texture(white, png));
  REQUIRE(model.scene().materials[white].albedo_map);
  CHECK(model.scene().materials[white].albedo_texture == png);
  const DisplayFrame red = final_frame(model);
  // The back wall (white, now albedo × red): its green falls to almost nothing, its red stays.
  const glm::dvec3 b = block_mean(before, 14, 8, 26, 16), r = block_mean(red, 14, 8, 26, 16);
  CHECK(r.y < 0.2 * b.y);
  CHECK(r.x > 0.5 * b.x);
  const uint64_t g = model.session().stats().generation;
  CHECK(!model.set_albedo_texture(white, "no-such-texture.png"));
  CHECK(model.status_is_error());
  CHECK(model.status().find("no-such-texture.png") != std::string::npos);
  CHECK(model.session().stats().generation == g);
  CHECK(model.scene().materials[white].albedo_map);
  REQUIRE(model.set_albedo_texture(white, ""));
  CHECK(!model.scene().materials[white].albedo_map);
  CHECK(model.scene().materials[white].albedo_texture.empty());
  std::filesystem::remove(png);
}

TEST_CASE("viewer: on shadertoy (look-at 1 unit ahead in a room 25 wide) the orbit pivots about the room's centre") {
  SceneDesc d = load_scene("shadertoy");
  d.width = 64;
  d.height = 36;
  ViewerModel model(d, "shadertoy", stop_at(1));
  // The view is the file's until the first move; the pivot is on the view ray at the bounding box centre's depth.
  CHECK(model.camera().camera().look_at.z == -1.0);
  CHECK(model.camera().target().z == doctest::Approx(-30.0));
  CHECK(model.camera().distance() == doctest::Approx(30.0));
  // A drag of a tenth of the viewport height turns by π/10 about the pivot: the camera travels ~30·π/10 ≈ 9.4
  // units (before: ~0.3, orbiting a point 1 unit ahead), and keeps looking at the room's centre.
  ViewInput in;
  in.orbit = true;
  in.drag = Vec2(10.f, 0.f);
  in.viewport_height = 100.f;
  model.apply_input(in, 0.0);
  const CameraDesc& c = model.camera().camera();
  CHECK(glm::length(c.position - DVec3(0.0)) > 9.0);
  CHECK(glm::length(c.look_at - DVec3(0, 0, -30)) < 1e-9);
  // Scenes whose look-at point is meaningful keep it (cornell).
  ViewerModel cornell(small_cornell(), "cornell", stop_at(1));
  CHECK(glm::length(cornell.camera().target() - load_scene("cornell").camera.look_at) < 1e-12);
}

TEST_CASE("viewer: pick finds the material under an image point, double-click's pivot turns the camera to the hit") {
  ViewerModel model(small_cornell(), "cornell", stop_at(1));
  const size_t red = material_index(model, "red"), green = material_index(model, "green");
  // The red wall fills the left edge of the image, the green one the right edge, at mid height.
  const auto left = model.pick(1.0, 20.0), right = model.pick(39.0, 20.0);
  REQUIRE(left);
  REQUIRE(right);
  CHECK(left->material == red);
  CHECK(right->material == green);
  CHECK(left->point.x == doctest::Approx(552.8).epsilon(0.01));  // the red wall's plane (x ≈ 550–556)
  CHECK(right->point.x == doctest::Approx(0.0).scale(1.0));
  CHECK_FALSE(model.pick(-1.0, 20.0));  // outside the image

  const DVec3 eye = model.camera().camera().position;
  REQUIRE(model.set_pivot_at(1.0, 20.0));
  CHECK(glm::length(model.camera().target() - left->point) < 1e-9);
  CHECK(glm::length(model.camera().camera().position - eye) < 1e-6 * glm::length(eye));  // the eye stays
  // The pivot now sits in the image centre: a pick there finds the red wall at that point.
  const auto centre = model.pick(20.0, 20.0);
  REQUIRE(centre);
  CHECK(centre->material == red);
  CHECK(glm::length(centre->point - left->point) < 1.0);
}

TEST_CASE("viewer: the lens's radius and focus are set live, Alt+click focuses on the surface, bdpt takes the lens") {
  ViewerModel model(small_cornell(), "cornell", stop_at(1));
  REQUIRE(model.set_lens(20.0, 0.0));
  CHECK(model.camera().camera().aperture_radius == 20.0);
  // The focus lands on the picked surface's distance along the view direction.
  REQUIRE(model.focus_at(20.0, 20.0));
  const CameraDesc& c = model.camera().camera();
  const auto hit = model.pick(20.0, 20.0);
  REQUIRE(hit);
  CHECK(c.focus_distance == doctest::Approx(glm::dot(hit->point - c.position, glm::normalize(c.look_at - c.position))));
  CHECK(c.focus_distance > 800.0);  // beyond the box's open front (z = 0, the eye at z = -800)
  // The session renders with the lens (its film restarts and completes a pass).
  REQUIRE(model.session().wait_for([](const SessionStats& s) { return s.done; }, 60.0));
  // bdpt takes the lens: switching to it keeps the lens, and the lens can change under it; a negative or
  // non-finite radius is refused with a status.
  RenderSettings r = model.scene().render;
  r.estimator = Estimator::Bdpt;
  REQUIRE(model.set_render(r));
  CHECK(model.camera().camera().aperture_radius == 20.0);
  REQUIRE(model.set_lens(5.0, 0.0));
  CHECK(model.camera().camera().aperture_radius == 5.0);
  REQUIRE(model.session().wait_for([](const SessionStats& s) { return s.done; }, 60.0));
  CHECK_FALSE(model.set_lens(std::nan(""), 0.0));
  CHECK(model.status_is_error());
  CHECK(model.camera().camera().aperture_radius == 5.0);
}

TEST_CASE("viewer: a click on a block picks the whole block: its material and transform move its five quads, undo restores") {
  ViewerModel model(small_cornell(), "cornell", stop_at(1));
  const SceneDesc before = model.scene();
  // The short block stands right of centre, low in the image (the camera looks down +z, +x to the left).
  std::set<size_t> shapes;  // of the short block, seen in the image's lower right quarter
  for (int y = 20; y < 40; ++y)
    for (int x = 20; x < 40; ++x)
      if (const std::optional<PickResult> hit = model.pick(x + 0.5, y + 0.5); hit && hit->object == 0u) {
        CHECK(hit->shape >= 6);
        CHECK(hit->shape <= 10);
        shapes.insert(hit->shape);
        REQUIRE(model.select_at(x + 0.5, y + 0.5));
      }
  CHECK(shapes.size() >= 2);  // its top and a side: different shapes, one object
  REQUIRE(model.selection());
  CHECK(model.selection()->object == 0u);
  // One material for the whole object.
  const size_t red = material_index(model, "red");
  REQUIRE(model.set_object_material(0, red));
  for (size_t k = 0; k < before.shapes.size(); ++k)
    CHECK(model.scene().shapes[k].material == (k >= 6 && k <= 10 ? static_cast<int>(red) : before.shapes[k].material));
  // Its transform: 90 degrees about +y through the origin, then up by 100: (x, y, z) → (z, y + 100, −x).
  ObjectTransform t;
  t.degrees = 90.0;
  t.translate = DVec3(0, 100, 0);
  REQUIRE(model.set_object_transform(0, t));
  for (size_t k = 6; k <= 10; ++k)
    for (int v = 0; v < 4; ++v) {
      const DVec3 p = before.shapes[k].vertices[v], q = model.scene().shapes[k].vertices[v];
      CHECK(glm::length(q - DVec3(p.z, p.y + 100, -p.x)) < 1e-9);
    }
  for (size_t k = 11; k <= 15; ++k) CHECK(model.scene().shapes[k].vertices == before.shapes[k].vertices);
  // Moving one of its quads moves the object; a zero scale is refused and changes nothing.
  REQUIRE(model.move_shape(8, DVec3(5, 0, 0)));
  CHECK(model.scene().objects[0].transform.translate == DVec3(5, 100, 0));
  const std::vector<ShapeDesc> moved = model.scene().shapes;
  ObjectTransform flat = model.scene().objects[0].transform;
  flat.scale = DVec3(1, 0, 1);
  CHECK_FALSE(model.set_object_transform(0, flat));
  CHECK(model.status().find("scale must be finite and not 0") != std::string::npos);
  for (size_t k = 0; k < moved.size(); ++k) CHECK(model.scene().shapes[k].vertices == moved[k].vertices);
  // Undo walks back to the box as loaded, transform and all.
  while (model.can_undo()) model.undo();
  CHECK(model.scene().objects[0].transform == ObjectTransform{});
  for (size_t k = 0; k < before.shapes.size(); ++k) {
    CHECK(model.scene().shapes[k].vertices == before.shapes[k].vertices);
    CHECK(model.scene().shapes[k].material == before.shapes[k].material);
  }
}

TEST_CASE("viewer: the relMSE plot's axis is finite and bounded for every history a film can give") {
  // Before, the axis loop ran from floor(log10(0)) = -inf: a black film froze the window.
  auto axis = [](std::initializer_list<double> values) {
    std::vector<RelMsePoint> h;
    double t = 0.0;
    for (double v : values) h.push_back({t += 1.0, v, 16});
    return relmse_axis(h);
  };
  auto bounded = [](const RelMseAxis& a) {
    return a.hi > a.lo && a.hi - a.lo <= RelMseAxis::kMaxDecades && a.lo >= RelMseAxis::kLowest &&
           a.hi <= RelMseAxis::kHighest;
  };
  const double inf = std::numeric_limits<double>::infinity(), nan = std::numeric_limits<double>::quiet_NaN();
  const RelMseAxis black = axis({0.0, 0.0, 0.0});
  CHECK(bounded(black));
  CHECK_FALSE(black.any_positive);
  CHECK(black.any_zero);
  for (const RelMseAxis& a : {axis({}), axis({inf, nan}), axis({0.0, 1e-300}), axis({4.9e-324}), axis({1e300, 1e-3}),
                              axis({1e-3, 0.0, inf, 2e-4}), axis({1e-3})})
    CHECK(bounded(a));
  // An ordinary history: the decades just around it, each value placed by its logarithm.
  const RelMseAxis a = axis({0.04, 0.011, 0.0023});
  CHECK(a.lo == -3);
  CHECK(a.hi == -1);
  CHECK(a.fraction(1e-2) == doctest::Approx(0.5));
  CHECK(a.fraction(0.0) == 0.0);
  CHECK(a.fraction(inf) == 1.0);
  CHECK(a.fraction(nan) == 1.0);
  CHECK(a.fraction(1e9) == 1.0);
  // A span wider than the axis allows keeps its low end (where the newest estimates are).
  const RelMseAxis wide = axis({1e8, 1e-30});
  CHECK(wide.lo == -30);
  CHECK(wide.hi == -30 + RelMseAxis::kMaxDecades);
}

TEST_CASE("viewer: --script lines parse into timed actions, a bad line is refused with its file and line") {
  const std::vector<ScriptAction> a =
      parse_viewer_script("# a demo\n0.5 orbit 0.25 -0.1\n\n2 emission light 0  # lights out\n2 quit\n", "demo.txt");
  REQUIRE(a.size() == 3);
  CHECK(a[0].verb == ScriptVerb::Orbit);
  CHECK(a[0].at_seconds == 0.5);
  CHECK(a[0].x == 0.25);
  CHECK(a[0].y == -0.1);
  CHECK(a[1].verb == ScriptVerb::Emission);
  CHECK(a[1].name == "light");
  CHECK(a[1].line == 4);
  CHECK(a[2].verb == ScriptVerb::Quit);
  auto error = [](const std::string& text) {
    try {
      parse_viewer_script(text, "s.txt");
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  CHECK(error("1 orbit 1\n") == "s.txt:1: missing DY");
  CHECK(error("1 orbit 1 2\n0.5 quit\n").rfind("s.txt:2: the time goes back", 0) == 0);
  CHECK(error("x quit\n") == "s.txt:1: the time in seconds: 'x' is not a finite number");
  CHECK(error("1 dance\n").rfind("s.txt:1: unknown action 'dance' (orbit, emission, select, region, screenshot, quit)", 0) == 0);
  CHECK(error("1 region 0 0 1.5 1\n") == "s.txt:1: FX1 must be in [0, 1] (a fraction of the image)");
  CHECK(error("1 select 0.5\n") == "s.txt:1: missing FY");
  CHECK(error("1 quit now\n") == "s.txt:1: unexpected 'now' after the action");
  CHECK(error("1 emission light nan\n") == "s.txt:1: STRENGTH: 'nan' is not a finite number");
  CHECK(error("-1 quit\n") == "s.txt:1: the time must be >= 0");
  CHECK(error("1 screenshot\n") == "s.txt:1: missing the file name");
  const std::vector<ScriptAction> shot = parse_viewer_script("2.5 screenshot out/a.png\n", "s.txt");
  REQUIRE(shot.size() == 1);
  CHECK(shot[0].verb == ScriptVerb::Screenshot);
  CHECK(shot[0].name == "out/a.png");

  // Applied through the model's own actions: the light goes out, an unknown material is reported.
  ViewerModel model(small_cornell(), "cornell", stop_at(1));
  const size_t light = material_index(model, "light");
  CHECK(apply_script_action(model, a[1]) == "");
  CHECK(model.scene().materials[light].emission == Rgb(0.f));
  ScriptAction missing = a[1];
  missing.name = "lamp";
  CHECK(apply_script_action(model, missing) == "no material named 'lamp'");
  // select clicks the image: the red wall fills its left edge; region sets the render region in pixels.
  const std::vector<ScriptAction> more = parse_viewer_script("1 select 0.02 0.5\n1 region 0.25 0.5 0.75 1\n2 region 0 0 1 1\n", "s.txt");
  CHECK(apply_script_action(model, more[0]) == "");
  REQUIRE(model.selection());
  CHECK(model.selection()->material == material_index(model, "red"));
  CHECK(apply_script_action(model, more[1]) == "");
  REQUIRE(model.region());
  CHECK(*model.region() == PixelRect{10, 20, 30, 40});
  CHECK(apply_script_action(model, more[2]) == "");
  CHECK_FALSE(model.region());  // the whole image clears it
  const DVec3 before = model.camera().camera().position;
  CHECK(apply_script_action(model, a[0]) == "");
  CHECK(glm::length(model.camera().camera().position - before) > 1.0);
}

TEST_CASE("viewer: E saves the film's layers as one OpenEXR, written between passes, never over an earlier file") {
  const std::filesystem::path dir = "viewer_exr_" + std::to_string(getpid());
  std::filesystem::remove_all(dir);
  SessionSettings s = stop_at(4);
  s.denoise = true;
  ViewerModel model(small_cornell(), "cornell", s);
  model.files.output_dir = dir.string();
  REQUIRE(model.session().wait_for([](const SessionStats& st) { return st.done; }, 60.0));
  auto save = [&] {
    model.shortcut(Shortcut::SaveExr);
    const auto start = std::chrono::steady_clock::now();
    while (!model.poll_saves() && std::chrono::steady_clock::now() - start < std::chrono::seconds(60))
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    INFO(model.status());
    CHECK_FALSE(model.status_is_error());
  };
  save();
  save();  // a second save takes the next name
  REQUIRE(std::filesystem::exists(dir / "cornell-0001.exr"));
  REQUIRE(std::filesystem::exists(dir / "cornell-0002.exr"));
  Imf::InputFile file((dir / "cornell-0001.exr").c_str());
  std::set<std::string> channels;
  for (auto c = file.header().channels().begin(); c != file.header().channels().end(); ++c) channels.insert(c.name());
  for (const char* name : {"R", "G", "B", "albedo.R", "normal.X", "depth.Z", "emission.B", "variance.G", "spp.Y",
                           "denoised.R"})
    CHECK(channels.count(name) == 1);
  const Imath::Box2i window = file.header().dataWindow();
  CHECK(window.max.x - window.min.x + 1 == model.scene().width);
  // The session was not restarted by the saves.
  CHECK(model.session().stats().spp == 4);
  std::filesystem::remove_all(dir);
}
