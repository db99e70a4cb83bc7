# Glue that turns Debian packages into CMake targets. No third-party source lives here. Included from the top level.
find_package(Threads REQUIRED)
find_package(nlohmann_json 3.10 REQUIRED)
find_package(glm REQUIRED)
find_package(CLI11 REQUIRED)
find_package(PkgConfig REQUIRED)

# stb (libstb-dev): Debian ships the implementations compiled into libstb, headers under /usr/include/stb.
pkg_check_modules(STB REQUIRED IMPORTED_TARGET stb)
add_library(pt_stb INTERFACE)
target_link_libraries(pt_stb INTERFACE PkgConfig::STB)

# GLM as a plain header target, whatever name the package exports.
add_library(pt_glm INTERFACE)
if(TARGET glm::glm)
  target_link_libraries(pt_glm INTERFACE glm::glm)
elseif(TARGET glm)
  target_link_libraries(pt_glm INTERFACE glm)
endif()
target_compile_definitions(pt_glm INTERFACE GLM_FORCE_XYZW_ONLY GLM_ENABLE_EXPERIMENTAL)
