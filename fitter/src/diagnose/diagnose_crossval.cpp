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
//   enter  iff  mean(d) + SE(d) < 0,  mean(d) < ln(1 - min_gain)   (SE = sd(d) / sqrt(R))
//          and  it lowers the error of more than half of the runs.
//
// The pairing removes what the runs share (their difficulty, the model's common error): only
// the difference the candidate makes is compared with its run-to-run spread (a one-standard-
// error rule). Log ratios weight every run alike, whatever its amplitude. Why min_gain (10 %
// of the mean square error, 5 % of the RMS): the candidate's term (a knot position, which of
// the effect's terms) is chosen on all runs, the left-out one included, so a term fitted to
// noise still "helps" a left-out run a little (measured under AR(1) phi 0.8 noise with a
// complete model: mean gains up to 6 %, in 3 of 5 seeds by more than one SE); three numbers do
// not bound that by their spread alone. A real model error gains much more (0.3 to 2 in ln MSE
// on the tests' hidden effects; a second effect after a first may leave one run a little
// worse, so not every run must improve). Choosing the term inside each fold would remove the
// leak at R times the scan. With K > 3 folds the minimum is min_gain 3 / K
// (min_gain_for_folds): the left-out fold is 1 / K of the data the term was chosen on, so the
// chance gain it lends that fold shrinks as 1 / K, and min_gain was set for three (the leak
// under noise alone, measured with six and ten runs: docs/diagnose.md,
// tests/test_diagnose_crossval_many_runs.cpp). Written by hand: the folds are fit_experiment calls, the
// statistic is a mean and a standard deviation.
//
// Where a left-out run is scored (scored_samples): on its samples inside the angle range of the
// runs its fold fitted, widened at each end by a tenth of its width (kScoredMarginFraction); on
// all of them when fewer than min_scored_samples are inside. Beyond the fold's range its model
// holds every fitted angle-dependent term (a(x), b(x), C_aq(x), the static correction, the
// families' f0 correction) at the range's edge -- the runtime's envelope clamp; a static table
// alone follows the angle -- so there the run measures an extrapolation no such term can help,
// and with runs at different mean angles it dominated: leaving out the run at the highest mean
// angle of three predicts its stall from two cycles that never reached it (held-out RMS
// 0.44-0.64 against 0.03-0.12 for the other two on two of the development set's mean-angle
// triples), its log ratio is near 0 for every candidate and no effect can win a majority of
// the runs. The margin is a strip where the fold's model is clamped too, kept on purpose: the
// runs of one frequency sweep reach largest angles a degree or two apart, and without it the
// top of the highest run -- where stall effects act -- was cut: three sweeps' C_L models lost
// their effects and predicted the other cycles worse (tools/diagnose_ab.py, 2026-11-30,
// docs/diagnose-scoring.md). The prediction itself runs over the whole run (the states pass
// through the part outside); only the squared errors outside (and, for a non-periodic run,
// their pull on its fitted initial state) are left out. Runs that share one angle range (a
// sweep, replicates) are scored everywhere; the colored-noise null cases
// (test_diagnose_null.cpp, the matrix) still name nothing.
//
// Many runs (a tunnel entry has hundreds): R fits per candidate would cost R times the
// candidate's fit, so with more runs than max_folds (DiagnoseOptions::cv_max_folds, 10) the
// runs are dealt into K = max_folds folds, run r into fold r mod K (file order: runs listed by
// condition put neighbouring conditions into different folds, so every fold's runs have
// neighbours in its fit). Every run is still predicted by a model that did not see it; d is
// then taken per FOLD (the mean of its runs' log ratios) and SE over the K folds, since runs
// scored by one fitted model are not independent. With R <= max_folds, K = R: leave-one-run-out
// exactly as above.
//
// Groups (fold_plan, DiagnoseOptions::cv_unit group, `--cv-unit group`): every run has a group
// (Run::group, a runs entry's `group`: the tunnel entry, campaign or session it was measured
// in), and a fold leaves out whole groups (group g, in order of first appearance, into fold g
// mod max_folds), so a term enters only when it lowers the error of an entry its fit never saw.
// Runs of one entry share what changes between entries (a balance's zero, the model's
// installation): a term can lower the error of a left-out run of the same entry without
// carrying to another. Everything else (scoring, d per fold, the minimum gain for K folds) is
// as for runs. Not the default: diagnose.hpp's CrossValidationUnit says why (measured).
#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <limits>
#include <memory>

#include "diagnose/diagnose_internal.hpp"
#include "indicial/fitter/error.hpp"
#include "indicial/fitter/predict.hpp"
#include "indicial/runtime.hpp"
#include "numerics/parallel_for.hpp"

namespace indicial::diagnose_detail {

namespace {

// The scored range (scored_samples): the fold's angle range widened by this share of its width
// at each end (see "Where a left-out run is scored" above).
constexpr double kScoredMarginFraction = 0.1;

// The start values without the runs of fold j: their initial states dropped, the other runs
// renumbered (in order, as the fold's experiment lists them).
Estimates without_fold(const Estimates& e, int fold, const std::vector<int>& fold_of_run) {
  std::vector<int> renumbered(fold_of_run.size(), -1);
  int next = 0;
  for (std::size_t r = 0; r < fold_of_run.size(); ++r)
    if (fold_of_run[r] != fold) renumbered[r] = next++;
  Estimates out;
  for (const auto& [id, v] : e) {
    if (id.kind != ParamKind::initial_state) {
      out[id] = v;
      continue;
    }
    const std::size_t r = static_cast<std::size_t>(id.run);
    if (r >= renumbered.size() || renumbered[r] < 0) continue;
    ParamId moved = id;
    moved.run = renumbered[r];
    out[moved] = v;
  }
  return out;
}

// The first coefficient of run `run` predicted by the runtime from the steady state at its first
// sample with lag 1's state moved by dy0 (the loop of predict_motion, with that one change).
std::vector<double> stepped_output(Predictor<double, FitCapacity>& p, const Run& run, double airspeed_mps, double dy0) {
  const auto& m = p.model();
  const std::size_t n = run.size();
  std::vector<double> y(n);
  p.reset(run.motion_angle_rad[0], airspeed_mps);
  auto snap = p.snapshot();
  snap.y[0][0] += dy0;
  p.restore(snap);
  const double l_over_v_s = airspeed_scaling(m.airspeed_mps, m.reference_length_m, airspeed_mps).l_over_v_s;
  const double x0 = model_angle<double>(m.axis, m.alpha0_rad, run.motion_angle_rad[0]);
  y[0] = coefficient_output(m.coefficients[0], std::min(std::max(x0, m.x_min_rad), m.x_max_rad), run.rate_radps[0],
                            l_over_v_s, snap.y[0]);
  Predictor<double, FitCapacity>::Outputs out;
  for (std::size_t i = 1; i < n; ++i) {
    const StepStatus st = p.step(MotionInput{run.motion_angle_rad[i], run.rate_radps[i], airspeed_mps},
                                 run.time_s[i] - run.time_s[i - 1], &out);
    if (st != StepStatus::ok && st != StepStatus::angle_clamped)
      throw InputError(run.path, 0, "the runtime refused sample " + std::to_string(i) + ": " + to_string(st));
    y[i] = out.value[0];
  }
  return y;
}

struct RunScore {
  double mse = std::numeric_limits<double>::quiet_NaN();
  double scored_fraction = 0.0;
};

// Mean square error of the fold's model on the left-out run, over its scored samples
// (scored_samples). A periodic run: its periodic steady state (predict_periodic). Otherwise
// the run starts where the fitter starts every non-periodic run, at a free lag-1 initial
// state: the output is linear in it (y = y_a + dy0 (y_b - y_a)), and dy0 is the least-squares
// value on the run's scored samples -- one nuisance number per run, for the model with and
// without the candidate alike; no model parameter sees the run.
RunScore prediction_mse(const FitResult& f, const Run& run, double airspeed_mps, const AngleRange& fitted) {
  const std::vector<char> scored = scored_samples(run, f.model.axis, f.model.alpha0_rad, fitted);
  std::vector<double> y;
  if (run.periodic) {
    y = predict_periodic(f.model, run.time_s, run.motion_angle_rad, run.rate_radps, airspeed_mps).coefficients.at(0).predicted;
  } else {
    auto p = std::make_unique<Predictor<double, FitCapacity>>();  // tens of KB: heap
    ParseDiagnostic diag;
    if (p->load(f.model, &diag) != LoadStatus::ok)
      throw InputError(run.path, 0, std::string("the runtime refuses the fold's model: ") + diag.reason);
    y = stepped_output(*p, run, airspeed_mps, 0.0);
    const std::vector<double> yb = stepped_output(*p, run, airspeed_mps, 1.0);
    double num = 0.0, den = 0.0;
    for (std::size_t k = 0; k < y.size(); ++k) {
      if (!scored[k]) continue;
      const double phi = yb[k] - y[k];
      num += phi * (run.coefficient[k] - y[k]);
      den += phi * phi;
    }
    const double dy0 = den > 0.0 ? num / den : 0.0;
    for (std::size_t k = 0; k < y.size(); ++k) y[k] += dy0 * (yb[k] - y[k]);
  }
  double s = 0.0;
  std::size_t n = 0;
  for (std::size_t k = 0; k < y.size(); ++k) {
    if (!scored[k]) continue;
    s += (y[k] - run.coefficient[k]) * (y[k] - run.coefficient[k]);
    ++n;
  }
  return RunScore{s / static_cast<double>(n), static_cast<double>(n) / static_cast<double>(y.size())};
}

// A knot the fold's runs do not straddle (at or beyond the range of their model angle) has a
// term the fold cannot determine -- zero at every sample, or collinear with x^0 and x^1 -- and
// the fit refuses it. Why drop it rather than give up: a configuration with knots spread over
// the whole experiment (every 5 deg, say) would otherwise make every fold that leaves out the
// run reaching highest untestable, and diagnose would fall back to the likelihood ratio on
// measured data (validate-real's "means" training set: mean angles 6, 8, 15 deg, knot 20 deg).
// The fold's model has the term at zero, for the model with and without the candidate alike:
// it predicts the left-out run from what the other runs determine, which is the point.
void drop_knots_outside(SplineConfig& s, const AngleRange& r) {
  std::vector<double> kept;
  for (double k : s.knots_rad)
    if (k > r.min_rad && k < r.max_rad) kept.push_back(k);
  s.knots_rad = std::move(kept);
}

ModelConfig fold_model(const ModelConfig& m, const AngleRange& r) {
  ModelConfig f = m;
  for (SplineConfig* s : {&f.a, &f.b1, &f.static_correction, &f.rotary_correction, &f.stall.f0_correction})
    drop_knots_outside(*s, r);
  for (SplineConfig& s : f.further_lag_b) drop_knots_outside(s, r);
  return f;
}

}  // namespace

std::size_t min_scored_samples(std::size_t samples) { return std::max<std::size_t>(8, samples / 4); }

std::vector<char> scored_samples(const Run& run, Axis axis, double alpha0_rad, const AngleRange& fitted) {
  const double margin_rad = kScoredMarginFraction * (fitted.max_rad - fitted.min_rad);
  const std::size_t n = run.motion_angle_rad.size();
  std::vector<char> inside(n);
  std::size_t n_inside = 0;
  for (std::size_t k = 0; k < n; ++k) {
    const double x = model_angle(axis, alpha0_rad, run.motion_angle_rad[k]);
    inside[k] = x >= fitted.min_rad - margin_rad && x <= fitted.max_rad + margin_rad;
    n_inside += inside[k] ? 1 : 0;
  }
  if (n_inside < min_scored_samples(n)) std::fill(inside.begin(), inside.end(), 1);
  return inside;
}

bool majority_improved(int improved, int runs) { return 2 * improved > runs; }

FoldPlan fold_plan(const Experiment& e, int max_folds, CrossValidationUnit unit) {
  FoldPlan p;
  const std::size_t n = e.runs.size();
  const std::size_t k_max = static_cast<std::size_t>(std::max(1, max_folds));
  p.fold_of_run.resize(n);
  if (unit == CrossValidationUnit::run) {
    p.folds = static_cast<int>(std::min(n, k_max));
    for (std::size_t r = 0; r < n; ++r) p.fold_of_run[r] = static_cast<int>(r % static_cast<std::size_t>(p.folds));
    return p;
  }
  for (std::size_t r = 0; r < n; ++r) {
    const Run& run = e.runs[r];
    if (run.group.empty())
      throw InputError(e.path, run.experiment_line,  // the experiment file's runs entry
                       "--cv-unit group: run '" + run.path + "' has no 'group' (give every runs entry a group: "
                       "the tunnel entry, campaign or session it was measured in)");
    const auto it = std::find(p.groups.begin(), p.groups.end(), run.group);
    p.fold_of_run[r] = static_cast<int>(it - p.groups.begin());
    if (it == p.groups.end()) p.groups.push_back(run.group);
  }
  if (p.groups.size() < 2)
    throw InputError(e.path, 0, "--cv-unit group: every run is in group '" + (p.groups.empty() ? std::string() : p.groups[0]) +
                                    "'; leaving whole groups out needs at least two");
  p.unit = CrossValidationUnit::group;
  p.folds = static_cast<int>(std::min(p.groups.size(), k_max));
  for (int& f : p.fold_of_run) f %= p.folds;
  return p;
}

namespace {
// How a fold is named in messages: "run 3", "group 'campaign 5'", "fold 2 of 10".
std::string fold_label(const FoldPlan& p, std::size_t j, std::size_t runs) {
  if (p.unit == CrossValidationUnit::group)
    return p.folds == static_cast<int>(p.groups.size()) ? fmt::format("group '{}'", p.groups[j])
                                                        : fmt::format("fold {} of {} (groups)", j + 1, p.folds);
  return static_cast<std::size_t>(p.folds) == runs ? fmt::format("run {}", j + 1)
                                                  : fmt::format("fold {} of {}", j + 1, p.folds);
}
}  // namespace

HeldOut held_out_errors(const Experiment& w, const ModelConfig& m, const Estimates& start, int threads,
                        int max_folds, const FoldFit& fit, CrossValidationUnit unit) {
  const std::size_t n = w.runs.size();
  const FoldPlan plan = fold_plan(w, max_folds, unit);
  HeldOut h;
  h.folds = plan.folds;
  h.fold_of_run = plan.fold_of_run;
  const std::size_t folds = static_cast<std::size_t>(h.folds);
  h.mse.assign(n, std::numeric_limits<double>::quiet_NaN());
  h.scored_fraction.assign(n, 0.0);
  std::vector<std::string> why(folds);
  detail::parallel_for(folds, threads, [&](std::size_t j) {
    const int jf = static_cast<int>(j);
    Experiment fold = w;
    fold.runs.clear();
    for (std::size_t r = 0; r < n; ++r)
      if (plan.fold_of_run[r] != jf) fold.runs.push_back(w.runs[r]);
    const AngleRange range = model_angle_range(fold);
    fold.data_x_min_rad = range.min_rad;
    fold.data_x_max_rad = range.max_rad;
    const ModelConfig fm = fold_model(m, range);
    const std::string left_out = fold_label(plan, j, n);
    try {
      const FitResult f = fit(fold, fm, start_values_for(fm, without_fold(start, jf, plan.fold_of_run), fold.runs.size(), {}));
      if (!std::isfinite(f.fit_error)) {
        why[j] = fmt::format("the fit without {} failed: {}", left_out, f.output_error.message);
        return;
      }
      // Why: a term the other runs do not determine keeps its start value -- the full fit's,
      // which saw the left-out runs; its prediction of them would not be a prediction.
      if (f.output_error.termination == Termination::rank_deficient) {
        why[j] = fmt::format("not determined without {}", left_out);
        return;
      }
      for (std::size_t r = 0; r < n; ++r) {
        if (plan.fold_of_run[r] != jf) continue;
        const Run& run = w.runs[r];
        const RunScore score = prediction_mse(f, run, run.airspeed_mps > 0.0 ? run.airspeed_mps : w.airspeed_mps, range);
        h.mse[r] = score.mse;
        h.scored_fraction[r] = score.scored_fraction;
      }
    } catch (const std::exception& err) {
      why[j] = fmt::format("{} left out: {}", left_out, err.what());
    }
  });
  h.ok = true;
  for (std::size_t r = 0; r < n; ++r) {
    if (std::isfinite(h.mse[r])) continue;
    h.ok = false;
    if (h.message.empty())
      h.message = why[static_cast<std::size_t>(plan.fold_of_run[r])].empty()
                      ? fmt::format("run {}: no finite prediction", r + 1)
                      : why[static_cast<std::size_t>(plan.fold_of_run[r])];
  }
  return h;
}

double min_gain_for_folds(double min_gain, int folds) {
  return folds > kMinGainFolds ? min_gain * kMinGainFolds / static_cast<double>(folds) : min_gain;
}

HeldOutTest held_out_test(Effect effect, const std::string& terms, const char* stage, const HeldOut& without,
                          const HeldOut& with, double min_gain, double min_in_sample_gain) {
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
  // d per fold (the mean of its runs' log ratios; one run per fold under leave-one-run-out).
  const std::size_t n = with.mse.size();
  const std::size_t folds = with.folds > 0 ? static_cast<std::size_t>(with.folds) : n;  // 0: one run per fold
  std::vector<double> d(folds, 0.0);
  std::vector<int> in_fold(folds, 0);
  std::vector<double> run_d(n);
  for (std::size_t r = 0; r < n; ++r) {
    // Why the floor: a run predicted exactly (noise-free data) has no ratio; 1e-300 keeps it finite.
    run_d[r] = std::log(std::max(with.mse[r], 1e-300) / std::max(without.mse[r], 1e-300));
    const std::size_t j = r < with.fold_of_run.size() ? static_cast<std::size_t>(with.fold_of_run[r]) : r % folds;
    d[j] += run_d[r];
    ++in_fold[j];
  }
  double mean = 0.0;
  for (std::size_t j = 0; j < folds; ++j) {
    d[j] /= std::max(1, in_fold[j]);
    mean += d[j] / static_cast<double>(folds);
  }
  double ss = 0.0;
  for (double v : d) ss += (v - mean) * (v - mean);
  t.mean_log_ratio = mean;
  t.standard_error = folds > 1 ? std::sqrt(ss / static_cast<double>(folds - 1) / static_cast<double>(folds)) : 0.0;
  t.folds = static_cast<int>(folds);
  t.runs_improved = static_cast<int>(std::count_if(run_d.begin(), run_d.end(), [](double v) { return v < 0.0; }));
  // Materiality in sample too: a term that lowers the error of the runs it was fitted to by
  // less than min_in_sample_gain (DiagnoseOptions::cv_min_in_sample_gain, `--min-in-sample-gain`,
  // default 4 % of the MSE) does not enter, whatever a few left-out runs say. Why: with three runs a chance improvement of the left-out runs passes the held-out
  // conditions -- measured on the matrix's null cases (complete model): C_L AR(1) seed 5001
  // rotary_alpha, held out -0.12 (3 of 3 runs better) with an in-sample ln MSE ratio of -0.022;
  // C_m turbulence seed 6002 second_lag, -0.16 and -0.018. Why 4 % and not min_gain (10 %):
  // a real second b1 knot after two effects (test_diagnose_two_effects) gains -0.18 held out
  // and only -0.052 to -0.087 in sample; at 10 % it was refused and the last effect missed.
  // The margin is thin on both sides (0.022 against 0.052), measured, not derived.
  t.in_sample_log_ratio = std::isfinite(with.fit_error) && std::isfinite(without.fit_error) && without.fit_error > 0.0
                              ? 2.0 * std::log(std::max(with.fit_error, 1e-300) / without.fit_error)
                              : std::numeric_limits<double>::quiet_NaN();
  const bool material = !std::isfinite(t.in_sample_log_ratio) || t.in_sample_log_ratio < std::log1p(-min_in_sample_gain);
  t.enters = mean + t.standard_error < 0.0 && mean < std::log1p(-min_gain_for_folds(min_gain, t.folds)) && material &&
             majority_improved(t.runs_improved, static_cast<int>(n));
  return t;
}

}  // namespace indicial::diagnose_detail
