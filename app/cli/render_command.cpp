#include "cli/render_command.h"

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <optional>
#include <vector>

#include "cli/interrupt.h"
#include "cli/option_checks.h"
#include "cli/progress.h"
#include "cli/render_outputs.h"
#include "cli/render_sample_plan.h"
#include "cli/scene_arg.h"
#include "cli/watchdog.h"
#include "denoise/denoiser.h"
#include "film/film.h"
#include "render/progressive.h"
#include "render/renderer.h"
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
  r->add_option("--rr-depth", o.rr_depth, "Russian roulette from this bounce on; -1 = off (overrides the scene; its default, auto, is 5 for path tracing, and for bdpt 1, or 3 under a sky, sun or environment)")
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
              "Denoise (the filter of --denoiser, docs/denoising.md): the PNG shows the denoised image; the PFM "
              "stays the raw, unbiased estimate");
  r->add_option("--denoised-pfm", o.denoised_pfm, "With --denoise: write the denoised linear radiance (PFM) here");
  r->add_option("--denoiser", o.denoiser,
                enum_names_joined<DenoiseMethod>(" | ") +
                    ": the filter of --denoise: a first-order regression on the features (final frames, ~0.2 s at "
                    "512²) or the à-trous wavelet filter of the viewer (~0.1 s); default regression")
      ->check(CLI::IsMember(enum_name_list<DenoiseMethod>()));
  r->add_option("--exposure", o.exposure, "PNG exposure in EV stops")->check(finite_in(-64, 64))->capture_default_str();
  r->add_option("--tonemap", o.tonemap, "PNG tone map: " + enum_names_joined<ToneMap>(" | "))
      ->check(CLI::IsMember(enum_name_list<ToneMap>()))
      ->capture_default_str();
  r->add_flag("--adaptive", o.adaptive,
              "Adaptive sampling: passes spend samples where the film's error estimate is high (every 4th pass uniform; "
              "bdpt's passes stay uniform, its light subpaths reaching every pixel)");
  r->add_flag("--generic-kernel", o.generic_kernel,
              "Diagnostic: run the kernel compiled for every scene feature instead of the one specialised for this "
              "scene (same image, more work; for instruction-count comparisons)");
  r->add_option("--path-loop", o.path_loop,
                enum_names_joined<PathLoop>(" | ") +
                    ": trace paths one at a time, or a tile's paths together bounce by bounce with 16-ray packets "
                    "(same image; auto: the wavefront, on every scene)")
      ->check(CLI::IsMember(enum_name_list<PathLoop>()))
      ->capture_default_str();
  r->add_option("--instancing", o.instancing,
                enum_names_joined<Instancing>(" | ") +
                    ": keep every instanced mesh behind its instance, or (auto) place the triangles of a scene of at most "
                    "262,144 as polygons under one hierarchy (docs/performance.md; nearly the same image)")
      ->check(CLI::IsMember(enum_name_list<Instancing>()))
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

// Step 1: the scene with the command line's overrides, validated; nullopt after printing the error.
std::optional<SceneDesc> scene_for_render(const RenderOptions& o) {
  std::optional<SceneDesc> loaded = load_scene_arg(o.scene);
  if (!loaded) return std::nullopt;
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
  parse_enum(o.instancing, desc.render.instancing);
  // The bdpt diagnostics need bdpt.
  const char* bdpt_only_flag = !o.bdpt_strategy.empty() ? "--bdpt-strategy" : o.no_manifold ? "--no-manifold" : nullptr;
  if (bdpt_only_flag && desc.render.estimator != Estimator::Bdpt) {
    std::fprintf(stderr, "error: %s: needs --estimator bdpt (the scene's estimator is %s)\n", bdpt_only_flag,
                 to_string(desc.render.estimator));
    return std::nullopt;
  }
  if (!o.bdpt_strategy.empty()) desc.render.bdpt_only = {o.bdpt_strategy[0], o.bdpt_strategy[1]};
  if (o.no_manifold) desc.render.bdpt_manifold = false;
  if (std::string err = validate_scene(desc); !err.empty()) {
    std::fprintf(stderr, "error: %s: %s\n", o.scene.c_str(), err.c_str());
    return std::nullopt;
  }
  if (desc.render.estimator == Estimator::Auto && !o.quiet)  // which one, and why
    std::fprintf(stderr, "estimator auto: %s\n", choose_estimator(desc).reason.c_str());
  return loaded;
}

// What one pass of the loop is to do. With --mpi every rank gets the same answer: rank 0's pace, so the ranks
// stay in step and meet at the same collective calls.
struct PassDecision {
  bool finished = false, abort = false, checkpoint = false;
  int spp = 1;            // the pass's samples per pixel
  double global_spp = 0;  // samples per pixel over all ranks
};

PassDecision decide_pass(const RankStop& rs, const SamplePlan& plan, const ProgressivePasses& passes,
                         const Film& film, double elapsed, bool abort, bool checkpoint_due) {
  constexpr double kPassSeconds = 0.5;  // passes of about half a second keep the progress and stop checks timely
  const StopConditions& stop = rs.stop;
  const uint64_t spp = film.min_count();
  const double relmse_now = stop.relmse > 0.0 ? film.estimated_relmse() : 0.0;  // a pass over the film: if asked
  PassDecision d;
  d.finished = stop_reason(stop, spp, elapsed, relmse_now) != nullptr;
  d.spp = passes.next_spp(kPassSeconds, stop, spp, elapsed, relmse_now);
  d.checkpoint = checkpoint_due;
  d.abort = abort;
  d.global_spp = static_cast<double>(spp);
  if (!plan.mpi) return d;
  const MpiWorld& mpi = *plan.mpi;
  std::vector<int64_t> v{d.finished ? 0 : 1, d.abort ? 1 : 0, d.checkpoint && mpi.root() ? 1 : 0,
                         mpi.root() ? d.spp : 0};
  mpi.max_all(v);
  d.global_spp = mpi.sum_all(static_cast<double>(spp));
  if (rs.merged_relmse_target > 0.0) {  // the merged film's relMSE ≈ the mean of the ranks' over N (equal counts)
    const double local = spp >= 2 ? film.estimated_relmse() : 1e300;
    const double ranks = plan.ranks();
    const double merged = mpi.sum_all(std::min(local, 1e300)) / (ranks * ranks);
    if (d.global_spp >= kRelMseStopMinSpp && merged <= rs.merged_relmse_target) v[0] = 0;
  }
  d.finished = v[0] == 0;
  d.abort = v[1] != 0;
  d.checkpoint = v[2] != 0;
  d.spp = std::max(1, std::min(static_cast<int>(v[3]),
                               stop.spp > 0 ? static_cast<int>(stop.spp - spp) : kMaxPassSpp));
  return d;
}

// Step 4: passes until a stop condition, Ctrl-C or SIGTERM; checkpoints on the way. Returns the wall time.
double run_progressive(const RenderOptions& o, ProgressivePasses& passes, Film& film, const RankStop& rs,
                       const SamplePlan& plan, const OutputWriter& writer, InterruptScope& interrupts) {
  const StopConditions& stop = rs.stop;
  Progress progress(!o.quiet && plan.root());
  std::vector<RelMsePoint> relmse_history;  // with a target relMSE: the estimate after each pass (the ETA's fit)
  using clock = std::chrono::steady_clock;
  const auto start = clock::now();
  auto elapsed = [&] { return std::chrono::duration<double>(clock::now() - start).count(); };
  // One flag stops the pass in flight, within a sample: the first SIGINT/SIGTERM, or the time limit (a watchdog
  // raises it at the deadline, so --time holds even when a single pass or path would run far longer).
  std::atomic<bool>& stop_now = interrupts.stop_flag();
  Watchdog watchdog(stop_now, stop.seconds > 0.0 ? std::optional<double>(stop.seconds) : std::nullopt);
  double last_checkpoint = 0.0;
  for (;;) {
    const bool checkpoint_due = o.checkpoint_seconds > 0.0 && elapsed() - last_checkpoint >= o.checkpoint_seconds;
    const PassDecision d = decide_pass(rs, plan, passes, film, elapsed(), stop_now.load(), checkpoint_due);
    if (d.checkpoint && !d.finished && !d.abort) {
      last_checkpoint = elapsed();
      if (plan.mpi) {
        std::optional<Film> merged = merge_over_ranks(plan, film, writer.state_info, passes.busy_seconds());
        if (plan.root()) writer.write(*merged, elapsed(), true);
      } else {
        writer.write(film, elapsed(), true);
      }
    }
    if (d.finished || d.abort) break;
    const bool idle = stop.spp > 0 && film.min_count() >= stop.spp;  // this rank's share is done; others' not yet
    if (!idle) passes.render(d.spp, &stop_now);
    const uint64_t spp = film.min_count();
    const double relmse = stop.relmse > 0.0 ? film.estimated_relmse() : 0.0;  // a pass over the film: only if asked
    if (stop.relmse > 0.0 && spp >= kRelMseStopMinSpp && std::isfinite(relmse))  // the forecast's history
      relmse_history.push_back({elapsed(), relmse, spp});
    const double global_spp = plan.mpi ? d.global_spp : static_cast<double>(spp);
    StopConditions shown = stop;
    if (plan.mpi && plan.root() && stop.spp > 0) shown.spp = stop.spp * plan.ranks();  // the whole job, on rank 0
    progress.update(stop_progress(shown, static_cast<uint64_t>(global_spp), elapsed(), relmse, relmse_history).fraction,
                    elapsed(), static_cast<uint64_t>(global_spp),
                    static_cast<double>(passes.samples()) * plan.ranks() / elapsed());
  }
  watchdog.finish();
  progress.finish();
  const double seconds = elapsed();
  if (const int sig = interrupts.signal_received())
    std::fprintf(stderr, "interrupted by %s: stopping, writing the image from the samples so far\n",
                 InterruptScope::signal_name(sig));
  return seconds;
}

// Step 5's summary line: what was rendered, how fast, and how well.
void print_summary(const RenderOptions& o, const SceneDesc& desc, const Film& film, double seconds, double samples,
                   double rays, const std::string& path) {
  // `auto` names its pick: "auto=bdpt".
  const std::string estimator = desc.render.estimator == Estimator::Auto
                                    ? std::string("auto=") + to_string(choose_estimator(desc).estimator)
                                    : std::string(to_string(desc.render.estimator));
  std::printf("%s %dx%d %s/%s: %llu spp in %.2f s, %.2f Msamples/s, %.2f Mrays/s, estimated relMSE %.3g, "
              "%llu non-finite samples rejected\n",
              o.scene.c_str(), desc.width, desc.height, estimator.c_str(), to_string(desc.render.sampler),
              static_cast<unsigned long long>(film.min_count()), seconds, samples / seconds * 1e-6,
              rays / seconds * 1e-6, film.estimated_relmse(), static_cast<unsigned long long>(film.rejected()));
  std::printf("path: %s\n", path.c_str());
  if (film.rejected() > 0)
    std::fprintf(stderr, "warning: %llu samples were not finite and were left out of the image\n",
                 static_cast<unsigned long long>(film.rejected()));
}

}  // namespace

// The walk from scene file to written image, in named steps: (1) the options onto the scene, (2) the output plan,
// (3) the resume/MPI sample plan, both checked before the first sample, (4) the progressive run, (5) writing
// the outputs (rank 0 alone, from the merged film, with --mpi).
int run_render(const RenderOptions& o) {
  std::optional<SceneDesc> scene_desc = scene_for_render(o);
  if (!scene_desc) return 2;
  const SceneDesc& desc = *scene_desc;
  const std::optional<OutputPlan> outputs = plan_outputs(o);
  if (!outputs) return 2;
  SamplePlan plan;  // MPI: every rank runs this same command; rank 0 alone checks and writes the outputs and prints
  if (const int status = plan_samples(o, desc, outputs->features, plan)) return status;
  bool ok = plan.root() ? check_outputs(outputs->files, o.scene) : true;
  ok = ok && check_film_memory(desc.width, desc.height, outputs->features, outputs->features || !o.exr.empty());
  if (!plan.all_ranks(ok)) return 2;  // all ranks stop together when one cannot go on

  const auto scene = compile_scene(desc);
  const RankStop rank_stop = plan_stop(o, plan);
  StartingFilm start = start_film(desc, scene_stem(o.scene), outputs->features, !o.save_state.empty(), plan);
  Film& film = start.film;
  Renderer renderer(o.threads);
  if (!renderer.thread_start_error().empty())
    std::fprintf(stderr, "warning: %s; rendering with %d\n", renderer.thread_start_error().c_str(), renderer.threads());
  const OutputWriter writer{o, *outputs, start.info, plan.mpi.has_value(), renderer.pool()};
  ProgressivePasses passes(renderer, *scene, desc.render, film, o.adaptive);
  // Signals are caught from here to the last output written: the first stops the run (and the outputs are
  // written), a second exits at once.
  InterruptScope interrupts;
  const double seconds = run_progressive(o, passes, film, rank_stop, plan, writer, interrupts);

  double samples = static_cast<double>(passes.samples()), rays = static_cast<double>(passes.rays());
  if (plan.mpi) {
    // Rank 0 merges every rank's film exactly; the other ranks are done.
    const MpiWorld& mpi = *plan.mpi;
    samples = mpi.sum_all(samples);
    rays = mpi.sum_all(rays);
    const double all_busy = mpi.sum_all(passes.busy_seconds());
    std::optional<Film> merged = merge_over_ranks(plan, film, start.info, passes.busy_seconds());
    if (!plan.root()) return 0;
    film = std::move(*merged);
    std::printf("mpi: %d ranks, %.2f s, ranks busy %.0f %% of the time (sum of the ranks' pass times over ranks x "
                "wall time)\n", plan.ranks(), seconds, 100.0 * all_busy / (plan.ranks() * seconds));
  }
  print_summary(o, desc, film, seconds, std::floor(samples), std::floor(rays), Renderer::describe_path(*scene, desc.render));
  if (film.total_count() == 0) {
    std::fprintf(stderr, "error: no sample was rendered; nothing written\n");
    return 1;
  }
  if (film.min_count() == 0)
    std::fprintf(stderr, "warning: some pixels have no sample yet (they are written black)\n");
  return writer.write(film, seconds, false) ? 1 : 0;
}

}  // namespace pt
