#include "cli/stress_scenes.h"

#include <cmath>
#include <stdexcept>

#include "render/renderer.h"
#include "scene/scene_json.h"

namespace pt::stress {

ShapeDesc quad(DVec3 a, DVec3 b, DVec3 c, DVec3 d, int m) {
  ShapeDesc sh;
  sh.type = ShapeType::Quad;
  sh.vertices = {a, b, c, d};
  sh.material = m;
  return sh;
}

MaterialDesc material(std::string name, MaterialType type, Rgb albedo, Rgb emission,
                      bool two_sided, float ior) {
  MaterialDesc m;
  m.name = std::move(name);
  m.type = type;
  m.albedo = albedo;
  m.emission = emission;
  m.two_sided = two_sided;
  m.ior = ior;
  return m;
}

ShapeDesc sphere(DVec3 c, double r, int m) {
  ShapeDesc sh;
  sh.type = ShapeType::Sphere;
  sh.center = c;
  sh.radius = r;
  sh.material = m;
  return sh;
}

namespace {

int add_material(SceneDesc& s, MaterialDesc m) {
  s.materials.push_back(std::move(m));
  return static_cast<int>(s.materials.size()) - 1;
}

ShapeDesc triangle(DVec3 a, DVec3 b, DVec3 c, int m) {
  ShapeDesc sh;
  sh.type = ShapeType::Triangle;
  sh.vertices = {a, b, c, DVec3(0.0)};
  sh.material = m;
  return sh;
}

// Every scene here samples independently: the film's per-pixel variance, from which every statistical tolerance
// is derived, is an unbiased estimate of the variance of the mean only for independent samples (the stratified
// Sobol sampler's samples are not).
SceneDesc new_scene() {
  SceneDesc s;
  s.render.sampler = SamplerType::Independent;
  return s;
}

void set_camera(SceneDesc& s, DVec3 position, DVec3 look_at, double fov_deg, DVec3 up = DVec3(0, 1, 0)) {
  s.camera.position = position;
  s.camera.look_at = look_at;
  s.camera.up = up;
  s.camera.fov_deg = fov_deg;
  s.camera.fov_axis = FovAxis::Vertical;
}

// The six faces of the cube [-1,1]³ as corner index triples (0 = −1, 1 = +1), counter-clockwise seen from
// outside, so the front normal (b−a)×(c−a) points out. The diagonal a–c of each face passes through its centre.
constexpr int kCubeFaces[6][4][3] = {
    {{0, 0, 0}, {0, 0, 1}, {0, 1, 1}, {0, 1, 0}},  // −x
    {{1, 0, 0}, {1, 1, 0}, {1, 1, 1}, {1, 0, 1}},  // +x
    {{0, 0, 0}, {1, 0, 0}, {1, 0, 1}, {0, 0, 1}},  // −y
    {{0, 1, 0}, {0, 1, 1}, {1, 1, 1}, {1, 1, 0}},  // +y
    {{0, 0, 0}, {0, 1, 0}, {1, 1, 0}, {1, 0, 0}},  // −z
    {{0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}},  // +z
};

}  // namespace

SceneDesc transformed(SceneDesc s, double scale, DVec3 offset) {
  auto map = [&](DVec3 p) { return p * scale + offset; };
  s.camera.position = map(s.camera.position);
  s.camera.look_at = map(s.camera.look_at);
  for (ShapeDesc& sh : s.shapes) {
    if (sh.type == ShapeType::Sphere) {
      sh.center = map(sh.center);
      sh.radius *= scale;
    } else {
      const int n = sh.type == ShapeType::Triangle ? 3 : 4;
      for (int k = 0; k < n; ++k) sh.vertices[k] = map(sh.vertices[k]);
    }
  }
  return s;
}

SceneDesc builtin_at(const std::string& name, int width, int height) {
  SceneDesc s = load_scene(name);
  s.render.sampler = SamplerType::Independent;
  s.width = width;
  s.height = height;
  return s;
}

void add_box(SceneDesc& s, DVec3 center, double half, int m, bool triangles) {
  for (const auto& face : kCubeFaces) {
    DVec3 v[4];
    for (int k = 0; k < 4; ++k)
      v[k] = center + half * DVec3(2 * face[k][0] - 1, 2 * face[k][1] - 1, 2 * face[k][2] - 1);
    if (triangles) {
      s.shapes.push_back(triangle(v[0], v[1], v[2], m));
      s.shapes.push_back(triangle(v[0], v[2], v[3], m));
    } else {
      s.shapes.push_back(quad(v[0], v[1], v[2], v[3], m));
    }
  }
}

SceneDesc furnace(Rgb Le, Rgb rho, int max_bounces, int rr_depth, Estimator est) {
  SceneDesc s = new_scene();
  set_camera(s, DVec3(0.0), DVec3(0, 0, -1), 90);
  s.width = s.height = 8;
  s.render.max_bounces = max_bounces;
  s.render.russian_roulette_depth = rr_depth;
  s.render.estimator = est;
  const int m = add_material(s, material("furnace", MaterialType::Diffuse, rho, Le, true));
  s.shapes.push_back(sphere(DVec3(0.1, -0.2, 0.05), 1.0, m));  // camera off-centre: cosines vary
  return s;
}

double furnace_expected(double Le, double rho, int max_bounces, bool unbounded) {
  if (unbounded) return Le / (1.0 - rho);
  return Le * (1.0 - std::pow(rho, max_bounces + 1)) / (1.0 - rho);
}

SceneDesc white_furnace(MaterialType type, Estimator est, float albedo, float ior) {
  SceneDesc s = new_scene();
  set_camera(s, DVec3(0, 0, 4), DVec3(0.0), 40);
  s.width = s.height = 16;
  s.environment.radiance = Rgb(1.f);
  s.render.max_bounces = 1000;
  s.render.russian_roulette_depth = -1;
  s.render.estimator = est;
  const int m = add_material(s, material("m", type, Rgb(albedo), Rgb(0.f), false, ior));
  s.shapes.push_back(sphere(DVec3(0.0), 1.0, m));
  return s;
}

namespace {

// The six walls of the room [0,1]³: for each, the inward normal, the wall's centre and its corners.
struct Wall {
  DVec3 inward, centre;
  DVec3 v[4];
};

std::vector<Wall> room_walls() {
  std::vector<Wall> walls;
  for (const auto& face : kCubeFaces) {
    Wall w;
    DVec3 c(0.0);
    for (int k = 0; k < 4; ++k) {
      w.v[k] = DVec3(face[k][0], face[k][1], face[k][2]);
      c += w.v[k] / 4.0;
    }
    w.centre = c;
    w.inward = glm::normalize(DVec3(0.5) - c);
    walls.push_back(w);
  }
  return walls;
}

// A sphere of radius R through the four corners of a unit square wall, bulging into the room by the sagitta
// δ = h²/(R + √(R²−h²)) at the wall's centre (h = half-diagonal): the walls' spheres overlap along every edge.
ShapeDesc wall_sphere(const Wall& w, double R, int m) {
  const double h2 = 0.5;  // (√2/2)²
  const double sagitta = h2 / (R + std::sqrt(R * R - h2));
  return sphere(w.centre - w.inward * (R - sagitta), R, m);
}

}  // namespace

SceneDesc wall_room(bool huge_spheres, double radius_factor) {
  SceneDesc s = new_scene();
  set_camera(s, DVec3(0.5, 0.5, 0.04), DVec3(0.5, 0.45, 1.0), 80);
  s.width = s.height = 32;
  s.render.max_bounces = 16;
  s.render.russian_roulette_depth = 3;
  s.render.estimator = Estimator::Mis;
  const int white = add_material(s, material("white", MaterialType::Diffuse, Rgb(0.725f, 0.71f, 0.68f)));
  const int red = add_material(s, material("red", MaterialType::Diffuse, Rgb(0.63f, 0.065f, 0.05f)));
  const int green = add_material(s, material("green", MaterialType::Diffuse, Rgb(0.14f, 0.45f, 0.091f)));
  const int light = add_material(s, material("light", MaterialType::Diffuse, Rgb(0.f), Rgb(8.f, 6.f, 3.f)));
  const int chrome = add_material(s, material("chrome", MaterialType::Mirror, Rgb(0.95f)));
  const std::vector<Wall> walls = room_walls();
  for (size_t i = 0; i < walls.size(); ++i) {
    const int m = i == 0 ? green : i == 1 ? red : white;
    if (huge_spheres) s.shapes.push_back(wall_sphere(walls[i], radius_factor, m));
    else s.shapes.push_back(quad(walls[i].v[0], walls[i].v[1], walls[i].v[2], walls[i].v[3], m));
  }
  // The light 1e-3 below the ceiling, facing down (front normal −y), like the Cornell box's.
  const double y = 0.999;
  s.shapes.push_back(quad({0.65, y, 0.35}, {0.65, y, 0.65}, {0.35, y, 0.65}, {0.35, y, 0.35}, light));
  s.shapes.push_back(sphere({0.32, 0.2, 0.62}, 0.2, white));
  s.shapes.push_back(sphere({0.72, 0.15, 0.4}, 0.15, chrome));
  return s;
}

SceneDesc wall_room_furnace(bool huge_spheres, double radius_factor, double Le, double rho, int max_bounces,
                            int rr_depth, Estimator est) {
  SceneDesc s = new_scene();
  set_camera(s, DVec3(0.5, 0.5, 0.04), DVec3(0.5, 0.45, 1.0), 100);  // sees five walls, their edges and corners
  s.width = s.height = 16;
  s.render.max_bounces = max_bounces;
  s.render.russian_roulette_depth = rr_depth;
  s.render.estimator = est;
  const int m = add_material(s, material("wall", MaterialType::Diffuse, Rgb(static_cast<float>(rho)),
                                         Rgb(static_cast<float>(Le)), true));
  for (const Wall& w : room_walls()) {
    if (huge_spheres) s.shapes.push_back(wall_sphere(w, radius_factor, m));
    else s.shapes.push_back(quad(w.v[0], w.v[1], w.v[2], w.v[3], m));
  }
  return s;
}

SceneDesc tiny_spheres(double r, bool emissive, Estimator est) {
  SceneDesc s = new_scene();
  // The image plane at distance 1 spans ±8r vertically and horizontally: the cluster (±5r) fills its middle.
  set_camera(s, DVec3(0.0), DVec3(0, 0, -1), 2.0 * std::atan(8.0 * r) * 180.0 / glm::pi<double>());
  s.width = s.height = 32;
  s.render.estimator = est;
  if (emissive) {
    s.render.max_bounces = 0;
    const int m = add_material(s, material("lamp", MaterialType::Diffuse, Rgb(0.f), Rgb(1.f)));
    for (int i = -1; i <= 1; ++i)
      for (int j = -1; j <= 1; ++j) s.shapes.push_back(sphere(DVec3(4.0 * r * i, 4.0 * r * j, -1.0), r, m));
  } else {
    // One sphere (a cluster is not convex: light would bounce between its members), off the axis.
    s.render.max_bounces = 1000;
    s.render.russian_roulette_depth = -1;
    s.environment.radiance = Rgb(1.f);
    const int m = add_material(s, material("grey", MaterialType::Diffuse, Rgb(0.5f)));
    s.shapes.push_back(sphere(DVec3(2.0 * r, -1.5 * r, -1.0), 3.0 * r, m));
  }
  return s;
}

double tiny_spheres_coverage(const SceneDesc& s) {
  const DVec3 f = glm::normalize(s.camera.look_at - s.camera.position);
  const double tan_half = std::tan(glm::radians(s.camera.fov_deg) * 0.5);
  const double aspect = static_cast<double>(s.width) / s.height;
  const double plane_area = (2.0 * tan_half * aspect) * (2.0 * tan_half);
  double covered = 0.0;
  for (const ShapeDesc& sh : s.shapes) {
    const DVec3 c = sh.center - s.camera.position;
    const double r2 = sh.radius * sh.radius, cz = glm::dot(c, f);
    covered += glm::pi<double>() * r2 * std::sqrt(glm::dot(c, c) - r2) / std::pow(cz * cz - r2, 1.5);
  }
  return covered / plane_area;
}

const char* to_string(Enclosure e) {
  switch (e) {
    case Enclosure::Box12: return "box of 12 triangles";
    case Enclosure::Box6: return "box of 6 parallelograms";
    case Enclosure::Sphere: return "sphere";
  }
  return "?";
}

const char* to_string(View v) {
  switch (v) {
    case View::Interior: return "interior";
    case View::Vertex: return "vertex";
    case View::Edge: return "edge";
    case View::Diagonal: return "diagonal";
    case View::Grazing: return "grazing";
  }
  return "?";
}

SceneDesc light_tight(Enclosure enclosure, View view, Estimator est) {
  SceneDesc s = new_scene();
  s.width = s.height = 32;  // four 16×16 tiles: both render threads busy
  s.render.max_bounces = 64;
  s.render.russian_roulette_depth = 3;
  s.render.estimator = est;
  s.environment.radiance = Rgb(1.f);
  const int inside = add_material(s, material("inside", MaterialType::Diffuse, Rgb(0.8f)));
  const int lamp = add_material(s, material("lamp", MaterialType::Diffuse, Rgb(0.f), Rgb(1e4f), true));
  if (enclosure == Enclosure::Sphere) s.shapes.push_back(sphere(DVec3(0.0), 1.0, inside));
  else add_box(s, DVec3(0.0), 1.0, inside, enclosure == Enclosure::Box12);
  s.shapes.push_back(quad({-1, -1, 2.5}, {1, -1, 2.5}, {1, 1, 2.5}, {-1, 1, 2.5}, lamp));
  s.shapes.push_back(sphere({0, 3, 0}, 0.7, lamp));

  const DVec3 eye(0.3, 0.2, 0.1);
  const double narrow = 1e-4;  // degrees: the image spans ~4e-6 units at the target, a few dozen float ulps
  switch (view) {
    case View::Interior: set_camera(s, {0.13, -0.21, 0.17}, {-0.4, 0.3, 1.0}, 100); break;
    case View::Vertex: set_camera(s, eye, {-1, -1, -1}, narrow); break;
    case View::Edge: set_camera(s, eye, {1, 1, 0}, narrow); break;
    case View::Diagonal: set_camera(s, eye, {0, 0, 1}, narrow); break;
    case View::Grazing:
      if (enclosure == Enclosure::Sphere) set_camera(s, {0, 0, -(1 - 1e-6)}, {1, 0, -(1 - 1e-6)}, 60);
      else set_camera(s, {-1 + 1e-6, 0.1, -0.6}, {-1 + 1e-6, 0.1, 1.0}, 60);
      break;
  }
  return s;
}

std::vector<NamedScene> hazard_scenes(int size) {
  std::vector<NamedScene> out;
  auto cornell = [&] {
    SceneDesc s = builtin_at("cornell", size, size);
    s.render.max_bounces = 16;
    return s;
  };
  auto spheres = [&] {
    SceneDesc s = builtin_at("cornell-spheres", size, size);
    s.render.max_bounces = 16;
    return s;
  };
  auto material_index = [](const SceneDesc& s, const std::string& name) {
    for (size_t i = 0; i < s.materials.size(); ++i)
      if (s.materials[i].name == name) return static_cast<int>(i);
    throw std::logic_error("no material " + name);
  };
  {
    // Needles 1e-7 as thin as they are long, some of them emitting, across the room.
    SceneDesc s = cornell();
    const int white = material_index(s, "white"), light = material_index(s, "light");
    for (int k = 0; k < 24; ++k) {
      const double t = k / 24.0;
      const DVec3 a(60 + 400 * t, 40 + 15 * k, 100 + 300 * std::sin(7.0 * t));
      const DVec3 dir = glm::normalize(DVec3(std::cos(5.0 * t), 0.3 - t, std::sin(3.0 * t)));
      const DVec3 perp = glm::normalize(glm::cross(dir, DVec3(0.3, 1, 0.2)));
      const double len = 200;
      s.shapes.push_back(triangle(a, a + len * dir, a + 0.5 * len * dir + 1e-7 * len * perp, k % 4 ? white : light));
    }
    out.push_back({"sliver triangles 1e-7 thin", s});
  }
  {
    SceneDesc s = cornell();  // camera rays in the plane of the floor (and of the blocks' bottom faces)
    set_camera(s, {278, 0, -800}, {278, 0, 0}, 39.3077);
    out.push_back({"rays parallel to faces", s});
  }
  {
    SceneDesc s = cornell();  // the camera on the floor, looking up into the room
    set_camera(s, {278, 0, 280}, {278, 273, 559.2}, 60);
    out.push_back({"camera on a surface (floor)", s});
  }
  {
    SceneDesc s = cornell();  // on the back wall, looking at the open front
    set_camera(s, {278, 273, 559.2}, {278, 273, 0}, 60);
    out.push_back({"camera on a surface (back wall)", s});
  }
  for (float ior : {1.0f, 10.0f}) {
    SceneDesc s = spheres();
    s.materials[material_index(s, "glass")].ior = ior;
    out.push_back({ior == 1.f ? "dielectric ior 1.0" : "dielectric ior 10", s});
  }
  {
    // The camera inside a closed box of glass of index 10: nearly every ray meets total internal reflection.
    SceneDesc s = cornell();
    const int glass = add_material(s, material("dense glass", MaterialType::Dielectric, Rgb(1.f), Rgb(0.f), false, 10.f));
    add_box(s, {278, 273, 200}, 80, glass, true);
    set_camera(s, {300, 250, 190}, {278, 273, 559.2}, 70);
    s.render.max_bounces = 64;
    out.push_back({"total internal reflection (inside ior-10 box)", s});
  }
  {
    SceneDesc s = spheres();  // inside the glass sphere
    set_camera(s, {170, 100, 180}, {278, 273, 559.2}, 70);
    out.push_back({"camera inside a glass sphere", s});
  }
  {
    SceneDesc s = spheres();  // inside the mirror sphere: reflections until roulette ends them
    set_camera(s, {400, 120, 350}, {278, 273, 559.2}, 70);
    s.render.max_bounces = 1 << 20;
    out.push_back({"camera inside a mirror sphere", s});
  }
  {
    SceneDesc s = cornell();
    s.materials[material_index(s, "light")].emission = Rgb(1e30f, 12e30f / 17.f, 4e30f / 17.f);
    out.push_back({"emission 1e30", s});
  }
  {
    SceneDesc s = cornell();
    for (MaterialDesc& m : s.materials) m.albedo = Rgb(0.f);
    out.push_back({"albedo 0", s});
  }
  {
    SceneDesc s = cornell();  // the eye in the light's plane: the light and its plane seen exactly edge-on
    set_camera(s, {278, 548.7, -800}, {278, 548.7, 0}, 39.3077);
    out.push_back({"light seen edge-on", s});
  }
  {
    SceneDesc s = cornell();  // the light flush with the ceiling: receivers coplanar with the emitter
    for (ShapeDesc& sh : s.shapes)
      if (sh.material == material_index(s, "light"))
        for (DVec3& v : sh.vertices) v.y = 548.8;
    out.push_back({"light coplanar with the ceiling", s});
  }
  return out;
}

// ------------------------------------------------------------------------------------------------- statistics

double normal_upper_quantile(double p) {
  if (!(p > 0.0 && p < 1.0)) throw std::invalid_argument("normal_upper_quantile: p must be in (0, 1)");
  double lo = -40.0, hi = 40.0;  // bisection on the monotone tail 0.5·erfc(z/√2)
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    if (0.5 * std::erfc(mid / std::sqrt(2.0)) > p) lo = mid;
    else hi = mid;
  }
  return 0.5 * (lo + hi);
}

double bonferroni_z(double alpha, int m) { return normal_upper_quantile(alpha / (2.0 * std::max(m, 1))); }

double chi2_mean_bound(double alpha, int dof) {
  const double k = std::max(dof, 1), z = normal_upper_quantile(alpha);
  const double c = 1.0 - 2.0 / (9.0 * k) + z * std::sqrt(2.0 / (9.0 * k));
  return c * c * c;
}

Film render(const SceneDesc& s, int spp, int threads) {
  const auto scene = compile_scene(s);
  Film film(s.width, s.height);
  Renderer renderer(threads);
  renderer.render_pass(*scene, s.render, film, spp);
  return film;
}

std::optional<Film> render_unless_refused(const SceneDesc& s, int spp, int threads, std::string& refusal) {
  try {
    return render(s, spp, threads);
  } catch (const std::invalid_argument& e) {
    refusal = e.what();
    return std::nullopt;
  }
}

MeanSE film_mean(const Film& f) {
  MeanSE r;
  glm::dvec3 var(0.0);
  const double n = static_cast<double>(f.pixel_count());
  for (size_t i = 0; i < f.pixel_count(); ++i) {
    r.mean += glm::dvec3(f.mean(i));
    var += f.variance_of_mean(i);
  }
  r.mean /= n;
  r.se = glm::sqrt(var) / n;
  return r;
}

Blocks blocks_of(const Film& f, int b) {
  Blocks r;
  r.width = f.width() / b;
  r.height = f.height() / b;
  r.mean.assign(static_cast<size_t>(r.width) * r.height, glm::dvec3(0.0));
  r.var.assign(r.mean.size(), glm::dvec3(0.0));
  const double area = static_cast<double>(b) * b;
  for (int y = 0; y < r.height * b; ++y)
    for (int x = 0; x < r.width * b; ++x) {
      const size_t i = static_cast<size_t>(y) * f.width() + x;
      const size_t k = static_cast<size_t>(y / b) * r.width + x / b;
      r.mean[k] += glm::dvec3(f.mean(i)) / area;
      r.var[k] += f.variance_of_mean(i) / (area * area);
    }
  return r;
}

Agreement compare_blocks(const Film& a, const Film& b, int block, double alpha) {
  const Blocks ba = blocks_of(a, block), bb = blocks_of(b, block);
  Agreement g;
  double z2 = 0.0;
  for (size_t k = 0; k < ba.mean.size(); ++k)
    for (int c = 0; c < 3; ++c) {
      const double d = ba.mean[k][c] - bb.mean[k][c];
      const double s = std::sqrt(ba.var[k][c] + bb.var[k][c]);
      double z;
      if (s > 0.0) z = d / s;
      else z = std::abs(d) <= 1e-5 * std::max(std::abs(ba.mean[k][c]), std::abs(bb.mean[k][c])) ? 0.0 : INFINITY;
      if (!std::isfinite(z)) z = INFINITY;  // NaN means and infinite variances fail too
      z2 += z * z;
      g.max_abs_z = std::max(g.max_abs_z, std::abs(z));
      ++g.n;
    }
  g.mean_z2 = g.n ? z2 / g.n : 0.0;
  g.z_bound = bonferroni_z(alpha, g.n);
  g.z2_bound = chi2_mean_bound(alpha, static_cast<int>(ba.mean.size()));
  g.pass = g.n > 0 && g.max_abs_z < g.z_bound && g.mean_z2 < g.z2_bound;
  return g;
}

int nonzero_pixels(const Film& f) {
  int n = 0;
  for (size_t i = 0; i < f.pixel_count(); ++i) n += !is_black(f.mean(i));
  return n;
}

int nonfinite_pixels(const Film& f) {
  int n = 0;
  for (size_t i = 0; i < f.pixel_count(); ++i)
    for (int c = 0; c < 3; ++c)
      if (!std::isfinite(f.mean_channel(i, c))) {
        ++n;
        break;
      }
  return n;
}

}  // namespace pt::stress
