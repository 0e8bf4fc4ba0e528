// indicial/fitter/diagnose.hpp -- the missing-effect workflow (`indicial diagnose`).
//
// What it is for
// --------------
// diagnose_experiment() fits the configured model (ML output error, fit.hpp), looks at what
// the residuals still hold, and names the effect the model lacks, with statistics:
//
//   1. Fit the configured model; residuals per run; the noise level from the residuals'
//      short-lag structure (estimate_noise_level, noise_level.hpp: an AR(1) noise model fitted to the
//      first and second differences of the residual, which the noise passes and the smooth,
//      low-frequency model error of a tunnel motion does not).
//   2. Every candidate of the vocabulary (interface.md) is a concrete extension of the model
//      in shared/ (so the runtime evaluates it too), fitted by fit_experiment with the current
//      estimates as start values:
//        b1_alpha      a b1(x) plus-function term (x - k)_+ at a knot k of a scan grid inside
//                      the data's angle range, or b1's next power
//        a_alpha       an a(x) knot term (x - k)_+^2 from the same scan, or a(x)'s next power
//        rotary_alpha  a C_aq(x) term x^i or (x - k)_+ added to the a priori C_aq and
//                      estimated jointly (the joint-ML refinement of the two-stage step)
//        bias          the state-equation constant con
//        time_delay    a pure delay of the unsteady forcing, x_f = x(t - delay), estimated by
//                      ML with its sensitivity through indicial::delayed_angle (two starts)
//        second_lag    a second lag state b2, c2 (three starts of b2)
//        static_error  an angle-only correction dC_a(x): x^i (i >= 1) or (x - k)_+^2
//                      (no x^0: a constant offset equals con / b1 when b1 is constant, so it
//                      is tested, and named, as `bias`)
//   3. Score: the likelihood-ratio statistic LR = N ln(s0^2 / s1^2) (Gaussian residuals of
//      unknown variance, N samples; s = s(v) of the base and the extended fit) divided by
//      kappa = (1 + r1) / (1 - r1), r1 the lag-1 autocorrelation of the extended fit's
//      residuals (colored residuals inflate LR by about kappa), against chi^2(dp), dp = the
//      number of added ML parameters (Boost.Math); Delta BIC = -LR / kappa + dp ln(N / kappa).
//      Multiplicity (Bonferroni): a first term counts only if p < alpha / M, M = every
//      candidate model of the round (each scanned knot position counted, and 4 refinement
//      positions per knot effect), AND Delta BIC < 0.
//   4. Families, not single terms: every effect with a significant first term is grown into
//      its best sub-model (stepwise inside the effect: further knots/powers of the same kind
//      while each passes alpha / its scan and lowers BIC, up to max_family_terms); the
//      sub-models are compared by BIC (one common N_eff) and the lowest is added as ONE step
//      (several terms possible). Sub-models within indistinguishable_bic of it are named with
//      it (DiagnoseStep::indistinguishable), the simplest is the step (fewest parameters,
//      then the lower BIC, then the registry's order).
//   5. Repeat until nothing is significant or max_steps; at max_steps one more round is tested
//      and DiagnoseResult::stopped says whether an effect was still significant. The verdict
//      is the first step's effect ("none" without steps: the model is left as configured).
//      Final estimates whose bound exceeds their value are listed (ill_conditioned).
//
// Usage
// -----
//   indicial::Experiment e = indicial::load_experiment("experiment.toml");
//   indicial::DiagnoseOptions o;                                   // alpha = 0.01
//   indicial::DiagnoseResult d = indicial::diagnose_experiment(e, o);
//   std::puts(d.verdict.c_str());                                  // "time_delay", "none", ...
//   indicial::write_diagnose_outputs(d, e, o, "out", indicial::Overwrite::refuse);
//
// Warnings
// --------
// 1. A knot scan's position is a parameter that does not exist under the null hypothesis
//    (Davies' problem): the chi^2 p-value of one position is not the p-value of the best of
//    many; the Bonferroni count over every scanned position is what keeps the false-positive
//    rate at or below alpha per round (measured: tests/test_diagnose_null.cpp).
// 2. LR assumes white Gaussian residuals; the kappa correction is exact for AR(1) noise and
//    approximates other spectra by their lag-1 correlation. The noise estimate assumes AR(1)
//    noise: its marginal level has a sampling error of about 12 % at phi = 0.8 (2100
//    samples), and a noise smoother than the sample step (e.g. a low pass at a few Hz) is
//    indistinguishable from model error there (phi at its 0.98 clamp: the level is uncertain).
// 3. Names can be ambiguous where the model cannot tell effects apart on the data (e.g. bias
//    and a constant static offset with constant b1); such effects are named together with the
//    experiment that separates them (EffectDescription::separated_by).
// 4. When rotary.estimate = true, the two-stage fit's C_aq is frozen as the a priori C_aq for
//    the diagnosis (its power terms; knot terms are kept as estimated correction terms).
#pragma once

#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "indicial/fitter/experiment.hpp"
#include "indicial/fitter/fit.hpp"
#include "indicial/fitter/noise_level.hpp"
#include "indicial/fitter/output.hpp"
#include "indicial/fitter/replication.hpp"
#include "indicial/fitter/report.hpp"

namespace indicial {

// The effects diagnose can name. Each has ONE entry in the registry (fitter/src/diagnose/
// diagnose_effects.cpp: name, description, how it is written to the model, its residual
// signature, the experiment that separates it, its candidate generator); the count, --help
// list and report descriptions come from there. The dynamic-stall effects come last, from
// separation_lag on (EffectDescription::extends says which those are).
enum class Effect { b1_alpha, a_alpha, rotary_alpha, bias, time_delay, second_lag, static_error,
                    separation_lag, vortex_shedding, slow_reattachment, pressure_lag, static_hysteresis,
                    lag_limit };
inline constexpr int effect_count = 13;  // the registry checks it has exactly this many entries

// How far diagnose fits on the models its rounds compare against (the configured model, the
// model after each step) when their fit ends at the iteration limit: from their own estimates,
// up to this many times FitOptions::max_iterations in all (diagnose.cpp, Diagnoser::converged,
// says why). A model still at the limit then is listed in DiagnoseResult::unconverged_models.
inline constexpr int model_iteration_factor = 4;

// The part of the model an effect extends (EffectDescription::extends).
enum class EffectExtends {
  report_model,    // the report's model: its splines, lags, delay, bias, static curve
  stall_families   // model.hpp's separation and vortex families: offered only where a lift polar
                   // runs through stall (slow_reattachment, pressure_lag, static_hysteresis and lag_limit: on a model that has
                   // the families already)
};

struct EffectDescription {
  Effect effect = Effect::bias;
  EffectExtends extends = EffectExtends::report_model;
  const char* name = "";          // the contract's name: "b1_alpha", ...
  const char* description = "";   // the disagreement it explains
  const char* written_as = "";    // how it is written to the model (coefficient-file keys)
  const char* signature = "";     // what it looks like in the residuals
  const char* separated_by = "";  // the experiment that separates it from its look-alikes
};
const std::vector<EffectDescription>& effect_descriptions();  // one per Effect, enum order
const char* effect_name(Effect e);
std::string effect_names_list();  // "b1_alpha, a_alpha, ...", for --help and messages

// Which rule decides whether an effect (or a family's next term) enters (issue 21, item 2).
enum class DecisionRule {
  leave_one_run_out,     // >= cv_min_runs runs: it must lower the error of runs left out of its
                         // fit (paired over runs, one-standard-error rule; docs/diagnose.md)
  lr_replication_noise,  // too few runs, replication: LR / kappa, kappa from the replicates'
                         // lag-1 correlation (the noise's own, never the residual's)
  lr_residual            // too few runs, no replication: LR / kappa with kappa from the
                         // candidate's residual (the rule before issue 21; a structured model
                         // error can read as colored noise -- said in the outputs)
};
const char* decision_rule_name(DecisionRule r);  // "leave_one_run_out", ...
// What the leave-one-run-out rule leaves out of a fold (DiagnoseOptions::cv_unit, `--cv-unit`):
// runs (the default; dealt into folds by their order), or whole groups of runs (Run::group, the
// `runs` entries' `group` key: a tunnel entry, campaign or session; every run must have one and
// there must be at least two groups). Why groups: runs of one entry share its offsets (a
// balance's zero, the model's installation), so a term can lower the error of a left-out run of
// the same entry and still not carry to another. Why not the default: with few groups the test
// is coarse (two folds: the full --min-gain, a standard error from two values); measured on the
// development set (docs/validation-stall.md: 104 fit cycles of two campaigns, a third held out)
// leaving out whole campaigns chose fewer effects for C_L and predicted the third campaign
// worse than ten folds of runs (0.76x against 0.70x the Beddoes-Leishman peer's RMS; C_m 0.73x
// both).
enum class CrossValidationUnit { run, group };
inline const char* cross_validation_unit_name(CrossValidationUnit u) { return u == CrossValidationUnit::group ? "group" : "run"; }

enum class RuleChoice { automatic, leave_one_run_out, likelihood_ratio };

struct DiagnoseOptions {
  double alpha = 0.01;               // family-wise significance level per round
  RuleChoice rule = RuleChoice::automatic;  // automatic: leave_one_run_out with >= cv_min_runs runs
  int cv_min_runs = 3;               // runs needed for the leave-one-run-out rule
  double cv_min_gain = 0.10;         // a term must lower the held-out mean square error by at least
                                     // this fraction (and by one standard error, on more than half
                                     // of the runs: docs/diagnose.md)
  double cv_min_in_sample_gain = 0.04;  // and, fitted to every run, lower the mean square error by
                                     // at least this fraction: the materiality floor that keeps a
                                     // chance held-out gain of three runs out (in [0, 1); 0: off;
                                     // docs/diagnose.md, "Which rule decides")
  CrossValidationUnit cv_unit = CrossValidationUnit::run;  // what a fold leaves out: runs, or
                                     // whole groups of runs (Run::group; every run must have one)
  int cv_max_folds = 10;             // more runs (or groups, cv_unit group) than this: dealt into
                                     // this many folds (run r into fold r mod cv_max_folds; group g,
                                     // in order of first appearance, into fold g mod cv_max_folds),
                                     // each fold left out at once
  int threads = 2;                   // fits run in parallel (candidates of a scan, held-out
                                     // folds, and each fit's stall start grid: fit.threads is
                                     // replaced by this in every fit diagnose runs)
  int max_steps = 6;                 // effects added at most
  double knot_spacing_deg = 5.0;     // scan grid of knot positions (model angle x)
  double knot_margin_fraction = 0.1; // the grid stays this fraction of the range inside it
  int max_scan_knots = 16;           // the spacing widens when the range needs more
  int max_family_terms = 4;          // terms one effect's sub-model may have (stepwise inside it)
  double indistinguishable_bic = 6.0;  // families closer than this in BIC are named together
  FitOptions fit = fit_defaults();   // for every fit (start_values are set per candidate)

  // FitOptions' defaults with stall_start_search = configured: a stall candidate's own start is
  // fitted once, not from the fit's grid of 18 starts. Measured on docs/validation-real.md's
  // three-run studies, both on the same loaded machine: with the grid the four diagnoses took
  // 21-81 s (496 s the study), without 2-18 s (166 s; unloaded 0.3-2.5 s, a three-cycle
  // diagnosis should take seconds), and with it the choices predicted the held-out cycles no better
  // (sweep C_L: the grid's better in-sample separation fit displaced the vortex, held-out
  // median 0.55 -> 0.71 of quasi-steady). `--stall-start-search grid` (fit.stall_start_search)
  // turns it on, e.g. with many runs (docs/validation-stall.md). The configured model, when it
  // has the families, is fitted from the grid regardless (diagnose_experiment: one fit, as
  // `indicial fit` fits it).
  static FitOptions fit_defaults() {
    FitOptions f;
    f.stall_start_search = StallStartSearch::configured;
    return f;
  }

  // Every range above in one place (Ceres' Solver::Options::IsValid): true, or false with
  // *error (when not null) set to one line naming the first bad option -- its field, its
  // command-line flag where it has one -- its range and the value found. diagnose_experiment
  // throws InputError with that line; `indicial diagnose` and Python's diagnose report it
  // before reading anything. `fit` last, by FitOptions::IsValid (its message, naming the field
  // without `indicial fit`'s flag: OptionNaming::field).
  bool IsValid(std::string* error) const;
};

// A candidate's prediction of runs left out of its fit, against the model without it: for
// every run r, both models are fitted to the other runs (warm start: their full fits) and
// predict run r with the runtime (periodic runs at their periodic steady state; others from a
// lag-1 initial state fitted to run r, the one number the fitter also estimates per run). It
// enters when mean_log_ratio + standard_error < 0, mean_log_ratio < ln(1 - cv_min_gain),
// runs_improved is more than half of the runs and in_sample_log_ratio < ln(1 -
// cv_min_in_sample_gain).
struct HeldOutTest {
  Effect effect = Effect::bias;
  std::string terms;                 // the terms with it (`; `-separated)
  std::string stage;                 // "first term", "next term"
  std::vector<double> rms_without;   // per run: held-out RMS of the model without it
  std::vector<double> rms_with;      // per run: held-out RMS with it
  double mean_log_ratio = 0.0;       // mean over folds of ln(MSE_with / MSE_without) (per run: one run per fold)
  double standard_error = 0.0;       // of that mean: sd / sqrt(folds), d taken per fold
  int folds = 0;                     // runs left out together (folds == runs: leave-one-run-out)
  double in_sample_log_ratio = 0.0;  // ln(MSE_with / MSE_without) of the fits to every run (NaN: not known)
  int runs_improved = 0;             // runs with a lower held-out error with it
  bool enters = false;
  std::string message;               // why it could not be tested (a fold fit failed, ...)
};

// One candidate model of one round.
enum class CandidateStatus {
  fitted,              // the extended model was fitted; statistic and p_value are valid
  fit_failed,          // fit_experiment threw (e.g. collinear terms) or did not converge
  not_identifiable,    // the extended fit's information matrix is rank deficient
  refused_by_runtime   // the fitted model fails validate_for_runtime (e.g. b(x) <= 0)
};
const char* candidate_status_name(CandidateStatus s);

struct CandidateScore {
  Effect effect = Effect::bias;
  std::string term;         // what was added, e.g. "B at 30.0 deg", "delay_s", "con"
  std::string detail;       // for reports: "knot 30.0 deg", "delay 0.061 s", ...
  CandidateStatus status = CandidateStatus::fitted;
  int added_parameters = 0; // dp
  double fit_error = 0.0;   // s(v) of the extended fit
  double statistic = 0.0;   // LR / kappa, kappa = correlation_factor: the test statistic, >= 0
  double raw_statistic = 0.0;  // LR = N ln(s0^2 / s1^2) as for white residuals
  double correlation_factor = 1.0;  // kappa = (1 + r1) / (1 - r1) of this fit's residuals, >= 1
  double p_value = 1.0;     // chi^2(dp) upper tail of LR
  double log10_p = 0.0;     // log10 p, finite even when p underflows (asymptotic tail)
  double delta_bic = 0.0;   // BIC(extended) - BIC(base) with N_eff = N / kappa
  std::string message;      // why it failed, when it did
};

// One effect's best sub-model in a round: its first term (the most significant of the scan),
// then terms of the same effect added while they pay for themselves (stepwise in the family).
struct FamilyResult {
  Effect effect = Effect::bias;
  std::vector<std::string> terms;   // in the order added
  std::string detail;               // the terms for reports
  int added_parameters = 0;
  double fit_error = 0.0;
  double delta_bic = 0.0;           // against the round's base, common N_eff (the comparison)
  double log10_p = 0.0;             // of the whole sub-model (LR / kappa, chi^2(dp))
  // leave_one_run_out: the whole sub-model's held-out test against the round's base
  bool has_held_out = false;
  HeldOutTest held_out;
};

// The residual's signatures (issue 13 item 2), shares of the residual sum of squares:
struct ResidualSignature {
  double angle_only = 0.0;   // explained by a function of the angle alone (2 deg bins, all runs
                             // and both stroke directions): a static error
  double hysteresis = 0.0;   // further explained by the stroke direction within each angle bin
                             // (up/down difference): an unsteady or delay error
  double rate_in_phase = 0.0;  // explained by a per-run multiple of the rate (rotary, delay)
  double constant = 0.0;     // explained by per-run constants (a bias: the same in every run)
  std::vector<double> run_hysteresis;  // per run: RMS of (upstroke - downstroke) / 2 per bin
  std::vector<double> run_rate_gain;   // per run: residual-on-rate regression coefficient
  std::vector<double> run_mean;        // per run: mean residual
  std::vector<double> run_rms_rate;    // per run: RMS rate (rad/s), to read growth with rate
};
ResidualSignature residual_signature(const std::vector<RunSeries>& runs);

struct DiagnoseStep {
  int step = 0;                        // 1-based
  Effect effect = Effect::bias;
  std::string detail;
  std::string term;                    // the terms added (one or several of the same effect)
  std::vector<Effect> indistinguishable;  // other effects the data cannot tell from this one
  double correlation_factor = 1.0;     // kappa of the new fit's residuals
  double statistic = 0.0;
  double p_value = 1.0;
  double log10_p = 0.0;
  double threshold = 0.0;              // alpha / candidates_tested
  int candidates_tested = 0;           // M of the round (knot positions counted)
  int added_parameters = 0;
  double delta_bic = 0.0;
  double fit_error_before = 0.0;
  double fit_error_after = 0.0;
  std::vector<double> run_rms_before;  // per run RMS residual
  std::vector<double> run_rms_after;
  DecisionRule rule = DecisionRule::lr_residual;  // the rule that decided this step
  std::vector<double> held_out_rms_before;  // leave_one_run_out: per run, held-out RMS
  std::vector<double> held_out_rms_after;
  double held_out_log_ratio = 0.0;          // mean ln(MSE after / MSE before) over runs
  double held_out_standard_error = 0.0;
};

// A round: every candidate tested against the model of that round.
struct DiagnoseRound {
  int round = 0;                       // 1-based; round k decides step k
  double base_fit_error = 0.0;
  int candidates_tested = 0;
  double threshold = 0.0;
  std::vector<CandidateScore> candidates;
  int best = -1;                       // index into candidates of the smallest p (fitted)
  bool added = false;                  // whether a family became a step
  std::vector<FamilyResult> families;  // each significant effect's best sub-model
  int winner = -1;                     // index into families of the step's effect
  ResidualSignature signature;         // of the round's base residuals
  bool check_only = false;             // the round after max_steps: tested, nothing added
  DecisionRule rule = DecisionRule::lr_residual;
  std::vector<double> held_out_base_rms;  // leave_one_run_out: the base's held-out RMS per run
  // leave_one_run_out: per run, the share of its samples its held-out errors are taken over: the
  // samples inside the angle range of the runs its fold fitted, widened by a tenth of its width
  // at each end; 1 when that is all of them, or when too few are inside and all are scored
  // (diagnose_crossval.cpp, scored_samples). The same for every candidate of the round.
  std::vector<double> held_out_scored_fraction;
  std::vector<HeldOutTest> held_out;   // every held-out test of the round (first and next terms)
  std::string rule_note;               // leave_one_run_out could not run (why; the LR rule decided)
};

// Why the procedure stopped.
enum class DiagnoseStop {
  nothing_significant,  // the last round found no significant candidate
  max_steps             // DiagnoseOptions::max_steps effects added and one still significant
};
const char* diagnose_stop_name(DiagnoseStop s);  // "nothing_significant", "max_steps"

struct DiagnoseResult {
  DiagnoseStop stopped = DiagnoseStop::nothing_significant;
  double initial_fit_error = 0.0;
  NoiseEstimate noise;                 // from the INITIAL fit's residuals (differences; see
                                       // replication for the noise from replicates)
  ReplicationNoise replication;        // the noise from replication (source none: unknown)
  DecisionRule rule = DecisionRule::lr_residual;  // the rule of the rounds (a round whose held-out
                                       // test could not run says so in its rule_note)
  std::string rule_reason;             // one line: why this rule
  int cv_folds = 0;                    // leave_one_run_out: folds (== runs: one run each); else 0
  CrossValidationUnit cv_unit = CrossValidationUnit::run;  // leave_one_run_out: what a fold leaves out
  std::vector<std::string> cv_groups;  // cv_unit group: the groups, in order of first appearance
  NoiseEstimate final_noise;           // from the final fit's residuals
  std::vector<DiagnoseStep> steps;
  std::vector<DiagnoseRound> rounds;
  double final_fit_error = 0.0;
  std::string verdict = "none";
  std::vector<std::string> effects_added;
  std::vector<FitResult> fits;         // fits[0] the configured model, fits[k] after step k
  std::vector<ModelConfig> configs;    // the model configuration of each fit
  Experiment experiment;               // the working experiment (rotary frozen, warning 4)
  double alpha = 0.01;
  double elapsed_s = 0.0;
  int fits_run = 0;                    // fit_experiment calls
  std::string still_significant;       // stopped == max_steps: the effect still significant
  std::vector<std::string> ill_conditioned;  // final parameters whose bound exceeds |value|
  // The models the rounds compared against whose fit still ended at the iteration limit after
  // being fitted on from their estimates (model_iteration_factor times FitOptions::max_iterations
  // in all): 0 the configured model, k the model after step k. Empty: every one converged.
  std::vector<int> unconverged_models;
};

// The whole workflow (see the essay). Throws InputError for bad input (as fit_experiment).
DiagnoseResult diagnose_experiment(const Experiment& e, const DiagnoseOptions& o);

// diagnosis.json: the contract fields (initial_fit_error, noise_estimate, steps with effect,
// detail, statistic, p_value, fit_error_before, fit_error_after; final_fit_error, verdict),
// extended with effects_added, per-step p threshold, dp, Delta BIC, per-run RMS, the rounds'
// candidate tables, the final model's parameters and the runtime check.
nlohmann::json diagnosis_json(const DiagnoseResult& d, const Experiment& e,
                              const DiagnoseOptions& o, const RuntimeCheck* runtime);

// One step as `indicial diagnose` prints it on stdout: the effect, its detail, what decided
// it (held-out mean ln(MSE ratio) +- its standard error, or LR / kappa against the
// threshold), the fit error before and after, and every effect the data cannot tell from it,
// by name.
std::string diagnose_step_line(const DiagnoseStep& s);

// One-line warnings about the result (diagnosis.json "warnings", stderr): stopped at max_steps
// with an effect still significant; ill-conditioned final estimates.
std::vector<std::string> diagnose_warnings(const DiagnoseResult& d);

struct DiagnoseOutputs {
  std::filesystem::path dir;
  std::string diagnosis_json;
  std::string experiment_toml;         // the diagnosed experiment (diagnosed_experiment_toml)
  std::string model_coef;
  std::string report_md;
  PlotStatus plots = PlotStatus::not_requested;
  std::string plot_message;
  std::vector<std::string> images;     // relative to dir
  RuntimeCheck runtime;
};

// The experiment file of the diagnosed model: the working experiment (warning 4) with the
// final model configuration (extension keys of docs/formats.md: static_correction_*,
// rotary_correction_*, delay, further_lag_start), its runs and static table by absolute path,
// the run files' [columns] and [csv] from the experiment's path when that is a regular file
// (the defaults otherwise; a file that is not an experiment file: a warning on stderr), and the
// delay's start value at the diagnosed estimate. `indicial fit` on it refits the
// diagnosed model.
std::string diagnosed_experiment_toml(const DiagnoseResult& d);

// Writes DIR/diagnosis.json, DIR/model.coef (the final model, by the runtime's writer, replayed
// by the runtime), DIR/experiment.toml (diagnosed_experiment_toml), DIR/report.md and DIR/plots/
// through OutputDir (whole or nothing; a
// non-empty DIR only with Overwrite::replace). gnuplot problems are reported, not thrown.
DiagnoseOutputs write_diagnose_outputs(const DiagnoseResult& d, const Experiment& e,
                                       const DiagnoseOptions& o, const std::filesystem::path& dir,
                                       Overwrite overwrite, const ReportOptions& ro = {});

}  // namespace indicial
