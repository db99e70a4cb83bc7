// `pathtracer bench`: for each scene and estimator, one progressive render whose error against a converged
// reference is recorded at wall-clock checkpoints doubling from 1/4 s to --max-seconds (time spent computing the
// error is excluded from the clock). Writes convergence.csv, one log–log plot per scene (gnuplot) and
// summary.md (time to relMSE 1e-2 and 1e-3, efficiency, throughput, thread scaling, interactive pass times).
#include "cli/bench_command.h"

#include "cli/file_names.h"
#include "cli/instruction_count.h"
#include "cli/option_checks.h"
#include "cli/ray_throughput.h"

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <unistd.h>

#include "denoise/denoiser.h"
#include "render/progressive.h"
#include "film/film.h"
#include "io/film_state.h"
#include "scene/scene_identity.h"
#include "io/image_io.h"
#include "io/safe_file.h"
#include "render/metrics.h"
#include "render/renderer.h"
#include "scene/scene_json.h"

namespace pt {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

void add_bench_command(CLI::App& app, BenchOptions& o) {
  CLI::App* b = app.add_subcommand("bench", "Measure run time against error (writes CSV, plots and a summary)");
  b->add_flag("--quick", o.quick, "Smoke run: small images, budgets up to 0.5 s, cheap references (under a minute)");
  b->add_option("--out", o.out_dir,
                "Directory for convergence.csv, convergence-<scene>.png (a scene file: its name without the "
                "extension), summary.md")
      ->capture_default_str();
  b->add_option("--cache", o.cache_dir, "Directory caching converged references (keyed by scene and settings)")
      ->capture_default_str();
  b->add_option("--reference-dir", o.reference_dir,
                "Where cornell_512_cycles.pfm (the independent reference) is looked for")
      ->capture_default_str();
  b->add_option("--scenes", o.scenes, "Scenes to run")->capture_default_str();
  b->add_option("--estimators", o.estimators, "Estimators to run")
      ->check(CLI::IsMember(enum_name_list<Estimator>()))
      ->capture_default_str();
  b->add_option("--samplers", o.samplers, "Samplers to run")
      ->check(CLI::IsMember({"independent", "sobol", "independent+adaptive", "sobol+adaptive"}))
      ->capture_default_str();
  b->add_option("--max-seconds", o.max_seconds, "Largest wall-clock budget (budgets double from 0.25 s)")
      ->check(finite_in(1e-3, 1e6))
      ->capture_default_str();
  b->add_option("--threads", o.threads, "Render threads; 0 = all hardware threads")->check(whole_in(0, 1024))->capture_default_str();
  b->add_option("--reference-spp", o.reference_spp, "Samples per pixel of a rendered (cached) reference")
      ->check(whole_in(16, 1LL << 30))
      ->capture_default_str();
  b->add_flag("--instructions", o.instructions,
              "Also count instructions per sample of each scene and estimator with valgrind's callgrind (1 thread, "
              "64 px wide, sobol; needs a binary without AVX-512, see --instructions-binary)");
  b->add_option("--instructions-binary", o.instructions_binary,
                "The pathtracer that --instructions runs under valgrind (implies --instructions; default: this "
                "one, when it was built without AVX-512, e.g. -DPT_ARCH=x86-64-v3)");
}

namespace {

struct Checkpoint {
  double seconds;
  uint64_t spp;
  double relmse, rmse;
  // The same film denoised (denoise/denoiser.h): its relMSE, and the seconds spent denoising it (off the clock
  // of `seconds`; "time with denoising" adds them).
  double denoised_relmse, denoise_seconds;
};

struct Series {
  std::string scene, estimator, sampler;
  int threads;
  std::vector<Checkpoint> points;
  double msamples_per_s = 0, mrays_per_s = 0;
};

double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

Image film_image(const Film& f) { return Image{f.width(), f.height(), f.mean_image()}; }

// A scene's name as part of a file name (the reference cache's, the plots'): a built-in scene's name, or a scene
// file's stem with every character outside [A-Za-z0-9._-] made '_'. The whole path made "bench-cache/a dir/…"
// and "convergence-/usr/…" folders that do not exist: the bench stopped at its first reference, or wrote no plot.
std::string file_stem(const std::string& scene) {
  const std::string stem = file_name_part(fs::path(scene).stem().string());
  return stem.empty() ? "scene" : stem;
}

// A converged image of the scene: the independent Cycles reference for the canonical cornell at 512², else a
// long `mis` render, cached on disk under a key of everything that defines the image.
Image reference_for(const std::string& name, SceneDesc desc, const BenchOptions& o, Renderer& renderer,
                    std::string& label) {
  const fs::path cycles = fs::path(o.reference_dir) / "cornell_512_cycles.pfm";
  if (name == "cornell" && desc.width == 512 && desc.height == 512 && fs::exists(cycles)) {
    label = "Blender Cycles, " + cycles.filename().string();
    return read_pfm(cycles.string());
  }
  desc.render.estimator = Estimator::Mis;
  desc.render.seed = 0x5eed;
  const long long spp = o.quick ? 1024 : o.reference_spp;
  // The key: the scene's content hash (io/film_state.h; the seed is fixed above), then the sample count.
  char key[32];
  std::snprintf(key, sizeof key, "%016llx", static_cast<unsigned long long>(scene_content_hash(desc)));
  const fs::path path = fs::path(o.cache_dir) / (file_stem(name) + "-" + std::to_string(desc.width) + "x" +
                                                 std::to_string(desc.height) + "-" + key + "-" +
                                                 std::to_string(spp) + "spp.pfm");
  label = "mis " + std::to_string(spp) + " spp, cached as " + path.filename().string();
  if (fs::exists(path)) return read_pfm(path.string());
  std::fprintf(stderr, "rendering the reference of %s (%lld spp, cached as %s)...\n", name.c_str(), spp, path.c_str());
  const auto scene = compile_scene(desc);
  Film film(desc.width, desc.height);
  const auto start = Clock::now();
  for (long long done = 0; done < spp;) {
    const int pass = static_cast<int>(std::min<long long>(64, spp - done));
    renderer.render_pass(*scene, desc.render, film, pass);
    done += pass;
    if (isatty(2)) std::fprintf(stderr, "\r  %lld / %lld spp, %.0f s", done, spp, seconds_since(start));
  }
  if (isatty(2)) std::fprintf(stderr, "\n");
  fs::create_directories(o.cache_dir);
  Image img = film_image(film);
  write_pfm(path.string(), img);
  return img;
}

// One progressive render, error recorded at each budget. The clock stops while the error is computed.
Series run_series(const std::string& name, const SceneDesc& desc, bool adaptive, const Image& ref,
                  const std::vector<double>& budgets, Renderer& renderer) {
  Series s{name, to_string(desc.render.estimator), std::string(to_string(desc.render.sampler)) + (adaptive ? "+adaptive" : ""),
           renderer.threads(), {}, 0, 0};
  const auto scene = compile_scene(desc);
  Film film(desc.width, desc.height);
  film.enable_features(true);  // for the denoised error at each budget (≈ 3 % more instructions per sample)
  Denoiser denoiser;
  FilmPlanes planes;
  std::vector<float> denoised;
  ProgressivePasses passes(renderer, *scene, desc.render, film, adaptive);
  for (double budget : budgets) {
    StopConditions stop;
    stop.seconds = budget;
    while (!stop_reason(stop, passes.passes_spp(), passes.busy_seconds(), 0.0))
      passes.render(passes.next_spp(budget - passes.busy_seconds(), stop, passes.passes_spp(), passes.busy_seconds()));
    const Image img = film_image(film);
    const auto d0 = Clock::now();
    planes.copy_from(film);
    denoiser.run(planes.input(), {}, renderer.pool(), denoised);
    const double denoise_seconds = seconds_since(d0);
    s.points.push_back({passes.busy_seconds(), passes.passes_spp(), relmse(img, ref), rmse(img, ref),
                        relmse(Image{img.width, img.height, denoised}, ref), denoise_seconds});
  }
  s.msamples_per_s = static_cast<double>(passes.samples()) / passes.busy_seconds() * 1e-6;
  s.mrays_per_s = static_cast<double>(passes.rays()) / passes.busy_seconds() * 1e-6;
  return s;
}

// Seconds at which the series first reaches `target` relMSE, interpolated on log–log axes; < 0 if never. With
// `denoised`, the denoised image's relMSE against render time plus the time to denoise it.
double time_to(const Series& s, double target, bool denoised = false) {
  auto error = [&](const Checkpoint& c) { return denoised ? c.denoised_relmse : c.relmse; };
  auto time = [&](const Checkpoint& c) { return denoised ? c.seconds + c.denoise_seconds : c.seconds; };
  for (size_t i = 0; i < s.points.size(); ++i) {
    if (error(s.points[i]) > target) continue;
    if (i == 0) return time(s.points[0]);
    const Checkpoint &a = s.points[i - 1], &b = s.points[i];
    const double f = std::log(error(a) / target) / std::log(error(a) / error(b));
    return std::exp(std::log(time(a)) + f * (std::log(time(b)) - std::log(time(a))));
  }
  return -1;
}

std::string fmt_time(double t) {
  if (t < 0) return "not reached";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2f s", t);
  return buf;
}

// Reports go through write_file_safely (complete or not at all, the earlier file kept on failure).
bool write_report(const fs::path& path, const std::string& text) {
  try {
    write_file_safely(path.string(), text);
    return true;
  } catch (const FileError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return false;
  }
}

// The plot files' name part, convergence-<stem>.{gp,png}: the scene's file_stem, kept apart from another scene's
// of the same stem by -2, -3, … (`taken` holds those given out).
std::string plot_stem(const std::string& scene, std::set<std::string>& taken) {
  const std::string stem = file_stem(scene);
  std::string name = stem;
  for (int k = 2; !taken.insert(name).second; ++k) name = stem + "-" + std::to_string(k);
  return name;
}

// A string as gnuplot reads it between single quotes (no escapes there; a quote is written twice).
std::string gnuplot_quoted(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("''") : std::string(1, c);
  return q + "'";
}

bool write_plot(const fs::path& dir, const std::string& scene, const std::string& stem,
                const std::vector<Series>& series, const std::string& ref_label) {
  const fs::path script = dir / ("convergence-" + stem + ".gp");
  std::ostringstream gp;
  gp << "# gnuplot script written by pathtracer bench; data in convergence.csv\n"
     << "set terminal pngcairo size 900,600 font ',11'\n"
     << "set output " << gnuplot_quoted((dir / ("convergence-" + stem + ".png")).string()) << "\n"
     << "set title " << gnuplot_quoted(scene + ": relMSE against wall-clock time (reference: " + ref_label + ")")
     << " noenhanced\n"
     << "set logscale xy\nset format y '%.0e'\nset grid\nset key outside right\n"
     << "set xlabel 'seconds'\nset ylabel 'relMSE'\nset datafile separator ','\n";
  gp << "plot ";
  const Series* anchor = nullptr;
  for (size_t i = 0; i < series.size(); ++i) {
    const Series& s = series[i];
    if (s.scene != scene) continue;
    if (!anchor || s.estimator == "mis") anchor = &s;
    gp << gnuplot_quoted((dir / "convergence.csv").string()) << " using ((strcol(1) eq " << gnuplot_quoted(s.scene)
       << " && strcol(2) eq '" << s.estimator << "' && strcol(3) eq '" << s.sampler
       << "') ? $5 : 1/0):7 with linespoints title '" << s.estimator << " / " << s.sampler << "', ";
  }
  // The 1/t slope of an unbiased Monte Carlo estimator, through the anchor series' first point.
  if (anchor && !anchor->points.empty())
    gp << anchor->points[0].relmse * anchor->points[0].seconds << "/x with lines dashtype 2 lc 'gray' title '1/t slope'";
  gp << "\n";
  if (!write_report(script, gp.str())) return false;
  const std::string cmd = "gnuplot " + shell_quote(script.string()) + " 2>/dev/null";
  return std::system("command -v gnuplot >/dev/null 2>&1") == 0 && std::system(cmd.c_str()) == 0;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v[v.size() / 2];
}

// The binary that --instructions counts, checked before any work (a long bench should not fail at its end):
// --instructions-binary, else this one; "" without --instructions. Returns 0 or the exit status.
int counted_binary_for(const BenchOptions& o, std::string& counted_binary) {
  if (!o.instructions_binary.empty()) {
    std::error_code ec;
    if (!fs::is_regular_file(o.instructions_binary, ec)) {
      std::fprintf(stderr, "error: --instructions-binary %s: no such file\n", o.instructions_binary.c_str());
      return 2;
    }
    counted_binary = fs::absolute(o.instructions_binary).string();
  } else if (o.instructions) {
    if (!this_binary_runs_under_valgrind()) {
      std::fprintf(stderr,
                   "error: --instructions: this pathtracer was compiled for AVX-512, which valgrind cannot run; build "
                   "one with cmake -DPT_ARCH=x86-64-v3 and pass it as --instructions-binary PATH "
                   "(docs/performance.md, \"Instruction counts\")\n");
      return 2;
    }
    std::error_code ec;
    counted_binary = fs::read_symlink("/proc/self/exe", ec).string();
    if (ec) {
      std::fprintf(stderr, "error: --instructions: cannot find this executable's path: %s\n", ec.message().c_str());
      return 2;
    }
  }
  return 0;
}

// Every scene × estimator × sampler as one progressive series against its reference. Returns 0 or the exit status.
int run_all_series(const BenchOptions& o, const std::vector<double>& budgets, Renderer& renderer,
                   std::vector<Series>& all, std::map<std::string, std::string>& ref_labels) {
  try {
    fs::create_directories(o.out_dir);
    for (const std::string& name : o.scenes) {
      SceneDesc desc = load_scene(name);
      if (o.quick) {  // 64 pixels wide, the scene's aspect ratio
        desc.height = std::max(1, desc.height * 64 / desc.width);
        desc.width = 64;
      }
      std::string label;
      const Image ref = reference_for(name, desc, o, renderer, label);
      ref_labels[name] = label;
      for (const std::string& est : o.estimators)
        for (const std::string& smp : o.samplers) {
          parse_enum(est, desc.render.estimator);
          const bool adaptive = smp.ends_with("+adaptive");
          parse_enum(adaptive ? smp.substr(0, smp.size() - 9) : smp, desc.render.sampler);
          std::fprintf(stderr, "%s / %s / %s: up to %.2f s...\n", name.c_str(), est.c_str(), smp.c_str(),
                       budgets.back());
          all.push_back(run_series(name, desc, adaptive, ref, budgets, renderer));
        }
    }
  } catch (const SceneError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  } catch (const ImageError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 0;
}

bool write_convergence_csv(const fs::path& dir, const std::vector<Series>& all) {
  std::ostringstream csv;
  csv << "scene,estimator,sampler,threads,seconds,spp,relMSE,RMSE,Mrays/s,denoised relMSE,denoise seconds\n";
  for (const Series& s : all)
    for (const Checkpoint& c : s.points)
      csv << s.scene << ',' << s.estimator << ',' << s.sampler << ',' << s.threads << ',' << c.seconds << ','
          << c.spp << ',' << c.relmse << ',' << c.rmse << ',' << s.mrays_per_s << ',' << c.denoised_relmse << ','
          << c.denoise_seconds << '\n';
  return write_report(dir / "convergence.csv", csv.str());
}

// Thread scaling and interactive pass times on cornell.
struct InteractiveFigures {
  double one_thread = 0, all_threads = 0;  // Msamples/s
  double full_wavefront_ms = 0, full_scalar_ms = 0, quarter_wavefront_ms = 0, quarter_scalar_ms = 0;
};
InteractiveFigures measure_interactive(const BenchOptions& o, Renderer& renderer) {
  const SceneDesc cornell = load_scene("cornell");
  auto throughput = [&](int threads) {
    Renderer r(threads);
    SceneDesc d = cornell;
    d.width = d.height = o.quick ? 64 : 256;
    const auto sc = compile_scene(d);
    Film film(d.width, d.height);
    r.render_pass(*sc, d.render, film, 1);  // warm-up
    const auto t0 = Clock::now();
    uint64_t samples = 0;
    while (seconds_since(t0) < (o.quick ? 0.3 : 2.0)) samples += r.render_pass(*sc, d.render, film, 1).samples;
    return static_cast<double>(samples) / seconds_since(t0) * 1e-6;
  };
  // 1-spp pass times of both path loops, alternated pass by pass so that machine noise hits both alike.
  auto pass_ms = [&](int size, double& wavefront, double& scalar) {
    SceneDesc d = cornell;
    d.width = d.height = size;
    const auto sc = compile_scene(d);
    Film film(size, size);
    std::vector<double> ms[2];
    for (int i = 0; i < (o.quick ? 5 : 30); ++i) {
      for (PathLoop loop : {PathLoop::Wavefront, PathLoop::Scalar}) {
        RenderSettings settings = d.render;
        settings.path_loop = loop;
        const auto t0 = Clock::now();
        renderer.render_pass(*sc, settings, film, 1);
        ms[loop == PathLoop::Scalar].push_back(seconds_since(t0) * 1e3);
      }
    }
    wavefront = median(ms[0]);
    scalar = median(ms[1]);
  };
  InteractiveFigures f;
  f.one_thread = throughput(1);
  f.all_threads = throughput(renderer.threads());
  pass_ms(512, f.full_wavefront_ms, f.full_scalar_ms);
  pass_ms(256, f.quarter_wavefront_ms, f.quarter_scalar_ms);
  return f;
}

// Ray casting alone, one thread, on each scene's own incoherent path rays.
std::string ray_casting_table(const BenchOptions& o) {
  std::string md = "\n## Ray casting (1 thread, incoherent path rays, median of 5 replays)\n\n"
                   "| scene | polygons | spheres | closest hit, Mrays/s | any hit (shadow half), Mrays/s |\n"
                   "|---|---|---|---|---|\n";
  for (const std::string& name : o.scenes) {
    const auto sc = compile_scene(load_scene(name));
    const RayBatch batch = record_path_rays(*sc, o.quick ? (1u << 14) : (1u << 20), 1);
    const RayThroughput t = measure_ray_throughput(*sc, batch, 5);
    char row[200];
    std::snprintf(row, sizeof row, "| %s | %zu | %zu | %.1f | %.1f |\n", name.c_str(), sc->polygons.size(),
                  sc->spheres.size(), t.closest_mrays_per_s, t.shadow_half_mrays_per_s);
    md += row;
  }
  return md;
}

// Instructions per sample under callgrind: a repeatable figure where wall-clock time is noisy.
std::string instructions_table(const BenchOptions& o, const std::string& counted_binary, const fs::path& dir) {
  if (counted_binary.empty()) return "";
  std::string md = "\n## Instructions per sample (callgrind, 1 thread, 64 px wide, sobol)\n\n"
                   "Per sample = (count at " + std::to_string(InstructionsPerSample::kHigh) +
                   " spp − count at 1 spp) / (pixels × " + std::to_string(InstructionsPerSample::kHigh - 1) +
                   "): set-up cancels. Binary: `" + counted_binary + "`.\n\n"
                   "| scene | estimator | instructions per sample |\n|---|---|---|\n";
  for (const std::string& name : o.scenes) {
    const SceneDesc d = load_scene(name);
    const int w = 64, h = std::max(1, d.height * 64 / d.width);
    for (const std::string& est : o.estimators) {
      std::fprintf(stderr, "%s / %s: counting instructions under valgrind...\n", name.c_str(), est.c_str());
      const InstructionsPerSample n =
          count_instructions_per_sample(counted_binary, name, est, w, h, (dir / "callgrind").string());
      char row[300];
      if (n.error.empty())
        std::snprintf(row, sizeof row, "| %s | %s | %.0f |\n", name.c_str(), est.c_str(), n.per_sample);
      else
        std::snprintf(row, sizeof row, "| %s | %s | failed: %s |\n", name.c_str(), est.c_str(), n.error.c_str());
      md += row;
    }
  }
  return md;
}

// The report: time against error per series, then the interactive figures.
std::string summary_markdown(const BenchOptions& o, const std::vector<Series>& all,
                             std::map<std::string, std::string>& ref_labels, double max_budget, int threads,
                             const InteractiveFigures& f) {
  std::ostringstream md;
  md << "# Run time against error\n\n"
     << "Threads: " << threads << ". relMSE = mean over pixels and channels of (x − R)²/(R² + 0.01). "
     << "Efficiency = 1/(relMSE × seconds) at the largest budget (higher is better). Denoised: the film at each "
        "budget through the denoiser (docs/denoising.md); its times include the denoising.\n\n";
  for (const std::string& name : o.scenes) md << "- reference of `" << name << "`: " << ref_labels[name] << "\n";
  md << "\n| scene | estimator | sampler | time to 1e-2 | time to 1e-3 | relMSE at " << max_budget
     << " s | efficiency | Msamples/s | Mrays/s | denoised: time to 1e-2 | denoised: time to 1e-3 | denoised relMSE at "
     << max_budget << " s |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const Series& s : all) {
    const Checkpoint& last = s.points.back();
    char row[500];
    std::snprintf(row, sizeof row, "| %s | %s | %s | %s | %s | %.3g | %.3g | %.2f | %.2f | %s | %s | %.3g |\n",
                  s.scene.c_str(), s.estimator.c_str(), s.sampler.c_str(), fmt_time(time_to(s, 1e-2)).c_str(),
                  fmt_time(time_to(s, 1e-3)).c_str(), last.relmse, 1.0 / (last.relmse * last.seconds),
                  s.msamples_per_s, s.mrays_per_s, fmt_time(time_to(s, 1e-2, true)).c_str(),
                  fmt_time(time_to(s, 1e-3, true)).c_str(), last.denoised_relmse);
    md << row;
  }
  char tail[600];
  std::snprintf(tail, sizeof tail,
                "\n## Thread scaling (cornell, %d², mis)\n\n1 thread: %.2f Msamples/s; %d threads: %.2f Msamples/s; "
                "scaling %.2f×.\n\n## Interactive passes (cornell, 1 spp, %d threads, median)\n\n512×512: %.1f ms; "
                "256×256 (quarter resolution): %.1f ms (wavefront loop; the scalar loop, alternated with it: %.1f "
                "ms and %.1f ms).\n",
                o.quick ? 64 : 256, f.one_thread, threads, f.all_threads, f.all_threads / f.one_thread, threads,
                f.full_wavefront_ms, f.quarter_wavefront_ms, f.full_scalar_ms, f.quarter_scalar_ms);
  md << tail;
  return md.str();
}

}  // namespace

int run_bench(const BenchOptions& o) {
  std::string counted_binary;
  if (const int status = counted_binary_for(o, counted_binary)) return status;
  std::vector<double> budgets;
  const double max_s = o.quick ? 0.5 : o.max_seconds;
  for (double b = o.quick ? 0.0625 : 0.25; b <= max_s * 1.0001; b *= 2) budgets.push_back(b);
  Renderer renderer(o.threads);
  std::vector<Series> all;
  std::map<std::string, std::string> ref_labels;
  if (const int status = run_all_series(o, budgets, renderer, all, ref_labels)) return status;

  const fs::path dir(o.out_dir);
  if (!write_convergence_csv(dir, all)) return 1;
  bool plotted = true;
  std::set<std::string> stems;
  for (const std::string& name : o.scenes)
    plotted &= write_plot(dir, name, plot_stem(name, stems), all, ref_labels[name]);
  const InteractiveFigures interactive = measure_interactive(o, renderer);
  std::string md = summary_markdown(o, all, ref_labels, budgets.back(), renderer.threads(), interactive);
  md += ray_casting_table(o) + instructions_table(o, counted_binary, dir);
  if (!plotted) md += "\n(gnuplot was not found or failed: the .gp scripts are written, the PNG plots are not.)\n";
  if (!write_report(dir / "summary.md", md)) return 1;
  std::printf("%s", md.c_str());
  std::printf("\nwrote %s/{convergence.csv,summary.md,convergence-*.png}\n", fs::absolute(dir).c_str());
  return 0;
}

}  // namespace pt
