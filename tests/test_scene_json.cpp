// Scene files: the built-in scenes, the JSON round trip, and the error messages of malformed input.
#include <doctest/doctest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include <unistd.h>

#include "scene/scene.h"
#include "integrators/russian_roulette.h"
#include "scene/scene_json.h"

using namespace pt;

namespace {

// The message of the SceneError thrown by parse_scene, or "" when it parses.
std::string parse_error(const std::string& text, const std::string& source = "test.json") {
  try {
    parse_scene(text, source);
  } catch (const SceneError& e) {
    return e.what();
  }
  return {};
}

std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  REQUIRE_MESSAGE(at != std::string::npos, "test bug: '" << from << "' not in the base scene");
  return text.replace(at, from.size(), to);
}

uint32_t bits(float f) { return std::bit_cast<uint32_t>(f); }
uint64_t bits(double d) { return std::bit_cast<uint64_t>(d); }

// Bit-exact comparison (so -0 ≠ +0 and 0.1f ≠ the nearest double of 0.1).
void check_same(Vec3 a, Vec3 b, const std::string& what) {
  INFO(what);
  CHECK(bits(a.x) == bits(b.x));
  CHECK(bits(a.y) == bits(b.y));
  CHECK(bits(a.z) == bits(b.z));
}
void check_same(DVec3 a, DVec3 b, const std::string& what) {
  INFO(what);
  CHECK(bits(a.x) == bits(b.x));
  CHECK(bits(a.y) == bits(b.y));
  CHECK(bits(a.z) == bits(b.z));
}

void check_same_scene(const SceneDesc& a, const SceneDesc& b) {
  check_same(a.camera.position, b.camera.position, "camera.position");
  check_same(a.camera.look_at, b.camera.look_at, "camera.look_at");
  check_same(a.camera.up, b.camera.up, "camera.up");
  CHECK(bits(a.camera.fov_deg) == bits(b.camera.fov_deg));
  CHECK(a.camera.fov_axis == b.camera.fov_axis);
  CHECK(a.width == b.width);
  CHECK(a.height == b.height);
  CHECK(a.render.max_bounces == b.render.max_bounces);
  CHECK(a.render.estimator == b.render.estimator);
  CHECK(a.render.russian_roulette_depth == b.render.russian_roulette_depth);
  CHECK(a.render.seed == b.render.seed);
  check_same(a.environment.radiance, b.environment.radiance, "background");
  REQUIRE(a.materials.size() == b.materials.size());
  for (size_t i = 0; i < a.materials.size(); ++i) {
    const MaterialDesc &m = a.materials[i], &n = b.materials[i];
    INFO("material " << i << " " << m.name);
    CHECK(m.name == n.name);
    CHECK(m.type == n.type);
    check_same(m.albedo, n.albedo, "albedo");
    check_same(m.emission, n.emission, "emission");
    CHECK(m.two_sided == n.two_sided);
    CHECK(bits(m.ior) == bits(n.ior));
  }
  REQUIRE(a.shapes.size() == b.shapes.size());
  for (size_t i = 0; i < a.shapes.size(); ++i) {
    const ShapeDesc &s = a.shapes[i], &t = b.shapes[i];
    INFO("shape " << i);
    CHECK(s.type == t.type);
    for (int k = 0; k < 4; ++k) check_same(s.vertices[k], t.vertices[k], "vertex " + std::to_string(k));
    check_same(s.center, t.center, "center");
    CHECK(bits(s.radius) == bits(t.radius));
    CHECK(s.material == t.material);
  }
}

DVec3 polygon_normal(const ShapeDesc& s) {
  return glm::normalize(glm::cross(s.vertices[1] - s.vertices[0], s.vertices[2] - s.vertices[0]));
}

int material_index(const SceneDesc& s, const std::string& name) {
  for (size_t i = 0; i < s.materials.size(); ++i)
    if (s.materials[i].name == name) return static_cast<int>(i);
  return -1;
}

// A small valid scene; the malformed cases below each change one piece of it.
const std::string kBase = R"({
  "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov_deg": 40},
  "film": {"width": 64, "height": 48},
  "render": {"max_bounces": 4, "estimator": "nee", "russian_roulette_depth": 2, "seed": 7},
  "background": [0, 0, 0],
  "materials": {
    "white": {"type": "diffuse", "albedo": [0.5, 0.5, 0.5]},
    "lamp": {"type": "diffuse", "emission": [1, 1, 1], "two_sided": false},
    "glass": {"type": "dielectric", "ior": 1.5}
  },
  "shapes": [
    {"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "white"},
    {"type": "triangle", "vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0]], "material": "lamp"},
    {"type": "quad", "vertices": [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], "material": "glass"}
  ]
})";

struct BadCase {
  const char* from;    // text in kBase ...
  const char* to;      // ... replaced by this
  const char* path;    // expected JSON path in the message ("" for document-level errors)
  const char* reason;  // a phrase the reason must contain
};

const BadCase kBadCases[] = {
    // Syntax.
    {R"("fov_deg": 40})", R"("fov_deg": 40)", "line 16", "unexpected end of input"},
    {R"("seed": 7})", R"("seed": 7,})", "line 4", "syntax error"},
    {R"("glass": {"type": "dielectric", "ior": 1.5})", R"("glass": {"type": "dielectric", "ior": 1.5}})", "line 10",
     "syntax error"},
    // Unknown and duplicate keys.
    {R"("film": {)", R"("flim": {"width": 1}, "film": {)", "flim", "unknown key"},
    {R"("fov_deg": 40})", R"("fov_deg": 40, "foo": 1})", "camera.foo", "unknown key"},
    {R"("seed": 7)", R"("seed": 7, "spp": 16)", "render.spp", "unknown key"},
    {R"("radius": 1,)", R"("radius": 1, "radius": 2,)", "shapes[0].radius", "duplicate key"},
    {R"("glass": {)", R"("white": {"type": "mirror"}, "glass": {)", "materials.white", "duplicate key"},
    {R"("ior": 1.5})", R"("ior": 1.5, "g": 0.1})", "materials.glass.g", "does not apply to a dielectric material"},
    {R"("ior": 1.5})", R"("ior": 1.5, "roughness": 1.5})", "materials.glass.roughness", "[0, 1]"},
    {R"("ior": 1.5})", R"("ior": 1.5, "roughness": -0.1})", "materials.glass.roughness", "[0, 1]"},
    {R"("ior": 1.5})", R"("ior": 1.5, "shine": 1})", "materials.glass.shine", "unknown key"},
    {R"("white": {"type": "diffuse", "albedo": [0.5, 0.5, 0.5]})",
     R"("white": {"type": "conductor", "metal": "brass"})", "materials.white.metal", "unknown metal \"brass\""},
    {R"("white": {"type": "diffuse", "albedo": [0.5, 0.5, 0.5]})",
     R"("white": {"type": "conductor", "metal": "gold", "albedo": [0.5, 0.5, 0.5]})", "materials.white",
     "one of: albedo, metal, or eta and k"},
    {R"("white": {"type": "diffuse", "albedo": [0.5, 0.5, 0.5]})",
     R"("white": {"type": "conductor", "eta": [0.2, 0.9, 1.1]})", "materials.white.k", "missing required key"},
    {R"("white": {"type": "diffuse", "albedo": [0.5, 0.5, 0.5]})",
     R"("white": {"type": "conductor", "eta": [0.2, 0, 1.1], "k": [3, 2, 2]})", "materials.white.eta", "> 0"},
    {R"("white": {"type": "diffuse", "albedo": [0.5, 0.5, 0.5]})",
     R"("white": {"type": "subsurface", "albedo": [0.5, 0.5, 0.5], "g": 1})", "materials.white.g", "(-1, 1)"},
    {R"("white": {"type": "diffuse", "albedo": [0.5, 0.5, 0.5]})",
     R"("white": {"type": "plastic", "albedo": [0.5, 0.5, 0.5], "ior": 0.5})", "materials.white.ior", "[1, 4]"},
    {R"("white": {"type": "diffuse", "albedo": [0.5, 0.5, 0.5]})",
     R"("white": {"type": "subsurface", "roughness": 0.2})", "materials.white.roughness",
     "does not apply to a subsurface material"},
    // The environment.
    {R"("background": [0, 0, 0])", R"("environment": {"type": "studio"})", "environment.type",
     "unknown environment type \"studio\""},
    {R"("background": [0, 0, 0])", R"("background": [0, 0, 0], "environment": {"type": "sky"})", "background",
     "not both"},
    {R"("background": [0, 0, 0])", R"("environment": {"type": "constant"})", "environment.radiance",
     "missing required key"},
    {R"("background": [0, 0, 0])", R"("environment": {"type": "constant", "radiance": [1, -1, 1]})",
     "environment.radiance", ">= 0"},
    {R"("background": [0, 0, 0])", R"("environment": {"type": "sky", "turbidity": 12})", "environment.turbidity",
     "[1.7, 10]"},
    {R"("background": [0, 0, 0])", R"("environment": {"type": "sky", "sun_direction": [0, 0, 0]})",
     "environment.sun_direction", "non-zero"},
    {R"("background": [0, 0, 0])", R"("environment": {"type": "sky", "file": "a.exr"})", "environment.file",
     "does not apply to a sky environment"},
    {R"("background": [0, 0, 0])", R"("environment": {"type": "map"})", "environment.file", "missing required key"},
    {R"("background": [0, 0, 0])", R"("environment": {"type": "map", "file": "no-such-dir/none.exr"})",
     "environment.file", "no-such-dir/none.exr"},
    {R"("background": [0, 0, 0])", R"("environment": {"type": "sky", "scale": -1})", "environment.scale", "must be in [0, 1e+20]"},
    // Keys that do not apply to the type.
    {R"("albedo": [0.5, 0.5, 0.5]})", R"("albedo": [0.5, 0.5, 0.5], "ior": 1.3})", "materials.white.ior",
     "does not apply to a diffuse material"},
    {R"("type": "dielectric", )", R"("type": "dielectric", "albedo": [1, 1, 1], )", "materials.glass.albedo",
     "does not apply to a dielectric material"},
    {R"([0, 1, 0]], "material": "lamp")", R"([0, 1, 0]], "radius": 2, "material": "lamp")", "shapes[1].radius",
     "does not apply to a triangle"},
    // Numbers: finite, in range, integers.
    {R"("radius": 1,)", R"("radius": 1e999,)", "shapes[0].radius", "finite"},
    {R"([0, 1, 0]], "material": "lamp")", R"([0, -1e400, 0]], "material": "lamp")", "shapes[1].vertices[2][1]",
     "finite"},
    {R"("emission": [1, 1, 1])", R"("emission": [1, 1e39, 1])", "materials.lamp.emission[1]", "finite"},
    {R"("radius": 1,)", R"("radius": -1,)", "shapes[0].radius", "must be finite and > 0"},
    {R"("radius": 1,)", R"("radius": 0,)", "shapes[0].radius", "must be finite and > 0"},
    {R"("width": 64)", R"("width": 0)", "film.width", "must be in [1, 16384]"},
    {R"("width": 64)", R"("width": 1e10)", "film.width", "out of range"},
    {R"("height": 48)", R"("height": 48.5)", "film.height", "expected an integer, got 48.5"},
    {R"("max_bounces": 4)", R"("max_bounces": 2.5)", "render.max_bounces", "expected an integer"},
    {R"("max_bounces": 4)", R"("max_bounces": -1)", "render.max_bounces", ">= 0"},
    {R"("russian_roulette_depth": 2)", R"("russian_roulette_depth": -2)", "render.russian_roulette_depth", "-1"},
    {R"("seed": 7)", R"("seed": -7)", "render.seed", "non-negative integer"},
    // Wrong JSON types and array lengths.
    {R"("radius": 1,)", R"("radius": "1",)", "shapes[0].radius", "expected a number, got string"},
    {R"("center": [0, 0, 0])", R"("center": [0, 0])", "shapes[0].center", "expected an array of 3 numbers, got 2"},
    {R"("center": [0, 0, 0])", R"("center": 0)", "shapes[0].center", "expected an array of 3 numbers, got number"},
    {R"("emission": [1, 1, 1])", R"("emission": [1, "1", 1])", "materials.lamp.emission[1]",
     "expected a number, got string"},
    {R"("two_sided": false)", R"("two_sided": "yes")", "materials.lamp.two_sided", "expected true or false"},
    {R"("material": "white"})", R"("material": 0})", "shapes[0].material", "expected a string, got number"},
    {R"("white": {"type": "diffuse", "albedo": [0.5, 0.5, 0.5]})", R"("white": 3)", "materials.white",
     "expected an object, got number"},
    {R"([[0, 0, 0], [1, 0, 0], [0, 1, 0]])", R"([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 1]])", "shapes[1].vertices",
     "exactly 3 vertices, got 4"},
    {R"([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])", R"([[0, 0, 0], [1, 0, 0], [1, 1, 0]])", "shapes[2].vertices",
     "exactly 4 vertices, got 3"},
    {R"([[0, 0, 0], [1, 0, 0], [0, 1, 0]])", R"([[0, 0, 0], [1, 0], [0, 1, 0]])", "shapes[1].vertices[1]",
     "3 numbers"},
    // Enumerations.
    {R"("estimator": "nee")", R"("estimator": "photons")", "render.estimator", "unknown estimator \"photons\""},
    {R"("fov_deg": 40})", R"("fov_deg": 40, "fov_axis": "diagonal"})", "camera.fov_axis", "unknown fov_axis"},
    {R"("type": "sphere")", R"("type": "cube")", "shapes[0].type", "unknown shape type \"cube\""},
    {R"("type": "diffuse", "albedo")", R"("type": "lambert", "albedo")", "materials.white.type",
     "unknown material type"},
    // Missing and empty.
    {R"({"type": "sphere", )", R"({)", "shapes[0].type", "missing required key"},
    {R"("vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0]], )", "", "shapes[1].vertices", "missing required key"},
    {R"(, "material": "white"})", "}", "shapes[0].material", "missing required key"},
    {R"("position": [0, 0, 5], )", "", "camera.position", "missing required key"},
    {R"(, "fov_deg": 40})", "}", "camera.fov_deg", "missing required key"},
    {R"("materials": {)", R"("materials_": {)", "materials_", "unknown key"},
    {R"("shapes": [)", R"("shapes_": [)", "shapes_", "unknown key"},
    {R"("film": {"width": 64, "height": 48},)", R"("film": {"width": 64, "height": 48}, "materials": {},)",
     "materials", "duplicate key"},
    // Semantic (validate_scene).
    {R"("material": "white"})", R"("material": "foo"})", "shapes[0].material", "unknown material \"foo\""},
    {R"([[0, 0, 0], [1, 0, 0], [0, 1, 0]])", R"([[0, 0, 0], [1, 0, 0], [2, 0, 0]])", "shapes[1].vertices",
     "degenerate"},
    {R"([[0, 0, 0], [1, 0, 0], [0, 1, 0]])", R"([[1, 1, 1], [1, 1, 1], [0, 1, 0]])", "shapes[1].vertices",
     "degenerate"},
    {R"([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])", R"([[0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0]])",
     "shapes[2].vertices", "degenerate"},
    {R"([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])", R"([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]])",
     "shapes[2].vertices", "folded"},
    {R"("albedo": [0.5, 0.5, 0.5])", R"("albedo": [0.5, 1.5, 0.5])", "materials.white.albedo", "[0, 1]"},
    {R"("emission": [1, 1, 1])", R"("emission": [1, -1, 1])", "materials.lamp.emission", ">= 0"},
    {R"("ior": 1.5)", R"("ior": 0)", "materials.glass.ior", "> 0"},
    {R"("background": [0, 0, 0])", R"("background": [0, -0.5, 0])", "background", ">= 0"},
    {R"("look_at": [0, 0, 0])", R"("look_at": [0, 0, 5])", "camera.look_at", "must differ from camera.position"},
    {R"("up": [0, 1, 0])", R"("up": [0, 0, 2])", "camera.up", "parallel"},
    {R"("fov_deg": 40)", R"("fov_deg": 180)", "camera.fov_deg", "(0, 180)"},
};

}  // namespace

TEST_CASE("scene_json: the base scene of the malformed cases is valid") {
  CHECK(parse_error(kBase) == "");
}

TEST_CASE("scene_json: malformed scenes name the source, the JSON path and the reason") {
  for (const BadCase& c : kBadCases) {
    const std::string text = replaced(kBase, c.from, c.to);
    const std::string msg = parse_error(text);
    INFO("case: " << c.from << " -> " << c.to << "\nmessage: " << msg);
    REQUIRE(!msg.empty());
    const std::string prefix = std::string("test.json: ") + c.path + (std::string(c.path).rfind("line ", 0) == 0 ? "" : ": ");
    CHECK(msg.rfind(prefix, 0) == 0);
    CHECK(msg.find(c.reason) != std::string::npos);
  }
}

TEST_CASE("scene_json: document-level errors") {
  const auto check = [](const std::string& text, const std::string& prefix, const std::string& reason) {
    const std::string msg = parse_error(text, "bad.json");
    INFO("text: " << text << "\nmessage: " << msg);
    CHECK(msg.rfind(prefix, 0) == 0);
    CHECK(msg.find(reason) != std::string::npos);
  };
  check("", "bad.json: line 1, column 1: ", "unexpected end of input");
  check("[1, 2]", "bad.json: ", "the top level must be an object, got array");
  check(kBase + " x", "bad.json: line 16, column 3: ", "syntax error");
  check("{\"camera\": {\"position\": [0, 0, 5], \"look_at\": [0, 0, 0], \"fov_deg\": 40}, \"shapes\": []}",
        "bad.json: materials: ", "missing required key");
  check(replaced(kBase, R"("white": {"type": "diffuse", "albedo": [0.5, 0.5, 0.5]},)", R"("": {"type": "diffuse"},)"),
        "bad.json: materials: ", "must not be empty");
  // No materials at all, and no shapes at all.
  const std::string camera = R"("camera": {"position": [0, 0, 5], "look_at": [0, 0, 0], "fov_deg": 40})";
  check("{" + camera + R"(, "materials": {}, "shapes": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "a"}]})",
        "bad.json: materials: ", "at least one material");
  check("{" + camera + R"(, "materials": {"a": {"type": "diffuse"}}, "shapes": []})", "bad.json: shapes: ",
        "at least one shape");
  check("{" + camera + R"(, "materials": {"a": {"type": "diffuse"}}})", "bad.json: shapes: ", "missing required key");
  check("{" + camera + R"(, "materials": {"a": {"type": "diffuse"}}, "shapes": {"a": 1}})", "bad.json: shapes: ",
        "expected an array, got object");
  check(R"({"materials": {"a": {"type": "diffuse"}}, "shapes": []})", "bad.json: camera: ", "missing required key");
  // Invalid UTF-8 inside a string is a syntax error.
  check("{\"camera\": \"\xff\"}", "bad.json: line 1, column ", "UTF-8");
}

TEST_CASE("scene_json: defaults of optional fields") {
  const SceneDesc s = parse_scene(R"({
    "camera": {"position": [1, 2, 3], "look_at": [1, 2, 0], "fov_deg": 50},
    "materials": {"d": {"type": "diffuse"}, "m": {"type": "mirror"}, "g": {"type": "dielectric"}},
    "shapes": [{"type": "sphere", "center": [0, 0, -1], "radius": 0.5, "material": "g"}]
  })", "defaults");
  const SceneDesc d;
  CHECK(s.camera.up == DVec3(0, 1, 0));
  CHECK(s.camera.fov_axis == FovAxis::Vertical);
  CHECK(s.width == 512);
  CHECK(s.height == 512);
  CHECK(s.render.max_bounces == d.render.max_bounces);
  CHECK(s.render.estimator == d.render.estimator);
  CHECK(s.render.russian_roulette_depth == d.render.russian_roulette_depth);
  CHECK(s.render.seed == d.render.seed);
  CHECK(s.environment.radiance == Rgb(0.f));
  REQUIRE(s.materials.size() == 3);
  CHECK(s.materials[0].name == "d");
  CHECK(s.materials[0].albedo == Rgb(0.8f));
  CHECK(s.materials[1].albedo == Rgb(1.f));
  CHECK(s.materials[2].ior == 1.5f);
  for (const MaterialDesc& m : s.materials) {
    CHECK(m.emission == Rgb(0.f));
    CHECK(!m.two_sided);
  }
  CHECK(s.shapes[0].material == 2);
}

TEST_CASE("scene_json: russian_roulette_depth \"auto\" is the default, resolves per estimator and round-trips") {
  const auto with = [](const std::string& value) {
    return R"({"camera": {"position": [0, 0, 5], "look_at": [0, 0, 0], "fov_deg": 40},
      "render": {"russian_roulette_depth": )" + value + R"(}, "materials": {"d": {"type": "diffuse"}},
      "shapes": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "d"}]})";
  };
  const SceneDesc a = parse_scene(with(R"("auto")"), "auto");
  CHECK(a.render.russian_roulette_depth == kRouletteDepthAuto);
  CHECK(SceneDesc{}.render.russian_roulette_depth == kRouletteDepthAuto);  // absent = auto
  CHECK(parse_scene(scene_to_json(a), "again").render.russian_roulette_depth == kRouletteDepthAuto);
  CHECK(scene_to_json(a).find(R"("russian_roulette_depth": "auto")") != std::string::npos);
  CHECK(parse_scene(with("4"), "four").render.russian_roulette_depth == 4);
  // Resolved by the estimator that traces: path tracing from bounce 5, bdpt from 1 (3 under an infinite light); a
  // number stays itself.
  CHECK(roulette_depth(kRouletteDepthAuto, false, false) == 5);
  CHECK(roulette_depth(kRouletteDepthAuto, false, true) == 5);
  CHECK(roulette_depth(kRouletteDepthAuto, true, false) == 1);
  CHECK(roulette_depth(kRouletteDepthAuto, true, true) == 3);
  CHECK(roulette_depth(4, true, true) == 4);
  CHECK(roulette_depth(-1, false, false) == -1);
  EnvironmentDesc black, sky, grey;
  sky.type = EnvironmentType::Sky;
  grey.radiance = Rgb(0.f, 0.1f, 0.f);
  CHECK(!lit_from_infinity(black));
  CHECK(lit_from_infinity(sky));
  CHECK(lit_from_infinity(grey));
  // Neither another word nor the sentinel's number is accepted.
  for (const std::string bad : {R"("automatic")", "-2"}) {
    CAPTURE(bad);
    try {
      parse_scene(with(bad), "bad");
      FAIL("accepted");
    } catch (const std::exception& e) {
      CHECK(std::string(e.what()).find("render.russian_roulette_depth") != std::string::npos);
    }
  }
}

TEST_CASE("scene_json: integral numbers are accepted for integer fields, in any JSON spelling") {
  const std::string text = replaced(replaced(kBase, R"("width": 64)", R"("width": 64.0)"), R"("seed": 7)",
                                    R"("seed": 18446744073709551615)");
  const SceneDesc s = parse_scene(replaced(text, R"("height": 48)", R"("height": 4.8e1)"), "t");
  CHECK(s.width == 64);
  CHECK(s.height == 48);
  CHECK(s.render.seed == std::numeric_limits<uint64_t>::max());
}

TEST_CASE("scene_json: materials keep the file's order") {
  const SceneDesc s = parse_scene(R"({
    "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0], "fov_deg": 40},
    "materials": {"zeta": {"type": "diffuse"}, "alpha": {"type": "mirror"}, "mid": {"type": "diffuse"}},
    "shapes": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "mid"},
               {"type": "sphere", "center": [3, 0, 0], "radius": 1, "material": "zeta"}]
  })", "order");
  REQUIRE(s.materials.size() == 3);
  CHECK(s.materials[0].name == "zeta");
  CHECK(s.materials[1].name == "alpha");
  CHECK(s.materials[2].name == "mid");
  CHECK(s.shapes[0].material == 2);
  CHECK(s.shapes[1].material == 0);
}

TEST_CASE("scene_json: built-in scenes") {
  const std::vector<std::string> names = builtin_scene_names();
  CHECK(names == std::vector<std::string>{"cornell", "cornell-spheres", "shadertoy", "materials", "sky"});
  for (const std::string& name : names) {
    INFO(name);
    SceneDesc s;
    REQUIRE_NOTHROW(s = load_scene(name));
    CHECK(validate_scene(s) == "");
    CHECK_NOTHROW(compile_scene(s));
  }
}

TEST_CASE("scene_json: cornell is the Cornell box data") {
  const SceneDesc s = load_scene("cornell");
  CHECK(s.shapes.size() >= 16);
  REQUIRE(s.materials.size() == 4);
  CHECK(s.camera.position == DVec3(278, 273, -800));
  CHECK(s.camera.look_at == DVec3(278, 273, 0));
  CHECK(s.camera.up == DVec3(0, 1, 0));
  CHECK(s.camera.fov_deg == 39.3077);
  CHECK(s.camera.fov_axis == FovAxis::Vertical);
  CHECK(s.width == 512);
  CHECK(s.height == 512);
  CHECK(s.render.max_bounces == 64);
  CHECK(s.render.estimator == Estimator::Auto);
  CHECK(s.render.russian_roulette_depth == kRouletteDepthAuto);
  CHECK(s.environment.radiance == Rgb(0.f));
  const int white = material_index(s, "white"), red = material_index(s, "red"), green = material_index(s, "green"),
            light = material_index(s, "light");
  REQUIRE(white >= 0);
  REQUIRE(red >= 0);
  REQUIRE(green >= 0);
  REQUIRE(light >= 0);
  CHECK(s.materials[white].albedo == Rgb(0.725f, 0.71f, 0.68f));
  CHECK(s.materials[red].albedo == Rgb(0.63f, 0.065f, 0.05f));
  CHECK(s.materials[green].albedo == Rgb(0.14f, 0.45f, 0.091f));
  CHECK(s.materials[light].emission == Rgb(17.f, 12.f, 4.f));
  CHECK(s.materials[light].albedo == Rgb(0.f));
  CHECK(!s.materials[light].two_sided);
  int lights = 0;
  for (const ShapeDesc& sh : s.shapes) {
    CHECK(sh.type == ShapeType::Quad);
    if (sh.material != light) {
      CHECK(is_black(s.materials[sh.material].emission));
      continue;
    }
    ++lights;
    // Both triangles (a,b,c) and (a,c,d) face down.
    const DVec3 n1 = polygon_normal(sh);
    const DVec3 n2 = glm::normalize(glm::cross(sh.vertices[2] - sh.vertices[0], sh.vertices[3] - sh.vertices[0]));
    CHECK(glm::length(n1 - DVec3(0, -1, 0)) < 1e-12);
    CHECK(glm::length(n2 - DVec3(0, -1, 0)) < 1e-12);
    for (const DVec3& v : sh.vertices) CHECK(v.y == 548.7);
  }
  CHECK(lights == 1);
  // The red wall (x ≈ 552) is red and the green wall (x = 0) green.
  for (const ShapeDesc& sh : s.shapes) {
    if (sh.material == red) CHECK(sh.vertices[0].x > 549.0);
    if (sh.material == green) CHECK(sh.vertices[0].x == 0.0);
  }
}

TEST_CASE("scene_json: shadertoy room") {
  const SceneDesc s = load_scene("shadertoy");
  CHECK(s.width == 640);
  CHECK(s.height == 360);
  CHECK(s.camera.position == DVec3(0, 0, 0));
  CHECK(s.camera.look_at == DVec3(0, 0, -1));
  CHECK(s.camera.fov_deg == 90.0);
  CHECK(s.camera.fov_axis == FovAxis::Horizontal);
  CHECK(s.render.max_bounces == 8);
  CHECK(s.render.estimator == Estimator::Cosine);
  REQUIRE(s.shapes.size() == 9);
  int spheres = 0;
  const DVec3 room_centre(0, 0, -30);
  for (const ShapeDesc& sh : s.shapes) {
    const MaterialDesc& m = s.materials[sh.material];
    if (sh.type == ShapeType::Sphere) {
      ++spheres;
      CHECK(sh.radius == 3.0);
      CHECK(sh.center.y == -9.5);
      CHECK(sh.center.z == -30.0);
      continue;
    }
    REQUIRE(sh.type == ShapeType::Quad);
    // Every quad faces into the room.
    CHECK(glm::dot(polygon_normal(sh), room_centre - sh.vertices[0]) > 0.0);
    if (!is_black(m.emission)) {
      CHECK(m.emission == Rgb(20.f, 18.f, 14.f));
      CHECK(m.two_sided);
    }
  }
  CHECK(spheres == 3);
}

TEST_CASE("scene_json: cornell-spheres") {
  const SceneDesc s = load_scene("cornell-spheres");
  const SceneDesc box = load_scene("cornell");
  check_same(s.camera.position, box.camera.position, "camera");
  CHECK(s.render.max_bounces == 64);
  CHECK(s.render.estimator == Estimator::Auto);
  const int chrome = material_index(s, "chrome"), glass = material_index(s, "glass");
  REQUIRE(chrome >= 0);
  REQUIRE(glass >= 0);
  CHECK(s.materials[chrome].type == MaterialType::Mirror);
  CHECK(s.materials[chrome].albedo == Rgb(0.95f));
  CHECK(s.materials[glass].type == MaterialType::Dielectric);
  CHECK(s.materials[glass].ior == 1.5f);
  int spheres = 0, quads = 0;
  for (const ShapeDesc& sh : s.shapes) {
    if (sh.type == ShapeType::Quad) ++quads;
    if (sh.type != ShapeType::Sphere) continue;
    ++spheres;
    CHECK(sh.radius == 100.0);
    if (sh.material == chrome) CHECK(sh.center == DVec3(400, 100, 350));
    if (sh.material == glass) CHECK(sh.center == DVec3(170, 100, 180));
  }
  CHECK(spheres == 2);
  CHECK(quads == 6);
}

TEST_CASE("scene_json: round trip of the built-in scenes is exact") {
  for (const std::string& name : builtin_scene_names()) {
    INFO(name);
    const SceneDesc s = load_scene(name);
    const std::string json = scene_to_json(s);
    const SceneDesc t = parse_scene(json, "roundtrip");
    check_same_scene(s, t);
    CHECK(scene_to_json(t) == json);
  }
  // The files in scenes/ are in scene_to_json's form: saving an unmodified built-in scene reproduces its file.
  for (const std::string& name : builtin_scene_names()) {
    INFO(name);
    CHECK(scene_to_json(load_scene(name)) == std::string(*builtin_scene_json(name)));
  }
  // Floats are written in their short form, not as the double nearest to the float.
  const std::string json = scene_to_json(load_scene("cornell"));
  CHECK(json.find("[0.725, 0.71, 0.68]") != std::string::npos);
  CHECK(json.find("[278, 273, -800]") != std::string::npos);
}

TEST_CASE("scene_json: round trip of awkward values is exact") {
  SceneDesc s;
  s.camera.position = {0.1 + 0.2, -0.0, 7e11 + 1.0 / 3.0};  // far, within kMaxCameraDistance of the shapes
  s.camera.look_at = {1.0 / 3.0, 5e-324, -7.25};
  s.camera.up = {std::nextafter(0.0, 1.0), 1.0, 0.1 + 0.7};
  s.camera.fov_deg = std::nextafter(60.0, 0.0);
  s.camera.fov_axis = FovAxis::Horizontal;
  s.width = 1;
  s.height = 16384;
  s.render.max_bounces = 0;
  s.render.estimator = Estimator::Uniform;
  s.render.russian_roulette_depth = -1;
  s.render.seed = std::numeric_limits<uint64_t>::max();
  s.environment.radiance = {0.1f, 1e-40f, kMaxRadiance};  // the largest radiance the tracer represents
  MaterialDesc a;
  a.name = "quote \" back\\slash ü \t";
  a.albedo = {1.f / 3.f, std::nextafter(1.f, 0.f), 0.f};
  a.emission = {-0.f, 0.f, 0.f};
  a.two_sided = true;
  MaterialDesc b;
  b.name = "glass";
  b.type = MaterialType::Dielectric;
  b.ior = 1.333333333f;
  b.emission = {std::nextafter(kMaxRadiance, 0.f), 1e-45f, 0.3f};
  MaterialDesc c;
  c.name = "mirror";
  c.type = MaterialType::Mirror;
  c.albedo = {0.95f, 0.9500001f, 0.1f};
  s.materials = {a, b, c};
  ShapeDesc tri;
  tri.type = ShapeType::Triangle;
  tri.vertices = {DVec3(0.1, 0.2, 0.3), DVec3(1e-9, 1.0, 1e9), DVec3(-2.5, 0.7, 1.0 / 7.0), DVec3(0.0)};
  tri.material = 2;
  ShapeDesc quad;
  quad.type = ShapeType::Quad;
  quad.vertices = {DVec3(0, 0, 0), DVec3(0.1, 0, 0), DVec3(0.1, 0.1, 0), DVec3(0, 0.1, 0)};
  quad.material = 0;
  ShapeDesc sphere;
  sphere.type = ShapeType::Sphere;
  sphere.center = {1e-300, 123456789.123456789, -0.1};
  sphere.radius = 0.1 + 0.7;
  sphere.material = 1;
  s.shapes = {tri, quad, sphere};
  REQUIRE(validate_scene(s) == "");

  const std::string json = scene_to_json(s);
  INFO(json);
  SceneDesc t;
  REQUIRE_NOTHROW(t = parse_scene(json, "awkward"));
  check_same_scene(s, t);
  CHECK(scene_to_json(t) == json);
}

TEST_CASE("scene_json: scene_to_json rejects a dangling material index") {
  SceneDesc s = load_scene("cornell");
  s.shapes[0].material = 99;
  CHECK_THROWS_AS(scene_to_json(s), std::invalid_argument);
}

TEST_CASE("scene_json: files and built-in names") {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("pt_scene_json_test_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string good = (dir / "good.json").string();
  const std::string bad = (dir / "bad.json").string();
  {
    std::ofstream(good) << scene_to_json(load_scene("shadertoy"));
    std::ofstream(bad) << replaced(kBase, R"("radius": 1,)", R"("radius": -3,)");
  }
  SceneDesc s;
  REQUIRE_NOTHROW(s = load_scene(good));
  CHECK(s.width == 640);
  REQUIRE_NOTHROW(s = load_scene_file(good));

  const auto message = [](const std::string& spec) -> std::string {
    try {
      load_scene(spec);
    } catch (const SceneError& e) {
      return e.what();
    }
    return {};
  };
  CHECK(message(bad) == bad + ": shapes[0].radius: must be finite and > 0");

  const std::string missing = (dir / "missing.json").string();
  std::string msg = message(missing);
  CHECK(msg.rfind(missing + ": cannot open", 0) == 0);
  // Anything ending in .json is a file, even without a '/'.
  msg = message("no-such-scene.json");
  CHECK(msg.rfind("no-such-scene.json: cannot open", 0) == 0);
  // Anything with a '/' is a file, even without .json.
  msg = message(dir.string());
  CHECK(msg.rfind(dir.string() + ": cannot open", 0) == 0);
  // Otherwise a built-in name; the error lists them.
  msg = message("cornel");
  CHECK(msg.find("cornel") == 0);
  CHECK(msg.find("cornell, cornell-spheres, shadertoy") != std::string::npos);
  // Built-in scenes name themselves "builtin:NAME" in messages.
  CHECK(builtin_scene_json("cornell").has_value());
  CHECK(!builtin_scene_json("nope").has_value());

  fs::remove_all(dir);
}

TEST_CASE("scene_json: a mesh shape reads an OBJ file (triangulated, transformed, zero-area faces left out)") {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("pt_mesh_test_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  // A unit square as one quad face (triangulated into two), a triangle, and a zero-area triangle.
  std::ofstream(dir / "m.obj") << "# test mesh\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 2 0 0\n"
                                  "f 1 2 3 4\nf 1 2 5\nf 1 2 6\n";
  const auto scene_with = [&](const std::string& mesh) {
    std::string text(builtin_scene_json("cornell").value());
    const std::string first = R"("shapes": [)";
    return text.replace(text.find(first), first.size(), first + "\n" + mesh + ",");
  };
  const std::string mesh = R"({"type": "mesh", "file": "m.obj", "material": "red",
      "transform": {"scale": [2, 3, 4], "rotate_axis": [0, 0, 1], "rotate_deg": 90, "translate": [10, 20, 30]}})";
  const SceneDesc base = load_scene("cornell");
  const SceneDesc s = parse_scene(scene_with(mesh), "mesh.json", dir.string());
  REQUIRE(s.shapes.size() == base.shapes.size() + 3);
  // (x, y, z) → scale (2x, 3y, 4z) → 90° about z: (−3y, 2x, 4z) → + (10, 20, 30).
  const auto expect = [](double x, double y, double z) { return DVec3(-3 * y + 10, 2 * x + 20, 4 * z + 30); };
  int red = -1;
  for (size_t m = 0; m < s.materials.size(); ++m)
    if (s.materials[m].name == "red") red = static_cast<int>(m);
  std::vector<std::array<DVec3, 3>> got;
  for (int i = 0; i < 3; ++i) {
    const ShapeDesc& sh = s.shapes[i];
    CHECK(sh.type == ShapeType::Triangle);
    CHECK(sh.material == red);
    got.push_back({sh.vertices[0], sh.vertices[1], sh.vertices[2]});
  }
  const std::array<DVec3, 3> tri = {expect(0, 0, 0), expect(1, 0, 0), expect(0, 0, 1)};
  bool found_triangle = false;
  for (const auto& g : got)
    if (glm::length(g[0] - tri[0]) < 1e-12 && glm::length(g[1] - tri[1]) < 1e-12 && glm::length(g[2] - tri[2]) < 1e-12)
      found_triangle = true;
  CHECK(found_triangle);
  // The two halves of the square cover its corners, each corner at its transformed place.
  for (const DVec3 corner : {expect(0, 0, 0), expect(1, 0, 0), expect(1, 1, 0), expect(0, 1, 0)}) {
    bool seen = false;
    for (int i = 0; i < 2; ++i)
      for (const DVec3& v : got[i]) seen = seen || glm::length(v - corner) < 1e-12;
    CHECK(seen);
  }

  const auto message = [&](const std::string& text) -> std::string {
    try {
      parse_scene(text, "mesh.json", dir.string());
    } catch (const SceneError& e) {
      return e.what();
    }
    return "accepted";
  };
  CHECK(message(scene_with(R"({"type": "mesh", "file": "none.obj", "material": "red"})")) ==
        "mesh.json: shapes[0].file: " + (dir / "none.obj").string() + ": cannot open (No such file or directory)");
  // Writes an OBJ file and returns the error of a scene that uses it, less the part naming the file.
  const auto obj_error = [&](const std::string& name, const std::string& obj) {
    std::ofstream(dir / name) << obj;
    const std::string m = message(scene_with(R"({"type": "mesh", "file": ")" + name + R"(", "material": "red"})"));
    const std::string prefix = "mesh.json: shapes[0].file: " + (dir / name).string() + ": ";
    return m.rfind(prefix, 0) == 0 ? m.substr(prefix.size()) : "unexpected: " + m;
  };
  CHECK(obj_error("bad_index.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n") ==
        "a face refers to a vertex the file does not have (it has 3)");
  // Coordinates tinyobjloader would read as 0 without a word.
  CHECK(obj_error("nan.obj", "v 0 0 0\nv 1 0 0\n  v\t0 nan 0\nf 1 2 3\n") ==
        "line 3: vertex coordinate 2 'nan' is not a finite number");
  CHECK(obj_error("junk.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0abc\nf 1 2 3\n") ==
        "line 3: vertex coordinate 3 '0abc' is not a finite number");
  CHECK(obj_error("huge.obj", "v 0 0 0\nv 1e39 0 0\nv 0 1 0\nf 1 2 3\n") ==
        "line 2: vertex coordinate 1 '1e39' is not a finite number");
  CHECK(obj_error("short.obj", "v 0 0 0\nv 1 0\nv 0 1 0\nf 1 2 3\n") == "line 2: vertex coordinate 3 is missing");
  CHECK(obj_error("flat.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n") == "the mesh has no triangle of non-zero area");
  CHECK(message(scene_with(R"({"type": "mesh", "file": "m.obj", "material": "red", "transform": {"scale": 0}})")) ==
        "mesh.json: shapes[0].transform.scale: must not be 0 (it flattens the object)");
  CHECK(message(scene_with(R"({"type": "mesh", "file": "m.obj", "material": "red", "smooth": true})")) ==
        "mesh.json: shapes[0].smooth: unknown key (expected one of: type, name, file, material, transform)");
  CHECK(message(scene_with(R"({"type": "mesh", "file": "m.obj", "material": "nope"})")) ==
        "mesh.json: shapes[0].material: unknown material \"nope\"");
  fs::remove_all(dir);
}

TEST_CASE("scene_json: the Cornell box's blocks are groups, five quads each, at the published coordinates") {
  const SceneDesc s = load_scene("cornell");
  REQUIRE(s.objects.size() == 2);
  CHECK(s.objects[0].name == "short block");
  CHECK(s.objects[1].name == "tall block");
  for (size_t i = 0; i < 2; ++i) {
    CHECK(s.objects[i].kind == ObjectKind::Group);
    CHECK(s.objects[i].first_shape == 6 + 5 * i);
    CHECK(s.objects[i].shape_count == 5);
    CHECK(s.objects[i].transform == ObjectTransform{});
  }
  // The blocks' top faces in the Cornell data (graphics.cornell.edu/online/box/data.html).
  CHECK(s.shapes[6].vertices[0] == DVec3(130, 165, 65));
  CHECK(s.shapes[11].vertices[0] == DVec3(423, 330, 247));
  CHECK(object_containing(s, 5) == std::nullopt);  // the light stands alone
  CHECK(object_containing(s, 6) == 0u);
  CHECK(object_containing(s, 10) == 0u);
  CHECK(object_containing(s, 15) == 1u);
}

TEST_CASE("scene_json: a group's transform places its shapes, a mirror keeps faces' fronts, and errors name the file's element") {
  const auto scene_with = [](const std::string& first) {
    std::string text(builtin_scene_json("cornell").value());
    const std::string list = R"("shapes": [)";
    return text.replace(text.find(list), list.size(), list + "\n" + first + ",");
  };
  // (x, y, z) → × 2 → 90° about z: (−2y, 2x, 2z) → + (10, 0, 0).
  const std::string group = R"({"type": "group", "name": "g", "material": "red",
      "transform": {"scale": 2, "rotate_axis": [0, 0, 1], "rotate_deg": 90, "translate": [10, 0, 0]},
      "shapes": [{"type": "triangle", "vertices": [[1, 0, 0], [0, 1, 0], [0, 0, 0]]},
                 {"type": "sphere", "center": [0, 0, 1], "radius": 0.5}]})";
  const SceneDesc s = parse_scene(scene_with(group), "g.json");
  REQUIRE(s.objects.size() == 3);  // the group, then the two blocks
  CHECK(s.objects[0].name == "g");
  CHECK(s.objects[0].shape_count == 2);
  CHECK(s.objects[1].first_shape == 8);
  const auto near = [](DVec3 a, DVec3 b) { return glm::length(a - b) < 1e-12; };
  CHECK(near(s.shapes[0].vertices[0], DVec3(10, 2, 0)));
  CHECK(near(s.shapes[0].vertices[1], DVec3(8, 0, 0)));
  CHECK(near(s.shapes[0].vertices[2], DVec3(10, 0, 0)));
  CHECK(near(s.shapes[1].center, DVec3(10, 0, 2)));
  CHECK(s.shapes[1].radius == 1.0);
  // Written back in the group's own coordinates with its transform; read again, the same to rounding.
  const std::string json = scene_to_json(s);
  CHECK(json.find(R"("rotate_deg": 90)") != std::string::npos);
  const SceneDesc again = parse_scene(json, "again.json");
  REQUIRE(again.shapes.size() == s.shapes.size());
  CHECK(again.objects[0].transform == s.objects[0].transform);
  for (int k = 0; k < 3; ++k) CHECK(near(again.shapes[0].vertices[k], s.shapes[0].vertices[k]));
  CHECK(near(again.shapes[1].center, s.shapes[1].center));

  // A mirror (x → −x) lists a triangle's vertices the other way round: its front stays on the same side (+z).
  const SceneDesc m = parse_scene(scene_with(R"({"type": "group", "material": "red", "transform": {"scale": [-1, 1, 1]},
      "shapes": [{"type": "triangle", "vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0]]}]})"), "m.json");
  const auto& v = m.shapes[0].vertices;
  CHECK(glm::cross(v[1] - v[0], v[2] - v[0]).z > 0.0);
  CHECK(m.objects[0].name == "group 1");

  const auto message = [&](const std::string& first) -> std::string {
    try {
      parse_scene(scene_with(first), "g.json");
    } catch (const SceneError& e) {
      return e.what();
    }
    return "accepted";
  };
  CHECK(message(R"({"type": "group", "material": "red", "shapes": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "red"}]})") ==
        "g.json: shapes[0].shapes[0].material: a group's shapes take the group's material");
  CHECK(message(R"({"type": "group", "material": "red", "shapes": []})") == "g.json: shapes[0].shapes: a group holds at least one shape");
  CHECK(message(R"({"type": "group", "material": "red", "transform": {"scale": [1, 2, 1]}, "shapes": [{"type": "sphere", "center": [0, 0, 0], "radius": 1}]})") ==
        "g.json: shapes[0].transform: a group with a sphere takes the same scale on every axis");
  CHECK(message(R"({"type": "group", "material": "red", "shapes": [{"type": "sphere", "center": [0, 0, 0], "radiu": 1}]})") ==
        "g.json: shapes[0].shapes[0].radiu: unknown key (expected one of: type, vertices, center, radius, material)");
  CHECK(message(R"({"type": "group", "name": "", "material": "red", "shapes": []})") ==
        "g.json: shapes[0].name: must not be empty (leave the key out for the default name)");
  // validate_scene's complaints name the file's element, not the index among all shapes.
  const std::string tri = R"({"type": "triangle", "vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0]]})";
  const std::string flat = R"({"type": "triangle", "vertices": [[0, 0, 0], [1, 0, 0], [2, 0, 0]]})";
  CHECK(message(R"({"type": "group", "material": "red", "shapes": [)" + tri + "," + flat + "]}").rfind(
            "g.json: shapes[0].shapes[1].vertices: degenerate polygon", 0) == 0);
  CHECK(message(R"({"type": "group", "material": "red", "shapes": [)" + tri + "," + tri + "," + tri + "]}," +
                R"({"type": "triangle", "material": "red", "vertices": [[0, 0, 0], [1, 0, 0], [2, 0, 0]]})")
            .rfind("g.json: shapes[1].vertices: degenerate polygon", 0) == 0);
}

TEST_CASE("scene_json: a mesh is one object, written back as its file (named from where the scene is saved)") {
  namespace fs = std::filesystem;
  const std::string path = std::string(PT_SCENES_DIR) + "/cornell-bunny.json";
  const SceneDesc s = load_scene(path);
  REQUIRE(s.objects.size() == 1);
  CHECK(s.objects[0].kind == ObjectKind::Mesh);
  CHECK(s.objects[0].name == "bunny");
  CHECK(s.objects[0].first_shape == 6);
  CHECK(s.objects[0].shape_count == 3674);
  const std::string json = scene_to_json(s);
  CHECK(json.find(R"("file": "bunny.obj")") != std::string::npos);
  CHECK(json.size() < 4000);  // the reference, not 3674 triangles (~200 bytes each)
  // Saved into another folder, the reference leads from there to the same file: read back, the same triangles.
  const fs::path dir = fs::temp_directory_path() / ("pt_objects_" + std::to_string(::getpid())) / "sub";
  fs::create_directories(dir);
  const std::string moved = scene_to_json(s, dir.string());
  CHECK(moved.find(R"("file": "bunny.obj")") == std::string::npos);
  const SceneDesc back = parse_scene(moved, "moved.json", dir.string());
  REQUIRE(back.shapes.size() == s.shapes.size());
  bool same = true;
  for (size_t i = 0; i < s.shapes.size(); ++i) same = same && s.shapes[i].vertices == back.shapes[i].vertices;
  CHECK(same);
  fs::remove_all(dir.parent_path());
}

TEST_CASE("scene_json: scenes/cornell-bunny.json is the box and the bunny, compiled with a BVH") {
  const SceneDesc s = load_scene(std::string(PT_SCENES_DIR) + "/cornell-bunny.json");
  CHECK(s.shapes.size() == 6 + 3674);
  const auto scene = compile_scene(s);
  CHECK(!scene->polygon_bvh.empty());
}

TEST_CASE("scene_json: a model file alone opens in a studio: the mesh on a ground plane under a sky, framed") {
  const std::string path = "studio_" + std::to_string(getpid()) + ".OBJ";  // any case
  {
    // A unit cube from (1, 2, 3) to (2, 3, 4): 8 vertices, 12 triangles.
    std::ofstream obj(path);
    obj << "v 1 2 3\nv 2 2 3\nv 2 3 3\nv 1 3 3\nv 1 2 4\nv 2 2 4\nv 2 3 4\nv 1 3 4\n"
           "f 1 2 3 4\nf 5 8 7 6\nf 1 5 6 2\nf 2 6 7 3\nf 3 7 8 4\nf 4 8 5 1\n";
  }
  const SceneDesc s = load_scene(path);
  std::filesystem::remove(path);
  REQUIRE(s.shapes.size() == 13);  // 6 quads as 12 triangles, and the ground
  for (size_t i = 0; i < 12; ++i) CHECK(s.shapes[i].material == 0);
  CHECK(s.materials[0].name == "model");
  const ShapeDesc& ground = s.shapes.back();
  CHECK(ground.type == ShapeType::Quad);
  for (int k = 0; k < 4; ++k) CHECK(ground.vertices[k].y == 2.0);  // at the model's lowest point
  // Its front faces up (the camera and the sun are above it).
  const DVec3 n = glm::cross(ground.vertices[1] - ground.vertices[0], ground.vertices[2] - ground.vertices[0]);
  CHECK(n.y > 0.0);
  CHECK(s.environment.type == EnvironmentType::Sky);
  CHECK(s.environment.sun_direction.y > 0.0);
  // Framed: looking at the box's centre, from a distance at which its bounding sphere fills 90 % of the view.
  const DVec3 centre(1.5, 2.5, 3.5);
  CHECK(glm::length(s.camera.look_at - centre) < 1e-12);
  const double radius = 0.5 * std::sqrt(3.0);
  const double distance = glm::length(s.camera.position - centre);
  CHECK(std::asin(radius / distance) * 2.0 == doctest::Approx(0.9 * glm::radians(s.camera.fov_deg)));
  CHECK(s.camera.position.y > centre.y);
  CHECK(validate_scene(s).empty());
  // Bad model files are refused with the file's name.
  CHECK_THROWS_WITH_AS(load_scene("no/such/model.obj"), doctest::Contains("model.obj"), SceneError);
}

TEST_CASE("scene_json: each material type reads, writes and refuses exactly the parameters of its table row") {
  // kMaterialParams (materials/material.h) is the one statement of which keys a type takes; here the reader and
  // the writer are held to it, key by key, for every type. The expected keys are written out per type (the
  // scene-format table), not derived from kMaterialParams.
  const std::vector<std::pair<MaterialType, std::vector<std::string>>> expected = {
      {MaterialType::Diffuse, {"albedo"}},
      {MaterialType::Mirror, {"albedo"}},
      {MaterialType::Conductor, {"albedo", "metal", "eta", "k", "roughness"}},
      {MaterialType::Dielectric, {"ior", "roughness"}},
      {MaterialType::Plastic, {"albedo", "ior", "roughness"}},
      {MaterialType::Subsurface, {"albedo", "ior", "g"}},
      {MaterialType::MetallicRoughness, {"albedo", "ior", "roughness", "metallic"}},
  };
  const std::vector<std::string> all = {"albedo", "metal", "eta", "k", "ior", "roughness", "g", "metallic"};
  const auto value_of = [](const std::string& key) -> std::string {
    if (key == "metal") return "\"gold\"";
    if (key == "albedo" || key == "eta" || key == "k") return "[0.5, 0.5, 0.5]";
    return key == "ior" ? "1.4" : key == "g" ? "0.3" : "0.2";
  };
  for (const auto& [type_, keys_] : expected) {
    const auto& type = type_; const auto& keys = keys_;  // clang 14: lambdas cannot capture bindings
    for (const std::string& key : all) {
      const bool takes_it = std::find(keys.begin(), keys.end(), key) != keys.end();
      std::string text(builtin_scene_json("cornell").value());
      const std::string white = R"("white": {"type": "diffuse", "albedo": [0.725, 0.71, 0.68]})";
      std::string m = R"("white": {"type": ")" + std::string(to_string(type)) + R"(", ")" + key + "\": " + value_of(key);
      if (key == "eta") m += R"(, "k": [0.5, 0.5, 0.5])";
      if (key == "k") m += R"(, "eta": [0.5, 0.5, 0.5])";
      text.replace(text.find(white), white.size(), m + "}");
      INFO(to_string(type) << " with " << key);
      if (!takes_it) {
        std::string error = "accepted";
        try {
          parse_scene(text, "m.json");
        } catch (const SceneError& e) {
          error = e.what();
        }
        CHECK(error.find(key + ": does not apply to a " + to_string(type) + " material") != std::string::npos);
        continue;
      }
      const SceneDesc s = parse_scene(text, "m.json");
      // Written back: the key given (eta with k, k with eta), nothing of another type's.
      const std::string json = scene_to_json(s);
      const size_t at = json.find("\"white\": {");
      REQUIRE(at != std::string::npos);
      const std::string line = json.substr(at, json.find('}', at) - at);
      CHECK(line.find("\"" + key + "\"") != std::string::npos);
      for (const std::string& other : all)
        if (std::find(keys.begin(), keys.end(), other) == keys.end()) CHECK(line.find("\"" + other + "\"") == std::string::npos);
    }
  }
}
