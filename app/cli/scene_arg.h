// The scene argument shared by `pathtracer render` and `pathtracer view`: load it, or report why not.
#pragma once
#include <optional>
#include <string>

#include "scene/scene_desc.h"

namespace pt {

// Loads `spec` (a built-in scene name or a .json file path). On a SceneError prints "error: <what>" to stderr
// (the message names the file, the JSON path and the reason) and returns nothing: the command then exits with
// status 2 (invalid input).
std::optional<SceneDesc> load_scene_arg(const std::string& spec);

// The scene option's --help text, naming every built-in scene (builtin_scene_names(): one list, never retyped).
std::string scene_arg_help();

}  // namespace pt
