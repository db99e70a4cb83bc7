// The render-ready material: plain floats the BSDF functions read (bsdf.h). Compiled from a MaterialDesc by
// prepare_material(), which also derives what the BSDFs need at every hit but depends only on the parameters
// (GGX α, energy-compensation tables, the subsurface diffuse albedo), so a live edit of one material recomputes
// only that material.
#pragma once
#include <array>
#include <cstdint>

#include "core/enum_table.h"
#include "core/math.h"

namespace pt {

// Scattering models. The integrator never branches on these: it asks the BSDF for its flags (bsdf.h).
enum class MaterialType { Diffuse, Mirror, Conductor, Dielectric, Plastic, Subsurface, MetallicRoughness };

template <>
struct EnumTable<MaterialType> {
  static constexpr std::array<EnumEntry<MaterialType>, 7> kEntries{{
      {MaterialType::Diffuse, "diffuse", "Diffuse (Lambert)"},
      {MaterialType::Mirror, "mirror", "Mirror (smooth, tinted)"},
      {MaterialType::Conductor, "conductor", "Metal (GGX conductor)"},
      {MaterialType::Dielectric, "dielectric", "Glass (GGX dielectric)"},
      {MaterialType::Plastic, "plastic", "Plastic (diffuse under a coat)"},
      {MaterialType::Subsurface, "subsurface", "Subsurface (Jensen 2001 BRDF)"},
      {MaterialType::MetallicRoughness, "metallic_roughness", "glTF metallic-roughness"},
  }};
};

// Which parameters each material type takes, besides the emission every material may have: the one table the
// scene reader (which refuses the others, naming the type), the writer (which writes only these) and the viewer's
// Materials section (which shows only these) read. Names are the scene file's keys (docs/scene-format.md).
enum class MaterialParam : uint8_t {
  Albedo = 1,     // "albedo": diffuse reflectance, mirror tint, conductor F0, plastic base, subsurface α′
  Ior = 2,        // "ior"
  Roughness = 4,  // "roughness"
  G = 8,          // "g": the subsurface phase function's asymmetry
  Metal = 16,     // "metal", or "eta" and "k": a conductor's measured or given complex index (instead of albedo)
  Metallic = 32,  // "metallic": glTF's blend from the dielectric (0) to the metal (1)
};
constexpr uint8_t operator|(MaterialParam a, MaterialParam b) { return uint8_t(uint8_t(a) | uint8_t(b)); }
constexpr uint8_t operator|(uint8_t a, MaterialParam b) { return uint8_t(a | uint8_t(b)); }
struct MaterialParams {
  MaterialType type;
  uint8_t params;  // MaterialParam bits
};
inline constexpr std::array<MaterialParams, 7> kMaterialParams{{
    {MaterialType::Diffuse, uint8_t(MaterialParam::Albedo)},
    {MaterialType::Mirror, uint8_t(MaterialParam::Albedo)},
    {MaterialType::Conductor, MaterialParam::Albedo | MaterialParam::Metal | MaterialParam::Roughness},
    {MaterialType::Dielectric, MaterialParam::Ior | MaterialParam::Roughness},
    {MaterialType::Plastic, MaterialParam::Albedo | MaterialParam::Ior | MaterialParam::Roughness},
    {MaterialType::Subsurface, MaterialParam::Albedo | MaterialParam::Ior | MaterialParam::G},
    {MaterialType::MetallicRoughness,
     MaterialParam::Albedo | MaterialParam::Ior | MaterialParam::Roughness | MaterialParam::Metallic},
}};
constexpr bool takes(MaterialType type, MaterialParam p) {
  for (const MaterialParams& m : kMaterialParams)
    if (m.type == type) return (m.params & uint8_t(p)) != 0;
  return false;
}

// Named conductors: RGB complex index of refraction η + ik (materials/conductor_presets.h has the values).
enum class MetalPreset { None, Gold, Silver, Copper, Aluminium };

template <>
struct EnumTable<MetalPreset> {
  static constexpr std::array<EnumEntry<MetalPreset>, 5> kEntries{{
      {MetalPreset::None, "none", "(albedo)"},
      {MetalPreset::Gold, "gold", "Gold"},
      {MetalPreset::Silver, "silver", "Silver"},
      {MetalPreset::Copper, "copper", "Copper"},
      {MetalPreset::Aluminium, "aluminium", "Aluminium"},
  }};
};

// Directional albedo E(μ) of one microfacet lobe, tabulated over μ = cos θ ∈ [0, 1] at kSize evenly spaced points
// (linear interpolation), and its cosine-weighted average E_avg = 2∫E(μ)μ dμ. Used for multiple-scattering
// energy compensation (Kulla & Conty 2017) and for the plastic coat's transmitted energy.
struct EnergyTable {
  static constexpr int kSize = 32;
  std::array<float, kSize> e{};
  float e_avg = 1.f;
  float operator()(float mu) const {
    const float x = std::clamp(mu, 0.f, 1.f) * (kSize - 1);
    const int i = std::min(static_cast<int>(x), kSize - 2);
    const float t = x - static_cast<float>(i);
    return e[i] + t * (e[i + 1] - e[i]);
  }
};

struct Texture;

// A data image a material reads at each hit (a glTF file's metallic–roughness or normal texture): the image,
// owned by the scene (Scene::textures keeps it alive), and the map from surface uv to its uv.
struct TextureSlot {
  const Texture* texture = nullptr;
  glm::mat3 uv_transform{1.f};
};

struct Material {
  MaterialType type = MaterialType::Diffuse;
  Rgb albedo{0.8f};      // diffuse reflectance; mirror tint; conductor F0; plastic base; subsurface α′; glTF base
  Rgb emission{0.f};     // emitted radiance
  bool two_sided = false;  // emission from both faces
  float roughness = 0.f; // [0, 1]; GGX α = roughness²; 0 = smooth (delta)
  float ior = 1.5f;      // dielectric / plastic coat / subsurface medium index (outside is 1)
  float g = 0.f;         // subsurface Henyey–Greenstein asymmetry in (−1, 1)
  float metallic = 0.f;  // glTF metallic–roughness: [0, 1], the dielectric (0) to metal (1) blend
  MetalPreset metal = MetalPreset::None;
  bool complex_ior = false;  // conductor: Fresnel from eta/k instead of the Schlick curve through albedo
  Rgb eta{1.f}, k{0.f};      // conductor complex index (from the preset or the file)
  // The albedo's image (materials/texture.h), or null; owned by the scene (Scene::textures keeps it alive).
  const Texture* albedo_texture = nullptr;
  glm::mat3 albedo_uv_transform{1.f};  // surface uv → texture uv (MaterialDesc::albedo_uv_transform)
  // metallic_roughness: glTF's metallicRoughnessTexture, linear: roughness × its green, metallic × its blue.
  TextureSlot metallic_roughness_map;
  // A tangent-space normal map (glTF's normalTexture, materials/normal_map.h) and its scale of x and y.
  TextureSlot normal_map;
  float normal_scale = 1.f;
  // glTF's emissiveTexture (sRGB colour): the emission is `emission` (the factor) times it. Read where a ray
  // hits the surface and where a light sample lands on it (lights/light_sampling.h: textured_emission).
  TextureSlot emission_map;

  // Derived by prepare_material():
  float alpha = 0.f;     // GGX α = roughness² (roughness clamped to [0, 1]); α < kSmoothAlpha = 1e-3 is smooth
  EnergyTable energy;    // conductor: E(μ) of the GGX lobe with F = 1; plastic: E(μ) of the coat's reflection
  Rgb f_avg{1.f};        // conductor: cosine-averaged Fresnel reflectance (Kulla–Conty colour term)
  Rgb rd{0.f};           // subsurface: multiple-scattering diffuse reflectance R_d per channel (Jensen 2001)
  Rgb ss_norm{1.f};      // subsurface: per-channel scale ≤ 1 keeping the directional albedo ≤ 1 (subsurface.h)
};

// Fills the derived fields from the parameters. Call after any parameter change.
void prepare_material(Material& m);

// A textured material at one hit: `m` with the albedo `albedo` (the texture's value there) and what
// prepare_material derives from the albedo (a conductor's Schlick F_avg) redone. Materials whose derived
// tables depend on the albedo beyond that (subsurface) take no texture (validate_material).
Material with_albedo(const Material& m, Rgb albedo);

// Whether the material reads any image at a hit (the path loop then makes its per-hit copy: material_at).
inline bool has_textures(const Material& m) {
  return m.albedo_texture || m.metallic_roughness_map.texture || m.normal_map.texture || m.emission_map.texture;
}

}  // namespace pt
