// `pathtracer render`: the headless renderer.
#pragma once
#include <optional>
#include <string>
#include <vector>

namespace CLI {
class App;
}

namespace pt {

struct RenderOptions {
  std::string scene = "cornell";
  std::optional<int> width, height, bounces, rr_depth;
  std::optional<long long> spp;
  std::optional<double> time_seconds, target_relmse;
  std::optional<std::string> estimator, sampler;
  std::optional<unsigned long long> seed;
  int threads = 0;
  std::string png, pfm;
  std::string exr;                 // multi-layer OpenEXR (io/film_exr.h)
  std::vector<std::string> aovs;   // its layers; empty = all
  bool exr_half = false;
  bool denoise = false;
  std::string denoised_pfm;
  std::string denoiser;  // DenoiseMethod name; empty: regression
  float exposure = 0.f;
  std::string tonemap = "clamp";
  bool quiet = false;
  bool adaptive = false;
  bool generic_kernel = false;
  std::string path_loop = "auto";
  std::string instancing = "auto";
  std::vector<int> bdpt_strategy;  // s,t: only that strategy, unweighted (diagnostic)
  bool no_manifold = false;        // bdpt without its manifold strategy (diagnostic)
  std::string save_state;          // write the film's accumulation state here (io/film_state.h)
  std::string resume;              // continue from this state
  std::string sample_range;        // "A:B": render sample indices [A, B) of every pixel
  bool mpi = false;                // spread the render over the ranks of an MPI job (cli/mpi_world.h)
  double checkpoint_seconds = 0;   // write the outputs (merged, with --mpi) every this many seconds; 0 = at the end
};

void add_render_command(CLI::App& app, RenderOptions& options);
// Exit status: 0 done, 1 output could not be written, 2 bad input (scene file or options).
int run_render(const RenderOptions& options);

}  // namespace pt
