// diagnose_internal.hpp -- what diagnose.cpp (the algorithm), diagnose_effects.cpp (the effect
// registry and its candidate generators) and diagnose_output.cpp (JSON, Markdown, gnuplot)
// share. Not installed.
#pragma once

#include <limits>
#include <cmath>
#include <cstddef>
#include <functional>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "indicial/fitter/diagnose.hpp"

namespace indicial::diagnose_detail {

constexpr double kRadToDeg = 180.0 / M_PI;
constexpr double kDegToRad = M_PI / 180.0;

// Start values and estimates are keyed by what a parameter is (ParamId: kind, lag, power, knot
// position, run), never by its name: inserting a knot renumbers the names A1, A2, ..., not the
// terms. Names are made (parameter_name) only where a fit takes its start values.
using StartValues = std::vector<std::pair<ParamId, double>>;
using Estimates = std::map<ParamId, double>;

// The splines an effect may extend by a knot or a power.
enum class SplineFamily { b1, a, rotary, static_correction, none };

// One candidate model: the configuration and its start values (several starts: the best fit
// is kept; the starts are one model, one test).
struct CandidateSpec {
  Effect effect = Effect::bias;
  std::string term;    // what was added, e.g. "b1(x) knot (x - k)_+ at 30.00 deg"
  std::string detail;  // for reports: "knot 30.00 deg"
  ModelConfig config;
  std::vector<StartValues> starts;  // extra start values (empty: one start, new terms at 0)
  // Where the candidate's fits start (candidate_starts). current_and_own also fits from the
  // fitter's own start (`indicial fit`'s: equation error and the file's start keys, nothing
  // taken from the current model), the better fit kept. Why (the stall families): warm-started
  // from a current model whose lag had fitted to b1 -> 0 (measured C_m cycles, validate-real
  // `sweep`), the vortex candidate kept that lag and ended at 0.0566, where `indicial fit` of
  // the same structure ends at 0.0500 with b1 = 45 1/s.
  enum class StartFrom { current, current_and_own } start_from = StartFrom::current;
  SplineFamily family = SplineFamily::none;
  bool is_knot = false;
  double knot_rad = 0.0;
};

// What a candidate generator sees.
struct CandidateContext {
  const Experiment& experiment;  // the working experiment
  const ModelConfig& model;      // the model of the round
  const FitResult& base;         // its fit
  const std::vector<double>& knot_grid;
  double knot_spacing_rad = 0.0;
};

using CandidateGenerator = void (*)(const CandidateContext&, std::vector<CandidateSpec>&);

// The registry: one entry per effect, in the enum's order.
struct EffectEntry {
  EffectDescription description;
  SplineFamily family;  // the spline a knot refinement extends (none: no knots)
  CandidateGenerator generate;
  // Whether a family without a spline is grown term by term too (its generator, called against
  // the grown model, offers the next terms; each enters by the round's rule). Spline families
  // always grow; false: the effect is one model (bias, time_delay, second_lag).
  bool grows = false;
};
const std::vector<EffectEntry>& effect_registry();
const EffectEntry& effect_entry(Effect e);

// Candidates.
SplineConfig& family_spline(ModelConfig& m, SplineFamily f);
const SplineConfig& family_spline(const ModelConfig& m, SplineFamily f);
CandidateSpec knot_candidate(const ModelConfig& m, Effect effect, SplineFamily f, double knot_rad);
bool has_knot(const std::vector<double>& knots, double k, double min_gap);
std::vector<double> knot_grid(const Experiment& e, const DiagnoseOptions& o, double& spacing);
// Every registered effect's candidates against the model of a round.
std::vector<CandidateSpec> all_candidates(const CandidateContext& ctx);

// Parameter identity: start values carried from fit to fit by what a parameter is.
Estimates estimates_by_id(const FitResult& r);
// The start values of model `m` (its terms, and the initial states of n_runs runs, that are in
// `current`), then `extra` (replacing or adding).
StartValues start_values_for(const ModelConfig& m, const Estimates& current, std::size_t n_runs,
                             const StartValues& extra);
// The starts of candidate c's fits: the current estimates with each of c.starts' extra values
// (one start when it has none), then, with StartFrom::current_and_own, the fitter's own start
// (an empty StartValues: equation error and the file's start keys).
std::vector<StartValues> candidate_starts(const CandidateSpec& c, const Estimates& current, std::size_t n_runs);
// The best usable fit of one candidate over its starts (diagnose.cpp): `fit` from each start;
// a fit is usable when its error is finite, its information matrix is not rank deficient and
// the runtime accepts its model; the usable fit of lowest error is kept (status fitted).
// Otherwise the status is the last rank-deficient (not_identifiable) or runtime-refused
// (refused_by_runtime) start's, fit_failed when none got that far; `message` the last failure's.
struct CandidateFit {
  FitResult fit;
  CandidateStatus status = CandidateStatus::fit_failed;
  std::string message;
};
using StartFit = std::function<FitResult(const StartValues&)>;
CandidateFit best_usable_fit(const std::vector<StartValues>& starts, const StartFit& fit);
// The options of each fit diagnose runs (Diagnoser::fit_with): o.fit with the stall start
// search `search`, the start values sv (by contract name) and, for the stall start grid inside
// the fit (FitOptions::threads), DiagnoseOptions::threads whatever o.fit.threads says. Why the
// threads: the grid of a fit with stall
// families (the configured model's, or a candidate's retry: stall_grid_retry_needed) is most
// of a diagnose's time, and on one thread it ran alone while the other idled: the simulated
// dynamic-stall C_L of bench/diagnose-cv.sh kept 1.33 of 2 cores busy on average (a sampled
// timeline, 2.3 s of its 4.3 s on one core) and took 3.77 s; with the grid on both, 1.75
// cores and 3.15 s. Where diagnose's own candidates or folds already run in parallel the
// grids nest (up to threads^2 threads, time-shared); the results do not depend on it (each
// start is fitted alone: parallel_for).
FitOptions diagnose_fit_options(const DiagnoseOptions& o, StallStartSearch search, const StartValues& sv);
// Whether a stall family's candidate (separation_lag, vortex_shedding) fitted from its
// configured starts (`search` == configured) is fitted again from the start grid: when its best
// fit is not below the base's error, which a candidate that nests the base reaches only at a
// local minimum (or when no start gave a usable fit). Diagnoser::evaluate; docs/diagnose.md.
bool stall_grid_retry_needed(Effect effect, const CandidateFit& best, const FitResult& base, StallStartSearch search);
// The value of parameter `id` in a fit, or `fallback`.
double estimate_of(const FitResult& r, const ParamId& id, double fallback);

std::size_t total_samples(const Experiment& e);

// The step of a round among its families (diagnose.cpp): the lowest delta_bic; families within
// o.indistinguishable_bic of it go to `tied`, and among them the step is the one with the fewest
// added parameters, then the lower delta_bic, then the registry's (the enum's) order. -1 when
// `fr` is empty.
int choose_family(const std::vector<FamilyResult>& fr, const DiagnoseOptions& o, std::vector<Effect>& tied);

// ---- leave-one-run-out (diagnose_crossval.cpp) --------------------------------------------
// Per-run held-out mean square errors of one model: for every run r the model is fitted to the
// other runs (started from `start`, its full fit; run r's initial states dropped, the others
// renumbered) and the runtime predicts run r (periodic: its periodic steady state; otherwise
// from a least-squares lag-1 initial state). ok = false when some fold cannot be scored (its
// fit failed or is rank deficient -- a term the other runs do not determine -- or the runtime
// refuses it); `message` says which and why.
// The folds (fold_plan): unit run, runs dealt by their order (run r into fold r mod K, K =
// min(runs, max_folds)); unit group, whole groups (group g, in order of first appearance, into
// fold g mod K, K = min(groups, max_folds)): an InputError when a run has no group or there is
// only one.
struct FoldPlan {
  int folds = 0;
  std::vector<int> fold_of_run;      // each run's fold, 0-based
  CrossValidationUnit unit = CrossValidationUnit::run;
  std::vector<std::string> groups;  // unit group: the groups, in order of first appearance
};
FoldPlan fold_plan(const Experiment& e, int max_folds, CrossValidationUnit unit);

struct HeldOut {
  std::vector<double> mse;  // per run, over its scored samples
  std::vector<double> scored_fraction;  // per run: the share of its samples scored (1: all)
  int folds = 0;            // the number of folds (folds == runs or 0: one run each)
  std::vector<int> fold_of_run;  // each run's fold (empty: run r in fold r mod folds)
  double fit_error = std::numeric_limits<double>::quiet_NaN();  // the model's fit to ALL runs, s(v)
  bool ok = false;
  std::string message;
};
using FoldFit = std::function<FitResult(const Experiment&, const ModelConfig&, const StartValues&)>;
HeldOut held_out_errors(const Experiment& w, const ModelConfig& m, const Estimates& start, int threads,
                        int max_folds, const FoldFit& fit, CrossValidationUnit unit = CrossValidationUnit::run);
// The paired comparison (HeldOutTest in diagnose.hpp): d_r = ln(mse_with_r / mse_without_r);
// enters when mean d + SE(d) < 0, mean d < ln(1 - min_gain), it improves more than half of
// the runs (majority_improved) and the fits to every run differ by ln(MSE ratio) < ln(1 -
// min_in_sample_gain) (when both fit errors are known).
bool majority_improved(int improved, int runs);
// The held-out gain a term must reach with `folds` folds: min_gain for three folds or fewer,
// min_gain 3 / folds beyond (diagnose_crossval.cpp: the selection leak shrinks as 1 / folds).
inline constexpr int kMinGainFolds = 3;
double min_gain_for_folds(double min_gain, int folds);
// A left-out run is scored on its samples inside the angle range of the runs its fold fitted
// (widened by a tenth of its width at each end) when at least this many of its `samples` are
// (a quarter, and 8), on all of them otherwise.
std::size_t min_scored_samples(std::size_t samples);
// Which samples of `run` its held-out error is taken over (1: scored), given the model angle's
// axis and offset and the fold's angle range `fitted` (diagnose_crossval.cpp).
std::vector<char> scored_samples(const Run& run, Axis axis, double alpha0_rad, const AngleRange& fitted);
HeldOutTest held_out_test(Effect effect, const std::string& terms, const char* stage, const HeldOut& without,
                          const HeldOut& with, double min_gain, double min_in_sample_gain);

// Effects that are the same model as `e` on ANY data, given the model `m` it extends (bias and
// a constant static offset when b1 is constant); named with it in the step.
std::vector<Effect> structural_look_alikes(Effect e, const ModelConfig& m);

}  // namespace indicial::diagnose_detail
