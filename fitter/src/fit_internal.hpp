// fit_internal.hpp -- private pieces shared by the fit_*.cpp files (not installed).
//
// The term pool of the unsteady model, the prepared per-run series (model angle, its rate,
// y_E of eq. 12), the linear least-squares solve with white and colored covariances, stepwise
// regression, and the maximum-likelihood output-error estimator. fit.hpp is the public face.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <string>
#include <vector>

#include "indicial/fitter/experiment.hpp"
#include "indicial/fitter/fit.hpp"
#include "indicial/model.hpp"

namespace indicial::fit_detail {

using Cap = FitCapacity;
using SplineD = Spline<double, Cap::max_powers, Cap::max_knots>;

// ------------------------------------------------------------------------------------------
// Structure of the unsteady part: which terms a(x), b1(x), con and further lags carry.
// ------------------------------------------------------------------------------------------
struct SplineTerms {
  std::vector<int> powers;       // ascending
  std::vector<double> knots_rad; // ascending
  int knot_power = 1;
  std::size_t size() const { return powers.size() + knots_rad.size(); }
};

enum class Bias { absent, present };
// Whether the ML estimates a delay of the unsteady forcing (parameter delay_s, last of the
// structural parameters: it drives the states through indicial::delayed_angle).
enum class DelayTerm { absent, estimated };
// What jointly estimated rotary terms (UnsteadyStructure::rotary) mean: the two-stage loop's
// terms REPLACE the a priori C_aq (target C - C_a(x)); diagnose's rotary_alpha terms CORRECT
// it (target y_E of eq. 12, the a priori C_aq already subtracted).
enum class RotaryRole { replaces_a_priori, corrects_a_priori };

struct UnsteadyStructure {
  SplineTerms a;
  SplineTerms b1;
  Bias con = Bias::absent;
  int lags = 1;
  // Lags 2..lags: b_k(x) terms (same shape as b1 by default) and a gain c_k each.
  std::vector<SplineTerms> b_more;
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
  int y0_per_run() const { return further_lag_start == LagStart::at_rest ? 1 : lags; }
  double l_over_v_s = 0.0;
  // Number of structural parameters that drive the states (rotary and y0 not included).
  int n_struct() const;
};

enum class TermKind { a_power, a_knot, b_power, b_knot, con, gain, rotary_power, rotary_knot,
                      delay, static_power, static_knot };

struct Term {
  TermKind kind = TermKind::a_power;
  int lag = 0;            // 0-based lag for b_power / b_knot / gain
  int power = 0;          // x^power, or the knot term's power
  double knot_rad = 0.0;  // for knot terms
  int index = 0;          // 0-based index within its spline's powers or knots
  std::string name;       // contract name: a1, A2, b1_0, B1, con, b2_0, c2, Caq_2, CaqK1
};

// Order: a powers, a knots, b1 powers, b1 knots, con, then per further lag: b powers, knots, c.
std::vector<Term> structural_terms(const UnsteadyStructure& s);
UnsteadyStructure structure_from_config(const ModelConfig& m);
// The sub-structure made of the named terms of `pool` (names from structural_terms(pool)).
UnsteadyStructure select_terms(const UnsteadyStructure& pool,
                               const std::vector<std::string>& names);
std::vector<Term> rotary_terms(const SplineTerms& pool);
std::vector<Term> static_corr_terms(const SplineTerms& pool);  // dCa_{i}, dCaK{j}

// ------------------------------------------------------------------------------------------
// Prepared runs.
// ------------------------------------------------------------------------------------------
struct PreparedRun {
  std::string path;
  double dt_s = 0.0;
  bool periodic = false;
  std::vector<double> t, x, xdot, rate, coef;
  std::vector<double> static_value;  // C_a(x) (+ correction)
  std::vector<double> rotary_value;  // (l/V) C_aq(x) rate
  std::vector<double> y_e;           // eq. 12
};

std::vector<PreparedRun> prepare_runs(const Experiment& e, const ModelSet<double, Cap>& base);
void update_rotary(std::vector<PreparedRun>& runs, const SplineD& rotary, double l_over_v_s);

// Savitzky-Golay derivative (delegates to io.hpp's smooth_derivative).
std::vector<double> sg_derivative(const std::vector<double>& v, double dt_s, int half_window,
                                  int order);

// ------------------------------------------------------------------------------------------
// Linear algebra helpers.
// ------------------------------------------------------------------------------------------
// Residual autocorrelation pooled over segments [starts[i], starts[i+1]) and the lag window.
int choose_correlation_lag(const Eigen::VectorXd& v, const std::vector<std::size_t>& starts,
                           const FitOptions& o);
// The middle of the Morelli-Klein sandwich: sum over segments of
// sum_{|k| <= lag} R(k) sum_i g_i g_{i+k}'  with g_i the i-th row of G.
Eigen::MatrixXd colored_middle(const Eigen::MatrixXd& G, const Eigen::VectorXd& v,
                               const std::vector<std::size_t>& starts, int lag);

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

// Stepwise regression over the columns of X (see fit_stepwise.cpp). Returns the selected
// column indices (pool order) and fills the log.
std::vector<int> stepwise_select(const Eigen::MatrixXd& X, const Eigen::VectorXd& z,
                                 const std::vector<std::string>& names, const FitOptions& o,
                                 StepwiseResult& log);

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
  std::vector<std::string> names;
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
struct MLResult {
  UnsteadyStructure structure;
  std::vector<std::string> names;     // structural then y0 names
  Eigen::VectorXd theta;
  Eigen::MatrixXd cov_white;          // NaN rows/cols for unidentifiable parameters
  Eigen::MatrixXd cov_colored;
  std::vector<Identifiability> identifiability;
  OutputErrorSummary summary;
  std::vector<std::vector<double>> y_model;  // per run
};

// Value of the rotary basis term k (rotary_terms order) at x. Also the basis of the static
// correction terms (static_corr_terms order): the same powers-then-knots layout.
double rotary_basis(const SplineTerms& rotary, std::size_t k, double x);

// Layout of y0 parameters: for every non-periodic run, `lags` values.
int n_initial_states(const UnsteadyStructure& s, const std::vector<PreparedRun>& runs);
std::vector<std::string> parameter_names(const UnsteadyStructure& s,
                                         const std::vector<PreparedRun>& runs);

// theta0: structural start values followed by the y0 start values (size = names).
MLResult fit_output_error(const UnsteadyStructure& s, const std::vector<PreparedRun>& runs,
                          const Eigen::VectorXd& theta0, const FitOptions& o,
                          const std::string& context_file);

// Stepwise refinement of a structure on the output-error fit (fit_stepwise_output_error.cpp):
// from `ml` (a fit of a sub-structure of `pool`), a(x), b1(x) and con terms of the pool enter
// by the ML partial F and leave by the Wald F; returns the final fit and logs every step.
MLResult refine_structure_output_error(const UnsteadyStructure& pool,
                                       const std::vector<PreparedRun>& runs, MLResult ml,
                                       const FitOptions& o, const std::string& file,
                                       OutputErrorStepwiseResult* log);

// Writes the unsteady part of theta (structural part) into a double model.
void set_unsteady(const UnsteadyStructure& s, const double* theta, CoefficientModel<double, Cap>& m);

// Adds the jointly estimated linear output terms of theta (after the n_struct structural
// values: rotary, then static correction) to m: rotary terms into m.rotary (added to what is
// there when s.rotary_role == corrects_a_priori, replacing it otherwise), static terms into
// m.static_correction (added). Used to build the final model of fit_experiment.
void add_output_terms(const UnsteadyStructure& s, const double* theta,
                      CoefficientModel<double, Cap>& m);

}  // namespace indicial::fit_detail
