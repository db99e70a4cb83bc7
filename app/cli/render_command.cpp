#include "cli/render_command.h"

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "cli/interrupt.h"
#include "cli/mpi_world.h"
#include "cli/option_checks.h"
#include "core/memory_budget.h"
#include "io/safe_file.h"

#include "film/film.h"
#include "denoise/denoiser.h"
#include "io/film_exr.h"
#include "io/film_state.h"
#include "scene/scene_identity.h"
#include "io/image_io.h"
#include "cli/progress.h"
#include "render/progressive.h"
#include "render/renderer.h"
#include "cli/scene_arg.h"
#include "scene/estimator_choice.h"
#include "scene/scene_json.h"

namespace pt {

void add_render_command(CLI::App& app, RenderOptions& o) {
  CLI::App* r = app.add_subcommand("render", "Render a scene headless to PNG (tone-mapped) and PFM (linear radiance)");
  r->add_option("--scene", o.scene,
                scene_arg_help())
      ->capture_default_str();
  r->add_option("--width", o.width, "Image width in pixels (overrides the scene's film.width)")->check(whole_in(1, 16384));
  r->add_option("--height", o.height, "Image height in pixels (overrides film.height)")->check(whole_in(1, 16384));
  r->add_option("--spp", o.spp, "Stop after N samples per pixel (default 64 when no stop condition is given)")
      ->check(whole_in(1, 1LL << 31));
  r->add_option("--time", o.time_seconds,
                "Stop after this many seconds of rendering (held to within 0.1 s, even mid-pass and mid-path)")
      ->check(finite_in(1e-3, 1e7));
  r->add_option("--target-relmse", o.target_relmse,
                "Stop when the film's own estimate of relMSE falls to E (checked after each pass, from 16 spp on)")
      ->check(finite_in(1e-12, 1e6));
  r->add_option("--bounces", o.bounces, "Max scattering events after the first hit (overrides render.max_bounces)")
      ->check(whole_in(0, 1 << 30));
  r->add_option("--estimator", o.estimator, enum_names_joined<Estimator>(" | ") + " (overrides render.estimator)")
      ->check(CLI::IsMember(enum_name_list<Estimator>()));
  r->add_option("--sampler", o.sampler, enum_names_joined<SamplerType>(" | ") + " (overrides render.sampler)")
      ->check(CLI::IsMember(enum_name_list<SamplerType>()));
  r->add_option("--rr-depth", o.rr_depth, "Russian roulette from this bounce on; -1 = off (overrides the scene)")
      ->check(whole_in(-1, 1 << 30));
  r->add_option("--seed", o.seed, "Random seed (overrides render.seed); same seed, same image")->check(whole_u64());
  r->add_option("--threads", o.threads, "Render threads; 0 = all hardware threads (fewer if the system refuses)")
      ->check(whole_in(0, 1024))
      ->capture_default_str();
  r->add_option("--png", o.png, "Write the tone-mapped 8-bit sRGB image here");
  r->add_option("--pfm", o.pfm, "Write the linear mean radiance (float PFM) here");
  r->add_option("--exr", o.exr,
                "Write one multi-layer OpenEXR file here: the beauty (R, G, B) and the layers of --aov "
                "(docs/denoising.md lists the channel names)");
  r->add_option("--aov", o.aovs,
                "Layers of --exr, comma-separated: " + enum_names_joined<Aov>(", ") +
                    " (default: all; denoised only with --denoise)")
      ->delimiter(',')
      ->check(CLI::IsMember(enum_name_list<Aov>()));
  r->add_flag("--exr-half", o.exr_half, "Store the --exr channels as 16-bit half floats (default 32-bit float)");
  r->add_flag("--denoise", o.denoise,
              "Denoise (feature-guided à-trous filter, docs/denoising.md): the PNG shows the denoised image; the "
              "PFM stays the raw, unbiased estimate");
  r->add_option("--denoised-pfm", o.denoised_pfm, "With --denoise: write the denoised linear radiance (PFM) here");
  r->add_option("--denoiser", o.denoiser,
                enum_names_joined<DenoiseMethod>(" | ") +
                    ": the filter of --denoise: a first-order regression on the features (final frames, ~0.7 s at "
                    "512²) or the à-trous wavelet filter of the viewer (~0.1 s); default regression")
      ->check(CLI::IsMember(enum_name_list<DenoiseMethod>()));
  r->add_option("--exposure", o.exposure, "PNG exposure in EV stops")->check(finite_in(-64, 64))->capture_default_str();
  r->add_option("--tonemap", o.tonemap, "PNG tone map: " + enum_names_joined<ToneMap>(" | "))
      ->check(CLI::IsMember(enum_name_list<ToneMap>()))
      ->capture_default_str();
  r->add_flag("--adaptive", o.adaptive,
              "Adaptive sampling: passes spend samples where the film's error estimate is high (every 4th pass uniform)");
  r->add_flag("--generic-kernel", o.generic_kernel,
              "Diagnostic: run the kernel compiled for every scene feature instead of the one specialised for this "
              "scene (same image, more work; for instruction-count comparisons)");
  r->add_option("--path-loop", o.path_loop,
                enum_names_joined<PathLoop>(" | ") +
                    ": trace paths one at a time, or a tile's paths together bounce by bounce with 16-ray packets "
                    "(same image; auto: the wavefront where polygons are few enough for brute force)")
      ->check(CLI::IsMember(enum_name_list<PathLoop>()))
      ->capture_default_str();
  r->add_option("--bdpt-strategy", o.bdpt_strategy,
                "Diagnostic for --estimator bdpt: S,T renders only the strategy with S light and T camera vertices, "
                "without MIS weights (one term of the path sum: paths of S+T-2 bounces)")
      ->delimiter(',')
      ->expected(2)
      ->check(CLI::NonNegativeNumber);
  r->add_flag("--no-manifold", o.no_manifold,
              "Diagnostic for --estimator bdpt: leave out the manifold strategy (next-event estimation through smooth "
              "spheres), to measure what it gives");
  r->add_option("--save-state", o.save_state,
                "Also write the film's complete accumulation state here (.ptstate: resumable, mergeable; "
                "docs/scale-out.md); written on Ctrl-C too");
  r->add_option("--resume", o.resume,
                "Continue the render saved in this state file (same scene and settings) up to the stop condition; "
                "bit-identical to rendering straight there");
  r->add_option("--sample-range", o.sample_range,
                "A:B: render sample indices A to B-1 of every pixel (B-A spp), for `pathtracer merge`");
  r->add_flag("--mpi", o.mpi,
              "Run as one rank of an MPI job (mpirun -np N pathtracer render --mpi ...): the ranks split the samples, "
              "rank 0 merges them exactly and writes the outputs (docs/scale-out.md)");
  r->add_option("--checkpoint", o.checkpoint_seconds,
                "Also write every output (merged over the ranks with --mpi) every S seconds, e.g. with --save-state, "
                "so a run that dies keeps its last checkpoint")
      ->check(finite_in(0.1, 1e7));
  r->add_flag("--quiet,-q", o.quiet, "No progress line");
  r->footer(
      "With none of --png, --pfm and --exr, writes NAME.png and NAME.pfm in the current directory (NAME = scene\n"
      "name).\n"
      "Outputs are checked before rendering and written completely or not at all (an earlier file stays intact).\n"
      "Stop conditions combine: rendering stops at the first one met. Ctrl-C (SIGINT) or SIGTERM stops early and\n"
      "writes the image so far; a second one exits at once. Exit status: 0 ok, 1 an output could not be written\n"
      "(or no sample was rendered), 2 invalid scene or options, 3 out of memory, 128+N killed by a second signal N.");
}

namespace {

std::string scene_stem(const std::string& spec) {
  const std::filesystem::path p(spec);
  return p.has_extension() || spec.find('/') != std::string::npos ? p.stem().string() : spec;
}

struct OutputFile {
  const char* flag;
  std::string path;
};

// The same file, whether it exists yet or not (links and relative paths resolved).
bool same_file(const std::string& a, const std::string& b) {
  if (file_id(a) == file_id(b)) return true;
  std::error_code ea, eb;
  const auto ca = std::filesystem::weakly_canonical(std::filesystem::absolute(a), ea);
  const auto cb = std::filesystem::weakly_canonical(std::filesystem::absolute(b), eb);
  return !ea && !eb && ca == cb;
}

// Outputs that cannot be written, that are the scene being rendered, or that name one file twice are refused
// before any work is done.
bool check_outputs(const std::vector<OutputFile>& outputs, const std::string& scene_spec) {
  const FileId input = file_id(scene_spec);  // a built-in scene name is no file
  for (size_t i = 0; i < outputs.size(); ++i) {
    const OutputFile& out = outputs[i];
    if (std::string err = check_output_path(out.path); !err.empty()) {
      std::fprintf(stderr, "error: %s %s\n", out.flag, err.c_str());
      return false;
    }
    if (input.exists && same_file(out.path, scene_spec)) {
      std::fprintf(stderr, "error: %s %s: is the scene being rendered; refusing to overwrite it\n", out.flag,
                   out.path.c_str());
      return false;
    }
    for (size_t j = 0; j < i; ++j)
      if (same_file(outputs[j].path, out.path)) {
        std::fprintf(stderr, "error: %s and %s both name %s; give each output its own file\n", outputs[j].flag,
                     out.flag, out.path.c_str());
        return false;
      }
  }
  return true;
}

// The film and the output images, estimated before anything is allocated.
bool check_film_memory(int width, int height, bool features, bool layers) {
  // Mean image, PFM bytes, PNG pixels and bytes; with layers or denoising up to ~26 more float planes.
  const uint64_t output_bytes = 12 + 12 + 3 + 3 + (layers ? 26 * 4 : 0);
  const uint64_t film_bytes = Film::kBytesPerPixel + (features ? Film::kFeatureBytesPerPixel : 0);
  const uint64_t pixels = static_cast<uint64_t>(width) * static_cast<uint64_t>(height);
  const uint64_t need = pixels * (film_bytes + output_bytes), budget = memory_budget_bytes();
  if (need <= budget) return true;
  std::fprintf(stderr,
               "error: a %dx%d render needs about %s (%llu bytes per pixel); this machine allows %s (3/4 of its "
               "memory, or of ulimit -v); render a smaller image\n",
               width, height, format_bytes(need).c_str(),
               static_cast<unsigned long long>(film_bytes + output_bytes), format_bytes(budget).c_str());
  return false;
}

// Raises `flag` once `seconds` have passed, unless finish() came first.
class Watchdog {
 public:
  Watchdog(std::atomic<bool>& flag, std::optional<double> seconds) {
    if (!seconds) return;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                                                  std::chrono::duration<double>(*seconds));
    thread_ = std::thread([this, &flag, deadline] {
      std::unique_lock<std::mutex> lock(mutex_);
      if (!done_cv_.wait_until(lock, deadline, [this] { return done_; })) flag.store(true);
    });
  }
  ~Watchdog() { finish(); }
  void finish() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      done_ = true;
    }
    done_cv_.notify_all();
    if (thread_.joinable()) thread_.join();
  }

 private:
  std::mutex mutex_;
  std::condition_variable done_cv_;
  bool done_ = false;
  std::thread thread_;
};

// Every rank's film on rank 0, merged exactly (io/film_state: double-double sums); nullopt on the other ranks.
// The states travel in the file format, so the checksum also covers the transfer.
// With --resume, rank 0 adds the resumed state's film (`base`), whose samples precede the ranks'.
std::optional<Film> merge_over_ranks(const MpiWorld& mpi, const Film& film, const FilmStateInfo& info, double busy,
                                     const LoadedFilmState* base) {
  FilmStateInfo mine = info;
  mine.render_seconds = busy;
  const std::vector<std::string> parts = mpi.gather_to_root(encode_film_state(film, mine));
  if (!mpi.root()) return std::nullopt;
  std::vector<LoadedFilmState> decoded;
  std::vector<const LoadedFilmState*> states;
  std::vector<std::string> names;
  decoded.reserve(parts.size());
  for (size_t r = 0; r < parts.size(); ++r) {
    names.push_back("rank " + std::to_string(r));
    decoded.push_back(decode_film_state(parts[r], names.back()));
    states.push_back(&decoded.back());
  }
  if (base) {
    states.push_back(base);
    names.push_back("the resumed state");
  }
  return std::move(merge_film_states(states, names).film);
}

}  // namespace

int run_render(const RenderOptions& o) {
  std::optional<SceneDesc> loaded = load_scene_arg(o.scene);
  if (!loaded) return 2;
  SceneDesc& desc = *loaded;
  if (o.width) desc.width = *o.width;
  if (o.height) desc.height = *o.height;
  if (o.bounces) desc.render.max_bounces = *o.bounces;
  if (o.rr_depth) desc.render.russian_roulette_depth = *o.rr_depth;
  if (o.seed) desc.render.seed = *o.seed;
  if (o.estimator) parse_enum(*o.estimator, desc.render.estimator);
  if (o.sampler) parse_enum(*o.sampler, desc.render.sampler);
  desc.render.generic_kernel = o.generic_kernel;
  parse_enum(o.path_loop, desc.render.path_loop);
  if (!o.bdpt_strategy.empty()) {
    if (desc.render.estimator != Estimator::Bdpt) {
      std::fprintf(stderr, "error: --bdpt-strategy: needs --estimator bdpt (the scene's estimator is %s)\n",
                   to_string(desc.render.estimator));
      return 2;
    }
    desc.render.bdpt_only = {o.bdpt_strategy[0], o.bdpt_strategy[1]};
  }
  if (o.no_manifold) {
    if (desc.render.estimator != Estimator::Bdpt) {
      std::fprintf(stderr, "error: --no-manifold: needs --estimator bdpt (the scene's estimator is %s)\n",
                   to_string(desc.render.estimator));
      return 2;
    }
    desc.render.bdpt_manifold = false;
  }
  if (std::string err = validate_scene(desc); !err.empty()) {
    std::fprintf(stderr, "error: %s: %s\n", o.scene.c_str(), err.c_str());
    return 2;
  }
  if (desc.render.estimator == Estimator::Auto && !o.quiet)  // which one, and why
    std::fprintf(stderr, "estimator auto: %s\n", choose_estimator(desc).reason.c_str());

  // Layers and denoising: which options need which, refused before any work.
  if (!o.aovs.empty() && o.exr.empty()) {
    std::fprintf(stderr, "error: --aov: needs --exr (the layers are written into that file)\n");
    return 2;
  }
  if (!o.denoised_pfm.empty() && !o.denoise) {
    std::fprintf(stderr, "error: --denoised-pfm: needs --denoise\n");
    return 2;
  }
  if (!o.denoiser.empty() && !o.denoise) {
    std::fprintf(stderr, "error: --denoiser: needs --denoise\n");
    return 2;
  }
  std::vector<Aov> aovs;
  if (!o.exr.empty()) {
    if (o.aovs.empty()) {
      for (const auto& entry : enum_entries<Aov>())
        if (entry.value != Aov::Denoised || o.denoise) aovs.push_back(entry.value);
    }
    for (const std::string& name : o.aovs) {
      Aov a = Aov::Albedo;
      parse_enum(name, a);
      if (std::find(aovs.begin(), aovs.end(), a) != aovs.end()) continue;
      if (a == Aov::Denoised && !o.denoise) {
        std::fprintf(stderr, "error: --aov denoised: needs --denoise\n");
        return 2;
      }
      aovs.push_back(a);
    }
  }
  const bool features = o.denoise || std::any_of(aovs.begin(), aovs.end(), aov_needs_features);

  // MPI: every rank runs this same command; rank 0 alone checks and writes the outputs and prints.
  std::optional<MpiWorld> mpi;
  if (o.mpi) {
    if (!o.sample_range.empty()) {
      std::fprintf(stderr, "error: --mpi: not with --sample-range (the ranks share out the sample indices themselves)\n");
      return 2;
    }
    try {
      mpi.emplace(nullptr, nullptr);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "error: --mpi: %s\n", e.what());
      return 2;
    }
  }
  const bool root = !mpi || mpi->root();
  const int ranks = mpi ? mpi->size() : 1;

  // Resuming and sample ranges (docs/scale-out.md): checked before any work.
  std::optional<LoadedFilmState> resumed;
  uint32_t range_begin = 0, range_end = 0;
  if (!o.sample_range.empty()) {
    unsigned long long a = 0, b = 0;
    char tail = 0;
    if (std::sscanf(o.sample_range.c_str(), "%llu:%llu%c", &a, &b, &tail) != 2 || a >= b || b > (1ull << 31)) {
      std::fprintf(stderr, "error: --sample-range %s: expected A:B with 0 <= A < B <= 2^31 (sample indices A to B-1)\n",
                   o.sample_range.c_str());
      return 2;
    }
    if (o.spp || !o.resume.empty()) {
      std::fprintf(stderr, "error: --sample-range: %s (the range gives the samples)\n",
                   o.spp ? "not with --spp" : "not with --resume");
      return 2;
    }
    range_begin = static_cast<uint32_t>(a);
    range_end = static_cast<uint32_t>(b);
  }
  // With --mpi, rank 0 alone reads the state; the ranks learn where it stopped below.
  bool resume_failed = false;
  uint32_t resume_index = 0;  // with --mpi: the state's next sample index, the same in every pixel
  if (!o.resume.empty() && root) {
    try {
      resumed = read_film_state(o.resume);
    } catch (const FilmStateError& e) {
      std::fprintf(stderr, "error: --resume: %s\n", e.what());
      resume_failed = true;
    }
  }
  if (resumed) {
    if (std::string why = resume_problem(resumed->info, desc); !why.empty()) {
      std::fprintf(stderr, "error: --resume %s: cannot continue %s with it: %s\n", o.resume.c_str(), o.scene.c_str(),
                   why.c_str());
      resume_failed = true;
    } else if (features && !resumed->film.has_features()) {
      std::fprintf(stderr, "error: --resume %s: the state has no feature buffers, which --denoise and the feature "
                   "layers need (start it with them)\n", o.resume.c_str());
      resume_failed = true;
    }
  }
  if (resumed && mpi && !resume_failed) {
    // The ranks continue from one index for every pixel: a state whose pixels stopped at different indices (a
    // pass interrupted mid-way) is resumed in one process.
    Film& f = resumed->film;
    resume_index = f.next_sample_index(0);
    for (size_t i = 1; i < f.pixel_count() && !resume_failed; ++i)
      if (f.next_sample_index(i) != resume_index) {
        std::fprintf(stderr, "error: --resume %s: its pixels stopped at different sample indices (an interrupted "
                     "pass); resume it without --mpi first\n", o.resume.c_str());
        resume_failed = true;
      }
  }
  if (resume_failed) resumed.reset();
  if (mpi) {
    std::vector<int64_t> v{resume_failed ? 1 : 0, resume_index};
    mpi->max_all(v);
    if (v[0]) return 2;
    resume_index = static_cast<uint32_t>(v[1]);
  } else if (resume_failed) {
    return 2;
  }

  // Every output is checked before the first sample: a long render must not be lost to a typo.
  std::vector<OutputFile> outputs;
  if (!o.png.empty()) outputs.push_back({"--png", o.png});
  if (!o.pfm.empty()) outputs.push_back({"--pfm", o.pfm});
  if (outputs.empty() && o.exr.empty()) {
    outputs.push_back({"--png", scene_stem(o.scene) + ".png"});
    outputs.push_back({"--pfm", scene_stem(o.scene) + ".pfm"});
  }
  if (!o.exr.empty()) outputs.push_back({"--exr", o.exr});
  if (!o.denoised_pfm.empty()) outputs.push_back({"--denoised-pfm", o.denoised_pfm});
  if (!o.save_state.empty()) outputs.push_back({"--save-state", o.save_state});
  bool ok = root ? check_outputs(outputs, o.scene) : true;
  ok = ok && check_film_memory(desc.width, desc.height, features, features || !o.exr.empty());
  if (mpi) {  // all ranks stop together when one cannot go on
    std::vector<int64_t> failed{ok ? 0 : 1};
    mpi->max_all(failed);
    ok = failed[0] == 0;
  }
  if (!ok) return 2;

  const auto scene = compile_scene(desc);
  StopConditions stop;
  if (o.spp) stop.spp = static_cast<uint64_t>(*o.spp);
  if (o.time_seconds) stop.seconds = *o.time_seconds;
  if (o.target_relmse) stop.relmse = *o.target_relmse;
  if (range_end > 0) stop.spp = range_end - range_begin;
  if (!stop.any()) stop.spp = 64;
  // With --mpi, rank r renders the sample indices [s0 + r·(S−s0)/N, s0 + (r+1)·(S−s0)/N) of every pixel for a
  // target of S spp, s0 the resumed state's next index (0 without one): the merged film then has the straight
  // render's bits. Without an spp target, indices from s0 + r·(2^31 − s0)/N on.
  if (mpi) {
    const uint64_t total = stop.spp, s0 = resume_index;
    if (total > 0) {
      const uint64_t todo = total > s0 ? total - s0 : 0;
      range_begin = static_cast<uint32_t>(s0 + todo * mpi->rank() / ranks);
      stop.spp = s0 + todo * (mpi->rank() + 1) / ranks - range_begin;
    } else {
      range_begin = static_cast<uint32_t>(s0 + ((uint64_t{1} << 31) - s0) / ranks * mpi->rank());
    }
  }
  const double relmse_target = stop.relmse;  // with --mpi, for the merged film (checked across ranks below)
  if (mpi) stop.relmse = 0.0;

  Film film;
  FilmStateInfo state_info = state_info_for(desc, scene_stem(o.scene));
  // The ranks' films gather features when the state has them (rank 0 tells the others).
  bool film_features = features || (resumed && resumed->film.has_features());
  if (mpi) {
    std::vector<int64_t> v{film_features ? 1 : 0};
    mpi->max_all(v);
    film_features = v[0] != 0;
  }
  if (resumed && !mpi) {
    film = std::move(resumed->film);  // its features stay as saved
    state_info.sample_begin = resumed->info.sample_begin;
    state_info.render_seconds = resumed->info.render_seconds;
  } else {
    if (resumed) state_info.render_seconds = resumed->info.render_seconds;
    film.enable_features(film_features);
    film.reset(desc.width, desc.height);
    film.start_at(range_begin);
    state_info.sample_begin = range_begin;
  }
  Renderer renderer(o.threads);
  if (!renderer.thread_start_error().empty())
    std::fprintf(stderr, "warning: %s; rendering with %d\n", renderer.thread_start_error().c_str(), renderer.threads());
  Progress progress(!o.quiet && root);
  std::vector<RelMsePoint> relmse_history;  // with a target relMSE: the estimate after each pass (the ETA's fit)
  using clock = std::chrono::steady_clock;
  const auto start = clock::now();
  auto elapsed = [&] { return std::chrono::duration<double>(clock::now() - start).count(); };

  // One flag stops the pass in flight, within a sample: the first SIGINT/SIGTERM, or the time limit (a watchdog
  // raises it at the deadline, so --time holds even when a single pass or path would run far longer).
  InterruptScope interrupts;
  std::atomic<bool>& stop_now = interrupts.stop_flag();
  Watchdog watchdog(stop_now, stop.seconds > 0.0 ? std::optional<double>(stop.seconds) : std::nullopt);

  // Writes every output from `f` (the merged film with --mpi); a checkpoint says so. Returns the failures.
  auto write_outputs = [&](const Film& f, double seconds, bool checkpoint) {
    const Image img{desc.width, desc.height, f.mean_image()};
    // The denoised image (on the renderer's threads), shown by the PNG; the PFM stays the raw estimate.
    std::vector<float> denoised;
    if (o.denoise) {
      const auto denoise_start = clock::now();
      DenoiseMethod method = DenoiseMethod::Regression;
      if (!o.denoiser.empty()) parse_enum(o.denoiser, method);
      denoised = denoise_film(f, method, renderer.pool());
      if (!checkpoint)
        std::printf("denoised in %.1f ms\n", std::chrono::duration<double, std::milli>(clock::now() - denoise_start).count());
    }
    DisplaySettings display;
    display.exposure_ev = o.exposure;
    parse_enum(o.tonemap, display.tone_map);  // checked against the table by the command line
    // Each output on its own: one that fails does not keep the others from being written.
    int failed = 0;
    for (const OutputFile& out : outputs) {
      try {
        const std::string flag = out.flag;
        if (flag == "--png") write_png(out.path, o.denoise ? Image{img.width, img.height, denoised} : img, display);
        else if (flag == "--pfm") write_pfm(out.path, img);
        else if (flag == "--denoised-pfm") write_pfm(out.path, Image{img.width, img.height, denoised});
        else if (flag == "--save-state") {
          FilmStateInfo info = state_info;
          info.render_seconds += seconds;
          if (mpi) info.sample_begin = 0;
          write_film_state(out.path, f, info);
        }
        else write_film_exr(out.path, f, {aovs, o.exr_half, o.denoise ? &denoised : nullptr});
        if (!checkpoint) std::printf("wrote %s\n", std::filesystem::absolute(out.path).c_str());
      } catch (const std::runtime_error& e) {  // ImageError, FilmStateError
        std::fprintf(stderr, "error: %s: %s\n", out.flag, e.what());
        ++failed;
      }
    }
    if (checkpoint)
      std::fprintf(stderr, "checkpoint at %.1f s: %u spp written%s\n", seconds, f.min_count(), failed ? " (with errors)" : "");
    return failed;
  };

  uint64_t spp = film.min_count(), samples = 0, rays = 0, pass_index = 0;
  double seconds_per_spp = 0.0, busy_seconds = 0.0, last_checkpoint = 0.0;
  // Passes of about half a second keep the progress line and the stop checks timely.
  constexpr double kPassSeconds = 0.5;
  for (;;) {
    // Whether to go on, whether to checkpoint, and (with --mpi) the pass size: rank 0's pace, so the ranks stay
    // in step and meet at the same collective calls.
    const double relmse_now = stop.relmse > 0.0 ? film.estimated_relmse() : 0.0;  // a pass over the film: if asked
    bool finished = stop_reason(stop, spp, elapsed(), relmse_now) != nullptr;
    int pass = next_pass_spp(seconds_per_spp, kPassSeconds, stop, spp, elapsed(), relmse_now);
    bool checkpoint = o.checkpoint_seconds > 0.0 && elapsed() - last_checkpoint >= o.checkpoint_seconds;
    bool abort = stop_now.load();
    double global_spp = static_cast<double>(spp);
    if (mpi) {
      std::vector<int64_t> v{finished ? 0 : 1, abort ? 1 : 0, checkpoint && root ? 1 : 0, root ? pass : 0};
      mpi->max_all(v);
      global_spp = mpi->sum_all(static_cast<double>(spp));
      if (relmse_target > 0.0) {  // the merged film's relMSE ≈ the mean of the ranks' over N (equal sample counts)
        const double local = spp >= 2 ? film.estimated_relmse() : 1e300;
        const double merged = mpi->sum_all(std::min(local, 1e300)) / (static_cast<double>(ranks) * ranks);
        if (global_spp >= kRelMseStopMinSpp && merged <= relmse_target) v[0] = 0;
      }
      finished = v[0] == 0;
      abort = v[1] != 0;
      checkpoint = v[2] != 0;
      pass = std::max(1, std::min(static_cast<int>(v[3]), stop.spp > 0 ? static_cast<int>(stop.spp - spp) : kMaxPassSpp));
    }
    if (checkpoint && !finished && !abort) {
      last_checkpoint = elapsed();
      if (mpi) {
        std::optional<Film> merged = merge_over_ranks(*mpi, film, state_info, busy_seconds, resumed ? &*resumed : nullptr);
        if (root) write_outputs(*merged, elapsed(), true);
      } else {
        write_outputs(film, elapsed(), true);
      }
    }
    if (finished || abort) break;
    const bool idle = stop.spp > 0 && spp >= stop.spp;  // this rank's share is done; others are not yet
    const auto pass_start = clock::now();
    if (!idle) {
      const PassStats ps = run_pass(renderer, *scene, desc.render, film, pass, o.adaptive, pass_index, &stop_now);
      if (!ps.cancelled) seconds_per_spp = std::chrono::duration<double>(clock::now() - pass_start).count() / pass;
      samples += ps.samples;
      rays += ps.rays;
    }
    busy_seconds += std::chrono::duration<double>(clock::now() - pass_start).count();
    spp = film.min_count();
    const double relmse = stop.relmse > 0.0 ? film.estimated_relmse() : 0.0;  // a pass over the film: only if asked
    if (stop.relmse > 0.0 && spp >= kRelMseStopMinSpp && std::isfinite(relmse))  // the forecast's history
      relmse_history.push_back({elapsed(), relmse, static_cast<uint64_t>(spp)});
    StopConditions shown = stop;
    if (mpi && root && stop.spp > 0) shown.spp = stop.spp * ranks;  // progress of the whole job, from rank 0
    progress.update(stop_progress(shown, static_cast<uint64_t>(global_spp), elapsed(), relmse, relmse_history).fraction,
                    elapsed(),
                    static_cast<uint64_t>(global_spp), static_cast<double>(samples) * ranks / elapsed());
  }
  watchdog.finish();
  progress.finish();
  const double seconds = elapsed();
  if (const int sig = interrupts.signal_received())
    std::fprintf(stderr, "interrupted by %s: stopping, writing the image from the samples so far\n",
                 InterruptScope::signal_name(sig));

  if (mpi) {
    // Rank 0 merges every rank's film exactly; the other ranks are done.
    const double all_samples = mpi->sum_all(static_cast<double>(samples)), all_rays = mpi->sum_all(static_cast<double>(rays));
    const double all_busy = mpi->sum_all(busy_seconds);
    std::optional<Film> merged = merge_over_ranks(*mpi, film, state_info, busy_seconds, resumed ? &*resumed : nullptr);
    if (!root) return 0;
    film = std::move(*merged);
    samples = static_cast<uint64_t>(all_samples);
    rays = static_cast<uint64_t>(all_rays);
    spp = film.min_count();
    std::printf("mpi: %d ranks, %.2f s, ranks busy %.0f %% of the time (sum of the ranks' pass times over ranks x "
                "wall time)\n", ranks, seconds, 100.0 * all_busy / (ranks * seconds));
  }

  // `auto` names its pick: "auto=bdpt".
  const std::string estimator = desc.render.estimator == Estimator::Auto
                                    ? std::string("auto=") + to_string(choose_estimator(desc).estimator)
                                    : std::string(to_string(desc.render.estimator));
  std::printf("%s %dx%d %s/%s: %llu spp in %.2f s, %.2f Msamples/s, %.2f Mrays/s, estimated relMSE %.3g, "
              "%llu non-finite samples rejected\n",
              o.scene.c_str(), desc.width, desc.height, estimator.c_str(), to_string(desc.render.sampler),
              static_cast<unsigned long long>(spp), seconds, static_cast<double>(samples) / seconds * 1e-6,
              static_cast<double>(rays) / seconds * 1e-6, film.estimated_relmse(),
              static_cast<unsigned long long>(film.rejected()));
  if (film.rejected() > 0)
    std::fprintf(stderr, "warning: %llu samples were not finite and were left out of the image\n",
                 static_cast<unsigned long long>(film.rejected()));
  if (film.total_count() == 0) {
    std::fprintf(stderr, "error: no sample was rendered; nothing written\n");
    return 1;
  }
  if (spp == 0)
    std::fprintf(stderr, "warning: some pixels have no sample yet (they are written black)\n");
  return write_outputs(film, seconds, false) ? 1 : 0;
}

}  // namespace pt
