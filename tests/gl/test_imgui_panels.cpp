// One offscreen ImGui frame of the viewer's real panels, through the real ImGui OpenGL3 backend on OSMesa.
#include <doctest/doctest.h>
#include <backends/imgui_impl_opengl3.h>
#include <imgui.h>

#include "osmesa_context.h"
#include "scene/scene_json.h"
#include "viewer/viewer_model.h"
#include "viewer/viewer_panels.h"

using namespace pt;

namespace {

SceneDesc small_scene() {
  SceneDesc d = load_scene("cornell");
  d.width = d.height = 32;
  d.render.max_bounces = 3;
  return d;
}

}  // namespace

TEST_CASE("gl: the viewer panels render offscreen with the ImGui OpenGL3 backend") {
  const int w = 900, h = 1400;
  test::OsMesaContext ctx(w, h);
  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGuiIO& io = ImGui::GetIO();
  io.IniFilename = nullptr;
  io.DisplaySize = ImVec2(static_cast<float>(w), static_cast<float>(h));
  io.DeltaTime = 1.f / 60.f;
  REQUIRE(ImGui_ImplOpenGL3_Init("#version 330 core"));

  SessionSettings settings;
  settings.stop.spp = 6;
  settings.preview_divisor = 1;
  ViewerModel model(small_scene(), "cornell", settings);
  REQUIRE(model.session().wait_for([](const SessionStats& s) { return s.done; }, 60.0));
  model.help_open = true;
  PanelState state;
  state.expand_all = true;  // every section and material open: all of the UI code runs
  ShownImage shown;
  shown.width = shown.height = 32;
  shown.max_count = 6;

  // Colour view, then the two false-colour views with their legends.
  int vertices = 0, lists = 0;
  float panel = 0.f;
  for (ViewMode mode : {ViewMode::Colour, ViewMode::RelativeError, ViewMode::SampleCount}) {
    model.present.mode = mode;
    ImGui_ImplOpenGL3_NewFrame();
    ImGui::NewFrame();
    panel = draw_viewer_panels(model, state, shown);
    ImGui::Render();
    ctx.clear(0, 0, 0);
    ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
    const ImDrawData* dd = ImGui::GetDrawData();
    REQUIRE(dd != nullptr);
    lists = dd->CmdListsCount;
    vertices = dd->TotalVtxCount;
    CHECK(lists > 0);
    CHECK(vertices > 1000);
  }
  CHECK(panel == doctest::Approx(kPanelWidth));

  // Pixels were drawn in the panel's strip at the right, and nowhere else.
  const std::vector<uint8_t> px = ctx.read_pixels();
  size_t inside = 0, outside = 0;
  const int panel_x = w - static_cast<int>(kPanelWidth);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const uint8_t* p = &px[4 * (static_cast<size_t>(y) * w + x)];
      const bool lit = p[0] | p[1] | p[2];
      (x >= panel_x ? inside : outside) += lit;
    }
  MESSAGE("ImGui frame: " << lists << " draw lists, " << vertices << " vertices, " << inside << " lit pixels");
  CHECK(inside > 0.5 * kPanelWidth * h);
  CHECK(outside == 0);

  // After a click on the image and with an A/B snapshot kept, the Object section and the A/B controls appear:
  // more widgets, drawn through the real backend.
  model.present.mode = ViewMode::Colour;
  REQUIRE(model.select_at(2.0, 16.0));  // the red wall
  model.snapshot = SnapshotInfo{32, 32, 6};
  state.record_items = true;
  ImGui_ImplOpenGL3_NewFrame();
  ImGui::NewFrame();
  draw_viewer_panels(model, state, shown);
  ImGui::Render();
  ctx.clear(0, 0, 0);
  ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
  CHECK(ImGui::GetDrawData()->TotalVtxCount > vertices);
  CHECK(state.item_rects.count("position##object") == 1);
  CHECK(state.item_rects.count("red/type") == 1);  // the clicked material is open
  CHECK(state.item_rects.count("scale") == 0);     // a lone wall has no object transform

  // A click on a block shows the block as one object: its transform's fields.
  bool block = false;
  for (int y = 16; y < 32 && !block; ++y)
    for (int x = 16; x < 32 && !block; ++x) block = model.select_at(x + 0.5, y + 0.5) && model.selection()->object;
  REQUIRE(block);
  state.item_rects.clear();
  ImGui_ImplOpenGL3_NewFrame();
  ImGui::NewFrame();
  draw_viewer_panels(model, state, shown);
  ImGui::Render();
  CHECK(state.item_rects.count("scale") == 1);
  CHECK(state.item_rects.count("rotation (deg)") == 1);

  // Hidden panels draw nothing.
  model.ui_visible = false;
  ImGui_ImplOpenGL3_NewFrame();
  ImGui::NewFrame();
  CHECK(draw_viewer_panels(model, state, shown) == 0.f);
  ImGui::Render();
  CHECK(ImGui::GetDrawData()->TotalVtxCount == 0);

  ImGui_ImplOpenGL3_Shutdown();
  ImGui::DestroyContext();
}
