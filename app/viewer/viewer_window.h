// The GLFW side of the viewer: the window and its OpenGL 3.3 core context, the ImGui GLFW/OpenGL3 backends,
// translation of pointer and keys into ViewInput/shortcuts, and the frame loop. Everything else (state, camera
// maths, rendering, display transform, panels) lives in GL-free or GLFW-free modules the tests drive directly.
#pragma once
#include "render/render_session.h"
#include "viewer/view_command.h"
#include "viewer/viewer_script.h"

namespace pt {

// Opens the window, builds the ViewerModel for `scene`, runs until closed (or --frames), applying the script's
// actions when they fall due. Exit status as run_view.
int run_viewer_window(const ViewOptions& options, const SceneDesc& scene, const SessionSettings& settings,
                      std::vector<ScriptAction> script = {});

}  // namespace pt
