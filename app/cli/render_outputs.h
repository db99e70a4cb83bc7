// `render`'s outputs: which files it writes (planned and checked before the first sample, so a long render is
// never lost to a typo) and writing them from a film, at the end and at each checkpoint.
#pragma once
#include <optional>
#include <string>
#include <vector>

#include "cli/render_command.h"
#include "io/film_exr.h"
#include "io/film_state.h"

namespace pt {

class Film;
class ThreadPool;

// NAME of a scene argument: a file's stem, or the built-in scene's name (default outputs NAME.png, NAME.pfm).
std::string scene_stem(const std::string& spec);

struct OutputFile {
  const char* flag;  // the option that named it ("--png"), which also says what is written
  std::string path;
};

struct OutputPlan {
  std::vector<OutputFile> files;  // in the order they are written; NAME.png and NAME.pfm when none is named
  std::vector<Aov> aovs;          // the layers of --exr
  bool features = false;          // the film gathers per-pixel features (denoising, feature layers)
};

// The output options checked against each other (--aov needs --exr, --denoised-pfm needs --denoise, ...);
// nullopt after printing the error.
std::optional<OutputPlan> plan_outputs(const RenderOptions& options);

// Outputs that cannot be written, that are the scene being rendered, or that name one file twice are refused.
bool check_outputs(const std::vector<OutputFile>& outputs, const std::string& scene_spec);

// Whether the film and the output images fit the memory budget, estimated before anything is allocated.
bool check_film_memory(int width, int height, bool features, bool layers);

// Writes every planned output from a film (the merged one with --mpi). Each output on its own: one that fails
// does not keep the others from being written.
struct OutputWriter {
  const RenderOptions& options;
  const OutputPlan& plan;
  FilmStateInfo state_info;  // for --save-state; render_seconds are those before this run
  bool merged_ranks = false;  // the film holds every rank's samples from index 0
  ThreadPool& pool;           // denoises on the renderer's threads

  // Returns the number of outputs that failed. A checkpoint prints one line instead of the files' names.
  int write(const Film& film, double seconds, bool checkpoint) const;
};

}  // namespace pt
