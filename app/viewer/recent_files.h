// The viewer's recent scene files: most recent first, at most kMaxRecentFiles, kept across sessions in
// $XDG_CONFIG_HOME/pathtracer/recent-scenes.txt (else ~/.config/...), one absolute path per line. A missing or
// unreadable list is an empty one; writing it goes through write_file_safely, and a failure to write is
// reported, never fatal.
#pragma once
#include <string>
#include <vector>

namespace pt {

inline constexpr size_t kMaxRecentFiles = 10;

class RecentFiles {
 public:
  // `store` is the list's file; "" keeps the list in memory only.
  explicit RecentFiles(std::string store = default_store());
  static std::string default_store();  // "" when neither XDG_CONFIG_HOME nor HOME is set

  const std::vector<std::string>& paths() const { return paths_; }
  // Moves `path` (made absolute) to the front and writes the list; returns "" or why it could not be written.
  std::string add(const std::string& path);

 private:
  std::string store_;
  std::vector<std::string> paths_;
};

}  // namespace pt
