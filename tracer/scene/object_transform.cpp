#include "scene/object_transform.h"

#include <cmath>
#include <utility>

#include "scene/scene_desc.h"

namespace pt {
namespace {

bool finite(DVec3 v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

// Rodrigues' rotation of p about the unit axis k by θ: R p = cos θ p + sin θ (k × p) + (1 − cos θ)(k · p) k.
DVec3 rotate(DVec3 p, DVec3 k, double theta) {
  const double c = std::cos(theta), s = std::sin(theta);
  return c * p + s * glm::cross(k, p) + (1.0 - c) * glm::dot(k, p) * k;
}

}  // namespace

std::string transform_error(const ObjectTransform& t) {
  if (!finite(t.scale) || t.scale.x == 0.0 || t.scale.y == 0.0 || t.scale.z == 0.0)
    return "the scale must be finite and not 0 (0 flattens the object)";
  if (!finite(t.axis) || !(glm::length(t.axis) > 0.0)) return "the rotation axis must be finite and not the zero vector";
  if (!std::isfinite(t.degrees)) return "the rotation angle must be finite";
  if (!finite(t.translate)) return "the translation must be finite";
  return "";
}

DVec3 to_world(const ObjectTransform& t, DVec3 p) {
  return rotate(p * t.scale, glm::normalize(t.axis), glm::radians(t.degrees)) + t.translate;
}

glm::dmat4 world_matrix(const ObjectTransform& t) {
  glm::dmat4 m(1.0);
  for (int c = 0; c < 3; ++c) {
    DVec3 e(0.0);
    e[c] = 1.0;
    m[c] = glm::dvec4(to_world(t, e) - t.translate, 0.0);
  }
  m[3] = glm::dvec4(t.translate, 1.0);
  return m;
}

DVec3 to_object(const ObjectTransform& t, DVec3 p) {
  return rotate(p - t.translate, glm::normalize(t.axis), -glm::radians(t.degrees)) / t.scale;
}

DVec3 normal_to_world(const ObjectTransform& t, DVec3 n) {
  return rotate(n / t.scale, glm::normalize(t.axis), glm::radians(t.degrees));
}

bool mirrors(const ObjectTransform& t) { return (t.scale.x < 0.0) != ((t.scale.y < 0.0) != (t.scale.z < 0.0)); }

bool transform_shape(ShapeDesc& shape, const ObjectTransform& t, bool world) {
  const auto map = [&](DVec3 p) { return world ? to_world(t, p) : to_object(t, p); };
  if (shape.type == ShapeType::Sphere) {
    const DVec3 a = glm::abs(t.scale);
    if (a.x != a.y || a.y != a.z) return false;
    shape.center = map(shape.center);
    shape.radius = world ? shape.radius * a.x : shape.radius / a.x;
    return true;
  }
  const int n = shape.type == ShapeType::Triangle ? 3 : 4;
  for (int k = 0; k < n; ++k) shape.vertices[k] = map(shape.vertices[k]);
  if (mirrors(t)) std::swap(shape.vertices[1], shape.vertices[n - 1]);  // (a, b, c[, d]) → (a, c|d, …, b)
  return true;
}

}  // namespace pt
