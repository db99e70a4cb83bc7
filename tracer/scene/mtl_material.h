// Wavefront .mtl materials mapped to the project's nearest material (docs/scene-format.md, "OBJ materials"):
// what an OBJ model brings when the scene names no material for it. The .mtl model is Phong's (Kd diffuse, Ks
// and Ns a specular lobe, Ni an index, illum a lighting model); the mapping keeps what the project's materials
// can show:
// - illum 4, 6, 7 or 9 (transparency by refraction) → dielectric, index Ni (1.5 when Ni is below 1);
// - a black Kd with a non-black Ks → conductor with F0 = Ks;
// - a non-black Ks → plastic: base Kd under a dielectric coat of index 1.5 (the coat's tint is not Ks's);
// - otherwise diffuse with albedo Kd;
// - roughness from the Phong exponent by Walter et al. 2007 ("Microfacet Models for Refraction through Rough
//   Surfaces", §5.2: Beckmann α = √(2/(Ns + 2))), roughness = √α since the project's α = roughness²;
// - emission Ke, on both faces when the material is otherwise black (an .mtl lamp has no front).
// - dissolve d < 1 (without refraction): partial transparency, the surface there with probability d
//   (geometry/alpha_mask.h: stochastic transparency).
// map_Kd, the albedo's image (times Kd, as the format defines it), norm, a tangent-space normal map
// (materials/normal_map.h), and map_d, a cut-out mask (geometry/alpha_mask.h; with d < 1, the image times d
// gives the probability), are the mesh reader's to load (mesh_obj.h); the other textures (map_Ks, bump, …) are
// not read yet: each is one warning line, and the surface keeps its colours.
#pragma once
#include <string>
#include <vector>

#include "scene/scene_desc.h"

namespace pt {

// The parts of an .mtl material the mapping reads (tinyobjloader's material_t carries them).
struct MtlParams {
  std::string name;
  Rgb kd{0.8f}, ks{0.f}, ke{0.f};
  float ns = 0.f, ni = 1.f, dissolve = 1.f;
  int illum = 2;
  std::vector<std::string> textures;  // the texture statements it has that are not read (map_Ks, bump, …), by keyword
};

// The nearest project material; appends to `warnings` what it leaves out.
MaterialDesc mtl_material(const MtlParams& m, std::vector<std::string>& warnings);

}  // namespace pt
