// The light tree (lights/light_tree.h): next-event estimation's choice among many lights by their importance at
// the receiver. Its probabilities are a distribution that sampling follows exactly and that pmf() reproduces bit
// for bit (MIS needs both sides to agree); it never rules out a light that can reach the receiver; and images
// made with it estimate the same radiance as images made with the power-proportional choice.
#include <doctest/doctest.h>

#include <cmath>
#include <cstring>
#include <vector>

#include "core/rng.h"
#include "lights/light_sampling.h"
#include "render/renderer.h"
#include "sampling/sampling.h"
#include "scene/scene_json.h"
#include "test_helpers.h"

using namespace pt;
using namespace pt::test;

namespace {

// A 12 × 12 floor under `lamps` small lamps at heights 1–3 (one-sided, facing down, except every fourth: two-sided,
// tilted and facing up), a spherical lamp, a point light, two spots and a dim constant sky, seen from above at an angle. 48 × 40 pixels
// (30 blocks of 8 × 8), independent samples (the block test's variances assume them).
SceneDesc many_lamps(int lamps) {
  SceneDesc s;
  s.camera.position = DVec3(0, 7, 9);
  s.camera.look_at = DVec3(0, 0, 0);
  s.camera.up = {0, 1, 0};
  s.camera.fov_deg = 60;
  s.width = 48;
  s.height = 40;
  s.render.sampler = SamplerType::Independent;
  s.environment.type = EnvironmentType::Constant;
  s.environment.radiance = Rgb(0.05f);
  s.materials.push_back(diffuse_material("floor", Rgb(0.6f), Rgb(0.f), false));
  s.materials.push_back(diffuse_material("ball", Rgb(0.f), Rgb(3.f, 2.f, 1.f), false));
  ShapeDesc floor;
  floor.type = ShapeType::Quad;
  floor.vertices = {DVec3(-6, 0, -6), DVec3(-6, 0, 6), DVec3(6, 0, 6), DVec3(6, 0, -6)};
  floor.material = 0;
  s.shapes.push_back(floor);
  ShapeDesc ball;
  ball.type = ShapeType::Sphere;
  ball.center = DVec3(3, 1, -3);
  ball.radius = 0.3;
  ball.material = 1;
  s.shapes.push_back(ball);
  Pcg32 rng(5, 7);
  for (int i = 0; i < lamps; ++i) {
    const double x = -5.0 + 10.0 * rng.next_float(), z = -5.0 + 10.0 * rng.next_float();
    const double y = 1.0 + 2.0 * rng.next_float(), h = 0.2, tilt = i % 4 == 3 ? 0.15 : 0.0;
    const Rgb e(1.f + 9.f * rng.next_float(), 1.f + 9.f * rng.next_float(), 1.f + 9.f * rng.next_float());
    s.materials.push_back(diffuse_material("lamp" + std::to_string(i), Rgb(0.f), e, i % 4 == 3));
    ShapeDesc q;
    q.type = ShapeType::Quad;
    q.vertices = {DVec3(x - h, y - tilt, z - h), DVec3(x + h, y - tilt, z - h), DVec3(x + h, y + tilt, z + h),
                  DVec3(x - h, y + tilt, z + h)};
    // The two-sided lamps face up: the floor sees their backs (a choice that ignored two-sidedness would leave
    // them dark under nee).
    if (i % 4 == 3) std::swap(q.vertices[1], q.vertices[3]);
    q.material = static_cast<int>(s.materials.size()) - 1;
    s.shapes.push_back(q);
  }
  PunctualLightDesc point;
  point.kind = PunctualKind::Point;
  point.position = DVec3(-3, 2, 3);
  point.intensity = Rgb(4.f);
  // Two spots aimed down at the floor, one fading between its cones, one nearly hard-edged.
  PunctualLightDesc soft;
  soft.kind = PunctualKind::Spot;
  soft.position = DVec3(-2, 4, 1);
  soft.direction = DVec3(0.2, -1, 0.1);
  soft.intensity = Rgb(6.f);
  soft.inner_cone = 0.3;
  soft.outer_cone = 0.6;
  PunctualLightDesc hard = soft;
  hard.position = DVec3(2, 3.5, 2);
  hard.direction = DVec3(-0.1, -1, -0.3);
  hard.inner_cone = 0.39;
  hard.outer_cone = 0.4;
  s.punctual_lights = {point, soft, hard};
  return s;
}

Film render(const Scene& scene, RenderSettings settings, Estimator est, int spp, uint64_t seed) {
  settings.estimator = est;
  settings.seed = seed;
  Film film(scene.width, scene.height);
  Renderer r(2);
  r.render_pass(scene, settings, film, spp);
  return film;
}

}  // namespace

TEST_CASE("light tree: a scene takes one from kMinLights bounded lights on, and keeps power alone below") {
  CHECK(compile_scene(load_scene("cornell"))->light_tree.empty());
  // 4 lamps + the ball, the point light and the two spots = 8 bounded lights; 3 + 4 = 7 stay below the threshold.
  CHECK_FALSE(compile_scene(many_lamps(4))->light_tree.empty());
  CHECK(compile_scene(many_lamps(3))->light_tree.empty());
  const auto scene = compile_scene(many_lamps(40));
  REQUIRE_FALSE(scene->light_tree.empty());
  REQUIRE(scene->infinite_lights.size() == 1);
  // The sky is no member; the tree's share is every other light's power share.
  CHECK_FALSE(scene->light_tree.contains(static_cast<int>(scene->infinite_lights[0])));
  CHECK(scene->light_tree.share() == doctest::Approx(1.0 - scene->light_pmf[scene->infinite_lights[0]]).epsilon(1e-6));
}

TEST_CASE("light tree: at any receiver the choice probabilities sum to 1, and sampling follows them exactly, in trees two and four levels deep") {
  // 44 bounded lights make two levels of 8-wide nodes, 704 four.
  for (int lamps : {40, 700}) {
    CAPTURE(lamps);
    const auto scene = compile_scene(many_lamps(lamps));
    const Scene& s = *scene;
    REQUIRE_FALSE(s.light_tree.empty());
    const int lights = static_cast<int>(s.lights.size());
    Pcg32 rng(11, 3);
    constexpr int kStrata = 1 << 14;
    int receivers_with_lights = 0;
    for (int r = 0; r < 60; ++r) {
      // Receivers on and above the floor, facing up or any way (a point between the lamps, under them, behind them).
      const Vec3 p(-6.f + 12.f * rng.next_float(), r % 3 == 0 ? 0.f : 4.f * rng.next_float(), -6.f + 12.f * rng.next_float());
      const Vec3 n = r % 2 == 0 ? Vec3(0, 1, 0) : sample_uniform_sphere(Vec2(rng.next_float(), rng.next_float()));
      CAPTURE(r);
      double total = 0.0;
      std::vector<float> pmf(static_cast<size_t>(lights));
      for (int li = 0; li < lights; ++li) {
        pmf[static_cast<size_t>(li)] = light_choice_pmf(s, p, n, li);
        CHECK(pmf[static_cast<size_t>(li)] >= 0.f);
        total += pmf[static_cast<size_t>(li)];
      }
      // All of it, unless the tree can offer nothing here (then the lights outside it alone).
      if (std::abs(total - 1.0) > 1e-4) {
        CHECK(total == doctest::Approx(1.0 - s.light_tree.share()).epsilon(1e-5));
        continue;
      }
      ++receivers_with_lights;
      // Stratified u: each light's u form one interval of its probability's length, so the counts are exact to
      // one stratum at either end.
      std::vector<int> count(static_cast<size_t>(lights), 0);
      int failed = 0, differs = 0;
      for (int k = 0; k < kStrata; ++k) {
        float chosen_pmf = 0.f;
        const int li = choose_light_at(s, p, n, (static_cast<float>(k) + 0.5f) / kStrata, chosen_pmf);
        if (li < 0) {
          ++failed;
          continue;
        }
        differs += chosen_pmf != pmf[static_cast<size_t>(li)];  // bit for bit: what MIS will recompute
        ++count[static_cast<size_t>(li)];
      }
      CHECK(failed == 0);
      CHECK(differs == 0);
      for (int li = 0; li < lights; ++li)
        CHECK(std::abs(count[static_cast<size_t>(li)] - kStrata * static_cast<double>(pmf[static_cast<size_t>(li)])) <= 2.5);
    }
    CHECK(receivers_with_lights >= 50);
  }
}

TEST_CASE("light tree: a lamp keeps a chance wherever it can light the receiver, and none behind its back") {
  const auto scene = compile_scene(many_lamps(40));
  const Scene& s = *scene;
  Pcg32 rng(2, 9);
  int behind = 0, in_front = 0;
  for (size_t li = 0; li < s.lights.size(); ++li) {
    const Light& l = s.lights[li];
    if (!l.polygon()) continue;
    const Vec3 c = 0.25f * (s.polygons.v[0][l.prim] + s.polygons.v[1][l.prim] + s.polygons.v[2][l.prim] +
                            s.polygons.v[3][l.prim]);
    const Vec3 front = s.polygons.normal[l.prim];
    for (int k = 0; k < 20; ++k) {
      // A receiver in front of the lamp (any distance, any normal but one facing straight away) can be lit.
      const Vec3 d = sample_uniform_sphere(Vec2(rng.next_float(), rng.next_float()));
      const Vec3 dir = glm::dot(d, front) >= 0.f ? d : -d;
      const float dist = 0.05f + 20.f * rng.next_float();
      const Vec3 p = c + dist * dir;
      const Vec3 n = -dir;
      CHECK(light_choice_pmf(s, p, n, static_cast<int>(li)) > 0.f);
      ++in_front;
      // Behind a two-sided lamp, as in front.
      if (l.two_sided) CHECK(light_choice_pmf(s, c - dist * dir, dir, static_cast<int>(li)) > 0.f);
      // Behind a one-sided lamp, out of its bounding sphere's reach (the bounds are conservative: within 1.5 of
      // a lamp of half-diagonal 0.28 they cannot tell its back from its front), nothing.
      if (!l.two_sided && glm::dot(dir, front) > 0.2f) {
        const float far = 2.f + 18.f * rng.next_float();
        CHECK(light_choice_pmf(s, c - far * dir, dir, static_cast<int>(li)) == 0.f);
        ++behind;
      }
    }
  }
  CHECK(in_front >= 600);
  CHECK(behind >= 300);
}

TEST_CASE("light tree: a spot keeps a chance inside its outer cone and none well outside it") {
  // The spot's bounds (pbrt-v4's SpotLight::Bounds) rule out receivers its falloff cannot reach (a spot bounded
  // as a point light fails the second check) and keep every one it reaches.
  const auto scene = compile_scene(many_lamps(40));
  const Scene& s = *scene;
  REQUIRE_FALSE(s.light_tree.empty());
  Pcg32 rng(4, 1);
  int spots = 0, inside = 0, outside = 0;
  for (size_t li = 0; li < s.lights.size(); ++li) {
    const Light& l = s.lights[li];
    if (l.kind != LightKind::Spot) continue;
    ++spots;
    for (int k = 0; k < 4000; ++k) {
      // Receivers on the floor facing up, and anywhere above it facing any way.
      // (The compiled scene is camera-relative.)
      const Vec3 p = Vec3(DVec3(-6.f + 12.f * rng.next_float(), k % 2 == 0 ? 0.f : 3.f * rng.next_float(),
                                -6.f + 12.f * rng.next_float()) - s.world_origin);
      const Vec3 n = k % 2 == 0 ? Vec3(0, 1, 0) : sample_uniform_sphere(Vec2(rng.next_float(), rng.next_float()));
      const Vec3 to_p = glm::normalize(p - l.position);
      const float cos_axis = glm::dot(to_p, l.direction);
      if (glm::dot(n, -to_p) <= 0.01f) continue;  // the receiver's back to the spot: no light either way
      if (spot_falloff(l, cos_axis) > 0.f) {
        CHECK(light_choice_pmf(s, p, n, static_cast<int>(li)) > 0.f);
        ++inside;
      } else if (cos_axis < l.cos_outer - 0.02f) {
        CHECK(light_choice_pmf(s, p, n, static_cast<int>(li)) == 0.f);
        ++outside;
      }
    }
  }
  CHECK(spots == 2);
  CHECK(inside >= 400);
  CHECK(outside >= 3000);
}

TEST_CASE("light tree: images with it agree with power-proportional choice, under nee and mis") {
  // 8×8-block means against the films' own variances (blocks_agree: Bonferroni α = 1e-5 and a χ² bound), a
  // biased choice probability (the tree's share left out, a lamp's back ruled out for a two-sided lamp) fails it.
  const SceneDesc desc = many_lamps(40);
  const auto tree = compile_scene(desc);
  REQUIRE_FALSE(tree->light_tree.empty());
  auto power = compile_scene(desc);
  power->light_tree = LightTree();
  for (Estimator est : {Estimator::Nee, Estimator::Mis}) {
    CAPTURE(std::string(to_string(est)));
    const Film a = render(*tree, desc.render, est, 256, 1);
    const Film b = render(*power, desc.render, est, 1024, 2);
    CHECK(blocks_agree(a, b, std::string("tree against power, ") + std::string(to_string(est))));
  }
}

TEST_CASE("light tree: the scalar and the wavefront path loops (its shading lanes) choose alike, bit for bit") {
  // The lanes choose a lamp for each Lambertian floor hit through the tree, with the lit side's normal the scalar
  // loop passes; a different normal or point changes the choice probabilities and the image.
  SceneDesc desc = many_lamps(40);
  desc.render.sampler = SamplerType::Sobol;
  const auto scene = compile_scene(desc);
  REQUIRE_FALSE(scene->light_tree.empty());
  for (Estimator est : {Estimator::Nee, Estimator::Mis}) {
    CAPTURE(std::string(to_string(est)));
    RenderSettings settings = desc.render;
    settings.path_loop = PathLoop::Scalar;
    REQUIRE(Renderer::describe_path(*scene, [&] { RenderSettings r = settings; r.estimator = est; r.path_loop = PathLoop::Wavefront; return r; }())
                .find("SIMD shading lanes") != std::string::npos);
    const std::vector<float> a = render(*scene, settings, est, 3, 1).mean_image();
    settings.path_loop = PathLoop::Wavefront;
    const std::vector<float> b = render(*scene, settings, est, 3, 1).mean_image();
    REQUIRE(a.size() == b.size());
    CHECK(std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0);
  }
}
