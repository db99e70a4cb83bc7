#include "scene/mtl_material.h"

#include <algorithm>
#include <cmath>

namespace pt {

namespace {

bool black(Rgb c) { return max_component(c) < 1e-4f; }

Rgb clamped(Rgb c) { return glm::clamp(c, Rgb(0.f), Rgb(1.f)); }

// Walter et al. 2007, §5.2: the Beckmann width matching a Phong exponent, α = √(2/(Ns + 2)); roughness = √α.
float roughness_from_exponent(float ns) {
  const float alpha = std::sqrt(2.f / (std::max(ns, 0.f) + 2.f));
  return std::clamp(std::sqrt(alpha), 0.f, 1.f);
}

}  // namespace

MaterialDesc mtl_material(const MtlParams& p, std::vector<std::string>& warnings) {
  MaterialDesc d;
  d.name = p.name.empty() ? "unnamed" : p.name;
  const Rgb kd = clamped(p.kd), ks = clamped(p.ks);
  const float roughness = roughness_from_exponent(p.ns);
  const bool refracts = p.illum == 4 || p.illum == 6 || p.illum == 7 || p.illum == 9;
  if (refracts) {
    d.type = MaterialType::Dielectric;
    d.ior = p.ni >= 1.f && std::isfinite(p.ni) ? p.ni : 1.5f;
    d.roughness = black(ks) ? 0.f : roughness;
  } else if (black(kd) && !black(ks)) {
    d.type = MaterialType::Conductor;
    d.albedo = ks;
    d.roughness = roughness;
  } else if (!black(ks)) {
    d.type = MaterialType::Plastic;
    d.albedo = kd;
    d.ior = 1.5f;
    d.roughness = roughness;
  } else {
    d.type = MaterialType::Diffuse;
    d.albedo = kd;
  }
  d.emission = glm::max(p.ke, Rgb(0.f));
  if (!black(d.emission) && black(kd) && black(ks)) d.two_sided = true;
  for (const std::string& t : p.textures)
    warnings.push_back("material " + d.name + ": " + t + " is not read yet (textures): its colours stand alone");
  if (p.dissolve < 1.f && !refracts) {
    // Partial transparency: the surface is there with probability d (geometry/alpha_mask.h); a map_d image, if
    // any, multiplies it (mesh_obj.cpp).
    auto mask = std::make_shared<AlphaMask>();
    mask->blend = true;
    mask->factor = std::isfinite(p.dissolve) ? std::max(p.dissolve, 0.f) : 1.f;
    d.cutout = std::move(mask);
  }
  return d;
}

}  // namespace pt
