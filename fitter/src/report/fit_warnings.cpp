// The warnings about a finished fit (see report.hpp, fit_warnings): the fit error against the
// noise (replicates' spread, or the residual's short-lag level), lags that do not decay over the
// runs, dynamic-stall states too slow for the cycle, an estimate on the
// feasible set's boundary, and ill-conditioned estimates.
#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <limits>
#include <string>
#include <vector>

#include "indicial/fitter/noise_level.hpp"
#include "indicial/fitter/replication.hpp"
#include "indicial/fitter/report.hpp"

namespace indicial {

namespace {

// Lags whose decay over the longest run is under kLagDecayFloor: b_j(x) T < 0.05 everywhere in
// the envelope (b_j sampled at 257 angles). Why: y' = -b y - a(x) x' with b T << 1 integrates
// a(x) x' without decay, y = -A(x) + y(0): a static correction plus each run's initial state,
// not a lag. A fit lands there when the data show no lag of this structure (measured on the
// Glasgow NACA 0012 C_m cycles, tools/validate-real.sh: b1 = 8e-5 1/s +- 2.4 against runs of
// 0.43 s, a(x) coefficients of 1e3), and the ill-conditioned list alone does not say why.
constexpr double kLagDecayFloor = 0.05;

void warn_undamped_lags(const FitResult& r, const Experiment& e, std::vector<std::string>* w) {
  double longest_s = 0.0;
  for (const RunSeries& run : r.runs)
    if (run.time_s.size() > 1) longest_s = std::max(longest_s, run.time_s.back() - run.time_s.front());
  if (!(longest_s > 0.0) || r.model.n_coefficients < 1) return;
  const auto& cm = r.model.coefficients[0];
  constexpr int kSamples = 257;
  for (int j = 0; j < cm.n_lags; ++j) {
    double b_max = -std::numeric_limits<double>::infinity();
    for (int i = 0; i < kSamples; ++i) {
      const double x = r.model.x_min_rad + (r.model.x_max_rad - r.model.x_min_rad) * i / (kSamples - 1);
      b_max = std::max(b_max, spline_value(cm.lags[j].b, x));
    }
    if (!(b_max * longest_s < kLagDecayFloor)) continue;
    w->push_back(fmt::format(
        "{}: lag {} does not decay over the runs: b{}(x) <= {:.3g} 1/s over the envelope, a time constant "
        "of at least {:.3g} s against {:.3g} s of the longest run. Such a lag only integrates a(x) x': a "
        "static correction -A(x) plus each run's initial state, not an unsteady effect (its a(x) and "
        "b{} are then ill-conditioned). The fit found no decaying lag of this structure (or stopped at the "
        "boundary b -> 0 from its start): a rate term (`[rotary]`) or a dynamic-stall family may be what "
        "the data need; `indicial diagnose` decides",
        e.path, j + 1, j + 1, b_max, 1.0 / b_max, longest_s, j + 1));
  }
}

// A dynamic-stall state whose time constant T is long against the shortest periodic run's
// cycle: it keeps more than kStallCycleMemoryFloor of its value over one cycle (exp(-cycle / T)),
// so within the fitted cycles it hardly moves. Its periodic value (periodic_stall.hpp) is then
// set by the cycle's AVERAGE forcing over T / cycle cycles: a large offset that the output
// gains scale down, not a dynamic-stall transient, and a held-out cycle at another mean angle
// or amplitude gets another offset. Why a warning: of the 139 final models with the vortex
// family among the development set's 184 three-cycle diagnoses (docs/diagnose-speed.md), 18,
// all from the Beddoes-Leishman start, had T_v of 276-2.5e6 l/V and output gains up to |c_v| =
// 6e4, |x_v| = 4.6e5 (measured when periodic runs started after three warm-up cycles; the
// floor, 0.1 per cycle, is that rule's 1e-3 after three cycles).
constexpr double kStallCycleMemoryFloor = 0.1;

}  // namespace

std::vector<std::string> slow_stall_state_warnings(const FitResult& r, const Experiment& e) {
  std::vector<std::string> out;
  if (r.model.n_coefficients < 1) return out;
  const StallModel<double, FitCapacity>& st = r.model.coefficients[0].stall;
  if (st.families == StallFamilies::none) return out;
  double cycle = std::numeric_limits<double>::infinity();  // the shortest periodic cycle, l/V units
  for (const Run& run : e.runs) {
    if (!run.periodic || run.time_s.size() < 2) continue;
    const double v_mps = run.airspeed_mps > 0.0 ? run.airspeed_mps : e.airspeed_mps;
    const double l_over_v_s = airspeed_scaling(e.airspeed_mps, e.reference_length_m, v_mps).l_over_v_s;
    const std::size_t n = run.time_s.size();
    // The cycle: 1 / frequency when given, else the samples' span and one more step (a cycle
    // that does not repeat its first sample; one that does is a step shorter: the warning errs
    // toward saying so).
    const double span_s = run.time_s.back() - run.time_s.front();
    const double period_s =
        run.frequency_hz > 0.0 ? 1.0 / run.frequency_hz : span_s * static_cast<double>(n) / static_cast<double>(n - 1);
    if (period_s > 0.0 && l_over_v_s > 0.0) cycle = std::min(cycle, period_s / l_over_v_s);
  }
  if (!std::isfinite(cycle)) return out;
  struct Constant {
    const char* name;
    double semichords;
  };
  std::vector<Constant> constants{{"T1 (the separation point's)", st.separation.tau1_semichords}};
  if (st.separation.tau1_reattach_semichords > 0.0)
    constants.push_back({"T1r (the separation point's while reattaching)", st.separation.tau1_reattach_semichords});
  if (st.separation.forcing_lag == ForcingLag::first_order && st.separation.tau2_semichords > 0.0)
    constants.push_back({"T2 (the forcing angle's)", st.separation.tau2_semichords});
  if (st.families == StallFamilies::separation_and_vortex)
    constants.push_back({"T_v (the vortex lift's)", st.vortex.decay_semichords});
  for (const Constant& c : constants) {
    const double kept = std::exp(-cycle / c.semichords);
    if (!(kept > kStallCycleMemoryFloor)) continue;
    out.push_back(fmt::format(
        "{}: the dynamic-stall time constant {} = {:.4g} l/V is long against the shortest periodic run's "
        "cycle of {:.4g} l/V: the state keeps {:.3g} of its value over a cycle, so it hardly moves within "
        "the fitted cycles; its periodic value is set by the cycle's average, an offset the output gains "
        "scale, not a dynamic-stall transient, and held-out cycles at other conditions get other offsets. "
        "The data may not support this family (`indicial diagnose` decides), or hold the constant at a "
        "physical value (`model.stall_known`)",
        e.path, c.name, c.semichords, cycle, kept));
  }
  return out;
}

namespace {

// The fit error against the noise: replicates' spread when the data have replication,
// otherwise the residual's short-lag level (worded as such: not a measurement of the noise).
void warn_fit_error_against_noise(const FitResult& r, const Experiment& e, std::vector<std::string>* w) {
  // Why first: replicates' spread is the noise; a residual's short-lag level is noise only
  // where the model is right (replication.hpp).
  const ReplicationNoise rep = replication_noise(e);
  if (rep.source != NoiseSource::none) {
    if (std::isfinite(r.fit_error) && rep.sigma > 0.0 && r.fit_error > kFitErrorNoiseRatio * rep.sigma)
      w->push_back(fmt::format(
          "{}: the fit error s(v) = {:.4g} is {:.1f} times the noise level from replication ({:.4g}: {}); "
          "more than {:g} times means the model misses an effect or the input is wrong: check the angle "
          "units and columns, or run `indicial diagnose`",
          e.path, r.fit_error, r.fit_error / rep.sigma, rep.sigma, rep.detail, kFitErrorNoiseRatio));
    return;
  }
  const NoiseEstimate noise = estimate_noise_level(r.runs);
  // Why the white-equivalent level: a model error leaks into the marginal (AR(1)) level and
  // would hide itself; the second difference does not pass it (noise_level.hpp).
  const double level = noise.white_equivalent;
  if (std::isfinite(r.fit_error) && level > 0.0 && r.fit_error > kFitErrorNoiseRatio * level) {
    w->push_back(fmt::format(
        "{}: the fit error s(v) = {:.4g} is {:.1f} times the short-lag level of the fit's own residual "
        "({:.4g}, white-equivalent, from the residuals' second differences; their AR(1) phi is {:.2f}): "
        "more than {:g} times, the residual is smooth and structured -- wrong input (check the angle units "
        "and columns) or a missing effect. That level comes from this model's residual, not from "
        "replicated data, so it is not a measurement of the noise: `indicial diagnose` decides whether an "
        "effect is missing",
        e.path, r.fit_error, r.fit_error / level, level, noise.lag1_correlation, kFitErrorNoiseRatio));
  }
}

// An output-error estimate on the feasible set's boundary (the steps tried from it went to
// inadmissible models). Why a warning and not only fit.json's feasibility_boundary: the solver
// then reports "converged" where it was stopped by the boundary (a trial step it could not take),
// and its Cramer-Rao bounds describe an unconstrained minimum the estimate is not.
void warn_feasibility_boundary(const FitResult& r, const Experiment& e, std::vector<std::string>* w) {
  const OutputErrorSummary& oe = r.output_error;
  if (oe.boundary != FeasibilityBoundary::active) return;
  w->push_back(fmt::format(
      "{}: the output-error estimate sits on the boundary of the admissible models ({} trial steps over the "
      "solve went to inadmissible ones: a lag with b(x) <= 0 somewhere in the data's angle range (with periodic "
      "runs: below one decay per longest cycle), a negative delay, or a dynamic-stall time constant <= 0 (with "
      "periodic runs: beyond the shortest cycle / ln 10)): a constrained optimum, so its Cramer-Rao "
      "bounds describe an unconstrained minimum it is not. The data may want a term the structure cannot "
      "give (`indicial diagnose`), or another start (`--start-value`)",
      e.path, oe.infeasible_trials));
}

}  // namespace

std::vector<std::string> fit_warnings(const FitResult& r, const Experiment& e) {
  std::vector<std::string> w;
  warn_undamped_lags(r, e, &w);
  const std::vector<std::string> slow = slow_stall_state_warnings(r, e);
  w.insert(w.end(), slow.begin(), slow.end());
  warn_fit_error_against_noise(r, e, &w);
  warn_feasibility_boundary(r, e, &w);
  // Every fit, replicated or not (issue 21 item 8: an estimate whose bound exceeds its value was
  // flagged by diagnose but not by fit; with replicated runs fit returned before this list).
  std::string weak;
  for (const ParameterEstimate& p : r.parameters)
    if (bound_exceeds_value(p)) weak += fmt::format("{}{} = {:.4g} +- {:.4g}", weak.empty() ? "" : ", ", p.name, p.value, p.cr_bound);
  if (!weak.empty())
    w.push_back(fmt::format("{}: ill-conditioned estimates (Cramer-Rao bound larger than the value): {}; the data "
                            "do not determine them (remove the terms, or add runs that excite them)",
                            e.path, weak));
  return w;
}

}  // namespace indicial
