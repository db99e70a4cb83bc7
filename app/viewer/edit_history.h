// The viewer's undo history: scene states rather than commands (a state is small next to the work an edit
// starts, a full restart of the render), kept on two stacks, and the ids that say which state is the one last
// loaded or saved (the "*" of unsaved edits). ViewerModel records a state before every scene edit and restores
// the states undo and redo hand back; camera moves are views and are never recorded.
#pragma once
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "scene/scene_desc.h"

namespace pt {

// A material's emission as the panel edits it: a colour (max component 1) times a strength, kept apart so that
// strength 0 keeps the colour.
struct EmissionSetting {
  Rgb colour{1.f};
  float strength = 0.f;
};
std::vector<EmissionSetting> emission_settings_of(const std::vector<MaterialDesc>& materials);

// What undo restores: everything an edit may change but the camera; the shapes only when the edit changed
// geometry (scenes may have millions).
struct SceneState {
  std::vector<MaterialDesc> materials;
  std::vector<EmissionSetting> emission;
  EnvironmentDesc environment;
  RenderSettings render;
  int width = 0, height = 0;
  std::shared_ptr<const std::vector<ShapeDesc>> shapes;  // null: not part of this state
  std::vector<ObjectDesc> objects;                        // with the shapes
  std::vector<InstanceDesc> instances;                    // with the shapes (their materials; the meshes stay)
  uint64_t id = 0;  // which scene state this is (EditHistory::current_id)
};
SceneState scene_state(const SceneDesc& scene, std::vector<EmissionSetting> emission, bool geometry, uint64_t id);

class EditHistory {
 public:
  using Clock = std::chrono::steady_clock;
  static constexpr size_t kMaxSteps = 256;

  // Starts afresh for a newly loaded scene: no steps, and the loaded state (id 0) is the saved one.
  void clear();

  // Before an edit of `what` (a name for the thing edited, e.g. "material 3"), with the state it changes: pushed
  // as an undo step, unless the edit continues a drag (the same thing edited again within a second, and the last
  // step holds the shapes if this edit changes geometry), which stays one step. Clears redo; the edit about to be
  // applied makes a new current state.
  // `before` is called only when a step is pushed (it copies the shapes for a geometry edit).
  void record(const std::string& what, bool geometry, const std::function<SceneState()>& before,
              Clock::time_point now);
  // The next edit is a step of its own, even within a drag's second (after a save, an undo, a restore).
  void end_drag() { last_what_.clear(); }

  bool can_undo() const { return !undo_.empty(); }
  bool can_redo() const { return !redo_.empty(); }
  // Whether the step undo (redo) would restore holds the shapes: the current state pushed onto the other stack
  // must then hold them too.
  bool undo_has_shapes() const { return !undo_.empty() && undo_.back().shapes != nullptr; }
  bool redo_has_shapes() const { return !redo_.empty() && redo_.back().shapes != nullptr; }
  // One move between the stacks: `current` goes onto the other stack, the state returned is to be restored
  // (it becomes the current state); nullopt when there is nothing to undo (redo).
  std::optional<SceneState> undo(SceneState current);
  std::optional<SceneState> redo(SceneState current);
  // Back to `target` (revert: the scene as loaded) as one undoable step from `current`.
  SceneState revert(SceneState current, SceneState target);

  uint64_t current_id() const { return current_id_; }
  void mark_saved() { saved_id_ = current_id_; end_drag(); }
  // The scene differs from the state last loaded or saved (undoing back to that state clears it).
  bool unsaved() const { return current_id_ != saved_id_; }

 private:
  std::optional<SceneState> move(std::vector<SceneState>& from, std::vector<SceneState>& to, SceneState current);
  bool continues_drag(const std::string& what, bool geometry, Clock::time_point now) const;

  std::vector<SceneState> undo_, redo_;
  std::string last_what_;
  Clock::time_point last_time_;
  // Every state an edit makes gets a new id; undo and redo bring back a state's id with the state. The loaded
  // state's id is 0 (revert returns there).
  uint64_t current_id_ = 0, saved_id_ = 0, next_id_ = 1;
};

}  // namespace pt
