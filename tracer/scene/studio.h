// A scene for a model file given alone (`view model.obj`, `render --scene model.obj`, a dropped .obj): the model
// on a ground plane under a daylight sky, seen by a camera that frames it. What a user expects from opening a
// mesh in Blender or yocto-gl's viewer, so a model can be looked at without writing a scene file first
// (docs/scene-format.md, "A model file alone").
//
// - The model: the file's triangles as they are (OBJ is y-up by convention), material "model": diffuse, albedo
//   0.7 (the scene has no other information about it).
// - The ground: a diffuse quad (albedo 0.5) at the model's lowest point, 20 bounding radii wide.
// - The light: a Preetham sky with the sun 40° high (the `sky` scene's light, scaled by 0.15), so shapes show by
//   shading and shadow whatever their size.
// - The camera: 35° vertical field of view, looking at the bounding box's centre from above and in front (+z,
//   up 25°, 30° to the right), at the distance where the bounding sphere fills 90 % of the view's height.
#pragma once
#include <string>

#include "scene/scene_desc.h"

namespace pt {

// True for the file types studio_scene takes (by extension, any case): .obj, and glTF's .gltf and .glb.
bool is_model_file(const std::string& path);

// Throws SceneError naming the file and the reason (unreadable, no triangles, a non-finite vertex). A glTF file
// brings its own materials, camera and lighting rules (scene/gltf_import.h: gltf_scene).
SceneDesc studio_scene(const std::string& model_path);

// The light above: a Preetham sky with the sun 40° high, scaled by 0.15.
EnvironmentDesc daylight_environment();

// The camera above: 35° vertical field of view, looking at the centre of the box [lo, hi] from above and in
// front, at the distance where its bounding sphere fills 90 % of the view's height.
CameraDesc framing_camera(DVec3 lo, DVec3 hi);

}  // namespace pt
