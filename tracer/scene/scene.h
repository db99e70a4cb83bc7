// The render-ready scene: an immutable snapshot compiled from a validated SceneDesc.
//
// All geometry is stored relative to the camera position (subtracted in double at compile time, then rounded to
// float). Camera rays therefore start exactly at the origin, and the float precision available to a hit point
// depends on its distance from the camera, not on where the scene sits in the world: a scene translated by 10^6
// renders the same image.
//
// The primitives themselves, and how rays find them, are geometry/'s (primitives.h, scene_queries.h).
#pragma once
#include <array>
#include <memory>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "scene/camera.h"
#include "geometry/geometry.h"
#include "scene/scene_desc.h"
#include "geometry/primitives.h"
#include "lights/light_tree.h"
#include "lights/environment_map.h"
#include "materials/material.h"

namespace pt {

// Everything that emits: area lights (emitting polygons and spheres) and the infinitely distant ones (the
// environment and the sun). Lights are chosen with probability proportional to their power (Scene::light_pmf);
// lights/light_sampling.h samples and evaluates them.
enum class LightKind : uint8_t {
  Polygon,      // a triangle or quad, sampled uniformly by area
  Rectangle,    // a rectangular quad, sampled uniformly in solid angle (spherical rectangle, Ureña et al. 2013)
  Sphere,       // sampled in its cone (outside) or by area (inside)
  Environment,  // constant radiance or a lat-long map (Scene::environment)
  Sun,          // a distant disk: a cone of directions of constant radiance
  Point,        // punctual (no size: reached by light sampling alone): intensity `emission` W/sr from `position`
  Spot,         // a point whose intensity fades from cos_inner to cos_outer about `direction` (glTF's falloff)
  Directional,  // parallel light of irradiance `emission` travelling against `direction`
};
struct Light {
  LightKind kind = LightKind::Polygon;
  uint32_t prim = kNoPrimitive;  // global primitive id of an area light
  float area = 0.f;              // world units²
  Rgb emission{0.f};             // area light and sun radiance
  bool two_sided = false;
  Vec3 corner{0.f}, edge_x{0.f}, edge_y{0.f};  // Rectangle: corner and perpendicular edges (camera-relative)
  Vec3 direction{0.f};           // Sun, Directional: unit direction towards it; Spot: the way it shines
  float one_minus_cos_max = 0.f; // Sun: angular radius as 1 − cos
  Vec3 position{0.f};            // Point, Spot (camera-relative)
  float cos_inner = 1.f, cos_outer = 0.f;  // Spot
  TextureSlot emission_map;      // a textured area light (its material's emission_map; kind Polygon): emission × it
  bool uniform_parallelogram = false;  // a parallelogram without emission_map (light_sampling.h: parallelogram_by_area)
  bool infinite() const { return kind == LightKind::Environment || kind == LightKind::Sun; }
  bool delta() const { return kind == LightKind::Point || kind == LightKind::Spot || kind == LightKind::Directional; }
  bool polygon() const { return kind == LightKind::Polygon || kind == LightKind::Rectangle; }  // a triangle or quad
  bool sphere() const { return kind == LightKind::Sphere; }
};

// The environment as compiled: what escaping rays see (besides the sun, a Light of its own).
struct EnvironmentLight {
  bool present = false;    // emits anything at all
  bool uses_map = false;   // a lat-long map (a file, or the tabulated sky); else the constant `radiance`
  Rgb radiance{0.f};
  std::shared_ptr<const EnvironmentMap> map;
  Light sun;  // the sky's solar disk (kind Sun); black when there is none
};

// What the scene contains, recorded when it is compiled.
struct SceneFeatures {
  bool triangles = false, quads = false, spheres = false;  // quads: non-triangle polygons
  bool lambertian_only = true;  // every material is the Lambert lobe alone (materials/bsdf.h: is_lambertian)
  bool emissive_spheres = false, environment = false;
  bool smooth_shading = false;  // some polygon has vertex normals (SceneGeometry::shading)
  bool textures = false;        // some material reads an image (albedo, metallic-roughness, normal map)
};

// The geometry (SceneGeometry, geometry/primitives.h: what the ray queries read) with the camera, materials and
// lights.
class Scene : public SceneGeometry {
 public:
  Camera camera;
  EnvironmentLight environment;
  int width = 0, height = 0;
  DVec3 world_origin{0.0};  // the camera position subtracted from all geometry

  std::vector<Material> materials;
  std::vector<std::shared_ptr<const Texture>> textures;  // what the materials' texture pointers point to
  std::vector<char> material_used;  // per material: some shape has it (the `auto` estimator asks)
  SceneFeatures features;

  std::vector<Light> lights;
  std::vector<int32_t> light_of_prim;  // light index of each of the scene's own primitives, −1 for non-emitters
  // Per polygon, the SceneDesc::instances entry it was placed from (instances_as_polygons), kNoInstance for a
  // shape's; empty when no instance was placed so.
  std::vector<uint32_t> polygon_instance;
  static constexpr uint32_t kNoInstance = ~0u;
  // The light a primitive is, −1 for none (instanced meshes never emit: validate_scene).
  int32_t light_of(uint32_t prim) const { return prim < light_of_prim.size() ? light_of_prim[prim] : -1; }
  std::vector<float> light_cdf;        // cumulative power-proportional selection probabilities
  std::vector<float> light_pmf;
  // Next-event estimation's choice among many bounded lights by their importance at the receiver
  // (lights/light_tree.h); empty below LightTree::kMinLights of them, where power alone chooses.
  LightTree light_tree;
  std::vector<uint32_t> infinite_lights;  // indices into `lights` of the environment and the sun
  std::vector<Light> punctual_lights;     // compiled from SceneDesc::punctual_lights; compile_lights adds them
  bool directional_lights = false;        // some light of `lights` is a Directional one (starts paths as the sun)
  double bounding_radius = 0.0;        // of a sphere around all geometry (centred at the camera)
  // Where infinite lights aim half of their light paths (lights/light_emission.h): a sphere around every surface
  // with a glossy or specular lobe (what can focus light into a caustic) and every instanced mesh; radius 0 when
  // there is none, or when it would cover a quarter of the bounding sphere's disk or more (no gain).
  Vec3 emission_focus_center{0.f};
  float emission_focus_radius = 0.f;

  uint32_t kernel_features() const {
    return (features.triangles || features.quads ? kFeaturePolygons : 0u) | (features.spheres ? kFeatureSpheres : 0u) |
           (features.lambertian_only && !features.smooth_shading && !features.textures ? 0u : kFeatureGeneralMaterials);
  }

  // Closest hit in (0, t_max), never reporting `skip` (the planar primitive a spawned ray leaves; ~0u for none).
  // (The kernels call the feature-specialised versions in scene_queries.h.)
  bool intersect(const Ray& ray, float t_max, uint32_t skip, Hit& hit) const;
  // Any hit in (0, t_max) ignoring primitives skip_a and skip_b: for shadow rays.
  bool occluded(const Ray& ray, float t_max, uint32_t skip_a, uint32_t skip_b) const;
  // The same for n ≤ kLanes rays at once (geometry/packet_polygons.h): found[l] and hits[l] per ray; bit l of
  // occluded_packet's result for ray l (skip_b may be null).
  void intersect_packet(const Ray* rays, const float* t_max, const uint32_t* skip, int n, Hit* hits, bool* found) const;
  uint32_t occluded_packet(const Ray* rays, const float* t_max, const uint32_t* skip_a, const uint32_t* skip_b,
                           int n) const;
};

// A polygon corner (b−a, c−a) is degenerate when the sine of its angle is below 1e-12 (in double): slivers
// 10^-7 thin are legitimate geometry, zero-area triangles are not. validate_scene refuses them; the mesh reader
// leaves them out.
bool degenerate_triangle(DVec3 a, DVec3 b, DVec3 c);

// Builds the render-ready scene. The description must already be valid (scene_json validates files; code that
// builds a SceneDesc by hand can call validate_scene). Throws std::invalid_argument on anything it cannot render.
std::shared_ptr<Scene> compile_scene(const SceneDesc& desc);

// The SceneDesc::shapes index of every primitive id compile_scene(desc) makes (polygons, then spheres; a
// non-planar quad is two triangles): what a pick reports as the object.
std::vector<uint32_t> primitive_shapes(const SceneDesc& desc);

// Whether compile_scene places the instances' triangles as polygons, under the scene's own hierarchy, instead of
// instancing them: when all the scene's polygons and instanced triangles together are at most
// kPlacedPolygonsMax, no mesh has file tangents (polygons carry none), every placed triangle stays a triangle,
// and render.instancing is Auto. One hierarchy over every triangle beats two levels where the instances'
// boxes overlap: Debian's 2CylinderEngine.glb (29 meshes, 67 placements, 121,496 triangles) replays its path
// rays 28 % faster (closest hit) and 12 % faster (shadow rays); below kBvhMinPolygons (a small glTF model)
// the brute-force SIMD loop and the wavefront serve it (a 12-triangle glTF box: 13.9 against 9.7 Mrays/s
// through its instance). The price is memory: about 300 bytes a placed triangle (the engine: 26 → 64 MB peak)
// against one transform per instance, so larger scenes, and any that places a mesh many times over, keep
// their instances (docs/performance.md, "Instances placed as polygons").
inline constexpr size_t kPlacedPolygonsMax = size_t{1} << 18;
bool instances_as_polygons(const SceneDesc& desc);

// True when b has a's shapes, film size and number of materials: then the compiled geometry of a serves b, and
// update_scene_appearance can apply the difference in place.
bool same_geometry(const SceneDesc& a, const SceneDesc& b);
// The same without the film size (set_scene_resolution changes that in place).
bool same_shapes(const SceneDesc& a, const SceneDesc& b);

// Edits without recompiling geometry: `s` was compiled from `before` (possibly at another film size: a
// preview); applies `after`, whose shapes must be before's, by recompiling only the materials that differ, the
// environment if it differs and the light list (cheap: emitters may have changed), and by moving the camera in
// place (the geometry stays camera-relative to where it was compiled; rays start at the
// new eye). A live material edit thus costs that material's tables (≤ 1 ms), a camera drag almost nothing.
// Returns false, changing nothing, when the camera moved farther than the scene's bounding radius from where
// the geometry was compiled: recompile then (compile_scene), so precision never depends on the path travelled.
// Throws std::invalid_argument as compile_scene does.
bool update_scene_appearance(Scene& s, const SceneDesc& before, const SceneDesc& after);

// Typed edits: what the viewer changes live, applied without copying or comparing the scene's shapes (which
// may be millions). Render settings are not among them: they are not part of the compiled scene and go to the
// renderer with each pass.
struct MaterialEdit {
  size_t index = 0;
  MaterialDesc material;
};
// The film's size (the viewer following its window): no geometry is rebuilt, the camera's raster changes.
struct FilmSize {
  int width = 0, height = 0;
};
using SceneEdit = std::variant<MaterialEdit, CameraDesc, EnvironmentDesc, FilmSize>;
inline constexpr int kMaxFilmSide = 16384;

// Gives a compiled scene another film size (its camera's raster) in place: the geometry does not depend on it.
// `camera` is the scene's camera description (the eye stays where the scene has it now).
void set_scene_resolution(Scene& s, int width, int height, const CameraDesc& camera);

// "" when `edit` may be applied to `desc` (the index exists, the new values are valid), else "path: reason".
// Checks the edited part only: its cost does not grow with the scene.
std::string validate_edit(const SceneDesc& desc, const SceneEdit& edit);
// Applies a valid edit to a description.
void apply_edit(SceneDesc& desc, const SceneEdit& edit);
// Applies a valid edit to a compiled scene in place: the material's tables, the environment, the light list,
// or the eye. Returns false, changing nothing, for a camera moved farther than the scene's bounding radius from
// where the geometry was compiled: recompile then. Throws std::invalid_argument as compile_scene does (an
// unreadable environment map).
bool apply_edit(Scene& s, const SceneEdit& edit);

// The ranges the tracer represents (docs/reliability.md, "Representable ranges"). Geometry is compiled to float
// relative to the camera, and the watertight ray-triangle test forms products of three camera-relative
// coordinates, which overflow float near 7e12 and leave its normal range below 2e-13; these bounds keep a
// factor of ~100 from both ends. Measured: the Cornell box scaled by 10^k renders the same image for
// k = -15 ... 9 and goes black at k >= 11 (farthest point 1.4e14 from the camera).
inline constexpr double kMaxCameraDistance = 1e12;  // no point of any shape farther from the camera
inline constexpr double kMinSceneExtent = 1e-10;    // the farthest point of the scene at least this far
// Radiance of emitters, the background and environment maps (after `scale`): leaves float headroom for the
// products of a path's throughput, so no sample overflows to infinity.
inline constexpr float kMaxRadiance = 1e30f;
inline constexpr float kMaxEnvironmentScale = 1e20f;

// "" when every component of a radiance is finite and in [0, kMaxRadiance], else the reason.
std::string radiance_problem(Rgb c);

// "" when the render settings are valid, else "render.field: reason".
std::string validate_render_settings(const RenderSettings& render);
// "" or why a film of width × height cannot be rendered (each side 1 … kMaxFilmSide).
std::string validate_film_size(int width, int height);

// Punctual lights (glTF's point, spot and directional lights) with an estimator that does not sample lights
// (uniform, cosine: no ray can hit a light of no size): refused.
std::string validate_punctual_for_estimator(const SceneDesc& scene, const RenderSettings& render);
// At most this many triangles placed by instances (their ids follow the scene's own primitives' in 32 bits).
inline constexpr size_t kMaxInstancedTriangles = size_t{1} << 31;
// Where an instance puts its mesh: its object's transform after its own.
glm::dmat4 instance_world(const SceneDesc& scene, const InstanceDesc& instance);
// The world box of the mesh an instance places (from its mesh's box; not tight under rotation).
std::pair<DVec3, DVec3> placed_box(const SceneDesc& scene, const InstanceDesc& instance);
// Corner c (bits: x, y, z at hi) of the box lo–hi.
inline DVec3 box_corner(DVec3 lo, DVec3 hi, int c) { return {c & 1 ? hi.x : lo.x, c & 2 ? hi.y : lo.y, c & 4 ? hi.z : lo.z}; }
// `material "NAME"` for messages.
std::string shown_material(const SceneDesc& scene, int material);
// "" when the material's parameters are valid, else "materials.NAME.field: reason".
std::string validate_material(const MaterialDesc& material);
// Checks a SceneDesc built in code; returns an empty string when valid, else "path: reason".
std::string validate_scene(const SceneDesc& desc);
// The objects' part of it: each holds ≥ 1 shape, in shape order without overlap, of one material, with a usable
// transform; a mesh names its file and holds triangles.
std::string validate_objects(const SceneDesc& desc);
// The index of the object (SceneDesc::objects) holding shape `shape`; nullopt when it stands alone.
std::optional<size_t> object_containing(const SceneDesc& desc, size_t shape);

}  // namespace pt
