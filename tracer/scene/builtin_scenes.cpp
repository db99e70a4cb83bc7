// The built-in scenes: scenes/*.json embedded at build time (tools/embed_files.cmake generates embedded_files()).
#include <string_view>
#include <utility>
#include <vector>

#include "scene/scene_json.h"

namespace pt {

// Defined in the generated builtin_scenes_data.cpp: {file stem, file contents}.
const std::vector<std::pair<std::string_view, std::string_view>>& embedded_files();

std::vector<std::string> builtin_scene_names() {
  std::vector<std::string> names;
  for (const auto& [stem, text] : embedded_files()) names.emplace_back(stem);
  return names;
}

std::optional<std::string_view> builtin_scene_json(const std::string& name) {
  for (const auto& [stem, text] : embedded_files())
    if (stem == name) return text;
  return std::nullopt;
}

}  // namespace pt
