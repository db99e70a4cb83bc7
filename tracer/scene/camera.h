// Pinhole camera. Image right = normalize(forward × up); pixel (0,0) is the top-left corner; a pixel's value is
// the mean radiance over its square (box filter one pixel wide), sampled by jittering uniformly inside it.
#pragma once
#include "core/ray.h"
#include "sampling/sampling.h"
#include "scene/scene_desc.h"

namespace pt {

struct Camera {
  Vec3 forward{0, 0, 1}, right{-1, 0, 0}, up{0, 1, 0};  // orthonormal, world orientation
  float tan_half_x = 1, tan_half_y = 1;                  // half extents of the image plane at distance 1
  int width = 1, height = 1;
  // The eye in the scene's (camera-relative) coordinates: 0 as compiled; a camera moved in place
  // (update_scene_appearance) keeps the geometry where it was and starts its rays here.
  Vec3 origin{0.f};
  // Thin lens (pbrt-v4 §5.2.3): a lens of this radius centred on the eye, perpendicular to `forward`, focused on
  // the plane at focus_distance along `forward`. 0: a pinhole (generate_ray ignores the lens sample).
  float lens_radius = 0.f, focus_distance = 1.f;
  bool thin_lens() const { return lens_radius > 0.f; }

  // A camera at the (camera-relative) origin; fov in degrees along the given axis.
  static Camera make(DVec3 forward, DVec3 up, double fov_deg, bool fov_horizontal, int width, int height);

  // Ray through image point (x, y) in pixel units, (0,0) = top-left corner of the image. With a thin lens,
  // `u_lens` picks the point on the lens (concentric disk mapping) and the ray passes through the point of the
  // focus plane that the pinhole ray through (x, y) meets, so that plane stays sharp.
  Ray generate_ray(float x, float y, Vec2 u_lens = Vec2(0.5f)) const {
    const float sx = (2.f * x / static_cast<float>(width) - 1.f) * tan_half_x;
    const float sy = (1.f - 2.f * y / static_cast<float>(height)) * tan_half_y;
    const Vec3 d = glm::normalize(forward + sx * right + sy * up);
    if (!thin_lens()) return {origin, d};
    const Vec3 focus = origin + d * (focus_distance / glm::dot(d, forward));
    const Vec3 o = lens_point(u_lens);
    return {o, glm::normalize(focus - o)};
  }
  // The point of the lens that `u` picks (concentric disk mapping, uniform over the lens's area); the eye for a
  // pinhole.
  Vec3 lens_point(Vec2 u) const {
    if (!thin_lens()) return origin;
    const Vec2 lens = lens_radius * sample_uniform_disk_concentric(u);
    return origin + lens.x * right + lens.y * up;
  }

  // Importance (light tracing, integrators/bdpt.h). The image plane at distance 1 has area A = 4·tan_x·tan_y;
  // camera rays are uniform over it, so their density per solid angle is 1/(A·cos³θ) and the importance
  // that makes a pixel the mean radiance over its square is We = 1/(A·cos⁴θ) (pbrt-v3 §16.1.1, the pinhole
  // with lens area 1), normalised over the whole film: a light-traced path adds to pixel j with We, and one
  // light path per pixel and pass makes the sum over the pass an estimate of every pixel.
  // With a thin lens (pbrt-v4 PerspectiveCamera::We, PDF_We, SampleWi) the ray from lens point p in direction w
  // meets the focus plane at a point uniform over the image of the film there (area A·f², f the focus
  // distance, at distance f/cos θ from p), so its density per solid angle is again 1/(A·cos³θ), θ the angle of
  // w to the axis; We = 1/(A·A_lens·cos⁴θ), and a connection that picks the lens point uniformly (density
  // 1/A_lens per area, dist²/(cos θ·A_lens) per solid angle) carries We·cos θ/pdf = 1/(A·cos³θ·dist²): the
  // pinhole's, the lens area cancels.
  float image_plane_area() const { return 4.f * tan_half_x * tan_half_y; }
  // The image point (pixel units) a unit direction from the eye passes through; false when it misses the film.
  bool raster_of(Vec3 w, float& x, float& y) const {
    const float c = glm::dot(w, forward);
    if (!(c > 0.f)) return false;
    const float sx = glm::dot(w, right) / (c * tan_half_x), sy = glm::dot(w, up) / (c * tan_half_y);
    x = 0.5f * (sx + 1.f) * static_cast<float>(width);
    y = 0.5f * (1.f - sy) * static_cast<float>(height);
    return x >= 0.f && x < static_cast<float>(width) && y >= 0.f && y < static_cast<float>(height);
  }
  // The image point of the ray from lens point p along unit direction w: through the point where it meets the
  // focus plane (with a thin lens), or w itself (a pinhole, p the eye).
  bool raster_of(Vec3 p, Vec3 w, float& x, float& y) const {
    if (!thin_lens()) return raster_of(w, x, y);
    const float c = glm::dot(w, forward);
    if (!(c > 0.f)) return false;
    const Vec3 to_focus = p + w * (focus_distance / c) - origin;
    return raster_of(glm::normalize(to_focus), x, y);
  }
  // Density per solid angle with which generate_ray (with a uniform jitter over the film) produces direction w
  // from lens point p (the eye, for a pinhole).
  float direction_pdf(Vec3 p, Vec3 w) const {
    float x, y;
    if (!raster_of(p, w, x, y)) return 0.f;
    const float c = glm::dot(w, forward);
    return 1.f / (image_plane_area() * c * c * c);
  }
  // We(w)·cos θ / (the lens point's density per area): what a connection to a uniformly chosen lens point
  // carries, over dist² (above).
  float importance_cos(Vec3 w) const {
    const float c = glm::dot(w, forward);
    return c > 0.f ? 1.f / (image_plane_area() * c * c * c) : 0.f;
  }
};

// The camera of a scene description at the given film size (its eye at the origin).
Camera compile_camera(const CameraDesc& desc, int width, int height);

}  // namespace pt
