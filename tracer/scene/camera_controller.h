// Interactive camera maths, GL- and window-free so tests can drive it: orbit around a target, pan, dolly,
// first-person look and fly. The controller edits a CameraDesc (the authoring model), so what the viewer shows is
// exactly what a saved scene file reproduces.
//
// State: a target point, a distance, and the direction from the target to the camera as yaw (about the scene
// camera's `up`, right-handed) and pitch (elevation above the plane perpendicular to `up`). Pitch stays inside
// ±kMaxPitch so the view never becomes parallel to `up` (which would make the image basis undefined).
#pragma once
#include "scene/scene_desc.h"

namespace pt {

struct SceneBounds {
  DVec3 center{0.0};
  double radius = 1.0;  // half the diagonal of the axis-aligned box of all shapes
};
SceneBounds scene_bounds(const SceneDesc& scene);

class CameraController {
 public:
  static constexpr double kMaxPitch = 1.5533430342749532;  // 89°

  // Starts from a scene camera; camera() returns it unchanged until an operation moves it. `scene_radius` sets
  // the fly speed and the closest dolly distance (nothing here uses absolute lengths); aspect = width / height.
  void reset(const CameraDesc& camera, double scene_radius, double aspect);
  const CameraDesc& camera() const { return camera_; }

  // Rotates the camera around the target: yaw about `up` (right-handed, radians), pitch raises the camera.
  void orbit(double yaw, double pitch);
  // Moves camera and target in the image plane by (dx, dy) viewport heights, x right and y down on screen, so
  // the scene point at the target's depth follows the cursor ("grab" the scene).
  void pan(double dx, double dy);
  // Moves towards the target (steps > 0) or away: distance × 0.85^steps, never closer than 1e-4 scene radii.
  void dolly(double steps);
  // Turns the view about the camera position: yaw left (right-handed about `up`), pitch up; the target moves.
  void look(double yaw, double pitch);
  // Moves camera and target together: axes.x right, axes.y along `up`, axes.z forward, each in [-1, 1].
  void fly(DVec3 axes, double seconds, double speed_multiplier = 1.0);

  void set_fov(double fov_deg);
  // The thin lens (CameraDesc::aperture_radius, focus_distance; 0 focuses on the target); negatives become 0.
  void set_lens(double aperture_radius, double focus_distance);
  void set_position(DVec3 position);  // keeps the target
  void set_target(DVec3 target);      // keeps the position
  void set_aspect(double aspect) { aspect_ = aspect; }
  // Moves the orbit pivot (the target) along the current view ray to distance d from the camera; the view does
  // not change (camera() stays as it is until the next move). Ignored unless d is finite and > 0.
  void set_pivot_distance(double d);

  DVec3 target() const { return target_; }
  double distance() const { return distance_; }
  double fly_speed() const { return 0.5 * radius_; }  // scene units per second: crossing the scene takes ~4 s
  // Height of the viewport at the target's distance, in scene units.
  double viewport_height() const;

 private:
  DVec3 offset_direction() const;  // unit vector from the target to the camera
  void set_from_offset(DVec3 offset);
  void update();

  CameraDesc camera_;
  DVec3 target_{0.0}, up_{0, 1, 0}, e1_{1, 0, 0}, e2_{0, 0, -1};  // e1, e2 ⟂ up, e2 = up × e1
  double yaw_ = 0.0, pitch_ = 0.0, distance_ = 1.0;
  double radius_ = 1.0, aspect_ = 1.0;
};

}  // namespace pt
