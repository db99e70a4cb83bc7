// Punctual lights (glTF KHR_lights_punctual; lights/light_sampling.h): a point, a spot and a directional light
// over a diffuse plane against the closed forms of their irradiance, the spot's falloff, and the glTF reader's
// placement and units.
#include <doctest/doctest.h>

#include <cmath>
#include <fstream>
#include <iterator>
#include <string>

#include "film/film.h"
#include "lights/light_sampling.h"
#include "scene/estimator_choice.h"
#include "scene/gltf_import.h"
#include "scene/scene.h"
#include "scene/scene_json.h"
#include "temp_folder.h"
#include "test_helpers.h"

using namespace pt;

namespace {

// A diffuse floor (albedo 0.5, y = 0, 20 wide) seen straight down from y = 4 by a narrow camera, black
// surroundings, one bounce: every pixel is direct light alone, L = ρ/π · E.
SceneDesc floor_scene(const PunctualLightDesc& light) {
  SceneDesc s;
  s.camera.position = DVec3(0, 4, 0);
  s.camera.look_at = DVec3(0, 0, 0);
  s.camera.up = DVec3(0, 0, -1);
  s.camera.fov_deg = 2;
  s.width = s.height = 4;
  s.render.max_bounces = 1;
  s.render.estimator = Estimator::Mis;
  MaterialDesc floor;
  floor.name = "floor";
  floor.albedo = Rgb(0.5f);
  s.materials = {floor};
  ShapeDesc q;
  q.type = ShapeType::Quad;
  q.vertices = {DVec3(-10, 0, 10), DVec3(10, 0, 10), DVec3(10, 0, -10), DVec3(-10, 0, -10)};
  s.shapes = {q};
  s.punctual_lights = {light};
  return s;
}

double centre_radiance(const SceneDesc& d, int spp) {
  const Film film = test::render_film(d, spp, 2);
  double sum = 0;
  for (size_t i = 0; i < 16; ++i) sum += film.mean(i).x;
  return sum / 16;
}

}  // namespace

TEST_CASE("punctual lights: a point, a spot and a directional light give the irradiance of their closed forms") {
  const double rho_over_pi = 0.5 / glm::pi<double>();
  // A point light of 20 W/sr at (0, 2, 0): E = I/d² = 5 below it (the pixels see within 0.035 of the centre:
  // cos³ falls by < 0.03 %).
  PunctualLightDesc point;
  point.kind = PunctualKind::Point;
  point.position = DVec3(0, 2, 0);
  point.intensity = Rgb(20.f);
  CHECK(centre_radiance(floor_scene(point), 16) == doctest::Approx(rho_over_pi * 5.0).epsilon(0.002));
  // nee gives the same; uniform and cosine cannot reach it and are refused; auto takes mis (nothing focuses).
  SceneDesc nee = floor_scene(point);
  nee.render.estimator = Estimator::Nee;
  CHECK(centre_radiance(nee, 16) == doctest::Approx(rho_over_pi * 5.0).epsilon(0.002));
  for (Estimator e : {Estimator::Uniform, Estimator::Cosine}) {
    SceneDesc bad = floor_scene(point);
    bad.render.estimator = e;
    CHECK(validate_scene(bad).find("render.estimator") != std::string::npos);
  }
  CHECK(choose_estimator(floor_scene(point)).estimator == Estimator::Mis);
  // Moved sideways by 2: d² = 8, cos = 1/√2: E = 20/8/√2.
  point.position = DVec3(2, 2, 0);
  CHECK(centre_radiance(floor_scene(point), 16) == doctest::Approx(rho_over_pi * 20.0 / 8.0 / std::sqrt(2.0)).epsilon(0.003));
  // A directional light of 3 W/m² travelling down and sideways at 60° from the normal: E = 3 cos 60°.
  PunctualLightDesc sun;
  sun.kind = PunctualKind::Directional;
  sun.direction = DVec3(std::sin(glm::radians(60.0)), -std::cos(glm::radians(60.0)), 0);
  sun.intensity = Rgb(3.f);
  CHECK(centre_radiance(floor_scene(sun), 16) == doctest::Approx(rho_over_pi * 1.5).epsilon(0.002));
  // A spot at (0, 2, 0) pointing down: full inside its inner cone; tilted so the floor's centre lies between the
  // cones, glTF's smooth falloff t² with t = (cos θ − cos outer)/(cos inner − cos outer).
  PunctualLightDesc spot;
  spot.kind = PunctualKind::Spot;
  spot.position = DVec3(0, 2, 0);
  spot.direction = DVec3(0, -1, 0);
  spot.intensity = Rgb(20.f);
  spot.inner_cone = glm::radians(10.0);
  spot.outer_cone = glm::radians(30.0);
  CHECK(centre_radiance(floor_scene(spot), 16) == doctest::Approx(rho_over_pi * 5.0).epsilon(0.002));
  const double tilt = glm::radians(20.0);
  spot.direction = DVec3(std::sin(tilt), -std::cos(tilt), 0);
  const double t = (std::cos(tilt) - std::cos(glm::radians(30.0))) / (std::cos(glm::radians(10.0)) - std::cos(glm::radians(30.0)));
  CHECK(centre_radiance(floor_scene(spot), 16) == doctest::Approx(rho_over_pi * 5.0 * t * t).epsilon(0.01));
  spot.direction = DVec3(std::sin(glm::radians(40.0)), -std::cos(glm::radians(40.0)), 0);  // outside the cone
  CHECK(centre_radiance(floor_scene(spot), 4) == 0.0);
}

namespace {

// A diffuse floor and a diffuse back wall seen from the front at 48×32, lit by `light` alone, two bounces: the
// direct light and one bounce between the two.
SceneDesc floor_and_wall(const PunctualLightDesc& light) {
  SceneDesc s;
  s.camera.position = DVec3(0, 2.5, 6);
  s.camera.look_at = DVec3(0, 0.8, 0);
  s.camera.fov_deg = 50;
  s.width = 48;
  s.height = 32;
  s.render.max_bounces = 2;
  s.render.sampler = SamplerType::Independent;
  MaterialDesc floor, wall;
  floor.name = "floor";
  floor.albedo = Rgb(0.7f, 0.6f, 0.5f);
  wall.name = "wall";
  wall.albedo = Rgb(0.4f, 0.6f, 0.8f);
  s.materials = {floor, wall};
  ShapeDesc q;
  q.type = ShapeType::Quad;
  q.vertices = {DVec3(-4, 0, 3), DVec3(4, 0, 3), DVec3(4, 0, -2), DVec3(-4, 0, -2)};
  q.material = 0;
  s.shapes.push_back(q);
  q.vertices = {DVec3(-4, 0, -2), DVec3(4, 0, -2), DVec3(4, 4, -2), DVec3(-4, 4, -2)};
  q.material = 1;
  s.shapes.push_back(q);
  s.punctual_lights = {light};
  return s;
}

}  // namespace

TEST_CASE("punctual lights: bdpt's strategies each render what next-event estimation does, and bdpt what mis does") {
  // A point light, a spot whose cones cross the floor and the wall, and a directional light at a slant. Each
  // light-subpath strategy alone estimates the paths of its length: light tracing (2, 1) against next-event
  // estimation (1, 2) for the direct light, (3, 1) and the connection (2, 2) against (1, 3) for one bounce; then
  // the whole estimator (whose MIS leaves out the camera's hitting the light, s = 0) against mis, whose own
  // figures the closed forms above check.
  PunctualLightDesc point;
  point.kind = PunctualKind::Point;
  point.position = DVec3(-1, 2.5, 1);
  point.intensity = Rgb(6.f);
  PunctualLightDesc spot = point;
  spot.kind = PunctualKind::Spot;
  spot.direction = glm::normalize(DVec3(0.6, -1, -1));
  spot.inner_cone = glm::radians(15.0);
  spot.outer_cone = glm::radians(35.0);
  PunctualLightDesc sun;
  sun.kind = PunctualKind::Directional;
  sun.direction = glm::normalize(DVec3(0.5, -1, -0.7));
  sun.intensity = Rgb(1.5f);
  using test::blocks_agree;
  using test::render_estimator;
  uint64_t seed = 1;
  for (const auto& [name, light] : {std::pair{"point", point}, std::pair{"spot", spot}, std::pair{"directional", sun}}) {
    const SceneDesc d = floor_and_wall(light);
    REQUIRE(validate_scene(d).empty());
    const std::string n = name;
    const Film direct = render_estimator(d, Estimator::Bdpt, 128, seed++, 1, 2);
    CHECK(blocks_agree(render_estimator(d, Estimator::Bdpt, 256, seed++, 2, 1), direct, n + ": (2, 1) vs (1, 2)"));
    const Film bounce = render_estimator(d, Estimator::Bdpt, 256, seed++, 1, 3);
    CHECK(blocks_agree(render_estimator(d, Estimator::Bdpt, 512, seed++, 3, 1), bounce, n + ": (3, 1) vs (1, 3)"));
    CHECK(blocks_agree(render_estimator(d, Estimator::Bdpt, 256, seed++, 2, 2), bounce, n + ": (2, 2) vs (1, 3)"));
    const Film whole = render_estimator(d, Estimator::Bdpt, 128, seed++);
    CHECK(blocks_agree(whole, render_estimator(d, Estimator::Mis, 256, seed++), n + ": bdpt vs mis"));
  }
}

TEST_CASE("punctual lights: glTF lights sit at their nodes, read one to one, and move with their object") {
  test::TempFolder dir("punctual");
  // A triangle and two lights: a red point light of intensity 10 at (1, 2, 3) (node translation) and a spot
  // turned a quarter about +x (its −z axis then points down, −y).
  std::string buf;
  const float pos[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  buf.append(reinterpret_cast<const char*>(pos), sizeof pos);
  dir.write("tri.bin", buf);
  const std::string r = std::to_string(std::sqrt(0.5));
  dir.write("lit.gltf", R"({"asset": {"version": "2.0"}, "extensionsUsed": ["KHR_lights_punctual"],
    "extensions": {"KHR_lights_punctual": {"lights": [
      {"name": "bulb", "type": "point", "color": [1, 0, 0], "intensity": 10},
      {"type": "spot", "intensity": 4, "spot": {"innerConeAngle": 0.1, "outerConeAngle": 0.5}}]}},
    "buffers": [{"byteLength": 36, "uri": "tri.bin"}],
    "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36}],
    "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"}],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
    "nodes": [{"mesh": 0}, {"translation": [1, 2, 3], "extensions": {"KHR_lights_punctual": {"light": 0}}},
              {"rotation": [-)" + r + ", 0, 0, " + r + R"(], "extensions": {"KHR_lights_punctual": {"light": 1}}}],
    "scenes": [{"nodes": [0, 1, 2]}], "scene": 0})");
  const GltfContents g = load_gltf(dir.path("lit.gltf"));
  REQUIRE(g.lights.size() == 2);
  CHECK(g.lights[0].name == "bulb");
  CHECK(g.lights[0].kind == PunctualKind::Point);
  CHECK(glm::length(g.lights[0].position - DVec3(1, 2, 3)) < 1e-12);
  CHECK(g.lights[0].intensity == Rgb(10.f, 0.f, 0.f));  // candela read as W/sr, never divided by 683
  CHECK(g.lights[1].kind == PunctualKind::Spot);
  CHECK(glm::length(g.lights[1].direction - DVec3(0, -1, 0)) < 1e-9);
  CHECK(g.lights[1].outer_cone == doctest::Approx(0.5));
  // Alone, the file is lit by its lights against black; in a scene file its object's transform moves them.
  const SceneDesc alone = gltf_scene(dir.path("lit.gltf"));
  CHECK(alone.punctual_lights.size() == 2);
  CHECK(alone.environment.type == EnvironmentType::Constant);
  CHECK(alone.environment.radiance == Rgb(0.f));
  const SceneDesc placed = parse_scene(R"({"camera": {"position": [0, 0, 10], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov_deg": 40},
      "materials": {"white": {"type": "diffuse"}},
      "shapes": [{"type": "gltf", "file": "lit.gltf", "transform": {"translate": [100, 0, 0]}}]})", "s.json", dir.dir.string());
  REQUIRE(placed.punctual_lights.size() == 2);
  const auto scene = compile_scene(placed);
  REQUIRE(scene->punctual_lights.size() == 2);
  CHECK(glm::length(DVec3(scene->punctual_lights[0].position) + placed.camera.position - DVec3(101, 2, 3)) < 1e-4);
  // Both take part in the light choice.
  size_t punctual = 0;
  for (const Light& l : scene->lights) punctual += l.delta();
  CHECK(punctual == 2);
  // A light index past the list, or a spot whose cones are out of order, is refused with its path.
  const auto error = [&](const std::string& from, const std::string& to) {
    std::string text;
    {
      std::ifstream in(dir.path("lit.gltf"));
      text.assign(std::istreambuf_iterator<char>(in), {});
    }
    const size_t at = text.find(from);
    REQUIRE(at != std::string::npos);
    text.replace(at, from.size(), to);
    try {
      load_gltf(dir.write("bad.gltf", text));
    } catch (const SceneError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  CHECK(error(R"({"light": 0})", R"({"light": 7})").find("nodes[1].extensions.KHR_lights_punctual.light") != std::string::npos);
  CHECK(error(R"("innerConeAngle": 0.1)", R"("innerConeAngle": 0.7)").find("lights[1].spot") != std::string::npos);
}
