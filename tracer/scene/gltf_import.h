// glTF 2.0 files (`.gltf` with external or embedded buffers, `.glb`), parsed by Debian's libtinygltf-dev and
// checked here (docs/scene-format.md, "glTF 2.0"). This first step reads what the renderer can show today:
// - the node hierarchy of the default scene (else of every root node) with its transforms (a matrix, or
//   translation · rotation · scale), applied in double; a node graph with a cycle is refused;
// - indexed or plain triangle primitives (POSITION; any other primitive mode is refused, never guessed),
//   smooth-shaded by their NORMAL attribute (mapped by the inverse transpose of the node's transform), flat
//   without one; TEXCOORD_0 gives texture coordinates. Each mesh is read once into an indexed mesh in its own
//   coordinates (GltfMesh) and placed by an instance per node that shows it (geometry/instances.h: a million
//   triangles load and render a first pass in 0.4 s at 237 MB); a mesh whose material emits light is placed as
//   triangles in the file's world instead (lights are shapes), listed the other way round under a mirroring
//   transform so that faces keep their fronts;
// - the first perspective camera met in the node graph (yfov; the aspect ratio sets the film's shape);
// - materials: the specification's metallic–roughness BRDF (materials/metallic_roughness.h: base colour,
//   metallic, roughness, KHR_materials_ior's index, default 1.5); KHR_materials_transmission → the project's
//   smooth or rough dielectric of that index; emission = emissiveFactor × KHR_materials_emissive_strength;
//   a primitive without a material gets the specification's default (white, metallic 1, roughness 1).
// - base colour textures (baseColorTexture × baseColorFactor, on TEXCOORD_0, sRGB-decoded, the sampler's wrap
//   modes, trilinear filtering by ray cones: materials/texture.h), images embedded, in data URIs or in files
//   beside the model, decoded by stb_image; one texture shared by every material naming it; its
//   KHR_texture_transform (offset, rotation, scale);
// - KHR_lights_punctual: point, spot and directional lights at their nodes (position, −z axis), colour ×
//   intensity read one to one as W/sr (point, spot) and W/m² (directional), never divided by 683; the spot's
//   cone angles; `range` is passed over (the inverse-square law holds everywhere), said once as a warning.
// - metallicRoughnessTexture (roughness × green, metallic × blue, linear) and normalTexture with its scale
//   (a tangent-space normal map: materials/normal_map.h, in the frame of the TANGENT attribute, or where a
//   primitive has none, or its mesh emits and is placed as triangles, the per-face frame of the uv mapping),
//   each with its own KHR_texture_transform.
// - alpha mode MASK: cut-outs (geometry/alpha_mask.h) where baseColorFactor's alpha × the base colour
//   texture's alpha falls below alphaCutoff; BLEND: partial transparency, the surface there with probability
//   that alpha (stochastic transparency).
// - emissiveTexture: the emission is emissiveFactor × strength × the image (sRGB), where rays hit the surface
//   and where light samples land on it.
// Not read, each named once on the warnings list: occlusion textures (ambient occlusion baked for
// rasterisers: a path tracer computes occlusion), skins and morph targets,
// orthographic cameras. Extensions named in extensionsRequired that are not read are refused by name; other unknown
// extensions are warned about.
//
// Every failure throws SceneError naming the file, the glTF path (`meshes[2].primitives[0].attributes.POSITION`)
// and the reason: missing or short buffers, accessor indices, offsets or strides out of range, indices past the
// vertex count, non-finite positions or transforms, sparse accessors, a file or buffer over kMaxSceneFileBytes.
#pragma once
#include <array>
#include <optional>
#include <string>
#include <vector>

#include "scene/scene_desc.h"

namespace pt {

// A mesh of the file: stored once, indexed, in its own coordinates (MeshDesc), its material slots mapped to the
// file's materials.
struct GltfMesh {
  MeshDesc mesh;
  std::vector<int> slot_material;  // per slot, an index into GltfContents::materials
};
struct GltfInstance {
  uint32_t mesh = 0;            // index into GltfContents::meshes
  glm::dmat4 transform{1.0};    // its node's transform into the file's world
};

struct GltfContents {
  // The emitting meshes' triangles, in world coordinates (node transforms applied).
  std::vector<std::array<DVec3, 3>> triangles;
  std::vector<int> triangle_material;           // per triangle, an index into `materials`
  // Per triangle, its vertex normals (NORMAL, in the file's world, unit) and texture coordinates (TEXCOORD_0),
  // in the triangles' vertex order; empty when no primitive has normals (TriangleShading).
  std::vector<TriangleShading> shading;
  std::vector<GltfMesh> meshes;                 // the other meshes (whose materials do not emit)
  std::vector<GltfInstance> instances;          // their placements, one per node showing one
  std::vector<MaterialDesc> materials;          // the file's materials (unique names), then the default if used
  std::vector<PunctualLightDesc> lights;        // KHR_lights_punctual, placed by their nodes (object −1)
  std::optional<CameraDesc> camera;             // the first perspective camera in the node graph
  double aspect_ratio = 0;                      // that camera's aspect ratio (width/height); 0 when not given
  bool emits = false;                           // some material emits light
  size_t degenerate = 0;                        // zero-area triangles left out (they can never be hit)
  std::vector<std::string> warnings;            // what was not read, one line each
};

// True for .gltf and .glb (by extension, any case).
bool is_gltf_file(const std::string& path);

// Throws SceneError (scene_json.h) naming the file, the glTF path and the reason.
GltfContents load_gltf(const std::string& path);

// Places every instance's triangles among g.triangles (in the file's world, as the emitting meshes' are) and
// drops the meshes and instances: for a model whose triangles must all be shapes (a scene file giving it one
// emitting material).
void flatten_gltf(GltfContents& g);

// A scene for a glTF file given alone (`render --scene model.glb`, `view model.gltf`): the file's triangles and
// materials; its camera, else one that frames its bounds (scene/studio.h's framing); lit by its own emitters
// against a black background, or, when nothing in it emits, by the daylight sky an OBJ model gets (studio.h:
// shapes show by shading and shadow; no ground is added, since a glTF file may hold a whole scene). Warnings go
// to stderr. Throws SceneError.
SceneDesc gltf_scene(const std::string& path);

}  // namespace pt
