// Ray–primitive intersection: hits, misses, watertight shared edges and vertices, back faces, rays from inside
// spheres, parallel rays, huge and tiny radii, and the scene-level closest/any-hit queries.
#include <doctest/doctest.h>

#include "geometry/geometry.h"
#include "core/rng.h"
#include "scene/scene.h"
#include "scene/scene_json.h"

using namespace pt;

namespace {

bool tri(Vec3 a, Vec3 b, Vec3 c, Vec3 o, Vec3 d, PolygonHit& h, float t_max = kInfinity) {
  return intersect_triangle(a, b, c, o, RayShear(d), t_max, h);
}

}  // namespace

TEST_CASE("triangle: hit, barycentrics, miss, back face, t range") {
  const Vec3 a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);
  PolygonHit h;
  REQUIRE(tri(a, b, c, Vec3(0.25f, 0.25f, 1), Vec3(0, 0, -1), h));
  CHECK(h.t == doctest::Approx(1.0).epsilon(1e-6));
  CHECK(h.b0 == doctest::Approx(0.5).epsilon(1e-6));
  CHECK(h.b1 == doctest::Approx(0.25).epsilon(1e-6));
  CHECK(h.b2 == doctest::Approx(0.25).epsilon(1e-6));
  // From behind: geometry is two-sided for intersection.
  REQUIRE(tri(a, b, c, Vec3(0.25f, 0.25f, -2), Vec3(0, 0, 1), h));
  CHECK(h.t == doctest::Approx(2.0).epsilon(1e-6));
  // Outside the triangle (beyond the hypotenuse).
  CHECK_FALSE(tri(a, b, c, Vec3(0.6f, 0.6f, 1), Vec3(0, 0, -1), h));
  // Behind the origin: t must be positive.
  CHECK_FALSE(tri(a, b, c, Vec3(0.25f, 0.25f, 1), Vec3(0, 0, 1), h));
  // Beyond t_max.
  CHECK_FALSE(tri(a, b, c, Vec3(0.25f, 0.25f, 1), Vec3(0, 0, -1), h, 0.99f));
  // Parallel to the plane, inside the plane and beside it.
  CHECK_FALSE(tri(a, b, c, Vec3(-1, 0.25f, 0), Vec3(1, 0, 0), h));
  CHECK_FALSE(tri(a, b, c, Vec3(-1, 0.25f, 0.5f), Vec3(1, 0, 0), h));
}

TEST_CASE("watertight: rays through a shared edge of two triangles never pass between them") {
  // Two triangles (a,b,c) and (c,b,d) sharing edge b–c, in a tilted plane far from the axes.
  const Vec3 a(0.3f, -1.1f, 2.7f), b(3.1f, 0.2f, 1.9f), c(0.9f, 2.4f, 3.3f), d(3.6f, 2.9f, 2.2f);
  Pcg32 rng(42, 7);
  int misses = 0, double_hits = 0;
  const int n = 200000;
  for (int i = 0; i < n; ++i) {
    // A point exactly on the shared edge (as exactly as float allows) and a random origin in front.
    const float s = rng.next_float();
    const Vec3 target = b + s * (c - b);
    const Vec3 o = target + Vec3(rng.next_float() * 4 - 2, rng.next_float() * 4 - 2, 3 + rng.next_float() * 5);
    const Vec3 dir = glm::normalize(target - o);
    PolygonHit h1, h2;
    const bool hit1 = tri(a, b, c, o, dir, h1), hit2 = tri(c, b, d, o, dir, h2);
    misses += !hit1 && !hit2;
    double_hits += hit1 && hit2;
  }
  CHECK(misses == 0);
  INFO("rays reporting both triangles (allowed, not a leak): " << double_hits);
}

TEST_CASE("watertight: rays through a vertex shared by a fan of triangles hit at least one") {
  // Six triangles around a shared centre vertex, plus the same fan as parallelogram-free quads.
  const Vec3 centre(1.7f, -0.3f, 0.9f);
  Vec3 ring[6];
  for (int k = 0; k < 6; ++k) {
    const float ang = static_cast<float>(k) * 2.f * kPi / 6.f + 0.1f;
    ring[k] = centre + Vec3(std::cos(ang), std::sin(ang), 0.2f * std::sin(3.f * ang));
  }
  Pcg32 rng(3, 9);
  int misses = 0;
  for (int i = 0; i < 50000; ++i) {
    const Vec3 o = centre + Vec3(rng.next_float() * 6 - 3, rng.next_float() * 6 - 3, 2 + rng.next_float() * 4);
    const Vec3 dir = glm::normalize(centre - o);
    bool any = false;
    for (int k = 0; k < 6; ++k) {
      PolygonHit h;
      any |= tri(centre, ring[k], ring[(k + 1) % 6], o, dir, h);
    }
    misses += !any;
  }
  CHECK(misses == 0);
}

TEST_CASE("watertight: a parallelogram and a triangle sharing an edge") {
  // Parallelogram (a,b,c,d) and triangle (d,c,e) share edge c–d.
  const Vec3 a(0, 0, 0), b(2.3f, 0.1f, 0.4f), c(2.9f, 1.7f, 0.2f), d = a + c - b, e(1.1f, 3.5f, -0.6f);
  Pcg32 rng(5, 1);
  int misses = 0;
  for (int i = 0; i < 100000; ++i) {
    const Vec3 target = c + rng.next_float() * (d - c);
    const Vec3 o = target + Vec3(rng.next_float() * 4 - 2, rng.next_float() * 4 - 2, 1 + rng.next_float() * 5);
    const Vec3 dir = glm::normalize(target - o);
    PolygonHit h;
    const RayShear sh(dir);
    const bool p = intersect_quad(a, b, c, d, o, sh, kInfinity, h);
    const bool t = intersect_triangle(d, c, e, o, sh, kInfinity, h);
    misses += !p && !t;
  }
  CHECK(misses == 0);
}

TEST_CASE("parallelogram: inside, outside each edge, t and barycentrics") {
  const Vec3 a(0, 0, 0), b(2, 0, 0), c(3, 1, 0), d(1, 1, 0);
  PolygonHit h;
  const Vec3 down(0, 0, -1);
  const RayShear sh(down);
  REQUIRE(intersect_quad(a, b, c, d, Vec3(1.5f, 0.5f, 2), sh, kInfinity, h));
  CHECK(h.t == doctest::Approx(2.0).epsilon(1e-6));
  const Vec3 p = h.b0 * a + h.b1 * b + h.b2 * c;
  CHECK(p.x == doctest::Approx(1.5).epsilon(1e-5));
  CHECK(p.y == doctest::Approx(0.5).epsilon(1e-5));
  // A point in the (a,c,d) half, outside triangle (a,b,c): barycentrics extrapolate, the hit is still found.
  REQUIRE(intersect_quad(a, b, c, d, Vec3(1.2f, 0.8f, 2), sh, kInfinity, h));
  for (Vec3 o : {Vec3(0.1f, 0.5f, 2), Vec3(2.9f, 0.5f, 2), Vec3(1.5f, -0.1f, 2), Vec3(1.5f, 1.1f, 2)})
    CHECK_FALSE(intersect_quad(a, b, c, d, o, sh, kInfinity, h));
}

TEST_CASE("sphere: outside, inside, tangent, behind, misses") {
  const DVec3 c(0, 0, -5);
  float t;
  REQUIRE(intersect_sphere(c, 1.0, Vec3(0), Vec3(0, 0, -1), kInfinity, t));
  CHECK(t == doctest::Approx(4.0).epsilon(1e-6));
  // From inside: the far root.
  REQUIRE(intersect_sphere(c, 1.0, Vec3(0, 0, -5), Vec3(0, 0, -1), kInfinity, t));
  CHECK(t == doctest::Approx(1.0).epsilon(1e-6));
  // Behind the ray.
  CHECK_FALSE(intersect_sphere(c, 1.0, Vec3(0), Vec3(0, 0, 1), kInfinity, t));
  // Miss to the side, and t_max cut-off.
  CHECK_FALSE(intersect_sphere(c, 1.0, Vec3(1.01f, 0, 0), Vec3(0, 0, -1), kInfinity, t));
  CHECK_FALSE(intersect_sphere(c, 1.0, Vec3(0), Vec3(0, 0, -1), 3.9f, t));
  // Grazing just inside the silhouette still hits.
  CHECK(intersect_sphere(c, 1.0, Vec3(0.999f, 0, 0), Vec3(0, 0, -1), kInfinity, t));
}

TEST_CASE("sphere: huge and tiny radii and distant spheres keep float-level accuracy") {
  float t;
  // A sphere of radius 1e7 whose surface passes 1 unit below the origin: the plane y = −1 to the eye.
  const double R = 1e7;
  const DVec3 c(0, -1.0 - R, 0);
  const Vec3 d = glm::normalize(Vec3(0.3f, -1.f, 0.2f));
  REQUIRE(intersect_sphere(c, R, Vec3(0), d, kInfinity, t));
  // Exact distance to the sphere, solved in long double.
  {
    const long double dx = d.x, dy = d.y, dz = d.z, cy = c.y, r = R;
    const long double b = -(dy * -cy), cc = cy * cy - r * r;  // f = o − c = (0, −cy, 0)
    const long double disc = b * b - (dx * dx + dy * dy + dz * dz) * cc;
    const long double t_exact = (b - std::sqrt(disc)) / (dx * dx + dy * dy + dz * dz);
    CHECK(std::abs(t - static_cast<double>(t_exact)) <= 4e-7 * static_cast<double>(t_exact));
  }
  // A tiny sphere (1e-4) at distance 1: hit at 1 − 1e-4.
  REQUIRE(intersect_sphere(DVec3(0, 0, -1), 1e-4, Vec3(0), Vec3(0, 0, -1), kInfinity, t));
  CHECK(t == doctest::Approx(1.0 - 1e-4).epsilon(1e-6));
  // A unit sphere 1e6 away: its near surface at 1e6 − 1.
  REQUIRE(intersect_sphere(DVec3(0, 0, -1e6), 1.0, Vec3(0), Vec3(0, 0, -1), kInfinity, t));
  CHECK(t == doctest::Approx(1e6 - 1.0).epsilon(1e-7));
  // A ray just missing a tiny distant sphere, just outside its silhouette.
  CHECK_FALSE(intersect_sphere(DVec3(0, 0, -1e3), 1e-3, Vec3(1.001e-3f, 0, 0), Vec3(0, 0, -1), kInfinity, t));
}

TEST_CASE("scene queries: closest hit, skip, occlusion") {
  SceneDesc s;
  s.camera.position = {0, 0, 5};
  s.camera.look_at = {0, 0, 0};
  s.materials.push_back({"m", MaterialType::Diffuse, Rgb(0.5f), Rgb(0.f), false, 1.5f});
  ShapeDesc near_quad;
  near_quad.type = ShapeType::Quad;
  near_quad.vertices = {DVec3(-1, -1, 1), DVec3(1, -1, 1), DVec3(1, 1, 1), DVec3(-1, 1, 1)};
  ShapeDesc far_tri;
  far_tri.type = ShapeType::Triangle;
  far_tri.vertices = {DVec3(-2, -2, 0), DVec3(2, -2, 0), DVec3(0, 2, 0), DVec3(0)};
  ShapeDesc ball;
  ball.type = ShapeType::Sphere;
  ball.center = {0, 0, -3};
  ball.radius = 0.5;
  s.shapes = {far_tri, near_quad, ball};
  const auto scene = compile_scene(s);
  REQUIRE(scene->polygons.size() == 2);
  REQUIRE(scene->polygons.triangle[0] == 1);  // polygons keep the order of the shapes
  REQUIRE(scene->polygons.triangle[1] == 0);
  const Ray ray{Vec3(0), Vec3(0, 0, -1)};  // camera-relative: the camera sits at z = 5
  Hit h;
  REQUIRE(scene->intersect(ray, kInfinity, ~0u, h));
  CHECK(h.prim == 1u);
  CHECK(h.t == doctest::Approx(4.0));
  REQUIRE(scene->intersect(ray, kInfinity, 1u, h));
  CHECK(h.prim == 0u);
  CHECK(h.t == doctest::Approx(5.0));
  CHECK(scene->occluded(ray, 10.f, ~0u, ~0u));
  CHECK_FALSE(scene->occluded(ray, 3.9f, ~0u, ~0u));
  CHECK(scene->occluded(ray, 10.f, 1u, 0u));  // the sphere still blocks
  CHECK_FALSE(scene->occluded(ray, 7.f, 1u, 0u));  // sphere starts at 7.5
}

TEST_CASE("SIMD polygon kernels agree bit for bit with the scalar tests") {
  // Random rays from inside the Cornell box (17 polygons: a full SIMD block and a narrow tail, triangles and
  // quads mixed) and from outside it: the closest hit (distance and polygon) and the any-hit answer must equal a
  // brute-force loop over the scalar watertight tests.
  const auto scene = compile_scene(load_scene("cornell"));
  REQUIRE(scene->polygons.size() == 17);
  Pcg32 rng(11, 5);
  int hits = 0;
  for (int i = 0; i < 20000; ++i) {
    const bool inside = i % 2 == 0;
    const Vec3 o = inside ? Vec3(rng.next_float() * 500 - 250, rng.next_float() * 500 - 250, rng.next_float() * 500 + 820)
                          : Vec3(rng.next_float() * 4 - 2, rng.next_float() * 4 - 2, 0);
    Vec3 d(rng.next_float() * 2 - 1, rng.next_float() * 2 - 1, rng.next_float() * 2 - 1);
    if (!inside) d.z = std::abs(d.z) + 1;
    d = glm::normalize(d);
    const uint32_t skip = i % 3 == 0 ? rng.next_u32() % 17 : ~0u;
    const RayShear shear(d);
    float best = kInfinity;
    uint32_t best_id = ~0u;
    for (uint32_t p = 0; p < 17; ++p) {
      PolygonHit h;
      if (p != skip && intersect_polygon(scene->polygons, p, o, shear, best, h) && h.t < best) {
        best = h.t;
        best_id = p;
      }
    }
    Hit hit;
    const bool found = scene->intersect({o, d}, kInfinity, skip, hit);
    INFO("ray " << i);
    REQUIRE(found == (best_id != ~0u));
    if (found) {
      ++hits;
      CHECK(hit.prim == best_id);
      CHECK(hit.t == best);  // bit-identical distances
      // Shadow queries just short of and beyond the hit.
      CHECK_FALSE(scene->occluded({o, d}, best, skip, ~0u));
      CHECK(scene->occluded({o, d}, std::nextafter(best, kInfinity), skip, ~0u));
    }
  }
  CHECK(hits > 10000);
}
