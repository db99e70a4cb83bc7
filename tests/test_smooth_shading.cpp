// Smooth shading (geometry/interaction.h: vertex_shading, shading_normal; integrators/path_tracer.h): the
// terminator offset and the bent normal against hand-computed values, a tessellated sphere with vertex normals
// against the analytic sphere's image, and the models' normals as the OBJ and scene readers hand them on.
#include <doctest/doctest.h>

#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <tuple>
#include <vector>

#include "core/rng.h"
#include "film/film.h"
#include "geometry/interaction.h"
#include "geometry/scene_queries.h"
#include "integrators/wavefront.h"
#include "materials/texture.h"
#include "render/renderer.h"
#include "scene/estimator_choice.h"
#include "scene/scene.h"
#include "scene/scene_json.h"
#include "temp_folder.h"
#include "test_helpers.h"

using namespace pt;
using test::blocks_agree;
using test::render_estimator;

TEST_CASE("smooth shading: the terminator offset of a hand-computed triangle") {
  // Triangle (0,0,0), (1,0,0), (0,1,0) with normals (0,0,1), (1,0,1)/√2, (0,0,1), hit at barycentrics
  // (½, ½, 0), i.e. p = (½, 0, 0). Only vertex 1's tangent plane lies above p: (p − v1)·n1 = −½/√2, so
  // p' = p − ½·(−½/√2)·n1 = p + (1/8, 0, 1/8).
  Interaction it{};
  it.p = Vec3(0.5f, 0.f, 0.f);
  it.ng = it.ns = Vec3(0, 0, 1);
  const Vec3 v[3] = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)};
  const float r = std::sqrt(0.5f);
  // The barycentric gradients of (1,0,0) and (0,1,0) about (0,0,0): b1 = x, b2 = y.
  const std::array<Vec3, 2> kDual{Vec3(1, 0, 0), Vec3(0, 1, 0)};
  vertex_shading({Vec3(0, 0, 1), Vec3(r, 0, r), Vec3(0, 0, 1)}, {Vec2(0, 0), Vec2(1, 0), Vec2(0, 1)}, v, 0.5f, 0.5f,
                 0.f, kDual, it);
  REQUIRE(it.lifted);
  CHECK(it.lift.x == doctest::Approx(0.125).epsilon(1e-6));
  CHECK(it.lift.y == doctest::Approx(0.0));
  CHECK(it.lift.z == doctest::Approx(0.125).epsilon(1e-6));
  // The interpolated normal: (½·(0,0,1) + ½·(r,0,r)) normalised; uv interpolated.
  const Vec3 want = glm::normalize(Vec3(0.5f * r, 0, 0.5f + 0.5f * r));
  CHECK(glm::length(it.ns - want) < 1e-6f);
  CHECK(it.uv.x == doctest::Approx(0.5));
  CHECK(it.uv.y == doctest::Approx(0.0));
  CHECK(it.du_dp == Vec3(1, 0, 0));  // uv = (x, y) on this triangle
  CHECK(it.dv_dp == Vec3(0, 1, 0));
  // A ray leaving on the front starts from p + lift (plus the error offset), one leaving behind from p.
  it.p_error = Vec3(0.f);
  CHECK(glm::length(offset_ray_origin(it, Vec3(0, 0, 1)) - Vec3(0.625f, 0, 0.125f)) < 1e-6f);
  CHECK(glm::length(offset_ray_origin(it, Vec3(0, 0, -1)) - Vec3(0.5f, 0, 0)) < 1e-6f);

  // Flat normals lift nothing; normals that point the other way (a file whose winding disagrees) are turned to
  // the geometric side first, and lift towards it too.
  Interaction flat{};
  flat.p = it.p;
  flat.ng = flat.ns = Vec3(0, 0, 1);
  vertex_shading({Vec3(0, 0, 1), Vec3(0, 0, 1), Vec3(0, 0, 1)}, {}, v, 0.5f, 0.5f, 0.f, kDual, flat);
  CHECK_FALSE(flat.lifted);
  CHECK(flat.ns == Vec3(0, 0, 1));
  Interaction reversed{};
  reversed.p = it.p;
  reversed.ng = reversed.ns = Vec3(0, 0, 1);
  vertex_shading({Vec3(0, 0, -1), Vec3(-r, 0, -r), Vec3(0, 0, -1)}, {}, v, 0.5f, 0.5f, 0.f, kDual, reversed);
  CHECK(glm::length(reversed.ns - want) < 1e-6f);
  CHECK(glm::length(reversed.lift - it.lift) < 1e-6f);
}

TEST_CASE("smooth shading: the bent normal keeps the mirror reflection above the surface and wo in front") {
  // Random geometric normals, shading normals tilted up to 80° from them and viewing directions on either
  // side: the reflection of wo about the normal used must leave at an elevation ≥ min(0.9·|wo·ng|, 0.01) on wo's
  // side (within float rounding), wo must lie in front of it, and a normal that already satisfies this is kept.
  Pcg32 rng(11, 3);
  int bent = 0, kept = 0;
  for (int i = 0; i < 20000; ++i) {
    const Vec3 ng = sample_uniform_sphere(Vec2(rng.next_float(), rng.next_float()));
    const Frame f = Frame::from_normal(ng);
    const float tilt = 1.4f * rng.next_float(), phi = 6.2831853f * rng.next_float();
    const Vec3 ns = f.to_world(Vec3(std::sin(tilt) * std::cos(phi), std::sin(tilt) * std::sin(phi), std::cos(tilt)));
    Vec3 wo = sample_uniform_sphere(Vec2(rng.next_float(), rng.next_float()));
    if (std::abs(glm::dot(wo, ng)) < 1e-3f) continue;
    Interaction it{};
    it.ng = ng;
    it.ns = ns;
    const Vec3 n = shading_normal(it, wo);
    CHECK(std::abs(glm::length(n) - 1.f) < 1e-5f);
    CHECK(glm::dot(n, ng) > 0.f);  // on ng's side, as it.ns is
    const float side = glm::dot(wo, ng) < 0.f ? -1.f : 1.f;
    const Vec3 r = 2.f * glm::dot(n, wo) * n - wo;
    const float t = std::min(0.9f * std::abs(glm::dot(wo, ng)), 0.01f);
    CHECK(side * glm::dot(r, ng) >= t - 2e-5f);
    CHECK(side * glm::dot(wo, n) > 0.f);
    const Vec3 r0 = 2.f * glm::dot(ns, wo) * ns - wo;
    if (side * glm::dot(r0, ng) >= t) {
      CHECK(n == ns);
      ++kept;
    } else {
      ++bent;
    }
  }
  // Both branches ran many times.
  CHECK(bent > 1000);
  CHECK(kept > 1000);
}

namespace {

// A unit sphere at the origin as `rings` × 2·`rings` quads split into triangles (outward fronts), with the exact
// sphere normals at the vertices and a latitude–longitude texture mapping when `smooth`.
void add_tessellated_sphere(SceneDesc& s, int rings, bool smooth) {
  auto shading = std::make_shared<std::vector<TriangleShading>>();
  const int segments = 2 * rings;
  const auto vertex = [&](int i, int j) {
    const double th = glm::pi<double>() * j / rings, ph = 2.0 * glm::pi<double>() * i / segments;
    return DVec3(std::sin(th) * std::cos(ph), std::cos(th), std::sin(th) * std::sin(ph));
  };
  for (int j = 0; j < rings; ++j)
    for (int i = 0; i < segments; ++i) {
      const DVec3 q[4] = {vertex(i, j), vertex(i + 1, j), vertex(i + 1, j + 1), vertex(i, j + 1)};
      const Vec2 quv[4] = {Vec2(float(i) / segments, float(j) / rings), Vec2(float(i + 1) / segments, float(j) / rings),
                           Vec2(float(i + 1) / segments, float(j + 1) / rings),
                           Vec2(float(i) / segments, float(j + 1) / rings)};
      for (const std::array<int, 3>& t : {std::array<int, 3>{0, 1, 2}, std::array<int, 3>{0, 2, 3}}) {
        std::array<DVec3, 3> v{q[t[0]], q[t[1]], q[t[2]]};
        std::array<Vec2, 3> uv{quv[t[0]], quv[t[1]], quv[t[2]]};
        if (degenerate_triangle(v[0], v[1], v[2])) continue;  // the poles' collapsed corners
        if (glm::dot(glm::cross(v[1] - v[0], v[2] - v[0]), v[0] + v[1] + v[2]) < 0.0) {
          std::swap(v[1], v[2]);
          std::swap(uv[1], uv[2]);
        }
        ShapeDesc tri;
        tri.type = ShapeType::Triangle;
        tri.vertices = {v[0], v[1], v[2], DVec3(0.0)};
        if (smooth) {
          TriangleShading sh;
          sh.uv = uv;
          sh.has_uv = true;
          for (int k = 0; k < 3; ++k) sh.normal[k] = Vec3(v[k]);
          tri.shading = static_cast<uint32_t>(shading->size());
          shading->push_back(sh);
        }
        s.shapes.push_back(tri);
      }
    }
  if (smooth) s.shading = shading;
}

// A white sphere lit from the upper right by a large one-sided light, seen from +z, against black: the
// terminator crosses the visible disc. `kind`: 0 the analytic sphere, 1 tessellated flat, 2 tessellated smooth.
SceneDesc lit_sphere_scene(int kind, int rings, double light_size = 3.0) {
  SceneDesc s;
  s.camera.position = DVec3(0, 0, 4);
  s.camera.look_at = DVec3(0.0);
  s.camera.fov_deg = 32;
  s.width = s.height = 64;
  s.render.max_bounces = 1;
  s.render.estimator = Estimator::Mis;
  s.render.seed = 5;
  s.render.sampler = SamplerType::Independent;  // the film's variance is then the error's (test_helpers.h)
  MaterialDesc white, light;
  white.name = "white";
  white.albedo = Rgb(0.8f);
  light.name = "light";
  light.albedo = Rgb(0.f);
  light.emission = Rgb(static_cast<float>(36.0 / (light_size * light_size)));
  s.materials = {white, light};
  if (kind == 0) {
    ShapeDesc sphere;
    sphere.type = ShapeType::Sphere;
    sphere.radius = 1.0;
    s.shapes.push_back(sphere);
  } else {
    add_tessellated_sphere(s, rings, kind == 2);
  }
  // A 3 × 3 light centred at (4, 2.5, -1), facing the origin (its front is its counter-clockwise side).
  const DVec3 c(5, 1, 1), n = glm::normalize(-c);
  const DVec3 u = glm::normalize(glm::cross(n, DVec3(0, 1, 0))), w = glm::cross(n, u);
  ShapeDesc q;
  q.type = ShapeType::Quad;
  const double h = light_size / 2;
  q.vertices = {c - h * u - h * w, c - h * u + h * w, c + h * u + h * w, c + h * u - h * w};
  if (glm::dot(glm::cross(q.vertices[1] - q.vertices[0], q.vertices[2] - q.vertices[0]), n) < 0.0)
    std::swap(q.vertices[1], q.vertices[3]);
  q.material = 1;
  s.shapes.push_back(q);
  return s;
}

}  // namespace

TEST_CASE("smooth shading: a tessellated sphere with vertex normals renders as the analytic sphere") {
  const int spp = 256, rings = 12;
  const Film analytic = test::render_film(lit_sphere_scene(0, rings), spp, 2);
  const Film flat = test::render_film(lit_sphere_scene(1, rings), spp, 2);
  const Film smooth = test::render_film(lit_sphere_scene(2, rings), spp, 2);
  // Pixels well inside the disc (the polygon's silhouette lies inside the circle by up to 1 − cos(7.5°) ≈ 0.9 %
  // of the radius, a fraction of a pixel): the disc of radius R_px·0.9 around the centre.
  const int w = 64;
  const double radius_px = (1.0 / std::tan(glm::radians(16.0)) / std::sqrt(15.0)) * (w / 2.0);
  double flat_sq = 0, smooth_sq = 0, noise_sq = 0, sum = 0;
  int n = 0;
  for (int y = 0; y < w; ++y)
    for (int x = 0; x < w; ++x) {
      const double dx = x + 0.5 - w / 2.0, dy = y + 0.5 - w / 2.0;
      if (std::hypot(dx, dy) > 0.9 * radius_px) continue;
      const size_t i = static_cast<size_t>(y) * w + x;
      const double a = analytic.mean(i).x, f = flat.mean(i).x, sm = smooth.mean(i).x;
      flat_sq += (f - a) * (f - a);
      smooth_sq += (sm - a) * (sm - a);
      noise_sq += 2.0 * analytic.variance_of_mean(i).x;  // E[(x − y)²] of two independent estimates
      sum += a;
      ++n;
    }
  const double mean = sum / n, flat_rms = std::sqrt(flat_sq / n), smooth_rms = std::sqrt(smooth_sq / n),
               noise_rms = std::sqrt(noise_sq / n);
  MESSAGE("mean " << mean << ", rms differences from the analytic sphere: smooth " << smooth_rms << ", flat "
                  << flat_rms << ", noise alone " << noise_rms);
  CHECK(smooth_rms < 1.3 * noise_rms);
  CHECK(flat_rms > 2.0 * noise_rms);
}


// A face without vertex normals in a scene whose other faces have them (scene.cpp gives it its face normal at
// its three corners) is shaded exactly flat: ns is ng to the bit and no ray leaves from a lift. Interpolated and
// normalised, that normal came out an ulp off ng at most points of an oblique face (the check fails there without
// the rule in vertex_shading), and bdpt shaded such a wall as a smooth surface.
TEST_CASE("smooth shading: a face without vertex normals stays exactly flat beside a smooth mesh") {
  const SceneDesc d = lit_sphere_scene(2, 6);
  const auto scene = compile_scene(d);
  const Scene& sc = *scene;
  REQUIRE(!sc.shading.empty());
  const DVec3 c(5, 1, 1), n = glm::normalize(-c);
  const DVec3 u = glm::normalize(glm::cross(n, DVec3(0, 1, 0))), w = glm::cross(n, u);
  const DVec3 from = c + 2.0 * n - sc.world_origin;
  Pcg32 rng(4, 2);
  int hits = 0, off = 0;
  for (int i = 0; i < 2000; ++i) {
    const DVec3 target = c + (2.8 * rng.next_float() - 1.4) * u + (2.8 * rng.next_float() - 1.4) * w - sc.world_origin;
    const Ray ray{Vec3(from), Vec3(glm::normalize(target - from))};
    Hit h;
    if (!intersect_scene<kAllFeatures>(sc, ray, kInfinity, ~0u, h)) continue;
    const Interaction it = make_interaction<kAllFeatures>(sc, ray, h);
    if (sc.light_of(h.prim) < 0) continue;
    ++hits;
    off += it.ns != it.ng || it.lifted;
  }
  MESSAGE(hits << " hits on the light, " << off << " not exactly flat");
  CHECK(hits > 1500);
  CHECK(off == 0);
}

TEST_CASE("smooth shading: the scalar and wavefront loops render the same bits") {
  SceneDesc d = lit_sphere_scene(2, 6);  // 144 triangles: brute force, where auto takes the wavefront
  d.width = d.height = 24;
  d.render.path_loop = PathLoop::Scalar;
  const Film scalar = test::render_film(d, 8, 2);
  d.render.path_loop = PathLoop::Wavefront;
  const Film wavefront = test::render_film(d, 8, 2);
  for (size_t i = 0; i < size_t{24} * 24; ++i) REQUIRE(scalar.mean(i) == wavefront.mean(i));
}

namespace {

// The lit smooth sphere of lit_sphere_scene over a large diffuse floor at y = −1, for paths of two bounces.
SceneDesc sphere_on_floor(int kind, int rings = 12) {
  SceneDesc s = lit_sphere_scene(kind, rings);
  s.width = s.height = 32;
  s.camera.position = DVec3(0, 1.5, 4);
  s.camera.fov_deg = 45;
  MaterialDesc floor;
  floor.name = "floor";
  floor.albedo = Rgb(0.6f, 0.5f, 0.4f);
  s.materials.push_back(floor);
  ShapeDesc f;
  f.type = ShapeType::Quad;
  f.vertices = {DVec3(-8, -1, -8), DVec3(-8, -1, 8), DVec3(8, -1, 8), DVec3(8, -1, -8)};
  f.material = static_cast<int>(s.materials.size()) - 1;
  s.shapes.push_back(f);
  return s;
}

}  // namespace

namespace {

using test::check_lanes_match_scalar_loop;

// The coarse sphere on its floor (sphere_on_floor, six rings) at 24 × 24 pixels for paths of `bounces` bounces,
// Russian roulette from `rr_depth` (scene_desc.h: RenderSettings::russian_roulette_depth).
SceneDesc small_sphere_on_floor(int kind, int bounces, int rr_depth = kRouletteDepthAuto) {
  SceneDesc d = sphere_on_floor(kind, 6);
  d.width = d.height = 24;
  d.render.max_bounces = bounces;
  d.render.russian_roulette_depth = rr_depth;
  return d;
}

// check_lanes_match_scalar_loop on the sphere on its floor (24 × 24 pixels, three bounces), flat (kind 1) and
// smooth-shaded (kind 2), for the cases c < n that set_up(ball, floor, c) makes of its two materials;
// lanes_apply(kind, c) says whether the lanes must run there (shading_lanes_apply).
template <class SetUp, class LanesApply>
void check_lobe_cases(int n, const SetUp& set_up, const LanesApply& lanes_apply) {
  for (const int kind : {1, 2})
    for (int c = 0; c < n; ++c) {
      SceneDesc d = small_sphere_on_floor(kind, 3);
      set_up(d.materials[0], d.materials.back(), c);
      const auto scene = compile_scene(d);
      CAPTURE(kind);
      CAPTURE(c);
      CHECK(shading_lanes_apply(*scene, scene->kernel_features()) == lanes_apply(kind, c));
      check_lanes_match_scalar_loop(d);
    }
}
const auto kAlwaysApply = [](int, int) { return true; };

// The same for long paths (six bounces, roulette from the first), where the lanes always run: holds(scene) says
// that the compiled scene has the lobe a case is about.
template <class SetUp, class Holds>
void check_long_path_cases(int n, const SetUp& set_up, const Holds& holds) {
  for (const int kind : {1, 2})
    for (int c = 0; c < n; ++c) {
      SceneDesc d = small_sphere_on_floor(kind, 6, 1);
      set_up(d.materials[0], d.materials.back(), c);
      const auto scene = compile_scene(d);
      CAPTURE(kind);
      CAPTURE(c);
      CHECK(shading_lanes_apply(*scene, scene->kernel_features()));
      CHECK(holds(*scene));
      check_lanes_match_scalar_loop(d);
    }
}

}  // namespace

// The SIMD shading lanes (integrators/shading_lanes.h) shade the Lambertian hits on a smooth mesh with
// vertex_shading's normal and terminator offset, and hand back to shade_vertex the hits whose normal
// shading_normal would bend: the wavefront loop must still give the scalar loop's bits. A coarse smooth sphere
// (six rings: large lifts, bent normals along its silhouette) on a flat floor (flat faces among smooth ones), seen
// from outside under its light and from inside under a point light (the back faces), three bounces, nee and mis,
// Sobol and independent points, with the feature buffers, whose normal the lanes write at a first hit.
TEST_CASE("smooth shading: the SIMD shading lanes give the scalar loop's bits, outside and inside, features included") {
  SceneDesc outside = sphere_on_floor(2, 6);
  outside.render.max_bounces = 3;
  SceneDesc inside = outside;
  inside.camera.position = DVec3(0.2, -0.3, 0.5);
  inside.camera.look_at = DVec3(-0.5, 0.4, -1.0);
  inside.camera.fov_deg = 70;
  PunctualLightDesc bulb;
  bulb.kind = PunctualKind::Point;
  bulb.position = DVec3(-0.2, 0.4, -0.1);
  bulb.intensity = Rgb(0.8f, 0.7f, 0.5f);
  inside.punctual_lights = {bulb};
  for (const bool in : {false, true}) {
    SceneDesc d = in ? inside : outside;
    const auto scene = compile_scene(d);
    REQUIRE_FALSE(scene->shading.empty());
    REQUIRE(shading_lanes_apply(*scene, scene->kernel_features()));
    CAPTURE(in);
    check_lanes_match_scalar_loop(d);
  }
}

// The lanes shade rough glTF metallic–roughness materials too (layered_value, written once over the number type):
// the same scene with the sphere and the floor in such materials, metallic and not, rough and nearly smooth, and a
// smooth one (its layer's reflection a Dirac lobe over the base) on one of them in turn, flat and smooth-shaded.
TEST_CASE("smooth shading: the SIMD shading lanes give the scalar loop's bits on glTF metallic-roughness materials") {
  struct Lobe {
    float metallic, roughness;
  };
  const Lobe sphere_lobes[] = {{0.f, 1.f}, {0.3f, 0.5f}, {1.f, 0.2f}, {0.f, 0.f}};
  const Lobe floor_lobes[] = {{1.f, 0.6f}, {0.f, 0.04f}, {0.5f, 0.9f}, {0.2f, 0.35f}};
  const auto set_up = [&](MaterialDesc& ball, MaterialDesc& floor, int c) {
    for (MaterialDesc* m : {&ball, &floor}) m->type = MaterialType::MetallicRoughness;
    ball.albedo = Rgb(0.9f, 0.6f, 0.3f);
    ball.metallic = sphere_lobes[c].metallic;
    ball.roughness = sphere_lobes[c].roughness;
    floor.metallic = floor_lobes[c].metallic;
    floor.roughness = floor_lobes[c].roughness;
  };
  check_lobe_cases(4, set_up, kAlwaysApply);
}

// And the plastic, the same coupled lobe with its coat's exact Fresnel (layered_lobe.h), alone and beside glTF's
// lobe in one packet (the lanes then compute both Fresnels and pick one per lane): the sphere and the floor rough,
// nearly smooth and smooth (the smooth coat's reflection a Dirac lobe over the base), flat and smooth-shaded.
TEST_CASE("smooth shading: the SIMD shading lanes give the scalar loop's bits on plastic, beside glTF's lobe") {
  struct Case {
    MaterialType floor_type;
    float sphere_roughness, floor_roughness;
  };
  const Case cases[] = {{MaterialType::Plastic, 0.3f, 0.7f},
                        {MaterialType::MetallicRoughness, 0.05f, 0.4f},
                        {MaterialType::Plastic, 0.f, 0.15f},
                        {MaterialType::MetallicRoughness, 0.6f, 0.f}};
  const auto set_up = [&](MaterialDesc& ball, MaterialDesc& floor, int c) {
    ball.type = MaterialType::Plastic;
    ball.albedo = Rgb(0.7f, 0.1f, 0.05f);
    ball.ior = 1.4f;
    ball.roughness = cases[c].sphere_roughness;
    floor.type = cases[c].floor_type;
    if (floor.type == MaterialType::MetallicRoughness) floor.metallic = 0.3f;
    floor.roughness = cases[c].floor_roughness;
  };
  check_lobe_cases(4, set_up, kAlwaysApply);
}

// And the rough conductor (materials/conductor.h: Schlick's Fresnel through its albedo or a metal's complex index,
// Kulla–Conty's compensation), beside the Lambert, plastic and glTF lobes and itself with the other Fresnel in one
// packet, and beside a smooth one (a Dirac lobe: the next test's); flat and smooth-shaded, textured where smooth.
TEST_CASE("smooth shading: the SIMD shading lanes give the scalar loop's bits on rough conductors") {
  const auto colours = make_texture(2, 2, {0.9f, 0.6f, 0.3f, 0.4f, 0.8f, 0.9f, 0.95f, 0.95f, 0.9f, 0.2f, 0.3f, 0.5f},
                                    TextureWrap::Repeat, TextureWrap::Repeat, "tiles");
  const auto set_up = [&](MaterialDesc& ball, MaterialDesc& floor, int c) {
    ball.type = MaterialType::Conductor;
    ball.albedo = Rgb(0.95f, 0.7f, 0.4f);
    ball.roughness = c == 3 ? 0.f : 0.25f + 0.15f * static_cast<float>(c);
    if (c == 1) ball.metal = MetalPreset::Gold;
    if (c == 2) {
      ball.albedo_map = colours;
      floor.type = MaterialType::Conductor;
      floor.metal = MetalPreset::Copper;
      floor.roughness = 0.6f;
    } else if (c == 1) {
      floor.type = MaterialType::Plastic;
      floor.roughness = 0.4f;
    } else if (c == 3) {
      floor.type = MaterialType::MetallicRoughness;
      floor.roughness = 0.5f;
    }
  };
  check_lobe_cases(4, set_up, kAlwaysApply);
}

// The subsurface BRDF in the lanes (lane_lobes.h: subsurface_f, cosine-sampled) beside the Lambert, plastic and
// rough conductor lobes: forward and backward scattering, a low and a high index (its Fresnel transmittance, the
// refracted cosines), an albedo whose normalisation scales some channels (ss_norm < 1), a black one (no sample).
TEST_CASE("smooth shading: the SIMD shading lanes give the scalar loop's bits on subsurface materials") {
  const auto set_up = [](MaterialDesc& ball, MaterialDesc& floor, int c) {
    ball.type = MaterialType::Subsurface;
    ball.albedo = Rgb(0.95f, 0.6f, 0.3f);
    if (c == 0) {  // forward scattering wax on the Lambert floor
      ball.g = 0.6f, ball.ior = 1.4f;
    } else if (c == 1) {  // backward scattering, a low index, a non-absorbing channel (scaled by ss_norm)
      ball.g = -0.8f, ball.ior = 1.1f, ball.albedo = Rgb(1.f, 0.9f, 0.5f);
      floor.type = MaterialType::Plastic, floor.roughness = 0.4f;
    } else if (c == 2) {  // a high index on a rough conductor floor
      ball.g = 0.f, ball.ior = 2.2f;
      floor.type = MaterialType::Conductor, floor.roughness = 0.3f, floor.metal = MetalPreset::Copper;
    } else {  // black: no sample, beside a subsurface floor
      ball.albedo = Rgb(0.f);
      floor.type = MaterialType::Subsurface, floor.g = 0.3f, floor.ior = 1.5f;
    }
  };
  check_lobe_cases(4, set_up, kAlwaysApply);
}

// Textured materials in the lanes (material_at at each textured hit, one lane at a time, then the lanes): an
// albedo image on the Lambert, glTF and plastic lobes, glTF's metallic–roughness image (whose darkest texels make
// the lobe smooth: a Dirac reflection over the base there), and a normal map, which tilts the shading normal (where
// that bends it too far for the view, the hit goes back to shade_vertex). The sphere has texture coordinates where
// smooth (kind 2); the flat one (kind 1) has none, and its textured hits take shade_vertex. The floor's texture
// coordinates are 0 (one texel).
TEST_CASE("smooth shading: the SIMD shading lanes give the scalar loop's bits on textured materials") {
  std::vector<float> checker, ramp;  // 8 × 8 texels
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 8; ++x) {
      const float c = (x + y) % 2 ? 0.9f : 0.2f;
      checker.insert(checker.end(), {c, 0.5f * c + 0.1f, 0.3f});
      // metallic–roughness: roughness × green (0 to 1 along x: the first column smooth), metallic × blue
      ramp.insert(ramp.end(), {0.f, float(x) / 7.f, float(y) / 7.f});
    }
  const auto colours = make_texture(8, 8, checker, TextureWrap::Repeat, TextureWrap::Repeat, "checker");
  const auto mr = make_texture(8, 8, ramp, TextureWrap::Repeat, TextureWrap::Repeat, "ramp");
  const auto bumps = make_texture(1, 1, {0.7f, 0.55f, 0.9f}, TextureWrap::Repeat, TextureWrap::Repeat, "tilt");
  const auto set_up = [&](MaterialDesc& ball, MaterialDesc& floor, int c) {
    ball.albedo_map = colours;
    if (c == 1 || c == 3) floor.albedo_map = colours;
    if (c == 1) {  // glTF ball with both images; Lambert floor
      ball.type = MaterialType::MetallicRoughness;
      ball.roughness = 0.8f;
      ball.metallic = 1.f;
      ball.metallic_roughness_map.texture = mr;
    } else if (c == 2) {  // plastic ball; glTF floor with the metallic–roughness image
      ball.type = MaterialType::Plastic;
      ball.roughness = 0.4f;
      floor.type = MaterialType::MetallicRoughness;
      floor.roughness = 0.9f;
      floor.metallic = 1.f;
      floor.metallic_roughness_map.texture = mr;
    } else if (c == 3) {  // a normal map on the ball and on the (flat) floor
      ball.normal_map.texture = bumps;
      floor.normal_map.texture = bumps;
    }
  };
  // Textured materials count only where the scene has texture coordinates (the smooth ball's).
  check_lobe_cases(4, set_up, [](int kind, int c) { return kind == 2 || c == 0; });
}

// The Dirac lobes in the lanes (lane_lobes.h: sample_dirac): the mirror, the smooth conductor (Schlick's Fresnel
// and gold's complex index) and smooth glass, which are only sampled (no light sample there), beside the Lambert
// lobe and each other. The glass ball is entered and left (its index inverted inside, total internal reflection),
// a glass floor refracts paths away, a conductor of F0 = 0 reflects only at grazing angles; six bounces, roulette
// from the first (whose worth the refractions' η² scale enters), flat and smooth-shaded, a textured mirror where
// the sphere has texture coordinates, and the feature buffers, whose albedo is tinted through the Dirac vertices
// (FeatureTrace::through_specular).
TEST_CASE("smooth shading: the SIMD shading lanes give the scalar loop's bits on mirrors, smooth metals and smooth glass") {
  const auto colours = make_texture(2, 2, {0.9f, 0.6f, 0.3f, 0.4f, 0.8f, 0.9f, 0.95f, 0.95f, 0.9f, 0.2f, 0.3f, 0.5f},
                                    TextureWrap::Repeat, TextureWrap::Repeat, "tiles");
  const auto set_up = [&](MaterialDesc& ball, MaterialDesc& floor, int c) {
    if (c == 0) {  // a glass ball on the Lambert floor
      ball.type = MaterialType::Dielectric;
      ball.ior = 1.5f;
    } else if (c == 1) {  // a tinted mirror ball on smooth gold
      ball.type = MaterialType::Mirror;
      ball.albedo = Rgb(0.9f, 0.7f, 0.5f);
      floor.type = MaterialType::Conductor;
      floor.metal = MetalPreset::Gold;
    } else if (c == 2) {  // a smooth Schlick conductor ball on a glass floor
      ball.type = MaterialType::Conductor;
      ball.albedo = Rgb(0.6f, 0.9f, 0.95f);
      floor.type = MaterialType::Dielectric;
      floor.ior = 1.33f;
    } else if (c == 3) {  // a textured mirror ball on a glass floor of a high index
      ball.type = MaterialType::Mirror;
      ball.albedo_map = colours;
      floor.type = MaterialType::Dielectric;
      floor.ior = 2.4f;
    } else {  // a smooth Schlick conductor of F0 = 0 (its albedo: the Lambert lobe would absorb everything)
      ball.type = MaterialType::Conductor;
      ball.albedo = Rgb(0.f);
    }
  };
  check_long_path_cases(5, set_up, [](const Scene& scene) { return dirac_lane_material(scene.materials[0]); });
}

// Rough glass in the lanes (lane_lobes.h: dielectric_lobe_value and dielectric_lobe_sample, written once over the
// number type): its light sample on either side of the surface, its reflection or refraction about a visible normal,
// the index inverted inside the ball, total internal reflection, and the η² of each refraction in the roulette's
// worth (six bounces, roulette from the first). Beside the Lambert floor, a smooth glass floor (Dirac lanes in the same
// packet, whose refractions must not overwrite rough glass's), a smooth plastic floor (a smooth layer's Dirac
// reflection), a rough conductor floor, and as the floor itself under a Lambert ball; nearly smooth to very rough,
// indices 1.33 to 2.4, flat and smooth-shaded.
TEST_CASE("smooth shading: the SIMD shading lanes give the scalar loop's bits on rough glass") {
  const auto set_up = [](MaterialDesc& ball, MaterialDesc& floor, int c) {
    MaterialDesc& glass = c == 3 ? floor : ball;
    glass.type = MaterialType::Dielectric;
    glass.roughness = c == 0 ? 0.3f : c == 1 ? 0.05f : c == 2 ? 0.8f : c == 3 ? 0.4f : 0.2f;
    glass.ior = c == 1 ? 1.33f : c == 2 ? 2.4f : 1.5f;
    if (c == 1) {  // on smooth glass
      floor.type = MaterialType::Dielectric;
    } else if (c == 2) {  // on a smooth plastic
      floor.type = MaterialType::Plastic;
      floor.roughness = 0.f;
    } else if (c == 4) {  // on a rough gold floor
      floor.type = MaterialType::Conductor;
      floor.metal = MetalPreset::Gold;
      floor.roughness = 0.3f;
    }
  };
  check_long_path_cases(5, set_up, [](const Scene& scene) {
    return std::any_of(scene.materials.begin(), scene.materials.end(), rough_glass_lane_material);
  });
}

// The lanes shade analytic spheres too (make_interaction's sphere_point in the gather; a ray leaving a sphere may
// hit it again: a refraction into glass, a reflection off its inside). Four spheres in front of the mesh sphere,
// one material each, every lane material in turn: the Lambert, plastic, glTF and rough conductor lobes, a mirror,
// smooth glass, a smooth conductor, a smooth plastic and rough glass, and, handed back to shade_vertex, a textured
// sphere (no texture coordinates); beside a flat (kind 1) and a smooth-shaded mesh (kind 2, whose vertex
// normals the spheres' lanes must not read), six bounces, roulette from the first.
TEST_CASE("smooth shading: the SIMD shading lanes give the scalar loop's bits on analytic spheres of every material") {
  const auto colours = make_texture(2, 2, {0.9f, 0.6f, 0.3f, 0.4f, 0.8f, 0.9f, 0.95f, 0.95f, 0.9f, 0.2f, 0.3f, 0.5f},
                                    TextureWrap::Repeat, TextureWrap::Repeat, "tiles");
  const auto material = [&](int i) {
    MaterialDesc m;
    m.name = "sphere " + std::to_string(i);
    m.albedo = Rgb(0.9f, 0.6f, 0.3f);
    switch (i) {
      case 0: break;  // Lambert
      case 1: m.type = MaterialType::Plastic, m.roughness = 0.3f, m.ior = 1.4f; break;
      case 2: m.type = MaterialType::MetallicRoughness, m.metallic = 0.4f, m.roughness = 0.5f; break;
      case 3: m.type = MaterialType::Conductor, m.metal = MetalPreset::Gold, m.roughness = 0.35f; break;
      case 4: m.type = MaterialType::Mirror; break;
      case 5: m.type = MaterialType::Dielectric, m.ior = 1.5f; break;
      case 6: m.type = MaterialType::Conductor, m.roughness = 0.f; break;
      case 7: m.type = MaterialType::Plastic, m.roughness = 0.f; break;  // its coat's reflection: a Dirac lobe
      case 8: m.type = MaterialType::Dielectric, m.roughness = 0.3f; break;  // rough glass
      default: m.albedo_map = colours; break;  // a textured sphere: shade_vertex
    }
    return m;
  };
  const DVec3 centres[4] = {DVec3(-1.0, -0.55, 1.0), DVec3(1.0, -0.55, 1.0), DVec3(-0.45, 0.1, 1.9),
                            DVec3(0.45, 0.1, 1.9)};
  const double radii[4] = {0.4, 0.4, 0.25, 0.25};
  for (const int kind : {1, 2})
    for (int first = 0; first < 10; first += 4) {
      SceneDesc d = small_sphere_on_floor(kind, 6, 1);
      for (int j = 0; j < 4; ++j) {
        d.materials.push_back(material((first + j) % 10));
        ShapeDesc ball;
        ball.type = ShapeType::Sphere;
        ball.center = centres[j];
        ball.radius = radii[j];
        ball.material = static_cast<int>(d.materials.size()) - 1;
        d.shapes.push_back(ball);
      }
      const auto scene = compile_scene(d);
      CAPTURE(kind);
      CAPTURE(first);
      REQUIRE((scene->kernel_features() & kFeatureSpheres) != 0);
      CHECK(scene->shading.empty() == (kind == 1));
      CHECK(shading_lanes_apply(*scene, scene->kernel_features()));
      check_lanes_match_scalar_loop(d);
    }
}

// Emitters in the lanes (shading_lanes.h: add_lane_emission): an emitting ball of each kind of lobe, on a floor that
// emits too in some cases (two-sided, or through an emission map: its texel at the hit's texture coordinates, the
// smooth ball's or the floor's constant ones), and an emitting analytic sphere: the emission counted whole after a camera ray or a Dirac bounce, MIS-weighted after a lit one,
// exactly once where the lanes hand a hit back to shade_vertex after the gather (the smooth ball's silhouette, whose
// normal shading_normal would bend; the lamp behind the ball, which no light sample reaches from its back). Flat
// (kind 1) and smooth-shaded (kind 2) balls, four bounces, roulette from the first. A plain sphere keeps the lanes on
// where everything else emits (lamps alone do not make them run).
TEST_CASE("smooth shading: the SIMD shading lanes add an emitter's emission with the scalar loop's bits, once") {
  const auto tiles = make_texture(2, 2, {0.9f, 0.6f, 0.3f, 0.4f, 0.8f, 0.9f, 0.95f, 0.95f, 0.9f, 0.2f, 0.3f, 0.5f},
                                  TextureWrap::Repeat, TextureWrap::Repeat, "tiles");
  for (const int kind : {1, 2})
    for (int c = 0; c < 4; ++c) {
      SceneDesc d = small_sphere_on_floor(kind, 4, 1);
      MaterialDesc& ball = d.materials[0];
      MaterialDesc& floor = d.materials.back();
      ball.emission = Rgb(1.5f, 0.9f, 0.4f);
      if (c == 1) {  // a glowing plastic ball over a floor that glows on both faces
        ball.type = MaterialType::Plastic, ball.roughness = 0.3f;
        floor.emission = Rgb(0.05f, 0.1f, 0.2f), floor.two_sided = true;
      } else if (c == 2) {  // a glowing mirror (a Dirac lobe) on a glTF floor
        ball.type = MaterialType::Mirror;
        floor.type = MaterialType::MetallicRoughness, floor.roughness = 0.6f, floor.metallic = 0.5f;
      } else if (c == 3) {  // a textured ball glowing through an emission map; the floor's glow through one too
        ball.albedo_map = tiles;
        ball.emission_map.texture = tiles;
        floor.emission = Rgb(0.3f);
        floor.emission_map.texture = tiles;
      }
      MaterialDesc glow;
      glow.name = "glowing sphere";
      glow.type = MaterialType::Conductor, glow.roughness = 0.4f;
      glow.emission = Rgb(0.8f, 1.6f, 0.8f);
      d.materials.push_back(glow);
      ShapeDesc sphere;
      sphere.type = ShapeType::Sphere;
      sphere.center = DVec3(0.9, -0.6, 1.2);
      sphere.radius = 0.35;
      sphere.material = static_cast<int>(d.materials.size()) - 1;
      d.shapes.push_back(sphere);
      MaterialDesc plain;  // one material that does not emit: the lanes run only in scenes with one
      plain.name = "plain";
      d.materials.push_back(plain);
      sphere.center = DVec3(-0.9, -0.7, 1.4), sphere.radius = 0.25;
      sphere.material = static_cast<int>(d.materials.size()) - 1;
      d.shapes.push_back(sphere);
      const auto scene = compile_scene(d);
      CAPTURE(kind);
      CAPTURE(c);
      CHECK(shading_lanes_apply(*scene, scene->kernel_features()));
      REQUIRE(scene->materials.size() == 5);  // the ball, the lamp, the floor, the glowing sphere, the plain one
      CHECK(lane_material(scene->materials[0]));
      CHECK(lane_material(scene->materials[1]));
      CHECK(lane_material(scene->materials[2]));
      CHECK(lane_material(scene->materials[3]));
      check_lanes_match_scalar_loop(d);
    }
}

namespace {

// A diffuse floor of two triangles lit by a small one-sided square light above it (unseen by the camera); with
// `tilt`, vertex normals that lean towards each triangle's centre, so smooth shading makes the floor's
// brightness differ from the flat floor's over whole regions (|w_light·n_s| against |w_light·n_g|), not only
// within small facets; with `wall`, a flat wall behind it and two bounces.
SceneDesc lit_floor(bool tilt, bool wall = false) {
  SceneDesc s;
  s.camera.position = DVec3(0, 1.5, 5);
  s.camera.look_at = DVec3(0.0);
  s.camera.fov_deg = 50;
  s.width = 48;
  s.height = 32;
  s.render.max_bounces = 1;
  s.render.sampler = SamplerType::Independent;
  MaterialDesc floor, lamp;
  floor.name = "floor";
  floor.albedo = Rgb(0.5f, 0.6f, 0.7f);
  lamp.name = "lamp";
  lamp.albedo = Rgb(0.f);
  lamp.emission = Rgb(20.f);
  s.materials = {floor, lamp};
  const DVec3 a(-10, 0, -10), b(-10, 0, 10), c(10, 0, 10), d(10, 0, -10);  // counter-clockwise from above
  auto shading = std::make_shared<std::vector<TriangleShading>>();
  for (const std::array<DVec3, 3>& v : {std::array<DVec3, 3>{a, b, c}, std::array<DVec3, 3>{a, c, d}}) {
    ShapeDesc t;
    t.type = ShapeType::Triangle;
    t.vertices = {v[0], v[1], v[2], DVec3(0.0)};
    if (tilt) {
      // Each vertex normal leans 22° towards its triangle's centroid, as a bowl's would: every point of the
      // triangle lies above the vertices' tangent planes, so no ray origin is lifted (interaction.h).
      const DVec3 centre = (v[0] + v[1] + v[2]) / 3.0;
      TriangleShading sh;
      for (int k = 0; k < 3; ++k)
        sh.normal[k] = Vec3(glm::normalize(DVec3(0, 1, 0) + 0.4 * glm::normalize(centre - v[k])));
      t.shading = static_cast<uint32_t>(shading->size());
      shading->push_back(sh);
    }
    s.shapes.push_back(t);
  }
  if (tilt) s.shading = shading;
  if (wall) {  // a flat diffuse wall behind, facing the camera: paths of two bounces between it and the floor
    MaterialDesc w;
    w.name = "wall";
    w.albedo = Rgb(0.7f, 0.6f, 0.5f);
    s.materials.push_back(w);
    ShapeDesc q;
    q.type = ShapeType::Quad;
    q.vertices = {DVec3(-10, 0, -3), DVec3(10, 0, -3), DVec3(10, 10, -3), DVec3(-10, 10, -3)};
    q.material = 2;
    s.shapes.push_back(q);
    s.render.max_bounces = 2;
  }
  ShapeDesc l;
  l.type = ShapeType::Quad;  // facing down (counter-clockwise seen from below)
  l.vertices = {DVec3(0.5, 3, -0.5), DVec3(1.5, 3, -0.5), DVec3(1.5, 3, 0.5), DVec3(0.5, 3, 0.5)};
  l.material = 1;
  s.shapes.push_back(l);
  return s;
}

}  // namespace

TEST_CASE("smooth shading: bdpt's light tracing shades with the shading normal as mis does") {
  // One bounce: light → floor → eye. Light tracing alone, (s, t) = (2, 1), reaches the floor's points by the
  // light's emission (geometric cosines) and must weigh them by the shading-normal BSDF f·|w_light·n_s| /
  // |w_light·n_g| (bdpt_vertex.h) to shade as the path tracer does. The flat floor's image (what the plain f
  // gives) fails the same comparison, so the test can tell them apart (dropping the factor fails it: checked).
  const SceneDesc d = lit_floor(true);
  const Film mis = render_estimator(d, Estimator::Mis, 256, 1);
  CHECK(blocks_agree(render_estimator(d, Estimator::Bdpt, 256, 2, 2, 1), mis, "light tracing vs mis"));
  CHECK(blocks_agree(render_estimator(d, Estimator::Bdpt, 128, 3), mis, "bdpt vs mis"));
  CHECK_FALSE(stress::compare_blocks(render_estimator(lit_floor(false), Estimator::Mis, 256, 4), mis, 8).pass);
}

TEST_CASE("smooth shading: bdpt renders the coarse smooth sphere as mis does, its terminator included") {
  // Light tracing alone would not: near the terminator of a coarse mesh (12 rings) the path tracer also lights a
  // band past each facet's own terminator that no light path reaches (its shadow rays leave from the lifted
  // point, interaction.h: a path-tracing-only correction, Hanika 2021), several pixels wide here (light tracing
  // alone against mis: max |z| 23; at 24 rings below the noise). bdpt's MIS gives that light to the
  // light-sampling strategy, and the whole estimator agrees.
  SceneDesc d = lit_sphere_scene(2, 12);
  d.width = d.height = 32;
  CHECK(blocks_agree(render_estimator(d, Estimator::Bdpt, 256, 3), render_estimator(d, Estimator::Mis, 512, 4),
                     "bdpt vs mis"));
}

TEST_CASE("smooth shading: every bdpt strategy alone renders the two-bounce paths alike (the light walk's adjoint)") {
  // Paths of exactly two bounces between the smooth floor and the wall: each strategy alone is an unbiased
  // estimate of them (the cornell test of test_bdpt.cpp, with shading normals). Light tracing (3, 1) scatters
  // the light walk at the floor, where it must carry the adjoint's correction |wo·n_s||wi·n_g| /
  // (|wo·n_g||wi·n_s|) (dropping it fails (3, 1): max |z| 7.8, checked); the connection (2, 2) weighs its light
  // end by the shading-normal BSDF (dropping that fails both); path tracing (0, 4) hits the light; all against
  // next-event estimation (1, 3). Then the coarse smooth sphere on a floor, the whole estimator against mis.
  const SceneDesc d = lit_floor(true, true);
  const Film ref = render_estimator(d, Estimator::Bdpt, 256, 10, 1, 3);
  for (const auto& [s, t, spp] : {std::tuple{3, 1, 512}, std::tuple{2, 2, 256}, std::tuple{0, 4, 1024}})
    CHECK(blocks_agree(render_estimator(d, Estimator::Bdpt, spp, 11 + static_cast<uint64_t>(s), s, t), ref,
                       "strategy (" + std::to_string(s) + ", " + std::to_string(t) + ") vs (1, 3)"));
  CHECK(blocks_agree(render_estimator(d, Estimator::Bdpt, 128, 20), render_estimator(d, Estimator::Mis, 256, 21),
                     "bdpt vs mis"));
  SceneDesc sphere = sphere_on_floor(2);
  sphere.render.max_bounces = 2;
  sphere.render.sampler = SamplerType::Independent;
  CHECK(blocks_agree(render_estimator(sphere, Estimator::Bdpt, 256, 22),
                     render_estimator(sphere, Estimator::Mis, 512, 23), "sphere on the floor: bdpt vs mis"));
}

TEST_CASE("smooth shading: bdpt takes smooth meshes, and auto picks it for their caustics") {
  SceneDesc d = lit_sphere_scene(2, 6);
  d.render.estimator = Estimator::Bdpt;
  CHECK(validate_scene(d).empty());
  d.render.estimator = Estimator::Auto;
  // A white sphere alone: nothing focuses light, mis.
  CHECK(choose_estimator(d).estimator == Estimator::Mis);
  // A smooth glass sphere over a diffuse floor: caustics, bdpt.
  SceneDesc g = sphere_on_floor(2);
  g.materials[0].type = MaterialType::Dielectric;
  g.render.estimator = Estimator::Auto;
  const EstimatorChoice c = choose_estimator(g);
  CHECK(c.estimator == Estimator::Bdpt);
  CHECK(c.reason.find("focuses light") != std::string::npos);
  // The compiled scene runs the general kernels (the Lambert ones are flat-shaded).
  const auto scene = compile_scene(d);
  CHECK(scene->features.smooth_shading);
  CHECK((scene->kernel_features() & kFeatureGeneralMaterials) != 0);
  CHECK((compile_scene(lit_sphere_scene(1, 6))->kernel_features() & kFeatureGeneralMaterials) == 0);
}

namespace {

void check_normal(Vec3 got, Vec3 want) {
  INFO("got " << got.x << " " << got.y << " " << got.z << ", want " << want.x << " " << want.y << " " << want.z);
  CHECK(glm::length(got - glm::normalize(want)) < 1e-6f);
}

}  // namespace

TEST_CASE("smooth shading: OBJ vertex normals follow the object's transform and its mirroring") {
  test::TempFolder files("smooth");
  // One triangle (0,0,0), (1,0,0), (0,1,0), front +z, normals (0,0,1), (0.6,0,0.8), (0,0.6,0.8); a second
  // triangle names no normals and stays flat.
  files.write("tri.obj",
              "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nvn 0 0 1\nvn 0.6 0 0.8\nvn 0 0.6 0.8\nvt 0 0\nvt 1 0\nvt 0 1\n"
              "f 1/1/1 2/2/2 3/3/3\nf 1 3 4\n");
  const auto scene_with = [&](const std::string& transform) {
    return parse_scene(R"({"camera": {"position": [0, 0, 10], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov_deg": 40},
      "film": {"width": 16, "height": 16}, "render": {"max_bounces": 4, "estimator": "auto"}, "background": [1, 1, 1],
      "materials": {"white": {"type": "diffuse", "albedo": [0.5, 0.5, 0.5]}},
      "shapes": [{"type": "mesh", "file": "tri.obj", "material": "white", "transform": )" + transform + "}]}",
                       "tri.json", files.dir.string());
  };
  // Scale x by 2 and turn a quarter about +z: a normal maps by R·S⁻¹, (0.6,0,0.8) → (0.3,0,0.8) → (0,0.3,0.8).
  const SceneDesc plain = scene_with(R"({"scale": [2, 1, 1], "rotate_axis": [0, 0, 1], "rotate_deg": 90})");
  REQUIRE(plain.shapes.size() == 2);
  CHECK(plain.shapes[0].shading != kNoShading);
  CHECK(plain.shapes[1].shading == kNoShading);
  const auto s = compile_scene(plain);
  REQUIRE(s->shading.normal.size() == 2);
  check_normal(s->shading.normal[0][0], Vec3(0, 0, 1));
  check_normal(s->shading.normal[0][1], Vec3(0, 0.3f, 0.8f));
  check_normal(s->shading.normal[0][2], Vec3(-0.6f, 0, 0.8f));
  CHECK(s->shading.uv[0][1] == Vec2(1, 1));  // vt 1 0: OBJ's v grows upwards, the tracer's downwards
  for (const Vec3& n : s->shading.normal[1]) CHECK(n == s->polygons.normal[1]);  // the flat face's own normal
  // Mirrored in x: vertices 1 and 2 trade places (the front stays +z) and so do their normals and uv;
  // (0.6,0,0.8) → (−0.6,0,0.8) now belongs to vertex 2.
  const SceneDesc mirrored = scene_with(R"({"scale": [-1, 1, 1]})");
  const auto m = compile_scene(mirrored);
  CHECK(m->polygons.normal[0].z > 0.f);
  check_normal(m->shading.normal[0][1], Vec3(0, 0.6f, 0.8f));
  check_normal(m->shading.normal[0][2], Vec3(-0.6f, 0, 0.8f));
  CHECK(m->shading.uv[0][2] == Vec2(1, 1));
  // Geometry-preserving comparisons see the normals: the same file read twice shares no table but is equal in
  // shape; a scene without normals is not.
  CHECK(same_shapes(plain, plain));
  SceneDesc stripped = plain;
  stripped.shading.reset();
  for (ShapeDesc& sh : stripped.shapes) sh.shading = kNoShading;
  CHECK_FALSE(same_shapes(plain, stripped));
}
