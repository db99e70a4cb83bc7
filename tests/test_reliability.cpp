// Reliability (docs/reliability.md): files are written completely or not at all, special files and links are
// respected, outputs are checked before rendering, signals and deadlines stop a render within a sample and keep
// its image, and bad option values are refused with the flag, the valid range and exit status 2.
#include <doctest/doctest.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <string>

#include "io/image_io.h"
#include "io/safe_file.h"
#include "cli/stress_scenes.h"
#include "scene/scene.h"
#include "scene/scene_json.h"
#include "run_command.h"
#include "test_helpers.h"

using namespace pt;
namespace fs = std::filesystem;
using pt::test::Run;
using pt::test::slurp;
using pt::stress::builtin_at;
using pt::stress::transformed;

namespace {

// A fresh directory per test case, removed afterwards.
struct TempDir {
  fs::path path;
  explicit TempDir(const std::string& name) {
    path = fs::temp_directory_path() / ("pt_reliability_" + name + "_" + std::to_string(getpid()));
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
  std::string operator/(const std::string& name) const { return (path / name).string(); }
  // Names in the directory (to see that no temporary file was left behind).
  std::vector<std::string> names() const {
    std::vector<std::string> n;
    for (const auto& e : fs::directory_iterator(path)) n.push_back(e.path().filename().string());
    std::sort(n.begin(), n.end());
    return n;
  }
};

void put(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

Image small_image() { return Image{4, 2, std::vector<float>(24, 0.5f)}; }

Run run(const std::string& args) { return pt::test::run_pathtracer("", args); }

// Runs `script` with sh, the pathtracer executable as $PT; returns the exit status and the output files' text.
Run run_script(const std::string& script) {
  static int counter = 0;
  const std::string stem = "rel_" + std::to_string(getpid()) + "_" + std::to_string(counter++);
  const std::string cmd = "PT=\"" + std::string(PATHTRACER_EXE) + "\" sh -c '" + script + "' > " + stem + ".out 2> " +
                          stem + ".err";
  const int raw = std::system(cmd.c_str());
  Run r{WIFEXITED(raw) ? WEXITSTATUS(raw) : -1, slurp(stem + ".out"), slurp(stem + ".err")};
  fs::remove(stem + ".out");
  fs::remove(stem + ".err");
  return r;
}

// A closed box, every wall white with albedo 1, one wall emitting: with no bounce limit and no roulette a path
// never ends (and the radiance diverges), the worst case for a time limit.
std::string closed_white_room_json() {
  return R"({
  "camera": {"position": [0, 0, -0.5], "look_at": [0, 0, 1], "up": [0, 1, 0], "fov_deg": 60},
  "film": {"width": 32, "height": 32},
  "render": {"max_bounces": 1073741824, "russian_roulette_depth": -1, "estimator": "cosine"},
  "materials": {"white": {"type": "diffuse", "albedo": [1, 1, 1]},
                "lamp": {"type": "diffuse", "albedo": [1, 1, 1], "emission": [1, 1, 1]}},
  "shapes": [
    {"type": "quad", "vertices": [[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1]], "material": "white"},
    {"type": "quad", "vertices": [[-1, -1, 1], [-1, 1, 1], [1, 1, 1], [1, -1, 1]], "material": "white"},
    {"type": "quad", "vertices": [[-1, -1, -1], [-1, 1, -1], [-1, 1, 1], [-1, -1, 1]], "material": "white"},
    {"type": "quad", "vertices": [[1, -1, -1], [1, -1, 1], [1, 1, 1], [1, 1, -1]], "material": "white"},
    {"type": "quad", "vertices": [[-1, -1, -1], [-1, -1, 1], [1, -1, 1], [1, -1, -1]], "material": "white"},
    {"type": "quad", "vertices": [[-1, 1, -1], [1, 1, -1], [1, 1, 1], [-1, 1, 1]], "material": "lamp"}
  ]
})";
}

}  // namespace

TEST_CASE("safe writes: a failure mid-write (full disk) leaves the earlier file intact and no temporary file") {
  TempDir dir("full");
  const std::string out = dir / "out.pfm";
  put(out, "the earlier render");
  put(dir / "out.pfm.tmp", "somebody else's file");  // a name an old writer would have used: must survive
  testing::fail_writes_after(10, ENOSPC);
  try {
    write_pfm(out, small_image());
    FAIL("the write should have failed");
  } catch (const ImageError& e) {
    CHECK(std::string(e.what()) == out + ": cannot write (No space left on device)");
  }
  CHECK(slurp(out) == "the earlier render");
  CHECK(slurp(dir / "out.pfm.tmp") == "somebody else's file");
  CHECK(dir.names() == std::vector<std::string>{"out.pfm", "out.pfm.tmp"});
  // The fault was for one call only: the next write goes through, complete.
  write_pfm(out, small_image());
  CHECK(read_pfm(out).rgb == small_image().rgb);
  CHECK(dir.names() == std::vector<std::string>{"out.pfm", "out.pfm.tmp"});
}

TEST_CASE("safe writes: a hard-linked output on a full disk fails before its first byte") {
  // docs/reliability.md: a file with several hard links is written in place (every name sees the new image),
  // after checking that the file system has room, so a full disk fails before the first byte. The simulated
  // disk has 10 bytes of room: writing in place without the check would overwrite the file's start and then
  // fail, leaving both names a broken image.
  TempDir dir("linkfull");
  const std::string a = dir / "a.pfm", b = dir / "b.pfm";
  put(a, "the earlier render, long enough to be visibly damaged");
  fs::create_hard_link(a, b);
  testing::fail_writes_after(10, ENOSPC);
  CHECK_THROWS_WITH_AS(write_pfm(a, small_image()), (a + ": cannot write (No space left on device)").c_str(), ImageError);
  CHECK(slurp(a) == "the earlier render, long enough to be visibly damaged");
  CHECK(fs::hard_link_count(a) == 2);
  CHECK(dir.names() == std::vector<std::string>{"a.pfm", "b.pfm"});
  // With room enough, the same write goes through in place and both names see it.
  testing::fail_writes_after(size_t{1} << 20, ENOSPC);
  write_pfm(a, small_image());
  CHECK(read_pfm(b).rgb == small_image().rgb);
  CHECK(fs::hard_link_count(a) == 2);
}

TEST_CASE("safe writes: links, permissions and special files are respected") {
  TempDir dir("special");
  SUBCASE("a symbolic link is followed, and stays a link") {
    put(dir / "target.pfm", "old");
    fs::create_symlink("target.pfm", dir / "link.pfm");
    write_pfm(dir / "link.pfm", small_image());
    CHECK(fs::is_symlink(dir / "link.pfm"));
    CHECK(read_pfm(dir / "target.pfm").rgb == small_image().rgb);
  }
  SUBCASE("a hard-linked file is written in place: every name sees the new image") {
    put(dir / "a.pfm", "old");
    fs::create_hard_link(dir / "a.pfm", dir / "b.pfm");
    write_pfm(dir / "a.pfm", small_image());
    CHECK(fs::hard_link_count(dir / "a.pfm") == 2);
    CHECK(read_pfm(dir / "b.pfm").rgb == small_image().rgb);
  }
  SUBCASE("the mode of a replaced file is kept") {
    put(dir / "m.pfm", "old");
    ::chmod((dir / "m.pfm").c_str(), 0640);
    write_pfm(dir / "m.pfm", small_image());
    struct stat st {};
    REQUIRE(::stat((dir / "m.pfm").c_str(), &st) == 0);
    CHECK((st.st_mode & 07777) == 0640);
  }
  SUBCASE("a device stays a device (/dev/zero discards writes); /dev/full reports the full disk") {
    write_pfm("/dev/zero", small_image());
    CHECK(fs::is_character_file("/dev/zero"));
    CHECK_THROWS_WITH_AS(write_pfm("/dev/full", small_image()), "/dev/full: cannot write (No space left on device)",
                         ImageError);
    CHECK(fs::is_character_file("/dev/full"));
  }
  SUBCASE("a FIFO without a reader fails at once instead of blocking; a directory is refused") {
    REQUIRE(::mkfifo((dir / "fifo").c_str(), 0600) == 0);
    CHECK_THROWS_WITH_AS(write_pfm(dir / "fifo", small_image()),
                         (dir / "fifo" + ": cannot write (no process is reading the FIFO)").c_str(), ImageError);
    CHECK(fs::is_fifo(dir / "fifo"));
    fs::create_directory(dir / "sub");
    CHECK_THROWS_WITH_AS(write_pfm(dir / "sub", small_image()), (dir / "sub" + ": cannot write (Is a directory)").c_str(),
                         ImageError);
  }
}

TEST_CASE("safe reads: only regular files, with a size cap") {
  TempDir dir("read");
  CHECK_THROWS_WITH_AS(read_file_limited("/dev/zero", 1000),
                       "/dev/zero: not a regular file (a device, FIFO or socket; use - to read standard input)", FileError);
  REQUIRE(::mkfifo((dir / "fifo").c_str(), 0600) == 0);
  CHECK_THROWS_AS(read_file_limited(dir / "fifo", 1000), FileError);  // refused before opening: no hang
  put(dir / "big", std::string(2000, 'x'));
  CHECK_THROWS_WITH_AS(read_file_limited(dir / "big", 1000),
                       (dir / "big" + ": file too large (2000 bytes; the limit is 1000)").c_str(), FileError);
  CHECK(read_file_limited(dir / "big", 2000).size() == 2000);
  CHECK_THROWS_WITH_AS(read_file_limited(dir / "missing", 10),
                       (dir / "missing" + ": cannot open (No such file or directory)").c_str(), FileError);
}

TEST_CASE("cli: bad option values are refused with the flag and the valid range (exit 2)") {
  struct Case {
    const char* args;
    const char* message;
  };
  const std::string render = "render -q --spp 1 --width 8 --height 8 --png /dev/null ";
  const Case render_cases[] = {
      {"--time nan", "--time: must be a finite number in [0.001, 1e+07], not 'nan'"},
      {"--time 1e-300", "--time: must be a finite number in [0.001, 1e+07], not '1e-300'"},
      {"--target-relmse nan", "--target-relmse: must be a finite number in [1e-12, 1e+06], not 'nan'"},
      {"--exposure nan", "--exposure: must be a finite number in [-64, 64], not 'nan'"},
      {"--seed 18446744073709551616", "--seed: must be a whole number in [0, 18446744073709551615]"},
      {"--width 32.0", "--width: must be a whole number in [1, 16384], not '32.0'"},
      {"--threads 2000", "--threads: must be a whole number in [0, 1024], not '2000'"},
  };
  for (const Case& c : render_cases) {
    INFO(c.args);
    const Run r = run(render + c.args);
    CHECK(r.status == 2);
    CHECK(r.err.find(c.message) != std::string::npos);
  }
  // The other commands: options are checked before anything starts (the viewer needs no display to refuse).
  const Case other_cases[] = {
      {"view --time nan", "--time: must be a finite number in [0.001, 1e+07], not 'nan'"},
      {"view --exposure inf", "--exposure: must be a finite number in [-64, 64], not 'inf'"},
      {"view --seconds -1", "--seconds: must be a finite number in [0, 1e+07], not '-1'"},
      {"view --spp 4.5", "--spp: must be a whole number in [1, 2147483648], not '4.5'"},
      {"view --frames 1e3", "--frames: must be a whole number in [0, 1099511627776], not '1e3'"},
      {"view --max-fps nan", "--max-fps: must be a finite number in [0, 10000], not 'nan'"},
      {"bench --max-seconds nan", "--max-seconds: must be a finite number in [0.001, 1e+06], not 'nan'"},
      {"bench --threads 4096", "--threads: must be a whole number in [0, 1024], not '4096'"},
      {"bench --reference-spp 8", "--reference-spp: must be a whole number in [16, 1073741824], not '8'"},
      {"compare a.pfm b.pfm --downsample 2.0", "--downsample: must be a whole number in [1, 64], not '2.0'"},
      {"stress --soak inf", "--soak: must be a finite number in [1, 1e+06], not 'inf'"},
      {"stress --soak-seed -1", "--soak-seed: must be a whole number in [0, 18446744073709551615], not '-1'"},
      {"stress --threads 1e9", "--threads: must be a whole number in [0, 1024], not '1e9'"},
  };
  for (const Case& c : other_cases) {
    INFO(c.args);
    const Run r = run_script("env -u DISPLAY -u WAYLAND_DISPLAY \"$PT\" " + std::string(c.args));
    CHECK(r.status == 2);
    CHECK(r.err.find(c.message) != std::string::npos);
  }
}

TEST_CASE("cli: outputs are checked before rendering: the input scene, duplicates and bad paths are refused") {
  TempDir dir("outputs");
  const std::string scene = dir / "scene.json";
  fs::copy_file(std::string(PT_SCENES_DIR) + "/cornell.json", scene);
  const std::string original = slurp(scene);
  Run r = run("render -q --scene " + scene + " --spp 1 --width 8 --height 8 --pfm " + scene);
  CHECK(r.status == 2);
  CHECK(r.err.find("is the scene being rendered") != std::string::npos);
  CHECK(slurp(scene) == original);
  r = run("render -q --spp 1 --width 8 --height 8 --png " + (dir / "x") + " --pfm " + (dir / "x"));
  CHECK(r.status == 2);
  CHECK(r.err.find("--png and --pfm both name") != std::string::npos);
  // A missing directory is found at once (before a 1e6-spp render, which would take minutes).
  put(dir / "good.pfm", "earlier");
  const auto t0 = std::chrono::steady_clock::now();
  r = run("render -q --spp 1000000 --png " + (dir / "no/such/dir/x.png") + " --pfm " + (dir / "good.pfm"));
  CHECK(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() < 5.0);
  CHECK(r.status == 2);
  CHECK(r.err.find("--png " + (dir / "no/such/dir/x.png") + ": directory " + (dir / "no/such/dir") +
                   " is not usable (No such file or directory)") != std::string::npos);
  CHECK(slurp(dir / "good.pfm") == "earlier");
}

TEST_CASE("cli: a write that fails at the end (file size limit) is reported, the other output is written") {
  TempDir dir("fsize");
  put(dir / "old.pfm", "the earlier render");
  // ulimit -f 8: files of at most 4 KiB. The 32×32 PFM (12 KiB) fails with EFBIG; the PNG (< 4 KiB) is written.
  const Run r = run_script("ulimit -f 8; exec \"$PT\" render -q --spp 2 --width 32 --height 32 --png " +
                           (dir / "new.png") + " --pfm " + (dir / "old.pfm"));
  CHECK(r.status == 1);
  CHECK(r.err.find("error: --pfm: " + (dir / "old.pfm") + ": cannot write (File too large)") != std::string::npos);
  CHECK(slurp(dir / "old.pfm") == "the earlier render");
  CHECK(fs::file_size(dir / "new.png") > 0);
  CHECK(dir.names() == std::vector<std::string>{"new.png", "old.pfm"});  // no temporary file left
}

TEST_CASE("cli: outputs of stress are checked before the run and written safely") {
  // The CSV path was opened with ofstream: a bad directory was found only by the open, and a failed write could
  // leave a truncated file. Now it is checked before any scenario runs and written through write_file_safely.
  TempDir dir("stress-csv");
  const auto t0 = std::chrono::steady_clock::now();
  const Run bad = run("stress --quick --csv " + (dir / "no/such/dir/x.csv"));
  CHECK(bad.status == 2);
  CHECK(bad.err.find("error: --csv: " + (dir / "no/such/dir/x.csv") + ": directory " + (dir / "no/such/dir") +
                     " is not usable") != std::string::npos);
  CHECK(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() < 2.0);  // before the run
  put(dir / "old.csv", "earlier");
  const Run full = run_script("ulimit -f 1; exec \"$PT\" stress --quick --only \"furnace: emitting\" --csv " +
                              (dir / "old.csv"));
  CHECK(full.status == 2);
  CHECK(full.err.find("cannot write (File too large)") != std::string::npos);
  CHECK(slurp(dir / "old.csv") == "earlier");
  CHECK(dir.names() == std::vector<std::string>{"old.csv"});
}

TEST_CASE("cli: a film larger than the memory budget is refused before rendering, with the figures") {
  // A 16384² render aborted in the allocator (bad_alloc after minutes of setup); under a 4 GB address-space
  // limit it is now refused at once with the estimate and the limit, and nothing is written.
  TempDir dir("film-memory");
  const Run r = run_script("ulimit -v 4000000; exec \"$PT\" render -q --width 16384 --height 16384 --spp 1 --pfm " +
                           (dir / "big.pfm"));
  CHECK(r.status == 2);
  CHECK(r.err.find("error: a 16384x16384 render needs about 27.5 GiB (110 bytes per pixel); this machine allows 2.9 GiB") !=
        std::string::npos);
  CHECK(dir.names().empty());
}

TEST_CASE("cli: running out of memory while loading a mesh exits with status 3 and writes nothing") {
  // README: "3 out of memory". A 200,000-triangle OBJ under a 100 MB address-space limit: the loader's
  // bad_alloc used to be caught as a broken file (exit 2, "error: std::bad_alloc"), and at 150 MB the BVH
  // build's helper thread failed to start (exit 1, "Resource temporarily unavailable"); now the allocation
  // failure is reported as such, and a thread that cannot start leaves its subtree to the caller.
  TempDir dir("oom");
  {
    std::ofstream obj(dir / "many.obj");
    for (int i = 0; i < 200000; ++i) {
      const double x = i * 0.001;
      obj << "v " << x << " 0 0\nv " << x << " 1 0\nv " << x + 0.0005 << " 0 1\n";
    }
    for (int i = 0; i < 200000; ++i) obj << "f " << 3 * i + 1 << ' ' << 3 * i + 2 << ' ' << 3 * i + 3 << '\n';
  }
  for (const char* limit : {"100000", "150000"}) {
    const Run r = run_script(std::string("ulimit -v ") + limit + "; exec \"$PT\" render -q --threads 2 --width 32 "
                             "--height 32 --spp 1 --scene " + (dir / "many.obj") + " --pfm " + (dir / "out.pfm"));
    INFO("ulimit -v " << limit << ": " << r.err);
    CHECK(r.status == 3);
    CHECK(r.err.find("error: out of memory") != std::string::npos);
    CHECK_FALSE(std::filesystem::exists(dir / "out.pfm"));
  }
  // With room enough the same file renders.
  const Run ok = run_script("ulimit -v 400000; exec \"$PT\" render -q --threads 2 --width 32 --height 32 --spp 1 "
                            "--scene " + (dir / "many.obj") + " --pfm " + (dir / "out.pfm"));
  INFO(ok.err);
  CHECK(ok.status == 0);
}

TEST_CASE("cli: compare checks PFM headers against the file size and the memory budget before allocating") {
  // A bogus header asked for 51 GB and aborted in the allocator.
  TempDir dir("compare-header");
  put(dir / "bogus.pfm", std::string("PF\n60000 60000\n-1\n") + std::string(64, '\0'));
  put(dir / "ok.pfm", std::string("PF\n1 1\n-1\n") + std::string(12, '\0'));
  Run r = run("compare " + (dir / "bogus.pfm") + " " + (dir / "ok.pfm"));
  CHECK(r.status == 2);
  CHECK(r.err.find("error: " + (dir / "bogus.pfm") + ": truncated PFM data") != std::string::npos);
  // A consistent header whose image the machine cannot hold: a sparse 16384² grey PFM (1 GiB of data, 4 GiB
  // once read and expanded to RGB) under a 2 GB address-space limit is refused with the figures.
  {
    std::ofstream big(dir / "big.pfm", std::ios::binary);
    big << "Pf\n16384 16384\n-1\n";
  }
  fs::resize_file(dir / "big.pfm", fs::file_size(dir / "big.pfm") + 16384ull * 16384 * 4);
  r = run_script("ulimit -v 2000000; exec \"$PT\" compare " + (dir / "big.pfm") + " " + (dir / "ok.pfm"));
  INFO(r.err);
  CHECK(r.status == 2);
  CHECK(r.err.find("error: " + (dir / "big.pfm") + ": reading this 16384x16384 image needs about 4.0 GiB; this "
                   "machine allows 1.4 GiB") != std::string::npos);
}

TEST_CASE("cli: SIGINT stops a render and writes the image so far, a second signal exits at once") {
  TempDir dir("signal");
  Run r = run_script("\"$PT\" render --spp 100000000 --width 64 --height 64 --pfm " + (dir / "a.pfm") +
                     " & pid=$!; sleep 1.5; kill -INT $pid; wait $pid");
  CHECK(r.status == 0);
  CHECK(r.err.find("interrupted by SIGINT: stopping, writing the image from the samples so far") != std::string::npos);
  REQUIRE(fs::exists(dir / "a.pfm"));
  CHECK(read_pfm(dir / "a.pfm").width == 64);
  // After the first signal a render busy writing (here blocked on a FIFO whose reader never reads: 192 KiB do
  // not fit its 64 KiB buffer) is left alone; the second signal ends it at once.
  r = run_script("cd " + dir.path.string() + " && mkfifo f; sleep 20 < f & reader=$!; \"$PT\" render -q --spp 1 "
                 "--width 128 --height 128 --pfm f & pid=$!; sleep 1.5; kill -TERM $pid; sleep 0.5; "
                 "kill -TERM $pid; wait $pid; st=$?; kill $reader; exit $st");
  CHECK(r.status == 128 + 15);
  CHECK(r.err.find("interrupted again: exiting without writing") != std::string::npos);
}

TEST_CASE("cli: --time holds within 0.1 s even where a single path never ends") {
  TempDir dir("deadline");
  put(dir / "room.json", closed_white_room_json());
  // Without the in-pass deadline this never returns (wall < 3 s catches that at once). The 0.1 s is a timing
  // claim that a machine loaded by other work can miss once by chance: up to three runs, the claim must hold in
  // one of them (a render that overruns by design overruns every time).
  Run r;
  double reported = 0.0;
  for (int attempt = 0; attempt < 3; ++attempt) {
    const auto t0 = std::chrono::steady_clock::now();
    r = run("render --scene " + (dir / "room.json") + " --time 1 --pfm " + (dir / "room.pfm"));
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    INFO(r.out << r.err);
    CHECK(wall < 3.0);  // start-up included
    // The summary line reports the render time: "... N spp in S s, ...".
    std::smatch m;
    const std::string out = r.out;
    REQUIRE(std::regex_search(out, m, std::regex(R"( in ([0-9.]+) s,)")));
    reported = std::stod(m[1]);
    CHECK(reported >= 1.0);
    if (reported < 1.1) break;
    MESSAGE("attempt " << attempt + 1 << ": " << reported << " s");
  }
  CHECK(reported < 1.1);
  // No path of this room ever ends, so no whole sample exists: said plainly, nothing written, status 1.
  CHECK(r.status == 1);
  CHECK(r.err.find("error: no sample was rendered; nothing written") != std::string::npos);
  CHECK(!fs::exists(dir / "room.pfm"));
}

TEST_CASE("hostile scene input: nesting, long strings, NUL bytes, special files and escapes get clear errors") {
  auto error_of = [](const std::string& text) {
    try {
      parse_scene(text, "t.json");
    } catch (const SceneError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  // Found by fuzz_scene: text ending inside a UTF-8 sequence made the reader step past the end of the buffer
  // (a heap over-read that ASan reports; the CI's sanitizer stage runs this case).
  for (const char* tail : {"\xf0", "\xe2\x82", "\xc3"}) {
    const std::string text = std::string("{\n  \"camera\": {\"posi5, ") + tail;
    CHECK(error_of(text) == "t.json: line 2, column 22: syntax error: invalid UTF-8 in a string");
  }
  // 200,000 nested arrays: refused at the limit, no stack overflow.
  const std::string deep = "{\"camera\": " + std::string(200000, '[') + std::string(200000, ']') + "}";
  const std::string deep_error = error_of(deep);
  CHECK(deep_error.rfind("t.json: camera", 0) == 0);
  CHECK(deep_error.find(": nested deeper than 64 levels") != std::string::npos);
  // A huge string is refused with its size, not echoed.
  const std::string huge = "{\"materials\": {\"" + std::string(1 << 20, 'x') + "\": {}}}";
  const std::string huge_error = error_of(huge);
  CHECK(huge_error.size() < 300);
  CHECK(huge_error.find("key of 1048576 bytes (the limit is 4096)") != std::string::npos);
  // A NUL byte does not silently end the scene.
  CHECK(error_of(std::string("{\n\"camera\": {}\n}\0{}", 19)) == "t.json: line 3: a NUL byte (this is not a JSON text file)");
  // Terminal escapes in a name are escaped in the message, and long names are cut.
  std::string esc = slurp(std::string(PT_SCENES_DIR) + "/cornell.json");
  const size_t type_at = esc.find("\"diffuse\"");
  REQUIRE(type_at != std::string::npos);
  esc.replace(type_at, 9, "\"\\u001b[31mred" + std::string(200, 'y') + "\"");
  const std::string esc_error = error_of(esc);
  CHECK(esc_error.find('\x1b') == std::string::npos);
  CHECK(esc_error.find("\\x1b[31mred") != std::string::npos);
  CHECK(esc_error.find("... (208 bytes)") != std::string::npos);
  // Special files: refused before they are read.
  CHECK_THROWS_WITH_AS(load_scene_file("/dev/zero"),
                       "/dev/zero: not a regular file (a device, FIFO or socket; use - to read standard input)", SceneError);
  TempDir dir("hostile");
  REQUIRE(::mkfifo((dir / "fifo.json").c_str(), 0600) == 0);
  CHECK_THROWS_AS(load_scene_file(dir / "fifo.json"), SceneError);
}

TEST_CASE("scene loading is linear: 100,000 materials and 1,000,000 shapes load in seconds") {
  // Quadratic loading took 18 s for 100,000 materials and 17 s for 300,000 shapes; 10^6 shapes now load in
  // about 1.5 s on a shared 2-core machine (docs/reliability.md). The bound is not a benchmark: it leaves a
  // wide margin for a slow or busy machine and still fails anything quadratic (which would take hours here).
  std::string text = R"({"camera": {"position": [0, 0, 0], "look_at": [0, 0, 1], "fov_deg": 60}, "film": {"width": 8, "height": 8},)";
  text += "\"materials\": {";
  constexpr int materials = 100000, shapes = 1000000;
  for (int i = 0; i < materials; ++i)
    text += (i ? ",\"m" : "\"m") + std::to_string(i) + "\": {\"type\": \"diffuse\", \"albedo\": [0.5, 0.5, 0.5]}";
  text += "}, \"shapes\": [";
  for (int i = 0; i < shapes; ++i)
    text += std::string(i ? "," : "") + "{\"type\": \"triangle\", \"vertices\": [[" + std::to_string(i % 100) +
            ", 0, 5], [1, 1, 5], [0, 1, 5.5]], \"material\": \"m" + std::to_string(i % materials) + "\"}";
  text += "]}";
  const auto t0 = std::chrono::steady_clock::now();
  const SceneDesc desc = parse_scene(text, "big.json");
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  MESSAGE("parsed " << materials << " materials and " << shapes << " shapes (" << text.size() / 1000000 << " MB) in "
                    << seconds << " s");
  CHECK(desc.materials.size() == materials);
  REQUIRE(desc.shapes.size() == shapes);
  CHECK(desc.shapes[shapes - 1].material == (shapes - 1) % materials);
  CHECK(desc.shapes[shapes - 1].vertices[0] == DVec3((shapes - 1) % 100, 0, 5));
  CHECK(desc.shapes[shapes - 1].vertices[2] == DVec3(0, 1, 5.5));
  CHECK(seconds < 30.0);
}

TEST_CASE("representable ranges: the image holds across scales up to the limits, beyond them the value is named") {
  // The same paths (same seed) through the Cornell box scaled by 1e-9 and by 5e8 (farthest point 7e11 from the
  // camera) give the image at scale 1 to float rounding. Before the limits, scale 1e10 rendered a darker image
  // and 1e11 a black one with exit 0 (overflow in the watertight test); now such scenes are refused.
  const SceneDesc base = builtin_at("cornell", 12, 12);
  const Film ref = test::render_film(base, 16, 1);
  for (double scale : {1e-9, 5e8}) {
    const SceneDesc s = transformed(base, scale, DVec3(0.0));
    REQUIRE(validate_scene(s) == "");
    const Film f = test::render_film(s, 16, 1);
    double worst = 0.0;
    for (size_t i = 0; i < f.pixel_count(); ++i)
      for (int c = 0; c < 3; ++c) {
        const double a = ref.mean_channel(i, c), b = f.mean_channel(i, c);
        worst = std::max(worst, std::abs(a - b) / std::max(std::abs(a), 1e-3));
      }
    INFO("scale " << scale << ": worst relative pixel difference " << worst);
    CHECK(f.rejected() == 0);
    CHECK(worst < 1e-3);
  }
  auto refusal = [](const SceneDesc& s) { return validate_scene(s); };
  CHECK(refusal(transformed(base, 1e10, DVec3(0.0))).find("from the camera, beyond the 1e+12") != std::string::npos);
  CHECK(refusal(transformed(base, 1e-14, DVec3(0.0))).find("shapes: the whole scene lies within 1.41e-11") == 0);
  // Far from the origin is fine when the camera is there too (geometry is camera-relative; at 1e9 doubles still
  // resolve the box to 1e-7)...
  CHECK(refusal(transformed(base, 1.0, DVec3(1e9, -1e9, 1e9))) == "");
  // ...but a triangle at 1e200 seen from near the origin is refused for its distance, not called "degenerate".
  SceneDesc far = base;
  for (DVec3& v : far.shapes[0].vertices) v *= 1e200;
  CHECK(refusal(far).rfind("shapes[0].vertices[0]: ", 0) == 0);
  CHECK(refusal(far).find("e+202 from the camera, beyond the 1e+12") != std::string::npos);
  SceneDesc huge_sphere = builtin_at("cornell-spheres", 8, 8);
  for (ShapeDesc& sh : huge_sphere.shapes)
    if (sh.type == ShapeType::Sphere) sh.radius = 1e15;
  CHECK(refusal(huge_sphere).find(".radius: the sphere reaches 1e+15 from the camera") != std::string::npos);
  SceneDesc bright = base;
  bright.environment.radiance = Rgb(3.4e38f, 0.f, 0.f);
  CHECK(refusal(bright) == "environment.radiance: component 3.4e+38 is above the largest radiance the tracer "
                           "represents, 1e+30");
  bright.environment.radiance = Rgb(kMaxRadiance);
  CHECK(refusal(bright) == "");
  // The scene file reader says the same, with the file and the key the file used.
  std::string text(builtin_scene_json("cornell").value());
  const std::string black = "\"background\": [0, 0, 0]";
  text.replace(text.find(black), black.size(), "\"background\": [1e31, 0, 0]");
  try {
    parse_scene(text, "bright.json");
    FAIL("a background of 1e31 was accepted");
  } catch (const SceneError& e) {
    CHECK(std::string(e.what()).rfind("bright.json: background: component 1e+31 is above", 0) == 0);
  }
}
