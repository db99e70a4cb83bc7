// The material at a hit, with what its textures say there (integrators/path_tracer.h and bdpt read it alike), and
// the ray cone whose footprint filters the textures.
#pragma once
#include <algorithm>
#include <cmath>
#include <new>
#include <type_traits>

#include "geometry/interaction.h"
#include "materials/bsdf.h"
#include "materials/normal_map.h"
#include "materials/texture.h"
#include "scene/scene.h"

namespace pt {

// The angle one pixel spans (at the image's centre).
inline float pixel_angle_of(const Camera& camera) {
  return 2.f * camera.tan_half_y / static_cast<float>(std::max(camera.height, 1));
}

// The ray cone's spread angle for the pixel's sample number `index`, for pixels spanning `pixel_angle`, kept along
// the whole path (Akenine-Möller et al. 2021 track its change at curved mirrors; a bounce off a rough surface blurs
// far more than any texture level). The jittered samples integrate the pixel's area themselves, so a texture
// filtered over a whole pixel would blur every pixel over two; as pbrt-v4 scales its ray differentials by max(1/8,
// 1/√spp), the cone of sample k spans max(1/8, 1/√(k+1)) of a pixel: the first samples of a progressive render are
// smooth, later ones sharp, and the converged image filters over an eighth of a pixel. Measured on a receding
// checkerboard against its supersampled image (tests/test_textures.cpp): a whole-pixel cone errs by 0.088 rms at 64
// spp, this one by 0.036; at 4 spp far from the camera, unfiltered lookups err by 0.135, these by 0.085.
inline float ray_cone_spread(float pixel_angle, uint32_t index) {
  return pixel_angle * std::max(0.125f, 1.f / std::sqrt(static_cast<float>(index) + 1.f));
}

// Room for a textured material's per-hit copy, left unconstructed unless a texture needs it (a Material is a
// few hundred bytes: constructing one per hit would cost every scene).
union MaterialScratch {
  MaterialScratch() {}
  Material m;
};
static_assert(std::is_trivially_destructible_v<Material>);

// The material at a hit: the scene's, or for a textured one a copy with what its images say there, each
// filtered over the ray cone's footprint (materials/texture.h): where the cone of width w meets the surface at
// cosine c, an ellipse w/c long along the ray's direction projected on the surface and w wide across it
// (Akenine-Möller et al. 2021 take the long axis alone, which blurs grazing views; the anisotropic lookup keeps
// them sharp), mapped into each image's uv by the triangle's uv gradients and the image's uv transform:
// - the albedo: its own (the factor) times the albedo texture;
// - glTF's metallic and roughness: the factors times the metallic–roughness texture's blue and green;
// - the emission: the factor times the emission texture (unfiltered, as lights/light_sampling.h reads it);
// - the shading normal it.ns: bent by the normal map (materials/normal_map.h), which is why `it` is written.
// NormalLookup::Finest reads the normal map at its finest level whatever the cone: bdpt's, whose two walks must
// shade a point with one normal (the light walk has no cone), since every strategy has to evaluate one and the
// same measurement; the pixel's samples still average the bumps over its footprint.
enum class NormalLookup { Cone, Finest };
template <MaterialSet kM>
[[gnu::always_inline]] inline const Material& material_at(const Scene& s, Interaction& it, Vec3 d, float cone_width,
                                                         MaterialScratch& scratch,
                                                         NormalLookup normals = NormalLookup::Cone) {
  const Material& m = s.materials[it.material];
  if constexpr (kM == MaterialSet::Any) {
    if (has_textures(m)) [[unlikely]] {
      const float dn = glm::dot(d, it.ng);
      const float cos = std::max(std::abs(dn), 1e-4f);
      Vec3 along = d - dn * it.ng;  // the ray's direction in the surface
      const float len = glm::length(along);
      along = len > 1e-6f ? along / len : Frame::from_normal(it.ng).s;
      const Vec3 across = glm::cross(it.ng, along);
      const Vec3 major_p = along * (cone_width / cos), minor_p = across * cone_width;
      const auto lookup = [&](const Texture& tex, const glm::mat3& t) {  // t: surface uv → texture uv
        const glm::mat2 linear(t);
        const auto to_uv = [&](Vec3 w) { return linear * Vec2(glm::dot(it.du_dp, w), glm::dot(it.dv_dp, w)); };
        return texture_lookup(tex, Vec2(t * glm::vec3(it.uv, 1.f)), to_uv(major_p), to_uv(minor_p));
      };
      Material& out = *new (&scratch.m) Material(
          m.albedo_texture ? with_albedo(m, m.albedo * lookup(*m.albedo_texture, m.albedo_uv_transform)) : m);
      if (const TextureSlot& mr = m.metallic_roughness_map; mr.texture) {
        const Rgb v = lookup(*mr.texture, mr.uv_transform);
        out.roughness = std::clamp(m.roughness * v.y, 0.f, 1.f);
        out.metallic = std::clamp(m.metallic * v.z, 0.f, 1.f);
        out.alpha = out.roughness * out.roughness;  // all prepare_material derives for this type
      }
      // The emission as the light reads it (emission_texel), where it does: a model's triangles with uv.
      if (const TextureSlot& em = m.emission_map; em.texture && !s.shading.empty() && it.prim < s.sphere_begin())
        out.emission = m.emission * texture_at(*em.texture, em.uv_transform, it.uv);
      if (const TextureSlot& nm = m.normal_map; nm.texture) {
        const Rgb texel = normals == NormalLookup::Cone
                              ? lookup(*nm.texture, nm.uv_transform)
                              : texture_at(*nm.texture, nm.uv_transform, it.uv);
        it.ns = normal_mapped(it.ns, it.ng, it.du_dp, it.dv_dp, it.tangent, texel, m.normal_scale);
      }
      return out;
    }
  }
  return m;
}

}  // namespace pt
