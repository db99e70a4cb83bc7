// The `auto` estimator: which of the path tracer's estimators suits a scene, and why (docs/estimators.md,
// "Choosing an estimator").
//
// mis (light sampling + BSDF sampling, power heuristic) finds every path whose light reaches a diffuse or glossy
// surface directly. It finds light that reaches a diffuse surface only through a smooth or nearly smooth
// specular surface (glass, a mirror, polished metal: a caustic, L S+ D in Heckbert's notation) only when a BSDF
// sample happens to hit the light after the specular chain: rarely, and then with a large weight, so those
// scenes stay speckled with fireflies and their relMSE plateaus. bdpt (bidirectional, with its manifold
// strategy) traces those paths from the light. The rule: bdpt when a material that focuses light (a mirror, or
// glass or metal with roughness below kFocusingRoughness) and a material that receives it diffusely are both
// on the scene's shapes, and mis otherwise. Measured on every built-in scene in docs/estimators.md.
#pragma once
#include <string>

#include "scene/scene_desc.h"

namespace pt {

class Scene;

// Glass and metal below this roughness focus light sharply enough that mis samples their caustics poorly.
inline constexpr float kFocusingRoughness = 0.3f;

struct EstimatorChoice {
  Estimator estimator = Estimator::Mis;  // never Auto
  std::string reason;                    // one sentence, for the viewer's panel and render's summary line
};

// The rule's two questions about one material (`metallic`: glTF's metallic–roughness blend, 0 for the others;
// its mostly-metal smooth surfaces focus light, its dielectric part receives it).
bool focuses_light(MaterialType type, float roughness, float metallic = 0.f);
bool receives_diffusely(MaterialType type, Rgb albedo, float metallic = 0.f);

// What `auto` picks for this scene (whatever its render.estimator says).
EstimatorChoice choose_estimator(const SceneDesc& scene);
// The same pick for a compiled scene (its materials as edited since: the renderer resolves `auto` per pass).
Estimator choose_estimator(const Scene& scene, int max_bounces);

// The render settings to trace with: `settings`, with Auto replaced by choose_estimator's pick for `scene`.
RenderSettings resolved_render_settings(const Scene& scene, const RenderSettings& settings);

}  // namespace pt
