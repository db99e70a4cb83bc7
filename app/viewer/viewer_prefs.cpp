#include "viewer/viewer_prefs.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "io/safe_file.h"

namespace pt {

std::string viewer_config_path(const std::string& name) {
  namespace fs = std::filesystem;
  if (const char* xdg = std::getenv("XDG_CONFIG_HOME"); xdg && *xdg) return (fs::path(xdg) / "pathtracer" / name).string();
  if (const char* home = std::getenv("HOME"); home && *home)
    return (fs::path(home) / ".config" / "pathtracer" / name).string();
  return "";
}

namespace {

bool parse_float(const std::string& text, float& out) {
  size_t used = 0;
  try {
    out = std::stof(text, &used);
  } catch (const std::exception&) {
    return false;
  }
  return used == text.size() && std::isfinite(out);
}

}  // namespace

ViewerPrefs read_viewer_prefs(const std::string& path, std::vector<std::string>& warnings) {
  ViewerPrefs p;
  if (path.empty()) return p;
  std::ifstream in(path);
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (line.empty() || line[0] == '#') continue;
    const size_t eq = line.find('=');
    const std::string key = line.substr(0, eq), value = eq == std::string::npos ? "" : line.substr(eq + 1);
    const std::string where = path + ":" + std::to_string(number) + ": ";
    float v = 0.f;
    if (key == "panel_width" && parse_float(value, v) && v >= ViewerPrefs::kMinPanelWidth && v <= ViewerPrefs::kMaxPanelWidth)
      p.panel_width = v;
    else if (key == "follow_window" && (value == "0" || value == "1"))
      p.follow_window = value == "1";
    else if (key == "follow_scale" && parse_float(value, v) &&
             std::find(std::begin(kFollowScales), std::end(kFollowScales), v) != std::end(kFollowScales))
      p.follow_scale = v;
    else
      warnings.push_back(where + "ignored '" + line + "' (panel_width in [" +
                         std::to_string(static_cast<int>(ViewerPrefs::kMinPanelWidth)) + ", " +
                         std::to_string(static_cast<int>(ViewerPrefs::kMaxPanelWidth)) +
                         "], follow_window 0 or 1, follow_scale 1, 0.5 or 0.25)");
  }
  return p;
}

std::string write_viewer_prefs(const std::string& path, const ViewerPrefs& p) {
  if (path.empty()) return "";
  std::ostringstream text;
  text << "panel_width=" << p.panel_width << "\nfollow_window=" << (p.follow_window ? 1 : 0)
       << "\nfollow_scale=" << p.follow_scale << "\n";
  try {
    if (const auto parent = std::filesystem::path(path).parent_path(); !parent.empty())
      std::filesystem::create_directories(parent);
    write_file_safely(path, text.str());
  } catch (const std::exception& e) {
    return std::string("viewer preferences not saved: ") + e.what();
  }
  return "";
}

}  // namespace pt
