// What a film state (io/film_state.h) records of the scene it was rendered from, and whether a scene may
// continue it: the scene's content hash and render settings. Here rather than in io/ because it reads scenes.
#pragma once
#include <cstdint>
#include <string>

#include "io/film_state.h"
#include "scene/scene_desc.h"

namespace pt {

// FNV-1a 64 of the scene without its shapes as scene_to_json writes it with the seed set to 0 (materials,
// camera, film size, environment and the render settings that change samples: estimator, sampler, bounces,
// Russian roulette), continued over each shape's binary record (docs/scale-out.md); the seed is compared on its
// own. An environment map enters by its file name, not its pixels.
uint64_t scene_content_hash(const SceneDesc& scene);
// The state's description of a render of `scene`; without `hash` its scene_hash stays 0 (a film whose state is
// never written need not pay for hashing a large mesh).
FilmStateInfo state_info_for(const SceneDesc& scene, const std::string& scene_name, bool hash = true);

// "" when a state of `info` may continue rendering `scene` (same content hash and seed, resumable), else the reason.
std::string resume_problem(const FilmStateInfo& info, const SceneDesc& scene);

}  // namespace pt
