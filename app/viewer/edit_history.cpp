#include "viewer/edit_history.h"

#include <algorithm>

namespace pt {

std::vector<EmissionSetting> emission_settings_of(const std::vector<MaterialDesc>& materials) {
  std::vector<EmissionSetting> out(materials.size());
  for (size_t i = 0; i < materials.size(); ++i) {
    const Rgb e = materials[i].emission;
    const float s = max_component(e);
    out[i] = s > 0.f ? EmissionSetting{e / s, s} : EmissionSetting{Rgb(1.f), 0.f};
  }
  return out;
}

SceneState scene_state(const SceneDesc& d, std::vector<EmissionSetting> emission, bool geometry, uint64_t id) {
  SceneState s;
  s.materials = d.materials;
  s.emission = std::move(emission);
  s.environment = d.environment;
  s.render = d.render;
  s.width = d.width;
  s.height = d.height;
  if (geometry) {
    s.shapes = std::make_shared<const std::vector<ShapeDesc>>(d.shapes);
    s.objects = d.objects;
    s.instances = d.instances;
  }
  s.id = id;
  return s;
}

void EditHistory::clear() {
  undo_.clear();
  redo_.clear();
  last_what_.clear();
  current_id_ = saved_id_ = 0;
}

bool EditHistory::continues_drag(const std::string& what, bool geometry, Clock::time_point now) const {
  return !undo_.empty() && what == last_what_ && now - last_time_ < std::chrono::seconds(1) &&
         (!geometry || undo_.back().shapes);
}

void EditHistory::record(const std::string& what, bool geometry, const std::function<SceneState()>& before,
                         Clock::time_point now) {
  const bool same_drag = continues_drag(what, geometry, now);
  last_time_ = now;
  redo_.clear();
  if (!same_drag) {
    last_what_ = what;
    undo_.push_back(before());
    if (undo_.size() > kMaxSteps) undo_.erase(undo_.begin());
  }
  current_id_ = next_id_++;
}

std::optional<SceneState> EditHistory::move(std::vector<SceneState>& from, std::vector<SceneState>& to,
                                            SceneState current) {
  if (from.empty()) return std::nullopt;
  to.push_back(std::move(current));
  SceneState s = std::move(from.back());
  from.pop_back();
  current_id_ = s.id;
  end_drag();
  return s;
}

std::optional<SceneState> EditHistory::undo(SceneState current) { return move(undo_, redo_, std::move(current)); }
std::optional<SceneState> EditHistory::redo(SceneState current) { return move(redo_, undo_, std::move(current)); }

SceneState EditHistory::revert(SceneState current, SceneState target) {
  redo_.clear();
  undo_.push_back(std::move(current));
  current_id_ = target.id;
  end_drag();
  return target;
}

}  // namespace pt
