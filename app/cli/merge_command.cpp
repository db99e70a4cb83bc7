#include "cli/merge_command.h"

#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>

#include "io/film_state.h"
#include "io/image_io.h"
#include "io/safe_file.h"

namespace pt {

void add_merge_command(CLI::App& app, MergeOptions& o) {
  CLI::App* m = app.add_subcommand(
      "merge", "Combine film states (render --save-state) of disjoint sample ranges or other seeds into one film");
  m->add_option("states", o.states, "State files (.ptstate) of one scene")->required()->expected(1, -1);
  m->add_option("--pfm", o.pfm, "Write the merged linear mean radiance here");
  m->add_option("--png", o.png, "Write the merged image, tone-mapped (clamp) 8-bit sRGB, here");
  m->add_option("--save-state", o.save_state, "Write the merged state here (to merge further, or resume)");
  m->footer("Outputs are checked before reading the states and written completely or not at all. Exit status: 0 ok,\n"
            "1 an output could not be written, 2 unreadable, corrupted or incompatible states.");
}

int run_merge(const MergeOptions& o) {
  if (o.pfm.empty() && o.png.empty() && o.save_state.empty()) {
    std::fprintf(stderr, "error: merge: give at least one of --pfm, --png, --save-state\n");
    return 2;
  }
  for (const auto& [flag, path] : {std::pair{"--pfm", o.pfm}, {"--png", o.png}, {"--save-state", o.save_state}}) {
    if (path.empty()) continue;
    if (std::string err = check_output_path(path); !err.empty()) {
      std::fprintf(stderr, "error: %s %s\n", flag, err.c_str());
      return 2;
    }
    for (const std::string& in : o.states)
      if (file_id(in) == file_id(path)) {
        std::fprintf(stderr, "error: %s %s: is one of the states being merged; refusing to overwrite it\n", flag,
                     path.c_str());
        return 2;
      }
  }
  std::vector<LoadedFilmState> states;
  states.reserve(o.states.size());
  try {
    for (const std::string& path : o.states) states.push_back(read_film_state(path));
  } catch (const FilmStateError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  }
  LoadedFilmState merged;
  try {
    merged = merge_film_states(states, o.states);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: merge: %s\n", e.what());
    return 2;
  }
  const Film& film = merged.film;
  std::printf("merged %zu states of %s: %dx%d, %u to %llu spp, %.2f s of rendering%s, estimated relMSE %.3g\n",
              states.size(), merged.info.scene_name.c_str(), film.width(), film.height(), film.min_count(),
              static_cast<unsigned long long>(film.total_count() / std::max<size_t>(film.pixel_count(), 1)),
              merged.info.render_seconds, merged.info.mixed_seeds ? " (several seeds: not resumable)" : "",
              film.estimated_relmse());
  int failed = 0;
  const Image img{film.width(), film.height(), film.mean_image()};
  auto write = [&](const char* flag, const std::string& path, auto&& fn) {
    if (path.empty()) return;
    try {
      fn();
      std::printf("wrote %s\n", std::filesystem::absolute(path).c_str());
    } catch (const std::runtime_error& e) {
      std::fprintf(stderr, "error: %s: %s\n", flag, e.what());
      ++failed;
    }
  };
  write("--pfm", o.pfm, [&] { write_pfm(o.pfm, img); });
  write("--png", o.png, [&] { write_png(o.png, img); });
  write("--save-state", o.save_state, [&] { write_film_state(o.save_state, film, merged.info); });
  return failed ? 1 : 0;
}

}  // namespace pt
