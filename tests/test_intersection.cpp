// Ray–primitive intersection: hits, misses, watertight shared edges and vertices, back faces, rays from inside
// spheres, parallel rays, huge and tiny radii, and the scene-level closest/any-hit queries.
#include <array>
#include <bit>
#include <doctest/doctest.h>

#include "geometry/geometry.h"
#include "geometry/packet_polygons.h"
#include "geometry/polygon_bvh.h"
#include "core/rng.h"
#include "scene/scene.h"
#include "scene/scene_json.h"

#include "test_helpers.h"

using namespace pt;

namespace {

bool tri(Vec3 a, Vec3 b, Vec3 c, Vec3 o, Vec3 d, PolygonHit& h, float t_max = kInfinity) {
  return intersect_triangle(a, b, c, o, RayShear(d), t_max, h);
}

}  // namespace

TEST_CASE("shear: z is the axis of largest |d| (max_dimension's ties), x and y the next two in turn, swapped where d[z] < 0") {
  // Woop et al. 2013's rule, written out: kz = max_dimension(|d|), kx and ky the next two axes cyclically, and
  // kx, ky swapped when d[kz] < 0 so that the edge functions keep their sign. Every direction whose components
  // come from {0, -0, ±0.5, ±1, 2} (ties, zeros and signs), and random ones.
  const float values[7] = {0.f, -0.f, 0.5f, -0.5f, 1.f, -1.f, 2.f};
  const auto check = [](Vec3 d) {
    const int kz = max_dimension(glm::abs(d));
    int kx = (kz + 1) % 3, ky = (kz + 2) % 3;
    if (d[kz] < 0.f) std::swap(kx, ky);
    const RayShear s(d);
    CHECK(s.kz == kz);
    CHECK(s.kx == kx);
    CHECK(s.ky == ky);
    if (d[kz] != 0.f) {
      CHECK(s.sz == 1.f / d[kz]);
      CHECK(s.sx == d[kx] * s.sz);
      CHECK(s.sy == d[ky] * s.sz);
    }
  };
  for (float x : values)
    for (float y : values)
      for (float z : values) check(Vec3(x, y, z));
  Pcg32 rng(5, 3);
  for (int i = 0; i < 1000; ++i) check(Vec3(rng.next_float() - 0.5f, rng.next_float() - 0.5f, rng.next_float() - 0.5f));
  // Two ties spelled out: |x| = |y| > |z| picks y, |x| = |z| > |y| picks z.
  CHECK(RayShear(Vec3(1.f, -1.f, 0.5f)).kz == 1);
  CHECK(RayShear(Vec3(-1.f, 0.5f, 1.f)).kz == 2);
}

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

// The spheres' SIMD step (geometry/sphere_lanes.h) passes on only the spheres whose discriminant is not negative;
// it must never drop one that intersect_sphere would hit, so that a scene's sphere queries answer as a loop over
// every sphere does, bit for bit. 21 spheres (full blocks of lanes and a partial one), radii from 1e-3 to 1e5;
// random rays, rays from inside, and rays along each sphere's silhouette jittered by a few ulps (discriminants
// within rounding of 0: about half of them hit).
TEST_CASE("spheres: the lanes drop only spheres the ray misses, so the scene's queries answer as a loop over all") {
  SceneDesc desc;
  desc.camera.position = {0, 0, 0};
  desc.camera.look_at = {0, 0, -1};
  desc.materials.push_back(test::diffuse_material("m", Rgb(0.5f), Rgb(0.f), false));
  Pcg32 rng(48, 3);
  const auto uniform = [&](float lo, float hi) { return lo + (hi - lo) * rng.next_float(); };
  for (int i = 0; i < 21; ++i) {
    ShapeDesc ball;
    ball.type = ShapeType::Sphere;
    ball.center = {uniform(-200.f, 200.f), uniform(-200.f, 200.f), uniform(-200.f, 200.f)};
    ball.radius = i == 0 ? 1e5 : i == 1 ? 1e-3 : double(uniform(0.5f, 40.f));
    if (i == 0) ball.center = {0, -1e5 - 250, 0};  // a huge floor below all the others
    desc.shapes.push_back(ball);
  }
  const auto scene = compile_scene(desc);
  const SphereSoA& S = scene->spheres;
  REQUIRE(S.size() == 21);
  REQUIRE(S.size() >= kSphereLanesFrom);  // the lanes' path
  REQUIRE(S.lanes.blocks() == (21 + kSphereLanes - 1) / kSphereLanes);
  const auto unit = [&] {
    for (;;) {
      const Vec3 v(uniform(-1.f, 1.f), uniform(-1.f, 1.f), uniform(-1.f, 1.f));
      if (glm::dot(v, v) > 1e-4f && glm::dot(v, v) <= 1.f) return glm::normalize(v);
    }
  };
  std::vector<Ray> rays;
  std::vector<uint32_t> grazed;  // per ray: the sphere whose silhouette it follows, or ~0u
  for (int k = 0; k < 3000; ++k) rays.push_back({Vec3(uniform(-300.f, 300.f), uniform(-300.f, 300.f), uniform(-300.f, 300.f)), unit()});
  for (size_t i = 1; i < S.size(); ++i) {
    for (int k = 0; k < 150; ++k) {
      // Along the silhouette: the tangent direction at angle asin(r / D) from the centre's, jittered.
      const Vec3 o = Vec3(S.center[i]) + unit() * float(S.radius[i] * uniform(1.5f, 20.f));
      const DVec3 w = S.center[i] - DVec3(o);
      const double D = glm::length(w);
      const DVec3 axis = w / D;
      DVec3 side = glm::cross(axis, DVec3(unit()));
      side = glm::normalize(side);
      const double sin_t = S.radius[i] / D * (1.0 + 1e-7 * uniform(-4.f, 4.f));
      rays.push_back({o, Vec3(glm::normalize(std::sqrt(1.0 - sin_t * sin_t) * axis + sin_t * side))});
      grazed.resize(rays.size(), ~0u);
      grazed.back() = static_cast<uint32_t>(i);
    }
    for (int k = 0; k < 20; ++k)  // from inside
      rays.push_back({Vec3(S.center[i]) + unit() * float(S.radius[i] * uniform(0.f, 0.9f)), unit()});
  }
  grazed.resize(rays.size(), ~0u);
  size_t candidates = 0, hits = 0, grazing = 0, graze_hits = 0;
  for (size_t r = 0; r < rays.size(); ++r) {
    const Ray& ray = rays[r];
    CAPTURE(r);
    std::vector<uint8_t> candidate(S.size(), 0);
    visit_sphere_candidates(S.lanes, ray.o, ray.d, [&](uint32_t i) {
      candidate[i] = 1;
      return false;
    });
    // The plain loop: the nearest hit and a shadow query skipping sphere `skip`, then the same through the scene.
    float t_near = kInfinity, t;
    uint32_t id = ~0u;
    const uint32_t skip = r % 3 == 0 ? static_cast<uint32_t>(r % S.size()) : ~0u;
    bool blocked = false;
    for (uint32_t i = 0; i < S.size(); ++i) {
      const bool hit = intersect_sphere(S.center[i], S.radius[i], ray.o, ray.d, kInfinity, t);
      CHECK((!hit || candidate[i] != 0));  // never a hit the lanes dropped
      candidates += candidate[i];
      hits += hit;
      if (grazed[r] == i) ++grazing, graze_hits += hit;
      if (intersect_sphere(S.center[i], S.radius[i], ray.o, ray.d, t_near, t)) t_near = t, id = i;
      blocked = blocked || (i != skip && intersect_sphere(S.center[i], S.radius[i], ray.o, ray.d, 1e4f, t));
    }
    Hit h;
    const bool found = scene->intersect(ray, kInfinity, ~0u, h);
    CHECK(found == (id != ~0u));
    if (found && id != ~0u) {
      CHECK(h.prim == id);
      CHECK(std::bit_cast<uint32_t>(h.t) == std::bit_cast<uint32_t>(t_near));
    }
    CHECK(scene->occluded(ray, 1e4f, skip, ~0u) == blocked);
  }
  MESSAGE(rays.size() << " rays, " << candidates << " candidates of " << rays.size() * S.size() << " tests, " << hits
                      << " hits; " << graze_hits << " of " << grazing << " grazing rays hit their sphere");
  CHECK(candidates < rays.size() * S.size() / 2);  // the lanes drop most spheres, or they would not pay
  // The silhouette rays straddle it: both outcomes occur often.
  CHECK(graze_hits > grazing / 5);
  CHECK(graze_hits < grazing * 4 / 5);
}

TEST_CASE("scene queries: closest hit, skip, occlusion") {
  SceneDesc s;
  s.camera.position = {0, 0, 5};
  s.camera.look_at = {0, 0, 0};
  s.materials.push_back(test::diffuse_material("m", Rgb(0.5f), Rgb(0.f), false));
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

namespace {

// A polygon soup as the scene stores it (a triangle repeats vertex a as its fourth vertex).
struct Soup {
  std::vector<Vec3> v[4];
  std::vector<uint8_t> triangle;
  void add_triangle(Vec3 a, Vec3 b, Vec3 c) { add(a, b, c, a, true); }
  void add_parallelogram(Vec3 a, Vec3 b, Vec3 d) { add(a, b, b + d - a, d, false); }
  void add(Vec3 a, Vec3 b, Vec3 c, Vec3 d, bool tri) {
    v[0].push_back(a), v[1].push_back(b), v[2].push_back(c), v[3].push_back(d);
    triangle.push_back(tri);
  }
  bool test(uint32_t i, Vec3 o, const RayShear& s, float t_max, PolygonHit& h) const {
    if (triangle[i]) return intersect_triangle(v[0][i], v[1][i], v[2][i], o, s, t_max, h);
    return intersect_quad(v[0][i], v[1][i], v[2][i], v[3][i], o, s, t_max, h);
  }
};

// A closed lat-long triangulated sphere of radius 3 about the origin; returns its vertex (ring i, segment j).
struct SphereMesh {
  int rings, segments;
  Vec3 point(int i, int j) const {
    const float th = glm::pi<float>() * i / rings, ph = 2 * glm::pi<float>() * (j % segments) / segments;
    return Vec3(std::sin(th) * std::cos(ph), std::cos(th), std::sin(th) * std::sin(ph)) * 3.f;
  }
  void add_to(Soup& soup) const {
    for (int i = 0; i < rings; ++i)
      for (int j = 0; j < segments; ++j) {
        if (i > 0) soup.add_triangle(point(i, j), point(i, j + 1), point(i + 1, j));
        if (i < rings - 1) soup.add_triangle(point(i, j + 1), point(i + 1, j + 1), point(i + 1, j));
      }
  }
};

// Checks closest and any-hit queries through the hierarchy against a loop over the scalar tests, ray by ray:
// the same distance bit for bit and the same polygon (or, on an exact tie, one hit at that distance).
// Every third ray skips a polygon (as a ray leaving a surface does) unless `skips` is false.
int check_bvh_against_brute_force(const Soup& soup, const std::vector<std::pair<Vec3, Vec3>>& rays, bool skips = true) {
  const PolygonBvh bvh = build_polygon_bvh(soup.v, soup.triangle);
  REQUIRE(!bvh.empty());
  // Every polygon sits in at least one lane (in several where spatial splits clipped it).
  std::vector<int> lanes_of(soup.triangle.size(), 0);
  for (uint32_t p : bvh.lane_polygon)
    if (p != kNoLanePolygon) ++lanes_of.at(p);
  REQUIRE(*std::min_element(lanes_of.begin(), lanes_of.end()) >= 1);
  const uint32_t n = static_cast<uint32_t>(soup.triangle.size());
  int hits = 0;
  for (size_t r = 0; r < rays.size(); ++r) {
    const Vec3 o = rays[r].first, d = rays[r].second;  // not a structured binding: lambdas below capture them
    const RayShear shear(d);
    const uint32_t skip = skips && r % 3 == 0 ? static_cast<uint32_t>(r * 7919 % n) : ~0u;
    float best = kInfinity;
    uint32_t best_id = ~0u;
    for (uint32_t p = 0; p < n; ++p) {
      PolygonHit h;
      if (p != skip && soup.test(p, o, shear, best, h) && h.t < best) best = h.t, best_id = p;
    }
    const auto scalar = [&](uint32_t i, float tm, PolygonHit& h) { return soup.test(i, o, shear, tm, h); };
    float t = kInfinity;
    uint32_t id = ~0u;
    const bool found = closest_polygon_bvh(bvh, o, d, shear, skip, t, id, scalar);
    INFO("ray " << r << " o " << o.x << " " << o.y << " " << o.z << " d " << d.x << " " << d.y << " " << d.z);
    REQUIRE(found == (best_id != ~0u));
    if (!found) continue;
    ++hits;
    CHECK(t == best);
    if (id != best_id) {  // a tie: the hierarchy's polygon must hit at the same distance
      PolygonHit h;
      CHECK((id != skip && soup.test(id, o, shear, kInfinity, h) && h.t == best));
    }
    CHECK_FALSE(any_polygon_bvh(bvh, o, d, shear, skip, ~0u, best, scalar));
    CHECK(any_polygon_bvh(bvh, o, d, shear, skip, ~0u, std::nextafter(best, kInfinity), scalar));
  }
  return hits;
}

// How many leaves of each kind the hierarchy holds: [triangles only][8 lanes].
std::array<std::array<int, 2>, 2> leaf_census(const PolygonBvh& bvh) {
  std::array<std::array<int, 2>, 2> n{};
  for (const BvhNode& node : bvh.nodes)
    for (uint32_t ref : node.child)
      if (is_leaf_ref(ref)) ++n[ref_triangles(ref)][ref_lanes(ref) == 8];
  return n;
}

// How many polygons sit in more than one lane (placed in several leaves by spatial splits).
int split_polygons(const PolygonBvh& bvh, size_t polygons) {
  std::vector<int> lanes(polygons, 0);
  for (uint32_t p : bvh.lane_polygon)
    if (p != kNoLanePolygon) ++lanes.at(p);
  return static_cast<int>(std::count_if(lanes.begin(), lanes.end(), [](int n) { return n > 1; }));
}

Vec3 random_in(Pcg32& rng, float lo, float hi) {
  return Vec3(lo + (hi - lo) * rng.next_float(), lo + (hi - lo) * rng.next_float(), lo + (hi - lo) * rng.next_float());
}

}  // namespace

TEST_CASE("BVH: closest and any hit equal brute force bit for bit (soups, a closed mesh, degenerate layouts)") {
  Pcg32 rng(20261123, 3);
  std::vector<std::pair<Vec3, Vec3>> rays;
  auto random_rays = [&](int count, float lo, float hi) {
    rays.clear();
    for (int i = 0; i < count; ++i) {
      Vec3 d = random_in(rng, -1, 1);
      // Every eighth ray axis-aligned (two components exactly 0), from an origin on a box plane (coordinate 0).
      if (i % 8 == 0) d = Vec3(0), d[i % 3] = i % 16 == 0 ? 1.f : -1.f;
      Vec3 o = random_in(rng, lo, hi);
      if (i % 8 == 0) o[(i + 1) % 3] = 0.f;
      rays.push_back({o, d});
    }
  };
  SUBCASE("3000 random triangles and parallelograms") {
    Soup soup;
    for (int i = 0; i < 3000; ++i) {
      const Vec3 a = random_in(rng, -10, 10), b = a + random_in(rng, -1, 1), c = a + random_in(rng, -1, 1);
      if (i % 2) soup.add_triangle(a, b, c);
      else soup.add_parallelogram(a, b, c);
    }
    random_rays(20000, -12, 12);
    // The mixed leaves' kernels run, 4 and 8 lanes (the sphere below runs the triangles-only ones).
    const auto census = leaf_census(build_polygon_bvh(soup.v, soup.triangle));
    CHECK(census[0][0] > 50);
    CHECK(census[0][1] > 50);
    CHECK(check_bvh_against_brute_force(soup, rays) > 5000);
  }
  SUBCASE("a closed triangulated sphere seen from inside: every ray hits (watertight through the hierarchy)") {
    Soup soup;
    const SphereMesh sphere{40, 80};
    sphere.add_to(soup);
    random_rays(20000, -1, 1);
    // Rays through the shared vertices and edges too: aimed exactly at vertices of the mesh.
    for (int k = 0; k < 2000; ++k) rays.push_back({Vec3(0.f), sphere.point(1 + k % (sphere.rings - 1), k)});
    // Every leaf is a triangles-only one (the kernel without the fourth corner), of 4 and of 8 lanes.
    const auto census = leaf_census(build_polygon_bvh(soup.v, soup.triangle));
    CHECK(census[0][0] + census[0][1] == 0);
    CHECK(census[1][0] > 50);
    CHECK(census[1][1] > 50);
    CHECK(check_bvh_against_brute_force(soup, rays, false) == static_cast<int>(rays.size()));
    CHECK(check_bvh_against_brute_force(soup, rays) > 19000);
  }
  SUBCASE("long slivers clipped by spatial splits: tubes through a cluster inside a closed sphere of slivers") {
    // Spatial splits place a polygon in several leaves, each bounding only its part: a ray must still find every
    // polygon there, and no ray may leave the closed sphere (watertight through the clipped boxes).
    Soup soup;
    const SphereMesh sphere{3, 400};  // pole-to-pole slivers
    sphere.add_to(soup);
    for (int i = 0; i < 2000; ++i) {  // small triangles filling the unit ball
      Vec3 c = random_in(rng, -1, 1);
      while (glm::dot(c, c) > 1.f) c = random_in(rng, -1, 1);
      soup.add_triangle(c + random_in(rng, -0.05f, 0.05f), c + random_in(rng, -0.05f, 0.05f),
                        c + random_in(rng, -0.05f, 0.05f));
    }
    for (int t = 0; t < 12; ++t) {  // tubes of radius 0.05 and length 4 through the ball, 48 slivers each
      const int axis = t % 3;
      const Vec3 offset = random_in(rng, -0.6f, 0.6f);
      const auto point = [&](int j, float s) {
        const float a = 2 * glm::pi<float>() * static_cast<float>(j) / 24.f;
        Vec3 p = offset;
        p[axis] = s;
        p[(axis + 1) % 3] += 0.05f * std::cos(a);
        p[(axis + 2) % 3] += 0.05f * std::sin(a);
        return p;
      };
      for (int j = 0; j < 24; ++j) {
        soup.add_triangle(point(j, -2), point(j + 1, -2), point(j, 2));
        soup.add_triangle(point(j + 1, -2), point(j + 1, 2), point(j, 2));
      }
    }
    random_rays(20000, -1, 1);
    for (int k = 0; k < 2000; ++k) rays.push_back({Vec3(0.f), sphere.point(1 + k % (sphere.rings - 1), k)});
    // The tubes' slivers are split (and nothing is without spatial splits).
    CHECK(split_polygons(build_polygon_bvh(soup.v, soup.triangle), soup.triangle.size()) > 50);
    CHECK(split_polygons(build_polygon_bvh(soup.v, soup.triangle, BvhSplits::Objects), soup.triangle.size()) == 0);
    CHECK(check_bvh_against_brute_force(soup, rays, false) == static_cast<int>(rays.size()));
    CHECK(check_bvh_against_brute_force(soup, rays) > 19000);
  }
  SUBCASE("degenerate layouts: 300 polygons with one centroid, and axis-aligned flat polygons in one plane") {
    Soup soup;
    for (int i = 0; i < 300; ++i) {
      const float a = 0.01f * i;
      const Vec3 u(std::cos(a), std::sin(a), 0.3f), w(-std::sin(a), std::cos(a), -0.2f);
      soup.add_triangle(u, w - u, -w);  // centroid 0 for every one
    }
    for (int i = 0; i < 30; ++i)
      for (int j = 0; j < 30; ++j)  // a 30×30 grid of unit squares in the plane z = 0 (flat boxes)
        soup.add_parallelogram(Vec3(i - 15, j - 15, 0), Vec3(i - 14, j - 15, 0), Vec3(i - 15, j - 14, 0));
    random_rays(20000, -4, 4);
    CHECK(check_bvh_against_brute_force(soup, rays) > 5000);
  }
}

TEST_CASE("BVH: a scene above the brute-force limit answers its queries as the scalar loop does") {
  // The Cornell box with 400 small triangles inside: compiled with a hierarchy, queried through Scene.
  SceneDesc desc = load_scene("cornell");
  Pcg32 rng(7, 7);
  for (int i = 0; i < 400; ++i) {
    ShapeDesc sh;
    sh.type = ShapeType::Triangle;
    sh.material = 0;
    const DVec3 a(rng.next_float() * 500, rng.next_float() * 500, rng.next_float() * 500);
    sh.vertices[0] = a;
    sh.vertices[1] = a + DVec3(rng.next_float() * 40, rng.next_float() * 40, 0);
    sh.vertices[2] = a + DVec3(0, rng.next_float() * 40, rng.next_float() * 40);
    desc.shapes.push_back(sh);
  }
  const auto scene = compile_scene(desc);
  REQUIRE(!scene->polygon_bvh.empty());
  CHECK(scene->polygon_lanes.count == 0);
  const uint32_t n = static_cast<uint32_t>(scene->polygons.size());
  int hits = 0;
  for (int i = 0; i < 5000; ++i) {
    const Ray ray = scene->camera.generate_ray(rng.next_float() * scene->width, rng.next_float() * scene->height);
    const RayShear shear(ray.d);
    float best = kInfinity;
    uint32_t best_id = ~0u;
    for (uint32_t p = 0; p < n; ++p) {
      PolygonHit h;
      if (intersect_polygon(scene->polygons, p, ray.o, shear, best, h) && h.t < best) best = h.t, best_id = p;
    }
    Hit hit;
    REQUIRE(scene->intersect(ray, kInfinity, ~0u, hit) == (best_id != ~0u));
    if (best_id == ~0u) continue;
    ++hits;
    CHECK(hit.t == best);
    CHECK(hit.prim == best_id);
    CHECK_FALSE(scene->occluded(ray, best, ~0u, ~0u));
    CHECK(scene->occluded(ray, std::nextafter(best, kInfinity), ~0u, ~0u));
  }
  CHECK(hits > 4000);
}

namespace {

// Checks the packet kernels (packet_polygons.h) against a loop over the scalar tests, ray by ray: packets of 1 to
// kLanes rays (inactive lanes), every third ray skipping a polygon; the same distance bit for bit and the same
// polygon (or, on an exact tie, one hit at that distance); any-hit answers just below and just above the hit.
int check_packets_against_scalar(const Soup& soup, const std::vector<std::pair<Vec3, Vec3>>& rays) {
  PolygonLanes lanes;
  lanes.assign(soup.v, soup.triangle);
  const uint32_t n = static_cast<uint32_t>(soup.triangle.size());
  int hits = 0;
  for (size_t first = 0, size = 1; first < rays.size(); first += size, size = size % kLanes + 1) {
    const int m = static_cast<int>(std::min(size, rays.size() - first));
    Ray packet_rays[kLanes];
    float t_max[kLanes], best[kLanes], below[kLanes], above[kLanes];
    uint32_t skip[kLanes], other[kLanes], best_id[kLanes];
    for (int l = 0; l < m; ++l) {
      const size_t r = first + l;
      packet_rays[l] = {rays[r].first, rays[r].second};
      const RayShear shear(packet_rays[l].d);
      skip[l] = r % 3 == 0 ? static_cast<uint32_t>(r * 7919 % n) : ~0u;
      other[l] = r % 5 == 0 ? static_cast<uint32_t>(r * 104729 % n) : ~0u;
      t_max[l] = r % 7 == 0 ? 2.f : kInfinity;
      best[l] = t_max[l];
      best_id[l] = ~0u;
      for (uint32_t p = 0; p < n; ++p) {
        PolygonHit h;
        if (p != skip[l] && soup.test(p, packet_rays[l].o, shear, best[l], h) && h.t < best[l]) best[l] = h.t, best_id[l] = p;
      }
    }
    RayPacket P;
    P.load(packet_rays, t_max, skip, nullptr, m);
    float t[kLanes];
    uint32_t id[kLanes];
    const auto scalar = [&](int l, uint32_t i, float tm, PolygonHit& h) {
      return soup.test(i, packet_rays[l].o, RayShear(packet_rays[l].d), tm, h);
    };
    closest_polygon_packet(lanes, P, t, id, scalar);
    for (int l = 0; l < m; ++l) {
      const Ray& ray = packet_rays[l];
      INFO("ray " << first + l << " lane " << l << " of " << m << " o " << ray.o.x << " " << ray.o.y << " " << ray.o.z
                  << " d " << ray.d.x << " " << ray.d.y << " " << ray.d.z);
      const bool found = best_id[l] != ~0u;
      REQUIRE((t[l] < t_max[l]) == found);
      // Shadow queries: up to the hit (exclusive) nothing, just past it something; skip_b is honoured too.
      below[l] = found ? best[l] : t_max[l];
      above[l] = found ? std::nextafter(best[l], kInfinity) : t_max[l];
      if (!found) continue;
      ++hits;
      CHECK(t[l] == best[l]);
      if (id[l] != best_id[l]) {
        PolygonHit h;
        CHECK((id[l] != skip[l] && soup.test(id[l], ray.o, RayShear(ray.d), kInfinity, h) && h.t == best[l]));
      }
    }
    uint32_t expect_below = 0, expect_above = 0;
    for (int l = 0; l < m; ++l) {
      const Ray& ray = packet_rays[l];
      const RayShear shear(ray.d);
      for (uint32_t p = 0; p < n; ++p) {
        PolygonHit h;
        if (p == skip[l] || p == other[l]) continue;
        if (soup.test(p, ray.o, shear, below[l], h)) expect_below |= 1u << l;
        if (soup.test(p, ray.o, shear, above[l], h)) expect_above |= 1u << l;
      }
    }
    P.load(packet_rays, below, skip, other, m);
    CHECK(any_polygon_packet(lanes, P, scalar) == expect_below);
    P.load(packet_rays, above, skip, other, m);
    CHECK(any_polygon_packet(lanes, P, scalar) == expect_above);
  }
  return hits;
}

}  // namespace

TEST_CASE("packet: 16 rays against one polygon per step give the scalar tests' distances bit for bit") {
  Pcg32 rng(20261124, 5);
  std::vector<std::pair<Vec3, Vec3>> rays;
  const auto random_rays = [&](int count, float lo, float hi) {
    rays.clear();
    for (int i = 0; i < count; ++i) {
      Vec3 d = random_in(rng, -1, 1);
      // Axis-aligned rays, and directions whose largest components tie (the axis choice of the shear).
      if (i % 8 == 0) d = Vec3(0), d[i % 3] = i % 16 == 0 ? 1.f : -1.f;
      if (i % 8 == 1) d = Vec3(i % 3 ? 0.5f : -0.5f, -0.5f, i % 5 ? 0.5f : 0.25f);
      if (i % 8 == 2) d = Vec3(0.3f, i % 3 ? -0.7f : 0.7f, 0.7f);
      rays.push_back({random_in(rng, lo, hi), d});
    }
  };
  SUBCASE("100 random triangles and parallelograms") {
    Soup soup;
    for (int i = 0; i < 100; ++i) {
      const Vec3 a = random_in(rng, -3, 3), b = a + random_in(rng, -2, 2), c = a + random_in(rng, -2, 2);
      if (i % 2) soup.add_triangle(a, b, c);
      else soup.add_parallelogram(a, b, c);
    }
    random_rays(20000, -4, 4);
    CHECK(check_packets_against_scalar(soup, rays) > 5000);
  }
  SUBCASE("a closed triangulated sphere seen from inside, rays aimed at its vertices (zero edge functions)") {
    Soup soup;
    const SphereMesh sphere{6, 12};
    sphere.add_to(soup);
    random_rays(4000, -1, 1);
    for (auto& r : rays) r.first = Vec3(0.f);  // from the centre: no ray may escape
    for (int k = 0; k < 2000; ++k) rays.push_back({Vec3(0.f), sphere.point(1 + k % (sphere.rings - 1), k)});
    // From the centre a ray misses only where t_max = 2 stops it (every 7th) or it leaves through the polygon
    // it skips (every 3rd ray skips one of 120).
    CHECK(check_packets_against_scalar(soup, rays) > static_cast<int>(rays.size() * 0.8));
  }
}

namespace {

// Scene's packet queries for rays [0, m) against its single-ray queries, lane by lane (closest hit: found, distance
// and polygon; any hit between skip and other); returns how many lanes hit.
int check_scene_packet(const Scene& scene, const Ray* rays, const float* t_max, const uint32_t* skip,
                       const uint32_t* other, int m) {
  Hit h[kLanes];
  bool found[kLanes];
  scene.intersect_packet(rays, t_max, skip, m, h, found);
  const uint32_t blocked = scene.occluded_packet(rays, t_max, skip, other, m);
  int hits = 0;
  for (int l = 0; l < m; ++l) {
    Hit one;
    const bool f = scene.intersect(rays[l], t_max[l], skip[l], one);
    INFO("lane " << l);
    REQUIRE(found[l] == f);
    if (f) {
      ++hits;
      CHECK(h[l].t == one.t);
      CHECK(h[l].prim == one.prim);
    }
    CHECK(((blocked >> l) & 1u) == (scene.occluded(rays[l], t_max[l], skip[l], other[l]) ? 1u : 0u));
  }
  return hits;
}

}  // namespace

TEST_CASE("packet: Scene's packet queries answer as its single-ray queries (cornell, cornell-spheres)") {
  for (const char* name : {"cornell", "cornell-spheres"}) {
    const auto scene = compile_scene(load_scene(name));
    Pcg32 rng(11, 2);
    int hits = 0;
    for (int batch = 0; batch < 400; ++batch) {
      const int m = 1 + batch % kLanes;
      Ray rays[kLanes];
      float t_max[kLanes];
      uint32_t skip[kLanes], other[kLanes];
      for (int l = 0; l < m; ++l) {
        // Origins anywhere in the box (camera-relative), directions anywhere.
        rays[l] = {random_in(rng, -300, 300) + Vec3(0, 0, 1000), glm::normalize(random_in(rng, -1, 1))};
        t_max[l] = l % 3 == 0 ? 300.f : kInfinity;
        skip[l] = l % 4 == 0 ? static_cast<uint32_t>(batch % scene->polygons.size()) : ~0u;
        other[l] = l % 5 == 0 ? static_cast<uint32_t>((batch + 3) % scene->polygons.size()) : ~0u;
      }
      INFO(name << " batch " << batch);
      hits += check_scene_packet(*scene, rays, t_max, skip, other, m);
    }
    CHECK(hits > 1000);
  }
}

TEST_CASE("packet: shared corners and packets of one axis permutation give the single-ray answers (cornell)") {
  const auto scene = compile_scene(load_scene("cornell"));
  const PolygonLanes& lanes = scene->polygon_lanes;
  // The room, the two blocks and the lamp: 17 polygons with 68 corners, of which 28 are distinct (8 per
  // block and room, 4 for the lamp); the packet kernels shear each once per packet.
  REQUIRE(lanes.count == 17);
  REQUIRE(lanes.shared_corners());
  CHECK(lanes.corner_xyz[0].size() == 28);
  for (uint32_t i = 0; i < lanes.count; ++i)
    for (int k = 0; k < 4; ++k) {
      const uint16_t c = lanes.corner_of[k][i];
      for (int a = 0; a < 3; ++a) CHECK(lanes.corner_xyz[a][c] == lanes.coord[k][a][i]);
    }
  Pcg32 rng(7, 3);
  int hits = 0, uniform = 0;
  for (int batch = 0; batch < 600; ++batch) {
    // Every lane's direction has its largest component along `axis`, of sign `sign`: one permutation for the
    // packet (every sixth batch mixes them).
    const int axis = batch % 3, m = 1 + batch % kLanes;
    const float sign = batch / 3 % 2 ? -1.f : 1.f;
    Ray rays[kLanes];
    float t_max[kLanes];
    uint32_t skip[kLanes], other[kLanes];
    for (int l = 0; l < m; ++l) {
      Vec3 d = random_in(rng, -0.9f, 0.9f);
      d[axis] = sign;
      if (batch % 6 == 5 && l == m - 1) d = Vec3(d.z, d.x, -d.y);
      rays[l] = {random_in(rng, -250, 250) + Vec3(0, 0, 1000), glm::normalize(d)};
      t_max[l] = l % 3 == 0 ? 300.f : kInfinity;
      skip[l] = l % 4 == 0 ? static_cast<uint32_t>(batch % lanes.count) : ~0u;
      other[l] = l % 5 == 0 ? static_cast<uint32_t>((batch + 3) % lanes.count) : ~0u;
    }
    RayPacket P;
    P.load(rays, t_max, skip, other, m);
    if (batch % 6 != 5 || m == 1) {
      CHECK(P.perm == 2 * RayShear(rays[0].d).kz + (sign < 0.f ? 1 : 0));
      ++uniform;
    } else {
      CHECK(P.perm == -1);
    }
    INFO("batch " << batch);
    hits += check_scene_packet(*scene, rays, t_max, skip, other, m);
  }
  CHECK(uniform > 450);
  CHECK(hits > 2000);
}

namespace {
// Every second count passes no second skip list (closest-hit queries skip one primitive).
const uint32_t* second_skips_or_none(int m, const uint32_t* skip_b) { return m % 2 == 0 ? skip_b : nullptr; }
}  // namespace

TEST_CASE("packet: a loaded packet holds each ray's shear set-up in its lane and missing lanes copy lane 0") {
  // RayPacket::load transposes the rays with fixed permutations of their floats: each lane must hold exactly its
  // own ray's RayShear constants and permuted origin, its t_max and skips (−1 for none), whatever the count.
  Pcg32 rng(2026, 12);
  for (int m = 1; m <= kLanes; ++m) {
    Ray rays[kLanes];
    float t_max[kLanes];
    uint32_t skip_a[kLanes], skip_b[kLanes];
    for (int l = 0; l < m; ++l) {
      rays[l] = {random_in(rng, -50, 50), glm::normalize(random_in(rng, -1, 1))};
      t_max[l] = 1.f + static_cast<float>(l);
      skip_a[l] = l % 3 == 0 ? ~0u : static_cast<uint32_t>(7 * l + m);
      skip_b[l] = l % 2 == 0 ? ~0u : static_cast<uint32_t>(1000 + l);
    }
    RayPacket P;
    P.load(rays, t_max, skip_a, second_skips_or_none(m, skip_b), m);
    for (int l = 0; l < kLanes; ++l) {
      const int r = l < m ? l : 0;
      const RayShear s(rays[r].d);
      const Vec3 o = rays[r].o;
      INFO("count " << m << " lane " << l);
      CHECK(static_cast<float>(P.sx[l]) == s.sx);
      CHECK(static_cast<float>(P.sy[l]) == s.sy);
      CHECK(static_cast<float>(P.sz[l]) == s.sz);
      CHECK(static_cast<float>(P.ox[l]) == o[s.kx]);
      CHECK(static_cast<float>(P.oy[l]) == o[s.ky]);
      CHECK(static_cast<float>(P.oz[l]) == o[s.kz]);
      CHECK(static_cast<float>(P.t_max[l]) == (l < m ? t_max[l] : -kInfinity));
      CHECK(static_cast<float>(P.skip_a[l]) == (l < m && skip_a[l] != ~0u ? static_cast<float>(skip_a[l]) : -1.f));
      const bool second = l < m && m % 2 == 0 && skip_b[l] != ~0u;
      CHECK(static_cast<float>(P.skip_b[l]) == (second ? static_cast<float>(skip_b[l]) : -1.f));
    }
  }
}
