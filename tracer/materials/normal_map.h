// Tangent-space normal maps (glTF 2.0's normalTexture; the convention of MikkTSpace and of the Khronos sample
// viewer): a texel (r, g, b) in [0, 1] is the normal n_t = ((2r − 1)·scale, (2g − 1)·scale, 2b − 1) in the frame
// (t, b, n) where n is the surface's shading normal, t the direction in which u grows along the surface, and b
// = ±(n × t) the direction in which the image's rows go up (v decreases: glTF's v grows downwards, the "green up"
// convention of OpenGL-style maps), its sign taken from the uv mapping itself so that mirrored uv islands keep
// their bumps.
//
// Tangents: a glTF file's TANGENT attribute where the mesh has one (interpolated, made orthogonal to the shading
// normal; bitangent = w·(n × t), the specification's rule); elsewhere from the triangle's own uv gradients (what
// MikkTSpace computes per face, before it averages the faces around a vertex; the Khronos sample viewer's
// screen-space tangents are the same per-face quantity), made orthogonal to the interpolated normal.
#pragma once
#include "core/math.h"

namespace pt {

namespace normal_map_detail {

// The file's frame: t = the tangent made orthogonal to ns, b = w·(ns × t); false where the tangent is zero or
// along ns.
inline bool file_frame(Vec3 ns, Vec4 tangent, Vec3& t, Vec3& b) {
  if (tangent.w == 0.f) return false;
  t = Vec3(tangent) - glm::dot(Vec3(tangent), ns) * ns;
  const float tl = glm::length(t);
  if (!(tl > 1e-12f)) return false;
  t /= tl;
  b = tangent.w * glm::cross(ns, t);
  return true;
}

// The uv mapping's frame: t along dp/du made orthogonal to ns, b = ±(ns × t) pointing where v decreases (the
// image's up); false where the mapping is degenerate (no gradient, or u and v changing along one direction).
inline bool uv_frame(Vec3 ns, Vec3 ng, Vec3 du_dp, Vec3 dv_dp, Vec3& t, Vec3& b) {
  // dp/du lies in the surface, across the gradient of v (moving along it changes u alone); likewise dp/dv.
  Vec3 dp_du = glm::cross(ng, dv_dp), dp_dv = glm::cross(ng, du_dp);
  const float su = glm::dot(dp_du, du_dp), sv = glm::dot(dp_dv, dv_dp);
  if (!(std::abs(su) > 0.f) || !(std::abs(sv) > 0.f)) return false;
  dp_du = su > 0.f ? dp_du : -dp_du;
  dp_dv = sv > 0.f ? dp_dv : -dp_dv;
  t = dp_du - glm::dot(dp_du, ns) * ns;  // Gram–Schmidt against the shading normal
  const float tl = glm::length(t);
  if (!(tl > 1e-12f)) return false;
  t /= tl;
  b = glm::cross(ns, t);
  if (glm::dot(b, dp_dv) > 0.f) b = -b;
  return true;
}

}  // namespace normal_map_detail

// The shading normal ns (unit, on ng's side) bent by the map's texel `texel` (linear, in [0, 1]) in the file's
// tangent frame (`tangent`, Interaction::tangent) or, without one, the frame of the surface's uv gradients du_dp,
// dv_dp (Interaction). Returns ns unchanged where neither frame exists; the result stays on ng's side, at least
// 1° above the surface, since a shading normal below the surface would turn the surface's front around.
inline Vec3 normal_mapped(Vec3 ns, Vec3 ng, Vec3 du_dp, Vec3 dv_dp, Vec4 tangent, Rgb texel, float scale) {
  Vec3 t, b;
  if (!normal_map_detail::file_frame(ns, tangent, t, b) && !normal_map_detail::uv_frame(ns, ng, du_dp, dv_dp, t, b))
    return ns;
  const Vec3 nt((2.f * texel.x - 1.f) * scale, (2.f * texel.y - 1.f) * scale, 2.f * texel.z - 1.f);
  Vec3 n = nt.x * t + nt.y * b + nt.z * ns;
  const float len = glm::length(n);
  if (!(len > 1e-12f)) return ns;
  n /= len;
  constexpr float kMinElevation = 0.0175f;  // sin 1°
  const float e = glm::dot(n, ng);
  if (e < kMinElevation) {
    Vec3 across = n - e * ng;
    const float al = glm::length(across);
    if (!(al > 1e-12f)) return ns;
    n = across * (std::sqrt(1.f - kMinElevation * kMinElevation) / al) + kMinElevation * ng;
  }
  return n;
}

}  // namespace pt
