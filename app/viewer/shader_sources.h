// GLSL sources of shaders/, embedded into the binary at build time (the program runs from any directory).
#pragma once
#include <string_view>

namespace pt {

// Contents of shaders/NAME.* by file stem (e.g. "present" for present.frag); throws std::out_of_range if absent.
std::string_view shader_source(std::string_view stem);

}  // namespace pt
