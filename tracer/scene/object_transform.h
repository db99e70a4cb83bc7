// Where an object's shapes sit in the world: its own coordinates (an OBJ file's, a group's shapes as the scene
// file writes them) scaled per axis, then rotated about an axis through the origin, then translated. This is the
// scene file's "transform" of a mesh or a group (docs/scene-format.md) and what the viewer's object panel edits.
#pragma once
#include <string>

#include "core/math.h"

namespace pt {

struct ShapeDesc;

struct ObjectTransform {
  DVec3 scale{1.0};               // per axis, no zero; a negative one mirrors
  DVec3 axis{0.0, 1.0, 0.0};      // rotation axis, any length but 0
  double degrees = 0.0;           // rotation angle, counter-clockwise looking down the axis
  DVec3 translate{0.0};

  bool operator==(const ObjectTransform&) const = default;
};

// Why the transform cannot be used ("" when it can): a zero or non-finite scale, a zero axis, a non-finite angle
// or translation.
std::string transform_error(const ObjectTransform& t);
// The object's point p in the world, and back.
DVec3 to_world(const ObjectTransform& t, DVec3 p);
DVec3 to_object(const ObjectTransform& t, DVec3 p);
// to_world as a matrix (the affine map p ↦ M·(p, 1)).
glm::dmat4 world_matrix(const ObjectTransform& t);
// A normal of the object's surface, mapped into the world: by the inverse transpose of the linear part
// (rotation · scale⁻¹), so that it stays perpendicular to the mapped surface. Not normalised.
DVec3 normal_to_world(const ObjectTransform& t, DVec3 n);
// True when the transform reverses orientation (an odd number of negative scale factors): polygons then list their
// vertices in the other order, so that a face keeps its front (one-sided emitters, a glass mesh's inside).
bool mirrors(const ObjectTransform& t);
// Maps a shape given in the object's coordinates into the world (world = true) or back. A sphere stays a sphere
// only under a scale of equal magnitude on every axis: otherwise the shape is left alone and false returned.
bool transform_shape(ShapeDesc& shape, const ObjectTransform& t, bool world);

}  // namespace pt
