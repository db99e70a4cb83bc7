#include "cli/render_command.h"

#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <filesystem>

#include "render/film.h"
#include "io/image_io.h"
#include "cli/progress.h"
#include "render/progressive.h"
#include "render/renderer.h"
#include "cli/scene_arg.h"
#include "scene/scene_json.h"

namespace pt {

void add_render_command(CLI::App& app, RenderOptions& o) {
  CLI::App* r = app.add_subcommand("render", "Render a scene headless to PNG (tone-mapped) and PFM (linear radiance)");
  r->add_option("--scene", o.scene,
                "Scene: a built-in name (cornell, cornell-spheres, shadertoy, materials, sky) or a .json file path")
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
  r->add_option("--estimator", o.estimator, enum_names_joined<Estimator>(" | ") + " (overrides render.estimator)")
      ->check(CLI::IsMember(enum_name_list<Estimator>()));
  r->add_option("--sampler", o.sampler, enum_names_joined<SamplerType>(" | ") + " (overrides render.sampler)")
      ->check(CLI::IsMember(enum_name_list<SamplerType>()));
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
  if (o.estimator) parse_enum(*o.estimator, desc.render.estimator);
  if (o.sampler) parse_enum(*o.sampler, desc.render.sampler);
  desc.render.generic_kernel = o.generic_kernel;
  if (std::string err = validate_scene(desc); !err.empty()) {
    std::fprintf(stderr, "error: %s: %s\n", o.scene.c_str(), err.c_str());
    return 2;
  }
  const auto scene = compile_scene(desc);

  StopConditions stop;
  if (o.spp) stop.spp = static_cast<uint64_t>(*o.spp);
  if (o.time_seconds) stop.seconds = *o.time_seconds;
  if (o.target_relmse) stop.relmse = *o.target_relmse;
  const bool no_stop = !stop.any();
  if (no_stop) stop.spp = 64;

  Film film(desc.width, desc.height);
  Renderer renderer(o.threads);
  Progress progress(!o.quiet);
  using clock = std::chrono::steady_clock;
  const auto start = clock::now();
  auto elapsed = [&] { return std::chrono::duration<double>(clock::now() - start).count(); };

  uint64_t spp = 0, samples = 0, rays = 0, pass_index = 0;
  double seconds_per_spp = 0.0;
  // Passes of about half a second keep the progress line and the stop checks timely.
  constexpr double kPassSeconds = 0.5;
  while (!stop_reason(stop, spp, elapsed(), film.estimated_relmse())) {
    const int pass = next_pass_spp(seconds_per_spp, kPassSeconds, stop, spp, elapsed());
    const auto pass_start = clock::now();
    const PassStats ps = run_pass(renderer, *scene, desc.render, film, pass, o.adaptive, pass_index);
    seconds_per_spp = std::chrono::duration<double>(clock::now() - pass_start).count() / pass;
    spp += static_cast<uint64_t>(pass);
    samples += ps.samples;
    rays += ps.rays;
    double fraction = -1.0;
    if (stop.spp) fraction = static_cast<double>(spp) / static_cast<double>(stop.spp);
    if (stop.seconds > 0.0) fraction = std::max(fraction, elapsed() / stop.seconds);
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
