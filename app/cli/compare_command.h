// `pathtracer compare`: error metrics of an image against a reference (docs/estimators.md: RMSE and relMSE).
#pragma once
#include <string>

namespace CLI {
class App;
}

namespace pt {

struct CompareOptions {
  std::string image, reference;
  int downsample = 1;
};

void add_compare_command(CLI::App& app, CompareOptions& options);
// Exit status: 0 done, 2 unreadable input or mismatched sizes.
int run_compare(const CompareOptions& options);

}  // namespace pt
