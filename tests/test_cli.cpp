// End-to-end: the real `pathtracer` executable, run as a user runs it.
#include <doctest/doctest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <stb_image.h>

#include "io/image_io.h"
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
    CHECK(std::abs(m[c] / mr[c] - 1.0) < 0.02);
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
  const Run target = run("render --width 32 --height 32 --target-relmse 0.05 --pfm target.pfm");
  INFO(target.out << target.err);
  CHECK(target.status == 0);
  CHECK(target.out.find("estimated relMSE") != std::string::npos);
}

TEST_CASE("cli: bench --quick writes a sane CSV, summary and plots") {
  std::filesystem::remove_all("bench_quick");
  const Run r = run("bench --quick --out bench_quick --cache bench_quick/cache --threads 2");
  INFO(r.out << r.err);
  REQUIRE(r.status == 0);
  std::ifstream csv("bench_quick/convergence.csv");
  std::string line;
  std::getline(csv, line);
  CHECK(line == "scene,estimator,sampler,threads,seconds,spp,relMSE,RMSE,Mrays/s");
  int rows = 0;
  std::map<std::string, int> per_series;
  while (std::getline(csv, line)) {
    ++rows;
    std::vector<std::string> f;
    std::stringstream ss(line);
    for (std::string cell; std::getline(ss, cell, ',');) f.push_back(cell);
    REQUIRE(f.size() == 9);
    ++per_series[f[0] + "/" + f[1] + "/" + f[2]];
    const double seconds = std::stod(f[4]), rel = std::stod(f[6]), rm = std::stod(f[7]);
    CHECK(seconds > 0);
    CHECK(std::isfinite(rel));
    CHECK(rel > 0);
    CHECK(rm > 0);
  }
  CHECK(per_series.size() == 60);  // 5 scenes × 4 estimators × 3 samplers
  for (const auto& [name, n] : per_series) CHECK(n == 4);  // budgets 1/16, 1/8, 1/4, 1/2 s
  const std::string summary = slurp("bench_quick/summary.md");
  CHECK(summary.find("time to 1e-3") != std::string::npos);
  CHECK(summary.find("Thread scaling") != std::string::npos);
  if (std::system("command -v gnuplot >/dev/null 2>&1") == 0)
    for (const char* scene : {"cornell", "cornell-spheres", "shadertoy", "materials", "sky"})
      CHECK(std::filesystem::file_size(std::string("bench_quick/convergence-") + scene + ".png") > 1000);
}
