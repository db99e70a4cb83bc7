#include "viewer/viewer_panels.h"

#include <imgui.h>

#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "scene/scene_json.h"
#include "core/thread_pool.h"
#include "viewer/viewer_model.h"

namespace pt {

namespace {

// A combo box over an enum's table (core/enum_table.h): the labels the viewer shows live with the enum.
template <class E>
bool enum_combo(const char* label, E& value) {
  bool changed = false;
  if (ImGui::BeginCombo(label, enum_label(value))) {
    for (const auto& entry : enum_entries<E>()) {
      const bool selected = entry.value == value;
      if (ImGui::Selectable(entry.label, selected) && !selected) {
        value = entry.value;
        changed = true;
      }
      if (selected) ImGui::SetItemDefaultFocus();
    }
    ImGui::EndCombo();
  }
  return changed;
}


const ImVec4 kErrorColour(1.f, 0.45f, 0.4f, 1.f);
const ImVec4 kDimColour(0.65f, 0.65f, 0.65f, 1.f);

// Opens the next header or tree node when the caller asked for everything expanded.
void expand_if(const PanelState& state) {
  if (state.expand_all) ImGui::SetNextItemOpen(true);
}

ImU32 palette_u32(size_t i) {
  const auto& c = kFalseColour[i];
  return IM_COL32(c[0], c[1], c[2], 255);
}

void copy_string(char* dst, size_t size, const std::string& src) {
  std::snprintf(dst, size, "%s", src.c_str());
}

std::string format_rate(double per_second) {
  char buf[32];
  if (per_second >= 1e6) std::snprintf(buf, sizeof buf, "%.2f M", per_second * 1e-6);
  else if (per_second >= 1e3) std::snprintf(buf, sizeof buf, "%.1f k", per_second * 1e-3);
  else std::snprintf(buf, sizeof buf, "%.0f ", per_second);
  return buf;
}

// The false-colour bar with labels at both ends (and the middle), exactly the palette the shader uses.
void legend(const char* left, const char* middle, const char* right) {
  const float w = ImGui::GetContentRegionAvail().x, h = ImGui::GetTextLineHeight();
  const ImVec2 p = ImGui::GetCursorScreenPos();
  ImDrawList* dl = ImGui::GetWindowDrawList();
  const size_t n = kFalseColour.size() - 1;
  for (size_t i = 0; i < n; ++i) {
    const float x0 = p.x + w * static_cast<float>(i) / n, x1 = p.x + w * static_cast<float>(i + 1) / n;
    dl->AddRectFilledMultiColor(ImVec2(x0, p.y), ImVec2(x1, p.y + h), palette_u32(i), palette_u32(i + 1),
                                palette_u32(i + 1), palette_u32(i));
  }
  ImGui::Dummy(ImVec2(w, h));
  ImGui::TextUnformatted(left);
  ImGui::SameLine(0.5f * w - 0.5f * ImGui::CalcTextSize(middle).x);
  ImGui::TextUnformatted(middle);
  ImGui::SameLine(w - ImGui::CalcTextSize(right).x);
  ImGui::TextUnformatted(right);
}

// Estimated relMSE against render time: linear time axis, log10 error axis with a line per decade.
void relmse_plot(const std::vector<RelMsePoint>& h) {
  const ImVec2 size(ImGui::GetContentRegionAvail().x, 90.f);
  const ImVec2 p0 = ImGui::GetCursorScreenPos();
  const ImVec2 p1(p0.x + size.x, p0.y + size.y);
  ImGui::Dummy(size);
  ImDrawList* dl = ImGui::GetWindowDrawList();
  dl->AddRectFilled(p0, p1, ImGui::GetColorU32(ImGuiCol_FrameBg));
  if (h.size() < 2) {
    dl->AddText(ImVec2(p0.x + 6, p0.y + 6), ImGui::GetColorU32(ImGuiCol_TextDisabled), "relMSE plot: waiting for 2 estimates");
    return;
  }
  double lo = std::log10(h.front().relmse), hi = lo;
  for (const RelMsePoint& q : h) {
    const double l = std::log10(q.relmse);
    lo = std::min(lo, l);
    hi = std::max(hi, l);
  }
  lo = std::floor(lo);
  hi = std::max(std::ceil(hi), lo + 1.0);
  const double t_max = std::max(h.back().seconds, 1e-9);
  auto map = [&](const RelMsePoint& q) {
    return ImVec2(p0.x + static_cast<float>(q.seconds / t_max) * size.x,
                  p1.y - static_cast<float>((std::log10(q.relmse) - lo) / (hi - lo)) * size.y);
  };
  const ImU32 grid = ImGui::GetColorU32(ImGuiCol_Border), text = ImGui::GetColorU32(ImGuiCol_TextDisabled);
  for (double d = lo; d <= hi; d += 1.0) {
    const float y = p1.y - static_cast<float>((d - lo) / (hi - lo)) * size.y;
    dl->AddLine(ImVec2(p0.x, y), ImVec2(p1.x, y), grid);
    char label[16];
    std::snprintf(label, sizeof label, "1e%d", static_cast<int>(d));
    dl->AddText(ImVec2(p0.x + 3, std::min(y, p1.y - ImGui::GetTextLineHeight())), text, label);
  }
  ImVec2 prev = map(h.front());
  for (size_t i = 1; i < h.size(); ++i) {
    const ImVec2 cur = map(h[i]);
    dl->AddLine(prev, cur, IM_COL32(250, 200, 80, 255), 1.5f);
    prev = cur;
  }
  char label[32];
  std::snprintf(label, sizeof label, "%.1f s", t_max);
  dl->AddText(ImVec2(p1.x - ImGui::CalcTextSize(label).x - 3, p0.y + 2), text, label);
}

void render_section(ViewerModel& model, PanelState& state) {
  expand_if(state);
  if (!ImGui::CollapsingHeader("Render", ImGuiTreeNodeFlags_DefaultOpen)) return;
  RenderSettings r = model.scene().render;
  bool changed = enum_combo("estimator", r.estimator);
  changed |= enum_combo("sampler", r.sampler);
  changed |= ImGui::InputInt("max bounces", &r.max_bounces);
  changed |= ImGui::InputInt("RR from bounce", &r.russian_roulette_depth);
  if (ImGui::IsItemHovered()) ImGui::SetTooltip("Russian roulette from this bounce on; -1 = off");
  if (changed) {
    r.max_bounces = std::clamp(r.max_bounces, 0, 1 << 20);
    r.russian_roulette_depth = std::max(r.russian_roulette_depth, -1);
    model.set_render(r);
  }

  SessionSettings s = model.session_settings();
  bool settings_changed = ImGui::SliderInt("threads", &s.threads, 0, 4 * hardware_threads(),
                                           s.threads == 0 ? "all" : "%d");
  ImGui::TextDisabled("stop at (0 = no limit):");
  settings_changed |= ImGui::InputScalar("spp", ImGuiDataType_U64, &s.stop.spp, nullptr, nullptr, "%" PRIu64);
  settings_changed |= ImGui::InputDouble("seconds", &s.stop.seconds, 0.0, 0.0, "%.1f");
  settings_changed |= ImGui::InputDouble("relMSE", &s.stop.relmse, 0.0, 0.0, "%.2e");
  if (settings_changed) {
    s.threads = std::max(s.threads, 0);
    s.stop.seconds = std::max(s.stop.seconds, 0.0);
    s.stop.relmse = std::max(s.stop.relmse, 0.0);
    model.set_session_settings(s);
  }
  if (ImGui::Button(model.paused() ? "Resume [P]" : "Pause [P]")) model.set_paused(!model.paused());
  ImGui::SameLine();
  if (ImGui::Button("Reset [R]")) model.restart();

  const SessionStats st = model.session().stats();
  const char* state_text = !st.error.empty() ? "scene error"
                           : st.paused      ? "paused"
                           : st.done        ? "done"
                           : st.rendering   ? "rendering"
                                            : "idle";
  ImGui::Text("%" PRIu64 " spp   %.1f s   %s%s%s", st.spp, st.seconds, state_text, st.done ? ": " : "",
              st.done ? st.stop_reason.c_str() : "");
  ImGui::Text("%ssamples/s   %srays/s   %d threads", format_rate(st.samples_per_second).c_str(),
              format_rate(st.rays_per_second).c_str(), st.threads);
  if (std::isfinite(st.estimated_relmse)) ImGui::Text("estimated relMSE %.3e", st.estimated_relmse);
  else ImGui::TextDisabled("estimated relMSE: from 2 spp on");
  if (st.rejected) ImGui::TextColored(kErrorColour, "%" PRIu64 " non-finite samples rejected", st.rejected);
  if (!st.error.empty()) ImGui::TextColored(kErrorColour, "%s", st.error.c_str());
  model.session().copy_history(state.history);
  relmse_plot(state.history);
}

void display_section(ViewerModel& model, const PanelState& state, const ShownImage& shown) {
  expand_if(state);
  if (!ImGui::CollapsingHeader("Display", ImGuiTreeNodeFlags_DefaultOpen)) return;
  PresentSettings& p = model.present;
  int mode = static_cast<int>(p.mode);
  ImGui::RadioButton("colour", &mode, 0);
  ImGui::SameLine();
  ImGui::RadioButton("rel. error", &mode, 1);
  ImGui::SameLine();
  ImGui::RadioButton("samples", &mode, 2);
  p.mode = static_cast<ViewMode>(mode);
  // Denoising: the session gathers the feature buffers and denoises on its render thread (turning it on
  // restarts the accumulation); the view picks the raw film, the denoised image, or both halves side by side.
  SessionSettings ss = model.session_settings();
  if (ImGui::Checkbox("denoise", &ss.denoise)) model.set_session_settings(ss);
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip("Feature-guided a-trous filter (docs/denoising.md); saved PFMs stay the raw estimate");
  if (ss.denoise) {
    int view = static_cast<int>(p.denoise_view);
    ImGui::SameLine();
    ImGui::RadioButton("raw", &view, 0);
    ImGui::SameLine();
    ImGui::RadioButton("denoised", &view, 1);
    ImGui::SameLine();
    ImGui::RadioButton("split", &view, 2);
    p.denoise_view = static_cast<DenoiseView>(view);
  }
  ImGui::SliderFloat("exposure", &p.display.exposure_ev, -10.f, 10.f, "%+.2f EV");
  int tone = static_cast<int>(p.display.tone_map);
  if (ImGui::Combo("tone map", &tone, "none (clamp)\0Reinhard\0ACES fitted\0"))
    p.display.tone_map = static_cast<ToneMap>(tone);
  if (p.mode == ViewMode::RelativeError) {
    ImGui::DragFloatRange2("log10 range", &p.error_log10_min, &p.error_log10_max, 0.05f, -8.f, 2.f, "%.1f");
    if (p.error_log10_max <= p.error_log10_min) p.error_log10_max = p.error_log10_min + 0.1f;
    char lo[32], mid[32], hi[32];
    std::snprintf(lo, sizeof lo, "%.0e", std::pow(10.0, p.error_log10_min));
    std::snprintf(mid, sizeof mid, "%.0e", std::pow(10.0, 0.5 * (p.error_log10_min + p.error_log10_max)));
    std::snprintf(hi, sizeof hi, ">= %.0e", std::pow(10.0, p.error_log10_max));
    ImGui::TextDisabled("relative standard error per pixel (log scale)");
    legend(lo, mid, hi);
  } else if (p.mode == ViewMode::SampleCount) {
    char hi[32], mid[32];
    std::snprintf(mid, sizeof mid, "%.0f", 0.5 * shown.max_count);
    std::snprintf(hi, sizeof hi, "%.0f spp", shown.max_count);
    ImGui::TextDisabled("samples per pixel (linear)");
    legend("0", mid, hi);
  }
}

void camera_section(ViewerModel& model, const PanelState& state) {
  expand_if(state);
  if (!ImGui::CollapsingHeader("Camera")) return;
  const CameraDesc& c = model.camera().camera();
  float fov = static_cast<float>(c.fov_deg);
  if (ImGui::SliderFloat(c.fov_axis == FovAxis::Vertical ? "vertical fov" : "horizontal fov", &fov, 5.f, 150.f, "%.2f°"))
    model.set_fov(fov);
  double pos[3] = {c.position.x, c.position.y, c.position.z};
  if (ImGui::InputScalarN("position", ImGuiDataType_Double, pos, 3, nullptr, nullptr, "%.3f",
                          ImGuiInputTextFlags_EnterReturnsTrue))
    model.set_camera_position({pos[0], pos[1], pos[2]});
  double target[3] = {c.look_at.x, c.look_at.y, c.look_at.z};
  if (ImGui::InputScalarN("target", ImGuiDataType_Double, target, 3, nullptr, nullptr, "%.3f",
                          ImGuiInputTextFlags_EnterReturnsTrue))
    model.set_camera_target({target[0], target[1], target[2]});
  if (ImGui::Button("Reset to scene camera")) model.reset_camera();
  ImGui::TextDisabled("fly speed %.3g units/s (shift: 4x)", model.camera().fly_speed());
}

void environment_section(ViewerModel& model, const PanelState& state) {
  expand_if(state);
  if (!ImGui::CollapsingHeader("Environment")) return;
  EnvironmentDesc e = model.scene().environment;
  bool changed = enum_combo("type", e.type);
  switch (e.type) {
    case EnvironmentType::Constant:
      changed |= ImGui::ColorEdit3("radiance", &e.radiance.x, ImGuiColorEditFlags_Float | ImGuiColorEditFlags_HDR);
      break;
    case EnvironmentType::Sky: {
      // The sun direction as elevation above the horizon and azimuth about +y (0° = towards −z).
      const DVec3 d = glm::normalize(e.sun_direction);
      float elevation = static_cast<float>(glm::degrees(std::asin(std::clamp(d.y, -1.0, 1.0))));
      float azimuth = static_cast<float>(glm::degrees(std::atan2(d.x, -d.z)));
      bool sun_changed = ImGui::SliderFloat("sun elevation", &elevation, 0.f, 90.f, "%.1f°");
      sun_changed |= ImGui::SliderFloat("sun azimuth", &azimuth, -180.f, 180.f, "%.1f°");
      if (sun_changed) {
        const double el = glm::radians(double(elevation)), az = glm::radians(double(azimuth));
        e.sun_direction = {std::cos(el) * std::sin(az), std::sin(el), -std::cos(el) * std::cos(az)};
        changed = true;
      }
      changed |= ImGui::SliderFloat("turbidity", &e.turbidity, 1.7f, 10.f, "%.2f", ImGuiSliderFlags_AlwaysClamp);
      changed |= ImGui::Checkbox("sun disk", &e.sun);
      changed |= ImGui::DragFloat("scale", &e.scale, 0.01f, 0.f, 1e4f, "%.3f", ImGuiSliderFlags_Logarithmic | ImGuiSliderFlags_AlwaysClamp);
      break;
    }
    case EnvironmentType::Map: {
      char file[512];
      std::snprintf(file, sizeof file, "%s", e.file.c_str());
      if (ImGui::InputText("file", file, sizeof file, ImGuiInputTextFlags_EnterReturnsTrue)) {
        e.file = file;
        changed = true;
      }
      changed |= ImGui::SliderFloat("rotation", &e.rotation_deg, -180.f, 180.f, "%.1f°");
      changed |= ImGui::DragFloat("scale", &e.scale, 0.01f, 0.f, 1e4f, "%.3f", ImGuiSliderFlags_Logarithmic | ImGuiSliderFlags_AlwaysClamp);
      break;
    }
  }
  if (changed) model.set_environment(e);
}

void materials_section(ViewerModel& model, const PanelState& state) {
  expand_if(state);
  if (!ImGui::CollapsingHeader("Materials")) return;
  const std::vector<MaterialDesc>& mats = model.scene().materials;
  for (size_t i = 0; i < mats.size(); ++i) {
    ImGui::PushID(static_cast<int>(i));
    expand_if(state);
    if (ImGui::TreeNode(mats[i].name.c_str())) {
      MaterialDesc m = mats[i];
      bool changed = enum_combo("type", m.type);
      const MaterialType t = m.type;
      const bool rough = t == MaterialType::Conductor || t == MaterialType::Dielectric || t == MaterialType::Plastic;
      const bool has_ior = t == MaterialType::Dielectric || t == MaterialType::Plastic || t == MaterialType::Subsurface;
      if (t == MaterialType::Conductor) {
        changed |= enum_combo("metal", m.metal);
        if (m.metal != MetalPreset::None) m.complex_ior = false;
      }
      const bool uses_albedo = t != MaterialType::Dielectric && !(t == MaterialType::Conductor && (m.metal != MetalPreset::None || m.complex_ior));
      if (uses_albedo) changed |= ImGui::ColorEdit3("albedo", &m.albedo.x, ImGuiColorEditFlags_Float);
      if (rough) changed |= ImGui::SliderFloat("roughness", &m.roughness, 0.f, 1.f, "%.3f", ImGuiSliderFlags_AlwaysClamp);
      if (has_ior) changed |= ImGui::DragFloat("IOR", &m.ior, 0.002f, 1.0f, 4.0f, "%.3f", ImGuiSliderFlags_AlwaysClamp);
      if (t == MaterialType::Subsurface)
        changed |= ImGui::SliderFloat("g (anisotropy)", &m.g, -0.95f, 0.95f, "%.2f", ImGuiSliderFlags_AlwaysClamp);
      changed |= ImGui::Checkbox("two-sided emission", &m.two_sided);
      if (changed) model.set_material(i, m);
      Rgb colour = model.emission_colour(i);
      float strength = model.emission_strength(i);
      bool emission_changed = ImGui::ColorEdit3("emission", &colour.x, ImGuiColorEditFlags_Float);
      emission_changed |= ImGui::DragFloat("strength", &strength, 0.05f, 0.f, 1e5f, "%.3f",
                                           ImGuiSliderFlags_Logarithmic | ImGuiSliderFlags_AlwaysClamp);
      if (emission_changed) model.set_emission(i, colour, strength);
      ImGui::TreePop();
    }
    ImGui::PopID();
  }
}

void scene_section(ViewerModel& model, PanelState& state) {
  expand_if(state);
  if (!ImGui::CollapsingHeader("Scene")) return;
  if (state.builtin_names.empty()) state.builtin_names = builtin_scene_names();
  ImGui::Text("%s: %d x %d, %zu shapes, %zu materials", model.scene_name().c_str(), model.scene().width,
              model.scene().height, model.scene().shapes.size(), model.scene().materials.size());
  const char* current = state.builtin_names[std::clamp<size_t>(state.builtin, 0, state.builtin_names.size() - 1)].c_str();
  if (ImGui::BeginCombo("built-in", current)) {
    for (size_t i = 0; i < state.builtin_names.size(); ++i)
      if (ImGui::Selectable(state.builtin_names[i].c_str(), static_cast<int>(i) == state.builtin)) state.builtin = static_cast<int>(i);
    ImGui::EndCombo();
  }
  ImGui::SameLine();
  if (ImGui::Button("Load##builtin")) model.load(state.builtin_names[state.builtin]);
  ImGui::InputText("file", state.scene_path, sizeof state.scene_path);
  ImGui::SameLine();
  if (ImGui::Button("Load##file")) model.load(state.scene_path);
  ImGui::InputText("save as", state.save_scene_path, sizeof state.save_scene_path);
  ImGui::SameLine();
  if (ImGui::Button("Save")) model.save_scene(state.save_scene_path);
}

void output_section(ViewerModel& model, PanelState& state, const ShownImage& shown) {
  expand_if(state);
  if (!ImGui::CollapsingHeader("Output")) return;
  if (ImGui::InputText("folder", state.output_dir, sizeof state.output_dir)) model.output_dir = state.output_dir;
  ImGui::BeginDisabled(shown.width == 0);
  if (ImGui::Button("Save image: PNG + PFM [S]")) model.save_requested = true;
  ImGui::EndDisabled();
  ImGui::TextDisabled("PNG: the image as shown; PFM: linear mean radiance");
}

void help_section(ViewerModel& model) {
  ImGui::SetNextItemOpen(model.help_open);
  model.help_open = ImGui::CollapsingHeader("Help [F1]");
  if (!model.help_open) return;
  static const char* const rows[][2] = {
      {"left drag", "orbit around the target"},    {"middle / shift+left drag", "pan"},
      {"wheel", "dolly towards / away"},           {"right drag", "look around"},
      {"right held + WASD QE", "fly (shift: 4x)"}, {"R", "reset accumulation"},
      {"P", "pause / resume"},                     {"S", "save image (PNG + PFM)"},
      {"Tab", "hide / show panels"},               {"F1", "this help"},
      {"Esc", "quit"}};
  if (ImGui::BeginTable("keys", 2, ImGuiTableFlags_SizingFixedFit)) {
    for (const auto& r : rows) {
      ImGui::TableNextRow();
      ImGui::TableNextColumn();
      ImGui::TextUnformatted(r[0]);
      ImGui::TableNextColumn();
      ImGui::TextUnformatted(r[1]);
    }
    ImGui::EndTable();
  }
}

}  // namespace

float draw_viewer_panels(ViewerModel& model, PanelState& state, const ShownImage& shown) {
  if (!model.ui_visible) return 0.f;
  if (state.output_dir[0] == '\0' || model.output_dir != state.output_dir) copy_string(state.output_dir, sizeof state.output_dir, model.output_dir);
  const ImGuiIO& io = ImGui::GetIO();
  const float width = std::min(kPanelWidth, io.DisplaySize.x);
  ImGui::SetNextWindowPos(ImVec2(io.DisplaySize.x - width, 0.f));
  ImGui::SetNextWindowSize(ImVec2(width, io.DisplaySize.y));
  ImGui::Begin("pathtracer", nullptr,
               ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoResize | ImGuiWindowFlags_NoCollapse |
                   ImGuiWindowFlags_NoSavedSettings);
  ImGui::PushItemWidth(-110.f);
  ImGui::Text("%s  %dx%d%s  %.1f ms/frame", model.scene_name().c_str(), shown.width, shown.height,
              shown.preview ? " (preview)" : "", shown.frame_ms);
  if (shown.edit_latency_ms >= 0) ImGui::TextDisabled("last edit shown after %.0f ms", shown.edit_latency_ms);
  if (!model.status().empty()) {
    if (model.status_is_error()) ImGui::PushStyleColor(ImGuiCol_Text, kErrorColour);
    else ImGui::PushStyleColor(ImGuiCol_Text, kDimColour);
    ImGui::TextWrapped("%s", model.status().c_str());
    ImGui::PopStyleColor();
  }
  render_section(model, state);
  display_section(model, state, shown);
  camera_section(model, state);
  materials_section(model, state);
  environment_section(model, state);
  scene_section(model, state);
  output_section(model, state, shown);
  help_section(model);
  ImGui::PopItemWidth();
  ImGui::End();
  return width;
}

}  // namespace pt
