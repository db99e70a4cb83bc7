// Instructions per sample, counted by valgrind's callgrind: a repeatable measure of the work a sample costs,
// unlike wall-clock time on a shared machine (docs/performance.md, "Instruction counts"). Used by
// `pathtracer bench --instructions`.
//
// valgrind does not decode AVX-512, so the counted binary must be built without it (-DPT_ARCH=x86-64-v3): the
// bench's own executable when it was, else the one given by --instructions-binary.
#pragma once
#include <cstdint>
#include <optional>
#include <string>

namespace pt {

// The total instruction count of a callgrind run, from its log ("==PID== Collected : N"); none if absent.
std::optional<uint64_t> parse_callgrind_total(const std::string& log);

// The command line of one counted render: `render -q --threads 1` of `scene` with `estimator` and the Sobol
// sampler at width × height and `spp` samples per pixel, the PFM written to `pfm`.
std::string counted_render_command(const std::string& binary, const std::string& scene, const std::string& estimator,
                                   int width, int height, int spp, const std::string& pfm);

// The name (no directory) of one counted render's files: scene, estimator and spp, as file_name_part makes them
// (cli/file_names.h: a scene may be a file path).
std::string counted_file_stem(const std::string& scene, const std::string& estimator, int spp);

struct InstructionsPerSample {
  double per_sample = 0;  // (count at kHigh spp − count at 1 spp) / (pixels × (kHigh − 1)): set-up cancels
  std::string error;  // non-empty: the count failed, and why
  static constexpr int kHigh = 16;
};

// Runs `valgrind --tool=callgrind` on `binary` twice (1 and kHigh spp); its files go to `work_dir`.
InstructionsPerSample count_instructions_per_sample(const std::string& binary, const std::string& scene,
                                                    const std::string& estimator, int width, int height,
                                                    const std::string& work_dir);

// Whether this executable may run under valgrind (false: it was compiled for AVX-512).
bool this_binary_runs_under_valgrind();

}  // namespace pt
