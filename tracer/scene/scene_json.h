// Scene files: JSON <-> SceneDesc, and the built-in scenes compiled into the binary.
// The format is documented in docs/scene-format.md.
#pragma once
#include <cstddef>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "scene/scene_desc.h"

namespace pt {

// Thrown for any unreadable or invalid scene. what() is "SOURCE: JSON.PATH: reason", e.g.
// "scenes/bad.json: shapes[3].radius: must be finite and > 0"; for syntax errors "SOURCE: line L, column C: reason".
struct SceneError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// Limits on scene input (docs/reliability.md): a larger file, deeper nesting or longer string is refused with
// the path and the figure, before it can exhaust memory or the stack. Counts of shapes and materials are bounded
// by the file size (a shape takes at least ~60 bytes of JSON).
inline constexpr size_t kMaxSceneFileBytes = size_t{1} << 30;  // 1 GiB
inline constexpr size_t kMaxSceneNesting = 64;
inline constexpr size_t kMaxSceneStringBytes = 4096;

// Parses and fully validates (structure, then validate_scene) a scene. `source_name` only prefixes error messages;
// files the scene refers to (an environment map) are found relative to `base_dir` ("" = the working directory)
// and read here, so that a missing or bad file is reported with its JSON path.
SceneDesc parse_scene(const std::string& json_text, const std::string& source_name, const std::string& base_dir = "");

// Reads and parses a file; errors (including "cannot open") name the file.
SceneDesc load_scene_file(const std::string& path);

// Pretty JSON (2-space indent, short arrays and shapes on one line). For a valid scene,
// parse_scene(scene_to_json(s)) reproduces s exactly, floats included. Fields the scene's types do not use
// (a dielectric's albedo, a non-dielectric's ior, a sphere's vertices, a polygon's centre/radius, a triangle's
// 4th vertex) are not written, so they come back as their defaults. Non-finite numbers are written as null.
// Objects are written as they are read: a mesh as its file and transform (the triangles stay in the OBJ file), a
// group as its shapes in its own coordinates (to_object(), so a group with a transform other than the identity
// comes back to within rounding, not bit for bit). With a `destination_dir`, files the scene refers to (meshes,
// an environment map) are named relative to that folder, where the written file will be read from; without
// one, as they were written. Throws std::invalid_argument when a shape's material index is out of range.
std::string scene_to_json(const SceneDesc& scene, const std::optional<std::string>& destination_dir = std::nullopt);

// Names of the built-in scenes, the default ("cornell") first: {"cornell", "cornell-spheres", "shadertoy",
// "materials", "sky"}.
std::vector<std::string> builtin_scene_names();

// JSON text of a built-in scene, or nullopt for an unknown name.
std::optional<std::string_view> builtin_scene_json(const std::string& name);

// `spec` is a built-in name or a file path: a model file (".obj", any case) is placed in a studio scene
// (scene/studio.h); anything else ending in ".json" or containing '/' is a scene file; otherwise a built-in name
// (the error lists the built-in names). The source name used in messages is the path or "builtin:NAME".
SceneDesc load_scene(const std::string& spec);

}  // namespace pt
