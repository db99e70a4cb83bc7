// `pathtracer merge`: combines film states (`render --save-state`) rendered with disjoint sample ranges or other
// seeds into one film (docs/scale-out.md), written as images and/or a state.
#pragma once
#include <string>
#include <vector>

namespace CLI {
class App;
}

namespace pt {

struct MergeOptions {
  std::vector<std::string> states;
  std::string pfm, png, save_state;
};

void add_merge_command(CLI::App& app, MergeOptions& options);
// Exit status: 0 done, 1 an output could not be written, 2 unreadable, corrupted or incompatible states.
int run_merge(const MergeOptions& options);

}  // namespace pt
