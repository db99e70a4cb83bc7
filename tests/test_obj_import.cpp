// OBJ models' .mtl materials (scene/mtl_material.h, scene/mesh_obj.h): the mapping to the nearest project
// material against hand-computed values, and a scene file's mesh taking its file's materials, saved and read back.
#include <doctest/doctest.h>

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "io/image_io.h"
#include "scene/mesh_obj.h"
#include "scene/mtl_material.h"
#include "scene/scene.h"
#include "scene/scene_json.h"
#include "scene/studio.h"

#include "temp_folder.h"

using namespace pt;

TEST_CASE("obj materials: .mtl parameters map to the nearest project material") {
  std::vector<std::string> warnings;
  MtlParams p;
  p.name = "clay";
  p.kd = Rgb(0.5f, 0.25f, 2.f);  // clamped to [0, 1]
  MaterialDesc d = mtl_material(p, warnings);
  CHECK(d.type == MaterialType::Diffuse);
  CHECK(d.albedo == Rgb(0.5f, 0.25f, 1.f));
  // Ks and Ns: plastic, roughness = (2/(Ns + 2))^¼ (Walter et al. 2007's Beckmann width, α = roughness²).
  p.ks = Rgb(0.5f);
  p.ns = 1000.f;
  d = mtl_material(p, warnings);
  CHECK(d.type == MaterialType::Plastic);
  CHECK(d.roughness == doctest::Approx(std::pow(2.0 / 1002.0, 0.25)).epsilon(1e-6));
  CHECK(d.albedo == Rgb(0.5f, 0.25f, 1.f));
  p.ns = 0.f;  // the widest lobe: α = 1
  CHECK(mtl_material(p, warnings).roughness == doctest::Approx(1.0));
  // Black Kd, coloured Ks: a metal whose F0 is Ks.
  p.kd = Rgb(0.f);
  p.ks = Rgb(0.9f, 0.6f, 0.2f);
  p.ns = 98.f;
  d = mtl_material(p, warnings);
  CHECK(d.type == MaterialType::Conductor);
  CHECK(d.albedo == Rgb(0.9f, 0.6f, 0.2f));
  CHECK(d.roughness == doctest::Approx(std::pow(0.02, 0.25)).epsilon(1e-6));
  // illum 7 (refraction): glass of index Ni; smooth without Ks.
  p.illum = 7;
  p.ni = 1.33f;
  p.ks = Rgb(0.f);
  d = mtl_material(p, warnings);
  CHECK(d.type == MaterialType::Dielectric);
  CHECK(d.ior == doctest::Approx(1.33));
  CHECK(d.roughness == 0.f);
  // An index below 1 is not a glass's: 1.5.
  p.ni = 0.f;
  CHECK(mtl_material(p, warnings).ior == doctest::Approx(1.5));
  // Ke emits; a black lamp emits from both faces.
  MtlParams lamp;
  lamp.name = "lamp";
  lamp.kd = Rgb(0.f);
  lamp.ke = Rgb(10.f, 9.f, 8.f);
  d = mtl_material(lamp, warnings);
  CHECK(d.emission == Rgb(10.f, 9.f, 8.f));
  CHECK(d.two_sided);
  // What is not read is said: a texture. Partial transparency (d < 1) is read: there with probability d.
  warnings.clear();
  MtlParams textured;
  textured.name = "wood";
  textured.textures = {"bump"};
  textured.dissolve = 0.4f;
  d = mtl_material(textured, warnings);
  REQUIRE(warnings.size() == 1);
  CHECK(warnings[0].find("wood: bump") != std::string::npos);
  REQUIRE(d.cutout);
  CHECK(d.cutout->blend);
  CHECK(d.cutout->factor == 0.4f);
  // Opaque (d = 1) and refracting glass (d < 1 with illum 7: transparency by refraction) have no mask.
  textured.dissolve = 1.f;
  CHECK_FALSE(mtl_material(textured, warnings).cutout);
  textured.dissolve = 0.4f;
  textured.illum = 7;
  CHECK_FALSE(mtl_material(textured, warnings).cutout);
}

namespace {


const char* kTwoMaterialsObj =
    "mtllib two.mtl\n"
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nv 0 0 1\n"
    "usemtl paint\nf 1 2 3\n"
    "usemtl chrome\nf 2 4 3\n"
    "usemtl nowhere\nf 1 3 5\n";
const char* kTwoMaterialsMtl =
    "newmtl paint\nKd 0.8 0.1 0.1\nKs 0 0 0\n"
    "newmtl chrome\nKd 0 0 0\nKs 0.9 0.9 0.9\nNs 200\n";

std::string scene_text(const std::string& mesh) {
  return R"({"camera": {"position": [0.5, 0.5, 5], "look_at": [0.5, 0.5, 0], "up": [0, 1, 0], "fov_deg": 40},
    "film": {"width": 16, "height": 16}, "render": {"max_bounces": 4, "estimator": "auto"}, "background": [1, 1, 1],
    "materials": {"white": {"type": "diffuse", "albedo": [0.5, 0.5, 0.5]}},
    "shapes": [)" + mesh + "]}";
}

}  // namespace

TEST_CASE("obj materials: a mesh without a material takes its .mtl materials, saved and read back as overrides") {
  test::TempFolder f("obj");
  f.write("tri.obj", kTwoMaterialsObj);
  f.write("two.mtl", kTwoMaterialsMtl);
  const SceneDesc s = parse_scene(scene_text(R"({"type": "mesh", "file": "tri.obj"})"), "s.json", f.dir.string());
  REQUIRE(s.shapes.size() == 3);
  const auto name = [&](size_t shape) { return s.materials[s.shapes[shape].material].name; };
  CHECK(name(0) == "tri/paint");
  CHECK(name(1) == "tri/chrome");
  CHECK(name(2) == "tri/default");  // a name no library defines: the format's default, diffuse Kd 0.8
  const MaterialDesc& paint = s.materials[s.shapes[0].material];
  CHECK(paint.type == MaterialType::Diffuse);
  CHECK(paint.albedo == Rgb(0.8f, 0.1f, 0.1f));
  CHECK(s.materials[s.shapes[1].material].type == MaterialType::Conductor);
  CHECK(s.materials[s.shapes[2].material].albedo == Rgb(0.8f));
  CHECK(validate_scene(s).empty());

  // Saved: the mesh names no material; its three are written among the scene's and come back as overrides,
  // an edit included.
  SceneDesc edited = s;
  edited.materials[s.shapes[0].material].albedo = Rgb(0.2f, 0.3f, 0.4f);
  const std::string text = scene_to_json(edited, f.dir.string());
  CHECK(text.find("\"tri/chrome\"") != std::string::npos);
  const SceneDesc back = parse_scene(text, "back.json", f.dir.string());
  REQUIRE(back.shapes.size() == 3);
  CHECK(back.materials[back.shapes[0].material].name == "tri/paint");
  CHECK(back.materials[back.shapes[0].material].albedo == Rgb(0.2f, 0.3f, 0.4f));
  CHECK(back.materials[back.shapes[1].material].name == "tri/chrome");

  // "material" gives one scene material to all faces, as before.
  const SceneDesc one = parse_scene(scene_text(R"({"type": "mesh", "file": "tri.obj", "material": "white"})"), "o.json",
                                    f.dir.string());
  for (const ShapeDesc& sh : one.shapes) CHECK(one.materials[sh.material].name == "white");

  // The model alone takes them too.
  const SceneDesc alone = studio_scene((f.dir / "tri.obj").string());
  CHECK(alone.materials[alone.shapes[1].material].name == "tri/chrome");
  CHECK(alone.materials[alone.shapes.back().material].name == "ground");
}

TEST_CASE("obj materials: a missing library is a warning, and a mesh without materials or \"material\" is refused") {
  test::TempFolder f("obj");
  f.write("lost.obj", "mtllib nowhere.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl paint\nf 1 2 3\n");
  const MeshTriangles mesh = load_obj_mesh((f.dir / "lost.obj").string(), ObjectTransform{});
  REQUIRE(!mesh.warnings.empty());
  CHECK(mesh.warnings[0].find("nowhere.mtl") != std::string::npos);  // then the parser's "material not found"
  CHECK(mesh.materials.empty());
  try {
    parse_scene(scene_text(R"({"type": "mesh", "file": "lost.obj"})"), "s.json", f.dir.string());
    FAIL("a mesh with neither materials nor \"material\" was accepted");
  } catch (const SceneError& e) {
    CHECK(std::string(e.what()).find("shapes[0].material") != std::string::npos);
    CHECK(std::string(e.what()).find("mtllib") != std::string::npos);
  }
}

TEST_CASE("obj materials: map_Kd is the albedo's texture (times Kd), with vt flipped to the image's top-left origin") {
  test::TempFolder f("obj");
  std::filesystem::create_directories(f.dir / "model");
  // 2 x 1: left red, right green.
  write_png_rgb8((f.dir / "model" / "rg.png").string(), 2, 1, {255, 0, 0, 0, 255, 0});
  std::ofstream((f.dir / "model" / "tex.obj").string())
      << "mtllib tex.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0.25 0\nvt 0.75 0\nvt 0.25 1\nusemtl painted\nf 1/1 2/2 3/3\n";
  std::ofstream((f.dir / "model" / "tex.mtl").string()) << "newmtl painted\nKd 0.5 0.5 0.5\nmap_Kd rg.png\n";
  const MeshTriangles mesh = load_obj_mesh((f.dir / "model" / "tex.obj").string(), ObjectTransform{});
  REQUIRE(mesh.materials.size() == 1);
  const MaterialDesc& m = mesh.materials[0];
  REQUIRE(m.albedo_map);
  CHECK(m.albedo == Rgb(0.5f));  // Kd, the texture's factor
  CHECK(m.albedo_map->levels[0].at(0, 0) == Rgb(1.f, 0.f, 0.f));
  REQUIRE(mesh.shading.size() == 1);
  CHECK(mesh.shading[0].has_uv);
  CHECK(mesh.shading[0].uv[0] == Vec2(0.25f, 1.f));  // vt (0.25, 0): the bottom row, v = 1 from the top
  CHECK(mesh.shading[0].uv[2] == Vec2(0.25f, 0.f));
  // In a scene file one folder up: saved with the texture's path from there, read back with the texture.
  const SceneDesc s = parse_scene(scene_text(R"({"type": "mesh", "file": "model/tex.obj"})"), "s.json", f.dir.string());
  const std::string text = scene_to_json(s, f.dir.string());
  INFO(text);
  CHECK(text.find("\"albedo_texture\": \"model/rg.png\"") != std::string::npos);
  const SceneDesc back = parse_scene(text, "back.json", f.dir.string());
  CHECK(back.materials[back.shapes[0].material].albedo_map);
  // A map that cannot be read is a warning; the material keeps Kd.
  std::filesystem::remove(f.dir / "model" / "rg.png");
  const MeshTriangles lost = load_obj_mesh((f.dir / "model" / "tex.obj").string(), ObjectTransform{});
  CHECK(!lost.materials[0].albedo_map);
  bool warned = false;
  for (const std::string& w : lost.warnings) warned = warned || w.find("map_Kd") != std::string::npos;
  CHECK(warned);
}

TEST_CASE("obj materials: norm is a linear tangent-space normal map that stays with the material when saved") {
  test::TempFolder f("obj");
  std::filesystem::create_directories(f.dir / "model");
  write_png_rgb8((f.dir / "model" / "n.png").string(), 1, 1, {191, 128, 221});
  std::ofstream((f.dir / "model" / "bumpy.obj").string())
      << "mtllib bumpy.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nusemtl bumpy\nf 1/1 2/2 3/3\n";
  std::ofstream((f.dir / "model" / "bumpy.mtl").string()) << "newmtl bumpy\nKd 0.5 0.5 0.5\nnorm n.png\n";
  const MeshTriangles mesh = load_obj_mesh((f.dir / "model" / "bumpy.obj").string(), ObjectTransform{});
  REQUIRE(mesh.materials.size() == 1);
  REQUIRE(mesh.materials[0].normal_map.texture);
  CHECK(mesh.materials[0].normal_map.texture->levels[0].at(0, 0).x == doctest::Approx(191.f / 255.f));  // linear
  for (const std::string& w : mesh.warnings) CHECK(w.find("norm") == std::string::npos);  // read, not warned about
  // Saved (the material written among the scene's, overriding the file's) and read back: the map stays.
  const SceneDesc s = parse_scene(scene_text(R"({"type": "mesh", "file": "model/bumpy.obj"})"), "s.json", f.dir.string());
  const SceneDesc back = parse_scene(scene_to_json(s, f.dir.string()), "back.json", f.dir.string());
  CHECK(back.materials[back.shapes[0].material].normal_map.texture);
  // Unreadable: a warning, and a smooth surface.
  std::filesystem::remove(f.dir / "model" / "n.png");
  const MeshTriangles lost = load_obj_mesh((f.dir / "model" / "bumpy.obj").string(), ObjectTransform{});
  CHECK(!lost.materials[0].normal_map.texture);
  bool warned = false;
  for (const std::string& w : lost.warnings) warned = warned || w.find("norm not read") != std::string::npos;
  CHECK(warned);
}

TEST_CASE("obj materials: map_d is a cut-out, by the image's alpha or else its grey level") {
  test::TempFolder f("obj");
  std::filesystem::create_directories(f.dir / "model");
  // Grey 2 x 1 (written as RGB): left black (cut), right white (kept).
  write_png_rgb8((f.dir / "model" / "leaf.png").string(), 2, 1, {0, 0, 0, 255, 255, 255});
  std::ofstream((f.dir / "model" / "leaf.obj").string())
      << "mtllib leaf.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nusemtl leaf\nf 1/1 2/2 3/3\n";
  std::ofstream((f.dir / "model" / "leaf.mtl").string()) << "newmtl leaf\nKd 0.2 0.6 0.1\nmap_d leaf.png\n";
  const MeshTriangles mesh = load_obj_mesh((f.dir / "model" / "leaf.obj").string(), ObjectTransform{});
  REQUIRE(mesh.materials.size() == 1);
  REQUIRE(mesh.materials[0].cutout);
  CHECK_FALSE(mesh.materials[0].cutout->opaque_at(Vec2(0.1f, 0.5f)));
  CHECK(mesh.materials[0].cutout->opaque_at(Vec2(0.9f, 0.5f)));
  for (const std::string& w : mesh.warnings) CHECK(w.find("map_d") == std::string::npos);
  // Unreadable: a warning, and an opaque surface.
  std::filesystem::remove(f.dir / "model" / "leaf.png");
  const MeshTriangles lost = load_obj_mesh((f.dir / "model" / "leaf.obj").string(), ObjectTransform{});
  CHECK(!lost.materials[0].cutout);
  bool warned = false;
  for (const std::string& w : lost.warnings) warned = warned || w.find("map_d not read") != std::string::npos;
  CHECK(warned);
}
