#include "scene/estimator_choice.h"

#include <vector>

#include "scene/scene.h"

namespace pt {

// A Dirac or narrow glossy lobe that sends light on: a mirror, clear or lightly frosted glass, polished metal.
bool focuses_light(MaterialType type, float roughness) {
  switch (type) {
    case MaterialType::Mirror: return true;
    case MaterialType::Dielectric:
    case MaterialType::Conductor: return roughness < kFocusingRoughness;
    default: return false;
  }
}

// A diffuse lobe that reflects something shows light arriving from anywhere: where a caustic becomes visible
// (a black lamp, albedo 0, shows none).
bool receives_diffusely(MaterialType type, Rgb albedo) {
  return (type == MaterialType::Diffuse || type == MaterialType::Plastic || type == MaterialType::Subsurface) &&
         max_component(albedo) > 0.f;
}

EstimatorChoice choose_estimator(const SceneDesc& scene) {
  std::vector<char> used(scene.materials.size(), 0);
  for (const ShapeDesc& s : scene.shapes)
    if (s.material >= 0 && static_cast<size_t>(s.material) < used.size()) used[static_cast<size_t>(s.material)] = 1;
  const MaterialDesc* focusing = nullptr;
  bool receiver = false;
  for (size_t i = 0; i < scene.materials.size(); ++i) {
    if (!used[i]) continue;
    const MaterialDesc& m = scene.materials[i];
    if (!focusing && focuses_light(m.type, m.roughness)) focusing = &m;
    receiver = receiver || receives_diffusely(m.type, m.albedo);
  }
  if (!focusing || !receiver)
    return {Estimator::Mis, focusing ? "mis: no diffuse surface receives what the smooth ones reflect or refract"
                                     : "mis: no glass, mirror or polished metal, so light sampling reaches every "
                                       "diffuse surface directly"};
  if (scene.render.max_bounces > kMaxBdptBounces)
    return {Estimator::Mis, "mis: caustics, but more bounces than bdpt's limit of " + std::to_string(kMaxBdptBounces)};
  return {Estimator::Bdpt, "bdpt: '" + focusing->name + "' (" + to_string(focusing->type) +
                               ") focuses light onto diffuse surfaces, caustics that mis finds only by chance"};
}

Estimator choose_estimator(const Scene& scene, int max_bounces) {
  bool focusing = false, receiver = false;
  for (size_t i = 0; i < scene.materials.size(); ++i) {
    if (i >= scene.material_used.size() || !scene.material_used[i]) continue;
    const Material& m = scene.materials[i];
    focusing = focusing || focuses_light(m.type, m.roughness);
    receiver = receiver || receives_diffusely(m.type, m.albedo);
  }
  return focusing && receiver && max_bounces <= kMaxBdptBounces ? Estimator::Bdpt : Estimator::Mis;
}

RenderSettings resolved_render_settings(const Scene& scene, const RenderSettings& settings) {
  RenderSettings r = settings;
  if (r.estimator == Estimator::Auto) r.estimator = choose_estimator(scene, r.max_bounces);
  return r;
}

RenderSettings resolved_render_settings(const SceneDesc& scene) {
  RenderSettings r = scene.render;
  if (r.estimator == Estimator::Auto) r.estimator = choose_estimator(scene).estimator;
  return r;
}

}  // namespace pt
