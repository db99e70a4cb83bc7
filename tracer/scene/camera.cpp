#include "scene/camera.h"

namespace pt {

Camera Camera::make(DVec3 forward, DVec3 up, double fov_deg, bool fov_horizontal, int width, int height) {
  Camera c;
  const DVec3 f = glm::normalize(forward);
  const DVec3 r = glm::normalize(glm::cross(f, up));
  const DVec3 u = glm::cross(r, f);
  c.forward = Vec3(f);
  c.right = Vec3(r);
  c.up = Vec3(u);
  c.width = width;
  c.height = height;
  const double half = std::tan(glm::radians(fov_deg) * 0.5);
  const double aspect = static_cast<double>(width) / height;
  c.tan_half_x = static_cast<float>(fov_horizontal ? half : half * aspect);
  c.tan_half_y = static_cast<float>(fov_horizontal ? half / aspect : half);
  return c;
}

Camera compile_camera(const CameraDesc& d, int width, int height) {
  Camera c = Camera::make(d.look_at - d.position, d.up, d.fov_deg, d.fov_axis == FovAxis::Horizontal, width, height);
  c.lens_radius = static_cast<float>(d.aperture_radius);
  c.focus_distance = static_cast<float>(d.focus());
  return c;
}

}  // namespace pt
