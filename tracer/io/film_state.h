// A film's complete accumulation state on disk (`render --save-state`, `--resume`, `pathtracer merge`): per
// pixel the sample count, the next sample index and the exact double running sums of Film (mean and second
// moment, and the feature and half buffers when kept), with what it was rendered from, so that a resumed render
// is bit-identical to an uninterrupted one. docs/scale-out.md documents the format (version 2):
//
//   "PTSTATE\0"  u32 version  u32 header_bytes  header  arrays  u64 checksum
//
// little-endian; the checksum is FNV-1a 64 over every byte before it. A file that is truncated, longer than its
// header says, corrupted (checksum) or of another version is refused with the reason; nothing is half-loaded.
#pragma once
#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "film/film.h"

namespace pt {

struct FilmStateError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// Version 2: the scene hash reads shapes by their bits (version 1 hashed their JSON).
inline constexpr uint32_t kFilmStateVersion = 2;

// What a state was rendered from, besides the film itself.
struct FilmStateInfo {
  uint64_t scene_hash = 0;     // scene_content_hash of the scene, render settings included (scene/scene_identity.h)
  uint64_t seed = 0;
  uint32_t estimator = 0, sampler = 0;  // enum values, for messages
  int32_t max_bounces = 0, rr_depth = 0;
  uint32_t sample_begin = 0;   // first sample index of this film's range (0 unless --sample-range)
  bool mixed_seeds = false;    // merged from renders with different seeds: mergeable, not resumable
  double render_seconds = 0;   // total render time of the samples in it
  std::string scene_name;      // for messages
};

void write_film_state(const std::string& path, const Film& film, const FilmStateInfo& info);
// The same bytes in memory (what ranks send each other, io/mpi).
std::string encode_film_state(const Film& film, const FilmStateInfo& info);

struct LoadedFilmState {
  Film film;
  FilmStateInfo info;
};
// Throws FilmStateError ("path: reason").
LoadedFilmState read_film_state(const std::string& path);
// The trailing checksum of a state whose bytes (checksum excluded) are `body` (FNV-1a 64).
uint64_t film_state_checksum(std::string_view body);
// Decodes bytes of encode_film_state; `name` labels the errors.
LoadedFilmState decode_film_state(std::string_view bytes, const std::string& name);

// Merges states rendered from the same scene (content hash): with one seed their sample ranges must be
// disjoint in every pixel; with different seeds any samples combine (the result is marked mixed: mergeable, not
// resumable). States are combined in the order of their first sample index (Film::merge). Throws
// FilmStateError with the reason (naming the states by `names`).
LoadedFilmState merge_film_states(const std::vector<const LoadedFilmState*>& states, const std::vector<std::string>& names);
LoadedFilmState merge_film_states(const std::vector<LoadedFilmState>& states, const std::vector<std::string>& names);

}  // namespace pt
