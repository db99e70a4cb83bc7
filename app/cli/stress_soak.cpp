#include "cli/stress_soak.h"

#include <malloc.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>
#include <random>
#include <string>
#include <thread>

#include "cli/stress_scenes.h"
#include "io/image_io.h"
#include "render/render_session.h"
#include "scene/scene.h"

namespace pt {
namespace {

using Rng = std::mt19937_64;
using Clock = std::chrono::steady_clock;

double uniform(Rng& rng, double a, double b) { return std::uniform_real_distribution<double>(a, b)(rng); }
int pick(Rng& rng, int n) { return std::uniform_int_distribution<int>(0, n - 1)(rng); }
bool coin(Rng& rng, double p = 0.5) { return uniform(rng, 0.0, 1.0) < p; }
Rgb colour(Rng& rng, float hi) {
  return Rgb(static_cast<float>(uniform(rng, 0, hi)), static_cast<float>(uniform(rng, 0, hi)),
             static_cast<float>(uniform(rng, 0, hi)));
}
DVec3 point(Rng& rng, double r) { return DVec3(uniform(rng, -r, r), uniform(rng, -r, r), uniform(rng, -r, r)); }

template <class E>
E any_of(Rng& rng) {
  const auto entries = enum_entries<E>();
  return entries[pick(rng, static_cast<int>(entries.size()))].value;
}

// Resident memory of this process (VmRSS), after handing freed heap pages back (so growth means live memory).
uint64_t resident_bytes() {
  malloc_trim(0);
  std::ifstream in("/proc/self/status");
  std::string key;
  while (in >> key) {
    if (key == "VmRSS:") {
      uint64_t kb = 0;
      in >> kb;
      return kb * 1024;
    }
    in.ignore(1 << 20, '\n');
  }
  return 0;
}

MaterialDesc random_material(Rng& rng, const std::string& name) {
  MaterialDesc m;
  m.name = name;
  m.type = any_of<MaterialType>(rng);
  m.albedo = colour(rng, 1.f);
  if (coin(rng, 0.15)) m.emission = colour(rng, coin(rng) ? 20.f : 1e4f);
  m.two_sided = coin(rng, 0.2);
  m.ior = static_cast<float>(m.type == MaterialType::Dielectric ? uniform(rng, 0.3, 3.0) : uniform(rng, 1.0, 3.0));
  m.roughness = static_cast<float>(coin(rng, 0.2) ? 0.0 : uniform(rng, 0.0, 1.0));
  m.g = static_cast<float>(uniform(rng, -0.95, 0.95));
  if (m.type == MaterialType::MetallicRoughness) m.metallic = static_cast<float>(uniform(rng, 0.0, 1.0));
  if (m.type == MaterialType::Conductor && coin(rng)) m.metal = any_of<MetalPreset>(rng);
  return m;
}

CameraDesc random_camera(Rng& rng, double size) {
  CameraDesc c;
  c.position = point(rng, 2.5 * size);
  c.look_at = point(rng, 0.3 * size);
  c.fov_deg = uniform(rng, 10.0, 120.0);
  c.fov_axis = any_of<FovAxis>(rng);
  return c;
}

EnvironmentDesc random_environment(Rng& rng) {
  EnvironmentDesc e;
  e.type = any_of<EnvironmentType>(rng);
  e.radiance = coin(rng, 0.3) ? Rgb(0.f) : colour(rng, 2.f);
  e.sun_direction = point(rng, 1.0) + DVec3(0, 0.05, 0);
  e.turbidity = static_cast<float>(uniform(rng, 1.7, 10.0));
  e.sun = coin(rng);
  e.scale = static_cast<float>(uniform(rng, 0.0, 2.0));
  e.rotation_deg = static_cast<float>(uniform(rng, -360.0, 360.0));
  if (e.type == EnvironmentType::Map) {  // a small random lat-long map, with a hot spot sometimes
    auto img = std::make_shared<Image>();
    img->width = 2 * (1 + pick(rng, 32));
    img->height = 1 + pick(rng, 32);
    img->rgb.resize(3 * static_cast<size_t>(img->width) * img->height);
    for (float& v : img->rgb) v = static_cast<float>(coin(rng, 0.01) ? uniform(rng, 0, 1e4) : uniform(rng, 0, 1));
    e.file = "soak-map.pfm";
    e.resolved_file = e.file;
    e.image = img;
  }
  return e;
}

// A built-in scene, or random spheres, triangles and quads with random materials: valid by construction
// (retried until validate_scene accepts it).
SceneDesc random_scene(Rng& rng) {
  static const char* const kBuiltins[] = {"cornell", "cornell-spheres", "shadertoy"};
  const int width = 16 + pick(rng, 150), height = 16 + pick(rng, 120);
  if (coin(rng, 0.3)) {
    SceneDesc s = stress::builtin_at(kBuiltins[pick(rng, 3)], width, height);
    const double scale = std::pow(10.0, uniform(rng, -6, 6));
    s = stress::transformed(s, scale, point(rng, coin(rng) ? 0.0 : 1e6 * scale));
    if (validate_scene(s).empty()) return s;
  }
  for (;;) {
    SceneDesc s;
    s.width = width;
    s.height = height;
    const int nm = 1 + pick(rng, 6);
    for (int i = 0; i < nm; ++i) s.materials.push_back(random_material(rng, std::string("m").append(std::to_string(i))));
    const int ns = 1 + pick(rng, 40);
    for (int i = 0; i < ns; ++i) {
      ShapeDesc sh;
      sh.type = any_of<ShapeType>(rng);
      sh.material = pick(rng, nm);
      const DVec3 c = point(rng, 1.0);
      const double r = std::pow(10.0, uniform(rng, -3, 0.3));
      if (sh.type == ShapeType::Sphere) {
        sh.center = c;
        sh.radius = r;
      } else {  // a parallelogram (quad) or its half (triangle) around c
        const DVec3 u = point(rng, r), v = point(rng, r);
        sh.vertices = {c - u - v, c + u - v, c + u + v, c - u + v};
      }
      s.shapes.push_back(sh);
    }
    s.camera = random_camera(rng, 1.0);
    s.environment = random_environment(rng);
    s.render.max_bounces = pick(rng, 12);
    if (validate_scene(s).empty()) return s;
  }
}

RenderSettings random_render(Rng& rng) {
  RenderSettings r;
  r.max_bounces = coin(rng, 0.1) ? 1000 : pick(rng, 16);
  r.estimator = any_of<Estimator>(rng);
  r.sampler = any_of<SamplerType>(rng);
  r.russian_roulette_depth = pick(rng, 6) - 1;
  r.seed = rng();
  return r;
}

// Non-finite values in a published frame (the relative error may be kUnknownError, which is finite).
size_t non_finite_values(const DisplayFrame& f) {
  size_t n = 0;
  for (float v : f.rgba) n += !std::isfinite(v);
  for (float v : f.count) n += !std::isfinite(v);
  return n;
}

}  // namespace

int run_soak(const SoakOptions& o) {
  Rng rng(o.seed);
  const int max_threads = o.threads > 0 ? o.threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  SessionSettings settings;
  settings.threads = max_threads;
  settings.background_priority = false;
  SceneDesc desc = random_scene(rng);
  RenderSession session(desc, settings);

  uint64_t actions = 0, scenes = 1, edits = 0, refused = 0, frames = 0, bad_values = 0, errors = 0, max_rejected = 0;
  const auto start = Clock::now();
  const auto elapsed = [&] { return std::chrono::duration<double>(Clock::now() - start).count(); };
  const double warmup = std::min(300.0, 0.1 * o.seconds);
  uint64_t rss_after_warmup = 0, rss_peak = 0, rss = resident_bytes();
  const uint64_t rss_start = rss;
  double next_report = 0.0;
  DisplayFrame frame;
  std::printf("pathtracer stress --soak %.0f s, seed %llu, up to %d threads; memory baseline after %.0f s\n",
              o.seconds, static_cast<unsigned long long>(o.seed), max_threads, warmup);
  std::printf("%8s %9s %7s %7s %8s %9s %8s\n", "seconds", "actions", "scenes", "edits", "frames", "RSS MiB",
              "problems");
  // A typed edit as the viewer sends it: validated first, applied to the model, then to the session.
  const auto send = [&](const SceneEdit& e, bool valid) {
    if (!valid || !validate_edit(desc, e).empty()) {
      ++refused;
      return;
    }
    apply_edit(desc, e);
    session.edit(e);
    ++edits;
  };
  while (elapsed() < o.seconds) {
    // One action, as a user would do it, then a pause of 0-40 ms while the session renders.
    switch (pick(rng, 10)) {
      case 0:
        desc = random_scene(rng);
        session.set_scene(desc);
        ++scenes;
        break;
      case 1:
      case 2: {
        MaterialEdit m{static_cast<size_t>(pick(rng, static_cast<int>(desc.materials.size()))), {}};
        m.material = random_material(rng, desc.materials[m.index].name);
        send(m, true);
        break;
      }
      case 3:
      case 4: {  // a camera move: small (a drag) or anywhere
        CameraDesc c = desc.camera;
        if (coin(rng)) {
          c.position += point(rng, 0.05 * glm::length(c.look_at - c.position));
        } else {
          const double size = glm::length(c.look_at - c.position);
          c = random_camera(rng, size);
          c.position += desc.camera.look_at;
          c.look_at += desc.camera.look_at;
        }
        SceneDesc moved = desc;  // the shapes must stay within the representable distance of the new eye
        moved.camera = c;
        send(c, validate_scene(moved).empty());
        break;
      }
      case 5:
        send(random_environment(rng), true);
        break;
      case 6:
        desc.render = random_render(rng);
        session.set_render(desc.render);
        break;
      case 7:
        session.restart();
        break;
      case 8:
        session.set_paused(coin(rng, 0.3));
        break;
      case 9: {
        SessionSettings s = session.settings();
        s.threads = 1 + pick(rng, max_threads);
        s.stop.spp = coin(rng, 0.3) ? static_cast<uint64_t>(1 + pick(rng, 64)) : 0;
        session.set_settings(s);
        break;
      }
    }
    ++actions;
    std::this_thread::sleep_for(std::chrono::milliseconds(pick(rng, 41)));
    if (session.take_frame(frame)) {
      ++frames;
      bad_values += non_finite_values(frame);
    }
    const SessionStats st = session.stats();
    max_rejected = std::max(max_rejected, st.rejected);
    if (!st.error.empty()) {
      ++errors;
      std::fprintf(stderr, "soak: session error: %s\n", st.error.c_str());
      desc = random_scene(rng);
      session.set_scene(desc);
    }
    if (elapsed() >= next_report) {
      rss = resident_bytes();
      if (elapsed() >= warmup) {
        if (!rss_after_warmup) rss_after_warmup = rss;
        rss_peak = std::max(rss_peak, rss);
      }
      std::printf("%8.0f %9llu %7llu %7llu %8llu %9.1f %8llu\n", elapsed(),
                  static_cast<unsigned long long>(actions), static_cast<unsigned long long>(scenes),
                  static_cast<unsigned long long>(edits), static_cast<unsigned long long>(frames), rss / 1048576.0, static_cast<unsigned long long>(bad_values + errors));
      std::fflush(stdout);
      next_report += std::max(1.0, std::min(60.0, o.seconds / 20));
    }
  }
  session.set_paused(true);
  rss = resident_bytes();
  if (!rss_after_warmup) rss_after_warmup = rss;
  rss_peak = std::max(rss_peak, rss);
  const int64_t growth = static_cast<int64_t>(rss) - static_cast<int64_t>(rss_after_warmup);
  std::printf(
      "soak: %.0f s, %llu actions (%llu scenes, %llu edits, %llu invalid edits refused before sending), %llu frames "
      "checked\n",
      elapsed(), static_cast<unsigned long long>(actions), static_cast<unsigned long long>(scenes),
      static_cast<unsigned long long>(edits), static_cast<unsigned long long>(refused),
      static_cast<unsigned long long>(frames));
  std::printf("soak: non-finite values in frames: %llu; session errors: %llu; most non-finite samples rejected in "
              "one accumulation: %llu\n",
              static_cast<unsigned long long>(bad_values), static_cast<unsigned long long>(errors),
              static_cast<unsigned long long>(max_rejected));
  std::printf("soak: resident memory %.1f MiB at start, %.1f MiB after warm-up, %.1f MiB peak, %.1f MiB at the "
              "end: growth %+.1f MiB (limit %.0f MiB)\n",
              rss_start / 1048576.0, rss_after_warmup / 1048576.0, rss_peak / 1048576.0, rss / 1048576.0,
              growth / 1048576.0, kSoakMaxGrowthBytes / 1048576.0);
  const bool ok = bad_values == 0 && errors == 0 && max_rejected == 0 &&
                  growth <= static_cast<int64_t>(kSoakMaxGrowthBytes);
  std::printf("soak: %s\n", ok ? "PASS" : "FAIL");
  return ok ? 0 : 1;
}

}  // namespace pt
