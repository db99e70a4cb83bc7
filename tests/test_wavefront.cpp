// The wavefront path loop (integrators/wavefront.h) against the scalar loop: the same samples must give the same
// radiance bit for bit, on every built-in scene, estimator and sampler.
#include <doctest/doctest.h>

#include <chrono>
#include <fstream>
#include <cstring>
#include <set>
#include <thread>

#include "geometry/alpha_mask.h"
#include "integrators/wavefront.h"
#include "materials/texture.h"
#include "render/renderer.h"
#include "scene/scene_json.h"
#include "skip.h"
#include "test_helpers.h"
#include "uv_scenes.h"

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

TEST_CASE("wavefront: the scalar loop's bits on users' scenes: glTF, thin lens, textures, normal maps, kept instances, cut-outs in a BVH") {
  // Since auto runs the wavefront on every scene, each kind of scene a user brings must give the scalar loop's
  // image: these run through a BVH (or the instances' two levels), textures, normal maps and cut-out filters.
  std::vector<std::pair<std::string, SceneDesc>> scenes;
  scenes.emplace_back("torus-and-gem.glb", load_scene(std::string(PT_SCENES_DIR) + "/torus-and-gem.glb"));
  scenes.emplace_back("cornell-gltf (thin lens)", load_scene(std::string(PT_SCENES_DIR) + "/cornell-gltf.json"));
  scenes.emplace_back("ball.obj (texture, normal map)", load_scene(std::string(PT_SCENES_DIR) + "/ball.obj"));
  const std::string engine = "/usr/share/assimp/models/glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb";
  if (std::ifstream(engine).good()) {
    SceneDesc d = load_scene(engine);
    d.render.instancing = Instancing::Keep;  // the instances' own hierarchy, not placed polygons
    scenes.emplace_back("2CylinderEngine.glb, instances kept", d);
  } else {
    skip_for_missing("assimp-testmodels", "the instanced engine's part of this test");
  }
  {
    // 80 cut-out blockers (160 triangles: a BVH) above a floor lit by a sun straight down.
    SceneDesc d;
    look_down_from_4(d, 40.0);
    d.render.max_bounces = 3;
    MaterialDesc floor, blocker;
    floor.name = "floor";
    floor.albedo = Rgb(0.5f);
    blocker.name = "blocker";
    blocker.albedo = Rgb(0.7f);
    auto mask = std::make_shared<AlphaMask>();
    mask->alpha = make_texture(2, 1, {0, 0, 0, 1, 1, 1}, TextureWrap::Clamp, TextureWrap::Clamp, "half");
    mask->cutoff = 0.5f;
    blocker.cutout = mask;
    d.materials = {floor, blocker};
    auto shading = std::make_shared<std::vector<TriangleShading>>();
    add_uv_square(d, *shading, 0.0, 10.0, 0);
    for (int i = 0; i < 80; ++i) add_uv_square(d, *shading, 6.0 + 0.01 * i, 1.0 + 0.1 * i, 1, 1.f, true);
    d.shading = shading;
    PunctualLightDesc sun;
    sun.kind = PunctualKind::Directional;
    sun.direction = DVec3(0.3, -1, 0.2);
    sun.intensity = Rgb(2.f);
    d.punctual_lights = {sun};
    scenes.emplace_back("cut-outs in a BVH", d);
  }
  for (auto& entry : scenes) {
    const std::string name = entry.first;  // a plain variable: clang 14 cannot capture a structured binding
    SceneDesc& desc = entry.second;
    desc.width = 24;
    desc.height = 16;
    const auto scene = compile_scene(desc);
    if (name == "cut-outs in a BVH") {
      REQUIRE(scene->has_cutouts());
      REQUIRE_FALSE(scene->polygon_bvh.empty());
    }
    if (name.rfind("2CylinderEngine", 0) == 0) REQUIRE_FALSE(scene->instances.empty());
    // Each has a material the shading lanes take (an untextured Lambertian or rough glTF one: the box's walls,
    // the floor under the cut-outs, the studio's ground under the OBJ ball, the gold, the engine's parts).
    INFO(name);
    CHECK(shading_lanes_apply(*scene, scene->kernel_features()));
    if (name == "torus-and-gem.glb") {
      // A smooth gold and the crystal alone: Dirac lobes, which the lanes take too (the scalar loop's bits below).
      SceneDesc smooth = desc;
      for (MaterialDesc& m : smooth.materials) m.roughness = 0.f;
      smooth.render.estimator = Estimator::Mis;
      const auto polished = compile_scene(smooth);
      CHECK(shading_lanes_apply(*polished, polished->kernel_features()));
      check_loops_agree(smooth);
      // Rough glass alone, which the lanes take too (its light samples on both sides of the smooth-shaded mesh).
      SceneDesc frosted = smooth;
      for (MaterialDesc& m : frosted.materials) m.type = MaterialType::Dielectric, m.roughness = 0.3f;
      const auto rough_glass = compile_scene(frosted);
      CHECK(shading_lanes_apply(*rough_glass, rough_glass->kernel_features()));
      check_loops_agree(frosted);
    }
    for (Estimator est : {Estimator::Nee, Estimator::Mis}) {
      desc.render.estimator = est;
      INFO(name << " " << std::string(to_string(est)));
      check_loops_agree(desc);
    }
  }
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

TEST_CASE("wavefront: the shading lanes sample every kind of light with the scalar loop's bits") {
  // cornell's walls lit by each kind of light the lanes take from the scalar sample_li (its own lamp, sampled by
  // area in the lanes, stays): a point light and a spot (punctual: no MIS weight), a glowing ball (a sphere
  // light), a constant background (a light at infinity: an unbounded shadow ray), a directional light.
  SceneDesc desc = load_scene("cornell");
  desc.width = 40;
  desc.height = 24;
  PunctualLightDesc point;
  point.kind = PunctualKind::Point;
  point.position = DVec3(150.0, 400.0, 200.0);
  point.intensity = Rgb(2e4f, 1.5e4f, 1e4f);
  PunctualLightDesc spot = point;
  spot.kind = PunctualKind::Spot;
  spot.position = DVec3(450.0, 450.0, 400.0);
  spot.direction = DVec3(-0.3, -1.0, 0.2);
  spot.inner_cone = 0.3;
  spot.outer_cone = 0.6;
  PunctualLightDesc directional;
  directional.kind = PunctualKind::Directional;
  directional.direction = DVec3(0.2, -1.0, 0.5);  // in through the open front, onto the floor
  directional.intensity = Rgb(0.5f);
  MaterialDesc glow;
  glow.name = "glowing ball";
  glow.albedo = Rgb(0.f);
  glow.emission = Rgb(4.f, 6.f, 8.f);
  desc.materials.push_back(glow);
  ShapeDesc ball;
  ball.type = ShapeType::Sphere;
  ball.center = DVec3(400.0, 80.0, 150.0);
  ball.radius = 40.0;
  ball.material = static_cast<int>(desc.materials.size()) - 1;
  desc.shapes.push_back(ball);
  const auto check = [&](const char* lights) {
    const auto scene = compile_scene(desc);
    REQUIRE(shading_lanes_apply(*scene, scene->kernel_features()));
    for (Estimator est : {Estimator::Nee, Estimator::Mis}) {
      desc.render.estimator = est;
      CAPTURE(std::string(lights));
      CAPTURE(std::string(to_string(est)));
      check_loops_agree(desc);
    }
  };
  desc.punctual_lights = {point, spot};
  check("lamp, point, spot, sphere");
  desc.punctual_lights = {directional};
  desc.environment.type = EnvironmentType::Constant;
  desc.environment.radiance = Rgb(0.3f, 0.4f, 0.5f);
  check("lamp, sphere, directional, background");
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

// Scenes of spheres alone: the kernels for spheres without polygons shade in the lanes too (they did not before
// session 48: shading_lanes_apply refused every scene without polygons), and give the scalar loop's bits, images,
// feature buffers and ray counts. One scene has a sphere of each kind of material under the sun and sky (the
// kernel for any material); the other Lambertian spheres lit by an emitting sphere (the Lambert kernel).
TEST_CASE("wavefront: scenes of spheres alone shade in the lanes with the scalar loop's bits") {
  const std::string sky = R"({
    "camera": {"position": [0, 120, -700], "look_at": [0, 70, 0], "up": [0, 1, 0], "fov_deg": 40},
    "film": {"width": 40, "height": 24},
    "render": {"max_bounces": 8, "sampler": "sobol", "russian_roulette_depth": 2},
    "environment": {"type": "sky", "sun_direction": [-0.45, 0.5, -0.74], "turbidity": 3, "sun": true, "scale": 0.5},
    "materials": {
      "ground": {"type": "diffuse", "albedo": [0.35, 0.33, 0.3]},
      "gold": {"type": "conductor", "metal": "gold", "roughness": 0.15},
      "mirror": {"type": "conductor", "metal": "silver", "roughness": 0},
      "glass": {"type": "dielectric", "ior": 1.5, "roughness": 0},
      "frost": {"type": "dielectric", "ior": 1.5, "roughness": 0.3},
      "plastic": {"type": "plastic", "albedo": [0.7, 0.08, 0.05], "ior": 1.5, "roughness": 0.2},
      "wax": {"type": "subsurface", "albedo": [0.999, 0.995, 0.98], "ior": 1.3, "g": 0}
    },
    "shapes": [
      {"type": "sphere", "center": [0, -100000, 0], "radius": 100000, "material": "ground"},
      {"type": "sphere", "center": [-200, 60, 120], "radius": 60, "material": "mirror"},
      {"type": "sphere", "center": [-60, 60, -40], "radius": 60, "material": "gold"},
      {"type": "sphere", "center": [80, 55, -120], "radius": 55, "material": "glass"},
      {"type": "sphere", "center": [200, 50, 20], "radius": 50, "material": "plastic"},
      {"type": "sphere", "center": [-180, 30, -160], "radius": 30, "material": "frost"},
      {"type": "sphere", "center": [60, 40, 120], "radius": 40, "material": "wax"}
    ]})";
  const std::string lamp = R"({
    "camera": {"position": [0, 1, -6], "look_at": [0, 0.8, 0], "up": [0, 1, 0], "fov_deg": 45},
    "film": {"width": 32, "height": 24},
    "render": {"max_bounces": 8, "sampler": "sobol", "russian_roulette_depth": 2},
    "materials": {
      "white": {"type": "diffuse", "albedo": [0.75, 0.75, 0.75]},
      "red": {"type": "diffuse", "albedo": [0.7, 0.1, 0.1]},
      "lamp": {"type": "diffuse", "albedo": [0, 0, 0], "emission": [20, 18, 14]}
    },
    "shapes": [
      {"type": "sphere", "center": [0, -1000, 0], "radius": 1000, "material": "white"},
      {"type": "sphere", "center": [0, 0, 1006], "radius": 1000, "material": "white"},
      {"type": "sphere", "center": [-1.2, 0.7, 0.5], "radius": 0.7, "material": "red"},
      {"type": "sphere", "center": [0, 0.4, -1.0], "radius": 0.4, "material": "white"},
      {"type": "sphere", "center": [0.3, 3.2, 0.5], "radius": 0.5, "material": "lamp"}
    ]})";
  for (const auto& [json, general] : {std::pair{sky, true}, std::pair{lamp, false}}) {
    const SceneDesc d = parse_scene(json, general ? "spheres-sky.json" : "spheres-lamp.json");
    const auto scene = compile_scene(d);
    const uint32_t features = scene->kernel_features();
    CAPTURE(features);
    REQUIRE((features & kFeaturePolygons) == 0);
    REQUIRE((features & kFeatureSpheres) != 0);
    REQUIRE(((features & kFeatureGeneralMaterials) != 0) == general);
    CHECK(shading_lanes_apply(*scene, features));
    check_lanes_match_scalar_loop(d);
    for (Estimator est : {Estimator::Nee, Estimator::Mis}) {
      SceneDesc e = d;
      e.render.estimator = est;
      CAPTURE(std::string(to_string(est)));
      check_loops_agree(e);
    }
  }
}

// The order the kernels for any material shade a bounce's hits in (wavefront.h: lane_sort_key): every kind of
// material, which the lanes all take since rough glass joined them, has a key of its own kind (a material the lanes
// take, keyed as one they hand back, would be shaded among those), a miss is Missed; and the batch sorts only where
// the lanes take several kinds.
TEST_CASE("wavefront: each kind of lobe the lanes take has its own sort key, and only scenes of several kinds sort") {
  const auto scene_of = [](std::vector<MaterialDesc> materials) {
    SceneDesc d = load_scene("cornell");
    for (MaterialDesc& m : materials) {
      // (Not "m" + std::to_string(...): GCC 12 flags that here with a false -Wrestrict warning.)
      m.name = std::to_string(d.materials.size());
      m.name.insert(m.name.begin(), 'm');
      d.materials.push_back(m);
    }
    return compile_scene(d);
  };
  std::vector<MaterialDesc> lane_kinds(10);
  lane_kinds[1].type = MaterialType::Plastic, lane_kinds[1].roughness = 0.3f;
  lane_kinds[2].type = MaterialType::MetallicRoughness, lane_kinds[2].roughness = 0.5f;
  lane_kinds[3].type = MaterialType::Conductor, lane_kinds[3].roughness = 0.4f;
  lane_kinds[4].type = MaterialType::Conductor, lane_kinds[4].roughness = 0.4f, lane_kinds[4].metal = MetalPreset::Gold;
  lane_kinds[5].type = MaterialType::Mirror;
  lane_kinds[6].type = MaterialType::Conductor, lane_kinds[6].metal = MetalPreset::Copper;
  lane_kinds[7].type = MaterialType::Dielectric;
  lane_kinds[8].type = MaterialType::Subsurface;
  lane_kinds[9].type = MaterialType::Dielectric, lane_kinds[9].roughness = 0.3f;
  const auto scene = scene_of(lane_kinds);
  const size_t first = scene->materials.size() - lane_kinds.size();
  std::set<LaneSortKey> keys;
  for (size_t i = first; i < scene->materials.size(); ++i) {
    const Material& m = scene->materials[i];
    CAPTURE(i - first);
    const LaneSortKey key = material_sort_key(m);
    CHECK(lane_material(m));
    CHECK(key != LaneSortKey::Scalar);
    CHECK(key != LaneSortKey::Missed);
    CHECK(static_cast<int>(key) < static_cast<int>(LaneSortKey::Count));
    CHECK(keys.insert(key).second);  // a kind of its own
  }
  // An emitter is shaded by its lobe's lanes (its emission, an emission map's texel included, added one lane at a
  // time).
  MaterialDesc lamp;
  lamp.emission = Rgb(3.f);
  lamp.type = MaterialType::Plastic;
  CHECK(material_sort_key(scene_of({lamp})->materials.back()) == LaneSortKey::Plastic);
  lamp.emission_map.texture = make_texture(1, 1, {1, 1, 1}, TextureWrap::Clamp, TextureWrap::Clamp, "white");
  CHECK(material_sort_key(scene_of({lamp})->materials.back()) == LaneSortKey::Plastic);
  lamp.type = MaterialType::Diffuse;
  CHECK(material_sort_key(scene_of({lamp})->materials.back()) == LaneSortKey::Lambert);
  MaterialKeys table;
  table.look_up(*scene);
  CHECK(table.mixed);
  CHECK(lane_sort_key(*scene, Hit{}, false, table) == LaneSortKey::Missed);
  // The cornell box is Lambertian walls and a lamp: one kind, no sort; one metal more makes two.
  const auto cornell = compile_scene(load_scene("cornell"));
  table.look_up(*cornell);
  CHECK_FALSE(table.mixed);
  table.look_up(*scene_of({lane_kinds[3]}));
  CHECK(table.mixed);
}

TEST_CASE("wavefront: auto takes it on every scene, the scalar loop only when asked") {
  RenderSettings settings;
  REQUIRE(settings.path_loop == PathLoop::Auto);
  const auto cornell = compile_scene(load_scene("cornell"));
  const auto bunny = compile_scene(load_scene(std::string(PT_SCENES_DIR) + "/cornell-bunny.json"));
  const auto ball = compile_scene(furnace_scene(Rgb(1.f), Rgb(0.5f), 4, -1, Estimator::Mis));
  settings.estimator = Estimator::Mis;  // describe_path names bdpt's rounds, not a loop
  REQUIRE_FALSE(bunny->polygon_bvh.empty());  // polygons in a BVH
  REQUIRE(ball->polygons.size() == 0);        // a sphere only
  for (const Scene* scene : {cornell.get(), bunny.get(), ball.get()}) {
    settings.path_loop = PathLoop::Auto;
    CHECK(has_batch_kernel<SobolSampler>(*scene, settings));
    CHECK(has_batch_kernel<IndependentSampler>(*scene, settings));
    CHECK(Renderer::describe_path(*scene, settings).rfind("wavefront loop", 0) == 0);
    settings.path_loop = PathLoop::Scalar;
    CHECK_FALSE(has_batch_kernel<SobolSampler>(*scene, settings));
    CHECK(Renderer::describe_path(*scene, settings).rfind("scalar loop", 0) == 0);
  }
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
