// Adaptive sampling: where the next pass's samples go. The film's own variance estimate says which tiles are
// far from converged; they get more samples, converged-looking tiles fewer or none.
//
// Policy (per pass, with a budget of mean_spp samples per pixel on average):
// - every `uniform_every`-th pass, and every pass while any pixel has fewer than `min_spp` samples, is uniform,
//   so no pixel is starved and every variance estimate keeps being refreshed by fresh samples;
// - otherwise tile t gets samples in proportion to its share of the image's estimated squared error
//   E_t = Σ_pixels Var[mean]/(mean² + 0.01) (the relMSE it contributes), capped at 8× the mean.
// Deciding from a pixel's own past samples makes the stopping of a pixel's sampling depend weakly on its values;
// the uniform passes bound that effect, and the agreement test with the reference checks it stays invisible.
#pragma once
#include <vector>

#include "film/film.h"

namespace pt {

struct AdaptiveSettings {
  int uniform_every = 4;
  uint32_t min_spp = 8;
  int max_factor = 8;
};

// Samples per pixel for each tile (row-major tiles of `tile_size`) in pass number `pass_index` (0-based).
std::vector<int> plan_adaptive_pass(const Film& film, int tile_size, int mean_spp, uint64_t pass_index,
                                    const AdaptiveSettings& settings = {});

}  // namespace pt
