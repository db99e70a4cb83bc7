#include "cli/render_sample_plan.h"

#include <cstdio>
#include <string>
#include <vector>

#include "scene/scene_identity.h"

namespace pt {

bool SamplePlan::all_ranks(bool ok) const {
  if (!mpi) return ok;
  std::vector<int64_t> failed{ok ? 0 : 1};
  mpi->max_all(failed);
  return failed[0] == 0;
}

namespace {

// "A:B" into [A, B); false after printing the error.
bool parse_sample_range(const RenderOptions& o, SamplePlan& plan) {
  unsigned long long a = 0, b = 0;
  char tail = 0;
  if (std::sscanf(o.sample_range.c_str(), "%llu:%llu%c", &a, &b, &tail) != 2 || a >= b || b > (1ull << 31)) {
    std::fprintf(stderr, "error: --sample-range %s: expected A:B with 0 <= A < B <= 2^31 (sample indices A to B-1)\n",
                 o.sample_range.c_str());
    return false;
  }
  if (o.spp || !o.resume.empty()) {
    std::fprintf(stderr, "error: --sample-range: %s (the range gives the samples)\n",
                 o.spp ? "not with --spp" : "not with --resume");
    return false;
  }
  plan.range_begin = static_cast<uint32_t>(a);
  plan.range_end = static_cast<uint32_t>(b);
  return true;
}

// Reads the state on rank 0 and checks it against the scene and the outputs; false after printing the error.
bool read_resumed_state(const RenderOptions& o, const SceneDesc& desc, bool features, SamplePlan& plan) {
  if (o.resume.empty() || !plan.root()) return true;
  try {
    plan.resumed = read_film_state(o.resume);
  } catch (const FilmStateError& e) {
    std::fprintf(stderr, "error: --resume: %s\n", e.what());
    return false;
  }
  if (std::string why = resume_problem(plan.resumed->info, desc); !why.empty()) {
    std::fprintf(stderr, "error: --resume %s: cannot continue %s with it: %s\n", o.resume.c_str(), o.scene.c_str(),
                 why.c_str());
    return false;
  }
  if (features && !plan.resumed->film.has_features()) {
    std::fprintf(stderr, "error: --resume %s: the state has no feature buffers, which --denoise and the feature "
                 "layers need (start it with them)\n", o.resume.c_str());
    return false;
  }
  if (!plan.mpi) return true;
  // The ranks continue from one index for every pixel: a state whose pixels stopped at different indices (a pass
  // interrupted mid-way) is resumed in one process.
  const Film& f = plan.resumed->film;
  plan.resume_index = f.next_sample_index(0);
  for (size_t i = 1; i < f.pixel_count(); ++i)
    if (f.next_sample_index(i) != plan.resume_index) {
      std::fprintf(stderr, "error: --resume %s: its pixels stopped at different sample indices (an interrupted "
                   "pass); resume it without --mpi first\n", o.resume.c_str());
      return false;
    }
  return true;
}

}  // namespace

int plan_samples(const RenderOptions& o, const SceneDesc& desc, bool features, SamplePlan& plan) {
  if (o.mpi) {
    if (!o.sample_range.empty()) {
      std::fprintf(stderr, "error: --mpi: not with --sample-range (the ranks share out the sample indices themselves)\n");
      return 2;
    }
    try {
      plan.mpi.emplace(nullptr, nullptr);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "error: --mpi: %s\n", e.what());
      return 2;
    }
  }
  if (!o.sample_range.empty() && !parse_sample_range(o, plan)) return 2;
  const bool resume_ok = read_resumed_state(o, desc, features, plan);
  if (!resume_ok) plan.resumed.reset();
  if (!plan.mpi) return resume_ok ? 0 : 2;
  std::vector<int64_t> v{resume_ok ? 0 : 1, plan.resume_index};  // rank 0 tells the others
  plan.mpi->max_all(v);
  if (v[0]) return 2;
  plan.resume_index = static_cast<uint32_t>(v[1]);
  return 0;
}

RankStop plan_stop(const RenderOptions& o, SamplePlan& plan) {
  RankStop r;
  StopConditions& stop = r.stop;
  if (o.spp) stop.spp = static_cast<uint64_t>(*o.spp);
  if (o.time_seconds) stop.seconds = *o.time_seconds;
  if (o.target_relmse) stop.relmse = *o.target_relmse;
  if (plan.range_end > 0) stop.spp = plan.range_end - plan.range_begin;
  if (!stop.any()) stop.spp = 64;
  if (!plan.mpi) return r;
  const uint64_t total = stop.spp, s0 = plan.resume_index, rank = plan.mpi->rank(), ranks = plan.ranks();
  if (total > 0) {
    const uint64_t todo = total > s0 ? total - s0 : 0;
    plan.range_begin = static_cast<uint32_t>(s0 + todo * rank / ranks);
    stop.spp = s0 + todo * (rank + 1) / ranks - plan.range_begin;
  } else {
    plan.range_begin = static_cast<uint32_t>(s0 + ((uint64_t{1} << 31) - s0) / ranks * rank);
  }
  r.merged_relmse_target = stop.relmse;
  stop.relmse = 0.0;
  return r;
}

StartingFilm start_film(const SceneDesc& desc, const std::string& scene_name, bool features, bool needs_identity,
                        SamplePlan& plan) {
  StartingFilm s;
  // The scene's content hash goes only into film states (--save-state, the ranks' merge): hashing a million
  // triangles takes a tenth of a second that a plain render need not spend.
  s.info = state_info_for(desc, scene_name, needs_identity || plan.mpi);
  bool film_features = features || (plan.resumed && plan.resumed->film.has_features());
  if (plan.mpi) {
    std::vector<int64_t> v{film_features ? 1 : 0};
    plan.mpi->max_all(v);
    film_features = v[0] != 0;
  }
  if (plan.resumed && !plan.mpi) {
    s.film = std::move(plan.resumed->film);  // its features stay as saved
    s.info.sample_begin = plan.resumed->info.sample_begin;
    s.info.render_seconds = plan.resumed->info.render_seconds;
    return s;
  }
  if (plan.resumed) s.info.render_seconds = plan.resumed->info.render_seconds;
  s.film.enable_features(film_features);
  s.film.reset(desc.width, desc.height);
  s.film.start_at(plan.range_begin);
  s.info.sample_begin = plan.range_begin;
  return s;
}

std::optional<Film> merge_over_ranks(const SamplePlan& plan, const Film& film, const FilmStateInfo& info,
                                     double busy_seconds) {
  FilmStateInfo mine = info;
  mine.render_seconds = busy_seconds;
  const std::vector<std::string> parts = plan.mpi->gather_to_root(encode_film_state(film, mine));
  if (!plan.mpi->root()) return std::nullopt;
  std::vector<LoadedFilmState> decoded;
  std::vector<const LoadedFilmState*> states;
  std::vector<std::string> names;
  decoded.reserve(parts.size());
  for (size_t r = 0; r < parts.size(); ++r) {
    names.push_back("rank " + std::to_string(r));
    decoded.push_back(decode_film_state(parts[r], names.back()));
    states.push_back(&decoded.back());
  }
  if (plan.resumed) {
    states.push_back(&*plan.resumed);
    names.push_back("the resumed state");
  }
  return std::move(merge_film_states(states, names).film);
}

}  // namespace pt
