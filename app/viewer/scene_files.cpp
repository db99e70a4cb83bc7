#include "viewer/scene_files.h"

#include <filesystem>
#include <stdexcept>

#include "denoise/denoiser.h"
#include "io/film_exr.h"
#include "io/image_io.h"
#include "io/safe_file.h"
#include "scene/scene_json.h"
#include "viewer/output_files.h"

namespace pt {

namespace {

namespace fs = std::filesystem;

void create_folder(const std::string& dir) {
  std::error_code ec;
  if (!dir.empty() && !fs::exists(dir) && !fs::create_directories(dir, ec) && ec)
    throw std::runtime_error("cannot create folder " + dir + ": " + ec.message());
}

}  // namespace

std::string SceneFiles::note_loaded(const std::string& spec) {
  scene_file_ = fs::is_regular_file(spec) ? spec : "";
  if (recent && !scene_file_.empty()) return recent->add(spec);
  return "";
}

FileOutcome SceneFiles::read_ahead(const std::string& spec) {
  try {
    read_ahead_.emplace(spec, load_scene(spec));
  } catch (const std::exception& e) {  // SceneError, and anything else a broken file might raise
    read_ahead_.reset();
    return {false, e.what()};
  }
  return {true, ""};
}

std::optional<SceneDesc> SceneFiles::take_read_ahead(const std::string& spec) {
  std::optional<SceneDesc> out;
  if (read_ahead_ && read_ahead_->first == spec) out = std::move(read_ahead_->second);
  read_ahead_.reset();
  return out;
}

std::string SceneFiles::suggested_save_path(const std::string& scene_name) const {
  if (!scene_file_.empty()) return scene_file_;
  const fs::path plain = fs::path(output_dir) / (scene_name + ".json");
  std::error_code ec;
  if (!fs::exists(plain, ec) && !ec) return plain.string();
  return unique_output_stem(output_dir, scene_name, {".json"}) + ".json";
}

FileOutcome SceneFiles::save_scene(const std::string& path, bool replace, const SceneDesc& scene) {
  if (path.empty()) return {false, "scene not saved: enter a file name"};
  std::error_code ec;
  if (!replace && fs::exists(path, ec))
    return {false, "scene not saved: " + path + " exists (replace it, or choose another name)"};
  try {
    const fs::path parent = fs::path(path).parent_path();
    create_folder(parent.string());
    // Files the scene refers to (a mesh, an environment map) are named from the saved file's folder.
    write_file_safely(path, scene_to_json(scene, parent.string()));
  } catch (const std::exception& e) {
    return {false, std::string("scene not saved: ") + e.what()};
  }
  scene_file_ = path;
  if (recent)  // a saved scene is one to open again, and its folder the next save's default
    if (std::string err = recent->add(path); !err.empty()) return {true, err, true};
  return {true, "saved scene " + path};
}

FileOutcome SceneFiles::save_image(const std::string& scene_name, const std::vector<uint8_t>& rgba8,
                                   const DisplayFrame& frame) {
  if (frame.width <= 0 || frame.height <= 0) return {false, "no image to save yet"};
  std::string stem;
  try {
    create_folder(output_dir);
    stem = unique_output_stem(output_dir, scene_name, {".png", ".pfm"});
    write_png_rgba8(stem + ".png", frame.width, frame.height, rgba8);
    Image img{frame.width, frame.height, std::vector<float>(3ull * frame.width * frame.height)};
    for (size_t i = 0, n = static_cast<size_t>(frame.width) * frame.height; i < n; ++i)
      for (int c = 0; c < 3; ++c) img.rgb[3 * i + c] = frame.rgba[4 * i + c];
    write_pfm(stem + ".pfm", img);
  } catch (const std::exception& e) {
    return {false, std::string("image not saved: ") + e.what()};
  }
  return {true, stem};
}

FileOutcome SceneFiles::start_exr(RenderSession& session, const std::string& scene_name, bool denoise) {
  if (exr_save_.valid()) return {false, "an EXR is being written already", false};
  const std::string dir = output_dir, name = scene_name;
  // Runs on the render thread with the film itself (no copy); the name is chosen there, so two saves in a row
  // never take the same one.
  exr_save_ = session.with_film([dir, name, denoise](const Film& film) -> std::string {
    create_folder(dir);
    const std::string path = unique_output_stem(dir, name, {".exr"}) + ".exr";
    FilmExrOptions options;
    for (const auto& entry : enum_entries<Aov>())
      if (entry.value != Aov::Denoised && (film.has_features() || !aov_needs_features(entry.value)))
        options.aovs.push_back(entry.value);
    std::vector<float> denoised;
    if (denoise && film.has_features()) {  // the final-frame filter, as render --denoise writes it
      ThreadPool pool(0);
      denoised = denoise_film(film, DenoiseMethod::Regression, pool);
      options.aovs.push_back(Aov::Denoised);
      options.denoised = &denoised;
    }
    write_film_exr(path, film, options);
    return "saved " + path + " (" + std::to_string(film.min_count()) + " spp, " +
           std::to_string(options.aovs.size() + 1) + " layers)";
  });
  return {true, "writing the EXR at the next pass boundary..."};
}

std::optional<FileOutcome> SceneFiles::poll_exr() {
  if (!exr_save_.valid() || exr_save_.wait_for(std::chrono::seconds(0)) != std::future_status::ready)
    return std::nullopt;
  try {
    return FileOutcome{true, exr_save_.get()};
  } catch (const std::exception& e) {
    return FileOutcome{false, std::string("EXR not saved: ") + e.what()};
  }
}

}  // namespace pt
