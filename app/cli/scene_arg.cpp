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

std::string scene_arg_help() {
  std::string names;
  for (const std::string& n : builtin_scene_names()) names += (names.empty() ? "" : ", ") + n;
  return "Scene: a built-in name (" + names + "), a .json file path, an .obj model (shown in a studio) or a glTF 2.0 file (.gltf, .glb)";
}

}  // namespace pt
