// Scenes and statistics of the accuracy / numerical-stability checks, shared by `pathtracer stress`
// (app/stress_command.cpp) and the test suite (tests/test_accuracy.cpp). GL-free: it needs only the tracer.
//
// Every scene is built in code as a SceneDesc, in the scene's own units, around a nominal size of 1 (the built-in
// Cornell scenes keep their millimetre-like units); transformed() then moves and scales a whole scene, camera
// included, so one builder serves every translation and scale of the matrix. What each scene checks, and why its
// expected value is what it is, is documented in docs/accuracy.md.
#pragma once
#include <optional>
#include <string>
#include <vector>

#include "film/film.h"
#include "scene/scene.h"

namespace pt::stress {

// Scene builders' helpers: a quad shape of material m, vertices counter-clockwise seen from the front; a sphere;
// a material.
ShapeDesc quad(DVec3 a, DVec3 b, DVec3 c, DVec3 d, int m);
ShapeDesc sphere(DVec3 c, double r, int m);
MaterialDesc material(std::string name, MaterialType type, Rgb albedo, Rgb emission = Rgb(0.f),
                      bool two_sided = false, float ior = 1.5f);

// ---------------------------------------------------------------------------------------------- scene building

// Every position of the scene (camera position and look_at, vertices, sphere centres) mapped p → p·scale + offset
// and every radius multiplied by scale: the same picture, the same radiance, in other world coordinates.
SceneDesc transformed(SceneDesc s, double scale, DVec3 offset);

// A built-in scene (cornell, cornell-spheres, shadertoy) at width × height pixels.
SceneDesc builtin_at(const std::string& name, int width, int height);

// "No bounce limit" for a furnace: 1 << 30, or bdpt's kMaxBdptBounces (it stores its subpaths), where a series
// of ratio ρ ≤ 0.9 loses below 1e-46 of its sum.
inline int unlimited_bounces(Estimator est) { return est == Estimator::Bdpt ? kMaxBdptBounces : 1 << 30; }

// The furnace: a closed sphere of radius 1 with uniform two-sided emission Le and albedo rho, the camera inside
// (off-centre so cosines vary). Every path sees Le at every vertex: L = Le·(1−ρ^(k+1))/(1−ρ) after k bounces,
// Le/(1−ρ) with Russian roulette and no bounce limit.
SceneDesc furnace(Rgb Le, Rgb rho, int max_bounces, int rr_depth, Estimator est);
double furnace_expected(double Le, double rho, int max_bounces, bool unbounded);

// The white furnace: a unit sphere of the given material seen from outside under uniform background radiance 1.
// Albedo 1 (mirror, diffuse) or a lossless dielectric gives exactly 1 in expectation for every estimator; with
// `cosine` (and diffuse albedo 1) exactly 1 per sample.
SceneDesc white_furnace(MaterialType type, Estimator est, float albedo = 1.f, float ior = 1.5f);

// A closed room [0,1]³ with white floor, ceiling, back and front walls, a red and a green wall, a quad light
// below the ceiling and a diffuse ball; the camera inside. With huge_spheres each of the six walls is a sphere
// of radius radius_factor (× the room size) whose surface passes through the wall's four corners (so the six
// spheres overlap along every edge and close the room); otherwise the walls are parallelograms. The two images
// differ only by the spheres' sagitta (≤ 0.25/radius_factor of the room): equal within noise.
SceneDesc wall_room(bool huge_spheres, double radius_factor = 1e5);

// The same six walls (spheres or quads) with uniform two-sided emission Le and albedo rho, nothing else: a
// furnace with corners and edges, whose value is furnace_expected().
SceneDesc wall_room_furnace(bool huge_spheres, double radius_factor, double Le, double rho, int max_bounces,
                            int rr_depth, Estimator est);

// A 3×3 cluster of tiny spheres of radius radius_factor (× the distance 1 to the camera), 4 radii apart, seen
// through a narrow field of view (the cluster fills the middle of the image). emissive: the spheres emit 1 on a
// black background and max_bounces is 0, so every sample is exactly 0 or 1 and the image mean is the covered
// fraction of the image plane. Otherwise the spheres are diffuse with albedo 0.5 under background radiance 1
// (a convex object: one bounce then escape), so each sample is 0.5 on a sphere and 1 beside it and the image
// mean is 1 − 0.5·coverage: a ray re-hitting its own sphere (acne) would return 0.25 and lower it.
SceneDesc tiny_spheres(double radius_factor, bool emissive, Estimator est = Estimator::Cosine);
// The exact covered fraction of the image plane: each sphere projects to an ellipse of area
// π·r²·√(|c|²−r²)/(c_z²−r²)^(3/2) on the plane at distance 1 (c = centre in camera space, c_z along the view).
double tiny_spheres_coverage(const SceneDesc& s);

// Light-tightness: the camera inside a closed enclosure of half-size 1 centred at the origin, diffuse albedo 0.8
// inside, with bright emitters outside (background 1, a two-sided emitting quad and an emitting sphere, both of
// radiance 1e4). Any ray or shadow ray slipping through the enclosure reaches an emitter, so the image must be
// exactly 0 everywhere.
enum class Enclosure { Box12, Box6, Sphere };  // 12 triangles, 6 parallelograms, a sphere of radius 1
enum class View {
  Interior,  // a wide view from an off-centre point: every kind of bounce
  Vertex,    // a 1e-4° view centred on a corner where 3 faces (6 triangles) meet: rays within ulps of it
  Edge,      // the same, centred on the middle of an edge between two faces
  Diagonal,  // the same, centred on a face's centre, i.e. on the diagonal shared by its two triangles
  Grazing    // the camera 1e-6 from a wall, looking along it: rays (nearly) parallel to the face
};
const char* to_string(Enclosure e);
const char* to_string(View v);
SceneDesc light_tight(Enclosure enclosure, View view, Estimator est);

// Adds a closed axis-aligned box (outward front normals) as 12 triangles or 6 parallelograms.
void add_box(SceneDesc& s, DVec3 center, double half_size, int material, bool triangles);

// Scenes that invite NaN and Inf. Each is rendered with every estimator; film.rejected() must stay 0.
struct NamedScene {
  std::string name;
  SceneDesc scene;
};
std::vector<NamedScene> hazard_scenes(int size);

// --------------------------------------------------------------------------------------------------- statistics

// z with P(Z > z) = p for a standard normal Z (0 < p < 1).
double normal_upper_quantile(double p);
// Two-sided Bonferroni bound: P(any of m standard normal |z| exceeds it) ≤ alpha.
double bonferroni_z(double alpha, int m);
// Upper alpha-quantile of χ²_dof divided by dof (Wilson–Hilferty): the bound on a mean of dof squared z-scores.
double chi2_mean_bound(double alpha, int dof);

// The false-alarm probability of each statistical verdict (a fixed seed makes each verdict deterministic; this is
// the chance that a correct tracer fails it for a given seed).
inline constexpr double kAlpha = 1e-5;

// Renders spp samples per pixel in one pass (threads 0 = all hardware threads).
Film render(const SceneDesc& s, int spp, int threads = 0);
// The same, or no film and the reason when the scene is refused (compile_scene throws std::invalid_argument,
// e.g. for geometry beyond the range the tracer represents): the matrix reports the refusal as a row.
std::optional<Film> render_unless_refused(const SceneDesc& s, int spp, int threads, std::string& refusal);

// Image mean and its standard error from the film's per-pixel variance (pixels are independent).
struct MeanSE {
  glm::dvec3 mean{0.0}, se{0.0};
};
MeanSE film_mean(const Film& f);

// b×b-pixel block means and the variances of those means (from the film's per-pixel variance of the mean).
struct Blocks {
  int width = 0, height = 0;
  std::vector<glm::dvec3> mean, var;
};
Blocks blocks_of(const Film& f, int b);

// Block-by-block agreement of two independent renders of the same image: z = Δ/√(σa²+σb²) per block and
// channel. Passes when max |z| is below the Bonferroni bound for alpha over all z-scores and the mean z² is below
// the χ² bound for alpha, with one degree of freedom per block (the three channels of a block are strongly
// correlated, so counting them as one is the conservative choice). Blocks where both variances are 0 must agree
// to float rounding (1e-5 relative) or get z = ∞.
struct Agreement {
  int n = 0;
  double max_abs_z = 0.0, mean_z2 = 0.0;
  double z_bound = 0.0, z2_bound = 0.0;
  bool pass = false;
};
Agreement compare_blocks(const Film& a, const Film& b, int block, double alpha = kAlpha);

// Number of pixels whose mean is not exactly 0 in some channel, and of pixels with a non-finite mean.
int nonzero_pixels(const Film& f);
int nonfinite_pixels(const Film& f);

}  // namespace pt::stress
