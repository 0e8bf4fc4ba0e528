// diagnose_crossval.cpp -- leave-one-run-out prediction for `indicial diagnose` (issue 21,
// item 2): whether a candidate lowers the error of runs left out of its fit.
//
// Why prediction and not a likelihood ratio: the LR test needs the noise's spectrum. Taken from
// the residual (diagnose.hpp warning 2), a structured model error -- repeatable from run to
// run, lag-1 correlation 0.98 on measured pitching cycles -- reads as colored noise, kappa
// reaches ~99 and every extension is "not significant". A term fitted to noise does not help
// a run it was not fitted to (its noise is independent); a term that captures a real model
// error does, whatever the residual's correlation. So with enough runs the decision is:
//
//   d_r = ln(MSE_r(with) / MSE_r(without)),  r = 1..R, both fitted without run r,
//   enter  iff  mean(d) + SE(d) < 0  and  mean(d) < ln(1 - min_gain),   SE = sd(d) / sqrt(R).
//
// The pairing removes what the runs share (their difficulty, the model's common error): only
// the difference the candidate makes is compared with its run-to-run spread (a one-standard-
// error rule). min_gain (1 % of the mean square error by default) refuses gains too small to
// matter, which the spread of three numbers alone cannot bound. Log ratios weight every run
// alike, whatever its amplitude. Written by hand: the folds are fit_experiment calls, the
// statistic is a mean and a standard deviation.
#include <cmath>
#include <fmt/format.h>
#include <limits>

#include "diagnose_internal.hpp"
#include "indicial/fitter/error.hpp"
#include "indicial/fitter/predict.hpp"
#include "parallel_for.hpp"

namespace indicial::diagnose_detail {

namespace {

// The start values without run r: its initial states dropped, later runs renumbered.
Estimates without_run(const Estimates& e, int r) {
  Estimates out;
  for (const auto& [id, v] : e) {
    if (id.kind != ParamKind::initial_state) {
      out[id] = v;
      continue;
    }
    if (id.run == r) continue;
    ParamId moved = id;
    if (moved.run > r) --moved.run;
    out[moved] = v;
  }
  return out;
}

double prediction_mse(const FitResult& f, const Run& run, double airspeed_mps) {
  const Prediction p = run.periodic
                           ? predict_periodic(f.model, run.time_s, run.motion_angle_rad, run.rate_radps, airspeed_mps)
                           : predict_motion(f.model, run.time_s, run.motion_angle_rad, run.rate_radps, airspeed_mps);
  const std::vector<double>& y = p.coefficients.at(0).predicted;
  double s = 0.0;
  for (std::size_t k = 0; k < y.size(); ++k) s += (y[k] - run.coefficient[k]) * (y[k] - run.coefficient[k]);
  return s / static_cast<double>(y.size());
}

}  // namespace

HeldOut held_out_errors(const Experiment& w, const ModelConfig& m, const Estimates& start, int threads,
                        const FoldFit& fit) {
  const std::size_t n = w.runs.size();
  HeldOut h;
  h.mse.assign(n, std::numeric_limits<double>::quiet_NaN());
  std::vector<std::string> why(n);
  detail::parallel_for(n, threads, [&](std::size_t r) {
    Experiment fold = w;
    fold.runs.erase(fold.runs.begin() + static_cast<std::ptrdiff_t>(r));
    try {
      const FitResult f = fit(fold, m, start_values_for(m, without_run(start, static_cast<int>(r)), fold.runs.size(), {}));
      if (!std::isfinite(f.fit_error)) {
        why[r] = fmt::format("the fit without run {} failed: {}", r + 1, f.output_error.message);
        return;
      }
      // Why: a term the other runs do not determine keeps its start value -- the full fit's,
      // which saw run r; its prediction of run r would not be a prediction.
      if (f.output_error.termination == Termination::rank_deficient) {
        why[r] = fmt::format("not determined without run {}", r + 1);
        return;
      }
      const Run& run = w.runs[r];
      h.mse[r] = prediction_mse(f, run, run.airspeed_mps > 0.0 ? run.airspeed_mps : w.airspeed_mps);
    } catch (const std::exception& err) {
      why[r] = fmt::format("run {} left out: {}", r + 1, err.what());
    }
  });
  h.ok = true;
  for (std::size_t r = 0; r < n; ++r) {
    if (std::isfinite(h.mse[r])) continue;
    h.ok = false;
    if (h.message.empty()) h.message = why[r].empty() ? fmt::format("run {}: no finite prediction", r + 1) : why[r];
  }
  return h;
}

HeldOutTest held_out_test(Effect effect, const std::string& terms, const char* stage, const HeldOut& without,
                          const HeldOut& with, double min_gain) {
  HeldOutTest t;
  t.effect = effect;
  t.terms = terms;
  t.stage = stage;
  for (double v : without.mse) t.rms_without.push_back(std::sqrt(v));
  for (double v : with.mse) t.rms_with.push_back(std::sqrt(v));
  if (!without.ok || !with.ok) {
    t.message = !with.ok ? with.message : "the model without it: " + without.message;
    t.mean_log_ratio = std::numeric_limits<double>::quiet_NaN();
    t.standard_error = std::numeric_limits<double>::quiet_NaN();
    return t;
  }
  const std::size_t n = with.mse.size();
  std::vector<double> d(n);
  double mean = 0.0;
  for (std::size_t r = 0; r < n; ++r) {
    // Why the floor: a run predicted exactly (noise-free data) has no ratio; 1e-300 keeps it finite.
    d[r] = std::log(std::max(with.mse[r], 1e-300) / std::max(without.mse[r], 1e-300));
    mean += d[r] / static_cast<double>(n);
  }
  double ss = 0.0;
  for (double v : d) ss += (v - mean) * (v - mean);
  t.mean_log_ratio = mean;
  t.standard_error = n > 1 ? std::sqrt(ss / static_cast<double>(n - 1) / static_cast<double>(n)) : 0.0;
  t.enters = mean + t.standard_error < 0.0 && mean < std::log1p(-min_gain);
  return t;
}

}  // namespace indicial::diagnose_detail
