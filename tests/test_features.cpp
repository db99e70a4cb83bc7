// Feature buffers (integrators/features.h) and the film's half buffers: values checked against the scene's own
// numbers (material albedos, plane normals, analytic distances), never against the code under test.
#include <doctest/doctest.h>

#include <cmath>

#include "integrators/feature_pass.h"
#include "scene/scene_json.h"
#include "test_helpers.h"

namespace pt {
namespace {

using stress::quad;

const Rgb kRoomAlbedo(0.3f, 0.5f, 0.7f);
const Rgb kMirrorTint(0.9f, 0.6f, 0.25f);
const DVec3 kBallCenter(0.4, 0.45, -1.8);
constexpr double kBallRadius = 0.4;
constexpr double kBackWallZ = -3.0;

// A closed room x ∈ [−2, 2], y ∈ [−1, 3], z ∈ [−3, 3] whose six walls have one diffuse albedo, seen from the
// origin along −z (90° field of view), with a small light and one specular object in view: a mirror ball, a
// clear glass ball or a glass pane across the whole room (the far part of the room then lies inside the glass,
// so a camera path crosses one interface only).
enum class Specular { MirrorBall, GlassBall, GlassPane };
constexpr double kPaneZ = -1.2;

SceneDesc room_scene(Estimator est, Specular object) {
  SceneDesc s = test::origin_camera_scene(16, 16);
  s.render.estimator = est;
  s.render.max_bounces = 6;
  MaterialDesc wall;
  wall.name = "wall";
  wall.albedo = kRoomAlbedo;
  MaterialDesc mirror;
  mirror.name = "mirror";
  mirror.type = MaterialType::Mirror;
  mirror.albedo = kMirrorTint;
  MaterialDesc glass;
  glass.name = "glass";
  glass.type = MaterialType::Dielectric;
  glass.ior = 1.5f;
  MaterialDesc lamp;
  lamp.name = "lamp";
  lamp.albedo = kRoomAlbedo;
  lamp.emission = Rgb(5.f);
  s.materials = {wall, mirror, glass, lamp};
  const double x0 = -2, x1 = 2, y0 = -1, y1 = 3, z0 = kBackWallZ, z1 = 3;
  s.shapes = {
      quad({x0, y0, z1}, {x1, y0, z1}, {x1, y0, z0}, {x0, y0, z0}, 0),  // floor, normal +y
      quad({x0, y1, z0}, {x1, y1, z0}, {x1, y1, z1}, {x0, y1, z1}, 0),  // ceiling, −y
      quad({x0, y0, z0}, {x1, y0, z0}, {x1, y1, z0}, {x0, y1, z0}, 0),  // back wall, +z
      quad({x1, y0, z1}, {x0, y0, z1}, {x0, y1, z1}, {x1, y1, z1}, 0),  // front wall, −z
      quad({x0, y0, z1}, {x0, y0, z0}, {x0, y1, z0}, {x0, y1, z1}, 0),  // left wall, +x
      quad({x1, y0, z0}, {x1, y0, z1}, {x1, y1, z1}, {x1, y1, z0}, 0),  // right wall, −x
      // A lamp just below the ceiling, behind the camera (out of view), facing down.
      quad({-0.3, 2.99, 1.3}, {-0.3, 2.99, 1.7}, {0.3, 2.99, 1.7}, {0.3, 2.99, 1.3}, 3),
  };
  if (object == Specular::GlassPane) {
    s.shapes.push_back(quad({x0, y0, kPaneZ}, {x1, y0, kPaneZ}, {x1, y1, kPaneZ}, {x0, y1, kPaneZ}, 2));
    return s;
  }
  ShapeDesc ball;
  ball.type = ShapeType::Sphere;
  ball.radius = kBallRadius;
  ball.center = kBallCenter;
  ball.material = object == Specular::MirrorBall ? 1 : 2;
  s.shapes.push_back(ball);
  return s;
}

Film render_with_features(const SceneDesc& desc, int spp, PathLoop loop = PathLoop::Auto) {
  SceneDesc d = desc;
  d.render.path_loop = loop;
  return test::render_film(d, spp, 2, true);
}

bool ray_hits_ball(const Ray& r, DVec3 center) {
  const DVec3 o(r.o), dir = glm::normalize(DVec3(r.d));
  const DVec3 oc = o - center;
  const double b = glm::dot(oc, dir), c = glm::dot(oc, oc) - kBallRadius * kBallRadius;
  return b * b - c > 0.0 && -b - std::sqrt(b * b - c) > 0.0;
}

// Pixels whose whole footprint (a 5×5 grid of rays over it) sees the ball, or misses it.
enum class Coverage { Inside, Outside, Edge };
Coverage ball_coverage(const Camera& cam, int x, int y, DVec3 center) {
  int hits = 0;
  for (int j = 0; j <= 4; ++j)
    for (int i = 0; i <= 4; ++i) hits += ray_hits_ball(cam.generate_ray(x + i / 4.f, y + j / 4.f), center);
  return hits == 25 ? Coverage::Inside : hits == 0 ? Coverage::Outside : Coverage::Edge;
}

}  // namespace

TEST_CASE("features: room albedo exact, floor normal (0,1,0), back-wall depth analytic, mirror and glass tints") {
  for (const Estimator est : {Estimator::Mis, Estimator::Bdpt})
  for (const Specular object : {Specular::MirrorBall, Specular::GlassBall, Specular::GlassPane}) {
    CAPTURE(std::string(to_string(est)));
    CAPTURE(static_cast<int>(object));
    const SceneDesc desc = room_scene(est, object);
    const bool pane = object == Specular::GlassPane;
    const auto scene = compile_scene(desc);
    const Camera& cam = scene->camera;
    const Film film = render_with_features(desc, 16);
    const std::vector<float> albedo = film.albedo_image(), normal = film.normal_image(), depth = film.depth_image();
    int wall_pixels = 0, ball_pixels = 0, floor_pixels = 0, depth_pixels = 0;
    // Clear glass has tint 1 in reflection and, with refraction's 1/η² undone, in transmission (the pane tests
    // the undoing: through a ball the 1/η² going in and the η² coming out cancel).
    const Rgb ball_tint = object == Specular::MirrorBall ? kMirrorTint : Rgb(1.f);
    for (int y = 0; y < desc.height; ++y) {
      for (int x = 0; x < desc.width; ++x) {
        const size_t i = static_cast<size_t>(y) * desc.width + x;
        const Rgb a(albedo[3 * i], albedo[3 * i + 1], albedo[3 * i + 2]);
        const Coverage ball = pane ? Coverage::Inside : ball_coverage(cam, x, y, kBallCenter);
        if (ball == Coverage::Outside) {
          // Every wall has the same albedo: the mean of identical values is exact.
          CHECK(a == kRoomAlbedo);
          ++wall_pixels;
        } else if (ball == Coverage::Inside) {
          // Whatever the ball shows is a wall: its tint × the wall's albedo.
          for (int c = 0; c < 3; ++c) CHECK(a[c] == doctest::Approx(ball_tint[c] * kRoomAlbedo[c]).epsilon(1e-5));
          ++ball_pixels;
        }
        // The bottom rows see only the floor (its rays reach y = −1 before z = −3 or |x| = 2).
        if (y >= desc.height - 3) {
          CHECK(normal[3 * i] == 0.f);
          CHECK(normal[3 * i + 1] == 1.f);
          CHECK(normal[3 * i + 2] == 0.f);
          ++floor_pixels;
        }
        // Pixels that see only the back wall (or the pane): depth = |z|·|d|/|d_z|, averaged over the pixel.
        const double first_z = pane ? kPaneZ : kBackWallZ;
        if (y >= 5 && y < 9 && x >= 4 && x < 12 && (pane || ball == Coverage::Outside)) {
          double sum = 0.0;
          constexpr int kGrid = 64;
          for (int j = 0; j < kGrid; ++j)
            for (int k = 0; k < kGrid; ++k) {
              const DVec3 d(cam.generate_ray(x + (k + 0.5f) / kGrid, y + (j + 0.5f) / kGrid).d);
              sum += -first_z * glm::length(d) / std::abs(d.z);
            }
          // 16 stratified samples integrate the few-percent variation of depth over a pixel to ~4e-4; a wrong
          // point or an unnormalised direction would be off by far more.
          CHECK(depth[i] == doctest::Approx(sum / (kGrid * kGrid)).epsilon(1e-3));
          ++depth_pixels;
        }
      }
    }
    CHECK(wall_pixels + ball_pixels > 200);
    CHECK(ball_pixels >= 4);
    CHECK(floor_pixels == 3 * desc.width);
    CHECK(depth_pixels >= 16);
  }
}

TEST_CASE("features: through glass, the emission layer never exceeds the image (bdpt's lobe-summed chains)") {
  // The room's ceiling behind the camera is one big lamp, so the glass ball's Fresnel reflection shows it. The
  // emission layer is the part of each pixel the denoiser adds back unfiltered: it must be part of the image.
  // Every contribution to a sample is non-negative, so per pixel emission ≤ image holds exactly when the layer
  // counts what the image counts. bdpt sums a pure-specular chain's lobes (specular_chain_emission), so the image
  // has F·Le in every sample; before the fix the layer took the one lobe the walk sampled, Le in the ~1 sample of
  // 8 that reflected, which made isolated pixels brighter than the image there.
  for (const Estimator est : {Estimator::Mis, Estimator::Bdpt}) {
    CAPTURE(std::string(to_string(est)));
    SceneDesc desc = room_scene(est, Specular::GlassBall);
    desc.shapes[6] = quad({-2, 2.99, 0}, {2, 2.99, 0}, {2, 2.99, 3}, {-2, 2.99, 3}, 3);  // facing down
    desc.width = desc.height = 48;
    const auto scene = compile_scene(desc);
    const Film film = render_with_features(desc, 8);
    const std::vector<float> image = film.mean_image(), emission = film.emission_image();
    int ball_pixels = 0, lit = 0;
    for (int y = 0; y < desc.height; ++y)
      for (int x = 0; x < desc.width; ++x) {
        if (ball_coverage(scene->camera, x, y, kBallCenter) != Coverage::Inside) continue;
        ++ball_pixels;
        const size_t i = static_cast<size_t>(y) * desc.width + x;
        for (int c = 0; c < 3; ++c) {
          CHECK(emission[3 * i + c] <= image[3 * i + c] * (1.f + 1e-5f));
          lit += c == 0 && emission[3 * i] > 0.f;
        }
      }
    CHECK(ball_pixels >= 4);
    // bdpt's layer has the reflection in every ball pixel that shows it, so the check above is not vacuous there;
    // mis's has it only in the samples whose lobe choice fell under F.
    if (est == Estimator::Bdpt) CHECK(lit >= 2);
  }
}

TEST_CASE("features: gathering them leaves the image bit for bit, and both path loops gather the same") {
  // The room with a glass ball (general materials), and cornell, whose Lambertian polygons the wavefront loop
  // shades on SIMD lanes once a path's features are recorded (integrators/shading_lanes.h).
  SceneDesc cornell = load_scene("cornell");
  cornell.width = 40;
  cornell.height = 24;
  for (const SceneDesc& desc : {room_scene(Estimator::Mis, Specular::GlassBall), cornell}) {
    const Film plain = test::render_film(desc, 8, 2);
    const Film scalar = render_with_features(desc, 8, PathLoop::Scalar);
    const Film wavefront = render_with_features(desc, 8, PathLoop::Wavefront);
    CHECK(plain.mean_image() == scalar.mean_image());
    CHECK(plain.mean_image() == wavefront.mean_image());
    CHECK(scalar.albedo_image() == wavefront.albedo_image());
    CHECK(scalar.normal_image() == wavefront.normal_image());
    CHECK(scalar.depth_image() == wavefront.depth_image());
  }
}

TEST_CASE("film halves: one sample of each pair per half, and each half covers the whole pixel") {
  // A back wall whose left half emits 1 and right half nothing, the edge through the middle column's centre:
  // each sample there is 0 or 1 depending on its camera jitter alone (uniform estimator, no bounce).
  SceneDesc s = test::origin_camera_scene(15, 16);
  s.render.estimator = Estimator::Uniform;
  s.render.max_bounces = 0;
  MaterialDesc light, dark;
  light.name = "light";
  light.albedo = Rgb(0.f);
  light.emission = Rgb(1.f);
  dark.name = "dark";
  dark.albedo = Rgb(0.f);
  s.materials = {light, dark};
  s.shapes = {quad({-5, -5, -1}, {0, -5, -1}, {0, 5, -1}, {-5, 5, -1}, 0),
              quad({0, -5, -1}, {5, -5, -1}, {5, 5, -1}, {0, 5, -1}, 1)};
  for (const SamplerType sampler : {SamplerType::Sobol, SamplerType::Independent}) {
    CAPTURE(std::string(to_string(sampler)));
    s.render.sampler = sampler;
    const Film film = render_with_features(s, 64);
    const std::vector<float> a = film.half_image(0), b = film.half_image(1), mean = film.mean_image();
    double sum_abs_dev = 0.0;
    for (int y = 0; y < s.height; ++y) {
      const size_t i = static_cast<size_t>(y) * s.width + 7;
      CHECK(film.half_a_count(i) == 32);  // one member of each of the 32 pairs
      // The halves recombine to the whole, exactly up to float rounding.
      CHECK(0.5f * (a[3 * i] + b[3 * i]) == doctest::Approx(mean[3 * i]).epsilon(1e-6));
      sum_abs_dev += std::abs(a[3 * i] - mean[3 * i]);
    }
    // Each half must see both sides of the edge (a half confined to part of the pixel would deviate by up to
    // 0.5). For independent samples A − mean = (A − B)/2 with A, B binomial shares of 32: E|A − mean| ≈ 0.05,
    // and the 16-pixel average has a standard deviation ≈ 0.01, so 0.15 lies ten of them away.
    CHECK(sum_abs_dev / s.height < 0.15);
  }
}

}  // namespace pt

namespace pt {

TEST_CASE("feature pass: the viewer's guide has the scene's albedos, the floor's normal and the back wall's depth at "
          "each pixel's centre, through glass and mirrors") {
  for (const Specular object : {Specular::MirrorBall, Specular::GlassBall, Specular::GlassPane}) {
    CAPTURE(static_cast<int>(object));
    const SceneDesc desc = room_scene(Estimator::Mis, object);
    const auto scene = compile_scene(desc);
    const Camera& cam = scene->camera;
    ThreadPool pool(2);
    FeatureImage g;
    trace_feature_image(*scene, desc.render, pool, g);
    REQUIRE(g.width == desc.width);
    REQUIRE(g.height == desc.height);
    const bool pane = object == Specular::GlassPane;
    const Rgb ball_tint = object == Specular::MirrorBall ? kMirrorTint : Rgb(1.f);
    int walls = 0, through = 0;
    for (int y = 0; y < g.height; ++y)
      for (int x = 0; x < g.width; ++x) {
        const size_t i = static_cast<size_t>(y) * g.width + x;
        const Ray centre = cam.generate_ray(x + 0.5f, y + 0.5f);
        const bool behind = pane || ray_hits_ball(centre, kBallCenter);
        const Rgb a(g.albedo[3 * i], g.albedo[3 * i + 1], g.albedo[3 * i + 2]);
        const Rgb want = behind ? ball_tint * kRoomAlbedo : kRoomAlbedo;  // clear glass: the likelier lobe, tint 1
        for (int c = 0; c < 3; ++c) CHECK(a[c] == doctest::Approx(want[c]).epsilon(1e-5));
        (behind ? through : walls) += 1;
        CHECK(g.emission[3 * i] == 0.f);  // the lamp is out of view
        if (y >= desc.height - 3 && !behind) {
          CHECK(g.normal[3 * i] == 0.f);
          CHECK(g.normal[3 * i + 1] == 1.f);
          CHECK(g.normal[3 * i + 2] == 0.f);
        }
        // The pixel centre's ray alone, so the analytic distance holds to float rounding.
        if (y >= 5 && y < 9 && x >= 4 && x < 12) {
          const double first_z = pane ? kPaneZ : kBackWallZ;
          if (pane || !ray_hits_ball(centre, kBallCenter)) {
            const DVec3 d(centre.d);
            CHECK(g.depth[i] == doctest::Approx(-first_z * glm::length(d) / std::abs(d.z)).epsilon(1e-5));
          }
        }
      }
    CHECK(through >= 4);
    CHECK(walls + through == g.width * g.height);
  }
}

}  // namespace pt
