// indicial/fitter/fit.hpp -- the identification procedure of Klein & Murphy, as a library.
//
// What it is for
// --------------
// fit_experiment() turns an Experiment (tunnel runs + the static curve + the a priori rotary
// term + the model's term pool, see experiment.hpp) into an identified model and everything a
// report needs to judge it. It follows the report's "Model Identification" section and its
// Figure 1:
//
//   1. y_E by eq. 12 for every run: y_E = C - C_a(x) - (l/V) C_aq(x) rate, x the model angle.
//   2. Equation error (eq. 22): least squares of y_E' on -x^i y_E, -(x-k)_+ y_E, -x^i x',
//      -(x-k)_+^2 x' and 1 (con), solved by SVD with a relative singular-value cut-off; white and
//      colored-residual covariances. With structure = "stepwise" the configured terms are a
//      candidate pool and stepwise regression (partial F to enter / remove, stop at the minimum
//      predicted squared error) picks the structure. Every stepwise F is corrected for colored
//      residuals by default (StepwiseSignificance); when the regression selects nothing or its
//      R^2 is below fallback_r_squared, the output-error stepwise of step 3 picks the structure
//      instead (StepwiseFallback; FitResult::stepwise_fallback says why).
//   3. Maximum-likelihood output error (eqs. 23-24) started from the equation-error estimates:
//      unknowns are the a(x), b1(x), con (and further-lag) coefficients and one initial state
//      per run (periodic runs: the periodic steady state, no parameter); the state is propagated
//      with indicial::advance_lags -- the runtime's own update -- and the Gauss-Newton /
//      Levenberg-Marquardt iteration uses exact sensitivities from Eigen's forward AutoDiff
//      through that same template. Cramer-Rao bounds, white and colored-residual corrected.
//      With FitOptions::stepwise_refinement = output_error a stepwise structure is then refined
//      on the ML fit: pool terms enter by the output error's partial F and leave by Wald F
//      (fit_stepwise_output_error.cpp; docs/validation.md measures why: the regression's
//      collinear a(x) columns).
//   4. When rotary.estimate = true, the two-stage loop (eqs. 25-26): stepwise regression of
//      z = C - C_a(x) - y_model on the C_aq(x) candidates, y_E recomputed with the new C_aq, ML
//      re-run from the previous estimates; repeated until the ML cost stops improving.
//
// Usage
// -----
//   indicial::Experiment e = indicial::load_experiment("experiment.toml");   // io.hpp
//   indicial::FitOptions o;                                                  // documented defaults
//   indicial::FitResult r = indicial::fit_experiment(e, o);
//   for (const auto& p : r.parameters) fmt::print("{} {} ({})\n", p.name, p.value, p.cr_bound);
//   // r.model is a ModelSet ready for write_coef_file (runtime/include/indicial/coef_file.hpp).
//
// Parameter names (docs/formats.md, fit.json): a{i} for a(x)'s x^i term, A{j} for its
// knot terms (j from 1, knots ascending), b1_{i} and B{j} for b1(x), con, Caq_{i} for the
// estimated rotary polynomial and CaqK{j} for its knot terms, y0_{r} for run r's initial state
// (r from 1, lag 1), y0_{r}_{k} for lag k >= 2, b{k}_{i}, B{k}_{j} and c{k} for lag k >= 2; with the
// diagnose extensions of ModelConfig (experiment.hpp): dCa_{i} / dCaK{j} for static-correction
// terms, Caq_{i} / CaqK{j} for rotary-correction terms, delay_s for an estimated delay; the
// dynamic-stall families (model.stall): T1, T2, f0c_{i}, f0cK{j}, k0, k1, k2, CN1, Tv, Tvl, cv, xv.
//
// Warnings
// --------
// 1. Angles are radians everywhere in these structures (knots included); the names say _rad.
// 2. Bad input throws indicial::InputError naming the experiment file (or run) and the problem:
//    fewer samples than parameters, a regressor column that is zero or linearly dependent on the
//    others (the term is named), a model that cannot be propagated. An ML divergence or an
//    iteration limit is NOT an exception: OutputErrorSummary::termination says so and the best
//    estimate found is kept.
// 3. A parameter the information matrix cannot determine (its direction lies in the numerical
//    null space) is marked Identifiability::not_identifiable and its bounds are NaN -- never a
//    huge number; OutputErrorSummary::unidentifiable names them and termination is
//    rank_deficient.
// 4. The discrete update is second order in dt; at dt = 0.01 s its bias is small but not zero
//    (docs/validation.md measures it against the Cramer-Rao bounds). The fitter does not correct
//    it: the runtime uses the same update, so the fitted model is the best model FOR the runtime.
// 5. Every run must share the experiment's airspeed (time_scale = 1 in the fit).
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "indicial/fitter/experiment.hpp"
#include "indicial/model.hpp"

namespace indicial {

// How the equation-error step obtains the state derivative y_E'.
enum class StateDerivative {
  smoothed_difference,  // Savitzky-Golay derivative of y_E (local polynomial, exact end points)
  modulating_function   // report ref. 12: integrate against functions vanishing at window ends
};

// How the two-stage loop's ML step treats the C_aq(x) terms the stepwise regression picked.
enum class RotaryRefinement {
  // The regression of eq. 26 picks the terms and their start values; the ML step then
  // estimates them jointly with a(x), b1(x) and y0 (the output is y + (l/V) C_aq(x) rate).
  // The loop reaches the ML cost minimum the report's Figure 1 iterates towards in one or two
  // iterations, and the bounds come from the full information matrix (they account for the
  // correlation between C_aq and a(x)).
  joint_ml,
  // The report's literal alternation: C_aq fixed at the regression's estimate, ML on a(x),
  // b1(x) and y0 only; bounds on C_aq are the regression's (conditional on the ML states).
  // Converges linearly (about 0.6 per iteration on Example 1), so 5 iterations may stop short.
  regression_only
};

// Which colored-residual lag window the sandwich covariance uses.
enum class ColoredLagRule {
  automatic,  // lags up to the first one where the residual autocorrelation is insignificant
              // (|R(k)| < 2 R(0) / sqrt(N)), capped by max_correlation_lag
  fixed       // exactly max_correlation_lag lags
};

// How a stepwise structure (model.structure = "stepwise") is finished.
enum class StepwiseRefinement {
  none,          // the equation-error regression's selection (the report's procedure)
  output_error   // then entry / removal by the output-error fit (fit_stepwise_output_error.cpp):
                 // partial F of the ML fit to enter, Wald F to leave, same F_in / F_out
};

// How the stepwise F tests (equation-error and output-error, and the two-stage loop's C_aq
// regression) judge significance (docs/validation.md, "Stepwise under colored residuals").
enum class StepwiseSignificance {
  colored_residuals,  // a term's partial F is scaled by var_white / var_colored of its estimate
                      // (the sandwich covariance of the fit with the term in, lags chosen by
                      // colored_lag_rule): F_c = estimate^2 / colored variance. White residuals
                      // (no significant lag) leave F exactly as it was.
  white_residuals     // the textbook partial F (Klein & Morelli), which assumes white residuals
};

// Whether a stepwise fit whose equation-error regression explains little is finished by the
// output-error stepwise instead (docs/validation.md, "Output-error fallback").
enum class StepwiseFallback {
  automatic,  // when the regression selected no term, or its R^2 < fallback_r_squared: the
              // output-error stepwise (as StepwiseRefinement::output_error) runs, and
              // FitResult::stepwise_fallback says why
  off         // never: the regression's selection is kept (no term selected is an InputError)
};

// Where the output-error fit of the dynamic-stall families starts (docs/formats.md, fit.json's
// `stall_start_search`). Why a search: that fit is multimodal in the time constants. The
// vortex's shedding threshold switches its lift on and off, so from a start whose vortex
// misses the data the cost is flat in T_v and T_vl, and the fit converges where it began.
// Measured on the Glasgow C_m fit cycles of tools/validate_stall.py (the extended model with a
// constant C_mq): from the 18 starts of the grid below the fit ended at s(v) between 0.031 and
// 0.088, from the configured start alone at 0.068; tests/test_fit_stall_recovery.cpp has a synthetic
// truth the configured start misses (8.9 sigma) and the grid reaches (0.99 sigma).
enum class StallStartSearch {
  grid,       // the configured starts and 17 more: T1 x {1/2, 1, 2}, T_v x {1/2, 1, 2},
              // T2 x {1/3, 1} (with the separation family alone: T1 and T2, 6 starts); a
              // parameter held (model.stall_known) is not varied; the lowest cost is kept.
              // Not run when FitOptions::start_values names a stall parameter (the caller
              // chose the start: diagnose's warm starts and held-out folds).
  configured  // the configured starts only (the experiment's stall_*_start keys)
};

// A priori information on the dynamic-stall parameters in the output-error fit (docs/formats.md,
// "A priori values of the dynamic-stall parameters"). Why: a family the data do not excite
// (cycles that never stall, a vortex that never sheds) leaves its parameters undetermined; the
// fit then moved them anywhere (a vortex output gain c_v = 768 on C_m cycles of -5 to 11 deg)
// and the model predicted stall cycles elsewhere at 10-70 times the quasi-steady error. With a
// weak prior such a parameter stays near its Beddoes-Leishman value and its bound says the data
// did not determine it; a parameter the data determine moves by a small part of its bound.
enum class StallPrior {
  beddoes_leishman,  // each estimated stall parameter (not the f0 correction) gets a Gaussian
                     // prior at its default start (Beddoes-Leishman's NACA 0012 constants, the
                     // polar's C_N1; the experiment's stall_*_start keys move it) with the
                     // spreads of docs/formats.md, weighted as if the data's noise were a tenth
                     // of the quasi-steady model's RMS error, or the fit's own s(v) when it
                     // ends below that (maximum a posteriori; never stronger than the stated
                     // spreads at the fit's residual level)
  none               // maximum likelihood alone (the fit before 2026-11-30)
};

// One step of the output-error refinement.
struct OutputErrorStepwiseStep {
  enum class Action { entered, removed };
  Action action = Action::entered;
  std::string term;
  double f = 0.0;           // partial F of the ML fit (entered) or Wald F (removed), as
                            // judged (colored-corrected unless StepwiseSignificance::white)
  double f_white = 0.0;     // the same with white residuals
  double sse_before = 0.0;  // sum of squared output errors before and after the step
  double sse_after = 0.0;
};
struct OutputErrorStepwiseResult {
  std::vector<OutputErrorStepwiseStep> steps;  // empty: the regression's selection was kept
  std::vector<std::string> selected;           // the final a(x), b1(x), con terms, named as in
                                               // the pool (EquationErrorResult::stepwise)
};

// How FitOptions::IsValid names a bad option: its field and `indicial fit`'s flag ("f_to_enter
// (--f-to-enter)": the fit command, Python's fit), or its field alone (a caller without the
// fit's flags: DiagnoseOptions::IsValid, for the library, `indicial diagnose` and Python's
// diagnose, whose keyword is the field's name).
enum class OptionNaming { field_and_fit_flag, field };

struct FitOptions {
  // Singular values below sv_cutoff * (largest singular value) are treated as zero, in the
  // equation-error solve and in the information matrix (rank decision). Columns (regressors,
  // sensitivities) are scaled to unit norm first, so the test judges collinearity, not units.
  double sv_cutoff = 1e-8;
  // Stepwise regression thresholds (Klein & Morelli use F_in = F_out = 4 as defaults).
  double f_to_enter = 4.0;
  double f_to_remove = 4.0;
  StepwiseRefinement stepwise_refinement = StepwiseRefinement::none;
  StepwiseSignificance stepwise_significance = StepwiseSignificance::colored_residuals;
  StepwiseFallback stepwise_fallback = StepwiseFallback::automatic;
  // The equation-error R^2 below which a stepwise fit falls back to the output-error stepwise.
  // Measured: 0.96-0.99 on the simulator's tailless and F-16XL cases (tests/golden/), 0.69-0.80
  // on the dynamic-stall generator's cycles, 0.09-0.17 on the tunnel data of issue 12.
  double fallback_r_squared = 0.9;
  // Output error: Gauss-Newton / Levenberg-Marquardt iterations (accepted or rejected steps);
  // 0 (as Ceres' max_num_iterations): no step, the estimates and bounds at the start values.
  int max_iterations = 50;
  // Convergence: relative cost change below cost_tolerance AND every parameter change below
  // step_tolerance times its Cramer-Rao bound.
  double cost_tolerance = 1e-8;
  double step_tolerance = 1e-3;
  // Divergence: the LM damping grows above this without finding a lower cost, or the cost
  // becomes non-finite at the start point.
  double max_damping = 1e12;
  // Two-stage loop (rotary.estimate = true).
  int max_two_stage_iterations = 5;
  // The two-stage loop stops when an iteration lowers the ML cost by less than this fraction
  // (or raises it; then the previous iteration's estimates are kept).
  double two_stage_tolerance = 1e-3;
  RotaryRefinement rotary_refinement = RotaryRefinement::joint_ml;
  StateDerivative state_derivative = StateDerivative::smoothed_difference;
  // Savitzky-Golay derivative of y_E: window half-width (samples) and polynomial order.
  int derivative_half_window = 5;
  int derivative_order = 3;
  // Modulating functions (state_derivative = modulating_function): window length in samples
  // and shift between windows.
  int modulating_window = 101;
  int modulating_shift = 5;
  // Colored-residual covariance.
  ColoredLagRule colored_lag_rule = ColoredLagRule::automatic;
  int max_correlation_lag = 200;
  // Output-error start values that replace the equation-error ones, by parameter name
  // (e.g. {"b1_0", 3.0}, {"y0_2", 0.0}); names not in the model are an InputError.
  std::vector<std::pair<std::string, double>> start_values;
  StallStartSearch stall_start_search = StallStartSearch::grid;
  StallPrior stall_prior = StallPrior::beddoes_leishman;
  // Threads for independent fits inside one fit (the stall start grid); >= 1. (In diagnose
  // DiagnoseOptions::threads replaces it: diagnose.hpp.)
  int threads = 1;

  // Every range above in one place (Ceres' Solver::Options::IsValid, as
  // DiagnoseOptions::IsValid): true, or false with *error (when not null) set to one line
  // naming the first bad option -- its field and, with OptionNaming::field_and_fit_flag,
  // `indicial fit`'s flag where it has one (Python's keyword is the field's name) -- its range
  // and the value found, e.g. "f_to_remove (--f-to-remove): must be in (0, f_to_enter = 4]
  // (...), found 5". A caller without those flags (diagnose) asks for OptionNaming::field:
  // "f_to_remove: must be ...". fit_experiment and fit_equation_error throw InputError with
  // that line before they look at the experiment; `indicial fit` and Python's fit report it
  // before reading anything. Start-value names are checked by the fit (they need the model),
  // their values here.
  bool IsValid(std::string* error, OptionNaming naming = OptionNaming::field_and_fit_flag) const;
};

// Parameter identity ------------------------------------------------------------------------
// Every estimated parameter (and every internal term of the fitter) carries a ParamId: what it
// is, not what it is called. The contract's display name (a1, A2, b1_0, B1, con, Caq_2, CaqK1,
// dCa_1, dCaK1, b2_0, B2_1, c2, delay_s, y0_3, y0_3_2; see the essay above) is derived from it
// by parameter_name() only, and parse_parameter_name() is its one inverse, used only where a
// name enters from outside (a start value, a table row).
enum class ParamKind {
  a_power, a_knot,            // a(x): x^power, (x - knot_rad)_+^power
  b_power, b_knot,            // b_{lag+1}(x)
  con,                        // the constant of the first state equation
  gain,                       // c_{lag+1} of a further lag (lag >= 1)
  delay,                      // delay_s of the unsteady forcing
  rotary_power, rotary_knot,  // C_aq(x) terms (two-stage loop, or diagnose's correction)
  static_power, static_knot,  // dC_a(x) terms (diagnose's static correction)
  initial_state,              // y0 of lag `lag` in run `run`
  // Dynamic-stall families (model.hpp "Dynamic stall"; names in parentheses):
  stall_tau1, stall_tau2,     // T1, T2 in l / V (T1, T2)
  f0_power, f0_knot,          // the f0 correction spline's terms (f0c_{i}, f0cK{j})
  stall_cp,                   // k0, k1, k2 of h(f): `power` is the index (k0, k1, k2)
  shedding_threshold,         // C_N1 (CN1)
  vortex_decay, vortex_travel,  // T_v, T_vl in l / V (Tv, Tvl)
  vortex_lift, vortex_cp,     // c_v, x_v (cv, xv)
  stall_tau1_reattach,        // T1r in l / V: f's time constant while reattaching (T1r)
  stall_reattach_shift,       // dxr in rad: the static hysteresis of stall (dxr)
  stall_lag_limit             // D in rad: the limit of the forcing angle's lag (dxl)
};

// Where dxr starts when a model without the hysteresis is extended by it (the fit's nested
// trial, diagnose's static_hysteresis candidate): 1e-3 rad (0.06 deg), a band too narrow to
// move the fit error (dxr = 0 is that model, and the feasible set's edge, where a trial step to
// dxr < 0 is refused), yet dxr's sensitivity is there to follow.
inline constexpr double kHysteresisNestedStartRad = 1e-3;

// Where D starts when a model without the forcing lag's limit is extended by it (the fit's
// nested trial): 0.9 of its bound kMaxLagLimitRad (18 deg), near the model without the limit
// (D -> infinity; a lag of 5 deg is cut by 2.5 %, 10 deg by 9 %) yet inside the feasible set,
// so a trial step toward the bound is not refused at the first iteration.
inline constexpr double kLagLimitNestedStartRad = 0.9 * kMaxLagLimitRad;

struct ParamId {
  ParamKind kind = ParamKind::a_power;
  int lag = 0;            // 0-based lag: b_power, b_knot, gain, initial_state
  int power = 0;          // power kinds: x^power; knot kinds: the plus function's power
  int knot = 0;           // knot kinds: 0-based index among its spline's knots (ascending);
                          // the display number (A{knot+1}), NOT part of the identity
  double knot_rad = 0.0;  // knot kinds: where the knot is (part of the identity)
  int run = 0;            // initial_state: 0-based run of the experiment
};

// The id of a non-knot parameter (b2_0: {b_power, 1, 0}; c2: {gain, 1}; delay_s: {delay};
// T1: {stall_tau1}). Knot terms also need knot_rad; run-indexed ones (initial_state) the run.
inline ParamId param_id(ParamKind kind, int lag = 0, int power = 0) {
  ParamId id;
  id.kind = kind;
  id.lag = lag;
  id.power = power;
  return id;
}

// Identity: a knot term is the same term wherever it is numbered (adding a knot renumbers the
// names A1, A2, ... but not the terms). Comparable, ordered and hashable, so it can key maps.
bool same_parameter(const ParamId& x, const ParamId& y);
inline bool operator==(const ParamId& x, const ParamId& y) { return same_parameter(x, y); }
inline bool operator!=(const ParamId& x, const ParamId& y) { return !same_parameter(x, y); }
bool operator<(const ParamId& x, const ParamId& y);
struct ParamIdHash {
  std::size_t operator()(const ParamId& id) const;
};

// The contract name of a parameter (see the essay above).
std::string parameter_name(const ParamId& id);
// The inverse of parameter_name, for names from outside (start values, report tables): false
// for a string that is no parameter name. A knot's knot_rad is unknown from its name (NaN):
// the caller resolves it against its model (the knot with index `knot`).
bool parse_parameter_name(const std::string& name, ParamId* id);

enum class Identifiability {
  identified,        // the information matrix determines it; bounds are finite
  not_identifiable   // (a component of) its direction is in the null space; bounds are NaN
};

struct ParameterEstimate {
  ParamId id;
  std::string name;               // parameter_name(id), for output
  double value = 0.0;
  double cr_bound = 0.0;          // white-residual standard error (Cramer-Rao bound)
  double cr_bound_colored = 0.0;  // colored-residual (sandwich) standard error
  Identifiability identifiability = Identifiability::identified;
};

// An estimate the data barely determine: its Cramer-Rao bound exceeds its magnitude (a run's
// initial state excepted: a nuisance parameter that may well be ~0). fit warns about these and
// diagnose lists them, by this one rule.
inline bool bound_exceeds_value(const ParameterEstimate& p) {
  return p.id.kind != ParamKind::initial_state && p.identifiability == Identifiability::identified &&
         std::isfinite(p.cr_bound) && p.cr_bound > std::abs(p.value);
}

enum class StepwiseAction { entered, removed };

// One step of stepwise regression.
struct StepwiseStep {
  int step = 0;              // 1-based
  std::string term;          // parameter name the term carries (a1, A2, b1_0, con, Caq_2, ...)
  StepwiseAction action = StepwiseAction::entered;
  double partial_f = 0.0;    // partial F of the term at this step, as judged (with
                             // StepwiseSignificance::colored_residuals: corrected)
  double partial_f_white = 0.0;  // the textbook (white-residual) partial F
  double r_squared = 0.0;    // R^2 after the step
  double pse = 0.0;          // predicted squared error after the step
  int n_terms = 0;           // terms in the model after the step
};

// A stepwise selection: the log and the terms in the model at the minimum PSE.
struct StepwiseResult {
  std::vector<StepwiseStep> steps;
  std::vector<std::string> selected;  // in pool order
  double min_pse = 0.0;
  std::size_t n_samples = 0;
  double sigma_max_squared = 0.0;     // variance of the dependent variable about its mean
};

// The equation-error (least-squares) estimate of eq. 22.
struct EquationErrorResult {
  std::vector<ParameterEstimate> parameters;  // a, A, b1, B, con in that order
  double fit_error = 0.0;                     // s(e) = sqrt(sum e^2 / (N - p))
  double r_squared = 0.0;
  std::size_t n_samples = 0;
  int correlation_lag = 0;                    // lags used by the colored covariance
  StateDerivative state_derivative = StateDerivative::smoothed_difference;
  StepwiseResult stepwise;                    // empty steps when structure = fixed
};

enum class Termination {
  converged,        // both convergence tests passed, full-rank information matrix
  iteration_limit,  // max_iterations reached; the best estimate is kept
  diverged,         // no step reduced the cost (damping exceeded max_damping) before the
                    // convergence tests passed, or the start cost was not finite; best kept
  rank_deficient    // the information matrix is singular at the estimate; see unidentifiable
};

// The words of fit.json's and diagnosis.json's options (the command line's and Python's too).
inline const char* stall_start_search_name(StallStartSearch s) {
  return s == StallStartSearch::grid ? "grid" : "configured";
}
inline const char* stall_prior_name(StallPrior p) {
  return p == StallPrior::none ? "none" : "beddoes_leishman";
}

inline const char* termination_name(Termination t) {
  switch (t) {
    case Termination::converged: return "converged";
    case Termination::iteration_limit: return "iteration_limit";
    case Termination::diverged: return "diverged";
    case Termination::rank_deficient: return "rank_deficient";
  }
  return "?";
}

struct OutputErrorIteration {
  int iteration = 0;
  double cost = 0.0;       // J = 0.5 sum v^2 after the iteration
  double damping = 0.0;    // Levenberg-Marquardt lambda used for the accepted step
  double max_step_in_bounds = 0.0;  // max |d theta_i| / CR bound_i of the accepted step
};

// Whether the estimate sits on the boundary of the admissible models (the output-error
// solver's feasibility predicate rejected the steps tried from it), see
// fitter/src/numerics/levenberg_marquardt.hpp.
enum class FeasibilityBoundary { interior, active };

// Whether the output-error start could be propagated (its lags decay and its outputs are
// finite). not_propagated: nothing was estimated; the message names the start value that
// failed, and a front end says what to do (the command line: --start-value, a simpler start).
enum class StartOutcome { propagated, not_propagated };

struct OutputErrorSummary {
  Termination termination = Termination::converged;
  int iterations = 0;
  double cost = 0.0;              // J = 0.5 sum v^2 at the estimate
  double fit_error = 0.0;         // s(v) = sqrt(sum v^2 / N)
  std::size_t n_samples = 0;
  int n_parameters = 0;
  int rank = 0;                   // numerical rank of the information matrix
  int correlation_lag = 0;        // lags used by the colored bounds
  std::vector<std::string> unidentifiable;  // parameters in the null space (empty if full rank)
  std::vector<OutputErrorIteration> log;
  FeasibilityBoundary boundary = FeasibilityBoundary::interior;
  int infeasible_trials = 0;      // trial steps rejected as inadmissible models
  StartOutcome start = StartOutcome::propagated;
  std::string message;            // one line: what happened (for reports and the CLI)
};

struct TwoStageIteration {
  int iteration = 0;                          // 1-based
  double cost = 0.0;                          // ML cost after this iteration's ML
  double fit_error = 0.0;                     // s(v) after it
  std::vector<double> rotary;                 // C_aq polynomial coefficients of x^0..x^degree
  std::vector<double> rotary_knot_coef;       // C_aq knot terms (knots ascending)
  std::vector<ParameterEstimate> rotary_parameters;  // Caq_i / CaqK{j} selected, with bounds
  StepwiseResult stepwise;                    // the regression of z on the C_aq candidates
};

// Per-run series for plots and tables.
struct RunSeries {
  std::string path;
  std::vector<double> time_s;
  std::vector<double> x_rad;              // model angle
  std::vector<double> rate_radps;         // q, p or r
  std::vector<double> measured;           // measured coefficient
  std::vector<double> model;              // full model coefficient (static+rotary+states)
  std::vector<double> quasi_steady;       // static + rotary only
  std::vector<double> y_measured;         // y_E by eq. 12 with the final C_aq
  std::vector<double> y_model;            // sum of the lag states
  std::vector<double> residual;           // measured - model (= y_E - y_model)
  // With dynamic-stall families: y_model includes their output, and this is their state at
  // sample 0 (the periodic state of a periodic run), which the runtime replay starts from.
  StallState<double> stall_initial;
};

// Indices of a spline's coefficients in FitResult::parameters / covariance, for bands.
enum class ModelFunction { a, b1, rotary };

// The stall start grid's trials (StallStartSearch::grid): each start's varied values (by
// parameter name, in l / V) and the fit error it ended at (NaN: it could not be propagated).
// `origin` is empty for a grid point; with T1r estimated a trial starts from the symmetric
// model's best fit (the same grid without T1r), with dxr or D estimated from the best fit
// without it, and with a(x) or b1(x) of several terms the last from the constant-coefficient
// model's best fit (fit_two_stage.cpp), each saying so there.
struct StallStartTrial {
  std::vector<std::pair<std::string, double>> start;
  double fit_error = 0.0;
  std::string origin;
};
struct StallStartSearchResult {
  std::vector<StallStartTrial> trials;  // trials[0]: the configured start
  int chosen = -1;                      // the index of the kept fit; -1: no search
};

struct FitResult {
  ModelSet<double, FitCapacity> model;         // one coefficient; loadable by the runtime
  std::vector<ParameterEstimate> parameters;   // final estimates (ML), y0_r last
  Eigen::MatrixXd covariance;                  // white-residual covariance of `parameters`
                                               // (NaN rows/cols for unidentifiable ones)
  Eigen::MatrixXd covariance_colored;
  std::vector<RunSeries> runs;
  EquationErrorResult equation_error;          // the start values (first stage)
  OutputErrorSummary output_error;             // the final ML run
  std::vector<TwoStageIteration> two_stage;    // empty unless rotary.estimate
  OutputErrorStepwiseResult output_error_stepwise;  // with StepwiseRefinement::output_error
                                                    // or after a fallback
  std::string stepwise_fallback;               // why the output-error stepwise replaced the
                                               // regression's selection, and whether it began
                                               // from the simple start (the start values gave
                                               // a non-finite output); empty: neither
  StallStartSearchResult stall_start_search;  // empty unless the grid ran
  double fit_error = 0.0;                      // s(v) of the final model
  double elapsed_s = 0.0;                      // wall time of fit_experiment
};

// The whole procedure (see the essay above). Throws InputError on bad input.
FitResult fit_experiment(const Experiment& e, const FitOptions& o);

// Value and standard deviation (white-residual covariance, or colored) of a(x), b1(x) or
// C_aq(x) at x_rad, for +/- 2 sigma bands. Terms that were not estimated (a priori C_aq when
// rotary.estimate = false) contribute no variance.
enum class BoundKind { white, colored };
struct FunctionBand { double value = 0.0; double sigma = 0.0; };
FunctionBand function_band(const FitResult& r, ModelFunction f, double x_rad,
                           BoundKind kind = BoundKind::white);

// Building blocks, for diagnose and tests ---------------------------------------------------

// Static curve and a priori rotary term from the experiment, as the model's curves (no
// unsteady part yet). Throws InputError for a static table that is not strictly increasing.
ModelSet<double, FitCapacity> base_model_set(const Experiment& e);

// Equation error with the experiment's configured structure (stepwise when configured),
// using the experiment's rotary polynomial as C_aq.
EquationErrorResult fit_equation_error(const Experiment& e, const FitOptions& o);

}  // namespace indicial
