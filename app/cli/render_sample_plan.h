// Which sample indices a `render` process takes (docs/scale-out.md): its share of an MPI job, a --sample-range,
// or the continuation of a --resume'd state; checked before any work. Every rank of an MPI job runs the same
// steps and meets the others at the same collective calls.
#pragma once
#include <cstdint>
#include <optional>

#include "cli/mpi_world.h"
#include "cli/render_command.h"
#include "film/film.h"
#include "io/film_state.h"
#include "render/progressive.h"
#include "scene/scene_desc.h"

namespace pt {

struct SamplePlan {
  std::optional<MpiWorld> mpi;              // with --mpi
  std::optional<LoadedFilmState> resumed;   // with --resume (read by rank 0 alone with --mpi)
  uint32_t range_begin = 0, range_end = 0;  // --sample-range [begin, end); both 0 without one
  uint32_t resume_index = 0;                // with --mpi and --resume: the state's next index, one for every pixel

  bool root() const { return !mpi || mpi->root(); }
  int ranks() const { return mpi ? mpi->size() : 1; }
  // Whether every rank says `ok` (without --mpi, `ok` itself).
  bool all_ranks(bool ok) const;
};

// Starts MPI, parses --sample-range, reads and checks the --resume state (`features`: the outputs need the
// film's feature buffers). Returns 0, or the exit status after printing the error (every rank returns it).
int plan_samples(const RenderOptions& options, const SceneDesc& desc, bool features, SamplePlan& plan);

// This process's stop conditions: the options' (64 spp when none is given). With --mpi, rank r renders the
// sample indices [s0 + r·(S−s0)/N, s0 + (r+1)·(S−s0)/N) of every pixel for a target of S spp, s0 the resumed
// state's next index (0 without one), so the merged film has the straight render's bits (without an spp
// target, indices from s0 + r·(2^31 − s0)/N on); plan.range_begin is set to the rank's first index. The relMSE
// target is then the merged film's, checked across ranks by the loop: returned apart, and left out of `stop`.
struct RankStop {
  StopConditions stop;
  double merged_relmse_target = 0.0;  // with --mpi
};
RankStop plan_stop(const RenderOptions& options, SamplePlan& plan);

// The film the run adds to (the resumed one, or a new one from plan.range_begin) and its state's description.
// With --mpi the ranks' films gather features when the resumed state has them (rank 0 tells the others).
struct StartingFilm {
  Film film;
  FilmStateInfo info;
};
// needs_identity: the film's state will be written (--save-state), so its info carries the scene's hash.
StartingFilm start_film(const SceneDesc& desc, const std::string& scene_name, bool features, bool needs_identity,
                        SamplePlan& plan);

// Every rank's film on rank 0, merged exactly (io/film_state: double-double sums); nullopt on the other ranks.
// The states travel in the file format, so the checksum also covers the transfer. With --resume, rank 0 adds the
// resumed state's film, whose samples precede the ranks'.
std::optional<Film> merge_over_ranks(const SamplePlan& plan, const Film& film, const FilmStateInfo& info,
                                     double busy_seconds);

}  // namespace pt
