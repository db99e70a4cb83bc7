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

# RapidJSON (rapidjson-dev, headers only): the scene files' reader (iterative, ~2.5x nlohmann's SAX speed).
find_path(PT_RAPIDJSON_INCLUDE_DIR rapidjson/reader.h REQUIRED)
add_library(pt_rapidjson INTERFACE)
target_include_directories(pt_rapidjson SYSTEM INTERFACE ${PT_RAPIDJSON_INCLUDE_DIR})

# GLM as a plain header target, whatever name the package exports.
add_library(pt_glm INTERFACE)
if(TARGET glm::glm)
  target_link_libraries(pt_glm INTERFACE glm::glm)
elseif(TARGET glm)
  target_link_libraries(pt_glm INTERFACE glm)
endif()
target_compile_definitions(pt_glm INTERFACE GLM_FORCE_XYZW_ONLY GLM_ENABLE_EXPERIMENTAL)

# --- Interactive viewer -------------------------------------------------------------------------------------------
# GLFW (libglfw3-dev) exports the target `glfw`; OpenGL::GL is the GLVND libGL (GLX), which the viewer's window uses.
find_package(glfw3 3.3 REQUIRED)
set(OpenGL_GL_PREFERENCE GLVND)
find_package(OpenGL REQUIRED)

# Dear ImGui 1.86 (libimgui-dev): Debian ships no CMake package, only one static archive with the core *and* the
# backends compiled in (`nm -C libimgui.a` defines ImGui_ImplGlfw_* and ImGui_ImplOpenGL3_*). Of its members,
# the ones the viewer pulls in need: imgui_draw.o stb_truetype/stb_rect_pack (from libstb, imgui.pc says
# "Requires: stb"); imgui_impl_opengl3.o dlopen/dlsym (its gl3w loader opens libGL.so.1 itself, so it needs no
# GL link); imgui_impl_glfw.o glfw. Freetype is only needed by imgui_freetype.o, which nothing references.
find_library(PT_IMGUI_LIBRARY NAMES libimgui.a imgui REQUIRED)
find_path(PT_IMGUI_INCLUDE_DIR imgui.h PATH_SUFFIXES imgui REQUIRED)
add_library(pt_imgui STATIC IMPORTED)
set_target_properties(pt_imgui PROPERTIES
  IMPORTED_LOCATION ${PT_IMGUI_LIBRARY}
  INTERFACE_INCLUDE_DIRECTORIES ${PT_IMGUI_INCLUDE_DIR}
  INTERFACE_LINK_LIBRARIES "PkgConfig::STB;${CMAKE_DL_LIBS};m")
# The GLFW platform backend lives in the same archive; linking this target orders glfw after it.
add_library(pt_imgui_glfw INTERFACE)
target_link_libraries(pt_imgui_glfw INTERFACE pt_imgui glfw)

# OSMesa (libosmesa6-dev): Mesa's off-screen GL, for the headless GL tests only. libOSMesa exports the GL entry
# points itself, so a test executable links it *instead of* OpenGL::GL.
if(PT_BUILD_TESTS)
  pkg_check_modules(OSMESA REQUIRED IMPORTED_TARGET osmesa)
endif()

# OpenEXR 3 (libopenexr-dev): reading latitude-longitude HDR environment maps (io/image_io.cpp).
find_package(OpenEXR REQUIRED CONFIG)

# tinyobjloader (libtinyobjloader-dev): Wavefront OBJ meshes of the scene's "mesh" shape (scene/mesh_obj.cpp).
find_package(tinyobjloader REQUIRED CONFIG)

# tinygltf (libtinygltf-dev, header-only): glTF 2.0 scenes (scene/gltf_import.cpp, the one translation unit that
# holds its implementation); it includes nlohmann/json.hpp (nlohmann-json3-dev).
find_path(TINYGLTF_INCLUDE_DIR tiny_gltf.h REQUIRED)

# Open MPI (libopenmpi-dev, openmpi-bin): `render --mpi` spreads one frame over ranks (docs/scale-out.md). Only the
# C API is used (through the CXX component: the project enables no C language); MPI_Init runs only with --mpi,
# so a plain render never touches it.
find_package(MPI REQUIRED COMPONENTS CXX)
