// Scale-out (docs/scale-out.md): films rendered in pieces and merged, or saved and resumed, have the bits of one
// straight render; state files are exact, and refused when truncated, corrupted or of another scene.
#include <doctest/doctest.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <unistd.h>

#include "skip.h"
#include "io/film_state.h"
#include "scene/scene_identity.h"
#include "render/renderer.h"
#include "run_command.h"
#include "scene/scene.h"
#include "scene/scene_json.h"
#include "test_helpers.h"

using namespace pt;
using pt::test::Run;

namespace {

SceneDesc small(const char* name, int size = 48) {
  SceneDesc d = load_scene(name);
  d.width = d.height = size;
  d.render.seed = 7;
  return d;
}

// Samples [first, first + spp) of every pixel, in one pass.
Film render_range(const SceneDesc& desc, uint32_t first, int spp, bool features = false) {
  const auto scene = compile_scene(desc);
  Film film;
  film.enable_features(features);
  film.reset(desc.width, desc.height);
  film.start_at(first);
  Renderer renderer(2);
  renderer.render_pass(*scene, desc.render, film, spp);
  return film;
}

size_t mean_bits_differing(const Film& a, const Film& b) {
  const std::vector<float> x = a.mean_image(), y = b.mean_image();
  size_t n = 0;
  for (size_t i = 0; i < x.size(); ++i) n += std::memcmp(&x[i], &y[i], sizeof(float)) != 0;
  for (size_t i = 0; i < a.pixel_count(); ++i)
    for (int c = 0; c < 3; ++c) n += a.mean_channel(i, c) != b.mean_channel(i, c);  // the doubles too
  return n;
}

std::string bytes_of(const std::string& path) { return pt::test::slurp(path); }

struct TempDir {
  std::filesystem::path path;
  explicit TempDir(const std::string& name) : path("scale_out_" + name + "_" + std::to_string(getpid())) {
    std::filesystem::remove_all(path);
    std::filesystem::create_directories(path);
  }
  ~TempDir() { std::filesystem::remove_all(path); }
  std::string operator/(const std::string& f) const { return (path / f).string(); }
};

}  // namespace

TEST_CASE("scale-out: films of disjoint sample ranges merged in any order have the straight film's mean bits") {
  for (const char* name : {"cornell", "cornell-spheres"}) {
    CAPTURE(name);
    const SceneDesc d = small(name);
    const Film straight = render_range(d, 0, 24);
    std::vector<Film> parts;
    for (const auto& [first, spp] : {std::pair{0u, 5}, {5u, 8}, {13u, 3}, {16u, 8}})  // [0,5) [5,13) [13,16) [16,24)
      parts.push_back(render_range(d, first, spp));
    // Sequential order, reversed, and a tree.
    Film forward(d.width, d.height), backward(d.width, d.height), left(d.width, d.height), right(d.width, d.height);
    for (const Film& p : parts) forward.merge(p);
    for (auto it = parts.rbegin(); it != parts.rend(); ++it) backward.merge(*it);
    left.merge(parts[0]);
    left.merge(parts[1]);
    right.merge(parts[3]);
    right.merge(parts[2]);
    left.merge(right);
    CHECK(forward.min_count() == 24);
    CHECK(mean_bits_differing(forward, straight) == 0);
    CHECK(mean_bits_differing(backward, straight) == 0);
    CHECK(mean_bits_differing(left, straight) == 0);
    CHECK(forward.next_sample_index(0) == 24);
    // The second moments agree to rounding (Chan's combination is not the sequential update bit for bit).
    for (size_t i = 0; i < straight.pixel_count(); i += 97)
      CHECK(forward.variance_of_mean(i).x == doctest::Approx(straight.variance_of_mean(i).x).epsilon(1e-9));
    CHECK(forward.estimated_relmse() == doctest::Approx(straight.estimated_relmse()).epsilon(1e-9));
  }
}

TEST_CASE("scale-out: a film resumed from its saved state continues bit for bit, features included") {
  TempDir dir("resume");
  const SceneDesc d = small("cornell-spheres");
  const auto scene = compile_scene(d);
  Renderer renderer(2);
  Film straight, piecewise;
  for (Film* f : {&straight, &piecewise}) {
    f->enable_features(true);
    f->reset(d.width, d.height);
  }
  renderer.render_pass(*scene, d.render, straight, 12);
  renderer.render_pass(*scene, d.render, piecewise, 5);
  FilmStateInfo info = state_info_for(d, "cornell-spheres");
  info.render_seconds = 1.5;
  write_film_state(dir / "a.ptstate", piecewise, info);
  LoadedFilmState loaded = read_film_state(dir / "a.ptstate");
  CHECK(loaded.info.scene_hash == info.scene_hash);
  CHECK(loaded.info.seed == 7);
  CHECK(loaded.info.render_seconds == 1.5);
  CHECK(loaded.info.scene_name == "cornell-spheres");
  CHECK(resume_problem(loaded.info, d).empty());
  CHECK(mean_bits_differing(loaded.film, piecewise) == 0);
  renderer.render_pass(*scene, d.render, loaded.film, 7);
  CHECK(mean_bits_differing(loaded.film, straight) == 0);
  CHECK(loaded.film.albedo_image() == straight.albedo_image());
  CHECK(loaded.film.half_image(1) == straight.half_image(1));
  CHECK(loaded.film.variance_image() == straight.variance_image());  // same sequence of updates: same bits
}

TEST_CASE("scale-out: state files that are truncated, corrupted, padded, of another version or another scene are refused") {
  TempDir dir("corrupt");
  const SceneDesc d = small("cornell", 16);
  const Film film = render_range(d, 0, 3);
  write_film_state(dir / "good.ptstate", film, state_info_for(d, "cornell"));
  const std::string good = bytes_of(dir / "good.ptstate");
  REQUIRE(good.size() > 1000);
  auto refused = [&](const std::string& bytes, const std::string& reason) {
    { std::ofstream(dir / "bad.ptstate", std::ios::binary) << bytes; }
    try {
      read_film_state(dir / "bad.ptstate");
      FAIL("accepted a bad state (" << reason << ")");
    } catch (const FilmStateError& e) {
      INFO(e.what());
      CHECK(std::string(e.what()).find(reason) != std::string::npos);
    }
  };
  refused(good.substr(0, good.size() / 2), "truncated");
  refused(good.substr(0, 20), "truncated");
  refused(good + "x", "more than its header says");
  std::string flipped = good;
  flipped[good.size() / 2] ^= 0x10;
  refused(flipped, "checksum");
  std::string version = good;
  version[8] = 3;
  refused(version, "version 3");
  version[8] = 1;  // the scene hash of version 1 was another function
  refused(version, "version 1");
  refused("P3\n16 16\n255\n", "not a pathtracer state file");
  refused("", "not a pathtracer state file");

  // A state of another scene, another seed or other settings cannot be resumed; a merged multi-seed one neither.
  const FilmStateInfo info = read_film_state(dir / "good.ptstate").info;
  SceneDesc other = d;
  other.render.seed = 8;
  CHECK(resume_problem(info, other).find("seed 7") != std::string::npos);
  other = d;
  other.render.max_bounces += 1;
  CHECK(resume_problem(info, other).find("max bounces") != std::string::npos);
  other = d;
  other.materials[0].albedo = other.materials[0].albedo * 0.5f;
  CHECK(resume_problem(info, other).find("another scene") != std::string::npos);
  FilmStateInfo mixed = info;
  mixed.mixed_seeds = true;
  CHECK(resume_problem(mixed, d).find("different seeds") != std::string::npos);
}

TEST_CASE("scale-out: the scene hash sees every field a shape uses, survives the JSON round trip and ignores the seed") {
  const SceneDesc d = small("cornell-spheres");
  const uint64_t h = scene_content_hash(d);
  const auto differs = [&](const char* what, const auto& edit) {
    SceneDesc e = d;
    edit(e);
    INFO(what);
    CHECK(scene_content_hash(e) != h);
  };
  size_t quad = 0, sphere = 0;
  while (d.shapes[quad].type != ShapeType::Quad) ++quad;
  while (d.shapes[sphere].type != ShapeType::Sphere) ++sphere;
  const auto ulp = [](double x) { return std::nextafter(x, 1e300); };
  differs("a quad's 4th vertex, one ulp", [&](SceneDesc& e) { e.shapes[quad].vertices[3].z = ulp(e.shapes[quad].vertices[3].z); });
  differs("a quad's 1st vertex, one ulp", [&](SceneDesc& e) { e.shapes[quad].vertices[0].x = ulp(e.shapes[quad].vertices[0].x); });
  differs("a sphere's radius, one ulp", [&](SceneDesc& e) { e.shapes[sphere].radius = ulp(e.shapes[sphere].radius); });
  differs("a sphere's centre, one ulp", [&](SceneDesc& e) { e.shapes[sphere].center.y = ulp(e.shapes[sphere].center.y); });
  differs("a shape's material", [&](SceneDesc& e) { e.shapes[quad].material = (e.shapes[quad].material + 1) % static_cast<int>(e.materials.size()); });
  differs("a quad made a triangle", [&](SceneDesc& e) { e.shapes[quad].type = ShapeType::Triangle; });
  differs("two shapes swapped", [&](SceneDesc& e) { std::swap(e.shapes[quad], e.shapes[sphere]); });
  differs("a shape removed", [&](SceneDesc& e) { e.shapes.pop_back(); });
  differs("a material's albedo", [&](SceneDesc& e) { e.materials[0].albedo.x *= 0.5f; });
  differs("the bounces", [&](SceneDesc& e) { e.render.max_bounces += 1; });
  // Fields a shape's type does not use are not written to JSON, so they do not enter the hash either.
  SceneDesc same = d;
  same.render.seed = 12345;
  same.shapes[sphere].vertices[0] = DVec3(1, 2, 3);
  same.shapes[quad].radius = 9;
  CHECK(scene_content_hash(same) == h);
  CHECK(scene_content_hash(parse_scene(scene_to_json(d), "round trip")) == h);
}

TEST_CASE("scale-out: merging refuses overlapping sample ranges of one seed and other scenes, and marks several seeds") {
  const SceneDesc d = small("cornell", 16);
  std::vector<LoadedFilmState> states(2);
  states[0].film = render_range(d, 0, 4);
  states[0].info = state_info_for(d, "cornell");
  states[1].film = render_range(d, 3, 4);  // indices 3..6 overlap 0..3
  states[1].info = state_info_for(d, "cornell");
  states[1].info.sample_begin = 3;
  CHECK_THROWS_WITH_AS(merge_film_states(states, {"a", "b"}), doctest::Contains("both hold sample indices 3 to 3"),
                       FilmStateError);
  SceneDesc seeded = d;
  seeded.render.seed = 99;
  states[1].film = render_range(seeded, 0, 4);
  states[1].info = state_info_for(seeded, "cornell");
  const LoadedFilmState m = merge_film_states(states, {"a", "b"});
  CHECK(m.info.mixed_seeds);
  CHECK(m.film.min_count() == 8);
  SceneDesc other = d;
  other.render.max_bounces += 1;
  states[1].info = state_info_for(other, "cornell");
  CHECK_THROWS_WITH_AS(merge_film_states(states, {"a", "b"}), doctest::Contains("different scenes"), FilmStateError);
}

TEST_CASE("scale-out cli: stopped at 32 spp and resumed to 64, or two 32-spp halves merged, gives the straight render's PFM bytes") {
  TempDir dir("cli");
  const std::string common = "-q --scene cornell --seed 1 --width 96 --height 96 --threads 2 ";
  auto render = [&](const std::string& args) {
    const Run r = pt::test::run_pathtracer("", "render " + common + args);
    INFO(r.out << r.err);
    REQUIRE(r.status == 0);
  };
  render("--spp 64 --pfm " + dir / "straight.pfm");
  render("--spp 32 --pfm " + dir / "a.pfm --save-state " + dir / "a.ptstate");
  render("--spp 64 --resume " + dir / "a.ptstate --pfm " + dir / "resumed.pfm --save-state " + dir / "b.ptstate");
  const std::string straight = bytes_of(dir / "straight.pfm");
  REQUIRE(straight.size() > 96u * 96u * 12u);
  CHECK(bytes_of(dir / "resumed.pfm") == straight);
  CHECK(bytes_of(dir / "a.pfm") != straight);  // the test can tell them apart

  render("--sample-range 0:32 --save-state " + dir / "h0.ptstate --pfm " + dir / "h0.pfm");
  render("--sample-range 32:64 --save-state " + dir / "h1.ptstate --pfm " + dir / "h1.pfm");
  const Run m = pt::test::run_pathtracer("", "merge " + dir / "h1.ptstate " + dir / "h0.ptstate --pfm " +
                                                 dir / "merged.pfm --save-state " + dir / "merged.ptstate");
  INFO(m.out << m.err);
  REQUIRE(m.status == 0);
  CHECK(m.out.find("merged 2 states of cornell: 96x96, 64 to 64 spp") != std::string::npos);
  CHECK(bytes_of(dir / "merged.pfm") == straight);
  // The merged state continues like the straight one: resumed to 80 spp, the same bytes as a straight 80.
  render("--spp 80 --pfm " + dir / "straight80.pfm");
  render("--spp 80 --resume " + dir / "merged.ptstate --pfm " + dir / "merged80.pfm");
  CHECK(bytes_of(dir / "merged80.pfm") == bytes_of(dir / "straight80.pfm"));
}

TEST_CASE("scale-out cli: bad resume and merge requests exit 2 with the reason, before any work") {
  TempDir dir("cli_bad");
  const std::string common = "-q --scene cornell --seed 1 --width 32 --height 32 --threads 2 ";
  REQUIRE(pt::test::run_pathtracer("", "render " + common + "--spp 4 --save-state " + dir / "s.ptstate --pfm " + dir / "s.pfm").status == 0);
  const Run seed = pt::test::run_pathtracer("", "render -q --scene cornell --seed 2 --width 32 --height 32 --spp 8 --resume " + dir / "s.ptstate --pfm " + dir / "x.pfm");
  CHECK(seed.status == 2);
  CHECK(seed.err.find("seed 1, not 2") != std::string::npos);
  const Run size = pt::test::run_pathtracer("", "render -q --scene cornell --seed 1 --width 40 --height 32 --spp 8 --resume " + dir / "s.ptstate --pfm " + dir / "x.pfm");
  CHECK(size.status == 2);
  CHECK(size.err.find("another scene or other settings") != std::string::npos);
  std::string bytes = bytes_of(dir / "s.ptstate");
  bytes.resize(bytes.size() - 100);
  { std::ofstream(dir / "cut.ptstate", std::ios::binary) << bytes; }
  const Run cut = pt::test::run_pathtracer("", "render " + common + "--spp 8 --resume " + dir / "cut.ptstate --pfm " + dir / "x.pfm");
  CHECK(cut.status == 2);
  CHECK(cut.err.find("truncated") != std::string::npos);
  CHECK_FALSE(std::filesystem::exists(dir / "x.pfm"));
  const Run range = pt::test::run_pathtracer("", "render " + common + "--sample-range 8:4 --pfm " + dir / "x.pfm");
  CHECK(range.status == 2);
  CHECK(range.err.find("expected A:B") != std::string::npos);
  const Run both = pt::test::run_pathtracer("", "render " + common + "--sample-range 0:4 --spp 4 --pfm " + dir / "x.pfm");
  CHECK(both.status == 2);
  const Run twice = pt::test::run_pathtracer("", "merge " + dir / "s.ptstate " + dir / "s.ptstate --pfm " + dir / "x.pfm");
  CHECK(twice.status == 2);
  CHECK(twice.err.find("both hold sample indices 0 to 3") != std::string::npos);
  const Run over = pt::test::run_pathtracer("", "merge " + dir / "s.ptstate --save-state " + dir / "s.ptstate");
  CHECK(over.status == 2);
  CHECK(over.err.find("refusing to overwrite") != std::string::npos);
  CHECK_FALSE(std::filesystem::exists(dir / "x.pfm"));
}

namespace {

bool have_mpirun() { return std::system("command -v mpirun > /dev/null 2>&1") == 0; }
// The MPI tests' guard: true (with a message) where mpirun is missing and the test should return.
bool skip_without_mpirun() {
  if (have_mpirun()) return false;
  pt::test::skip_for_missing("mpirun", "the MPI test");
  return true;
}

// mpirun as CI runs it: as root when it is root, more ranks than cores allowed.
std::string mpirun(int ranks) {
  return "timeout 120 mpirun " + std::string(geteuid() == 0 ? "--allow-run-as-root " : "") + "--oversubscribe -np " +
         std::to_string(ranks);
}

}  // namespace

TEST_CASE("scale-out mpi: 2, 3 and 4 ranks write the single process's PFM bytes") {
  if (skip_without_mpirun()) return;
  TempDir dir("mpi");
  const std::string common = "render -q --scene cornell --seed 1 --width 64 --height 64 --spp 24 ";
  const Run one = pt::test::run_pathtracer("", common + "--threads 2 --pfm " + dir / "one.pfm --save-state " + dir / "one.ptstate");
  REQUIRE(one.status == 0);
  for (int n : {2, 3, 4}) {
    CAPTURE(n);
    const std::string pfm = dir / ("mpi" + std::to_string(n) + ".pfm");
    const Run r = pt::test::run_pathtracer(mpirun(n), common + "--threads 1 --mpi --pfm " + pfm + " --save-state " +
                                                          dir / ("mpi" + std::to_string(n) + ".ptstate"));
    INFO(r.out << r.err);
    REQUIRE(r.status == 0);
    CHECK(r.out.find("mpi: " + std::to_string(n) + " ranks") != std::string::npos);
    CHECK(bytes_of(pfm) == bytes_of(dir / "one.pfm"));
    // The merged state continues like the single process's (resumed to 32 spp, same bytes).
    const Run a = pt::test::run_pathtracer("", "render -q --scene cornell --seed 1 --width 64 --height 64 --spp 32 --resume " +
                                                   dir / ("mpi" + std::to_string(n) + ".ptstate") + " --pfm " + dir / "a.pfm");
    const Run b = pt::test::run_pathtracer("", "render -q --scene cornell --seed 1 --width 64 --height 64 --spp 32 --resume " +
                                                   dir / "one.ptstate --pfm " + dir / "b.pfm");
    REQUIRE(a.status == 0);
    REQUIRE(b.status == 0);
    CHECK(bytes_of(dir / "a.pfm") == bytes_of(dir / "b.pfm"));
  }
}

TEST_CASE("scale-out mpi: a state resumed by 2 ranks gives the single process's bytes, a mismatched one is refused by all") {
  if (skip_without_mpirun()) return;
  TempDir dir("mpi_resume");
  const std::string common = "render -q --scene cornell --seed 1 --width 48 --height 48 ";
  REQUIRE(pt::test::run_pathtracer("", common + "--spp 20 --threads 2 --pfm " + dir / "straight.pfm").status == 0);
  REQUIRE(pt::test::run_pathtracer("", common + "--spp 8 --threads 2 --save-state " + dir / "s8.ptstate --pfm " + dir / "s8.pfm").status == 0);
  const Run r = pt::test::run_pathtracer(mpirun(2), common + "--spp 20 --threads 1 --mpi --resume " + dir / "s8.ptstate --pfm " +
                                                         dir / "resumed.pfm");
  INFO(r.out << r.err);
  REQUIRE(r.status == 0);
  CHECK(bytes_of(dir / "resumed.pfm") == bytes_of(dir / "straight.pfm"));
  const Run bad = pt::test::run_pathtracer(mpirun(2), "render -q --scene cornell --seed 2 --width 48 --height 48 --spp 20 "
                                                           "--threads 1 --mpi --resume " + dir / "s8.ptstate --pfm " + dir / "bad.pfm");
  CHECK(bad.status != 0);
  CHECK(bad.err.find("seed 1, not 2") != std::string::npos);
  CHECK_FALSE(std::filesystem::exists(dir / "bad.pfm"));
}

TEST_CASE("scale-out mpi: a rank that dies ends the job with an error, no hang, and the last checkpoint stays readable") {
  if (skip_without_mpirun()) return;
  TempDir dir("mpi_death");
  // Two ranks render for up to 60 s with a checkpoint every 0.5 s; once the first checkpoint is on disk (polled,
  // not a fixed delay that a loaded machine could outrun), one rank is killed.
  const std::string script = mpirun(2) + " \"$0\" \"$@\" & job=$!; for i in $(seq 300); do [ -s " + dir / "ck.ptstate" +
                             " ] && break; sleep 0.1; done; pkill -KILL -n -f \"render --mpi -q --scene cornell --seed 3\"; "
                             "wait $job";
  const auto start = std::chrono::steady_clock::now();
  const Run r = pt::test::run_pathtracer(
      "sh -c '" + script + "'",
      "render --mpi -q --scene cornell --seed 3 --width 48 --height 48 --time 60 --threads 1 --checkpoint 0.5 --save-state " +
          dir / "ck.ptstate --pfm " + dir / "ck.pfm");
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  INFO(r.out << r.err);
  CHECK(r.status != 0);
  CHECK(seconds < 40.0);  // not the 60 s of the render, nor a hang
  const LoadedFilmState ck = read_film_state(dir / "ck.ptstate");  // written whole, checksum good
  CHECK(ck.film.min_count() > 0);
  CHECK(ck.film.width() == 48);
}

TEST_CASE("scale-out cli: Ctrl-C writes the state with the images, and the state resumes") {
  TempDir dir("sigint");
  // A render of 10^6 spp is interrupted once its first checkpoint (0.5 s of render time) is on disk (polled, not a
  // fixed delay that a loaded machine could outrun): the state must be there, whole, with the samples so far.
  const std::string script = "\"$0\" \"$@\" & pid=$!; for i in $(seq 300); do [ -s " + dir / "s.ptstate" +
                             " ] && break; sleep 0.1; done; kill -INT $pid; wait $pid";
  const Run r = pt::test::run_pathtracer("sh -c '" + script + "'",
                                         "render -q --scene cornell --seed 1 --width 48 --height 48 --threads 2 "
                                         "--spp 1000000 --checkpoint 0.5 --save-state " + dir / "s.ptstate --pfm " +
                                             dir / "s.pfm");
  INFO(r.out << r.err);
  CHECK(r.status == 0);
  CHECK(r.err.find("interrupted by SIGINT") != std::string::npos);
  const LoadedFilmState s = read_film_state(dir / "s.ptstate");
  CHECK(s.film.total_count() > 0);
  CHECK(s.info.render_seconds > 0.5);
  const uint32_t target = s.film.min_count() + 2;
  const Run resumed = pt::test::run_pathtracer("", "render -q --scene cornell --seed 1 --width 48 --height 48 --spp " +
                                                       std::to_string(target) + " --resume " + dir / "s.ptstate --pfm " + dir / "r.pfm");
  INFO(resumed.err);
  CHECK(resumed.status == 0);
  CHECK(std::filesystem::exists(dir / "r.pfm"));
}
