#include "cli/instruction_count.h"

#include "cli/file_names.h"

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>

namespace pt {

namespace fs = std::filesystem;

namespace {

std::string read_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

}  // namespace

std::optional<uint64_t> parse_callgrind_total(const std::string& log) {
  static const std::regex collected(R"(==\d+== Collected : (\d+))");
  std::smatch m;
  if (!std::regex_search(log, m, collected)) return std::nullopt;
  try {
    return std::stoull(m[1].str());
  } catch (const std::exception&) {
    return std::nullopt;  // out of range
  }
}

std::string counted_render_command(const std::string& binary, const std::string& scene, const std::string& estimator,
                                   int width, int height, int spp, const std::string& pfm) {
  return shell_quote(binary) + " render -q --threads 1 --scene " + shell_quote(scene) + " --estimator " +
         shell_quote(estimator) + " --sampler sobol --width " + std::to_string(width) + " --height " +
         std::to_string(height) + " --spp " + std::to_string(spp) + " --pfm " + shell_quote(pfm);
}

std::string counted_file_stem(const std::string& scene, const std::string& estimator, int spp) {
  return file_name_part(scene + "-" + estimator + "-" + std::to_string(spp));
}

InstructionsPerSample count_instructions_per_sample(const std::string& binary, const std::string& scene,
                                                    const std::string& estimator, int width, int height,
                                                    const std::string& work_dir) {
  InstructionsPerSample r;
  if (std::system("command -v valgrind >/dev/null 2>&1") != 0) {
    r.error = "valgrind was not found (Debian package valgrind)";
    return r;
  }
  std::error_code ec;
  fs::create_directories(work_dir, ec);
  if (ec) {
    r.error = "cannot create " + work_dir + ": " + ec.message();
    return r;
  }
  uint64_t counts[2] = {0, 0};
  const int spps[2] = {1, InstructionsPerSample::kHigh};
  for (int k = 0; k < 2; ++k) {
    const fs::path stem = fs::path(work_dir) / counted_file_stem(scene, estimator, spps[k]);
    const fs::path log = stem.string() + ".log", pfm = stem.string() + ".pfm";
    fs::remove(pfm, ec);  // render never overwrites an output
    const std::string cmd = "valgrind --tool=callgrind --callgrind-out-file=" +
                            shell_quote(stem.string() + ".callgrind") + " " +
                            counted_render_command(binary, scene, estimator, width, height, spps[k], pfm.string()) +
                            " >/dev/null 2>" + shell_quote(log.string());
    const int status = std::system(cmd.c_str());
    const std::optional<uint64_t> n = parse_callgrind_total(read_text(log));
    if (status != 0 || !n) {
      r.error = "the counted render failed (exit status " + std::to_string(status) + "); see " + log.string();
      return r;
    }
    counts[k] = *n;
  }
  const double samples = static_cast<double>(width) * height * (InstructionsPerSample::kHigh - 1);
  r.per_sample = (static_cast<double>(counts[1]) - static_cast<double>(counts[0])) / samples;
  return r;
}

bool this_binary_runs_under_valgrind() {
#ifdef __AVX512F__
  return false;
#else
  return true;
#endif
}

}  // namespace pt
