#include "render/progressive.h"

#include <algorithm>
#include <cmath>

#include "render/adaptive.h"

namespace pt {

const char* stop_reason(const StopConditions& stop, uint64_t spp, double seconds, double estimated_relmse) {
  if (stop.spp > 0 && spp >= stop.spp) return "target spp";
  if (stop.seconds > 0.0 && seconds >= stop.seconds) return "time limit";
  if (stop.relmse > 0.0 && spp >= kRelMseStopMinSpp && estimated_relmse <= stop.relmse) return "target relMSE";
  return nullptr;
}

StopProgress stop_progress(const StopConditions& stop, uint64_t spp, double seconds, double estimated_relmse) {
  StopProgress best;
  auto consider = [&](double fraction, double eta, const char* name) {
    if (!(eta >= 0.0) || !std::isfinite(eta)) return;
    if (best.eta_seconds < 0.0 || eta < best.eta_seconds) best = {std::clamp(fraction, 0.0, 1.0), eta, name};
  };
  if (stop.spp > 0 && spp > 0 && seconds > 0.0) {
    const double done = static_cast<double>(spp), target = static_cast<double>(stop.spp);
    consider(done / target, std::max(seconds * (target - done) / done, 0.0), "target spp");
  }
  if (stop.seconds > 0.0) consider(seconds / stop.seconds, std::max(stop.seconds - seconds, 0.0), "time limit");
  if (stop.relmse > 0.0 && spp >= kRelMseStopMinSpp && estimated_relmse > 0.0 && std::isfinite(estimated_relmse))
    consider(stop.relmse / estimated_relmse, std::max(seconds * (estimated_relmse / stop.relmse - 1.0), 0.0),
             "target relMSE");
  return best;
}

int next_pass_spp(double seconds_per_spp, double target_seconds, const StopConditions& stop, uint64_t spp_done,
                  double seconds_done) {
  double spp = 1.0;
  if (seconds_per_spp > 0.0) {
    double budget = target_seconds;
    if (stop.seconds > 0.0) budget = std::min(budget, stop.seconds - seconds_done);
    spp = std::clamp(budget / seconds_per_spp, 1.0, static_cast<double>(kMaxPassSpp));
  }
  uint64_t n = static_cast<uint64_t>(spp);
  if (stop.spp > spp_done) n = std::min<uint64_t>(n, stop.spp - spp_done);
  return static_cast<int>(std::max<uint64_t>(n, 1));
}

PassStats run_pass(Renderer& renderer, const Scene& scene, const RenderSettings& settings, Film& film, int spp,
                   bool adaptive, uint64_t& pass_index, const std::atomic<bool>* cancel) {
  if (!adaptive) return renderer.render_pass(scene, settings, film, spp, cancel);
  return renderer.render_pass(scene, settings, film, plan_adaptive_pass(film, Renderer::kTileSize, spp, pass_index++),
                              cancel);
}

}  // namespace pt
