// `view --script FILE`: timed actions for demos, measurements and tests. Each action goes through the same
// ViewerModel action the panels or the mouse use, so a script exercises what a user does, without a person.
//
// The file is plain text, one action per line, `#` starts a comment:
//   SECONDS ACTION [ARGUMENTS]
// SECONDS counts from the window's first frame (as --seconds does) and must not decrease from line to line.
// The actions and their arguments are in kScriptActions (one table: the parser, --help and docs/viewer.md).
#pragma once
#include <string>
#include <vector>

#include "core/enum_table.h"

namespace pt {

class ViewerModel;

enum class ScriptVerb { Orbit, Emission, Select, Region, Screenshot, Quit };

template <>
struct EnumTable<ScriptVerb> {
  static constexpr std::array<EnumEntry<ScriptVerb>, 6> kEntries{{
      {ScriptVerb::Orbit, "orbit", "DX DY: orbit as a drag of DX, DY image heights would (1 = half a turn)"},
      {ScriptVerb::Emission, "emission", "MATERIAL STRENGTH: set that material's emission strength (0 = off)"},
      {ScriptVerb::Select, "select", "FX FY: click the image at that point (fractions of its width and height): "
                                     "select the material and object there"},
      {ScriptVerb::Region, "region", "FX0 FY0 FX1 FY1: set the render region, corners as fractions of the image "
                                     "(0 0 1 1 clears it)"},
      {ScriptVerb::Screenshot, "screenshot", "FILE: write the window as it is drawn next (PNG, panels included)"},
      {ScriptVerb::Quit, "quit", "quit (asking first if the scene has unsaved edits, as Esc does)"},
  }};
};

struct ScriptAction {
  double at_seconds = 0.0;
  ScriptVerb verb = ScriptVerb::Quit;
  std::string name;            // emission: the material; screenshot: the file
  double x = 0.0, y = 0.0;     // orbit: DX, DY; emission: x = the strength; select, region: a point
  double x1 = 0.0, y1 = 0.0;   // region: the other corner
  int line = 0;                // in the file, for messages
};

// Parses a script; throws std::runtime_error("FILE:LINE: reason") on the first bad line.
std::vector<ScriptAction> parse_viewer_script(const std::string& text, const std::string& file);
// Reads and parses FILE; throws std::runtime_error naming the file on a read error.
std::vector<ScriptAction> read_viewer_script(const std::string& file);

// Applies one action to the model. Returns "" or why it could not be applied (an unknown material, a value the
// scene refuses): the window prints that, as the panels show a refused value. Screenshot is the window's own
// (it alone reads the drawn pixels): here it does nothing.
std::string apply_script_action(ViewerModel& model, const ScriptAction& action);

// The actions of a script that are due at `seconds`, in order; `next` is the index of the first not yet run.
class ViewerScript {
 public:
  ViewerScript() = default;
  explicit ViewerScript(std::vector<ScriptAction> actions) : actions_(std::move(actions)) {}
  template <class F>
  void run_due(double seconds, F&& apply) {
    while (next_ < actions_.size() && actions_[next_].at_seconds <= seconds) apply(actions_[next_++]);
  }
  bool empty() const { return actions_.empty(); }

 private:
  std::vector<ScriptAction> actions_;
  size_t next_ = 0;
};

}  // namespace pt
