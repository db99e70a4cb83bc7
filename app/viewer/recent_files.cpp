#include "viewer/recent_files.h"

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "io/safe_file.h"
#include "viewer/viewer_prefs.h"

namespace pt {

std::string RecentFiles::default_store() { return viewer_config_path("recent-scenes.txt"); }

RecentFiles::RecentFiles(std::string store) : store_(std::move(store)) {
  if (store_.empty()) return;
  std::ifstream in(store_);
  std::string line;
  while (paths_.size() < kMaxRecentFiles && std::getline(in, line))
    if (!line.empty() && std::find(paths_.begin(), paths_.end(), line) == paths_.end()) paths_.push_back(line);
}

std::string RecentFiles::add(const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  std::string p = fs::absolute(path, ec).lexically_normal().string();
  if (ec) p = path;
  paths_.erase(std::remove(paths_.begin(), paths_.end(), p), paths_.end());
  paths_.insert(paths_.begin(), p);
  if (paths_.size() > kMaxRecentFiles) paths_.resize(kMaxRecentFiles);
  if (store_.empty()) return "";
  try {
    fs::create_directories(fs::path(store_).parent_path());
    std::string text;
    for (const std::string& q : paths_) text += q + "\n";
    write_file_safely(store_, text);
  } catch (const std::exception& e) {
    return std::string("recent files not saved: ") + e.what();
  }
  return "";
}

}  // namespace pt
