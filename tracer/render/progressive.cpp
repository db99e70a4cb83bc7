#include "render/progressive.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "render/adaptive.h"

namespace pt {

const char* stop_reason(const StopConditions& stop, uint64_t spp, double seconds, double estimated_relmse) {
  if (stop.spp > 0 && spp >= stop.spp) return "target spp";
  if (stop.seconds > 0.0 && seconds >= stop.seconds) return "time limit";
  if (stop.relmse > 0.0 && spp >= kRelMseStopMinSpp && estimated_relmse <= stop.relmse) return "target relMSE";
  return nullptr;
}

RelMseForecast forecast_relmse(std::span<const RelMsePoint> history, double target) {
  RelMseForecast f;
  const RelMsePoint* newest = nullptr;
  for (const RelMsePoint& q : history)
    if (q.spp >= kRelMseStopMinSpp && q.seconds > 0.0 && q.relmse > 0.0 && std::isfinite(q.relmse)) newest = &q;
  if (!newest || !(target > 0.0)) return f;
  const double now = newest->seconds;
  if (newest->relmse <= target) {
    f.seconds = f.low = f.high = 0.0;
    return f;
  }
  // The 1/time rule from the newest point: the fallback.
  f.seconds = f.low = f.high = now * (newest->relmse / target - 1.0);
  // Least squares of y = ln relMSE on x = ln t over the latest half of the render time.
  double sx = 0.0, sy = 0.0, sxx = 0.0, sxy = 0.0;
  int n = 0;
  for (const RelMsePoint& q : history) {
    if (q.spp < kRelMseStopMinSpp || q.seconds < 0.5 * now || !(q.relmse > 0.0) || !std::isfinite(q.relmse)) continue;
    const double x = std::log(q.seconds), y = std::log(q.relmse);
    sx += x, sy += y, sxx += x * x, sxy += x * y;
    ++n;
  }
  if (n < 3) return f;
  const double mx = sx / n, my = sy / n, vxx = sxx / n - mx * mx, vxy = sxy / n - mx * my;
  if (!(vxx > 1e-4)) return f;  // the points span under ~1 % of the time: no slope to speak of
  double rss = 0.0;
  const double slope = vxy / vxx;
  for (const RelMsePoint& q : history) {
    if (q.spp < kRelMseStopMinSpp || q.seconds < 0.5 * now || !(q.relmse > 0.0) || !std::isfinite(q.relmse)) continue;
    const double r = std::log(q.relmse) - (my + slope * (std::log(q.seconds) - mx));
    rss += r * r;
  }
  const double se = std::sqrt(rss / std::max(n - 2, 1) / (vxx * n));
  // The time at which the line through the points' centre with exponent e reaches the target. Exponents are
  // kept in [0.2, 2]: a flat or rising stretch of estimates (fireflies found) predicts a long wait, not never.
  auto finish = [&](double e) {
    e = std::clamp(e, 0.2, 2.0);
    return std::exp(mx + (my - std::log(target)) / e);
  };
  // The film's estimate falls more slowly than 1/time while rare paths are still being found, and its decay
  // speeds up towards 1/time as they are: over the time still to go, the exponent lies between the fitted one
  // and 1. So the forecast is the geometric mean of the two finishing times (the fitted line's and the 1/time
  // rule's from the newest point), and the range spans both, widened by the fit's ± 2 standard errors.
  // Measured on three scenes a quarter of the way through (tests/test_render_session.cpp): fit alone +28 %,
  // 1/time alone −10 % on cornell-spheres; the mean +7 %.
  const double e = -slope;
  const double rule = now * newest->relmse / target;
  const double fit = finish(e), a = finish(e - 2.0 * se), b = finish(e + 2.0 * se);
  f.exponent = std::clamp(e, 0.2, 2.0);
  f.seconds = std::max(std::sqrt(fit * rule) - now, 0.0);
  f.low = std::max(std::min({a, b, rule}) - now, 0.0);
  f.high = std::max(std::max({a, b, rule}) - now, 0.0);
  f.fitted = true;
  return f;
}

StopProgress stop_progress(const StopConditions& stop, uint64_t spp, double seconds, double estimated_relmse,
                           std::span<const RelMsePoint> history) {
  StopProgress best;
  auto consider = [&](double fraction, double eta, double low, double high, const char* name) {
    if (!(eta >= 0.0) || !std::isfinite(eta)) return;
    if (best.eta_seconds < 0.0 || eta < best.eta_seconds) best = {std::clamp(fraction, 0.0, 1.0), eta, low, high, name};
  };
  if (stop.spp > 0 && spp > 0 && seconds > 0.0) {
    const double done = static_cast<double>(spp), target = static_cast<double>(stop.spp);
    const double eta = std::max(seconds * (target - done) / done, 0.0);
    consider(done / target, eta, eta, eta, "target spp");
  }
  if (stop.seconds > 0.0) {
    const double eta = std::max(stop.seconds - seconds, 0.0);
    consider(seconds / stop.seconds, eta, eta, eta, "time limit");
  }
  if (stop.relmse > 0.0 && spp >= kRelMseStopMinSpp && estimated_relmse > 0.0 && std::isfinite(estimated_relmse)) {
    const RelMseForecast f = forecast_relmse(history, stop.relmse);
    if (f.fitted) {
      consider(seconds / std::max(seconds + f.seconds, 1e-300), f.seconds, f.low, f.high, "target relMSE");
    } else {
      const double eta = std::max(seconds * (estimated_relmse / stop.relmse - 1.0), 0.0);
      consider(stop.relmse / estimated_relmse, eta, eta, eta, "target relMSE");
    }
  }
  return best;
}

int next_pass_spp(double seconds_per_spp, double target_seconds, const StopConditions& stop, uint64_t spp_done,
                  double seconds_done, double estimated_relmse) {
  double spp = 1.0;
  if (seconds_per_spp > 0.0) {
    double budget = target_seconds;
    if (stop.seconds > 0.0) budget = std::min(budget, stop.seconds - seconds_done);
    spp = std::clamp(budget / seconds_per_spp, 1.0, static_cast<double>(kMaxPassSpp));
  }
  uint64_t n = static_cast<uint64_t>(spp);
  if (stop.spp > spp_done) n = std::min<uint64_t>(n, stop.spp - spp_done);
  if (stop.relmse > 0.0) {
    if (spp_done < kRelMseStopMinSpp) {
      n = std::min<uint64_t>(n, kRelMseStopMinSpp - spp_done);
    } else if (estimated_relmse > stop.relmse && std::isfinite(estimated_relmse)) {
      // relMSE ∝ 1/spp: the target at spp_done · relMSE / target (rounded up; at least one more sample).
      const double needed = std::ceil(static_cast<double>(spp_done) * (estimated_relmse / stop.relmse));
      if (needed < static_cast<double>(kMaxPassSpp) + static_cast<double>(spp_done))
        n = std::min<uint64_t>(n, static_cast<uint64_t>(needed) - spp_done);
    }
  }
  return static_cast<int>(std::max<uint64_t>(n, 1));
}

PassStats ProgressivePasses::render(int spp, const std::atomic<bool>* cancel) {
  const auto start = std::chrono::steady_clock::now();
  const PassStats ps =
      adaptive_ ? renderer_.render_pass(scene_, settings_, film_,
                                        plan_adaptive_pass(film_, Renderer::kTileSize, spp, adaptive_pass_index_++), cancel)
                : renderer_.render_pass(scene_, settings_, film_, spp, cancel);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (!ps.cancelled) seconds_per_spp_ = seconds / spp;
  busy_seconds_ += seconds;
  samples_ += ps.samples;
  rays_ += ps.rays;
  passes_spp_ += static_cast<uint64_t>(spp);
  return ps;
}

}  // namespace pt
