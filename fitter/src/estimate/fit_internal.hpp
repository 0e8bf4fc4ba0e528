// fit_internal.hpp -- private pieces shared by the fit_*.cpp files (not installed).
//
// The term pool of the unsteady model, the prepared per-run series (model angle, its rate,
// y_E of eq. 12), the linear least-squares solve with white and colored covariances, stepwise
// regression, and the maximum-likelihood output-error estimator. fit.hpp is the public face.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include "indicial/fitter/experiment.hpp"
#include "indicial/fitter/fit.hpp"
#include "indicial/model.hpp"
#include "numerics/covariance.hpp"

namespace indicial::fit_detail {

using Cap = FitCapacity;
using SplineD = Spline<double, Cap::max_powers, Cap::max_knots>;
struct PreparedRun;

// ------------------------------------------------------------------------------------------
// Structure of the unsteady part: which terms a(x), b_j(x), con, the delay and the jointly
// estimated output terms carry.
// ------------------------------------------------------------------------------------------
struct SplineTerms {
  std::vector<int> powers;       // ascending
  std::vector<double> knots_rad; // ascending
  int knot_power = 1;
  std::size_t size() const { return powers.size() + knots_rad.size(); }
  // The basis of term k (powers first, then knots): model.hpp's BasisTerm.
  BasisTerm basis(std::size_t k) const {
    return k < powers.size() ? BasisTerm{BasisKind::power, powers[k], 0.0}
                             : BasisTerm{BasisKind::knot, knot_power, knots_rad[k - powers.size()]};
  }
};

enum class Bias { absent, present };
// Whether the ML estimates a delay of the unsteady forcing (parameter delay_s, last of the
// structural parameters: it drives the states through indicial::delayed_angle).
enum class DelayTerm { absent, estimated };
// What jointly estimated rotary terms (UnsteadyStructure::rotary) mean: the two-stage loop's
// terms REPLACE the a priori C_aq (target C - C_a(x)); diagnose's rotary_alpha terms CORRECT
// it (target y_E of eq. 12, the a priori C_aq already subtracted).
enum class RotaryRole { replaces_a_priori, corrects_a_priori };

// The dynamic-stall part of a structure (model.hpp "Dynamic stall"): which families, the
// static separation derived from the lift polar (not estimated: stall_polar.cpp), the terms of
// the fitted f0 correction; every other stall parameter is one scalar (structural_terms).
struct StallStructure {
  StallFamilies families = StallFamilies::none;
  double normal_force_slope_per_rad = 0.0;
  double zero_lift_angle_rad = 0.0;
  std::vector<double> f0_x_rad, f0_value;
  SplineTerms f0_correction;
  double shedding_threshold_start = 1.0;  // N(x) where f0 first falls below 0.7 (above alpha_0)
  StallReattachment reattachment = StallReattachment::as_separation;  // T1r estimated or not (0)
  StallHysteresis hysteresis = StallHysteresis::none;                 // dxr estimated or not (0)
  StallLagLimit lag_limit = StallLagLimit::none;                      // D estimated or not (0)
  ForcingLag forcing_lag = ForcingLag::delay;                         // StallConfig::forcing_lag
  std::vector<std::pair<ParamId, double>> known;  // StallConfig::known: held, not estimated
  bool is_known(const ParamId& id) const {
    for (const auto& k : known)
      if (same_parameter(k.first, id)) return true;
    return false;
  }
};

struct UnsteadyStructure {
  SplineTerms a;
  // b[j] = b_{j+1}(x), one per lag (at least one; at most Cap::max_lags). Each lag j >= 1 also
  // has a gain c_{j+1}.
  std::vector<SplineTerms> b{SplineTerms{}};
  Bias con = Bias::absent;
  // Rotary terms estimated jointly in the output-error step (two-stage loop, joint_ml):
  // the output is then y_model + (l/V) C_aq(x) rate and the target C - C_a(x). Empty: C_aq is
  // known (the a priori one or the last regression's) and the target is y_E.
  SplineTerms rotary;
  RotaryRole rotary_role = RotaryRole::replaces_a_priori;
  // Angle-only static correction dC_a(x) terms estimated jointly (linear in the output, after
  // the rotary terms in the parameter vector; names dCa_{i}, dCaK{j}).
  SplineTerms static_corr;
  DelayTerm delay = DelayTerm::absent;
  // Lags 2..: initial state per run estimated, or 0 (experiment.hpp LagStart).
  LagStart further_lag_start = LagStart::estimated;
  StallStructure stall;
  int lags() const { return static_cast<int>(b.size()); }
  int y0_per_run() const { return further_lag_start == LagStart::at_rest ? 1 : lags(); }
};

// The terms of a structure, as parameter ids (names by parameter_name), in parameter-vector
// order. Structural (they drive the states): a powers, a knots, b1 powers, b1 knots, con, then
// per further lag: b powers, b knots, gain; then delay.
std::vector<ParamId> structural_terms(const UnsteadyStructure& s);
// Whether a parameter belongs to the dynamic-stall families (model.hpp "Dynamic stall": T1,
// T2, T1r, the f0 correction, k0..k2, C_N1, T_v, T_vl, c_v, x_v). The stall states depend on
// these and the angle only, the lags on none of them (fit_output_error.cpp's Jacobian relies
// on it).
bool is_stall_parameter(const ParamId& id);
// Of those, the ones that enter the stall output only, not the states (k0..k2, c_v, x_v).
bool is_stall_output_parameter(const ParamId& id);
// The stall part of a structure from the experiment's configuration: the attached line and
// the Kirchhoff table from the lift polar (stall_polar.cpp). Throws InputError (naming the
// polar file, or context_file) for a polar without an attached part.
StallStructure stall_structure(const StallConfig& c, const std::string& context_file);
// The stall output of every sample of run r with model m (0 without families), as the fit
// propagates it (fit_output_error.cpp); *initial: the stall state at sample 0 (the periodic
// state of a periodic run).
std::vector<double> stall_outputs(const CoefficientModel<double, Cap>& m, const PreparedRun& r,
                                  StallState<double>* initial);
// Output terms (linear in the output): the rotary terms, then the static correction terms.
std::vector<ParamId> output_terms(const UnsteadyStructure& s);
std::vector<ParamId> rotary_terms(const SplineTerms& pool);        // Caq_{i}, CaqK{j}
std::vector<ParamId> static_corr_terms(const SplineTerms& pool);   // dCa_{i}, dCaK{j}
// The basis of a spline term (power or knot kind).
BasisTerm term_basis(const ParamId& t);

// A model whose output is exactly one output term at coefficient 1 (everything else zero):
// coefficient_output of it is that term's regressor (the output is linear in these terms).
CoefficientModel<double, Cap> unit_output_model(const ParamId& term);

UnsteadyStructure structure_from_config(const ModelConfig& m);
// The sub-structure of `pool` made of the given a(x), b1(x) and con terms (identity by
// ParamId: knots by position); further lags and the ML-only terms are kept whole.
UnsteadyStructure select_terms(const UnsteadyStructure& pool, const std::vector<ParamId>& ids);

// The parameter vector of the output-error fit: one ordered list of ids,
//   [structural terms | output terms | initial states (per non-periodic run, y0_per_run)],
// which builds the model from a vector, names it, places start values and indexes the
// covariance. Every index arithmetic on theta goes through it.
class ParameterLayout {
 public:
  struct Range { int begin = 0; int end = 0; int size() const { return end - begin; } };
  ParameterLayout(const UnsteadyStructure& s, const std::vector<PreparedRun>& runs);
  const UnsteadyStructure& structure() const { return s_; }
  const std::vector<ParamId>& ids() const { return ids_; }
  int size() const { return static_cast<int>(ids_.size()); }
  Range structural() const { return {0, n_struct_}; }
  Range output() const { return {n_struct_, n_struct_ + n_output_}; }
  Range initial_states() const { return {n_struct_ + n_output_, size()}; }
  // Index of run r's first initial state, or -1 (a periodic run: no parameter).
  int y0_offset(std::size_t r) const { return y0_offset_[r]; }
  int y0_per_run() const { return s_.y0_per_run(); }
  std::vector<std::string> names() const;
  int find(const ParamId& id) const;  // -1 when absent
  // The model of theta's structural part (size structural().size()): spline shapes from the
  // structure, every coefficient from its parameter; rotary and static terms not included.
  template <class S>
  void build_unsteady(const S* structural, CoefficientModel<S, Cap>& m) const;
  // Adds the output terms of theta (full vector) to m: rotary terms into m.rotary (added to
  // what is there when they correct the a priori C_aq, replacing it otherwise), static terms
  // into m.static_correction (added).
  void add_output_terms(const double* theta, CoefficientModel<double, Cap>& m) const;

 private:
  UnsteadyStructure s_;
  std::vector<ParamId> ids_;
  int n_struct_ = 0;
  int n_output_ = 0;
  std::vector<int> y0_offset_;
};

// Spline shape (powers, knots and their powers) of a term set, coefficients zero.
template <class S>
void shape_spline(const SplineTerms& t, Spline<S, Cap::max_powers, Cap::max_knots>& sp) {
  int n_powers = 0;
  for (int p : t.powers) n_powers = std::max(n_powers, p + 1);
  sp.n_powers = n_powers;
  for (int i = 0; i < Cap::max_powers; ++i) sp.power_coef[i] = S(0);
  sp.n_knots = static_cast<int>(t.knots_rad.size());
  for (std::size_t j = 0; j < t.knots_rad.size(); ++j) {
    sp.knot_rad[j] = t.knots_rad[j];
    sp.knot_power[j] = t.knot_power;
    sp.knot_coef[j] = S(0);
  }
}

// The dynamic-stall part of a model from its structure: families, polar, f0 table, the f0
// correction's shape; the estimated scalars are set by set_parameter.
template <class S>
void shape_stall(const StallStructure& t, StallModel<S, Cap>& m) {
  m = StallModel<S, Cap>{};
  m.families = t.families;
  if (t.families == StallFamilies::none) return;
  SeparationParameters<S, Cap>& p = m.separation;
  p.normal_force_slope_per_rad = S(t.normal_force_slope_per_rad);
  p.zero_lift_angle_rad = S(t.zero_lift_angle_rad);
  p.forcing_lag = t.forcing_lag;
  p.n_f0 = static_cast<int>(t.f0_x_rad.size());
  for (std::size_t i = 0; i < t.f0_x_rad.size(); ++i) {
    p.f0_x_rad[i] = t.f0_x_rad[i];
    p.f0_value[i] = S(t.f0_value[i]);
  }
  shape_spline(t.f0_correction, p.f0_correction);
}

// Writes the value of one unsteady parameter into its slot of a model shaped by
// ParameterLayout::build_unsteady (output terms and initial states have no slot there).
template <class S>
void set_parameter(const ParamId& id, const S& v, CoefficientModel<S, Cap>& m) {
  switch (id.kind) {
    case ParamKind::a_power: m.a.power_coef[id.power] = v; break;
    case ParamKind::a_knot: m.a.knot_coef[id.knot] = v; break;
    case ParamKind::b_power: m.lags[id.lag].b.power_coef[id.power] = v; break;
    case ParamKind::b_knot: m.lags[id.lag].b.knot_coef[id.knot] = v; break;
    case ParamKind::con: m.con = v; break;
    case ParamKind::gain: m.lags[id.lag].gain = v; break;
    case ParamKind::delay: m.delay_s = v; break;
    case ParamKind::stall_tau1: m.stall.separation.tau1_semichords = v; break;
    case ParamKind::stall_tau2: m.stall.separation.tau2_semichords = v; break;
    case ParamKind::stall_tau1_reattach: m.stall.separation.tau1_reattach_semichords = v; break;
    case ParamKind::stall_reattach_shift: m.stall.separation.reattach_shift_rad = v; break;
    case ParamKind::stall_lag_limit: m.stall.separation.lag_limit_rad = v; break;
    case ParamKind::f0_power: m.stall.separation.f0_correction.power_coef[id.power] = v; break;
    case ParamKind::f0_knot: m.stall.separation.f0_correction.knot_coef[id.knot] = v; break;
    case ParamKind::stall_cp:
      (id.power == 0 ? m.stall.separation.cp_k0
                     : id.power == 1 ? m.stall.separation.cp_k1 : m.stall.separation.cp_k2) = v;
      break;
    case ParamKind::shedding_threshold: m.stall.vortex.shedding_threshold = v; break;
    case ParamKind::vortex_decay: m.stall.vortex.decay_semichords = v; break;
    case ParamKind::vortex_travel: m.stall.vortex.travel_semichords = v; break;
    case ParamKind::vortex_lift: m.stall.vortex.lift_gain = v; break;
    case ParamKind::vortex_cp: m.stall.vortex.cp_travel = v; break;
    default: break;
  }
}

template <class S>
void ParameterLayout::build_unsteady(const S* structural, CoefficientModel<S, Cap>& m) const {
  shape_spline(s_.a, m.a);
  m.n_lags = s_.lags();
  for (int j = 0; j < m.n_lags; ++j) {
    shape_spline(s_.b[static_cast<std::size_t>(j)], m.lags[j].b);
    m.lags[j].gain = S(1);
  }
  m.con = S(0);
  m.delay_s = S(0);
  shape_stall(s_.stall, m.stall);
  for (int k = 0; k < n_struct_; ++k) set_parameter(ids_[static_cast<std::size_t>(k)], structural[k], m);
  if (s_.stall.families != StallFamilies::none)
    for (const auto& k : s_.stall.known) set_parameter(k.first, S(k.second), m);
}

// ------------------------------------------------------------------------------------------
// Prepared runs.
// ------------------------------------------------------------------------------------------
// A run as every fit step sees it. Its airspeed and time grid are the run's own (issue 12):
//  * airspeed: b_j(x), con (1/s) and the delay (s) of the model are at the experiment's
//    reference airspeed; on this run they act at time_scale = V / V_ref (StepGeometry's
//    time_scale; the delay through model.hpp's delay_at_airspeed) and the rotary term carries
//    l_over_v_s = l / V -- the runtime's and the simulator's own scaling, the same model.hpp
//    expressions. At V = V_ref the factors are exactly 1 and l / V_ref, so nothing moves.
//  * time grid: on a uniform grid every step is dt_s (one value, t[1] - t[0], as always); on a
//    nonuniform grid (declared, or a phase column with jitter: csv_reader.hpp) each step is
//    t[k+1] - t[k] and derivatives are taken on the actual times (step_s, y_e_derivative).
struct PreparedRun {
  std::string path;
  double dt_s = 0.0;
  TimeGrid time_grid = TimeGrid::uniform;
  bool periodic = false;
  double airspeed_mps = 0.0;            // V of this run (> 0)
  double reference_airspeed_mps = 0.0;  // V_ref, the model's airspeed_mps
  double time_scale = 1.0;              // V / V_ref
  double l_over_v_s = 0.0;              // l / V: the rotary term's time scale on this run
  std::vector<double> t, x, xdot, rate, coef;
  std::vector<double> static_value;  // C_a(x) (+ correction)
  std::vector<double> rotary_value;  // (l/V) C_aq(x) rate
  std::vector<double> y_e;           // eq. 12
  // The step from sample k to k + 1 (k + 1 < size).
  double step_s(std::size_t k) const { return time_grid == TimeGrid::uniform ? dt_s : t[k + 1] - t[k]; }
  // The step that closes an open periodic cycle (last sample back to the first): dt_s, or the
  // mean step on a nonuniform grid (as predict_periodic does).
  double wrap_step_s() const {
    return time_grid == TimeGrid::uniform ? dt_s
                                          : (t.back() - t.front()) / static_cast<double>(t.size() - 1);
  }
  // The model's delay (s at V_ref) on this run: delay_at_airspeed, model.hpp.
  template <class S>
  S delay_here(const S& delay_s) const {
    return delay_at_airspeed(delay_s, reference_airspeed_mps, airspeed_mps);
  }
};

std::vector<PreparedRun> prepare_runs(const Experiment& e, const ModelSet<double, Cap>& base);
// Recomputes rotary_value and y_e (eq. 12) with C_aq = rotary, at each run's own l / V.
void update_rotary(std::vector<PreparedRun>& runs, const SplineD& rotary);
// The derivative of a run's y_E (eq. 22's left side): Savitzky-Golay on a uniform grid, the
// same local polynomial on the actual times on a nonuniform one (derivative.hpp).
std::vector<double> y_e_derivative(const PreparedRun& r, int half_window, int order);


// ------------------------------------------------------------------------------------------
// Linear algebra helpers.
// ------------------------------------------------------------------------------------------
// The colored-residual lag window of FitOptions (numerics::Covariance::correlation_lag over
// segments [starts[i], starts[i+1])). The sandwich's middle is
// numerics::Covariance::correlated_middle.
inline int choose_correlation_lag(const Eigen::VectorXd& v, const std::vector<std::size_t>& starts,
                                  const FitOptions& o) {
  using Rule = numerics::Covariance::LagRule;
  return numerics::Covariance::correlation_lag(
      v, starts, o.max_correlation_lag,
      o.colored_lag_rule == ColoredLagRule::fixed ? Rule::fixed : Rule::automatic);
}

struct LinearFit {
  Eigen::VectorXd beta;
  Eigen::MatrixXd cov_white;
  Eigen::MatrixXd cov_colored;
  Eigen::VectorXd residual;
  double sse = 0.0;
  double r_squared = 0.0;
  int lag = 0;
};

// Least squares by SVD with a relative singular-value cut-off on unit-norm-scaled columns.
// Throws InputError(context_file, 0, ...) naming the offending terms if a column is zero or
// the matrix is rank deficient (names[i] labels column i).
LinearFit least_squares(const Eigen::MatrixXd& X, const Eigen::VectorXd& z,
                        const std::vector<std::size_t>& starts,
                        const std::vector<std::string>& names, const FitOptions& o,
                        const std::string& context_file);

// Stepwise regression over the columns of X (see fit_stepwise.cpp); `starts` are the
// segment (run) starts plus the end, for the residual autocorrelation of the colored-residual
// significance. Returns the selected column indices (pool order) and fills the log.
std::vector<int> stepwise_select(const Eigen::MatrixXd& X, const Eigen::VectorXd& z,
                                 const std::vector<std::size_t>& starts,
                                 const std::vector<std::string>& names, const FitOptions& o,
                                 StepwiseResult& log);

// The columns a stepwise fit starts the output-error fallback from when the regression
// selected nothing (fit_stepwise_output_error.cpp): the lowest-order a(x) term and the
// lowest-order b1(x) term of the pool, column indices into `terms`. Empty when the pool has
// no a(x) or no b1(x) term.
std::vector<int> fallback_start_columns(const std::vector<ParamId>& terms);

// Throws InputError if a column is identically zero (names the term).
void refuse_zero_columns(const Eigen::MatrixXd& X, const std::vector<std::string>& names,
                         const std::string& context_file);

// ------------------------------------------------------------------------------------------
// Equation error on a given structure pool: regressor matrix, z and segment starts.
// ------------------------------------------------------------------------------------------
struct EquationErrorProblem {
  Eigen::MatrixXd X;
  Eigen::VectorXd z;
  std::vector<std::size_t> starts;  // segment starts (+ end), one segment per run
  std::vector<ParamId> terms;       // column j's term
  std::vector<std::string> names;   // its name (messages, the stepwise log)
};
EquationErrorProblem equation_error_problem(const std::vector<PreparedRun>& runs,
                                            const UnsteadyStructure& s, const FitOptions& o);

// Equation error with structure pool `pool` (stepwise when mode says so). Returns the
// result and the structure actually estimated.
EquationErrorResult run_equation_error(const std::vector<PreparedRun>& runs,
                                       const UnsteadyStructure& pool, StructureMode mode,
                                       const FitOptions& o, const std::string& context_file,
                                       UnsteadyStructure& selected);

// ------------------------------------------------------------------------------------------
// Maximum-likelihood output error.
// ------------------------------------------------------------------------------------------
// What an output-error fit works on: the prepared runs and the known part of the model (the
// static curve, its known correction and the current C_aq: the model y_E was computed with)
// and the envelope the fitted model is written with (base_model_set's x_min_rad / x_max_rad,
// the data's model-angle range), on which every b_j(x) must stay positive.
// A priori value of one parameter (FitOptions::stall_prior): the fit's cost gains
// 0.5 (s_ref (theta - mean) / sigma)^2, s_ref = stall_prior_scale(runs).
struct PriorTerm {
  ParamId id;
  double mean = 0.0;
  double sigma = 1.0;
};

struct OutputErrorData {
  const std::vector<PreparedRun>& runs;
  const CoefficientModel<double, Cap>& known;
  const std::string& context_file;
  AngleRange envelope;
  const std::vector<PriorTerm>* prior = nullptr;  // none: maximum likelihood alone
};

// The prior's residual scale: a tenth of the quasi-steady model's RMS error (y_E, eq. 12) over
// the runs. 0 without samples.
double stall_prior_scale(const std::vector<PreparedRun>& runs);

// Whether a model is admissible for the output-error fit (e.g. every b_j(x) > 0 on the
// envelope). A trial step to an inadmissible model is rejected like a cost increase.
// Empty: every model is.
using FeasibilityPredicate = std::function<bool(const CoefficientModel<double, Cap>&)>;

// The output-error problem's residuals v = C - C_model at theta (ParameterLayout order), and
// with them its Jacobian dv/dtheta (forward autodiff, the lag and stall chains apart), as the
// fit's solver sees them (fit_output_error.cpp; tests compare the two by finite differences).
// False when the model cannot be propagated or gives non-finite values.
bool output_error_residuals(const ParameterLayout& L, const OutputErrorData& d,
                            const Eigen::VectorXd& theta, Eigen::VectorXd& v);
bool output_error_jacobian(const ParameterLayout& L, const OutputErrorData& d,
                           const Eigen::VectorXd& theta, Eigen::VectorXd& v, Eigen::MatrixXd& J);

struct MLResult {
  UnsteadyStructure structure;
  std::vector<ParamId> ids;           // ParameterLayout order: structural, output, y0
  std::vector<std::string> names;     // parameter_name of each id
  Eigen::VectorXd theta;
  Eigen::MatrixXd cov_white;          // NaN rows/cols for unidentifiable parameters
  Eigen::MatrixXd cov_colored;
  std::vector<Identifiability> identifiability;
  OutputErrorSummary summary;
  std::vector<std::vector<double>> y_model;  // per run
  ParameterEstimate estimate(int i) const;   // parameter i with its bounds
};

// The whole model at theta: `known` with the unsteady part and the output terms of theta.
CoefficientModel<double, Cap> model_at(const ParameterLayout& L, const Eigen::VectorXd& theta,
                                       const CoefficientModel<double, Cap>& known);

// theta0: start values in ParameterLayout(s, runs) order.
MLResult fit_output_error(const UnsteadyStructure& s, const OutputErrorData& d,
                          const Eigen::VectorXd& theta0, const FitOptions& o,
                          const FeasibilityPredicate& feasible = {});

// Stepwise refinement of a structure on the output-error fit (fit_stepwise_output_error.cpp):
// from `ml` (a fit of a sub-structure of `pool`), a(x), b1(x) and con terms of the pool enter
// by the ML partial F and leave by the Wald F; returns the final fit and logs every step.
MLResult refine_structure_output_error(const UnsteadyStructure& pool, const OutputErrorData& d,
                                       MLResult ml, const FitOptions& o,
                                       OutputErrorStepwiseResult* log);

// The stall start grid (FitOptions::stall_start_search; fit_stall_starts.cpp): whether it runs
// for layout L under options o, and its points, the configured start theta0 first (`varied`:
// the grid's parameters by name with their start values).
struct StallStartGridPoint {
  std::vector<std::pair<std::string, double>> varied;
  Eigen::VectorXd theta;
};
bool stall_start_search_runs(const ParameterLayout& L, const FitOptions& o);
std::vector<StallStartGridPoint> stall_start_grid(const ParameterLayout& L, const Eigen::VectorXd& theta0);

}  // namespace indicial::fit_detail
