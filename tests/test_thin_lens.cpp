// The thin-lens camera (scene/camera.h): its rays' geometry, and the depth of field it renders against the
// analytic blur of an edge.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "film/film.h"
#include "render/renderer.h"
#include "core/rng.h"
#include "scene/camera.h"
#include "scene/estimator_choice.h"
#include "scene/scene.h"
#include "scene/scene_json.h"
#include "test_helpers.h"

using namespace pt;

TEST_CASE("thin lens: rays leave the lens disk and meet the pinhole ray where the focus plane cuts it") {
  CameraDesc d;
  d.position = DVec3(0.0);
  d.look_at = DVec3(0.3, 0.2, -1.0);
  d.fov_deg = 50;
  d.aperture_radius = 0.25;
  d.focus_distance = 4.0;
  const Camera c = compile_camera(d, 40, 30);
  Pcg32 rng(3, 5);
  double mean_r2 = 0;
  const int n = 20000;
  for (int i = 0; i < n; ++i) {
    const float x = 40.f * rng.next_float(), y = 30.f * rng.next_float();
    const Vec2 u(rng.next_float(), rng.next_float());
    const Ray pin = c.generate_ray(x, y);
    const Ray lens = c.generate_ray(x, y, u);
    // The origin lies on the lens: in the plane through the eye perpendicular to `forward`, within the radius.
    CHECK(std::abs(glm::dot(lens.o - c.origin, c.forward)) < 1e-6f);
    const float r = glm::length(lens.o - c.origin);
    CHECK(r <= 0.25f * (1.f + 1e-6f));
    mean_r2 += double(r) * r / n;
    // Both rays reach the focus plane (depth 4 along forward) at the same point.
    const Vec3 a = pin.o + pin.d * (4.f / glm::dot(pin.d, c.forward));
    const Vec3 b = lens.o + lens.d * ((4.f - glm::dot(lens.o - c.origin, c.forward)) / glm::dot(lens.d, c.forward));
    CHECK(glm::length(a - b) < 1e-5f * 4.f * 4.f);
  }
  // Uniform over the disk: E[r²] = R²/2 (R = 0.25); 20000 samples give a standard error of ~0.2 % of it.
  CHECK(mean_r2 == doctest::Approx(0.25 * 0.25 / 2).epsilon(0.01));
  // A pinhole ignores the lens sample.
  CameraDesc pin = d;
  pin.aperture_radius = 0;
  const Camera p = compile_camera(pin, 40, 30);
  const Ray r1 = p.generate_ray(7.5f, 3.25f, Vec2(0.1f, 0.9f)), r2 = p.generate_ray(7.5f, 3.25f);
  CHECK(r1.o == r2.o);
  CHECK(r1.d == r2.d);
}

namespace {

// Expected value of pixel column i of the edge scene below: the fraction of (image point, lens point) pairs whose
// ray hits the half-plane x < 0 at depth D. A ray through image coordinate s (tan units, s = x/depth of the
// pinhole ray) and lens offset l along `right` meets depth D at x = s·D + l·(1 − D/f), so it hits where
// s < l·k, k = 1/f − 1/D. s is uniform over the pixel, l has the uniform disk's marginal density
// 2·sqrt(R² − l²)/(π R²). Integrated by the midpoint rule (independently of the renderer's code).
double expected_column(int i, int width, double tan_half, double R, double k) {
  const double s0 = (2.0 * i / width - 1.0) * tan_half, s1 = (2.0 * (i + 1) / width - 1.0) * tan_half;
  if (R == 0.0 || k == 0.0) return std::clamp((0.0 - s0) / (s1 - s0), 0.0, 1.0);
  const int m = 20000;
  double sum = 0, weight = 0;
  for (int j = 0; j < m; ++j) {
    const double l = R * (-1.0 + (2.0 * j + 1.0) / m);
    const double p = std::sqrt(std::max(0.0, R * R - l * l));
    sum += p * std::clamp((l * k - s0) / (s1 - s0), 0.0, 1.0);
    weight += p;
  }
  return sum / weight;
}

}  // namespace

TEST_CASE("thin lens: an edge at the focus distance is sharp and one off it blurs by the analytic circle of confusion") {
  const double D = 4.0, R = 0.5;
  SceneDesc s;
  s.width = 48;
  s.height = 4;
  s.camera.position = DVec3(0.0);
  s.camera.look_at = DVec3(0, 0, -1);
  s.camera.fov_deg = 2.0 * glm::degrees(std::atan(0.5 * 4.0 / 48.0));  // vertical: tan_half_y = 1/24, so tan_half_x = 1/2
  s.camera.aperture_radius = R;
  s.render.max_bounces = 0;
  s.environment.radiance = Rgb(0.f);
  MaterialDesc lamp;
  lamp.name = "lamp";
  lamp.albedo = Rgb(0.f);
  lamp.emission = Rgb(1.f);
  lamp.two_sided = true;
  s.materials = {lamp};
  ShapeDesc q;  // the half-plane x < 0 at depth D (far wider than the view)
  q.type = ShapeType::Quad;
  q.vertices = {DVec3(-100, -100, -D), DVec3(0, -100, -D), DVec3(0, 100, -D), DVec3(-100, 100, -D)};
  s.shapes = {q};
  const double tan_half_x = 0.5;  // width/height × tan_half_y
  Renderer renderer(2);
  for (const double f : {D, 2.0, 8.0}) {
    s.camera.focus_distance = f;
    REQUIRE(choose_estimator(s).estimator == Estimator::Mis);
    const auto scene = compile_scene(s);
    Film film(s.width, s.height);
    const int spp = 512;
    renderer.render_pass(*scene, s.render, film, spp);
    const std::vector<float> img = film.mean_image();
    const double k = 1.0 / f - 1.0 / D;
    int blurred = 0;
    for (int i = 0; i < s.width; ++i) {
      double mean = 0;
      for (int y = 0; y < s.height; ++y) mean += img[3 * (y * s.width + i)] / s.height;
      const double e = expected_column(i, s.width, tan_half_x, R, k);
      // Bernoulli samples: standard error sqrt(e(1 − e)/n), n = 4 rows × spp; 5 standard errors and the
      // midpoint rule's 1e-4 (Sobol stratification makes the real error smaller).
      const double se = std::sqrt(e * (1 - e) / (s.height * spp));
      INFO("focus " << f << " column " << i << " expected " << e << " got " << mean);
      CHECK(std::abs(mean - e) <= 5 * se + 1e-4);
      blurred += e > 0.01 && e < 0.99;
    }
    // In focus, no column is grey; off focus the circle of confusion spans many columns (R·|k| vs 1/48 per column).
    if (f == D) CHECK(blurred == 0);
    else CHECK(blurred >= 4);
  }
}

TEST_CASE("thin lens: the scene file reads and writes aperture_radius and focus_distance and refuses bad values") {
  SceneDesc s = load_scene("cornell");
  const std::string pinhole = scene_to_json(s);
  CHECK(pinhole.find("aperture_radius") == std::string::npos);  // a pinhole's file is as before
  s.camera.aperture_radius = 12.5;
  s.camera.focus_distance = 1000.25;
  const SceneDesc back = parse_scene(scene_to_json(s), "lens.json");
  CHECK(back.camera.aperture_radius == 12.5);
  CHECK(back.camera.focus_distance == 1000.25);
  // Negative or non-finite values are refused with the key's path; every estimator takes the lens.
  std::string text = scene_to_json(s);
  const size_t at = text.find("12.5");
  REQUIRE(at != std::string::npos);
  std::string negative = text;
  negative.replace(at, 4, "-1");
  CHECK_THROWS_WITH_AS(parse_scene(negative, "neg.json"), doctest::Contains("camera.aperture_radius"), SceneError);
  s.render.estimator = Estimator::Bdpt;
  CHECK(validate_scene(s).empty());
  s.render.estimator = Estimator::Auto;
  CHECK(choose_estimator(s).reason.find("thin-lens") == std::string::npos);  // cornell: mis for its materials
}

TEST_CASE("thin lens: bdpt's light tracing connects to the lens, each strategy and the whole estimator agree with mis") {
  // The Cornell box at 64², two bounces, through a lens of radius 40 focused at 500 (its front; the back wall,
  // 1,300 away, is blurred over ~9 pixels, the blocks' edges over more). Each strategy alone estimates the paths
  // of its own length: light tracing, (2, 1) and (3, 1), one and two bounces, must connect each light vertex to a
  // point of the lens and find its pixel through the focus plane, or its image is sharp (or shifted) where the
  // camera's is blurred; each against next-event estimation of the same length, (1, 2) and (1, 3). With the pinhole connection of before,
  // (2, 1) fails; so does mapping the lens point's direction to the film as if it left the eye (both checked).
  // Then the whole estimator against mis.
  SceneDesc d = load_scene("cornell");
  d.width = d.height = 64;
  d.render.max_bounces = 2;
  d.render.sampler = SamplerType::Independent;
  d.camera.aperture_radius = 40.0;
  d.camera.focus_distance = 500.0;
  REQUIRE(validate_scene(d).empty());
  using test::blocks_agree;
  using test::render_estimator;
  CHECK(blocks_agree(render_estimator(d, Estimator::Bdpt, 512, 3, 2, 1), render_estimator(d, Estimator::Bdpt, 128, 4, 1, 2),
                     "one bounce: (2, 1) vs (1, 2)"));
  CHECK(blocks_agree(render_estimator(d, Estimator::Bdpt, 512, 5, 3, 1), render_estimator(d, Estimator::Bdpt, 128, 6, 1, 3),
                     "two bounces: (3, 1) vs (1, 3)"));
  CHECK(blocks_agree(render_estimator(d, Estimator::Bdpt, 128, 7), render_estimator(d, Estimator::Mis, 256, 8), "bdpt vs mis"));
}
