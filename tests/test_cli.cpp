// End-to-end: the real `pathtracer` executable, run as a user runs it.
#include <doctest/doctest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <optional>
#include <sstream>
#include <stb_image.h>
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <algorithm>
#include <array>
#include <cmath>

#include "skip.h"
#include "cli/instruction_count.h"
#include "io/image_io.h"
#include "io/ray_file.h"
#include "render/metrics.h"
#include "run_command.h"

using namespace pt;

using pt::test::Run;
using pt::test::slurp;

namespace {
Run run(const std::string& args) { return pt::test::run_pathtracer("", args); }
}  // namespace

TEST_CASE("cli: render of the default scene writes PNG and PFM whose mean matches the independent reference") {
  std::filesystem::remove("e2e.png");
  std::filesystem::remove("e2e.pfm");
  const Run r = run("render --spp 16 --png e2e.png --pfm e2e.pfm");
  INFO(r.out << r.err);
  REQUIRE(r.status == 0);
  CHECK(r.out.find("16 spp") != std::string::npos);
  CHECK(r.out.find("Mrays/s") != std::string::npos);
  CHECK(r.out.find("0 non-finite") != std::string::npos);
  int w = 0, h = 0, n = 0;
  REQUIRE(stbi_info("e2e.png", &w, &h, &n));
  CHECK(w == 512);
  CHECK(h == 512);
  const Image img = read_pfm("e2e.pfm");
  REQUIRE(img.width == 512);
  REQUIRE(img.height == 512);
  // The reference: Blender Cycles, 6,940 spp, block-averaged 4×4 (which preserves the image mean).
  const Image ref = read_pfm(std::string(PT_TEST_DATA_DIR) + "/cornell_128_cycles.pfm");
  const glm::dvec3 m = mean_rgb(img), mr = mean_rgb(ref);
  for (int c = 0; c < 3; ++c) {
    INFO("channel " << c << ": ours " << m[c] << ", reference " << mr[c]);
    // Measured +0.12 to +0.24 % over seeds 0-3 (the 16-spp standard error is ~0.03 % of the mean): 0.6 % leaves
    // room for that offset and catches a 1 % output scale error.
    CHECK(std::abs(m[c] / mr[c] - 1.0) < 0.006);
  }
}

TEST_CASE("cli: errors name the file, the JSON path and the reason, with exit status 2") {
  {
    const Run r = run("render --scene no-such-dir/missing.json");
    CHECK(r.status == 2);
    CHECK(r.err.find("no-such-dir/missing.json") != std::string::npos);
  }
  {
    std::ofstream("bad_radius.json") << R"({"camera": {"position": [0,0,5], "look_at": [0,0,0], "fov_deg": 40},
      "materials": {"m": {"type": "diffuse", "albedo": [0.5,0.5,0.5]}},
      "shapes": [{"type": "sphere", "center": [0,0,0], "radius": -1, "material": "m"}]})";
    const Run r = run("render --scene bad_radius.json");
    CHECK(r.status == 2);
    CHECK(r.err.find("bad_radius.json") != std::string::npos);
    CHECK(r.err.find("shapes[0].radius") != std::string::npos);
  }
  {
    const Run r = run("render --scene no-such-builtin");
    CHECK(r.status == 2);
    CHECK(r.err.find("cornell") != std::string::npos);  // lists the built-in scenes
  }
  {
    // bdpt's limits and its diagnostic option are refused with the reason, before any sample.
    const Run deep = run("render --estimator bdpt --bounces 5000 --spp 1 --png x.png");
    CHECK(deep.status == 2);
    CHECK(deep.err.find("render.max_bounces: bdpt traces at most 1024") != std::string::npos);
    const Run wrong = run("render --estimator mis --bdpt-strategy 1,2 --spp 1 --png x.png");
    CHECK(wrong.status == 2);
    CHECK(wrong.err.find("--bdpt-strategy: needs --estimator bdpt") != std::string::npos);
    const Run bad = run("render --estimator bdpt --bdpt-strategy 1,1 --spp 1 --png x.png");
    CHECK(bad.status == 2);
    CHECK(bad.err.find("not s = t = 1") != std::string::npos);
    CHECK(run("render --estimator bdpt --bdpt-strategy 2 --spp 1 --png x.png").status == 2);
    const Run no_manifold = run("render --estimator mis --no-manifold --spp 1 --png x.png");
    CHECK(no_manifold.status == 2);
    CHECK(no_manifold.err.find("--no-manifold: needs --estimator bdpt") != std::string::npos);
    CHECK_FALSE(std::filesystem::exists("x.png"));
  }
  {
    // A glTF file whose index runs past its vertices: the file, the glTF path and the reason; nothing written.
    std::ofstream("bad_index.gltf") << R"({"asset": {"version": "2.0"},
      "buffers": [{"byteLength": 44, "uri": "data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAAAAABAAkAAAA="}],
      "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 6}],
      "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"},
                    {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}],
      "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
      "nodes": [{"mesh": 0}], "scenes": [{"nodes": [0]}]})";
    const Run r = run("render --scene bad_index.gltf --spp 1 --png gltf.png");
    CHECK(r.status == 2);
    CHECK(r.err.find("bad_index.gltf: meshes[0].primitives[0].indices: index 2 is 9, past the 3 vertices") !=
          std::string::npos);
    CHECK_FALSE(std::filesystem::exists("gltf.png"));
  }
  CHECK(run("render --estimator magic").status == 2);
  CHECK(run("render --spp 0").status == 2);
  CHECK(run("frobnicate").status == 2);
}

TEST_CASE("cli: --help documents the options, --time stops, progress does not flood a log") {
  const Run help = run("render --help");
  CHECK(help.status == 0);
  for (const char* flag : {"--scene", "--width", "--height", "--spp", "--time", "--target-relmse", "--bounces",
                           "--estimator", "--seed", "--threads", "--png", "--pfm"})
    CHECK(help.out.find(flag) != std::string::npos);
  const Run timed = run("render --scene shadertoy --width 64 --height 36 --time 0.5 --pfm timed.pfm --threads 2");
  INFO(timed.out << timed.err);
  CHECK(timed.status == 0);
  CHECK(read_pfm("timed.pfm").width == 64);
  // stderr is a file here: at most one progress line per 10 s.
  CHECK(std::count(timed.err.begin(), timed.err.end(), '\n') <= 2);
  // --target-relmse stops once the film's estimate is at or below the target, never before 16 spp, and not far
  // past it: passes are cut where the estimate reaches the target at the 1/spp rate (before, a half-second pass
  // ran on: 565 spp and 4.5e-4 for a target of 5e-3 here).
  const auto summary = [](const std::string& out) {
    const size_t at = out.find(" spp in "), rel = out.find("estimated relMSE ");
    REQUIRE(at != std::string::npos);
    REQUIRE(rel != std::string::npos);
    const size_t start = out.rfind(' ', at - 1) + 1;
    return std::pair<long, double>{std::stol(out.substr(start, at - start)), std::stod(out.substr(rel + 17))};
  };
  for (const double goal : {5e-3, 1e-3}) {
    const Run target = run("render --scene cornell --width 64 --height 64 --threads 2 --target-relmse " +
                           std::to_string(goal) + " --pfm target.pfm");
    INFO(target.out << target.err);
    REQUIRE(target.status == 0);
    const auto [spp, relmse] = summary(target.out);
    CHECK(spp >= 16);
    CHECK(relmse <= goal);
    CHECK(relmse >= 0.5 * goal);  // at 1/spp, stopping at twice the samples needed would give 0.5 × the target
  }
  const Run early = run("render --scene cornell --width 64 --height 64 --threads 2 --target-relmse 0.5 --pfm target.pfm");
  REQUIRE(early.status == 0);
  CHECK(summary(early.out).first == 16);  // met at once, but the estimate is read from 16 spp on
}

TEST_CASE("cli: bench --quick writes a sane CSV, summary and plots") {
  std::filesystem::remove_all("bench_quick");
  const Run r = run("bench --quick --out bench_quick --cache bench_quick/cache --threads 2");
  INFO(r.out << r.err);
  REQUIRE(r.status == 0);
  std::ifstream csv("bench_quick/convergence.csv");
  std::string line;
  std::getline(csv, line);
  CHECK(line == "scene,estimator,sampler,threads,seconds,spp,relMSE,RMSE,Mrays/s,denoised relMSE,denoise seconds");
  int rows = 0;
  std::map<std::string, int> per_series;
  struct Point {
    double seconds, spp, relmse;
  };
  std::map<std::string, std::vector<Point>> series;
  while (std::getline(csv, line)) {
    ++rows;
    std::vector<std::string> f;
    std::stringstream ss(line);
    for (std::string cell; std::getline(ss, cell, ',');) f.push_back(cell);
    REQUIRE(f.size() == 11);
    ++per_series[f[0] + "/" + f[1] + "/" + f[2]];
    const double seconds = std::stod(f[4]), rel = std::stod(f[6]), rm = std::stod(f[7]), den = std::stod(f[9]),
                 den_s = std::stod(f[10]);
    series[f[0] + "/" + f[1] + "/" + f[2]].push_back({seconds, std::stod(f[5]), rel});
    CHECK(seconds > 0);
    CHECK(std::isfinite(rel));
    CHECK(rel > 0);
    CHECK(rm > 0);
    CHECK(std::isfinite(den));
    CHECK(den > 0);
    CHECK(den_s > 0);
  }
  CHECK(per_series.size() == 75);  // 5 scenes × 5 estimators × 3 samplers
  for (const auto& [name, n] : per_series) CHECK(n == 4);  // budgets 1/16, 1/8, 1/4, 1/2 s
  // One progressive render per series: time and samples grow from budget to budget, and the error falls. With 8×
  // the time an unbiased estimate's relMSE falls about 8× (about 6-9x measured on the scenes checked); a film
  // restarted at each budget, or a budget ignored, would keep it level. Not checked on `sky` and `materials`:
  // there the sun's and the mirrors' rare caustic paths make relMSE at these budgets heavy-tailed (sky under
  // mis with sobol measured 0.014, 0.025, 17, 4.6 at the four budgets). This check found adaptive bdpt passes
  // running 8x their planned size (two budgets ending at the same 0.58 s, relMSE 0.0054 -> 0.00075): they are
  // uniform now.
  double worst_ratio = 0;
  std::string worst;
  for (const auto& [name_, pts_] : series) {
    const auto& name = name_; const auto& pts = pts_;  // clang 14: lambdas cannot capture bindings
    INFO(name);
    REQUIRE(pts.size() == 4);
    // Non-decreasing: on a loaded machine one pass may run past two budgets (they then share a point).
    for (size_t i = 1; i < pts.size(); ++i) {
      CHECK(pts[i].seconds >= pts[i - 1].seconds);
      CHECK(pts[i].spp >= pts[i - 1].spp);
    }
    // 8x the time: more samples, by less than 8x where the machine's load changes between budgets (measured
    // 115 against 61 spp under a parallel build); a budget ignored would keep the count level.
    CHECK(pts.back().spp * 4 > pts.front().spp * 5);
    if (name.starts_with("sky/") || name.starts_with("materials/")) continue;
    const double ratio = pts.back().relmse / pts.front().relmse;
    if (ratio > worst_ratio) worst_ratio = ratio, worst = name;
    CHECK(ratio < 0.75);  // ~1/8 expected, 0.26 the worst measured: room for a loaded machine, not for a restart
  }
  MESSAGE("relMSE at 1/2 s over relMSE at 1/16 s: at most " << worst_ratio << " (" << worst << ")");
  const std::string summary = slurp("bench_quick/summary.md");
  CHECK(summary.find("time to 1e-3") != std::string::npos);
  CHECK(summary.find("denoised: time to 1e-3") != std::string::npos);
  CHECK(summary.find("Thread scaling") != std::string::npos);
  if (std::system("command -v gnuplot >/dev/null 2>&1") != 0) return pt::test::skip_for_missing("gnuplot", "the plot check");
  for (const char* scene : {"cornell", "cornell-spheres", "shadertoy", "materials", "sky"})
    CHECK(std::filesystem::file_size(std::string("bench_quick/convergence-") + scene + ".png") > 1000);
}

TEST_CASE("cli: bench takes a scene file by its path: its reference and plots are named by its stem") {
  // The whole path went into the reference cache's file name and the plots' ("bench-cache/a dir/it's…", a folder
  // that does not exist): the bench stopped with "cannot create a temporary file" at its first reference. A
  // quote in the path and in --out also reaches gnuplot's script and the shell intact.
  namespace fs = std::filesystem;
  fs::remove_all("bench file");
  fs::create_directories("bench file/a dir");
  std::ofstream("bench file/a dir/it's a room.json") << slurp(std::string(PT_SCENES_DIR) + "/cornell.json");
  const Run r = run("bench --quick --scenes \"bench file/a dir/it's a room.json\" cornell --estimators mis "
                    "--samplers sobol --threads 2 --out \"bench file/out'q\" --cache \"bench file/cache\"");
  INFO(r.out << r.err);
  REQUIRE(r.status == 0);
  int cached = 0;
  for (const auto& e : fs::directory_iterator("bench file/cache"))
    cached += e.path().filename().string().starts_with("it_s_a_room-64x64-");
  CHECK(cached == 1);
  CHECK(fs::exists("bench file/out'q/convergence-it_s_a_room.gp"));
  CHECK(slurp("bench file/out'q/convergence.csv").find("bench file/a dir/it's a room.json,mis,sobol") !=
        std::string::npos);
  if (std::system("command -v gnuplot >/dev/null 2>&1") != 0) return pt::test::skip_for_missing("gnuplot", "the plot check");
  CHECK(fs::file_size("bench file/out'q/convergence-it_s_a_room.png") > 1000);
  CHECK(fs::file_size("bench file/out'q/convergence-cornell.png") > 1000);
}

TEST_CASE("cli: bench --instructions reads callgrind's total and refuses a binary valgrind cannot run") {
  // The total as valgrind 3.19 prints it, amid the rest of its log; the PID field varies.
  const std::string log =
      "==4242== Callgrind, a call-graph generating cache profiler\n==4242== Events    : Ir\n"
      "==4242== Collected : 456242331\n==4242==\n==4242== I   refs:      456,242,331\n";
  CHECK(parse_callgrind_total(log) == std::optional<uint64_t>(456242331ull));
  CHECK(!parse_callgrind_total("==1== Events : Ir\n==1== I   refs: 12\n"));  // killed before the summary
  CHECK(!parse_callgrind_total("==1== Collected : 99999999999999999999999\n"));  // out of range, not wrapped
  // Paths reach /bin/sh quoted: a space and a quote in them stay literal.
  const std::string cmd = counted_render_command("/opt/my pt/pathtracer", "cornell", "mis", 64, 48, 16, "it's.pfm");
  CHECK(cmd == "'/opt/my pt/pathtracer' render -q --threads 1 --scene 'cornell' --estimator 'mis' --sampler sobol "
               "--width 64 --height 48 --spp 16 --pfm 'it'\\''s.pfm'");
  // A scene given as a file path names files in the work directory itself, not in subdirectories of it.
  CHECK(counted_file_stem("scenes/my room.json", "bdpt", 16) == "scenes_my_room.json-bdpt-16");
  CHECK(counted_file_stem("cornell", "mis", 1) == "cornell-mis-1");
  // Checked before the bench starts (exit 2, nothing written).
  std::filesystem::remove_all("bench_instr");
  const Run missing = run("bench --quick --out bench_instr --instructions-binary no/such/pathtracer");
  CHECK(missing.status == 2);
  CHECK(missing.err.find("no/such/pathtracer") != std::string::npos);
  CHECK(!std::filesystem::exists("bench_instr"));
  if (!this_binary_runs_under_valgrind()) {  // this build uses AVX-512: valgrind would die on its first such op
    const Run self = run("bench --quick --out bench_instr --instructions");
    CHECK(self.status == 2);
    CHECK(self.err.find("--instructions-binary") != std::string::npos);
    CHECK(self.err.find("x86-64-v3") != std::string::npos);
    CHECK(!std::filesystem::exists("bench_instr"));
  }
}

TEST_CASE("cli: bench rays replays a ray file over [tnear, tfar] and records the scene's own rays") {
  // Rays in cornell's world coordinates with answers known from the box's layout (x in [0, 556], y in [0, 548.8],
  // z in [0, 559.2], the front at z = 0 open; the blocks below y = 330): from a point above the blocks every
  // direction but -z hits a wall.
  const float inf = std::numeric_limits<float>::infinity();
  const std::vector<RecordedRay> rays = {
      {{278, 400, 280}, {1, 0, 0}, 0, inf},      // hit (right wall)
      {{278, 400, 280}, {-1, 0, 0}, 0, inf},     // hit (left wall)
      {{278, 400, 280}, {0, 1, 0}, 0, 1e30f},    // hit (ceiling or light)
      {{278, 400, 280}, {0, -1, 0}, 0, inf},     // hit (floor)
      {{278, 400, 280}, {0, 0, 1}, 0, inf},      // hit (a block or the back wall)
      {{278, 400, 280}, {0, 0, -1}, 0, inf},     // miss: out through the open front
      {{278, 400, 280}, {1, 0, 0}, 0, 100},      // miss: tfar ends 178 short of the wall
      {{278, 274, -1000}, {0, 0, 2}, 0, 400},    // miss: t is in units of |d|, so it stops at z = -200
      {{278, 274, -1000}, {0, 0, 2}, 0, 800},    // hit: reaches z = 600
      {{278, 274, -1000}, {0, 0, 1}, 2000, inf}, // miss: starts at tnear, z = 1000, behind the back wall
  };
  write_ray_file("bench_rays_known.bin", rays);
  const Run r = run("bench rays --scene cornell --rays bench_rays_known.bin --repeats 2 --json");
  INFO(r.out << r.err);
  REQUIRE(r.status == 0);
  CHECK(r.out.find("\"closest_hits\": 6,") != std::string::npos);
  CHECK(r.out.find("\"occluded\": 6,") != std::string::npos);  // over [tnear, tfar]: blocked wherever it hits
  // The shadow-half rule stops odd rays that hit (1 and 3 here) at 0.99 × the hit: those two pass.
  CHECK(r.out.find("\"occluded_half\": 4,") != std::string::npos);
  CHECK(r.out.find("\"rays\": 10,") != std::string::npos);
  // The packet queries give the same answers.
  const Run packets = run("bench rays --scene cornell --rays bench_rays_known.bin --repeats 1 --packets --json");
  INFO(packets.out << packets.err);
  REQUIRE(packets.status == 0);
  CHECK(packets.out.find("\"closest_hits\": 6, \"occluded\": 6, \"occluded_half\": 4,") != std::string::npos);

  std::filesystem::remove("bench_rays_own.bin");
  const Run rec = run("bench rays --scene cornell --record bench_rays_own.bin --count 1000");
  INFO(rec.out << rec.err);
  REQUIRE(rec.status == 0);
  CHECK(std::filesystem::file_size("bench_rays_own.bin") == 16 + 32 * 1000);
  const std::vector<RecordedRay> own = read_ray_file("bench_rays_own.bin");
  CHECK(own.front().origin[2] == -800.f);  // world coordinates: the first ray leaves cornell's camera
  const Run replay = run("bench rays --scene cornell --rays bench_rays_own.bin --repeats 1 --threads 2 "
                         "--export-tris bench_rays.tris");
  INFO(replay.out << replay.err);
  CHECK(replay.status == 0);
  CHECK(replay.out.find("1000 rays from bench_rays_own.bin, 2 threads") != std::string::npos);
  // cornell.json has 16 quads: 32 triangles of 9 floats after a 60-byte header (as scene_tris.py of the peers).
  const std::string tris = slurp("bench_rays.tris");
  REQUIRE(tris.size() == 60 + 32 * 36);
  CHECK(tris.substr(0, 8) == "PTTRIS01");
  uint32_t tri_count = 0;
  std::memcpy(&tri_count, tris.data() + 56, 4);
  CHECK(tri_count == 32);

  const Run both = run("bench rays --rays bench_rays_own.bin --record x.bin");
  CHECK(both.status == 2);
  CHECK(both.err.find("excludes --record") != std::string::npos);
  const Run neither = run("bench rays --scene cornell");
  CHECK(neither.status == 2);
  CHECK(neither.err.find("give --rays FILE (replay) or --record FILE (record)") != std::string::npos);
  const Run bad_dir = run("bench rays --record no_such_dir/r.bin");
  CHECK(bad_dir.status == 2);
  CHECK(bad_dir.err.find("--record no_such_dir/r.bin") != std::string::npos);
  std::ofstream("bench_rays_bad.bin") << "PTRAYS01";
  const Run bad = run("bench rays --rays bench_rays_bad.bin");
  CHECK(bad.status == 2);
  CHECK(bad.err.find("error: bench_rays_bad.bin: not a ray file") != std::string::npos);
  for (const char* f : {"bench_rays.tris", "bench_rays_known.bin", "bench_rays_own.bin", "bench_rays_bad.bin"}) std::filesystem::remove(f);
}

namespace {

// The bytes of a file ("" when missing).
std::string file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// The "path: ..." line of render's summary.
std::string path_line(const Run& r) {
  const size_t at = r.out.find("path: ");
  return at == std::string::npos ? "" : r.out.substr(at, r.out.find('\n', at) - at);
}

}  // namespace

// Issue 41: a flag parsed and then ignored must fail a test. The diagnostic flags (--path-loop, --generic-kernel)
// keep the image's bits and change the compiled path, which render's summary names; the others change the
// image in a way checked against what they promise.
TEST_CASE("cli: --path-loop and --generic-kernel keep the image's bits and change the path taken") {
  const std::string base = "render --width 32 --height 32 --spp 2 -q --threads 2 ";
  const Run wave = run(base + "--path-loop wavefront --pfm loop_w.pfm");
  const Run scalar = run(base + "--path-loop scalar --pfm loop_s.pfm");
  const Run generic = run(base + "--generic-kernel --pfm loop_g.pfm");
  const Run automatic = run(base + "--pfm loop_a.pfm");
  REQUIRE(wave.status == 0);
  REQUIRE(scalar.status == 0);
  REQUIRE(generic.status == 0);
  REQUIRE(automatic.status == 0);
  CHECK(file_bytes("loop_w.pfm").size() > 32 * 32 * 12);
  CHECK(file_bytes("loop_w.pfm") == file_bytes("loop_s.pfm"));
  CHECK(file_bytes("loop_w.pfm") == file_bytes("loop_g.pfm"));
  CHECK(path_line(wave) == "path: wavefront loop, kernel for polygons with Lambert materials, SIMD shading lanes");
  CHECK(path_line(scalar) == "path: scalar loop, kernel for polygons with Lambert materials");
  CHECK(path_line(generic) == "path: wavefront loop, generic kernel (every feature), SIMD shading lanes");
  CHECK(path_line(automatic) == path_line(wave));  // auto: the wavefront
}

TEST_CASE("cli: --sampler and --rr-depth change the image as they say, and the defaults are what the scene names") {
  const std::string base = "render --width 32 --height 32 --spp 4 -q --threads 2 ";
  const Run sobol = run(base + "--pfm s_sobol.pfm");
  const Run independent = run(base + "--sampler independent --pfm s_indep.pfm");
  REQUIRE(sobol.status == 0);
  REQUIRE(independent.status == 0);
  CHECK(sobol.out.find("/sobol:") != std::string::npos);
  CHECK(independent.out.find("/independent:") != std::string::npos);
  CHECK(file_bytes("s_sobol.pfm") != file_bytes("s_indep.pfm"));
  CHECK(run(base + "--sampler sobol --pfm s_sobol2.pfm").status == 0);
  CHECK(file_bytes("s_sobol.pfm") == file_bytes("s_sobol2.pfm"));
  // The Cornell box's setting is "auto", roulette from bounce 5 under its mis: --rr-depth 5 is the same image,
  // other depths are not.
  REQUIRE(run(base + "--rr-depth 5 --pfm rr5.pfm").status == 0);
  REQUIRE(run(base + "--rr-depth 3 --pfm rr3.pfm").status == 0);
  REQUIRE(run(base + "--rr-depth -1 --pfm rr_off.pfm").status == 0);
  REQUIRE(run(base + "--rr-depth 0 --pfm rr0.pfm").status == 0);
  CHECK(file_bytes("rr5.pfm") == file_bytes("s_sobol.pfm"));
  CHECK(file_bytes("rr3.pfm") != file_bytes("rr5.pfm"));
  CHECK(file_bytes("rr_off.pfm") != file_bytes("rr5.pfm"));
  CHECK(file_bytes("rr0.pfm") != file_bytes("rr5.pfm"));
  CHECK(file_bytes("rr0.pfm") != file_bytes("rr_off.pfm"));
}

TEST_CASE("cli: --tonemap aces writes the Narkowicz curve's sRGB values, clamp and reinhard theirs") {
  // A camera inside a closed emitting box: every pixel sees radiance exactly 0.8 (an emitter of albedo 0, seen
  // directly; max_bounces 0).
  std::ofstream("tm.json") << R"({"camera": {"position": [0,0,0], "look_at": [0,0,-1], "fov_deg": 40},
    "film": {"width": 8, "height": 8}, "render": {"max_bounces": 0},
    "materials": {"glow": {"type": "diffuse", "albedo": [0,0,0], "emission": [0.8, 0.2, 3.0], "two_sided": true}},
    "shapes": [{"type": "sphere", "center": [0,0,0], "radius": 10, "material": "glow"}]})";
  auto pixel = [](const std::string& png) {
    int w = 0, h = 0, n = 0;
    unsigned char* p = stbi_load(png.c_str(), &w, &h, &n, 3);
    REQUIRE(p);
    std::array<int, 3> v{p[0], p[1], p[2]};
    stbi_image_free(p);
    return v;
  };
  // Independent of tracer/film/tonemap.h: the curve (Narkowicz 2015), the sRGB transfer function (IEC
  // 61966-2-1) and rounding, written out here in double.
  auto srgb8 = [](double x) {
    x = std::clamp(x, 0.0, 1.0);
    const double e = x <= 0.0031308 ? 12.92 * x : 1.055 * std::pow(x, 1.0 / 2.4) - 0.055;
    return static_cast<int>(std::lround(e * 255.0));
  };
  auto aces = [](double x) { return std::clamp(x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0); };
  const double radiance[3] = {0.8, 0.2, 3.0};
  for (const char* tm : {"aces", "clamp", "reinhard"}) {
    const std::string png = std::string("tm_") + tm + ".png";
    REQUIRE(run(std::string("render --scene tm.json --spp 1 -q --tonemap ") + tm + " --png " + png).status == 0);
    const std::array<int, 3> got = pixel(png);
    for (int c = 0; c < 3; ++c) {
      const double x = radiance[c];
      const double mapped = std::string(tm) == "aces" ? aces(x) : std::string(tm) == "clamp" ? std::min(x, 1.0) : x / (1 + x);
      INFO(tm << " channel " << c);
      CHECK(std::abs(got[c] - srgb8(mapped)) <= 1);  // float against double rounding: at most one step
    }
  }
  CHECK(pixel("tm_aces.png") != pixel("tm_clamp.png"));
}

TEST_CASE("cli: --adaptive spends samples unevenly (the EXR's spp layer), a uniform render evenly") {
  // Passes of ~0.5 s: after the first uniform ones (every pixel below 8 spp; every 4th pass) the error decides.
  // The uniform render stops at a sample count (every pixel exactly 64 spp, whatever the machine's load); the
  // adaptive one at a time, long enough for several error-driven passes even when a loaded machine makes the
  // first planned pass run 4 times too long (a time-limited uniform render cut its last pass short there and
  // failed the evenness bound).
  const std::string base = "render --scene cornell-spheres --estimator mis --width 64 --height 64 -q --threads 2 --aov spp ";
  REQUIRE(run(base + "--spp 64 --exr uniform.exr").status == 0);
  REQUIRE(run(base + "--time 4 --adaptive --exr adaptive.exr").status == 0);
  auto spp_range = [](const std::string& path) {
    Imf::InputFile file(path.c_str());
    const Imath::Box2i win = file.header().dataWindow();
    const int w = win.max.x - win.min.x + 1, h = win.max.y - win.min.y + 1;
    REQUIRE(file.header().channels().findChannel("spp.Y"));
    std::vector<float> spp(static_cast<size_t>(w) * h, -1.f);
    Imf::FrameBuffer fb;
    fb.insert("spp.Y", Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(spp.data()), sizeof(float), sizeof(float) * w));
    file.setFrameBuffer(fb);
    file.readPixels(win.min.y, win.max.y);
    const auto [lo, hi] = std::minmax_element(spp.begin(), spp.end());
    return std::pair<float, float>{*lo, *hi};
  };
  const auto uniform = spp_range("uniform.exr"), adaptive = spp_range("adaptive.exr");
  INFO("uniform spp from " << uniform.first << " to " << uniform.second);
  CHECK(uniform.first == 64.f);
  CHECK(uniform.second == 64.f);
  INFO("adaptive spp from " << adaptive.first << " to " << adaptive.second);
  CHECK(adaptive.first >= 1.f);
  CHECK(adaptive.second >= 2.f * adaptive.first);  // the error-driven passes favour some tiles (up to 8x)
}

TEST_CASE("cli: compare --blocks counts the blocks off the reference and names the worst") {
  Image ref{32, 32, std::vector<float>(32 * 32 * 3, 0.5f)};
  Image img = ref;
  // One 8x8 block 10 % brighter, another 2 % (inside a 3 % tolerance).
  for (int y = 8; y < 16; ++y)
    for (int x = 16; x < 24; ++x)
      for (int c = 0; c < 3; ++c) img.rgb[3 * (y * 32 + x) + c] = 0.55f;
  for (int y = 24; y < 32; ++y)
    for (int x = 0; x < 8; ++x)
      for (int c = 0; c < 3; ++c) img.rgb[3 * (y * 32 + x) + c] = 0.51f;
  write_pfm("blk_img.pfm", img);
  write_pfm("blk_ref.pfm", ref);
  const Run r = run("compare blk_img.pfm blk_ref.pfm --blocks 8 --block-tolerance 0.03");
  INFO(r.out << r.err);
  REQUIRE(r.status == 0);
  CHECK(r.out.find("blocks 8x8: 1 of 16 off the reference's mean luminance by more than 3 %, worst +10.0 % at pixel (16, 8)") !=
        std::string::npos);
}
