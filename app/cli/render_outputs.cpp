#include "cli/render_outputs.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>

#include "core/memory_budget.h"
#include "denoise/denoiser.h"
#include "film/film.h"
#include "io/image_io.h"
#include "io/safe_file.h"

namespace pt {

std::string scene_stem(const std::string& spec) {
  const std::filesystem::path p(spec);
  return p.has_extension() || spec.find('/') != std::string::npos ? p.stem().string() : spec;
}

namespace {

// The same file, whether it exists yet or not (links and relative paths resolved).
bool same_file(const std::string& a, const std::string& b) {
  if (file_id(a) == file_id(b)) return true;
  std::error_code ea, eb;
  const auto ca = std::filesystem::weakly_canonical(std::filesystem::absolute(a), ea);
  const auto cb = std::filesystem::weakly_canonical(std::filesystem::absolute(b), eb);
  return !ea && !eb && ca == cb;
}

// The layers of --exr: those named, or all (the denoised one only with --denoise); nullopt after the error.
std::optional<std::vector<Aov>> plan_layers(const RenderOptions& o) {
  std::vector<Aov> aovs;
  if (o.exr.empty()) return aovs;
  if (o.aovs.empty()) {
    for (const auto& entry : enum_entries<Aov>())
      if (entry.value != Aov::Denoised || o.denoise) aovs.push_back(entry.value);
  }
  for (const std::string& name : o.aovs) {
    Aov a = Aov::Albedo;
    parse_enum(name, a);  // checked against the table by the command line
    if (std::find(aovs.begin(), aovs.end(), a) != aovs.end()) continue;
    if (a == Aov::Denoised && !o.denoise) {
      std::fprintf(stderr, "error: --aov denoised: needs --denoise\n");
      return std::nullopt;
    }
    aovs.push_back(a);
  }
  return aovs;
}

}  // namespace

std::optional<OutputPlan> plan_outputs(const RenderOptions& o) {
  if (!o.aovs.empty() && o.exr.empty()) {
    std::fprintf(stderr, "error: --aov: needs --exr (the layers are written into that file)\n");
    return std::nullopt;
  }
  if (!o.denoised_pfm.empty() && !o.denoise) {
    std::fprintf(stderr, "error: --denoised-pfm: needs --denoise\n");
    return std::nullopt;
  }
  if (!o.denoiser.empty() && !o.denoise) {
    std::fprintf(stderr, "error: --denoiser: needs --denoise\n");
    return std::nullopt;
  }
  std::optional<std::vector<Aov>> aovs = plan_layers(o);
  if (!aovs) return std::nullopt;
  OutputPlan plan;
  plan.aovs = std::move(*aovs);
  plan.features = o.denoise || std::any_of(plan.aovs.begin(), plan.aovs.end(), aov_needs_features);
  std::vector<OutputFile>& files = plan.files;
  if (!o.png.empty()) files.push_back({"--png", o.png});
  if (!o.pfm.empty()) files.push_back({"--pfm", o.pfm});
  if (files.empty() && o.exr.empty()) {
    files.push_back({"--png", scene_stem(o.scene) + ".png"});
    files.push_back({"--pfm", scene_stem(o.scene) + ".pfm"});
  }
  if (!o.exr.empty()) files.push_back({"--exr", o.exr});
  if (!o.denoised_pfm.empty()) files.push_back({"--denoised-pfm", o.denoised_pfm});
  if (!o.save_state.empty()) files.push_back({"--save-state", o.save_state});
  return plan;
}

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

int OutputWriter::write(const Film& f, double seconds, bool checkpoint) const {
  const RenderOptions& o = options;
  const Image img{f.width(), f.height(), f.mean_image()};
  // The denoised image (on the renderer's threads), shown by the PNG; the PFM stays the raw estimate.
  std::vector<float> denoised;
  if (o.denoise) {
    const auto denoise_start = std::chrono::steady_clock::now();
    DenoiseMethod method = DenoiseMethod::Regression;
    if (!o.denoiser.empty()) parse_enum(o.denoiser, method);
    denoised = denoise_film(f, method, pool);
    if (!checkpoint)
      std::printf("denoised in %.1f ms\n",
                  std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - denoise_start).count());
  }
  DisplaySettings display;
  display.exposure_ev = o.exposure;
  parse_enum(o.tonemap, display.tone_map);  // checked against the table by the command line
  int failed = 0;
  for (const OutputFile& out : plan.files) {
    try {
      const std::string flag = out.flag;
      if (flag == "--png") write_png(out.path, o.denoise ? Image{img.width, img.height, denoised} : img, display);
      else if (flag == "--pfm") write_pfm(out.path, img);
      else if (flag == "--denoised-pfm") write_pfm(out.path, Image{img.width, img.height, denoised});
      else if (flag == "--save-state") {
        FilmStateInfo info = state_info;
        info.render_seconds += seconds;
        if (merged_ranks) info.sample_begin = 0;
        write_film_state(out.path, f, info);
      }
      else write_film_exr(out.path, f, {plan.aovs, o.exr_half, o.denoise ? &denoised : nullptr});
      if (!checkpoint) std::printf("wrote %s\n", std::filesystem::absolute(out.path).c_str());
    } catch (const std::runtime_error& e) {  // ImageError, FilmStateError
      std::fprintf(stderr, "error: %s: %s\n", out.flag, e.what());
      ++failed;
    }
  }
  if (checkpoint)
    std::fprintf(stderr, "checkpoint at %.1f s: %u spp written%s\n", seconds, f.min_count(), failed ? " (with errors)" : "");
  return failed;
}

}  // namespace pt
