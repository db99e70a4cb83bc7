// libFuzzer target: the image readers (read_hdr_image: OpenEXR, Radiance HDR, PFM). The first byte picks the
// format (the readers choose by file extension); the rest is the file. Any input must give either an image whose
// size is consistent and whose texels are finite and >= 0, or an error message naming the file; a crash, a
// sanitizer report, a hang or an oversized allocation is a finding.
// Build and run: tools/fuzz.sh (docs/reliability.md).
#include <unistd.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "io/image_io.h"

namespace {

[[noreturn]] void finding(const char* what, const std::string& detail) {
  std::fprintf(stderr, "fuzz_images: %s: %s\n", what, detail.c_str());
  std::abort();
}

// The readers take a path: the input goes to a per-process file in shared memory (RAM), rewritten each time.
std::string write_input(const uint8_t* data, size_t size, const char* extension) {
  const std::string dir = access("/dev/shm", W_OK) == 0 ? "/dev/shm" : "/tmp";
  const std::string path = dir + "/pt_fuzz_images_" + std::to_string(getpid()) + extension;
  FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) finding("cannot create the input file", path);
  if (size && std::fwrite(data, 1, size, f) != size) finding("cannot write the input file", path);
  if (std::fclose(f) != 0) finding("cannot close the input file", path);
  return path;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  static const char* const kExtensions[] = {".pfm", ".hdr", ".exr"};
  const std::string path = write_input(data + 1, size - 1, kExtensions[data[0] % 3]);
  const pt::HdrImageResult result = pt::read_hdr_image(path);
  if (result.ok()) {
    const pt::Image& img = result.image;
    if (img.width <= 0 || img.height <= 0 || img.rgb.size() != 3ull * img.width * img.height)
      finding("inconsistent image size", std::to_string(img.width) + "x" + std::to_string(img.height));
    for (float v : img.rgb)
      if (!std::isfinite(v) || v < 0.f) finding("bad texel accepted", std::to_string(v));
  } else if (result.error.rfind(path, 0) != 0) {
    finding("error message does not name the file", result.error);
  }
  return 0;
}
