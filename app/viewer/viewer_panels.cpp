#include "viewer/viewer_panels.h"

#include "materials/texture.h"

#include <imgui.h>
#include <imgui_internal.h>

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <functional>
#include <string_view>
#include <initializer_list>

#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "integrators/russian_roulette.h"
#include "scene/scene_json.h"
#include "core/thread_pool.h"
#include "viewer/relmse_axis.h"
#include "viewer/viewer_prefs.h"
#include "viewer/viewer_model.h"

namespace pt {

namespace {

const ImVec4 kErrorColour(1.f, 0.45f, 0.4f, 1.f);
const ImVec4 kDimColour(0.65f, 0.65f, 0.65f, 1.f);

// Tests find widgets by name (PanelState::record_items).
void note_item(PanelState& st, const char* label) {
  if (!st.record_items) return;
  const ImVec2 a = ImGui::GetItemRectMin(), b = ImGui::GetItemRectMax();
  st.item_rects[st.scope + label] = {a.x, a.y, b.x, b.y};
}

// A combo box over an enum's table (core/enum_table.h): the labels the viewer shows live with the enum.
template <class E>
bool enum_combo(PanelState& st, const char* label, E& value) {
  bool changed = false;
  const bool open = ImGui::BeginCombo(label, enum_label(value));
  note_item(st, label);
  if (open) {
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

// Radio buttons on one line for an enum's first `count` values (all by default), with the table's labels.
template <class E>
void radio_row(E& value, size_t count = enum_entries<E>().size()) {
  const auto entries = enum_entries<E>();
  for (size_t i = 0; i < count && i < entries.size(); ++i) {
    if (i > 0) ImGui::SameLine();
    if (ImGui::RadioButton(entries[i].label, value == entries[i].value)) value = entries[i].value;
  }
}

FieldMemory* find_refused(PanelState& st, ImGuiID id) {
  for (FieldMemory& m : st.refused)
    if (m.id == id) return &m;
  return nullptr;
}

void forget_refused(PanelState& st, ImGuiID id) {
  std::erase_if(st.refused, [&](const FieldMemory& m) { return m.id == id; });
}

template <class T, size_t N>
void store(FieldMemory& m, ImGuiID id, const std::array<T, N>& v) {
  static_assert(sizeof v <= sizeof m.bytes);
  m.id = id;
  std::memcpy(m.bytes.data(), v.data(), sizeof v);
}

template <class T, size_t N>
void load(const FieldMemory& m, std::array<T, N>& v) {
  std::memcpy(v.data(), m.bytes.data(), sizeof v);
}

// A numeric field: `draw(T*)` draws the widget (ImGui's "changed" as result), `apply(values)` hands a value to
// the model and returns "" or why it was refused. Typed text (a text field, or a drag or slider turned into
// one by Ctrl+click or double-click) applies once, on Enter or when the field loses focus, and only if it
// differs from the model's value (Esc reverts): typing 1.5 never applies 1 first. A drag or slider moved with
// the mouse applies live. A refused value stays in the field in red with the reason below it until the field
// is edited again; the model keeps its last valid value, and no other field changes.
template <class T, size_t N, class Draw, class Apply>
void numeric_field(PanelState& st, const char* label, std::array<T, N> value, bool text_field, Draw&& draw,
                   Apply&& apply) {
  const ImGuiID id = ImGui::GetID(label);
  const std::array<T, N> model_value = value;
  const FieldMemory* refused = find_refused(st, id);
  if (st.typing.id == id) load(st.typing, value);
  else if (refused) load(*refused, value);
  if (refused) ImGui::PushStyleColor(ImGuiCol_Text, kErrorColour);
  const bool changed = draw(value.data());
  if (refused) ImGui::PopStyleColor();
  note_item(st, label);
  const bool typing = text_field ? ImGui::IsItemActive() : ImGui::TempInputIsActive(ImGui::GetItemID());
  auto commit = [&](const std::array<T, N>& v) {
    const std::string error = apply(v);
    forget_refused(st, id);
    if (!error.empty()) {
      FieldMemory m;
      store(m, id, v);
      m.error = error;
      st.refused.push_back(std::move(m));
    }
  };
  if (typing) {
    if (changed || st.typing.id != id) store(st.typing, id, value);
  } else if (st.typing.id == id) {  // typing just ended: Enter, Tab, a click elsewhere, or Esc
    st.typing.id = 0;
    if (std::memcmp(value.data(), model_value.data(), sizeof value) != 0) commit(value);
    else forget_refused(st, id);
  } else if (changed) {
    commit(value);
  }
  if (const FieldMemory* r = find_refused(st, id)) {
    ImGui::PushStyleColor(ImGuiCol_Text, kErrorColour);
    ImGui::TextWrapped("%s", r->error.c_str());
    ImGui::PopStyleColor();
  }
}

// The model's answer to an edit, as numeric_field wants it.
std::string outcome(bool applied, const ViewerModel& model) { return applied ? std::string() : model.status(); }

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
    char text[64];
    std::snprintf(text, sizeof text, "relMSE plot: from %d spp on", static_cast<int>(kRelMseStopMinSpp));
    dl->AddText(ImVec2(p0.x + 6, p0.y + 6), ImGui::GetColorU32(ImGuiCol_TextDisabled), text);
    return;
  }
  const RelMseAxis axis = relmse_axis(h);
  const double t_max = std::max(h.back().seconds, 1e-9);
  auto map = [&](const RelMsePoint& q) {
    return ImVec2(p0.x + static_cast<float>(std::clamp(q.seconds / t_max, 0.0, 1.0)) * size.x,
                  p1.y - static_cast<float>(axis.fraction(q.relmse)) * size.y);
  };
  const ImU32 grid = ImGui::GetColorU32(ImGuiCol_Border), text = ImGui::GetColorU32(ImGuiCol_TextDisabled);
  if (!axis.any_positive) {  // nothing to put on a log scale: say why instead
    dl->AddText(ImVec2(p0.x + 6, p0.y + 6), text,
                axis.any_zero ? "relMSE 0: the image is black (exact)" : "relMSE: no estimate yet");
    return;
  }
  for (int d = axis.lo; d <= axis.hi; ++d) {
    const float y = p1.y - static_cast<float>(axis.fraction(std::pow(10.0, d))) * size.y;
    dl->AddLine(ImVec2(p0.x, y), ImVec2(p1.x, y), grid);
    char label[16];
    std::snprintf(label, sizeof label, "1e%d", d);
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

std::string format_duration(double s) {
  char buf[32];
  if (s < 60.0) std::snprintf(buf, sizeof buf, "%.1f s", s);
  else if (s < 3600.0) std::snprintf(buf, sizeof buf, "%d min %02d s", static_cast<int>(s / 60.0), static_cast<int>(s) % 60);
  else std::snprintf(buf, sizeof buf, "%d h %02d min", static_cast<int>(s / 3600.0), static_cast<int>(s / 60.0) % 60);
  return buf;
}

// Progress towards the stop condition met first, with the time left at the current rate (render/progressive.h
// stop_progress; for a target relMSE, forecast from the fall of the film's estimate, with a range).
void progress_bar(const ViewerModel& model, const SessionStats& st, const std::vector<RelMsePoint>& history) {
  const StopConditions& stop = model.session_settings().stop;
  if (!stop.any()) return;
  const StopProgress p = stop_progress(stop, st.spp, st.seconds, st.estimated_relmse, history);
  char overlay[128];
  if (st.done) std::snprintf(overlay, sizeof overlay, "done: %s", st.stop_reason.c_str());
  else if (p.fraction < 0.0) std::snprintf(overlay, sizeof overlay, "estimating the time left...");
  else if (p.eta_high > 1.05 * p.eta_low + 0.5)
    std::snprintf(overlay, sizeof overlay, "%s in %s (%s - %s)", p.condition, format_duration(p.eta_seconds).c_str(),
                  format_duration(p.eta_low).c_str(), format_duration(p.eta_high).c_str());
  else std::snprintf(overlay, sizeof overlay, "%s in %s", p.condition, format_duration(p.eta_seconds).c_str());
  ImGui::ProgressBar(st.done ? 1.f : static_cast<float>(std::max(p.fraction, 0.0)), ImVec2(-1.f, 0.f), overlay);
}

// The render region (Blender's render border): drawn on the image with a drag, cleared here or with Ctrl+Alt+B.
void region_row(ViewerModel& model, PanelState& state) {
  if (ImGui::Button(model.drawing_region ? "Drag on the image..." : "Render region [Ctrl+B]"))
    model.drawing_region = !model.drawing_region;
  note_item(state, "render region");
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip("drag a rectangle on the image: only its pixels accumulate (the rest keep what they have)");
  if (const std::optional<PixelRect>& r = model.region()) {
    ImGui::SameLine();
    if (ImGui::Button("Clear region")) model.set_region(std::nullopt);
    note_item(state, "clear region");
    ImGui::TextDisabled("region %d x %d at (%d, %d); spp and relMSE count it alone", r->x1 - r->x0, r->y1 - r->y0,
                        r->x0, r->y0);
  }
}

void render_section(ViewerModel& model, PanelState& state) {
  expand_if(state);
  if (!ImGui::CollapsingHeader("Render", ImGuiTreeNodeFlags_DefaultOpen)) return;
  RenderSettings r = model.scene().render;
  const bool changed_estimator = enum_combo(state, "estimator", r.estimator);
  if (r.estimator == Estimator::Auto) {  // which one auto traces with, and why
    const EstimatorChoice& c = model.estimator_choice();
    ImGui::TextDisabled("auto = %s", to_string(c.estimator));
    if (ImGui::IsItemHovered()) ImGui::SetTooltip("%s", c.reason.c_str());
    ImGui::SameLine();
    ImGui::TextWrapped("%s", c.reason.substr(c.reason.find(':') + 2).c_str());
  }
  const bool changed = changed_estimator | enum_combo(state, "sampler", r.sampler);
  if (changed) model.set_render(r);
  // Integer fields without ImGui's +/- buttons: 1.86's stepped InputScalar trips an assertion of its own
  // (MarkItemEdited) when its typed text changes.
  auto render_field = [&](const char* label, int RenderSettings::*field, const char* tip) {
    numeric_field(state, label, std::array<int, 1>{model.scene().render.*field}, true,
                  [&](int* v) { return ImGui::InputInt(label, v, 0, 0); },
                  [&](const std::array<int, 1>& v) {
                    RenderSettings edited = model.scene().render;
                    edited.*field = v[0];
                    return outcome(model.set_render(edited), model);
                  });
    if (tip && ImGui::IsItemHovered()) ImGui::SetTooltip("%s", tip);
  };
  render_field("max bounces", &RenderSettings::max_bounces, nullptr);
  // Russian roulette: auto (the estimator's measured default, integrators/russian_roulette.h) or a typed bounce.
  {
    RenderSettings edited = model.scene().render;
    bool automatic = edited.russian_roulette_depth == kRouletteDepthAuto;
    const Estimator traced = edited.estimator == Estimator::Auto ? model.estimator_choice().estimator : edited.estimator;
    const int auto_depth =
        roulette_depth(kRouletteDepthAuto, traced == Estimator::Bdpt, lit_from_infinity(model.scene().environment));
    if (ImGui::Checkbox("RR auto", &automatic)) {
      edited.russian_roulette_depth = automatic ? kRouletteDepthAuto : auto_depth;
      model.set_render(edited);
    }
    if (ImGui::IsItemHovered())
      ImGui::SetTooltip("Russian roulette from the estimator's measured best bounce: %d for path tracing; for bdpt %d, "
                        "or %d under a sky, sun or environment",
                        kPathRouletteDepth, kBdptRouletteDepth, kBdptRouletteDepthInfinite);
    if (automatic) {
      ImGui::SameLine();
      ImGui::TextDisabled("from bounce %d", auto_depth);
    } else {
      render_field("RR from bounce", &RenderSettings::russian_roulette_depth,
                   "Russian roulette from this bounce on; -1 = off");
    }
  }

  // Threads and stop conditions: typed values apply on Enter (a negative one is refused, never clamped).
  auto session_field = [&](const char* label, auto SessionSettings::*group, auto member, auto draw, const char* rule) {
    using T = std::remove_cvref_t<decltype(model.session_settings().*group.*member)>;
    numeric_field(state, label, std::array<T, 1>{model.session_settings().*group.*member}, true, draw,
                  [&](const std::array<T, 1>& v) {
                    if (!(v[0] >= T(0))) return std::string(label) + ": " + rule;
                    SessionSettings edited = model.session_settings();
                    edited.*group.*member = v[0];
                    model.set_session_settings(edited);
                    return std::string();
                  });
  };
  numeric_field(state, "threads", std::array<int, 1>{model.session_settings().threads}, true,
                [](int* v) { return ImGui::InputInt("threads", v, 0, 0); },
                [&](const std::array<int, 1>& v) {
                  if (v[0] < 0 || v[0] > 4 * hardware_threads())
                    return "threads: must be in [0, " + std::to_string(4 * hardware_threads()) + "] (0 = all " +
                           std::to_string(hardware_threads()) + ")";
                  SessionSettings edited = model.session_settings();
                  edited.threads = v[0];
                  model.set_session_settings(edited);
                  return std::string();
                });
  if (ImGui::IsItemHovered()) ImGui::SetTooltip("render threads; 0 = all %d hardware threads", hardware_threads());
  ImGui::TextDisabled("stop at (0 = no limit):");
  session_field("spp", &SessionSettings::stop, &StopConditions::spp,
                [](uint64_t* v) { return ImGui::InputScalar("spp", ImGuiDataType_U64, v, nullptr, nullptr, "%" PRIu64); },
                "must be >= 0");
  session_field("seconds", &SessionSettings::stop, &StopConditions::seconds,
                [](double* v) { return ImGui::InputDouble("seconds", v, 0.0, 0.0, "%.1f"); }, "must be >= 0");
  session_field("relMSE", &SessionSettings::stop, &StopConditions::relmse,
                [](double* v) { return ImGui::InputDouble("relMSE", v, 0.0, 0.0, "%.2e"); }, "must be >= 0");
  if (ImGui::Button(model.paused() ? "Resume [P]" : "Pause [P]")) model.set_paused(!model.paused());
  ImGui::SameLine();
  if (ImGui::Button("Reset [R]")) model.restart();
  region_row(model, state);

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
  // Below kRelMseStopMinSpp the per-pixel variances are too noisy to mean much (the estimate rises at first on
  // noisy scenes): the panel says "estimating" instead of a number.
  if (st.spp >= kRelMseStopMinSpp && std::isfinite(st.estimated_relmse)) ImGui::Text("estimated relMSE %.3e", st.estimated_relmse);
  else ImGui::TextDisabled("estimated relMSE: estimating... (from %d spp)", static_cast<int>(kRelMseStopMinSpp));
  model.session().copy_history(state.history);
  std::erase_if(state.history, [](const RelMsePoint& q) { return q.spp < kRelMseStopMinSpp; });
  progress_bar(model, st, state.history);
  if (st.rejected) ImGui::TextColored(kErrorColour, "%" PRIu64 " non-finite samples rejected", st.rejected);
  if (!st.error.empty()) ImGui::TextColored(kErrorColour, "%s", st.error.c_str());
  relmse_plot(state.history);
}

void display_section(ViewerModel& model, PanelState& state, const ShownImage& shown) {
  expand_if(state);
  if (!ImGui::CollapsingHeader("Display", ImGuiTreeNodeFlags_DefaultOpen)) return;
  PresentSettings& p = model.present;
  // The difference view is offered only while a snapshot fits the image.
  if (!model.snapshot_usable() && p.mode == ViewMode::Difference) p.mode = ViewMode::Colour;
  radio_row(p.mode, model.snapshot_usable() ? enum_entries<ViewMode>().size() : kStartupViewModes);
  // A/B compare: keep the current image, then flip to it, split, or view the difference heat map.
  if (ImGui::Button("Keep snapshot [K]")) model.shortcut(Shortcut::KeepSnapshot);
  if (model.snapshot_usable()) {
    ImGui::SameLine();
    radio_row(p.snapshot_view);
    ImGui::TextDisabled("snapshot: %llu spp%s", static_cast<unsigned long long>(model.snapshot->spp),
                        p.snapshot_view == SnapshotView::Split ? " (left), live (right)" : "");
  } else {
    p.snapshot_view = SnapshotView::Off;
    if (model.snapshot_requested) {
      ImGui::SameLine();
      ImGui::TextDisabled("waiting for a full image");
    }
  }
  // Denoising is a view: the session denoises its film on the render thread (toggling never restarts the
  // accumulation); the view picks the raw film, the denoised image, or both halves side by side.
  bool denoise = p.denoise;
  if (ImGui::Checkbox("denoise", &denoise)) model.set_denoise(denoise);
  note_item(state, "denoise");
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip("Feature-guided a-trous filter (docs/denoising.md); saved PFMs stay the raw estimate");
  if (p.denoise) {
    ImGui::SameLine();
    radio_row(p.denoise_view);
  }
  SessionSettings ss = model.session_settings();
  if (ImGui::Checkbox("clean preview while moving", &ss.preview_denoise)) model.set_session_settings(ss);
  note_item(state, "clean preview");
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip("The first image after a change, denoised and upsampled along a full-resolution guide "
                      "(docs/viewer.md, While you move); off: the raw 1-spp preview");
  // Image zoom (Ctrl+wheel, Ctrl+drag on the image; F, 1).
  if (ImGui::Button("Fit [F]")) model.zoom = ImageZoom{};
  ImGui::SameLine();
  if (ImGui::Button("1:1 [1]")) model.zoom = ImageZoom{false, 1.f, 0.f, 0.f};
  ImGui::SameLine();
  if (model.zoom.fit) ImGui::TextDisabled("zoom: fit");
  else ImGui::TextDisabled("zoom: %.0f %%", 100.0 * model.zoom.scale);
  ImGui::SliderFloat("exposure", &p.display.exposure_ev, -10.f, 10.f, "%+.2f EV");
  enum_combo(state, "tone map", p.display.tone_map);
  if (p.mode == ViewMode::RelativeError || p.mode == ViewMode::Difference) {
    ImGui::DragFloatRange2("log10 range", &p.error_log10_min, &p.error_log10_max, 0.05f, -8.f, 2.f, "%.1f");
    if (p.error_log10_max <= p.error_log10_min) p.error_log10_max = p.error_log10_min + 0.1f;
    char lo[32], mid[32], hi[32];
    std::snprintf(lo, sizeof lo, "%.0e", std::pow(10.0, p.error_log10_min));
    std::snprintf(mid, sizeof mid, "%.0e", std::pow(10.0, 0.5 * (p.error_log10_min + p.error_log10_max)));
    std::snprintf(hi, sizeof hi, ">= %.0e", std::pow(10.0, p.error_log10_max));
    ImGui::TextDisabled(p.mode == ViewMode::Difference ? "relative difference live vs snapshot (log scale)"
                                                        : "relative standard error per pixel (log scale)");
    legend(lo, mid, hi);
  } else if (p.mode == ViewMode::SampleCount) {
    char hi[32], mid[32];
    std::snprintf(mid, sizeof mid, "%.0f", 0.5 * shown.max_count);
    std::snprintf(hi, sizeof hi, "%.0f spp", shown.max_count);
    ImGui::TextDisabled("samples per pixel (linear)");
    legend("0", mid, hi);
  }
}

void camera_section(ViewerModel& model, PanelState& state) {
  expand_if(state);
  if (!ImGui::CollapsingHeader("Camera")) return;
  const CameraDesc& c = model.camera().camera();
  float fov = static_cast<float>(c.fov_deg);
  if (ImGui::SliderFloat(c.fov_axis == FovAxis::Vertical ? "vertical fov" : "horizontal fov", &fov, 5.f, 150.f, "%.2f°"))
    model.set_fov(fov);
  auto vector_field = [&](const char* label, DVec3 v, auto set) {
    numeric_field(state, label, std::array<double, 3>{v.x, v.y, v.z}, true,
                  [&](double* p) { return ImGui::InputScalarN(label, ImGuiDataType_Double, p, 3, nullptr, nullptr, "%.3f"); },
                  [&](const std::array<double, 3>& p) {
                    const DVec3 d(p[0], p[1], p[2]);
                    if (!std::isfinite(d.x + d.y + d.z)) return std::string(label) + ": must be finite";
                    set(d);
                    return std::string();
                  });
  };
  vector_field("position", c.position, [&](DVec3 d) { model.set_camera_position(d); });
  vector_field("target", c.look_at, [&](DVec3 d) { model.set_camera_target(d); });
  // Depth of field: the thin lens (scene/camera.h); Alt+click on the image focuses where it points.
  float aperture = static_cast<float>(c.aperture_radius), focus = static_cast<float>(c.focus_distance);
  const float speed = static_cast<float>(std::max(1e-3, 1e-3 * glm::length(c.look_at - c.position)));
  if (ImGui::DragFloat("aperture radius", &aperture, speed, 0.f, 1e6f, "%.4g", ImGuiSliderFlags_AlwaysClamp))
    model.set_lens(aperture, c.focus_distance);
  if (ImGui::DragFloat("focus distance", &focus, 10.f * speed, 0.f, 1e9f, focus > 0.f ? "%.4g" : "0 (the target)",
                       ImGuiSliderFlags_AlwaysClamp))
    model.set_lens(c.aperture_radius, focus);
  ImGui::TextDisabled("aperture 0: a pinhole; Alt+click on the image: focus there");
  if (ImGui::Button("Reset to scene camera")) model.reset_camera();
  ImGui::TextDisabled("fly speed %.3g units/s (shift: 4x)", model.camera().fly_speed());
}

void environment_section(ViewerModel& model, PanelState& state) {
  expand_if(state);
  if (!ImGui::CollapsingHeader("Environment")) return;
  EnvironmentDesc e = model.scene().environment;
  bool changed = enum_combo(state, "type", e.type);
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

// A material's emission: a colour (live) and a strength (typed or dragged; refused when negative).
void emission_fields(ViewerModel& model, PanelState& state, size_t m) {
  Rgb colour = model.emission_colour(m);
  if (ImGui::ColorEdit3("emission", &colour.x, ImGuiColorEditFlags_Float))
    model.set_emission(m, colour, model.emission_strength(m));
  numeric_field(state, "strength", std::array<float, 1>{model.emission_strength(m)}, false,
                [](float* v) { return ImGui::DragFloat("strength", v, 0.05f, 0.f, 1e5f, "%.3f", ImGuiSliderFlags_Logarithmic); },
                [&](const std::array<float, 1>& v) { return outcome(model.set_emission(m, model.emission_colour(m), v[0]), model); });
}

// A material's albedo texture: what it is (its file, or the model file it came in, and its size), a field to
// give it another image file (Enter applies) and a button to remove it.
void texture_fields(ViewerModel& model, size_t m, const MaterialDesc& material) {
  if (material.albedo_map) {
    const Texture& t = *material.albedo_map;
    ImGui::TextDisabled("texture: %s, %d x %d, %zu levels", t.source.c_str(), t.width(), t.height(), t.levels.size());
    ImGui::SameLine();
    if (ImGui::SmallButton("remove")) model.set_albedo_texture(m, "");
  }
  char file[512];
  std::snprintf(file, sizeof file, "%s", material.albedo_texture.c_str());
  if (ImGui::InputTextWithHint("albedo texture", "image file (.png, .jpg, .exr, ...)", file, sizeof file,
                               ImGuiInputTextFlags_EnterReturnsTrue) &&
      std::string(file) != material.albedo_texture)
    model.set_albedo_texture(m, file);
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip("an image whose colour times the albedo is the albedo at each point (the model's texture coordinates)");
}

// The model file's data textures a material reads (metallic-roughness, normal map, cut-out mask): shown, not
// edited.
void model_texture_lines(const MaterialDesc& material) {
  const auto line = [](const char* what, const Texture& t) {
    ImGui::TextDisabled("%s: %s, %d x %d", what, t.source.c_str(), t.width(), t.height());
  };
  if (material.metallic_roughness_map.texture && material.type == MaterialType::MetallicRoughness)
    line("metallic-roughness texture", *material.metallic_roughness_map.texture);
  if (material.normal_map.texture) line("normal map", *material.normal_map.texture);
  if (material.emission_map.texture) line("emission texture", *material.emission_map.texture);
  if (const AlphaMask* cut = material.cutout.get()) {
    if (cut->alpha) line("cut-out alpha", *cut->alpha);
    ImGui::TextDisabled("cut-out: opaque where %.3g x alpha >= %.3g", cut->factor, cut->cutoff);
  }
}

// True when `text` contains `filter` (case-insensitive); an empty filter matches everything.
bool matches_filter(const std::string& text, const char* filter) {
  const std::string_view f(filter);
  if (f.empty()) return true;
  auto lower = [](char c) { return static_cast<char>(std::tolower(static_cast<unsigned char>(c))); };
  return std::search(text.begin(), text.end(), f.begin(), f.end(),
                     [&](char a, char b) { return lower(a) == lower(b); }) != text.end();
}

void materials_section(ViewerModel& model, PanelState& state) {
  expand_if(state);
  if (model.selection() && model.selection()->serial != state.shown_selection) ImGui::SetNextItemOpen(true);
  if (!ImGui::CollapsingHeader("Materials")) return;
  const std::vector<MaterialDesc>& mats = model.scene().materials;
  const std::optional<Selection>& sel = model.selection();
  const bool new_selection = sel && sel->serial != state.shown_selection;
  // A search field: only the materials whose name (or type) contains the text, case-insensitively; the material
  // clicked on the image always shows.
  ImGui::InputTextWithHint("##material filter", "search materials", state.material_filter, sizeof state.material_filter);
  note_item(state, "material filter");
  size_t shown_count = 0;
  for (size_t i = 0; i < mats.size(); ++i) {
    const bool clicked = sel && sel->material == i;
    if (!clicked && !matches_filter(mats[i].name + " " + enum_label(mats[i].type), state.material_filter)) continue;
    ++shown_count;
    ImGui::PushID(static_cast<int>(i));
    expand_if(state);
    const bool selected = sel && sel->material == i;
    if (selected && new_selection) {  // a click on the image opens its material, once, and scrolls to it
      ImGui::SetNextItemOpen(true);
      ImGui::SetScrollHereY(0.2f);
    }
    if (selected) ImGui::PushStyleColor(ImGuiCol_Text, ImVec4(1.f, 0.85f, 0.3f, 1.f));
    const bool open = ImGui::TreeNode(mats[i].name.c_str());
    if (selected) ImGui::PopStyleColor();
    if (open) {
      state.scope = mats[i].name + "/";
      MaterialDesc m = mats[i];
      bool changed = enum_combo(state, "type", m.type);
      const MaterialType t = m.type;
      // Only the parameters the type takes (kMaterialParams, materials/material.h).
      const bool rough = takes(t, MaterialParam::Roughness), has_ior = takes(t, MaterialParam::Ior);
      if (takes(t, MaterialParam::Metal)) {
        changed |= enum_combo(state, "metal", m.metal);
        if (m.metal != MetalPreset::None) m.complex_ior = false;
      }
      const bool uses_albedo = takes(t, MaterialParam::Albedo) &&
                               !(takes(t, MaterialParam::Metal) && (m.metal != MetalPreset::None || m.complex_ior));
      if (uses_albedo) changed |= ImGui::ColorEdit3(m.albedo_map ? "albedo (x texture)" : "albedo", &m.albedo.x, ImGuiColorEditFlags_Float);
      if (uses_albedo && t != MaterialType::Subsurface) texture_fields(model, i, m);
      model_texture_lines(m);
      changed |= ImGui::Checkbox("two-sided emission", &m.two_sided);
      if (changed) model.set_material(i, m);
      // One numeric property: applied on the model's current material, so no other field is ever reverted.
      auto property = [&](const char* label, float MaterialDesc::*field, auto draw) {
        numeric_field(state, label, std::array<float, 1>{model.scene().materials[i].*field}, false, draw,
                      [&](const std::array<float, 1>& v) {
                        MaterialDesc edited = model.scene().materials[i];
                        edited.*field = v[0];
                        return outcome(model.set_material(i, edited), model);
                      });
      };
      if (takes(t, MaterialParam::Metallic))
        property("metallic", &MaterialDesc::metallic, [](float* v) { return ImGui::SliderFloat("metallic", v, 0.f, 1.f, "%.3f"); });
      if (rough)
        property("roughness", &MaterialDesc::roughness, [](float* v) { return ImGui::SliderFloat("roughness", v, 0.f, 1.f, "%.3f"); });
      if (has_ior)
        property("IOR", &MaterialDesc::ior, [](float* v) { return ImGui::DragFloat("IOR", v, 0.002f, 1.0f, 4.0f, "%.3f"); });
      if (takes(t, MaterialParam::G))
        property("g (anisotropy)", &MaterialDesc::g, [](float* v) { return ImGui::SliderFloat("g (anisotropy)", v, -0.95f, 0.95f, "%.2f"); });
      emission_fields(model, state, i);
      state.scope.clear();
      ImGui::TreePop();
    }
    ImGui::PopID();
  }
  if (shown_count == 0) ImGui::TextDisabled("no material matches \"%s\"", state.material_filter);
}

// The material combo of the object section: one entry for the whole object or lone shape.
void material_combo(ViewerModel& model, int current, const std::function<bool(size_t)>& set) {
  const auto& mats = model.scene().materials;
  if (ImGui::BeginCombo("material", mats[static_cast<size_t>(current)].name.c_str())) {
    for (size_t i = 0; i < mats.size(); ++i)
      if (ImGui::Selectable(mats[i].name.c_str(), static_cast<int>(i) == current) && static_cast<int>(i) != current)
        set(i);
    ImGui::EndCombo();
  }
}

// A light is an object whose material emits: its emission here too (the material's, shared by its shapes).
void object_emission(ViewerModel& model, PanelState& state, size_t material) {
  if (model.emission_strength(material) <= 0.f) return;
  ImGui::PushID("object");
  emission_fields(model, state, material);
  ImGui::PopID();
}

// An object (a mesh, a group): its material and its transform (position, rotation, scale), for all its shapes.
void object_fields(ViewerModel& model, PanelState& state, size_t index) {
  const SceneDesc& scene = model.scene();
  const ObjectDesc& o = scene.objects[index];
  // Its materials: its shapes', then its instanced meshes' (an object may hold instances alone).
  int first = -1;
  size_t differing = 0, instances = 0;
  const auto see = [&](int m) { first < 0 ? void(first = m) : void(differing += m != first); };
  for (size_t k = o.first_shape; k < o.first_shape + o.shape_count; ++k) see(scene.shapes[k].material);
  for (const InstanceDesc& in : scene.instances)
    if (in.object == static_cast<int>(index)) {
      ++instances;
      for (int m : in.materials) see(m);
    }
  ImGui::Text("%s: %s, %zu %s", o.name.c_str(), enum_label(o.kind), o.shape_count, o.shape_count == 1 ? "shape" : "shapes");
  if (instances) {
    ImGui::SameLine();
    ImGui::Text("+ %zu %s", instances, instances == 1 ? "instance" : "instances");
  }
  if (o.kind != ObjectKind::Group && ImGui::IsItemHovered()) ImGui::SetTooltip("%s", o.file.c_str());
  const int current = std::clamp(first, 0, static_cast<int>(scene.materials.size()) - 1);
  // A model file keeps its file's materials (each in Materials as NAME/MATERIAL); choosing one here gives that
  // one to all of its triangles.
  if (o.kind != ObjectKind::Group && differing)
    ImGui::TextDisabled("the file's materials (%s/...); one below for all", o.name.c_str());
  material_combo(model, current, [&](size_t m) { return model.set_object_material(index, m); });
  const ObjectTransform t = o.transform;
  const auto field = [&](const char* label, DVec3 value, const char* tip, auto&& with) {
    numeric_field(state, label, std::array<double, 3>{value.x, value.y, value.z}, true,
                  [label](double* p) { return ImGui::InputScalarN(label, ImGuiDataType_Double, p, 3, nullptr, nullptr, "%.4g"); },
                  [&](const std::array<double, 3>& p) {
                    ObjectTransform edited = t;
                    with(edited, DVec3(p[0], p[1], p[2]));
                    return outcome(model.set_object_transform(index, edited), model);
                  });
    if (ImGui::IsItemHovered()) ImGui::SetTooltip("%s", tip);
  };
  field("position##object", t.translate, "where the object's origin sits (its file's or group's coordinates)",
        [](ObjectTransform& e, DVec3 v) { e.translate = v; });
  field("rotation axis", t.axis, "the axis the object turns about (through its origin)",
        [](ObjectTransform& e, DVec3 v) { e.axis = v; });
  numeric_field(state, "rotation (deg)", std::array<double, 1>{t.degrees}, false,
                [](double* d) { return ImGui::DragScalar("rotation (deg)", ImGuiDataType_Double, d, 0.5f, nullptr, nullptr, "%.1f"); },
                [&](const std::array<double, 1>& d) {
                  ObjectTransform edited = t;
                  edited.degrees = d[0];
                  return outcome(model.set_object_transform(index, edited), model);
                });
  field("scale", t.scale, "per axis, about the object's origin; a sphere inside takes the same on every axis",
        [](ObjectTransform& e, DVec3 v) { e.scale = v; });
  object_emission(model, state, static_cast<size_t>(current));
}

// A shape standing alone: its material, where it is, a sphere's radius.
void lone_shape_fields(ViewerModel& model, PanelState& state, size_t index) {
  const ShapeDesc& sh = model.scene().shapes[index];
  ImGui::Text("shape %zu: %s", index, enum_label(sh.type));
  const int current = std::clamp(sh.material, 0, static_cast<int>(model.scene().materials.size()) - 1);
  material_combo(model, current, [&](size_t m) { return model.set_shape_material(index, m); });
  // Position: the sphere's centre, or the polygon's first vertex; a typed position moves the whole shape.
  const DVec3 at = sh.type == ShapeType::Sphere ? sh.center : sh.vertices[0];
  numeric_field(state, "position##object", std::array<double, 3>{at.x, at.y, at.z}, true,
                [](double* p) { return ImGui::InputScalarN("position##object", ImGuiDataType_Double, p, 3, nullptr, nullptr, "%.3f"); },
                [&](const std::array<double, 3>& p) {
                  return outcome(model.move_shape(index, DVec3(p[0], p[1], p[2]) - at), model);
                });
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip(sh.type == ShapeType::Sphere ? "the centre" : "the first vertex; the shape moves as a whole");
  object_emission(model, state, static_cast<size_t>(current));
  if (sh.type == ShapeType::Sphere)
    numeric_field(state, "radius", std::array<double, 1>{sh.radius}, true,
                  [](double* r) { return ImGui::InputDouble("radius", r, 0.0, 0.0, "%.4g"); },
                  [&](const std::array<double, 1>& r) { return outcome(model.set_sphere_radius(index, r[0]), model); });
}

// The object under the last click (a click picks the whole object a shape belongs to; a shape outside every
// object is one of its own). A light is an emitting object, so this moves lights too.
void object_section(ViewerModel& model, PanelState& state) {
  const std::optional<Selection>& sel = model.selection();
  if (!sel || (!sel->object && sel->shape >= model.scene().shapes.size())) return;
  if (sel->serial != state.shown_selection) ImGui::SetNextItemOpen(true);
  expand_if(state);
  if (!ImGui::CollapsingHeader("Object")) return;
  if (sel->object && *sel->object < model.scene().objects.size()) object_fields(model, state, *sel->object);
  else lone_shape_fields(model, state, sel->shape);
}

// Undo, redo and revert, above the sections.
void edit_row(ViewerModel& model) {
  ImGui::BeginDisabled(!model.can_undo());
  if (ImGui::Button("Undo")) model.undo();
  ImGui::EndDisabled();
  if (ImGui::IsItemHovered(ImGuiHoveredFlags_AllowWhenDisabled)) ImGui::SetTooltip("Ctrl+Z");
  ImGui::SameLine();
  ImGui::BeginDisabled(!model.can_redo());
  if (ImGui::Button("Redo")) model.redo();
  ImGui::EndDisabled();
  if (ImGui::IsItemHovered(ImGuiHoveredFlags_AllowWhenDisabled)) ImGui::SetTooltip("Ctrl+Shift+Z or Ctrl+Y");
  ImGui::SameLine();
  if (ImGui::Button("Revert to file")) model.revert();
}

// Save offers model.suggested_save_path() until the user types another path: after each load (a new scene or
// file), and again whenever a suggested file has appeared meanwhile, so a file the user never chose is never
// offered for replacement.
void refresh_save_path(const ViewerModel& model, PanelState& state) {
  const std::string key = model.scene_name() + "\n" + model.scene_file() + "\n" + model.files.output_dir;
  std::error_code ec;
  const bool stale = state.save_path_suggested && model.scene_file() != state.save_scene_path &&
                     std::filesystem::exists(state.save_scene_path, ec);
  if (key == state.known_scene && !stale) return;
  if (!state.save_path_suggested && model.scene_name() + "\n" + model.scene_file() ==
                                        state.known_scene.substr(0, state.known_scene.rfind('\n'))) {
    state.known_scene = key;  // only the output folder changed: a path the user typed stays
    return;
  }
  state.known_scene = key;
  state.save_path_suggested = true;
  copy_string(state.save_scene_path, sizeof state.save_scene_path, model.suggested_save_path());
}

// The film size: following the window (at a scale), or fixed: presets and typed values.
void resolution_field(ViewerModel& model, PanelState& state) {
  bool follow = model.follow_window();
  if (ImGui::Checkbox("follow the window", &follow)) model.set_follow_window(follow, model.follow_scale());
  note_item(state, "follow the window");
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip("The render's size is the image area's, at the scale beside (framebuffer pixels: HiDPI counts)");
  ImGui::SameLine();
  static const char* const kScaleLabels[] = {"1:1", "1/2", "1/4"};
  int scale_index = 0;
  for (int i = 0; i < 3; ++i)
    if (kFollowScales[i] == model.follow_scale()) scale_index = i;
  ImGui::SetNextItemWidth(70.f * ui_scale());
  if (ImGui::Combo("##follow scale", &scale_index, kScaleLabels, 3))
    model.set_follow_window(model.follow_window(), kFollowScales[scale_index]);
  ImGui::BeginDisabled(model.follow_window());
  static const int kPresets[][2] = {{256, 256}, {512, 512}, {1024, 1024}, {640, 360}, {1280, 720}, {1920, 1080}};
  char current[32];
  std::snprintf(current, sizeof current, "%d x %d", model.scene().width, model.scene().height);
  if (ImGui::BeginCombo("size preset", current)) {
    for (const auto& p : kPresets) {
      char label[32];
      std::snprintf(label, sizeof label, "%d x %d", p[0], p[1]);
      if (ImGui::Selectable(label, p[0] == model.scene().width && p[1] == model.scene().height))
        model.set_resolution(p[0], p[1]);
    }
    ImGui::EndCombo();
  }
  numeric_field(state, "resolution", std::array<int, 2>{model.scene().width, model.scene().height}, true,
                [](int* v) { return ImGui::InputInt2("resolution", v); },
                [&](const std::array<int, 2>& v) { return outcome(model.set_resolution(v[0], v[1]), model); });
  ImGui::EndDisabled();
}

void scene_section(ViewerModel& model, PanelState& state) {
  expand_if(state);
  if (!ImGui::CollapsingHeader("Scene")) return;
  if (state.builtin_names.empty()) state.builtin_names = builtin_scene_names();
  ImGui::Text("%s: %d x %d, %zu shapes, %zu materials", model.scene_name().c_str(), model.scene().width,
              model.scene().height, model.scene().shapes.size(), model.scene().materials.size());
  resolution_field(model, state);
  const char* current = state.builtin_names[std::clamp<size_t>(state.builtin, 0, state.builtin_names.size() - 1)].c_str();
  if (ImGui::BeginCombo("built-in", current)) {
    for (size_t i = 0; i < state.builtin_names.size(); ++i)
      if (ImGui::Selectable(state.builtin_names[i].c_str(), static_cast<int>(i) == state.builtin)) state.builtin = static_cast<int>(i);
    ImGui::EndCombo();
  }
  ImGui::SameLine();
  if (ImGui::Button("Load##builtin")) model.request_load(state.builtin_names[state.builtin]);
  ImGui::InputText("file", state.scene_path, sizeof state.scene_path);
  ImGui::SameLine();
  if (ImGui::Button("Load##file")) model.request_load(state.scene_path);
  if (model.files.recent && !model.files.recent->paths().empty() && ImGui::BeginCombo("recent", "open a recent scene...")) {
    for (const std::string& path : model.files.recent->paths())
      if (ImGui::Selectable(path.c_str())) {
        copy_string(state.scene_path, sizeof state.scene_path, path);
        model.request_load(path);
        break;  // loading reorders the list
      }
    ImGui::EndCombo();
  }
  ImGui::TextDisabled("or drop a .json scene or an .exr/.hdr/.pfm map on the window");
  if (ImGui::InputText("save as", state.save_scene_path, sizeof state.save_scene_path)) state.save_path_suggested = false;
  note_item(state, "save as");
  ImGui::SameLine();
  // An existing file is replaced only when the user says so.
  if (ImGui::Button("Save")) {
    std::error_code ec;
    if (std::filesystem::exists(state.save_scene_path, ec)) state.confirm_replace = true;
    else model.save_scene(state.save_scene_path);
  }
  note_item(state, "Save");
  if (state.confirm_replace) ImGui::OpenPopup("Replace scene file?");
  if (ImGui::BeginPopupModal("Replace scene file?", nullptr, ImGuiWindowFlags_AlwaysAutoResize)) {
    ImGui::Text("%s already exists.", state.save_scene_path);
    if (ImGui::Button("Replace")) {
      model.save_scene(state.save_scene_path, true);
      state.confirm_replace = false;
      ImGui::CloseCurrentPopup();
    }
    note_item(state, "Replace");
    ImGui::SameLine();
    if (ImGui::Button("Cancel")) {
      state.confirm_replace = false;
      ImGui::CloseCurrentPopup();
    }
    ImGui::EndPopup();
  } else {
    state.confirm_replace = false;  // closed another way (Esc)
  }
}

// Quitting or opening another scene with edits that were not saved (model.confirm_quit, model.confirm_load):
// save first, discard, or stay.
void discard_question(ViewerModel& model, PanelState& state) {
  if (!model.confirm_quit && !model.confirm_load) return;
  const char* id = "Unsaved edits";
  if (!ImGui::IsPopupOpen(id)) ImGui::OpenPopup(id);
  const ImGuiIO& io = ImGui::GetIO();
  ImGui::SetNextWindowPos(ImVec2(0.5f * io.DisplaySize.x, 0.5f * io.DisplaySize.y), ImGuiCond_Appearing, ImVec2(0.5f, 0.5f));
  if (!ImGui::BeginPopupModal(id, nullptr, ImGuiWindowFlags_AlwaysAutoResize)) {
    model.confirm_quit = false;
    model.confirm_load.reset();
    return;
  }
  const bool quitting = model.confirm_quit;
  const std::string next = model.confirm_load.value_or("");
  auto proceed = [&] {
    if (quitting) model.quit_requested = true;
    else model.load(next);
  };
  auto close = [&] {
    model.confirm_quit = false;
    model.confirm_load.reset();
    ImGui::CloseCurrentPopup();
  };
  if (quitting) ImGui::TextUnformatted("The scene has edits that are not saved. Quit anyway?");
  else ImGui::Text("The scene has edits that are not saved. Open %s anyway?", next.c_str());
  if (ImGui::InputText("scene file", state.save_scene_path, sizeof state.save_scene_path)) state.save_path_suggested = false;
  std::error_code ec;
  const bool exists = std::filesystem::exists(state.save_scene_path, ec);
  if (exists) ImGui::TextColored(ImVec4(1.f, 0.8f, 0.3f, 1.f), "exists: saving replaces it");
  const char* save_label = quitting ? (exists ? "Replace and quit" : "Save and quit") : (exists ? "Replace and open" : "Save and open");
  if (ImGui::Button(save_label)) {
    if (model.save_scene(state.save_scene_path, exists)) proceed();
    close();
  }
  note_item(state, "Save first");
  ImGui::SameLine();
  if (ImGui::Button(quitting ? "Quit without saving" : "Open without saving")) {
    proceed();
    close();
  }
  note_item(state, "Discard");
  ImGui::SameLine();
  if (ImGui::Button("Cancel")) close();
  note_item(state, "Cancel");
  ImGui::EndPopup();
}

void output_section(ViewerModel& model, PanelState& state, const ShownImage& shown) {
  expand_if(state);
  if (!ImGui::CollapsingHeader("Output")) return;
  if (ImGui::InputText("folder", state.output_dir, sizeof state.output_dir)) model.files.output_dir = state.output_dir;
  ImGui::BeginDisabled(shown.width == 0);
  if (ImGui::Button("Save image: PNG + PFM [S]")) model.save_requested = true;
  ImGui::EndDisabled();
  ImGui::TextDisabled("PNG: the image as shown; PFM: linear mean radiance");
  ImGui::BeginDisabled(shown.width == 0 || model.exr_saving());
  if (ImGui::Button("Save layers: OpenEXR [E]")) model.save_exr();
  note_item(state, "Save EXR");
  ImGui::EndDisabled();
  ImGui::TextDisabled("beauty, albedo, normal, depth, emission, variance, spp%s", model.present.denoise ? ", denoised" : "");
}

void help_section(ViewerModel& model, PanelState& state) {
  ImGui::SetNextItemOpen(model.help_open);
  model.help_open = ImGui::CollapsingHeader("Help [F1]");
  note_item(state, "Help");
  // Opened with F1: bring it into view, since it is the last section and usually below the fold.
  if (model.help_open && model.scroll_to_help) ImGui::SetScrollHereY(0.f);
  model.scroll_to_help = false;
  if (!model.help_open) return;
  static const char* const rows[][2] = {
      {"left drag", "orbit around the pivot"},     {"click", "select the material and object; pixel values"},
      {"double-click", "pivot on the surface under the cursor"},
      {"Ctrl+Z / Ctrl+Shift+Z, Ctrl+Y", "undo / redo scene edits"},
      {"middle / shift+left drag", "pan"},
      {"wheel", "dolly towards / away"},           {"right drag", "look around"},
      {"right held + WASD QE", "fly (shift: 4x)"}, {"R", "reset accumulation"},
      {"P", "pause / resume"},                     {"S", "save image (PNG + PFM)"},
      {"E", "save every layer (OpenEXR)"},
      {"Tab", "hide / show panels"},               {"F1", "this help"},
      {"Ctrl+wheel / Ctrl+drag", "zoom / pan the image"}, {"F / 1", "fit the image / 1:1"},
      {"K / B", "keep an A/B snapshot / flip to it"},
      {"Ctrl+B, then drag / Ctrl+Alt+B", "draw a render region (only it accumulates) / clear it"},
      {"Esc", "close a list / cancel typing; else quit (asks if the scene has unsaved edits)"}};
  // Both columns wrap inside the panel's width (a fixed-fit table ran past the panel's edge and was clipped).
  if (ImGui::BeginTable("keys", 2, ImGuiTableFlags_SizingStretchProp)) {
    ImGui::TableSetupColumn("input", ImGuiTableColumnFlags_WidthStretch, 0.4f);
    ImGui::TableSetupColumn("action", ImGuiTableColumnFlags_WidthStretch, 0.6f);
    int row = 0;
    for (const auto& r : rows) {
      ImGui::TableNextRow();
      for (const char* text : r) {
        ImGui::TableNextColumn();
        ImGui::TextWrapped("%s", text);
        note_item(state, ("help " + std::to_string(row) + (text == r[0] ? " input" : " action")).c_str());
      }
      ++row;
    }
    ImGui::EndTable();
  }
}

}  // namespace

namespace {
float g_ui_scale = 1.f;  // set by setup_viewer_style: one ImGui context per process
}  // namespace

void setup_viewer_style(float content_scale) {
  const float scale = std::isfinite(content_scale) && content_scale > 0.f ? std::clamp(content_scale, 0.5f, 4.f) : 1.f;
  g_ui_scale = scale;
  ImGui::StyleColorsDark();
  ImGuiStyle& style = ImGui::GetStyle();
  style.Colors[ImGuiCol_PopupBg].w = 1.f;
  style.Colors[ImGuiCol_WindowBg].w = 1.f;
  style.GrabMinSize = 4.f;
  style.ScaleAllSizes(scale);
  ImGuiIO& io = ImGui::GetIO();
  io.Fonts->Clear();
  ImFontConfig font;
  font.SizePixels = std::round(13.f * scale);
  io.Fonts->AddFontDefault(&font);
}

float panel_width() { return kPanelWidth * g_ui_scale; }
float ui_scale() { return g_ui_scale; }
float PanelState::width() const { return width_units * g_ui_scale; }

float draw_viewer_panels(ViewerModel& model, PanelState& state, const ShownImage& shown) {
  refresh_save_path(model, state);
  if (!model.ui_visible) {
    discard_question(model, state);  // also with the panels hidden
    return 0.f;
  }
  if (state.output_dir[0] == '\0' || model.files.output_dir != state.output_dir) copy_string(state.output_dir, sizeof state.output_dir, model.files.output_dir);
  const ImGuiIO& io = ImGui::GetIO();
  const float width = std::min(state.width(), io.DisplaySize.x);
  ImGui::SetNextWindowPos(ImVec2(io.DisplaySize.x - width, 0.f));
  ImGui::SetNextWindowSize(ImVec2(width, io.DisplaySize.y));
  // The left edge is a splitter: dragging it resizes the panel (within limits); the window keeps the width.
  ImGui::SetNextWindowSizeConstraints(ImVec2(ViewerPrefs::kMinPanelWidth * ui_scale(), io.DisplaySize.y),
                                      ImVec2(ViewerPrefs::kMaxPanelWidth * ui_scale(), io.DisplaySize.y));
  ImGui::Begin("pathtracer", nullptr,
               ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoCollapse | ImGuiWindowFlags_NoSavedSettings);
  if (const float now = ImGui::GetWindowWidth(); now != width && now > 0.f) state.width_units = now / ui_scale();
  ImGui::PushItemWidth(-110.f);
  ImGui::Text("%s  %dx%d%s  %.1f ms/frame", model.scene_name().c_str(), shown.width, shown.height,
              shown.preview ? " (preview)" : "", shown.frame_ms);
  if (shown.edit_latency_ms >= 0) ImGui::TextDisabled("last edit shown after %.0f ms", shown.edit_latency_ms);
  // The status line has room reserved (two lines), so a message never shifts the panel under the pointer.
  ImGui::BeginChild("status", ImVec2(0.f, 2.f * ImGui::GetTextLineHeightWithSpacing()), false,
                    ImGuiWindowFlags_NoScrollbar | ImGuiWindowFlags_NoScrollWithMouse);
  if (!model.status().empty()) {
    if (model.status_is_error()) ImGui::PushStyleColor(ImGuiCol_Text, kErrorColour);
    else ImGui::PushStyleColor(ImGuiCol_Text, kDimColour);
    ImGui::TextWrapped("%s", model.status().c_str());
    ImGui::PopStyleColor();
    if (ImGui::IsWindowHovered()) ImGui::SetTooltip("%s", model.status().c_str());
  }
  ImGui::EndChild();
  edit_row(model);
  render_section(model, state);
  display_section(model, state, shown);
  camera_section(model, state);
  object_section(model, state);
  materials_section(model, state);
  environment_section(model, state);
  scene_section(model, state);
  output_section(model, state, shown);
  help_section(model, state);
  if (model.selection()) state.shown_selection = model.selection()->serial;
  ImGui::PopItemWidth();
  ImGui::End();
  // After the panel window: a modal opened while that window first appears would block its focus (1.86 asserts).
  discard_question(model, state);
  return width;
}

}  // namespace pt
