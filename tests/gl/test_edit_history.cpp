// EditHistory (app/viewer/edit_history.h) on its own, with a clock the test sets: drags coalesce, undo and redo
// move states between the stacks with their ids, and the saved id tracks the "*" of unsaved edits.
#include <doctest/doctest.h>

#include "viewer/edit_history.h"

using namespace pt;

namespace {

SceneState state_with_width(int width, bool geometry = false) {
  SceneDesc d;
  d.width = width;
  return scene_state(d, {}, geometry, 0);
}

}  // namespace

TEST_CASE("edit history: a drag within a second is one step and another thing or a pause or a save starts a new one") {
  EditHistory h;
  using namespace std::chrono_literals;
  const auto t0 = EditHistory::Clock::time_point{} + 100s;
  int captured = 0;
  auto before = [&](int w) { return [&, w] { ++captured; return state_with_width(w); }; };
  h.record("material 1", false, before(1), t0);
  h.record("material 1", false, before(2), t0 + 300ms);   // the same drag
  h.record("material 1", false, before(3), t0 + 600ms);   // still (0.3 s after the last edit)
  CHECK(captured == 1);  // a drag's later edits capture nothing
  h.record("material 2", false, before(4), t0 + 700ms);   // another thing
  h.record("material 2", false, before(5), t0 + 1800ms);  // a pause of 1.1 s
  CHECK(captured == 3);
  h.mark_saved();
  h.record("material 2", false, before(6), t0 + 1900ms);  // after a save: a step of its own
  CHECK(captured == 4);
  // Undo returns the states in reverse order of recording; each undo takes the current state onto redo.
  std::vector<int> widths;
  while (h.can_undo()) widths.push_back(h.undo(state_with_width(-1))->width);
  CHECK(widths == std::vector<int>{6, 5, 4, 1});
  CHECK(h.can_redo());
}

TEST_CASE("edit history: undo and redo restore the states' ids so that undoing back to the saved state clears the mark") {
  EditHistory h;
  const auto t = EditHistory::Clock::time_point{};
  CHECK_FALSE(h.unsaved());
  h.record("render", false, [&] { SceneState s = state_with_width(10); s.id = h.current_id(); return s; }, t);
  CHECK(h.unsaved());
  const uint64_t edited = h.current_id();
  SceneState now = state_with_width(20);
  now.id = edited;
  const std::optional<SceneState> back = h.undo(now);
  REQUIRE(back);
  CHECK(back->width == 10);
  CHECK(h.current_id() == 0);
  CHECK_FALSE(h.unsaved());  // back at the loaded state
  const std::optional<SceneState> again = h.redo(*back);
  REQUIRE(again);
  CHECK(again->width == 20);
  CHECK(h.current_id() == edited);
  CHECK(h.unsaved());
  CHECK_FALSE(h.redo(*again));  // nothing left to redo
  // A new edit clears redo.
  h.undo(*again);
  h.record("render", false, [&] { return state_with_width(30); }, EditHistory::Clock::time_point{} + std::chrono::hours(1));
  CHECK_FALSE(h.can_redo());
}

TEST_CASE("edit history: the shapes travel only with geometry steps and revert is one undoable step") {
  EditHistory h;
  const auto t = EditHistory::Clock::time_point{};
  h.record("material 0", false, [] { return state_with_width(1); }, t);
  CHECK_FALSE(h.undo_has_shapes());
  h.record("shape 3", true, [] { return state_with_width(2, true); }, t);
  CHECK(h.undo_has_shapes());
  const SceneState target = h.revert(state_with_width(3, true), state_with_width(0, true));
  CHECK(target.width == 0);
  CHECK(h.current_id() == 0);
  CHECK_FALSE(h.unsaved());
  const std::optional<SceneState> undone = h.undo(state_with_width(0, true));
  REQUIRE(undone);
  CHECK(undone->width == 3);  // undoing the revert brings the edited scene back
  CHECK(undone->shapes != nullptr);
}
