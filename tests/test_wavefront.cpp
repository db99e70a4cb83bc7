// The wavefront path loop (integrators/wavefront.h) against the scalar loop: the same samples must give the same
// radiance bit for bit, on every built-in scene, estimator and sampler.
#include <doctest/doctest.h>

#include <chrono>
#include <cstring>
#include <thread>

#include "integrators/wavefront.h"
#include "render/renderer.h"
#include "scene/scene_json.h"
#include "test_helpers.h"

using namespace pt;
using namespace pt::test;

namespace {

struct LoopResult {
  std::vector<float> image;
  uint64_t rays = 0, samples = 0;
};

// Two passes (2 then 1 sample per pixel, so the second continues each pixel's sample numbering) on 2 threads.
LoopResult render_with(const Scene& scene, RenderSettings settings, PathLoop loop) {
  settings.path_loop = loop;
  Film film(scene.width, scene.height);
  Renderer r(2);
  LoopResult out;
  for (int spp : {2, 1}) {
    const PassStats ps = r.render_pass(scene, settings, film, spp);
    out.rays += ps.rays;
    out.samples += ps.samples;
  }
  out.image = film.mean_image();
  return out;
}

void check_loops_agree(const SceneDesc& desc) {
  const auto scene = compile_scene(desc);
  const LoopResult a = render_with(*scene, desc.render, PathLoop::Scalar);
  const LoopResult b = render_with(*scene, desc.render, PathLoop::Wavefront);
  CHECK(a.samples == 3ull * desc.width * desc.height);
  CHECK(b.samples == a.samples);
  CHECK(b.rays == a.rays);
  REQUIRE(a.image.size() == b.image.size());
  CHECK(std::memcmp(a.image.data(), b.image.data(), a.image.size() * sizeof(float)) == 0);
}

template <class Sampler>
bool has_batch_kernel(const Scene& scene, const RenderSettings& settings) {
  return select_batch_kernel<Sampler>(scene, settings) != nullptr;
}

}  // namespace

TEST_CASE("wavefront: the scalar loop's image and ray count, bit for bit, on every built-in scene") {
  for (const std::string& name : builtin_scene_names()) {
    SceneDesc desc = load_scene(name);
    desc.width = 40;  // 3 × 2 tiles, the last ones partial
    desc.height = 24;
    for (SamplerType sampler : {SamplerType::Sobol, SamplerType::Independent}) {
      for (Estimator est : {Estimator::Uniform, Estimator::Cosine, Estimator::Nee, Estimator::Mis}) {
        desc.render.sampler = sampler;
        desc.render.estimator = est;
        INFO(name << " " << std::string(to_string(sampler)) << " " << std::string(to_string(est)));
        check_loops_agree(desc);
      }
    }
  }
}

TEST_CASE("wavefront: the same through the generic kernel, a mesh in a BVH and no roulette") {
  SceneDesc desc = load_scene("cornell-spheres");
  desc.width = desc.height = 20;
  desc.render.generic_kernel = true;
  check_loops_agree(desc);
  desc.render.generic_kernel = false;
  desc.render.russian_roulette_depth = -1;
  desc.render.max_bounces = 30;
  check_loops_agree(desc);
  // A mesh of more than kBvhMinPolygons triangles lives in the BVH: the wavefront loop queries it ray by ray.
  SceneDesc bunny = load_scene(std::string(PT_SCENES_DIR) + "/cornell-bunny.json");
  bunny.width = bunny.height = 16;
  REQUIRE_FALSE(compile_scene(bunny)->polygon_bvh.empty());
  check_loops_agree(bunny);
}

TEST_CASE("wavefront: the shading lanes agree with the scalar loop for lights seen from behind, two-sided and triangular") {
  // cornell plus a one-sided square light standing upright in the room (half the room sees its back), then the
  // same light two-sided, then a triangular light (not a parallelogram: those lanes take the scalar path).
  SceneDesc desc = load_scene("cornell");
  desc.width = 40;
  desc.height = 24;
  MaterialDesc lamp;
  lamp.name = "upright lamp";
  lamp.albedo = Rgb(0.f);
  lamp.emission = Rgb(3.f, 2.f, 1.f);
  desc.materials.push_back(lamp);
  const int m = static_cast<int>(desc.materials.size()) - 1;
  desc.shapes.push_back(stress::quad({200, 100, 250}, {350, 100, 250}, {350, 250, 250}, {200, 250, 250}, m));
  for (Estimator est : {Estimator::Nee, Estimator::Mis}) {
    desc.render.estimator = est;
    desc.materials[static_cast<size_t>(m)].two_sided = false;
    CAPTURE(std::string(to_string(est)));
    check_loops_agree(desc);
    desc.materials[static_cast<size_t>(m)].two_sided = true;
    check_loops_agree(desc);
  }
  ShapeDesc& shape = desc.shapes.back();
  REQUIRE(shape.type == ShapeType::Quad);
  shape.type = ShapeType::Triangle;  // its first three vertices
  check_loops_agree(desc);
}

TEST_CASE("wavefront: among other materials and spheres, the lanes shade the Lambertian polygons with the scalar loop's bits") {
  // cornell with a rough metal wall, a plastic floor and a white ball: the kernel for general materials, whose
  // lanes take only the hits on Lambertian polygons (a lane shading the metal or the plastic as Lambertian, or a
  // sphere's hit as a polygon's, changes the image).
  SceneDesc desc = load_scene("cornell");
  desc.width = 40;
  desc.height = 24;
  MaterialDesc metal;
  metal.name = "rough metal";
  metal.type = MaterialType::Conductor;
  metal.albedo = Rgb(0.9f, 0.6f, 0.3f);
  metal.roughness = 0.3f;
  MaterialDesc plastic;
  plastic.name = "blue plastic";
  plastic.type = MaterialType::Plastic;
  plastic.albedo = Rgb(0.2f, 0.4f, 0.8f);
  plastic.roughness = 0.2f;
  desc.materials.push_back(metal);
  desc.materials.push_back(plastic);
  const int n = static_cast<int>(desc.materials.size());
  desc.shapes[4].material = n - 2;  // the right wall
  desc.shapes[0].material = n - 1;  // the floor
  ShapeDesc ball;
  ball.type = ShapeType::Sphere;
  ball.center = DVec3(380.0, 90.0, 120.0);
  ball.radius = 60.0;
  ball.material = desc.shapes[2].material;  // the back wall's white
  desc.shapes.push_back(ball);
  const auto scene = compile_scene(desc);
  REQUIRE((scene->kernel_features() & kFeatureGeneralMaterials) != 0);
  REQUIRE((scene->kernel_features() & kFeatureSpheres) != 0);
  REQUIRE(scene->shading.empty());
  for (Estimator est : {Estimator::Nee, Estimator::Mis}) {
    desc.render.estimator = est;
    CAPTURE(std::string(to_string(est)));
    check_loops_agree(desc);
  }
}

TEST_CASE("wavefront: auto takes it where polygons are searched by brute force, and only there") {
  RenderSettings settings;
  const auto cornell = compile_scene(load_scene("cornell"));
  const auto bunny = compile_scene(load_scene(std::string(PT_SCENES_DIR) + "/cornell-bunny.json"));
  const auto ball = compile_scene(furnace_scene(Rgb(1.f), Rgb(0.5f), 4, -1, Estimator::Mis));
  CHECK(wavefront_pays(*cornell));
  CHECK_FALSE(wavefront_pays(*bunny));  // polygons in a BVH
  CHECK_FALSE(wavefront_pays(*ball));   // a sphere only
  CHECK(has_batch_kernel<SobolSampler>(*cornell, settings));
  CHECK_FALSE(has_batch_kernel<SobolSampler>(*bunny, settings));
  settings.path_loop = PathLoop::Scalar;
  CHECK_FALSE(has_batch_kernel<SobolSampler>(*cornell, settings));
  settings.path_loop = PathLoop::Wavefront;
  CHECK(has_batch_kernel<IndependentSampler>(*ball, settings));
}

TEST_CASE("wavefront: a pass cancelled while paths never end stops and keeps only whole samples") {
  // Albedo 1, no roulette, no bounce limit: no path ever ends, so only the per-bounce poll can stop the batch.
  SceneDesc desc = furnace_scene(Rgb(1.f), Rgb(1.f), 1 << 30, -1, Estimator::Cosine);
  desc.render.path_loop = PathLoop::Wavefront;
  const auto scene = compile_scene(desc);
  Film film(desc.width, desc.height);
  Renderer r(2);
  std::atomic<bool> cancel{false};
  PassStats ps;
  const auto t0 = std::chrono::steady_clock::now();
  std::thread worker([&] { ps = r.render_pass(*scene, desc.render, film, 4, &cancel); });
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  cancel = true;
  worker.join();
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  CHECK(ps.cancelled);
  CHECK(seconds < 5.0);  // a bounce takes microseconds; the bound only catches a loop that ignores the flag
  CHECK(ps.samples == 0);
  CHECK(film.total_count() == 0);
  CHECK(film.next_sample_index(0) == 0);  // the dropped samples will be traced again with the same numbers
}
