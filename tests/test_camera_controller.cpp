// Camera controller maths of the viewer (orbit, pan, dolly, look, fly), without any window.
#include <doctest/doctest.h>

#include "scene/camera_controller.h"
#include "scene/scene.h"
#include "scene/scene_json.h"

using namespace pt;

namespace {

double dist(DVec3 a, DVec3 b) { return glm::length(a - b); }

CameraController cornell_controller(SceneDesc* out = nullptr) {
  const SceneDesc s = load_scene("cornell");
  if (out) *out = s;
  CameraController c;
  c.reset(s.camera, scene_bounds(s).radius, 1.0);
  return c;
}

}  // namespace

TEST_CASE("camera: scene bounds of the Cornell box") {
  const SceneBounds b = scene_bounds(load_scene("cornell"));
  CHECK(b.center.x == doctest::Approx(278.0));
  CHECK(b.center.y == doctest::Approx(274.4));
  CHECK(b.center.z == doctest::Approx(279.6));
  CHECK(b.radius == doctest::Approx(0.5 * std::sqrt(556.0 * 556.0 + 548.8 * 548.8 + 559.2 * 559.2)));
}

TEST_CASE("camera: reset reproduces the scene camera exactly, orbit keeps target and distance") {
  SceneDesc s;
  CameraController c = cornell_controller(&s);
  CHECK(c.camera().position == s.camera.position);
  CHECK(c.camera().look_at == s.camera.look_at);
  CHECK(c.camera().fov_deg == s.camera.fov_deg);
  const double d0 = dist(s.camera.position, s.camera.look_at);

  c.orbit(0.7, 0.3);
  CHECK(c.camera().look_at == s.camera.look_at);
  CHECK(dist(c.camera().position, c.camera().look_at) == doctest::Approx(d0));
  CHECK(c.camera().position.y > s.camera.position.y);  // positive pitch raises the camera
  // The rendered camera stays valid (up not parallel to the view).
  SceneDesc moved = s;
  moved.camera = c.camera();
  CHECK(validate_scene(moved).empty());

  c.orbit(-0.7, -0.3);
  CHECK(dist(c.camera().position, s.camera.position) < 1e-9 * d0);

  // A full turn of yaw comes back.
  c.orbit(2 * glm::pi<double>(), 0.0);
  CHECK(dist(c.camera().position, s.camera.position) < 1e-9 * d0);

  // Right-handed about up: yaw > 0 turns the offset from −z towards −x.
  c.orbit(0.1, 0.0);
  CHECK(c.camera().position.x < s.camera.position.x);
}

TEST_CASE("camera: pitch is clamped short of the up axis, however far one drags") {
  CameraController c = cornell_controller();
  c.orbit(0.0, 100.0);
  const DVec3 dir = glm::normalize(c.camera().position - c.camera().look_at);
  CHECK(glm::dot(dir, DVec3(0, 1, 0)) == doctest::Approx(std::sin(CameraController::kMaxPitch)));
  c.orbit(0.0, -200.0);
  const DVec3 dir2 = glm::normalize(c.camera().position - c.camera().look_at);
  CHECK(glm::dot(dir2, DVec3(0, 1, 0)) == doctest::Approx(-std::sin(CameraController::kMaxPitch)));
}

TEST_CASE("camera: pan moves camera and target together by viewport heights in the image plane") {
  SceneDesc s;
  CameraController c = cornell_controller(&s);
  const double h = 2.0 * 800.0 * std::tan(glm::radians(39.3077) / 2);
  CHECK(c.viewport_height() == doctest::Approx(h));
  c.pan(0.5, 0.0);  // cursor moves half a viewport to the right: the camera moves left, i.e. towards +x here
  CHECK(c.camera().look_at.x == doctest::Approx(278.0 + 0.5 * h));
  CHECK(c.camera().position.x == doctest::Approx(278.0 + 0.5 * h));
  CHECK(c.camera().position.z == doctest::Approx(-800.0));
  c.pan(0.0, 0.25);  // cursor down: camera up
  CHECK(c.camera().look_at.y == doctest::Approx(273.0 + 0.25 * h));
}

TEST_CASE("camera: dolly approaches the target geometrically and never reaches it") {
  CameraController c = cornell_controller();
  c.dolly(1.0);
  CHECK(c.distance() == doctest::Approx(800.0 * 0.85));
  c.dolly(-2.0);
  CHECK(c.distance() == doctest::Approx(800.0 / 0.85));
  c.dolly(1e4);
  CHECK(c.distance() > 0.0);
  CHECK(c.camera().position != c.camera().look_at);
}

TEST_CASE("camera: fly speed scales with the scene, look turns about the camera position") {
  SceneDesc s;
  CameraController c = cornell_controller(&s);
  const double r = scene_bounds(s).radius;
  CHECK(c.fly_speed() == doctest::Approx(0.5 * r));
  c.fly({0, 0, 1}, 0.5);  // W for half a second
  CHECK(c.camera().position.z == doctest::Approx(-800.0 + 0.25 * r));
  CHECK(c.camera().look_at.z == doctest::Approx(0.0 + 0.25 * r));
  c.fly({0, 1, 0}, 1.0, 4.0);  // E, fast
  CHECK(c.camera().position.y == doctest::Approx(273.0 + 2.0 * r));

  CameraController l = cornell_controller();
  const DVec3 p = l.camera().position;
  l.look(0.2, 0.1);
  CHECK(dist(l.camera().position, p) < 1e-9);
  const DVec3 f = glm::normalize(l.camera().look_at - p);
  CHECK(f.y == doctest::Approx(std::sin(0.1)));  // looked up
  CHECK(f.x > 0.0);                              // yaw left: image left is +x for this camera

  // A scene 10^6 times larger flies 10^6 times faster: no absolute lengths.
  SceneDesc big = s;
  for (ShapeDesc& sh : big.shapes)
    for (DVec3& v : sh.vertices) v *= 1e6;
  CHECK(scene_bounds(big).radius == doctest::Approx(1e6 * r));
}

TEST_CASE("camera: numeric position and target fields") {
  CameraController c = cornell_controller();
  c.set_position({278, 273, -400});
  CHECK(c.camera().position.z == doctest::Approx(-400.0));
  CHECK(c.distance() == doctest::Approx(400.0));
  c.set_target({0, 273, 0});
  CHECK(c.camera().look_at.x == doctest::Approx(0.0));
  CHECK(c.camera().position.z == doctest::Approx(-400.0));
  c.set_fov(500);
  CHECK(c.camera().fov_deg == 170.0);
}
