// `pathtracer compare`: error metrics of an image against a reference (docs/estimators.md: RMSE and relMSE;
// docs/denoising.md: the block test).
#pragma once
#include <string>

namespace CLI {
class App;
}

namespace pt {

struct CompareOptions {
  std::string image, reference;
  int downsample = 1;
  int blocks = 0;                // > 0: also count blocks of this size off the reference (metrics.h)
  double block_tolerance = 0.03;
};

void add_compare_command(CLI::App& app, CompareOptions& options);
// Exit status: 0 done, 2 unreadable input or mismatched sizes.
int run_compare(const CompareOptions& options);

}  // namespace pt
