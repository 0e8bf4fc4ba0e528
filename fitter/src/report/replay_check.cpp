// The runtime replay of a written model.coef over the fit's runs (see report.hpp,
// replay_in_runtime): numbers only; report_json.cpp and report_markdown.cpp word them.
#include <cmath>
#include <fmt/format.h>
#include <limits>
#include <memory>
#include <string>

#include "indicial/fitter/model_merge.hpp"
#include "indicial/fitter/report.hpp"
#include "indicial/runtime.hpp"

namespace indicial {

std::string model_coef_text(const FitResult& r, const std::string& origin) { return coef_file_text(r.model, origin); }

namespace {

// Returns false when they cannot be recovered (a periodic run of a multi-lag model).
bool initial_states(const FitResult& r, std::size_t ri, int n_lags, double* y) {
  bool found_first = false;
  for (int j = 0; j < n_lags; ++j) y[j] = 0.0;
  for (const ParameterEstimate& p : r.parameters) {
    if (p.id.kind != ParamKind::initial_state || p.id.run != static_cast<int>(ri)) continue;
    if (p.id.lag < n_lags) y[p.id.lag] = p.value;
    if (p.id.lag == 0) found_first = true;
  }
  if (found_first) return true;
  // Why: a periodic run has no y0 parameter (its state is the periodic steady state); with one
  // lag the model's state at sample 0 is the whole unsteady part there.
  const RunSeries& s = r.runs[ri];
  if (n_lags == 1 && !s.y_model.empty() && std::isfinite(s.y_model[0])) {
    // y_model includes the dynamic-stall families' output (zero without them).
    y[0] = s.y_model[0] - stall_output(r.model.coefficients[0].stall, s.x_rad[0], s.stall_initial);
    return true;
  }
  return false;
}

template <class Cap>
void replay_with(Predictor<double, Cap>& p, const FitResult& r, const Experiment& e,
                 RuntimeCheck& check) {
  const int n_lags = r.model.coefficients[0].n_lags;
  for (std::size_t ri = 0; ri < r.runs.size() && ri < e.runs.size(); ++ri) {
    const RunSeries& s = r.runs[ri];
    const Run& run = e.runs[ri];
    if (run.size() != s.model.size() || run.size() < 2) continue;
    double y0[FitCapacity::max_lags] = {};
    if (!initial_states(r, ri, n_lags, y0)) {
      check.detail += (check.detail.empty() ? "" : "; ") + s.path +
                      ": initial state not recoverable, not replayed";
      continue;
    }
    // The run's own airspeed (0 in a Run built in code: the experiment's), as the fit used it.
    const double airspeed_mps = run.airspeed_mps > 0.0 ? run.airspeed_mps : e.airspeed_mps;
    p.reset(run.motion_angle_rad[0], airspeed_mps);
    auto snap = p.snapshot();
    for (int j = 0; j < n_lags; ++j) snap.y[0][j] = y0[j];
    // The dynamic-stall states at sample 0 as the fit propagated them (the periodic state of a
    // periodic run; the steady state otherwise): RunSeries::stall_initial.
    snap.stall[0] = s.stall_initial;
    p.restore(snap);
    ++check.runs_replayed;
    typename Predictor<double, Cap>::Outputs out;
    for (std::size_t k = 1; k < run.size(); ++k) {
      const MotionInput in{run.motion_angle_rad[k], run.rate_radps[k], airspeed_mps};
      const StepStatus st = p.step(in, run.time_s[k] - run.time_s[k - 1], &out);
      if (st != StepStatus::ok && st != StepStatus::angle_clamped) {
        ++check.steps_not_ok;
        continue;
      }
      const double d = std::fabs(out.value[0] - s.model[k]);
      // Why the NaN test: a NaN difference must show up as a failure, not vanish in max().
      if (!(d <= check.max_abs_difference)) check.max_abs_difference = std::isnan(d) ? std::numeric_limits<double>::infinity() : d;
      ++check.samples_compared;
    }
  }
}


}  // namespace

RuntimeCheck replay_in_runtime(const FitResult& r, const Experiment& e,
                               const std::string& coef_text) {
  RuntimeCheck check;
  ParseDiagnostic diag;
  auto small = std::make_unique<Predictor<double, DefaultCapacity>>();
  check.load_status = small->load(coef_text.data(), coef_text.size(), &diag);
  if (check.load_status == LoadStatus::ok) {
    check.fit = RuntimeFit::default_capacity;
    replay_with(*small, r, e, check);
    return check;
  }
  const std::string small_reason = fmt::format("default capacity: {} at line {}: {}",
                                               to_string(check.load_status), diag.line, diag.reason);
  auto big = std::make_unique<Predictor<double, FitCapacity>>();
  ParseDiagnostic diag2;
  check.load_status = big->load(coef_text.data(), coef_text.size(), &diag2);
  if (check.load_status == LoadStatus::ok) {
    check.fit = RuntimeFit::needs_fit_capacity;
    check.detail = small_reason;
    replay_with(*big, r, e, check);
    return check;
  }
  check.fit = RuntimeFit::refused;
  check.detail = fmt::format("{}; fit capacity: {} at line {}: {}", small_reason,
                             to_string(check.load_status), diag2.line, diag2.reason);
  return check;
}

}  // namespace indicial
