// A vertex of a bidirectional subpath and the densities the MIS weights are made of (Veach 1997, ch. 10;
// pbrt-v3 §16.3, "Vertex"). Both subpaths store, per vertex, the density with which their own walk produced it
// (pdf_fwd) and the density with which a walk in the other direction would have (pdf_rev), both per unit area
// at the vertex (per unit solid angle at a vertex at infinity). The MIS weight of a strategy is then a product
// of ratios pdf_rev/pdf_fwd along the path (bdpt_kernels.h, mis_weight).
//
// Orientation: the BSDF is always evaluated for the physical flow of light, f(eye side, light side)
// (materials/bsdf.h takes (wo, wi) with light arriving from wi), whichever subpath the vertex is on.
#pragma once
#include "geometry/interaction.h"
#include "lights/light_emission.h"
#include "lights/light_sampling.h"
#include "materials/bsdf.h"

namespace pt {

enum class VertexKind : uint8_t { Camera, Light, Surface };

struct BdptVertex {
  VertexKind kind = VertexKind::Surface;
  bool delta = false;     // the direction sampled here was specular: no connection may end here
  bool infinite = false;  // a light vertex at infinity: only its direction (it.ng) means anything
  // A point, spot or directional light's vertex: a Dirac in position or direction, which no ray hits, so no
  // strategy ends a camera path there (s = 0); a point or spot light has no surface (no cosine at it).
  bool delta_light = false;
  int32_t light = -1;     // light index of a Light vertex or an emitting surface (Scene::light_of_prim), else −1
  // Position, rounding bound, normal, primitive and material. Area light vertices: the emitting side's normal.
  // Vertices at infinity: it.ng is the direction light travels, into the scene. The camera: p is the eye, or the
  // point of a thin lens the subpath left from (or light tracing joined).
  Interaction it{};
  // A surface vertex's material as its textures make it there (material_at.h), held by BdptScratch; null for
  // the camera, lights, and vertices made before their material was looked up (then Scene::materials's).
  const Material* material = nullptr;
  Vec3 wo{0.f};           // unit direction towards the previous vertex of its own subpath
  Rgb beta{1.f};          // the subpath's throughput up to and including this vertex's arrival
  float pdf_fwd = 0.f, pdf_rev = 0.f;
  // The MIS weights' sum over the strategies that split the subpath at this vertex or nearer its start, relative
  // to the strategy that splits it just after this vertex (bdpt_kernels.h, mis_prefix_sums).
  double mis_prefix = 0.0;

  bool on_surface() const {
    return kind == VertexKind::Surface || (kind == VertexKind::Light && !infinite && !delta_light);
  }
  bool emits() const { return kind == VertexKind::Light || light >= 0; }
};

namespace bdpt_detail {

inline const Material& material_of(const Scene& s, const BdptVertex& v) {
  return v.material ? *v.material : s.materials[v.it.material];
}

// Unit direction from vertex a towards vertex b and their squared distance (infinite towards a vertex at
// infinity).
struct Link {
  Vec3 w;
  float dist2;
};
inline Link link(const BdptVertex& a, const BdptVertex& b) {
  if (b.infinite) return {-b.it.ng, kInfinity};
  if (a.infinite) return {a.it.ng, kInfinity};
  const Vec3 d = b.it.p - a.it.p;
  const float d2 = glm::dot(d, d);
  return {d2 > 0.f ? d / std::sqrt(d2) : Vec3(0.f), d2};
}

// The geometry term |cos θ_a| |cos θ_b| / d² of the segment between a and b (a cosine only at a vertex on a
// surface; towards a vertex at infinity no distance: densities there are per solid angle).
inline float geometry_term(const BdptVertex& a, const BdptVertex& b) {
  const Link l = link(a, b);
  const float cos_a = a.on_surface() ? std::abs(glm::dot(a.it.ng, l.w)) : 1.f;
  const float cos_b = b.on_surface() ? std::abs(glm::dot(b.it.ng, l.w)) : 1.f;
  if (a.infinite || b.infinite) return cos_a * cos_b;
  return l.dist2 > 0.f ? cos_a * cos_b / l.dist2 : 0.f;
}

// link(b, a) from link(a, b): the same numbers negated (b − a is a − b negated exactly, and so is its quotient).
inline Link reversed(const Link& l) { return {-l.w, l.dist2}; }

// A solid-angle density at `from` towards `to` as a density per unit area at `to` (pbrt-v3 ConvertDensity);
// `l` is link(from, to).
inline float to_area_density(float pdf, const Link& l, const BdptVertex& from, const BdptVertex& to) {
  if (to.infinite || from.infinite) return pdf;
  if (!(l.dist2 > 0.f)) return 0.f;
  if (to.on_surface()) pdf *= std::abs(glm::dot(to.it.ng, l.w));
  return pdf / l.dist2;
}
inline float to_area_density(float pdf, const BdptVertex& from, const BdptVertex& to) {
  return to_area_density(pdf, link(from, to), from, to);
}

// Smooth shading (vertex normals, geometry/interaction.h). A vertex is shaded as the path tracer shades it: in
// the frame of shading_normal(it, w_eye), the normal bent for the direction towards the eye's side of the path
// (so the measurement is the same function whichever subpath made the vertex), with the shading cosine. Written
// with the geometric cosines of the geometry terms (G, area densities), that is the BSDF
//   f_sn(w_eye, w_light) = f(w_eye, w_light) · |w_light·n_s| / |w_light·n_g|,
// which is not symmetric: the light subpath, whose walk samples w_eye from w_light, carries its adjoint
// (Veach 1997, §5.3; pbrt-v3's CorrectShadingNormal). Flat vertices (ns = ng) take the plain frame and cosines,
// bit for bit the arithmetic of flat scenes.
inline bool smooth_vertex(const BdptVertex& v) { return v.it.ns != v.it.ng; }
// The frame a walk samples in at `it`, having arrived from direction `from` (the path tracer's frame for
// wo = from).
inline Frame shading_frame(const Interaction& it, Vec3 from) {
  return Frame::from_normal(it.ns != it.ng ? shading_normal(it, from) : it.ng);
}
inline Frame walk_frame(const BdptVertex& v, Vec3 from) { return shading_frame(v.it, from); }
// The origin of a ray leaving `it` along w (local_z: w's z in the shading frame), as the path tracer leaves a
// vertex: a smooth one on the side its shading frame sampled, a flat one on the side w points to.
inline Vec3 leaving_origin(const Interaction& it, Vec3 w, float local_z) {
  return it.ns != it.ng ? offset_ray_origin(it, local_z < 0.f) : offset_ray_origin(it, w);
}

// The light walk's defensive sampling at a smooth vertex. The measurement shades it in the frame bent for the eye's
// direction w_eye, which the light walk, sampling w_eye, cannot know: it samples in the frame bent for the
// light's direction. Where a map tilts the normal far from the surface's the two frames differ, and some w_eye
// the measurement lights lie below the sampling frame's horizon, which the light walk then never draws: light
// tracing alone missed them (a 30° normal map: (3, 1) off (1, 3) by |z| 7.8) and the MIS weights, which take its
// density as the strategy's, no longer summed to one over the strategies that make a path (the whole estimator
// off mis by |z| 5.8). So at a smooth vertex whose material has a non-specular lobe the light walk draws a
// direction uniform over the sphere with probability kLightWalkUniform instead (Hesterberg's defensive mixture,
// 1995; Owen and Zhou 2000): its density (light_walk_pdf) is positive wherever the measurement is. Flat vertices
// keep the BSDF's own sampling, bit for bit; the camera walk samples in the measurement's own frame and needs none.
inline constexpr float kLightWalkUniform = 0.1f;
inline bool light_walk_mixes(const BdptVertex& v, const Material& m) {
  return smooth_vertex(v) && has_non_specular(bsdf_flags(m));
}
// The light walk's density at such a vertex of a direction the BSDF's sampling gives density `bsdf_pdf`.
inline float light_walk_pdf(float bsdf_pdf) {
  return (1.f - kLightWalkUniform) * bsdf_pdf + kLightWalkUniform * kInv4Pi;
}

// BSDF value at surface vertex v towards `next`, for light flowing along the path. v on the camera subpath:
// light arrives from `next`, leaves towards v.wo; on the light subpath the other way round. At a smooth vertex
// f_sn above.
inline Rgb vertex_f(const Scene& s, const BdptVertex& v, const BdptVertex& next, bool light_subpath) {
  const Vec3 w = link(v, next).w;
  const Material& m = material_of(s, v);
  if (smooth_vertex(v)) {
    const Vec3 w_eye = light_subpath ? w : v.wo, w_light = light_subpath ? v.wo : w;
    const Frame frame = walk_frame(v, w_eye);
    const float cos_g = std::abs(glm::dot(w_light, v.it.ng));
    if (!(cos_g > 0.f)) return Rgb(0.f);
    return bsdf_eval(m, frame.to_local(w_eye), frame.to_local(w_light)) *
           (std::abs(glm::dot(w_light, frame.n)) / cos_g);
  }
  const Frame frame = Frame::from_normal(v.it.ng);
  const Vec3 a = frame.to_local(v.wo), b = frame.to_local(w);
  return light_subpath ? bsdf_eval(m, b, a) : bsdf_eval(m, a, b);
}

// A connection may end at v: a non-specular lobe to evaluate, or a light or the camera.
inline bool connectible(const Scene& s, const BdptVertex& v) {
  if (v.kind != VertexKind::Surface) return !v.infinite;
  return has_non_specular(bsdf_flags(material_of(s, v)));
}

// Density per unit area at `to` with which light vertex v (or an emitting surface) emits towards it; `l` is
// link(v, to).
inline float pdf_light(const Scene& s, const BdptVertex& v, const Link& l, const BdptVertex& to) {
  if (v.infinite) {
    float pdf = infinite_emission_pdf_pos(s, v.it.ng, to.it.p);
    if (to.on_surface()) pdf *= std::abs(glm::dot(to.it.ng, v.it.ng));
    return pdf;
  }
  if (!(l.dist2 > 0.f)) return 0.f;
  const Light& light = s.lights[v.light];
  float pdf = (v.delta_light ? punctual_emission_pdf_dir(light, l.w) : area_emission_pdf_dir(light, v.it.ng, l.w)) /
              l.dist2;
  if (to.on_surface()) pdf *= std::abs(glm::dot(to.it.ng, l.w));
  return pdf;
}

// Density with which a light subpath starts at light vertex v (an emitting surface, or at infinity; pbrt-v3
// PdfLightOrigin). Per unit area; per solid angle at infinity; a punctual light's Dirac counts its choice alone.
inline float pdf_light_origin(const Scene& s, const BdptVertex& v) {
  if (v.delta_light) return s.light_pmf[v.light];
  if (v.infinite) return infinite_lights_origin_pdf(s, -v.it.ng);
  return s.light_pmf[v.light] / s.lights[v.light].area;
}

// Radiance emitted by v towards its previous vertex (s = 0: the camera subpath found a light).
inline Rgb emitted(const Scene& s, const BdptVertex& v) {
  if (v.infinite) {
    Rgb Le(0.f);
    for (const uint32_t li : s.infinite_lights) Le += infinite_light_Le(s, s.lights[li], -v.it.ng);
    return Le;
  }
  const Light& light = s.lights[v.light];
  Rgb Le = area_light_emission(light, v.it.ng, v.wo);
  // An emission texture as the path tracer reads it where a ray hits the light (path_tracer.h).
  if (light.emission_map.texture) [[unlikely]] Le *= emission_texel(light, v.it.uv);
  return Le;
}

// Density per unit area at `next` with which vertex v samples it, v having been reached from `prev` (pbrt-v3
// Vertex::Pdf), by the light walk (`light_walk`: prev is on the light's side) or the camera walk. The links from v
// are passed in (mis_weight computes each once): to_next = link(v, next), to_prev = link(v, prev), unused (and may
// be null) for the camera and for lights.
inline float pdf_at(const Scene& s, const BdptVertex& v, const Link* to_prev, const Link& to_next,
                    const BdptVertex& next, bool light_walk) {
  if (v.kind == VertexKind::Light) return pdf_light(s, v, to_next, next);
  float pdf;
  if (v.kind == VertexKind::Camera) {
    pdf = s.camera.direction_pdf(v.it.p, to_next.w);
  } else {
    const Frame frame = walk_frame(v, to_prev->w);
    const Material& m = material_of(s, v);
    pdf = bsdf_pdf(m, frame.to_local(to_prev->w), frame.to_local(to_next.w));
    if (light_walk && light_walk_mixes(v, m)) pdf = light_walk_pdf(pdf);
  }
  return to_area_density(pdf, to_next, v, next);
}

}  // namespace bdpt_detail
}  // namespace pt
