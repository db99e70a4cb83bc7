// A folder of its own under the system's temporary directory for one test (named after the test file's tag and
// the process, so parallel ctest runs never share one), removed with everything in it when the test ends.
#pragma once
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

namespace pt::test {

struct TempFolder {
  std::filesystem::path dir;
  explicit TempFolder(const std::string& tag)
      : dir(std::filesystem::temp_directory_path() / ("pt_" + tag + "_" + std::to_string(::getpid()))) {
    std::filesystem::create_directories(dir);
  }
  ~TempFolder() {
    std::error_code ec;
    std::filesystem::remove_all(dir, ec);
  }
  TempFolder(const TempFolder&) = delete;
  TempFolder& operator=(const TempFolder&) = delete;
  std::string path(const std::string& name) const { return (dir / name).string(); }
  // Writes `text` (bytes as they are) to the file `name` in the folder; returns its path.
  std::string write(const std::string& name, const std::string& text) const {
    std::ofstream(path(name), std::ios::binary) << text;
    return path(name);
  }
};

}  // namespace pt::test
