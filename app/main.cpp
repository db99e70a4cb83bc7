// The `pathtracer` executable: subcommands share one parser so `pathtracer --help` lists them all.
#include <CLI/CLI.hpp>
#include <csignal>
#include <cstdio>
#include <exception>
#include <new>

#include "cli/bench_command.h"
#include "cli/bench_rays_command.h"
#include "cli/compare_command.h"
#include "cli/merge_command.h"
#include "cli/render_command.h"
#include "viewer/view_command.h"
#include "cli/stress_command.h"

int main(int argc, char** argv) {
  CLI::App app{"pathtracer: a progressive CPU path tracer"};
  app.require_subcommand(1);
  pt::RenderOptions render_options;
  pt::add_render_command(app, render_options);
  pt::BenchOptions bench_options;
  pt::add_bench_command(app, bench_options);
  pt::BenchRaysOptions bench_rays_options;
  pt::add_bench_rays_command(*app.get_subcommand("bench"), bench_rays_options);
  pt::CompareOptions compare_options;
  pt::add_compare_command(app, compare_options);
  pt::MergeOptions merge_options;
  pt::add_merge_command(app, merge_options);
  pt::ViewOptions view_options;
  pt::add_view_command(app, view_options);
  pt::StressOptions stress_options;
  pt::add_stress_command(app, stress_options);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : 2;  // --help exits 0; a bad flag is bad input (2)
  }
  // A write past the file-size limit (ulimit -f) fails with EFBIG and is reported like any other failed write,
  // instead of SIGXFSZ killing the process: for every command's outputs.
  std::signal(SIGXFSZ, SIG_IGN);
  // Whatever escapes a command becomes a message and an exit status, never an abort.
  try {
    if (app.got_subcommand("render")) return pt::run_render(render_options);
    if (app.got_subcommand("bench")) {
      if (app.get_subcommand("bench")->got_subcommand("rays")) return pt::run_bench_rays(bench_rays_options);
      return pt::run_bench(bench_options);
    }
    if (app.got_subcommand("compare")) return pt::run_compare(compare_options);
    if (app.got_subcommand("merge")) return pt::run_merge(merge_options);
    if (app.got_subcommand("view")) return pt::run_view(view_options);
    if (app.got_subcommand("stress")) return pt::run_stress(stress_options);
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "error: out of memory\n");
    return 3;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 2;
}
