// Shared helpers of the test suites: small scenes built in code, and rendering into a film.
#pragma once
#include <doctest/doctest.h>

#include <memory>
#include <string>

#include "film/film.h"
#include "render/renderer.h"
#include "scene/scene.h"
#include "cli/stress_scenes.h"

namespace pt::test {

// A diffuse material.
inline MaterialDesc diffuse_material(const std::string& name, Rgb albedo, Rgb emission, bool two_sided) {
  MaterialDesc m;
  m.name = name;
  m.albedo = albedo;
  m.emission = emission;
  m.two_sided = two_sided;
  return m;
}

// A closed sphere of the given material around a camera at its centre: the furnace.
inline SceneDesc furnace_scene(Rgb emission, Rgb albedo, int bounces, int rr_depth, Estimator est,
                               double scale = 1.0, DVec3 offset = DVec3(0.0)) {
  SceneDesc s;
  s.camera.position = offset;
  s.camera.look_at = offset + DVec3(0, 0, -scale);
  s.camera.up = {0, 1, 0};
  s.camera.fov_deg = 90;
  s.width = s.height = 8;
  s.render.max_bounces = bounces;
  s.render.russian_roulette_depth = rr_depth;
  s.render.estimator = est;
  // Tolerances come from the film's per-pixel variance, valid for independent samples (see the Sobol test).
  s.render.sampler = SamplerType::Independent;
  MaterialDesc m;
  m.name = "furnace";
  m.albedo = albedo;
  m.emission = emission;
  m.two_sided = true;  // seen from inside
  s.materials.push_back(m);
  ShapeDesc sphere;
  sphere.type = ShapeType::Sphere;
  sphere.center = offset + DVec3(0.1, -0.2, 0.05) * scale;  // camera off-centre: cosines vary
  sphere.radius = 1.0 * scale;
  s.shapes.push_back(sphere);
  return s;
}

// A scene of w×h pixels seen from the origin along −z with a 90° vertical field of view, no shapes yet: the
// camera of the analytic feature and denoiser tests.
inline SceneDesc origin_camera_scene(int width, int height) {
  SceneDesc s;
  s.camera.position = DVec3(0.0);
  s.camera.look_at = DVec3(0, 0, -1);
  s.camera.up = {0, 1, 0};
  s.camera.fov_deg = 90;
  s.width = width;
  s.height = height;
  return s;
}

// Image mean and its standard error: the one definition shared with `pathtracer stress`.
using MeanWithError = stress::MeanSE;
using stress::film_mean;

// `features`: the film keeps its feature buffers (Film::enable_features).
inline Film render_film(const SceneDesc& desc, int spp, int threads = 0, bool features = false) {
  const auto scene = compile_scene(desc);
  Film film(desc.width, desc.height);
  film.enable_features(features);
  Renderer renderer(threads);
  renderer.render_pass(*scene, desc.render, film, spp);
  return film;
}

// Renders `d` (4 spp, 2 threads, with feature buffers) through the scalar and the wavefront loop under nee and mis,
// Sobol and independent points: the images and the feature buffers must agree byte for byte (the SIMD shading lanes
// give the scalar loop's bits).
inline void check_lanes_match_scalar_loop(SceneDesc d) {
  for (const SamplerType sampler : {SamplerType::Sobol, SamplerType::Independent})
    for (const Estimator est : {Estimator::Nee, Estimator::Mis}) {
      d.render.sampler = sampler;
      d.render.estimator = est;
      CAPTURE(std::string(to_string(sampler)));
      CAPTURE(std::string(to_string(est)));
      d.render.path_loop = PathLoop::Scalar;
      const Film scalar = render_film(d, 4, 2, true);
      d.render.path_loop = PathLoop::Wavefront;
      const Film wavefront = render_film(d, 4, 2, true);
      CHECK(scalar.mean_image() == wavefront.mean_image());
      CHECK(scalar.normal_image() == wavefront.normal_image());
      CHECK(scalar.albedo_image() == wavefront.albedo_image());
    }
}

// The scene under estimator `e` with `seed` (for bdpt, only strategy (only_s, only_t) when they are ≥ 0, unweighted),
// on 2 threads.
inline Film render_estimator(SceneDesc d, Estimator e, int spp, uint64_t seed, int only_s = -1, int only_t = -1) {
  d.render.estimator = e;
  d.render.seed = seed;
  d.render.bdpt_only.s = only_s;
  d.render.bdpt_only.t = only_t;
  return render_film(d, spp, 2);
}

// Whether two films estimate the same image: z-scores of 8×8 block means from the films' own variances
// (stress::compare_blocks: Bonferroni bound at α = 1e-5 over all blocks and channels, and a χ² bound on the mean
// z²), with at least 16 blocks; the figures are reported under `what`.
inline bool blocks_agree(const Film& a, const Film& b, const std::string& what) {
  const stress::Agreement g = stress::compare_blocks(a, b, 8);
  MESSAGE(what << ": max |z| " << g.max_abs_z << " (bound " << g.z_bound << "), mean z² " << g.mean_z2
               << " (bound " << g.z2_bound << ") over " << g.n);
  CHECK(g.n >= 16);
  return g.pass;
}

}  // namespace pt::test
