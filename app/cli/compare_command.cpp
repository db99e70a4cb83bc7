#include "cli/compare_command.h"

#include <CLI/CLI.hpp>
#include <cstdio>

#include "cli/option_checks.h"
#include "render/metrics.h"

namespace pt {

void add_compare_command(CLI::App& app, CompareOptions& o) {
  CLI::App* c = app.add_subcommand("compare", "Print RMSE, relMSE and mean radiance of IMAGE against REFERENCE (PFM or OpenEXR files)");
  c->add_option("image", o.image, "Image to judge (PFM, or EXR: its R, G, B beauty channels)")->required();
  c->add_option("reference", o.reference, "Reference image (PFM or EXR), same size, or larger by --downsample")->required();
  c->add_option("--downsample", o.downsample,
                "Block-average the reference by this integer factor first (for references stored at higher resolution)")
      ->check(whole_in(1, 64))
      ->capture_default_str();
  c->add_option("--blocks", o.blocks,
                "Also count the N×N pixel blocks whose mean luminance is off the reference's by more than "
                "--block-tolerance (0: off)")
      ->check(whole_in(0, 4096))
      ->capture_default_str();
  c->add_option("--block-tolerance", o.block_tolerance, "Relative tolerance of --blocks (0.03 = 3 %)")
      ->check(CLI::Range(0.0, 1e6))
      ->capture_default_str();
}

int run_compare(const CompareOptions& o) {
  try {
    const Image img = read_image(o.image);
    Image ref = read_image(o.reference);
    if (o.downsample > 1) ref = block_average(ref, o.downsample);
    if (img.width != ref.width || img.height != ref.height) {
      std::fprintf(stderr, "error: %s is %dx%d but the reference is %dx%d\n", o.image.c_str(), img.width, img.height,
                   ref.width, ref.height);
      return 2;
    }
    const glm::dvec3 m = mean_rgb(img), mr = mean_rgb(ref);
    std::printf("RMSE %.6g  relMSE %.6g  mean (%.5f, %.5f, %.5f)  reference mean (%.5f, %.5f, %.5f)\n",
                rmse(img, ref), relmse(img, ref), m.x, m.y, m.z, mr.x, mr.y, mr.z);
    if (o.blocks > 0) {
      const BlockErrors b = block_errors(img, ref, o.blocks, o.block_tolerance);
      std::printf("blocks %dx%d: %d of %d off the reference's mean luminance by more than %g %%", o.blocks, o.blocks,
                  b.off, b.blocks, 100 * o.block_tolerance);
      if (b.blocks > b.black_off)
        std::printf(", worst %+.1f %% at pixel (%d, %d)", 100 * b.worst, b.worst_x, b.worst_y);
      if (b.black_off > 0)
        std::printf("; %d black in the reference but not in the image (mean luminance up to %.3g)", b.black_off,
                    b.black_worst);
      std::printf("\n");
    }
    return 0;
  } catch (const ImageError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  }
}

}  // namespace pt
