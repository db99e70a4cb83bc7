#include "cli/scene_arg.h"

#include <cstdio>

#include "scene/scene_json.h"

namespace pt {

std::optional<SceneDesc> load_scene_arg(const std::string& spec) {
  try {
    return load_scene(spec);
  } catch (const SceneError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return std::nullopt;
  }
}

}  // namespace pt
