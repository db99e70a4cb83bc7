#include "viewer/viewer_script.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <stdexcept>

#include "io/safe_file.h"
#include "viewer/viewer_model.h"

namespace pt {

namespace {

constexpr size_t kMaxScriptBytes = 1 << 20;  // a script is a few lines; a larger "script" is the wrong file

[[noreturn]] void fail(const std::string& file, int line, const std::string& reason) {
  throw std::runtime_error(file + ":" + std::to_string(line) + ": " + reason);
}

// A finite number, or the line's error naming what it should have been.
double number(std::istringstream& in, const std::string& file, int line, const char* what) {
  std::string word;
  if (!(in >> word)) fail(file, line, std::string("missing ") + what);
  size_t used = 0;
  double v = 0.0;
  try {
    v = std::stod(word, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != word.size() || !std::isfinite(v)) fail(file, line, std::string(what) + ": '" + word + "' is not a finite number");
  return v;
}

// A number in [0, 1]: a fraction of the image's width or height.
double fraction(std::istringstream& in, const std::string& file, int line, const char* what) {
  const double v = number(in, file, line, what);
  if (v < 0.0 || v > 1.0) fail(file, line, std::string(what) + " must be in [0, 1] (a fraction of the image)");
  return v;
}

}  // namespace

std::vector<ScriptAction> parse_viewer_script(const std::string& text, const std::string& file) {
  std::vector<ScriptAction> out;
  std::istringstream lines(text);
  std::string raw;
  int line = 0;
  while (std::getline(lines, raw)) {
    ++line;
    if (const size_t hash = raw.find('#'); hash != std::string::npos) raw.resize(hash);
    std::istringstream in(raw);
    std::string first;
    if (!(in >> first)) continue;  // blank or comment
    in.str(raw);
    in.clear();
    ScriptAction a;
    a.line = line;
    a.at_seconds = number(in, file, line, "the time in seconds");
    if (a.at_seconds < 0.0) fail(file, line, "the time must be >= 0");
    if (!out.empty() && a.at_seconds < out.back().at_seconds)
      fail(file, line, "the time goes back (" + std::to_string(out.back().at_seconds) + " s on line " +
                           std::to_string(out.back().line) + ")");
    std::string verb;
    if (!(in >> verb)) fail(file, line, "missing the action (" + enum_names_joined<ScriptVerb>() + ")");
    if (!parse_enum(verb, a.verb))
      fail(file, line, "unknown action '" + verb + "' (" + enum_names_joined<ScriptVerb>() + ")");
    switch (a.verb) {
      case ScriptVerb::Orbit:
        a.x = number(in, file, line, "DX");
        a.y = number(in, file, line, "DY");
        break;
      case ScriptVerb::Emission:
        if (!(in >> a.name)) fail(file, line, "missing the material's name");
        a.x = number(in, file, line, "STRENGTH");
        break;
      case ScriptVerb::Select:
        a.x = fraction(in, file, line, "FX");
        a.y = fraction(in, file, line, "FY");
        break;
      case ScriptVerb::Region:
        a.x = fraction(in, file, line, "FX0");
        a.y = fraction(in, file, line, "FY0");
        a.x1 = fraction(in, file, line, "FX1");
        a.y1 = fraction(in, file, line, "FY1");
        break;
      case ScriptVerb::Screenshot:
        if (!(in >> a.name)) fail(file, line, "missing the file name");
        break;
      case ScriptVerb::Quit: break;
    }
    if (std::string extra; in >> extra) fail(file, line, "unexpected '" + extra + "' after the action");
    out.push_back(std::move(a));
  }
  return out;
}

std::vector<ScriptAction> read_viewer_script(const std::string& file) {
  return parse_viewer_script(read_file_limited(file, kMaxScriptBytes), file);
}

std::string apply_script_action(ViewerModel& model, const ScriptAction& a) {
  switch (a.verb) {
    case ScriptVerb::Orbit: {
      ViewInput in;
      in.orbit = true;
      in.viewport_height = 1000.f;  // the drag in image heights, at any window size
      in.drag = Vec2(static_cast<float>(a.x * 1000.0), static_cast<float>(a.y * 1000.0));
      model.apply_input(in, 0.0);
      return "";
    }
    case ScriptVerb::Emission: {
      const std::vector<MaterialDesc>& m = model.scene().materials;
      for (size_t i = 0; i < m.size(); ++i)
        if (m[i].name == a.name) {
          if (model.set_emission(i, model.emission_colour(i), static_cast<float>(a.x))) return "";
          return model.status();
        }
      return "no material named '" + a.name + "'";
    }
    case ScriptVerb::Select: {
      const int w = model.scene().width, h = model.scene().height;
      const double x = std::min(a.x * w, w - 0.5), y = std::min(a.y * h, h - 0.5);
      if (!model.select_at(x, y)) return "nothing under the image point (" + std::to_string(a.x) + ", " + std::to_string(a.y) + ")";
      return "";
    }
    case ScriptVerb::Region: {
      const int w = model.scene().width, h = model.scene().height;
      const auto px = [](double f, int n) { return static_cast<int>(std::lround(f * n)); };
      if (model.set_region(PixelRect{px(a.x, w), px(a.y, h), px(a.x1, w), px(a.y1, h)})) return "";
      return model.status();
    }
    case ScriptVerb::Screenshot: return "";
    case ScriptVerb::Quit:
      // A script runs unattended: it never waits on the unsaved-edits question (Esc's), and its edits, never
      // written anywhere, are dropped with a note.
      if (model.has_unsaved_edits()) std::fprintf(stderr, "note: --script quit: the scene's unsaved edits are discarded\n");
      model.quit_requested = true;
      return "";
  }
  return "";
}

}  // namespace pt
