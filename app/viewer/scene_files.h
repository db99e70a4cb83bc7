// The viewer's files (docs/viewer.md, docs/reliability.md): the scene file the user opened or saved, which is
// the only existing file Save may offer to replace; the scene read ahead while the panels ask about unsaved
// edits; images and EXRs saved under new names in the output folder; and the recent-files list. Every outcome
// is a message for the status line, never an exception. ViewerModel owns one (its `files`).
#pragma once
#include <cstdint>
#include <future>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "render/render_session.h"
#include "scene/scene_desc.h"
#include "viewer/recent_files.h"

namespace pt {

// What a file action did, and the status line's message about it (an error when `error`: a failure, or a
// success whose recent-files list could not be written).
struct FileOutcome {
  bool ok = false;
  std::string message;
  bool error = !ok;
};

class SceneFiles {
 public:
  std::string output_dir = ".";   // saved images, EXRs and built-in scenes' save-as names go here
  RecentFiles* recent = nullptr;  // scene files loaded or saved are added here (the window owns it)

  // The file the scene was loaded from ("" for a built-in scene), or last saved to.
  const std::string& scene_file() const { return scene_file_; }
  // A scene was loaded from `spec`: it becomes the scene file when it is one (not a built-in name) and joins the
  // recent list. Returns "" or why the list could not be written.
  std::string note_loaded(const std::string& spec);

  // Reads `spec` ahead of loading it (a missing or broken file is reported before anyone is asked about unsaved
  // edits); take_read_ahead hands it over once, for the same spec.
  FileOutcome read_ahead(const std::string& spec);
  std::optional<SceneDesc> take_read_ahead(const std::string& spec);

  // What Save offers: the scene file when there is one (replacing it asks first); a built-in scene has none, so
  // it gets a name that does not exist yet in output_dir (NAME.json, else NAME-0001.json, ...).
  std::string suggested_save_path(const std::string& scene_name) const;
  // Writes the scene (atomically); never replaces an existing file unless `replace`; creates missing folders;
  // relative file references are rewritten to lead from the new file's folder. On success `path` becomes the
  // scene file and joins the recent list.
  FileOutcome save_scene(const std::string& path, bool replace, const SceneDesc& scene);
  // The displayed image as NAME-NNNN.png (the RGBA8 pixels as shown) and NAME-NNNN.pfm (the frame's linear
  // mean) under new names in output_dir. The outcome's message names the stem.
  FileOutcome save_image(const std::string& scene_name, const std::vector<uint8_t>& rgba8, const DisplayFrame& frame);
  // The film as one multi-layer OpenEXR, NAME-NNNN.exr in output_dir, written on the render thread between two
  // passes (the denoised layer too when `denoise`); poll_exr reports when it is done.
  FileOutcome start_exr(RenderSession& session, const std::string& scene_name, bool denoise);
  std::optional<FileOutcome> poll_exr();
  bool exr_saving() const { return exr_save_.valid(); }

 private:
  std::string scene_file_;
  std::optional<std::pair<std::string, SceneDesc>> read_ahead_;
  std::future<std::string> exr_save_;  // "saved NAME ..." when done
};

}  // namespace pt
