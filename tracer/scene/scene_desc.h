// The authoring model of a scene: what a JSON file says, what the viewer's UI edits, what `save scene` writes.
// Coordinates are double precision world units (the scene's own). Nothing here is render-ready: compile_scene()
// (scene.h) turns a validated SceneDesc into the tracer's camera-relative float structures.
#pragma once
#include <array>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "core/enum_table.h"
#include "core/math.h"
#include "geometry/alpha_mask.h"
#include "geometry/triangle_mesh.h"
#include "io/image_io.h"
#include "materials/material.h"
#include "materials/texture.h"
#include "scene/object_transform.h"

namespace pt {

enum class ShapeType { Triangle, Quad, Sphere };
enum class FovAxis { Vertical, Horizontal };
// Estimators of docs/estimators.md; all converge to the same image.
// Auto: mis or bdpt, whichever suits the scene (scene/estimator_choice.h); resolved before any path is traced.
// Last, so the others keep the numbers film-state files (io/film_state.h) store them under.
enum class Estimator { Uniform, Cosine, Nee, Mis, Bdpt, Auto };
// Sample generators (sampler.h): independent PCG32 numbers, or Owen-scrambled padded Sobol points.
enum class SamplerType { Independent, Sobol };
// What lights the scene from infinitely far away (lights/environment.h).
enum class EnvironmentType { Constant, Sky, Map };
// How paths are traced (integrators/wavefront.h): one at a time, or a tile's paths together, bounce by bounce,
// their rays 16 at a time through the packet kernels. Same image either way; `auto` takes the wavefront (on every
// scene: integrators/wavefront.h, runs_wavefront).
enum class PathLoop { Auto, Scalar, Wavefront };
// Whether compile_scene may place instanced meshes' triangles in the scene's own hierarchy (scene.h:
// instances_as_polygons) or must keep every instance.
enum class Instancing { Auto, Keep };
// What an object is made of (ObjectDesc): the shapes a scene file lists in a group, an OBJ file's triangles, or
// a glTF file's.
enum class ObjectKind { Group, Mesh, Gltf };

template <>
struct EnumTable<ShapeType> {
  static constexpr std::array<EnumEntry<ShapeType>, 3> kEntries{{
      {ShapeType::Triangle, "triangle", "Triangle"},
      {ShapeType::Quad, "quad", "Quad"},
      {ShapeType::Sphere, "sphere", "Sphere"},
  }};
};
template <>
struct EnumTable<FovAxis> {
  static constexpr std::array<EnumEntry<FovAxis>, 2> kEntries{{
      {FovAxis::Vertical, "vertical", "Vertical"},
      {FovAxis::Horizontal, "horizontal", "Horizontal"},
  }};
};
template <>
struct EnumTable<Estimator> {
  static constexpr std::array<EnumEntry<Estimator>, 6> kEntries{{
      {Estimator::Auto, "auto", "Automatic (mis or bdpt)"},
      {Estimator::Uniform, "uniform", "Uniform hemisphere"},
      {Estimator::Cosine, "cosine", "BSDF sampling"},
      {Estimator::Nee, "nee", "Next-event estimation"},
      {Estimator::Mis, "mis", "MIS (light + BSDF)"},
      {Estimator::Bdpt, "bdpt", "Bidirectional (BDPT)"},
  }};
};
template <>
struct EnumTable<SamplerType> {
  static constexpr std::array<EnumEntry<SamplerType>, 2> kEntries{{
      {SamplerType::Independent, "independent", "Independent (hashed)"},
      {SamplerType::Sobol, "sobol", "Sobol (Owen-scrambled)"},
  }};
};
template <>
struct EnumTable<PathLoop> {
  static constexpr std::array<EnumEntry<PathLoop>, 3> kEntries{{
      {PathLoop::Auto, "auto", "Automatic"},
      {PathLoop::Scalar, "scalar", "One path at a time"},
      {PathLoop::Wavefront, "wavefront", "Wavefront (16-ray packets)"},
  }};
};

template <>
struct EnumTable<Instancing> {
  static constexpr std::array<EnumEntry<Instancing>, 2> kEntries{{
      {Instancing::Auto, "auto", "Automatic"},
      {Instancing::Keep, "keep", "Keep every instance"},
  }};
};
template <>
struct EnumTable<ObjectKind> {
  static constexpr std::array<EnumEntry<ObjectKind>, 3> kEntries{{
      {ObjectKind::Group, "group", "Group of shapes"},
      {ObjectKind::Mesh, "mesh", "Mesh (OBJ file)"},
      {ObjectKind::Gltf, "gltf", "glTF 2.0 model"},
  }};
};
// Lights of no size (glTF's KHR_lights_punctual): a point radiating equally in all directions, a spot (a point
// whose cone fades from an inner to an outer angle), or a directional light (parallel rays from infinitely far).
enum class PunctualKind { Point, Spot, Directional };
template <>
struct EnumTable<PunctualKind> {
  static constexpr std::array<EnumEntry<PunctualKind>, 3> kEntries{{
      {PunctualKind::Point, "point", "Point light"},
      {PunctualKind::Spot, "spot", "Spot light"},
      {PunctualKind::Directional, "directional", "Directional light"},
  }};
};
template <>
struct EnumTable<EnvironmentType> {
  static constexpr std::array<EnumEntry<EnvironmentType>, 3> kEntries{{
      {EnvironmentType::Constant, "constant", "Constant colour"},
      {EnvironmentType::Sky, "sky", "Daylight sky (Preetham)"},
      {EnvironmentType::Map, "map", "HDR map (lat-long)"},
  }};
};

// The table's name of any enum value (enum_name), for messages and files.
template <class E>
const char* to_string(E value) {
  return enum_name(value);
}

// An image inside a model file and the map from surface uv to its uv (KHR_texture_transform; the identity
// elsewhere).
struct ModelTexture {
  std::shared_ptr<const Texture> texture;
  glm::mat3 uv_transform{1.f};
};

struct MaterialDesc {
  std::string name;
  MaterialType type = MaterialType::Diffuse;
  Rgb albedo{0.8f};         // diffuse reflectance; mirror tint; conductor F0; plastic base; subsurface α′; glTF base
  Rgb emission{0.f};        // emitted radiance (W·sr⁻¹·m⁻² in scene units), any material may emit
  bool two_sided = false;   // emission from both faces (default: front face only)
  float ior = 1.5f;         // dielectric / plastic coat / subsurface medium index inside (outside is 1)
  float roughness = 0.f;    // conductor, dielectric, plastic: [0, 1], GGX α = roughness², 0 = smooth
  float g = 0.f;            // subsurface Henyey–Greenstein asymmetry, (−1, 1)
  float metallic = 0.f;     // metallic_roughness: [0, 1], glTF's dielectric (0) to metal (1) blend
  MetalPreset metal = MetalPreset::None;  // conductor: measured η, k instead of albedo
  bool complex_ior = false;               // conductor: eta/k given in the file
  Rgb eta{1.f}, k{0.f};
  // An image whose colour, times `albedo` (then a factor, default 1), is the albedo at each point, looked up
  // at the surface's texture coordinates (materials/texture.h): the file as the scene file writes it ("" for
  // none, or for a texture that came inside a model file), the file relative to the scene file's folder (not
  // saved), and the loaded pyramid (null for none).
  std::string albedo_texture;
  std::string resolved_albedo_texture;
  std::shared_ptr<const Texture> albedo_map;
  // Maps the surface's texture coordinates to the texture's, (u, v, 1) ↦ M·(u, v, 1): glTF's
  // KHR_texture_transform (offset · rotation · scale); the identity elsewhere. Not written to scene files: it
  // comes with the model file's texture.
  glm::mat3 albedo_uv_transform{1.f};
  // Data textures that come with a model file's material (glTF), not written to scene files (a material saved
  // as an override keeps its model file's): metallic–roughness (read by metallic_roughness materials only:
  // roughness × green, metallic × blue) and a tangent-space normal map (any material), with its scale.
  ModelTexture metallic_roughness_map, normal_map;
  float normal_scale = 1.f;
  // A model file's emission image (glTF's emissiveTexture, colour): the emission is `emission` times it.
  ModelTexture emission_map;
  // glTF's alpha mode MASK: where the mask says so the surface is not there (geometry/alpha_mask.h); null for
  // an opaque material. Like the data textures, it comes with a model file's material only.
  std::shared_ptr<const AlphaMask> cutout;
  bool textured() const {
    return albedo_map || metallic_roughness_map.texture || normal_map.texture || emission_map.texture || cutout;
  }
};

// Per-vertex shading data of one triangle read from a model file (OBJ vn/vt, glTF NORMAL/TEXCOORD_0), in the
// coordinates of the model's file (before the object's transform, which compile_scene applies to the normals)
// and in the file's vertex order (the shape lists its vertices the other way round while its object's transform
// mirrors; compile_scene follows). Immutable once read: shared by every copy of the scene.
struct TriangleShading {
  std::array<Vec3, 3> normal{};  // unit vertex normals; all zero when the file gives none (flat shading)
  std::array<Vec2, 3> uv{};      // texture coordinates, v downwards (materials/texture.h); 0 when not given
  bool has_uv = false;
  bool has_normals() const { return normal[0] != Vec3(0.f); }
  bool any() const { return has_uv || has_normals(); }
};
inline constexpr uint32_t kNoShading = ~0u;

struct ShapeDesc {
  ShapeType type = ShapeType::Triangle;
  std::array<DVec3, 4> vertices{};  // triangle: 3, quad: 4 (counter-clockwise seen from the front)
  DVec3 center{0.0};                // sphere
  double radius = 0.0;              // sphere
  int material = 0;                 // index into SceneDesc::materials
  uint32_t shading = kNoShading;    // triangle: index into SceneDesc::shading, kNoShading for flat shading
};

// Shapes handled as one thing: an OBJ or glTF file's triangles, or a group's shapes (a box's five quads). Clicking
// one picks the object; its transform applies to all of its shapes, and so does its one material (a glTF model's
// triangles keep the file's materials until one is chosen for all). Its shapes are a contiguous
// run of SceneDesc::shapes, in world coordinates like every shape (the renderer never sees objects); `transform`
// places the object's own coordinates (the OBJ file's, or the group's shapes as the scene file writes them) in the
// world. A shape outside every object stands alone (object_containing(), scene.h). A glTF model's meshes are not
// among its shapes but instances (InstanceDesc::object names the object), save those whose materials emit light:
// such an object may hold no shape at all.
struct ObjectDesc {
  std::string name;
  ObjectKind kind = ObjectKind::Group;
  size_t first_shape = 0, shape_count = 0;
  ObjectTransform transform;
  std::string file;           // mesh: the OBJ file as written in the scene file
  std::string resolved_file;  // mesh: `file` relative to the scene file's directory (not saved)
};

// A triangle mesh that instances place (a glTF file's mesh): stored once, indexed, in its own coordinates
// (geometry/triangle_mesh.h), and shared, never changed, by every copy of the scene (the viewer's edits) and by
// the compiled scene. Its triangles have material slots, which each instance maps to the scene's materials.
using MeshDesc = TriangleMesh;

// One placement of a mesh: mesh → its object's coordinates (a glTF node's world transform), then the object's
// transform (ObjectDesc), so that moving the object moves its instances. Instanced triangles never emit
// (validate_scene): a model's emitting meshes are stored as shapes, which light sampling knows.
struct InstanceDesc {
  uint32_t mesh = 0;            // index into SceneDesc::meshes
  glm::dmat4 transform{1.0};    // affine, invertible
  int object = -1;              // the SceneDesc::objects entry that places it, −1 for the world
  std::vector<int> materials;   // per slot of the mesh, an index into SceneDesc::materials
};

// A punctual light, in the coordinates of the model file it came from (the object's transform places it, as it
// places the object's shapes; compile_scene applies it). Reached by light sampling alone: no ray can hit it.
struct PunctualLightDesc {
  std::string name;
  PunctualKind kind = PunctualKind::Point;
  DVec3 position{0.0};             // point, spot
  DVec3 direction{0.0, 0.0, -1.0}; // spot, directional: the way the light travels
  // Point and spot: radiant intensity (W/sr in scene units); directional: irradiance on a surface facing it
  // (W/m²). glTF's candela and lux are read one to one (docs/scene-format.md).
  Rgb intensity{1.f};
  double inner_cone = 0.0, outer_cone = 0.7853981633974483;  // spot: angles from the axis, radians
  int object = -1;  // the SceneDesc::objects entry that places it, −1 for the world
};

struct CameraDesc {
  DVec3 position{278, 273, -800};
  DVec3 look_at{278, 273, 0};
  DVec3 up{0, 1, 0};
  double fov_deg = 39.3077;
  FovAxis fov_axis = FovAxis::Vertical;
  // Thin lens (depth of field): the lens radius in scene units (0: a pinhole, everything sharp) and the distance
  // along the view direction at which the image is sharp (0: the distance to look_at).
  double aperture_radius = 0.0;
  double focus_distance = 0.0;
  // The focus distance in use: focus_distance, else look_at's distance along the view direction.
  double focus() const { return focus_distance > 0.0 ? focus_distance : glm::length(look_at - position); }
};

// The bidirectional estimator stores both subpaths and connects every pair of their vertices (O(n²) shadow rays
// per sample), so it traces at most this many bounces; render settings asking for more are refused.
inline constexpr int kMaxBdptBounces = 1024;

// RenderSettings::russian_roulette_depth's "auto": each estimator's own measured default
// (integrators/russian_roulette.h, roulette_depth).
inline constexpr int kRouletteDepthAuto = -2;

struct RenderSettings {
  int max_bounces = 8;             // scattering events after the camera ray's first hit (0 = emitters only)
  Estimator estimator = Estimator::Auto;
  SamplerType sampler = SamplerType::Sobol;
  // Bounce index from which Russian roulette runs; -1 = off; kRouletteDepthAuto = the estimator's default.
  int russian_roulette_depth = kRouletteDepthAuto;
  uint64_t seed = 0;
  // Diagnostic, not part of scene files: run the kernel compiled for every geometry kind instead of the one for
  // the scene's own (same image; for instruction-count comparisons, `render --generic-kernel`).
  bool generic_kernel = false;
  // Not part of scene files either: the path loop (same image; `render --path-loop`).
  PathLoop path_loop = PathLoop::Auto;
  // Not part of scene files either: keep every instance rather than place small scenes' instanced triangles as
  // polygons (nearly the same image; `render --instancing`, `bench rays --instancing`, and the tests of the
  // two-level hierarchy).
  Instancing instancing = Instancing::Auto;
  // Not part of scene files either: with s ≥ 0, the bidirectional estimator evaluates only the strategy with s
  // light and t camera vertices, unweighted (pbrt's per-strategy images; `render --bdpt-strategy s,t`).
  struct BdptStrategy {
    int s = -1, t = -1;
  } bdpt_only;
  // Not part of scene files either: the bidirectional estimator's manifold strategy, next-event estimation
  // through smooth spheres (integrators/bdpt_manifold.h); off only to measure it (`render --no-manifold`).
  bool bdpt_manifold = true;
};

struct EnvironmentDesc {
  EnvironmentType type = EnvironmentType::Constant;
  Rgb radiance{0.f};                    // constant: radiance of every escaping ray ("background" in files)
  DVec3 sun_direction{0.3, 0.6, -0.4};  // sky: towards the sun (normalised when compiled; y up)
  float turbidity = 3.f;                // sky: Preetham turbidity, [1.7, 10]
  bool sun = true;                      // sky: add the solar disk as a light
  float scale = 1.f;                    // sky and map: radiance multiplier
  std::string file;                     // map: lat-long image (.exr, .hdr, .pfm), as written in the scene file
  std::string resolved_file;            // map: `file` relative to the scene file's directory (not saved)
  float rotation_deg = 0.f;             // map: rotation about +y
  std::shared_ptr<const Image> image;    // map: the loaded image (loaded by the scene reader / the viewer)
};

// Whether the environment lights the scene from infinitely far away (a sky, a map, or a non-black constant
// background): what compile_environment turns into infinite lights, but for a map whose texels are all black.
inline bool lit_from_infinity(const EnvironmentDesc& e) {
  return e.type != EnvironmentType::Constant || !is_black(e.radiance);
}

struct SceneDesc {
  CameraDesc camera;
  int width = 512, height = 512;
  RenderSettings render;
  EnvironmentDesc environment;
  std::vector<MaterialDesc> materials;
  std::vector<ShapeDesc> shapes;
  std::vector<ObjectDesc> objects;  // in the order of their shapes, never overlapping
  std::vector<PunctualLightDesc> punctual_lights;  // from model files (glTF KHR_lights_punctual)
  // The model files' vertex normals and texture coordinates (ShapeDesc::shading indexes it); null when no shape
  // has any. Shared, never changed: copies of a scene (the viewer's edits) share it.
  std::shared_ptr<const std::vector<TriangleShading>> shading;
  // Meshes placed by instances (glTF files' meshes whose materials do not emit), and their placements.
  std::vector<std::shared_ptr<const MeshDesc>> meshes;
  std::vector<InstanceDesc> instances;
  // Some triangle has vertex normals.
  bool smooth_shading() const {
    if (shading)
      for (const TriangleShading& t : *shading)
        if (t.has_normals()) return true;
    for (const std::shared_ptr<const MeshDesc>& m : meshes)
      if (m->any_normals()) return true;
    return false;
  }
};

}  // namespace pt
