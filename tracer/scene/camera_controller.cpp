#include "scene/camera_controller.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "scene/scene.h"

namespace pt {

SceneBounds scene_bounds(const SceneDesc& scene) {
  DVec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
  for (const ShapeDesc& s : scene.shapes) {
    if (s.type == ShapeType::Sphere) {
      lo = glm::min(lo, s.center - DVec3(s.radius));
      hi = glm::max(hi, s.center + DVec3(s.radius));
    } else {
      const int n = s.type == ShapeType::Quad ? 4 : 3;
      for (int k = 0; k < n; ++k) {
        lo = glm::min(lo, s.vertices[k]);
        hi = glm::max(hi, s.vertices[k]);
      }
    }
  }
  for (const InstanceDesc& in : scene.instances) {
    const auto [ilo, ihi] = placed_box(scene, in);
    lo = glm::min(lo, ilo), hi = glm::max(hi, ihi);
  }
  SceneBounds b;
  if (!(lo.x <= hi.x)) {  // no shapes: centre on what the camera looks at
    b.center = scene.camera.look_at;
    b.radius = std::max(glm::length(scene.camera.look_at - scene.camera.position), 1e-30);
    return b;
  }
  b.center = 0.5 * (lo + hi);
  b.radius = 0.5 * glm::length(hi - lo);
  if (!(b.radius > 0.0)) b.radius = std::max(glm::length(scene.camera.look_at - scene.camera.position), 1e-30);
  return b;
}

void CameraController::reset(const CameraDesc& camera, double scene_radius, double aspect) {
  camera_ = camera;
  radius_ = scene_radius > 0.0 ? scene_radius : 1.0;
  aspect_ = aspect > 0.0 ? aspect : 1.0;
  up_ = glm::normalize(camera.up);
  // Any unit vector perpendicular to up: start from the world axis least aligned with it.
  const DVec3 a = std::abs(up_.x) < 0.9 ? DVec3(1, 0, 0) : DVec3(0, 0, 1);
  e1_ = glm::normalize(a - glm::dot(a, up_) * up_);
  e2_ = glm::cross(up_, e1_);
  target_ = camera.look_at;
  set_from_offset(camera.position - camera.look_at);
  // camera_ keeps the exact scene values: reset must reproduce the scene camera bit for bit.
}

DVec3 CameraController::offset_direction() const {
  return std::cos(pitch_) * (std::cos(yaw_) * e1_ + std::sin(yaw_) * e2_) + std::sin(pitch_) * up_;
}

void CameraController::set_from_offset(DVec3 offset) {
  const double len = glm::length(offset);
  if (!(len > 0.0 && std::isfinite(len))) {  // camera on the target: keep the direction, step back a little
    distance_ = 1e-4 * radius_;
    return;
  }
  distance_ = len;
  const DVec3 d = offset / len;
  pitch_ = std::asin(std::clamp(glm::dot(d, up_), -1.0, 1.0));
  yaw_ = std::atan2(glm::dot(d, e2_), glm::dot(d, e1_));
}

void CameraController::update() {
  pitch_ = std::clamp(pitch_, -kMaxPitch, kMaxPitch);
  yaw_ = std::remainder(yaw_, 2.0 * glm::pi<double>());
  distance_ = std::max(distance_, 1e-4 * radius_);
  camera_.look_at = target_;
  camera_.position = target_ + distance_ * offset_direction();
}

void CameraController::orbit(double yaw, double pitch) {
  yaw_ += yaw;
  pitch_ += pitch;
  update();
}

double CameraController::viewport_height() const {
  const double half = std::tan(glm::radians(camera_.fov_deg) * 0.5);
  const double tan_half_v = camera_.fov_axis == FovAxis::Vertical ? half : half / aspect_;
  return 2.0 * distance_ * tan_half_v;
}

void CameraController::pan(double dx, double dy) {
  const DVec3 forward = -offset_direction();
  const DVec3 right = glm::normalize(glm::cross(forward, up_));
  const DVec3 cam_up = glm::cross(right, forward);
  const double h = viewport_height();
  target_ += (-dx * right + dy * cam_up) * h;
  update();
}

void CameraController::dolly(double steps) {
  distance_ *= std::pow(0.85, steps);
  update();
}

void CameraController::look(double yaw, double pitch) {
  const DVec3 position = camera_.position;
  // The view direction is −offset: turning it by yaw turns the offset by the same yaw; raising it lowers the
  // offset's elevation.
  yaw_ += yaw;
  pitch_ = std::clamp(pitch_ - pitch, -kMaxPitch, kMaxPitch);
  target_ = position - distance_ * offset_direction();
  update();
}

void CameraController::fly(DVec3 axes, double seconds, double speed_multiplier) {
  const DVec3 forward = -offset_direction();
  const DVec3 right = glm::normalize(glm::cross(forward, up_));
  const DVec3 delta = (axes.x * right + axes.y * up_ + axes.z * forward) * (fly_speed() * speed_multiplier * seconds);
  target_ += delta;
  update();
}

void CameraController::set_pivot_distance(double d) {
  if (!(d > 0.0 && std::isfinite(d))) return;
  target_ = camera_.position - d * offset_direction();
  distance_ = d;
}

void CameraController::set_fov(double fov_deg) { camera_.fov_deg = std::clamp(fov_deg, 1.0, 170.0); }

void CameraController::set_lens(double aperture_radius, double focus_distance) {
  camera_.aperture_radius = std::isfinite(aperture_radius) ? std::max(0.0, aperture_radius) : 0.0;
  camera_.focus_distance = std::isfinite(focus_distance) ? std::max(0.0, focus_distance) : 0.0;
}

void CameraController::set_position(DVec3 position) {
  set_from_offset(position - target_);
  update();
}

void CameraController::set_target(DVec3 target) {
  const DVec3 position = camera_.position;
  target_ = target;
  set_from_offset(position - target_);
  update();
}

}  // namespace pt
