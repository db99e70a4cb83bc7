// libFuzzer target: the image readers (read_hdr_image: OpenEXR, Radiance HDR, PFM). The first byte picks the
// format (the readers choose by file extension); the rest is the file. Any input must give either an image whose
// size is consistent and whose texels are finite and >= 0, or an error message naming the file; a crash, a
// sanitizer report, a hang or an oversized allocation is a finding.
// Build and run: tools/fuzz.sh (docs/reliability.md).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "fuzz_input.h"
#include "io/image_io.h"

const char* const pt::fuzz::kTarget = "fuzz_images";

using pt::fuzz::finding;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  static const char* const kExtensions[] = {".pfm", ".hdr", ".exr"};
  const std::string path = pt::fuzz::write_input(data + 1, size - 1, kExtensions[data[0] % 3]);
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
