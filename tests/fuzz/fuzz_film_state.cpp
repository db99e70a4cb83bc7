// libFuzzer target: the film state reader (decode_film_state: `render --resume`, `merge`, MPI transfers). With
// the first byte odd the input gets a correct checksum appended, so the fuzzer reaches the header and array
// checks behind it; even, it is read as is. Any input must give either a film whose arrays are consistent
// (size, counts not above the sample indices, finite means) or an error naming the input; a crash, a sanitizer
// report, a hang or an oversized allocation is a finding.
// Build and run: tools/fuzz.sh (docs/reliability.md).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_input.h"
#include "io/film_state.h"
#include "io/little_endian.h"

const char* const pt::fuzz::kTarget = "fuzz_film_state";

using pt::fuzz::finding;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  std::string bytes(reinterpret_cast<const char*>(data + 1), size - 1);
  if (data[0] & 1) pt::put_le_u64(bytes, pt::film_state_checksum(bytes));
  try {
    pt::LoadedFilmState s = pt::decode_film_state(bytes, "input");
    const pt::Film& f = s.film;
    if (f.width() <= 0 || f.height() <= 0 || f.pixel_count() != static_cast<size_t>(f.width()) * f.height())
      finding("inconsistent film size", std::to_string(f.width()) + "x" + std::to_string(f.height()));
    for (size_t i = 0; i < f.pixel_count(); ++i)
      if (f.count(i) > f.next_sample_index(i)) finding("more samples than sample indices", std::to_string(i));
    (void)f.mean_image();
    (void)f.estimated_relmse();
  } catch (const pt::FilmStateError& e) {
    if (std::string(e.what()).rfind("input", 0) != 0) finding("error message does not name the input", e.what());
  }
  return 0;
}
