// The viewer's background render session: restarts, cancellation, pause, stop conditions, published frames.
#include <doctest/doctest.h>

#include <span>
#include <sys/resource.h>
#include <time.h>

#include <chrono>
#include <thread>

#include "denoise/denoiser.h"
#include "render/render_session.h"
#include "frame_helpers.h"
#include "scene/scene_json.h"
#include "test_helpers.h"

using namespace pt;
using pt::test::block_mean;

namespace {

SceneDesc small_cornell(int size = 32, int bounces = 4) {
  SceneDesc d = load_scene("cornell");
  d.width = d.height = size;
  d.render.max_bounces = bounces;
  return d;
}

SessionSettings settings_with(uint64_t spp, int preview_divisor = 1) {
  SessionSettings s;
  s.stop.spp = spp;
  s.preview_divisor = preview_divisor;
  return s;
}

// A scene whose every 1-spp pass takes seconds: a closed furnace sphere (albedo 0.99) around the camera, every
// path running its 300 bounces (no roulette), 512²: ~3.5 s a pass on this machine. Waiting for such a pass to
// end takes seconds, stopping it within a tile milliseconds: latency bounds of 1 s between the two leave a loaded
// machine room without letting a wait pass.
SceneDesc slow_pass_scene() {
  SceneDesc d = test::furnace_scene(Rgb(0.1f), Rgb(0.99f), 300, -1, Estimator::Cosine);
  d.width = d.height = 512;
  return d;
}

double seconds_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

// Polls for a published frame satisfying pred (frames are swapped in, so the last one taken is returned).
bool wait_frame(RenderSession& s, DisplayFrame& f, const std::function<bool(const DisplayFrame&)>& pred,
                double timeout = 30.0) {
  const auto start = std::chrono::steady_clock::now();
  while (seconds_since(start) < timeout) {
    if (s.take_frame(f) && pred(f)) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return false;
}

double process_cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

// What the whole process (every thread) used while this thread slept through `seconds` of wall time.
struct IdleUsage {
  double wall = 0.0, cpu = 0.0;  // seconds
  long switches = 0;             // context switches, voluntary + involuntary, of all threads
};

IdleUsage measure_idle(double seconds) {
  rusage r0{}, r1{};
  getrusage(RUSAGE_SELF, &r0);
  const double cpu0 = process_cpu_seconds();
  const auto t0 = std::chrono::steady_clock::now();
  std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
  IdleUsage u;
  u.cpu = process_cpu_seconds() - cpu0;
  u.wall = seconds_since(t0);
  getrusage(RUSAGE_SELF, &r1);
  u.switches = (r1.ru_nvcsw - r0.ru_nvcsw) + (r1.ru_nivcsw - r0.ru_nivcsw);
  return u;
}

}  // namespace

TEST_CASE("session: accumulates to the target spp, then its image equals one direct render of that many spp") {
  const SceneDesc desc = small_cornell();
  RenderSession session(desc, settings_with(12));
  REQUIRE(session.wait_for([](const SessionStats& s) { return s.done; }, 60.0));
  const SessionStats st = session.stats();
  CHECK(st.spp == 12);
  CHECK(st.stop_reason == "target spp");
  CHECK(st.error.empty());
  CHECK(st.samples == 12ull * 32 * 32);
  CHECK(st.samples_per_second > 0.0);
  CHECK(st.rays_per_second >= st.samples_per_second);
  DisplayFrame f;
  REQUIRE(session.take_frame(f));
  CHECK(f.spp == 12);
  CHECK(!f.preview);
  // Samples depend only on (pixel, sample index, seed), so however the session split its passes, the film is the
  // film of one 12-spp pass, bit for bit.
  const Film direct = test::render_film(desc, 12);
  REQUIRE(f.width == direct.width());
  int mismatches = 0;
  for (size_t i = 0; i < direct.pixel_count(); ++i)
    for (int c = 0; c < 3; ++c) mismatches += f.rgba[4 * i + c] != static_cast<float>(direct.mean_channel(i, c));
  CHECK(mismatches == 0);
  CHECK(st.estimated_relmse == doctest::Approx(direct.estimated_relmse()).epsilon(1e-12));
  // The per-pixel relative error squared, averaged, is the estimated relMSE.
  double mean_sq = 0.0;
  for (size_t i = 0; i < direct.pixel_count(); ++i) mean_sq += double(f.rgba[4 * i + 3]) * f.rgba[4 * i + 3];
  CHECK(mean_sq / direct.pixel_count() == doctest::Approx(st.estimated_relmse).epsilon(1e-4));
  std::vector<RelMsePoint> history;
  session.copy_history(history);
  REQUIRE(!history.empty());
  CHECK(history.back().relmse == doctest::Approx(st.estimated_relmse));
  for (size_t i = 1; i < history.size(); ++i) CHECK(history[i].seconds >= history[i - 1].seconds);
}

TEST_CASE("session: an edit restarts accumulation at once and the new image shows it") {
  SceneDesc desc = small_cornell();
  RenderSession session(desc, settings_with(8));
  REQUIRE(session.wait_for([](const SessionStats& s) { return s.done; }, 60.0));
  DisplayFrame before;
  REQUIRE(session.take_frame(before));
  const uint64_t g0 = session.stats().generation;

  for (MaterialDesc& m : desc.materials)
    if (m.name == "white") m.albedo = Rgb(0.95f);
  session.set_paused(true);  // no pass of the new generation can finish before the check below (not a race)
  const uint64_t g1 = session.set_scene(desc);
  CHECK(g1 == g0 + 1);
  const SessionStats right_after = session.stats();
  session.set_paused(false);
  CHECK(right_after.generation == g1);
  CHECK(right_after.spp == 0);  // at once, not after the next pass
  CHECK(!right_after.done);

  DisplayFrame after;
  REQUIRE(wait_frame(session, after, [&](const DisplayFrame& f) { return f.generation == g1 && f.spp >= 8; }));
  // The back wall (image centre, between the light and the blocks) is white: brighter with a higher albedo.
  const glm::dvec3 b = block_mean(before, 12, 9, 20, 14), a = block_mean(after, 12, 9, 20, 14);
  for (int c = 0; c < 3; ++c) CHECK(a[c] > b[c] * 1.1);
}

TEST_CASE("session: typed edits and render settings apply in place, the image is that of the edited scene") {
  SceneDesc desc = small_cornell();
  RenderSession session(desc, settings_with(6));
  REQUIRE(session.wait_for([](const SessionStats& s) { return s.done; }, 60.0));
  // A material, the camera, and the render settings, sent as typed edits in a burst.
  MaterialDesc white = desc.materials[0];
  white.type = MaterialType::Plastic;
  white.roughness = 0.3f;
  CameraDesc camera = desc.camera;
  camera.fov_deg = 30.0;
  RenderSettings render = desc.render;
  render.estimator = Estimator::Nee;
  render.max_bounces = 2;
  session.edit(MaterialEdit{0, white});
  session.edit(camera);
  const uint64_t g = session.set_render(render);
  SceneDesc expected = desc;
  apply_edit(expected, MaterialEdit{0, white});
  apply_edit(expected, camera);
  expected.render = render;
  DisplayFrame f;
  REQUIRE(wait_frame(session, f, [&](const DisplayFrame& fr) { return fr.generation == g && fr.spp >= 6; }));
  REQUIRE(session.wait_for([&](const SessionStats& s) { return s.done && s.generation == g; }, 60.0));
  session.take_frame(f);
  CHECK(session.stats().error.empty());
  // Same samples as a direct render of the edited description: bit for bit.
  const Film direct = test::render_film(expected, 6);
  int mismatches = 0;
  for (size_t i = 0; i < direct.pixel_count(); ++i)
    for (int c = 0; c < 3; ++c) mismatches += f.rgba[4 * i + c] != static_cast<float>(direct.mean_channel(i, c));
  CHECK(mismatches == 0);
  // An edit that does not fit the scene is reported and dropped; rendering goes on.
  const uint64_t g2 = session.edit(MaterialEdit{99, white});
  REQUIRE(session.wait_for([&](const SessionStats& s) { return s.done && s.generation == g2; }, 60.0));
  CHECK(session.stats().error == "edit not applied: materials[99]: no such material");
}

TEST_CASE("session: pause stops within a tile and uses no CPU, resume continues the same accumulation") {
  // Waits for whole passes are generous (a pass of this scene is ~3.5 s alone, several times that on a loaded
  // 2-core machine: a loaded run timed out at 60 s); they still catch a session that never renders.
  RenderSession session(slow_pass_scene(), settings_with(0));
  REQUIRE(session.wait_for([](const SessionStats& s) { return s.spp >= 1 && s.rendering; }, 300.0));
  const auto t = std::chrono::steady_clock::now();
  session.set_paused(true);
  REQUIRE(session.wait_for([](const SessionStats& s) { return !s.rendering; }, 5.0));
  const double stop_latency = seconds_since(t);
  MESSAGE("pause took effect in " << stop_latency * 1e3 << " ms, in a pass of " << session.stats().seconds << " s so far");
  CHECK(stop_latency < 1.0);
  const SessionStats paused = session.stats();
  CHECK(paused.paused);
  const double cpu0 = process_cpu_seconds();
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  const double cpu = process_cpu_seconds() - cpu0;
  MESSAGE("CPU while paused: " << cpu * 1e3 << " ms over 300 ms");
  CHECK(cpu < 0.03);
  CHECK(session.stats().seconds == paused.seconds);  // render time excludes the pause
  CHECK(session.stats().generation == paused.generation);

  session.set_paused(false);
  const uint64_t spp = paused.spp;
  REQUIRE(session.wait_for([&](const SessionStats& s) { return s.spp > spp; }, 300.0));
  CHECK(session.stats().generation == paused.generation);
}

TEST_CASE("session: once a stop condition is met the thread sleeps, raising the limit resumes") {
  RenderSession session(small_cornell(), settings_with(4));
  REQUIRE(session.wait_for([](const SessionStats& s) { return s.done; }, 60.0));
  const double cpu0 = process_cpu_seconds();
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  CHECK(process_cpu_seconds() - cpu0 < 0.02);
  CHECK(session.stats().spp == 4);

  SessionSettings more = session.settings();
  more.stop.spp = 9;
  session.set_settings(more);
  REQUIRE(session.wait_for([](const SessionStats& s) { return s.done && s.spp == 9; }, 60.0));
}

// A regression (seen once in CI as 389 spp against a limit of 8): a region change makes the session publish its
// film anew before the next pass, and the stop condition was then judged by the newest settings while the pass
// was sized by the worker's older copy. A limit raised in that window (4 → 5 here) let one pass run unbounded,
// far past it. The window is microseconds wide, so each round sends the second setting after a different delay
// (0 to 400 µs in steps of 10, on an 8 × 8 film); without the fix, five runs out of five failed here, each at
// a round with a 10 µs delay (rounds 42, 83 or 124: spp 1066 against a limit of 43). Each round must end at
// exactly its limit.
TEST_CASE("session: a limit raised while the film is republished for a region change bounds the next pass") {
  SceneDesc d = small_cornell(8, 2);
  SessionSettings s = settings_with(1);
  s.threads = 1;
  RenderSession session(d, s);
  REQUIRE(session.wait_for([](const SessionStats& st) { return st.done; }, 60.0));
  int overshoots = 0;
  for (uint64_t round = 1; round <= 400 && overshoots == 0; ++round) {
    // The whole film as the region: the accumulation is unchanged, but the region setting differs, so the film
    // is republished; it alternates with no region.
    s.region = round % 2 ? std::optional<PixelRect>(PixelRect{0, 0, 8, 8}) : std::nullopt;
    session.set_settings(s);
    const auto t0 = std::chrono::steady_clock::now();
    const auto delay = std::chrono::microseconds(static_cast<int>(round % 41) * 10);
    while (std::chrono::steady_clock::now() - t0 < delay) {
    }
    s.stop.spp = round + 1;
    session.set_settings(s);
    const uint64_t limit = s.stop.spp;
    REQUIRE(session.wait_for([&](const SessionStats& st) { return st.done && st.spp >= limit; }, 60.0));
    const SessionStats st = session.stats();
    INFO("round " << round << ": spp " << st.spp << " against a limit of " << limit);
    overshoots += st.spp != limit;
    CHECK(st.spp == limit);
  }
}

// "0 % CPU once a stop condition is met or when paused; nothing is traced when nothing changed." Every session and
// pool thread must then block on a condition variable: no busy waits, no sleep-polling.
// Bounds, over 0.5 s of wall time while this thread sleeps:
// - process CPU < 5 % of the interval (25 ms). Blocked threads cost nothing; what remains is this thread's own
//   sleep and wake-up (microseconds). One spinning thread costs a whole core, and even niced (background
//   priority) on a loaded 2-core machine it would get well over 5 %, so the bound separates the two with margin
//   for accounting noise on a shared CI machine.
// - at most 10 context switches in the whole process: a sleep-polling loop costs little CPU but wakes up every
//   period (a 50 ms poll is already 10 switches); the sleeping thread itself accounts for 1 or 2.
// The session uses 4 render threads whatever the machine, so there are pool workers that could spin.
TEST_CASE("session: idle means idle: no CPU and no tracing once stopped, paused, or sent no change") {
  constexpr double kInterval = 0.5, kSettle = 0.1;
  auto check_idle = [&](RenderSession& session, const std::string& what) {
    // Let the threads finish the pass's bookkeeping and go to sleep; a poller keeps polling past this.
    std::this_thread::sleep_for(std::chrono::duration<double>(kSettle));
    DisplayFrame f;
    session.take_frame(f);  // the last image of the stopped pass, if not taken yet
    const SessionStats before = session.stats();
    const IdleUsage u = measure_idle(kInterval);
    const SessionStats after = session.stats();
    MESSAGE(what << ": process CPU " << u.cpu * 1e3 << " ms over " << u.wall * 1e3 << " ms wall ("
                 << 100.0 * u.cpu / u.wall << " %), " << u.switches << " context switches; " << after.spp
                 << " spp, " << after.samples << " samples");
    CHECK(u.cpu < 0.05 * u.wall);
    CHECK(u.switches <= 10);
    // It really stopped: nothing traced, nothing published, render time frozen.
    CHECK(!after.rendering);
    CHECK(after.samples == before.samples);
    CHECK(after.spp == before.spp);
    CHECK(after.seconds == before.seconds);
    CHECK(after.generation == before.generation);
    CHECK(!session.take_frame(f));
  };

  SUBCASE("a stop condition is met, then the same settings are sent again") {
    SessionSettings s = settings_with(4);
    s.threads = 4;
    RenderSession session(small_cornell(), s);
    REQUIRE(session.wait_for([](const SessionStats& st) { return st.done; }, 60.0));
    CHECK(session.stats().spp == 4);
    check_idle(session, "stop condition met (4 spp)");
    // Nothing changed: an unchanged stop condition and an unpause of a session that is not paused trace nothing.
    session.set_settings(session.settings());
    session.set_paused(false);
    check_idle(session, "same settings sent again");
    CHECK(session.stats().done);
    CHECK(session.stats().spp == 4);
  }
  SUBCASE("paused in the middle of a render") {
    SessionSettings s = settings_with(0);  // no stop condition: it would render forever
    s.threads = 4;
    RenderSession session(small_cornell(256, 16), s);
    REQUIRE(session.wait_for([](const SessionStats& st) { return st.spp >= 1 && st.rendering; }, 60.0));
    session.set_paused(true);
    REQUIRE(session.wait_for([](const SessionStats& st) { return !st.rendering; }, 5.0));
    CHECK(!session.stats().done);
    check_idle(session, "paused mid-render");
    session.set_paused(false);  // and it was only paused
    const uint64_t samples = session.stats().samples;
    REQUIRE(session.wait_for([&](const SessionStats& st) { return st.samples > samples; }, 60.0));
  }
}

TEST_CASE("session: time and relMSE stop conditions") {
  SUBCASE("time") {
    SessionSettings s = settings_with(0);
    s.stop.seconds = 0.3;
    RenderSession session(small_cornell(64), s);
    REQUIRE(session.wait_for([](const SessionStats& st) { return st.done; }, 30.0));
    const SessionStats st = session.stats();
    CHECK(st.stop_reason == "time limit");
    CHECK(st.seconds >= 0.3);
    CHECK(st.seconds < 1.5);
  }
  SUBCASE("relMSE") {
    SessionSettings s = settings_with(0);
    s.stop.relmse = 0.05;
    RenderSession session(small_cornell(16), s);
    REQUIRE(session.wait_for([](const SessionStats& st) { return st.done; }, 60.0));
    const SessionStats st = session.stats();
    CHECK(st.stop_reason == "target relMSE");
    CHECK(st.spp >= 16);
    CHECK(st.estimated_relmse <= 0.05);
  }
}

TEST_CASE("session: a slow pass is cancelled promptly by an edit") {
  RenderSession session(slow_pass_scene(), settings_with(0));
  REQUIRE(session.wait_for([](const SessionStats& s) { return s.rendering; }, 30.0));
  std::this_thread::sleep_for(std::chrono::milliseconds(20));  // well inside the first (several seconds) pass
  SceneDesc tiny = small_cornell(8, 1);
  const auto t = std::chrono::steady_clock::now();
  const uint64_t g = session.set_scene(tiny);
  DisplayFrame f;
  REQUIRE(wait_frame(session, f, [&](const DisplayFrame& fr) { return fr.generation == g; }, 30.0));
  const double latency = seconds_since(t);
  MESSAGE("edit to first image of the new scene: " << latency * 1e3 << " ms");
  CHECK(latency < 1.0);
  CHECK(f.width == 8);
}

TEST_CASE("session: a preview pass at reduced resolution comes first after a restart, then full resolution") {
  // A full pass of this scene takes far longer than the preview, so the preview is normally seen before it is
  // replaced; under load the poll may miss it, so restart until a generation's first frame taken is its preview
  // (a session that published none would fail all 20 tries).
  RenderSession session(small_cornell(256, 16), settings_with(2, 4));
  DisplayFrame f;
  bool seen = false;
  for (int attempt = 0; attempt < 20 && !seen; ++attempt) {
    const uint64_t g = attempt > 0 ? session.restart() : 1;
    REQUIRE(wait_frame(session, f, [&](const DisplayFrame& fr) { return fr.generation >= g; }));
    seen = f.preview;
  }
  REQUIRE(seen);
  CHECK(f.width == 64);
  CHECK(f.height == 64);
  CHECK(f.spp == 1);
  REQUIRE(wait_frame(session, f, [](const DisplayFrame& fr) { return !fr.preview; }));
  CHECK(f.width == 256);
  // A preview is not the accumulation: the run stops at its 2 full-resolution samples, the preview's not counted
  // (checked once done, where the old check of spp == 0 right after the preview raced with the full pass).
  REQUIRE(session.wait_for([](const SessionStats& st) { return st.done; }, 60.0));
  CHECK(session.stats().spp == 2);
}

TEST_CASE("session: with preview_denoise the preview is a clean frame at full resolution, with its times") {
  SessionSettings settings = settings_with(2, 4);
  settings.preview_denoise = true;
  RenderSession session(small_cornell(256, 16), settings);
  // A preview lasts until the first full pass replaces it; under load the poll may miss one, so restart until
  // one is seen (each restart begins with a preview).
  DisplayFrame f;
  bool seen = false;
  for (int attempt = 0; attempt < 20 && !seen; ++attempt) {
    if (attempt > 0) session.restart();
    seen = wait_frame(session, f, [](const DisplayFrame& fr) { return fr.preview; }, 3.0);
  }
  REQUIRE(seen);
  CHECK(f.width == 256);  // the raw preview would be 64 × 64
  CHECK(f.height == 256);
  CHECK(f.spp == 1);
  CHECK(f.max_count == 1.f);
  CHECK(f.preview_times.pass > 0.0);
  CHECK(f.preview_times.guide > 0.0);
  CHECK(f.preview_times.upsample > 0.0);
  size_t finite = 0, lit = 0;
  for (size_t i = 0; i < f.count.size(); ++i) {
    CHECK(f.count[i] == 0.f);  // no samples of its own
    finite += std::isfinite(f.rgba[4 * i]) && std::isfinite(f.rgba[4 * i + 1]) && std::isfinite(f.rgba[4 * i + 2]);
    lit += f.rgba[4 * i] > 0.f;
    CHECK(f.rgba[4 * i + 3] == DisplayFrame::kUnknownError);
  }
  CHECK(finite == f.count.size());
  CHECK(lit > f.count.size() / 2);
  REQUIRE(wait_frame(session, f, [](const DisplayFrame& fr) { return !fr.preview; }));
  CHECK(f.width == 256);
  CHECK(f.preview_times.total() == 0.0);
}

TEST_CASE("session: changing the thread count does not restart, and the image stays exact") {
  const SceneDesc desc = small_cornell();
  SessionSettings s = settings_with(6);
  s.threads = 1;
  RenderSession session(desc, s);
  REQUIRE(session.wait_for([](const SessionStats& st) { return st.done; }, 60.0));
  const uint64_t g = session.stats().generation;
  CHECK(session.stats().threads == 1);
  s.threads = 3;
  s.stop.spp = 14;  // the accumulation continues from 6 spp with 3 threads
  session.set_settings(s);
  REQUIRE(session.wait_for([](const SessionStats& st) { return st.done && st.spp == 14; }, 60.0));
  CHECK(session.stats().generation == g);
  CHECK(session.stats().threads == 3);
  DisplayFrame f;
  REQUIRE(session.take_frame(f));
  const Film direct = test::render_film(desc, 14);
  int mismatches = 0;
  for (size_t i = 0; i < direct.pixel_count(); ++i)
    for (int c = 0; c < 3; ++c) mismatches += f.rgba[4 * i + c] != static_cast<float>(direct.mean_channel(i, c));
  CHECK(mismatches == 0);
}

TEST_CASE("session: an invalid scene is reported, not rendered, and a valid one recovers") {
  SceneDesc bad = small_cornell();
  bad.camera.fov_deg = -3;
  RenderSession session(bad, settings_with(2));
  REQUIRE(session.wait_for([](const SessionStats& s) { return !s.error.empty(); }, 10.0));
  CHECK(session.stats().error.find("fov") != std::string::npos);
  DisplayFrame f;
  CHECK(!session.take_frame(f));
  session.set_scene(small_cornell());
  REQUIRE(session.wait_for([](const SessionStats& s) { return s.done; }, 60.0));
  CHECK(session.stats().error.empty());
}

TEST_CASE("session: with denoising the final frame carries the final-frame denoise of the final film, the raw mean unchanged") {
  const SceneDesc desc = small_cornell();
  SessionSettings s = settings_with(8);
  s.denoise = true;
  RenderSession session(desc, s);
  REQUIRE(session.wait_for([](const SessionStats& st) { return st.done; }, 60.0));
  DisplayFrame f;
  REQUIRE(session.take_frame(f));
  CHECK(f.spp == 8);
  // The raw mean is the film's, as without denoising; the denoised image is the final-frame filter's output for
  // the final film (the last pass before the stop condition is always denoised afresh, with that filter).
  Film film = test::render_film(desc, 8, 0, true);
  const std::vector<float> color = film.mean_image();
  ThreadPool pool(2);
  const std::vector<float> want = denoise_film(film, DenoiseMethod::Regression, pool);
  REQUIRE(f.denoised.size() == want.size());
  int raw_mismatches = 0;
  for (size_t i = 0; i < film.pixel_count(); ++i)
    for (int c = 0; c < 3; ++c) raw_mismatches += f.rgba[4 * i + c] != color[3 * i + c];
  CHECK(raw_mismatches == 0);
  CHECK(f.denoised == want);
  CHECK(f.denoised != color);  // it did filter
}

TEST_CASE("session: turning denoising on keeps the accumulation and denoises the current film at once, and frames "
          "without it carry no denoised image") {
  const SceneDesc desc = small_cornell();
  RenderSession session(desc, settings_with(4));
  REQUIRE(session.wait_for([](const SessionStats& st) { return st.done; }, 60.0));
  DisplayFrame f;
  REQUIRE(session.take_frame(f));
  CHECK(f.denoised.empty());
  const SessionStats before = session.stats();
  SessionSettings s = session.settings();
  s.denoise = true;
  session.set_settings(s);
  // Before, this restarted the accumulation (the film gathered features only with denoising on).
  CHECK(session.stats().generation == before.generation);
  CHECK(session.stats().spp == before.spp);
  // The finished render is not rendered again: its film is denoised and published as it is.
  REQUIRE(wait_frame(session, f, [&](const DisplayFrame& fr) { return !fr.denoised.empty(); }));
  CHECK(f.generation == before.generation);
  CHECK(f.spp == 4);
  CHECK(f.denoised.size() == 3ull * desc.width * desc.height);
  CHECK(session.stats().spp == 4);
  CHECK(session.stats().samples == before.samples);
}

TEST_CASE("progressive: the relMSE forecast follows a power law exactly, and gives a range from noisy points") {
  // relMSE = 0.5 · t^−0.7: the fit must find the exponent, and the forecast is the geometric mean of the fitted
  // line's finish and the 1/time rule's.
  std::vector<RelMsePoint> h;
  for (int i = 1; i <= 40; ++i) {
    const double t = 0.25 * i;
    h.push_back({t, 0.5 * std::pow(t, -0.7), static_cast<uint64_t>(16 * i)});
  }
  const RelMseForecast f = forecast_relmse(h, 1e-3);
  REQUIRE(f.fitted);
  CHECK(f.exponent == doctest::Approx(0.7));
  const double fitted = std::pow(0.5 / 1e-3, 1.0 / 0.7), rule = 10.0 * h.back().relmse / 1e-3;
  CHECK(f.seconds == doctest::Approx(std::sqrt(fitted * rule) - 10.0).epsilon(1e-6));
  CHECK(f.low == doctest::Approx(rule - 10.0).epsilon(1e-6));  // no scatter: the range is the two finishes
  CHECK(f.high == doctest::Approx(fitted - 10.0).epsilon(1e-6));
  // Scatter widens the range around the forecast.
  for (size_t i = 0; i < h.size(); ++i) h[i].relmse *= i % 2 ? 1.1 : 0.9;
  const RelMseForecast g = forecast_relmse(h, 1e-3);
  CHECK(g.low < g.seconds);
  CHECK(g.high > g.seconds);
  // Too little history: the 1/time rule from the newest point.
  const std::vector<RelMsePoint> two = {{1.0, 0.1, 16}, {2.0, 0.05, 32}};
  const RelMseForecast r = forecast_relmse(two, 0.01);
  CHECK_FALSE(r.fitted);
  CHECK(r.seconds == doctest::Approx(2.0 * (0.05 / 0.01 - 1.0)));
  CHECK(forecast_relmse(two, 0.1).seconds == 0.0);  // already there
}

TEST_CASE("progressive: the relMSE forecast made a quarter of the way through predicts the finish within 10 % "
          "on three built-in scenes") {
  // Time is counted in samples per pixel here (render time is proportional to it on a steady machine), so the
  // test is exact and does not depend on the machine's load. Before, the 1/time rule from the newest estimate
  // said "10 s left" on materials at 22 s of a render that finished at 44.6 s.
  struct Case {
    const char* scene;
    double target;
  };
  for (const Case c : {Case{"cornell", 2.5e-4}, Case{"cornell-spheres", 1e-3}, Case{"materials", 5e-4}}) {
    const std::string name = c.scene;
    CAPTURE(name);
    SceneDesc d = load_scene(c.scene);
    d.width = d.height = 64;
    d.render.max_bounces = 8;
    d.render.estimator = Estimator::Mis;
    // The runs the figures below were measured on. With roulette from bounce 5 (mis's `auto` since session 28)
    // materials' forecast at a quarter says 1900 spp for a finish at 1444 (+32 %): its estimate falls more
    // slowly early on (docs/viewer.md, the progress bar).
    d.render.russian_roulette_depth = 3;
    const auto scene = compile_scene(d);
    Renderer renderer(2);
    Film film;
    film.reset(d.width, d.height);
    std::vector<RelMsePoint> history;
    uint64_t spp = 0;
    while (spp < 16384) {
      renderer.render_pass(*scene, d.render, film, 4);
      spp += 4;
      const double r = film.estimated_relmse();
      if (spp >= kRelMseStopMinSpp) history.push_back({static_cast<double>(spp), r, spp});
      if (spp >= kRelMseStopMinSpp && r <= c.target) break;
    }
    REQUIRE(spp < 16384);
    const double finish = static_cast<double>(spp);
    size_t quarter = 0;
    while (quarter + 1 < history.size() && history[quarter].seconds < 0.25 * finish) ++quarter;
    const std::span<const RelMsePoint> seen(history.data(), quarter + 1);
    const double now = seen.back().seconds;
    const RelMseForecast f = forecast_relmse(seen, c.target);
    const double naive = now * seen.back().relmse / c.target;
    MESSAGE(name << ": finished at " << finish << " spp; at " << now << " spp the forecast said " << now + f.seconds
                    << " (range " << now + f.low << " - " << now + f.high << ", exponent " << f.exponent
                    << "), the 1/time rule " << naive);
    CHECK(f.fitted);
    // Issue 37 asks for 30 %; measured −1.3 %, +7.3 % and +2.4 %, so 10 % holds with a margin, and the 1/time
    // rule alone (+0.7 %, −9.9 %, −11.1 %) would fail on materials.
    CHECK(std::abs(now + f.seconds - finish) <= 0.1 * finish);
  }
}

TEST_CASE("progressive: stop_progress gives the fraction and time left of the condition met first") {
  StopConditions none;
  CHECK(stop_progress(none, 10, 1.0, 0.1).fraction < 0.0);
  StopConditions spp;
  spp.spp = 100;
  const StopProgress a = stop_progress(spp, 25, 10.0, 0.1);
  CHECK(a.fraction == doctest::Approx(0.25));
  CHECK(a.eta_seconds == doctest::Approx(30.0));
  CHECK(std::string(a.condition) == "target spp");
  StopConditions both = spp;
  both.seconds = 20.0;  // 10 s left: sooner than the spp target's 30 s
  const StopProgress b = stop_progress(both, 25, 10.0, 0.1);
  CHECK(b.fraction == doctest::Approx(0.5));
  CHECK(b.eta_seconds == doctest::Approx(10.0));
  CHECK(std::string(b.condition) == "time limit");
  // relMSE ∝ 1/time: at 4× the target after 10 s, 30 s remain and a quarter is done.
  StopConditions relmse;
  relmse.relmse = 1e-3;
  const StopProgress c = stop_progress(relmse, 32, 10.0, 4e-3);
  CHECK(c.fraction == doctest::Approx(0.25));
  CHECK(c.eta_seconds == doctest::Approx(30.0));
  CHECK(std::string(c.condition) == "target relMSE");
  CHECK(stop_progress(relmse, kRelMseStopMinSpp - 1, 10.0, 4e-3).fraction < 0.0);  // not trusted yet
  CHECK(stop_progress(relmse, 64, 10.0, 5e-4).fraction == doctest::Approx(1.0));  // met
}
