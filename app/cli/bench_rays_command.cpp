#include "cli/bench_rays_command.h"

#include <CLI/CLI.hpp>
#include <array>
#include <cstdio>

#include "cli/option_checks.h"
#include "cli/ray_throughput.h"
#include "cli/scene_arg.h"
#include "core/thread_pool.h"
#include "io/little_endian.h"
#include "io/ray_file.h"
#include "io/safe_file.h"
#include "scene/scene_json.h"

namespace pt {

namespace {

// The peers' triangle file (../shared/peers/README.md): 8 bytes PTTRIS01; camera position, look-at, up and vertical
// fov (10 float32); film width, height, triangle count (3 uint32); 9 float32 per triangle. Quads split into
// (a, b, c), (a, c, d) as the tracer splits them; vertices back in world coordinates (camera-relative + origin in
// double, rounded once).
void write_triangle_file(const std::string& path, const SceneDesc& desc, const Scene& s) {
  if (desc.camera.fov_axis != FovAxis::Vertical) throw std::runtime_error(path + ": the triangle file needs a vertical fov");
  const PolygonSoA& p = s.polygons;
  std::vector<std::array<Vec3, 3>> tris;
  const auto world = [&](Vec3 v) { return Vec3(DVec3(v) + s.world_origin); };
  for (size_t i = 0; i < p.size(); ++i) {
    tris.push_back({world(p.v[0][i]), world(p.v[1][i]), world(p.v[2][i])});
    if (!p.triangle[i]) tris.push_back({world(p.v[0][i]), world(p.v[2][i]), world(p.v[3][i])});
  }
  // Instanced meshes (a glTF model's), each triangle placed as make_interaction places it (in double), so the
  // peer traces the same triangles without instancing.
  for (const Instance& in : s.instances.instances) {
    const MeshGeometry& mesh = *s.instances.meshes[in.mesh];
    for (uint32_t t = 0; t < mesh.size(); ++t) {
      std::array<Vec3, 3> tri;
      for (int k = 0; k < 3; ++k)
        tri[k] = Vec3(in.to_world_linear * DVec3(mesh.vertex(t, k)) + in.to_world_offset + s.world_origin);
      if (in.mirrors) std::swap(tri[1], tri[2]);
      tris.push_back(tri);
    }
  }
  std::string out = "PTTRIS01";
  for (const DVec3& v : {desc.camera.position, desc.camera.look_at, desc.camera.up})
    for (int k = 0; k < 3; ++k) put_le_f32(out, static_cast<float>(v[k]));
  put_le_f32(out, static_cast<float>(desc.camera.fov_deg));
  put_le_u32(out, static_cast<uint32_t>(desc.width));
  put_le_u32(out, static_cast<uint32_t>(desc.height));
  put_le_u32(out, static_cast<uint32_t>(tris.size()));
  for (const auto& t : tris)
    for (const Vec3& v : t)
      for (int k = 0; k < 3; ++k) put_le_f32(out, v[k]);
  write_file_safely(path, out);
}

}  // namespace

void add_bench_rays_command(CLI::App& bench, BenchRaysOptions& o) {
  CLI::App* r = bench.add_subcommand(
      "rays", "Ray-casting throughput on a ray file (--rays), or record the scene's own path rays (--record)");
  r->add_option("--scene", o.scene,
                scene_arg_help())
      ->capture_default_str();
  auto* rays = r->add_option("--rays", o.rays_file, "Replay this ray file (PTRAYS01, docs/performance.md)");
  auto* record = r->add_option("--record", o.record_file, "Write the scene's own diffuse path rays to this file");
  rays->excludes(record);
  r->add_option("--count", o.count, "Rays to record")->check(whole_in(1, 1LL << 28))->capture_default_str();
  r->add_option("--seed", o.seed, "Seed of the recorded paths")->check(whole_in(0, 1LL << 62))->capture_default_str();
  r->add_option("--threads", o.threads, "Replay threads; 0 = all hardware threads")
      ->check(whole_in(0, 1024))
      ->capture_default_str();
  r->add_option("--repeats", o.repeats, "Replays of the whole file; the median rate is reported")
      ->check(whole_in(1, 1000))
      ->capture_default_str();
  r->add_option("--export-tris", o.tris_file,
                "Also write the scene's polygons (as the tracer holds them, meshes and instances included) as the triangle file "
                "of ../shared/peers/embree_rays (PTTRIS01), so Embree traces the same geometry");
  r->add_flag("--packets", o.packets,
              "Query as many consecutive rays at a time as the SIMD width (16 with AVX-512): one polygon per step for all");
  r->add_option("--instancing", o.instancing,
                enum_names_joined<Instancing>(" | ") + ": as render --instancing (keep: trace through every instance)")
      ->check(CLI::IsMember(enum_name_list<Instancing>()))
      ->capture_default_str();
  r->add_flag("--json", o.json, "Print one JSON object instead of the table");
}

int run_bench_rays(const BenchRaysOptions& o) {
  if (o.rays_file.empty() == o.record_file.empty()) {
    std::fprintf(stderr, "error: bench rays: give --rays FILE (replay) or --record FILE (record)\n");
    return 2;
  }
  std::optional<SceneDesc> desc = load_scene_arg(o.scene);
  if (!desc) return 2;
  parse_enum(o.instancing, desc->render.instancing);
  const auto scene = compile_scene(*desc);
  if (!o.tris_file.empty()) {
    if (scene->spheres.size() != 0) {
      std::fprintf(stderr, "error: --export-tris: %s has spheres; the triangle file holds polygons only\n", o.scene.c_str());
      return 2;
    }
    try {
      write_triangle_file(o.tris_file, *desc, *scene);
    } catch (const std::runtime_error& e) {
      std::fprintf(stderr, "error: %s\n", e.what());
      return 1;
    }
  }

  if (!o.record_file.empty()) {
    if (const std::string why = check_output_path(o.record_file); !why.empty()) {
      std::fprintf(stderr, "error: --record %s: %s\n", o.record_file.c_str(), why.c_str());
      return 2;
    }
    const RayBatch batch = record_path_rays(*scene, static_cast<size_t>(o.count), static_cast<uint64_t>(o.seed));
    try {
      write_ray_file(o.record_file, recorded_from_batch(*scene, batch));
    } catch (const std::runtime_error& e) {
      std::fprintf(stderr, "error: %s\n", e.what());
      return 1;
    }
    std::fprintf(stderr, "wrote %zu rays of %s to %s\n", batch.rays.size(), o.scene.c_str(), o.record_file.c_str());
    return 0;
  }

  std::vector<RecordedRay> recorded;
  try {
    recorded = read_ray_file(o.rays_file);
  } catch (const std::runtime_error& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  }
  const int threads = o.threads == 0 ? hardware_threads() : o.threads;
  const RayThroughput t = measure_ray_throughput(*scene, batch_from_recorded(*scene, recorded), o.repeats, threads,
                                                   o.packets);
  const char* accel = scene->polygon_bvh.empty() ? "brute-force SIMD" : "8-wide BVH";
  if (o.json) {
    std::printf(
        "{\"closest_mrays_s\": %.4f, \"shadow_mrays_s\": %.4f, \"shadow_half_mrays_s\": %.4f, \"closest_hits\": %llu, "
        "\"occluded\": %llu, \"occluded_half\": %llu, \"rays\": %llu, \"threads\": %d, \"repeats\": %d, "
        "\"polygons\": %zu, \"spheres\": %zu, \"polygon_accel\": \"%s\", \"packets\": %s}\n",
        t.closest_mrays_per_s, t.shadow_mrays_per_s, t.shadow_half_mrays_per_s,
        static_cast<unsigned long long>(t.closest_hits), static_cast<unsigned long long>(t.occluded),
        static_cast<unsigned long long>(t.occluded_half), static_cast<unsigned long long>(t.rays), threads, o.repeats,
        scene->polygons.size(), scene->spheres.size(), accel, o.packets ? "true" : "false");
    return 0;
  }
  std::printf("scene %s: %zu polygons (%s), %zu spheres\n", o.scene.c_str(), scene->polygons.size(), accel,
              scene->spheres.size());
  std::printf("%llu rays from %s, %d thread%s, median of %d replays%s\n", static_cast<unsigned long long>(t.rays),
              o.rays_file.c_str(), threads, threads == 1 ? "" : "s", o.repeats, o.packets ? ", packets" : "");
  std::printf("query          Mrays/s   count\n");
  std::printf("closest hit  %9.2f   %llu hits\n", t.closest_mrays_per_s, static_cast<unsigned long long>(t.closest_hits));
  std::printf("shadow       %9.2f   %llu occluded (over (tnear, tfar))\n", t.shadow_mrays_per_s,
              static_cast<unsigned long long>(t.occluded));
  std::printf("shadow half  %9.2f   %llu occluded (odd rays that hit stop at 0.99 x the hit)\n",
              t.shadow_half_mrays_per_s, static_cast<unsigned long long>(t.occluded_half));
  return 0;
}

}  // namespace pt
