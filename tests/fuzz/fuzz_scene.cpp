// libFuzzer target: scene text -> parse and validate (parse_scene) -> compile (compile_scene) -> one tiny pass.
// Any input must end in a SceneError / std::invalid_argument or in a scene that renders finite samples only; a
// crash, a sanitizer report, a hang, an unexpected exception type or a non-finite sample is a finding.
// Build and run: tools/fuzz.sh (docs/reliability.md).
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "fuzz_input.h"
#include "film/film.h"
#include "render/renderer.h"
#include "scene/scene.h"
#include "scene/scene_json.h"

const char* const pt::fuzz::kTarget = "fuzz_scene";

using pt::fuzz::finding;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  pt::SceneDesc desc;
  try {
    // Relative environment-map paths resolve into a directory that does not exist.
    desc = pt::parse_scene(text, "fuzz.json", "/nonexistent-fuzz-dir");
  } catch (const pt::SceneError&) {
    return 0;  // a clear refusal is the expected outcome for most inputs
  }
  // A valid scene: render it small, whatever its own film size, with bounded work per input.
  desc.width = 4;
  desc.height = 3;
  if (desc.render.max_bounces > 6) desc.render.max_bounces = 6;
  std::shared_ptr<pt::Scene> scene;
  try {
    scene = pt::compile_scene(desc);
  } catch (const std::invalid_argument&) {
    return 0;  // compile_scene documents this for scenes its float structures cannot hold
  }
  pt::Renderer renderer(1);
  pt::Film film(desc.width, desc.height);
  renderer.render_pass(*scene, desc.render, film, 2);
  if (film.rejected() != 0)
    finding("non-finite samples from a valid scene", std::to_string(film.rejected()) + " rejected");
  return 0;
}
