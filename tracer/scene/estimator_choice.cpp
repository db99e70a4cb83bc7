#include "scene/estimator_choice.h"

#include <algorithm>
#include <vector>

#include "scene/scene.h"

namespace pt {

// A Dirac or narrow glossy lobe that sends light on: a mirror, clear or lightly frosted glass, polished metal.
bool focuses_light(MaterialType type, float roughness, float metallic) {
  switch (type) {
    case MaterialType::Mirror: return true;
    case MaterialType::Dielectric:
    case MaterialType::Conductor: return roughness < kFocusingRoughness;
    case MaterialType::MetallicRoughness: return metallic >= 0.5f && roughness < kFocusingRoughness;
    default: return false;
  }
}

// A diffuse lobe that reflects something shows light arriving from anywhere: where a caustic becomes visible
// (a black lamp, albedo 0, shows none).
bool receives_diffusely(MaterialType type, Rgb albedo, float metallic) {
  const bool diffuse = type == MaterialType::Diffuse || type == MaterialType::Plastic ||
                       type == MaterialType::Subsurface || (type == MaterialType::MetallicRoughness && metallic < 1.f);
  return diffuse && max_component(albedo) > 0.f;
}

namespace {

// The rule over a scene's materials (descriptions or compiled ones: both have type, roughness and albedo), those
// no shape uses left out: the first that focuses light (its index, or −1), and whether any receives it.
struct Scan {
  int focusing = -1;
  bool receiver = false;
};
template <class Materials, class Used>
Scan scan_materials(const Materials& materials, Used&& used) {
  Scan scan;
  for (size_t i = 0; i < materials.size(); ++i) {
    if (!used(i)) continue;
    const auto& m = materials[i];
    if (scan.focusing < 0 && focuses_light(m.type, m.roughness, m.metallic)) scan.focusing = static_cast<int>(i);
    scan.receiver = scan.receiver || receives_diffusely(m.type, m.albedo, m.metallic);
  }
  return scan;
}

Estimator pick(const Scan& scan, int max_bounces) {
  return scan.focusing >= 0 && scan.receiver && max_bounces <= kMaxBdptBounces ? Estimator::Bdpt : Estimator::Mis;
}

}  // namespace

EstimatorChoice choose_estimator(const SceneDesc& scene) {
  std::vector<char> used(scene.materials.size(), 0);
  for (const ShapeDesc& s : scene.shapes)
    if (s.material >= 0 && static_cast<size_t>(s.material) < used.size()) used[static_cast<size_t>(s.material)] = 1;
  for (const InstanceDesc& in : scene.instances)
    for (int m : in.materials)
      if (m >= 0 && static_cast<size_t>(m) < used.size()) used[static_cast<size_t>(m)] = 1;
  const Scan scan = scan_materials(scene.materials, [&](size_t i) { return used[i] != 0; });
  const Estimator e = pick(scan, scene.render.max_bounces);
  if (e == Estimator::Bdpt) {
    const MaterialDesc& m = scene.materials[static_cast<size_t>(scan.focusing)];
    return {e, "bdpt: '" + m.name + "' (" + to_string(m.type) +
                   ") focuses light onto diffuse surfaces, caustics that mis finds only by chance"};
  }
  if (scan.focusing < 0)
    return {e, "mis: no glass, mirror or polished metal, so light sampling reaches every diffuse surface directly"};
  if (!scan.receiver) return {e, "mis: no diffuse surface receives what the smooth ones reflect or refract"};
  return {e, "mis: caustics, but more bounces than bdpt's limit of " + std::to_string(kMaxBdptBounces)};
}

Estimator choose_estimator(const Scene& scene, int max_bounces) {
  return pick(scan_materials(scene.materials,
                             [&](size_t i) { return i < scene.material_used.size() && scene.material_used[i] != 0; }),
              max_bounces);
}

RenderSettings resolved_render_settings(const Scene& scene, const RenderSettings& settings) {
  RenderSettings r = settings;
  if (r.estimator == Estimator::Auto) r.estimator = choose_estimator(scene, r.max_bounces);
  return r;
}

}  // namespace pt
