// The authoring model of a scene: what a JSON file says, what the viewer's UI edits, what `save scene` writes.
// Coordinates are double precision world units (the scene's own). Nothing here is render-ready: compile_scene()
// (scene.h) turns a validated SceneDesc into the tracer's camera-relative float structures.
#pragma once
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "math.h"

namespace pt {

enum class MaterialType { Diffuse, Mirror, Dielectric };
enum class ShapeType { Triangle, Quad, Sphere };
enum class FovAxis { Vertical, Horizontal };

// Estimators of DESIGN.md; all converge to the same image.
enum class Estimator { Uniform, Cosine, Nee, Mis };
// Sample generators (sampler.h): independent PCG32 numbers, or Owen-scrambled padded Sobol points.
enum class SamplerType { Independent, Sobol };

struct MaterialDesc {
  std::string name;
  MaterialType type = MaterialType::Diffuse;
  Rgb albedo{0.8f};         // diffuse reflectance, or the mirror's tint; unused by dielectrics
  Rgb emission{0.f};        // emitted radiance (W·sr⁻¹·m⁻² in scene units), any material may emit
  bool two_sided = false;   // emission from both faces (default: front face only)
  float ior = 1.5f;         // dielectric index of refraction inside (front side / outside is 1)
};

struct ShapeDesc {
  ShapeType type = ShapeType::Triangle;
  std::array<DVec3, 4> vertices{};  // triangle: 3, quad: 4 (counter-clockwise seen from the front)
  DVec3 center{0.0};                // sphere
  double radius = 0.0;              // sphere
  int material = 0;                 // index into SceneDesc::materials
};

struct CameraDesc {
  DVec3 position{278, 273, -800};
  DVec3 look_at{278, 273, 0};
  DVec3 up{0, 1, 0};
  double fov_deg = 39.3077;
  FovAxis fov_axis = FovAxis::Vertical;
};

struct RenderSettings {
  int max_bounces = 8;             // scattering events after the camera ray's first hit (0 = emitters only)
  Estimator estimator = Estimator::Mis;
  SamplerType sampler = SamplerType::Sobol;
  int russian_roulette_depth = 3;  // bounce index from which Russian roulette runs; -1 = off
  uint64_t seed = 0;
  // Diagnostic, not part of scene files: run the kernel compiled for every feature instead of the one for the
  // scene's own (same image; for instruction-count comparisons, `render --generic-kernel`).
  bool generic_kernel = false;
};

struct SceneDesc {
  CameraDesc camera;
  int width = 512, height = 512;
  RenderSettings render;
  Rgb background{0.f};  // radiance of rays that escape the scene (uniform in all directions)
  std::vector<MaterialDesc> materials;
  std::vector<ShapeDesc> shapes;
};

const char* to_string(Estimator e);
const char* to_string(MaterialType t);
const char* to_string(ShapeType t);
bool parse_estimator(const std::string& s, Estimator& out);
const char* to_string(SamplerType s);
bool parse_sampler(const std::string& s, SamplerType& out);

}  // namespace pt
