#include "io/film_state.h"

#include <algorithm>
#include <cstring>
#include <filesystem>

#include "core/fnv1a.h"
#include "io/little_endian.h"
#include "io/safe_file.h"

namespace pt {

namespace {

constexpr char kMagic[8] = {'P', 'T', 'S', 'T', 'A', 'T', 'E', '\0'};
constexpr uint32_t kFlagFeatures = 1, kFlagMixedSeeds = 2;
// A header's fixed fields (docs/scale-out.md): width, height, flags, scene hash, seed, estimator, sampler,
// max bounces, RR depth, sample begin, rejected, render seconds, name length; then the name.
constexpr uint32_t kHeaderFixedBytes = 4 + 4 + 4 + 8 + 8 + 4 + 4 + 4 + 4 + 4 + 8 + 8 + 4;
constexpr uint32_t kMaxNameBytes = 4096;
// Per pixel: count and next sample index (u32), sum pairs and second moments (6 + 3 f64); with features the
// feature means (10 f64), the half-A count (u32) and mean (3 f64).
constexpr size_t kPixelBytes = 2 * 4 + 9 * 8, kFeaturePixelBytes = 10 * 8 + 4 + 3 * 8;
size_t pixel_bytes(bool features) { return kPixelBytes + (features ? kFeaturePixelBytes : 0); }
constexpr int kMaxSide = 65536;

// Bounds-checked reading: every read names what it wanted when the file ends early.
struct Reader {
  const unsigned char* p;
  size_t size, pos = 0;
  const std::string& path;
  const unsigned char* take(size_t n, const char* what) {
    if (n > size - pos) throw FilmStateError(path + ": truncated (ends inside " + what + ")");
    const unsigned char* q = p + pos;
    pos += n;
    return q;
  }
  uint32_t u32(const char* what) { return get_le_u32(take(4, what)); }
  uint64_t u64(const char* what) { return get_le_u64(take(8, what)); }
  double f64(const char* what) { return get_le_f64(take(8, what)); }
};

template <class T>
void put_array(std::string& out, const std::vector<T>& v) {
  for (const T& x : v) {
    if constexpr (std::is_same_v<T, double>) put_le_f64(out, x);
    else put_le_u32(out, x);
  }
}

template <class T>
void get_array(Reader& r, std::vector<T>& v, const char* what) {
  const unsigned char* p = r.take(v.size() * sizeof(T), what);
  for (size_t i = 0; i < v.size(); ++i) {
    if constexpr (std::is_same_v<T, double>) v[i] = get_le_f64(p + 8 * i);
    else v[i] = get_le_u32(p + 4 * i);
  }
}

}  // namespace

uint64_t film_state_checksum(std::string_view body) {
  return fnv1a(reinterpret_cast<const unsigned char*>(body.data()), body.size());
}

std::string encode_film_state(const Film& film, const FilmStateInfo& info) {
  const Film::ConstArrays a = film.arrays();
  const size_t n = film.pixel_count();
  const std::string name = info.scene_name.substr(0, kMaxNameBytes);
  std::string out;
  out.reserve(64 + name.size() + n * pixel_bytes(film.has_features()) + 8);
  out.append(kMagic, 8);
  put_le_u32(out, kFilmStateVersion);
  put_le_u32(out, kHeaderFixedBytes + static_cast<uint32_t>(name.size()));
  put_le_u32(out, static_cast<uint32_t>(film.width()));
  put_le_u32(out, static_cast<uint32_t>(film.height()));
  put_le_u32(out, (film.has_features() ? kFlagFeatures : 0u) | (info.mixed_seeds ? kFlagMixedSeeds : 0u));
  put_le_u64(out, info.scene_hash);
  put_le_u64(out, info.seed);
  put_le_u32(out, info.estimator);
  put_le_u32(out, info.sampler);
  put_le_u32(out, static_cast<uint32_t>(info.max_bounces));
  put_le_u32(out, static_cast<uint32_t>(info.rr_depth));
  put_le_u32(out, info.sample_begin);
  put_le_u64(out, film.rejected());
  put_le_f64(out, info.render_seconds);
  put_le_u32(out, static_cast<uint32_t>(name.size()));
  out += name;
  put_array(out, *a.count);
  put_array(out, *a.attempts);
  put_array(out, *a.sum);
  put_array(out, *a.m2);
  if (film.has_features()) {
    put_array(out, *a.feature);
    put_array(out, *a.half_count);
    put_array(out, *a.half_mean);
  }
  put_le_u64(out, fnv1a(reinterpret_cast<const unsigned char*>(out.data()), out.size()));
  return out;
}

void write_film_state(const std::string& path, const Film& film, const FilmStateInfo& info) {
  const std::string bytes = encode_film_state(film, info);
  try {
    write_file_safely(path, bytes);
  } catch (const std::exception& e) {
    throw FilmStateError(e.what());
  }
}

LoadedFilmState read_film_state(const std::string& path) {
  std::string bytes;
  try {
    // The largest film the renderer makes (16384², with features) plus its header.
    bytes = read_file_limited(path, static_cast<size_t>(16384) * 16384 * pixel_bytes(true) + (1u << 20));
  } catch (const std::exception& e) {
    throw FilmStateError(e.what());
  }
  return decode_film_state(bytes, path);
}

LoadedFilmState decode_film_state(std::string_view bytes, const std::string& path) {
  const auto* p = reinterpret_cast<const unsigned char*>(bytes.data());
  Reader r{p, bytes.size(), 0, path};
  if (bytes.size() < 8 || std::memcmp(p, kMagic, 8) != 0)
    throw FilmStateError(path + ": not a pathtracer state file (no PTSTATE signature)");
  r.take(8, "the signature");
  // The version, then the size the header promises, then the checksum: a corrupted file is refused before any
  // other field is trusted.
  if (bytes.size() < 8 + 8 + 8) throw FilmStateError(path + ": truncated (" + std::to_string(bytes.size()) + " bytes)");
  const uint64_t stored = get_le_u64(p + bytes.size() - 8);
  const uint32_t version = get_le_u32(p + 8);
  if (version != kFilmStateVersion)
    throw FilmStateError(path + ": state file version " + std::to_string(version) + ", this build reads version " +
                         std::to_string(kFilmStateVersion));
  r.pos = 12;
  const uint32_t header_bytes = r.u32("the header size");
  if (header_bytes < kHeaderFixedBytes || header_bytes > kHeaderFixedBytes + kMaxNameBytes)
    throw FilmStateError(path + ": corrupted (header size " + std::to_string(header_bytes) + ")");
  const int width = static_cast<int>(r.u32("the header")), height = static_cast<int>(r.u32("the header"));
  const uint32_t flags = r.u32("the header");
  if (width < 1 || height < 1 || width > kMaxSide || height > kMaxSide || (flags & ~(kFlagFeatures | kFlagMixedSeeds)))
    throw FilmStateError(path + ": corrupted header (size " + std::to_string(width) + "x" + std::to_string(height) +
                         ", flags " + std::to_string(flags) + ")");
  const bool features = flags & kFlagFeatures;
  const size_t n = static_cast<size_t>(width) * static_cast<size_t>(height);
  const size_t expected = 16 + header_bytes + n * pixel_bytes(features) + 8;
  if (bytes.size() < expected)
    throw FilmStateError(path + ": truncated (" + std::to_string(bytes.size()) + " of " + std::to_string(expected) +
                         " bytes)");
  if (bytes.size() > expected)
    throw FilmStateError(path + ": corrupted (" + std::to_string(bytes.size() - expected) + " bytes more than its header says)");
  if (fnv1a(p, bytes.size() - 8) != stored) throw FilmStateError(path + ": corrupted (checksum mismatch)");

  LoadedFilmState s;
  FilmStateInfo& info = s.info;
  info.mixed_seeds = flags & kFlagMixedSeeds;
  info.scene_hash = r.u64("the header");
  info.seed = r.u64("the header");
  info.estimator = r.u32("the header");
  info.sampler = r.u32("the header");
  info.max_bounces = static_cast<int32_t>(r.u32("the header"));
  info.rr_depth = static_cast<int32_t>(r.u32("the header"));
  info.sample_begin = r.u32("the header");
  const uint64_t rejected = r.u64("the header");
  info.render_seconds = r.f64("the header");
  const uint32_t name_bytes = r.u32("the header");
  if (name_bytes != header_bytes - kHeaderFixedBytes) throw FilmStateError(path + ": corrupted (scene name size)");
  const unsigned char* name = r.take(name_bytes, "the scene name");
  info.scene_name.assign(reinterpret_cast<const char*>(name), name_bytes);

  s.film.enable_features(features);
  s.film.reset(width, height);
  const Film::Arrays a = s.film.arrays();
  get_array(r, *a.count, "the sample counts");
  get_array(r, *a.attempts, "the sample indices");
  get_array(r, *a.sum, "the sums");
  get_array(r, *a.m2, "the second moments");
  if (features) {
    get_array(r, *a.feature, "the feature buffers");
    get_array(r, *a.half_count, "the half counts");
    get_array(r, *a.half_mean, "the half means");
  }
  for (size_t i = 0; i < n; ++i)
    if ((*a.count)[i] > (*a.attempts)[i])
      throw FilmStateError(path + ": corrupted (pixel " + std::to_string(i) + " has more samples than sample indices)");
  s.film.set_rejected(rejected);
  return s;
}

LoadedFilmState merge_film_states(const std::vector<LoadedFilmState>& states, const std::vector<std::string>& names) {
  std::vector<const LoadedFilmState*> pointers;
  for (const LoadedFilmState& s : states) pointers.push_back(&s);
  return merge_film_states(pointers, names);
}

LoadedFilmState merge_film_states(const std::vector<const LoadedFilmState*>& states, const std::vector<std::string>& names) {
  if (states.empty()) throw FilmStateError("nothing to merge");
  std::vector<size_t> order(states.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return states[a]->info.sample_begin < states[b]->info.sample_begin; });
  const LoadedFilmState& first = *states[order[0]];
  for (size_t k = 1; k < order.size(); ++k) {
    const LoadedFilmState& s = *states[order[k]];
    const std::string& name = names[order[k]];
    if (s.info.scene_hash != first.info.scene_hash)
      throw FilmStateError(name + " and " + names[order[0]] + " were rendered from different scenes or settings");
    if (s.film.width() != first.film.width() || s.film.height() != first.film.height())
      throw FilmStateError(name + ": another film size");
    if (s.film.has_features() != first.film.has_features())
      throw FilmStateError(name + ": feature buffers in one state and not the other");
  }
  // With one seed, a sample index rendered twice would count the same sample twice: refused.
  for (size_t k = 0; k < order.size(); ++k)
    for (size_t j = k + 1; j < order.size(); ++j) {
      const LoadedFilmState& a = *states[order[k]];
      const LoadedFilmState& b = *states[order[j]];
      if (a.info.seed != b.info.seed || a.info.mixed_seeds || b.info.mixed_seeds) continue;
      for (size_t i = 0; i < a.film.pixel_count(); ++i) {
        const uint32_t a0 = a.info.sample_begin, a1 = a.film.next_sample_index(i);
        const uint32_t b0 = b.info.sample_begin, b1 = b.film.next_sample_index(i);
        if (a.film.count(i) > 0 && b.film.count(i) > 0 && a0 < b1 && b0 < a1)
          throw FilmStateError(names[order[k]] + " and " + names[order[j]] + " both hold sample indices " +
                               std::to_string(std::max(a0, b0)) + " to " + std::to_string(std::min(a1, b1) - 1) +
                               " (pixel " + std::to_string(i) + ") with seed " + std::to_string(a.info.seed) +
                               ": render disjoint --sample-range's, or other seeds");
      }
    }
  LoadedFilmState out;
  out.info = first.info;
  out.film.enable_features(first.film.has_features());
  out.film.reset(first.film.width(), first.film.height());
  out.film.start_at(first.info.sample_begin);
  out.info.render_seconds = 0.0;
  for (size_t k : order) {
    const LoadedFilmState& s = *states[k];
    out.film.merge(s.film);
    out.info.render_seconds += s.info.render_seconds;
    out.info.mixed_seeds = out.info.mixed_seeds || s.info.mixed_seeds || s.info.seed != first.info.seed;
  }
  return out;
}

}  // namespace pt
