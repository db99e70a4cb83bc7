#include "render_command.h"

#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <filesystem>

#include "adaptive.h"
#include "film.h"
#include "image_io.h"
#include "progress.h"
#include "renderer.h"
#include "scene_arg.h"
#include "scene_json.h"

namespace pt {

void add_render_command(CLI::App& app, RenderOptions& o) {
  CLI::App* r = app.add_subcommand("render", "Render a scene headless to PNG (tone-mapped) and PFM (linear radiance)");
  r->add_option("--scene", o.scene,
                "Scene: a built-in name (cornell, cornell-spheres, shadertoy) or a .json file path")
      ->capture_default_str();
  r->add_option("--width", o.width, "Image width in pixels (overrides the scene's film.width)")->check(CLI::Range(1, 16384));
  r->add_option("--height", o.height, "Image height in pixels (overrides film.height)")->check(CLI::Range(1, 16384));
  r->add_option("--spp", o.spp, "Stop after N samples per pixel (default 64 when no stop condition is given)")
      ->check(CLI::Range(1LL, 1LL << 31));
  r->add_option("--time", o.time_seconds, "Stop after this many seconds of rendering")->check(CLI::PositiveNumber);
  r->add_option("--target-relmse", o.target_relmse,
                "Stop when the film's own estimate of relMSE falls to E (checked after each pass, from 16 spp on)")
      ->check(CLI::PositiveNumber);
  r->add_option("--bounces", o.bounces, "Max scattering events after the first hit (overrides render.max_bounces)")
      ->check(CLI::Range(0, 1 << 30));
  r->add_option("--estimator", o.estimator, "uniform | cosine | nee | mis (overrides render.estimator)")
      ->check(CLI::IsMember({"uniform", "cosine", "nee", "mis"}));
  r->add_option("--sampler", o.sampler, "independent | sobol (overrides render.sampler)")
      ->check(CLI::IsMember({"independent", "sobol"}));
  r->add_option("--rr-depth", o.rr_depth, "Russian roulette from this bounce on; -1 = off (overrides the scene)")
      ->check(CLI::Range(-1, 1 << 30));
  r->add_option("--seed", o.seed, "Random seed (overrides render.seed); same seed, same image");
  r->add_option("--threads", o.threads, "Render threads; 0 = all hardware threads")
      ->check(CLI::Range(0, 1024))
      ->capture_default_str();
  r->add_option("--png", o.png, "Write the tone-mapped 8-bit sRGB image here");
  r->add_option("--pfm", o.pfm, "Write the linear mean radiance (float PFM) here");
  r->add_option("--exposure", o.exposure, "PNG exposure in EV stops")->capture_default_str();
  r->add_option("--tonemap", o.tonemap, "PNG tone map: clamp | reinhard | aces")
      ->check(CLI::IsMember({"clamp", "reinhard", "aces"}))
      ->capture_default_str();
  r->add_flag("--adaptive", o.adaptive,
              "Adaptive sampling: passes spend samples where the film's error estimate is high (every 4th pass uniform)");
  r->add_flag("--generic-kernel", o.generic_kernel,
              "Diagnostic: run the kernel compiled for every scene feature instead of the one specialised for this "
              "scene (same image, more work; for instruction-count comparisons)");
  r->add_flag("--quiet,-q", o.quiet, "No progress line");
  r->footer(
      "With neither --png nor --pfm, writes NAME.png and NAME.pfm in the current directory (NAME = scene name).\n"
      "Stop conditions combine: rendering stops at the first one met. Exit status: 0 ok, 1 cannot write output,\n"
      "2 invalid scene or options.");
}

namespace {

std::string scene_stem(const std::string& spec) {
  const std::filesystem::path p(spec);
  return p.has_extension() || spec.find('/') != std::string::npos ? p.stem().string() : spec;
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
  if (o.estimator) parse_estimator(*o.estimator, desc.render.estimator);
  if (o.sampler) parse_sampler(*o.sampler, desc.render.sampler);
  desc.render.generic_kernel = o.generic_kernel;
  if (std::string err = validate_scene(desc); !err.empty()) {
    std::fprintf(stderr, "error: %s: %s\n", o.scene.c_str(), err.c_str());
    return 2;
  }
  const auto scene = compile_scene(desc);

  const bool no_stop = !o.spp && !o.time_seconds && !o.target_relmse;
  const uint64_t max_spp = o.spp ? static_cast<uint64_t>(*o.spp) : (no_stop ? 64 : UINT64_MAX);

  Film film(desc.width, desc.height);
  Renderer renderer(o.threads);
  Progress progress(!o.quiet);
  using clock = std::chrono::steady_clock;
  const auto start = clock::now();
  auto elapsed = [&] { return std::chrono::duration<double>(clock::now() - start).count(); };

  uint64_t spp = 0, samples = 0, rays = 0, pass_index = 0;
  double seconds_per_spp = 0.0;
  for (;;) {
    const double t = elapsed();
    if (spp >= max_spp) break;
    if (o.time_seconds && t >= *o.time_seconds) break;
    if (o.target_relmse && spp >= 16 && film.estimated_relmse() <= *o.target_relmse) break;
    // Size passes to about half a second (bounded by what is left) so progress and stop checks stay timely.
    uint64_t pass = 1;
    if (seconds_per_spp > 0.0) pass = static_cast<uint64_t>(std::max(1.0, 0.5 / seconds_per_spp));
    if (o.time_seconds && seconds_per_spp > 0.0)
      pass = std::min<uint64_t>(pass, static_cast<uint64_t>(std::max(1.0, (*o.time_seconds - t) / seconds_per_spp)));
    pass = std::min<uint64_t>({pass, max_spp - spp, 256});
    const auto pass_start = clock::now();
    const PassStats ps =
        o.adaptive ? renderer.render_pass(*scene, film,
                                          plan_adaptive_pass(film, Renderer::kTileSize, static_cast<int>(pass), pass_index++))
                   : renderer.render_pass(*scene, film, static_cast<int>(pass));
    const double pass_seconds = std::chrono::duration<double>(clock::now() - pass_start).count();
    seconds_per_spp = pass_seconds / static_cast<double>(pass);
    spp += pass;
    samples += ps.samples;
    rays += ps.rays;
    double fraction = -1.0;
    if (o.spp || no_stop) fraction = static_cast<double>(spp) / static_cast<double>(max_spp);
    if (o.time_seconds) fraction = std::max(fraction, elapsed() / *o.time_seconds);
    progress.update(std::min(fraction, 1.0), elapsed(), spp, static_cast<double>(samples) / elapsed());
  }
  progress.finish();
  const double seconds = elapsed();

  std::printf("%s %dx%d %s/%s: %llu spp in %.2f s, %.2f Msamples/s, %.2f Mrays/s, estimated relMSE %.3g, "
              "%llu non-finite samples rejected\n",
              o.scene.c_str(), desc.width, desc.height, to_string(desc.render.estimator), to_string(desc.render.sampler),
              static_cast<unsigned long long>(spp), seconds, static_cast<double>(samples) / seconds * 1e-6,
              static_cast<double>(rays) / seconds * 1e-6, film.estimated_relmse(),
              static_cast<unsigned long long>(film.rejected()));

  std::string png = o.png, pfm = o.pfm;
  if (png.empty() && pfm.empty()) {
    png = scene_stem(o.scene) + ".png";
    pfm = scene_stem(o.scene) + ".pfm";
  }
  const Image img{desc.width, desc.height, film.mean_image()};
  try {
    if (!png.empty()) {
      DisplaySettings display;
      display.exposure_ev = o.exposure;
      display.tone_map = o.tonemap == "reinhard" ? ToneMap::Reinhard
                         : o.tonemap == "aces"   ? ToneMap::AcesFitted
                                                 : ToneMap::Clamp;
      write_png(png, img, display);
      std::printf("wrote %s\n", std::filesystem::absolute(png).c_str());
    }
    if (!pfm.empty()) {
      write_pfm(pfm, img);
      std::printf("wrote %s\n", std::filesystem::absolute(pfm).c_str());
    }
  } catch (const ImageError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 0;
}

}  // namespace pt
