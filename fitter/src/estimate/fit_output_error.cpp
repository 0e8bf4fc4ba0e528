// fit_output_error.cpp -- maximum-likelihood output error (report eqs. 23-24).
//
// The state is propagated from the measured model angle, sample to sample, with
// indicial::advance_lags -- the runtime's own discrete update -- and the residual is
// v = y_E - y_model. For white Gaussian noise of unknown variance the ML estimate minimises
// J = 0.5 sum v^2; s(v)^2 = sum v^2 / N. The Gauss-Newton / Levenberg-Marquardt iteration uses
// EXACT sensitivities: the same template is evaluated with Eigen's forward AutoDiffScalar
// (fixed-size derivative vectors, so no heap per operation). No finite differences.
//
// Parameters: the structural coefficients (a, A, b1, B, con, further lags) and, for every
// non-periodic run, its initial state(s) y0. A periodic run's state is the periodic steady
// state: with y(end) = Phi y0 + psi per lag (the update is affine in y for a given model),
// propagating from y0 = 0 gives psi, from y0 = 1 gives Phi + psi, and y0 = psi / (1 - Phi);
// done with the autodiff type, its sensitivities come for free.
//
// Convergence (documented in fit.hpp): an accepted step with relative cost change below
// cost_tolerance AND every parameter change below step_tolerance times its Cramer-Rao bound.
// A rejected step whose undamped size is already below step_tolerance bounds also counts as
// converged (the cost cannot decrease further within round-off).
#include <Eigen/Core>
#include <unsupported/Eigen/AutoDiff>

#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <limits>
#include <memory>

#include "estimate/fit_internal.hpp"
#include "numerics/levenberg_marquardt.hpp"
#include "indicial/fitter/error.hpp"
#include "indicial/fitter/runtime_limits.hpp"
#include "indicial/periodic_stall.hpp"

namespace indicial::fit_detail {

namespace {

constexpr int kMaxDerivatives = 64;

void check_capacity(const UnsteadyStructure& s, const std::string& file) {
  auto check = [&](const SplineTerms& t, const char* what) {
    int n_powers = 0;
    for (int p : t.powers) n_powers = std::max(n_powers, p + 1);
    if (n_powers > Cap::max_powers || static_cast<int>(t.knots_rad.size()) > Cap::max_knots)
      throw InputError(file, 0, fmt::format("{} needs powers up to x^{} and {} knots; the fitter "
                                            "holds at most x^{} and {} knots", what, n_powers - 1,
                                            t.knots_rad.size(), Cap::max_powers - 1, Cap::max_knots));
  };
  if (s.lags() > Cap::max_lags)
    throw InputError(file, 0, fmt::format("{} lags; at most {}", s.lags(), Cap::max_lags));
  check(s.a, "a(x)");
  for (int j = 0; j < s.lags(); ++j)
    check(s.b[static_cast<std::size_t>(j)], j == 0 ? "b1(x)" : "a further lag's b(x)");
  check(s.rotary, "C_aq(x)");
  check(s.static_corr, "the static correction dC_a(x)");
}

// The forcing angles x_f(t_k) of a run: x itself without a delay; with an estimated delay,
// x(t_k - delay) through the shared indicial::delayed_angle (linear interpolation in time over
// the run's samples, the first sample's angle before them), whose derivative with respect to
// the delay an autodiff S carries into the sensitivities.
// The delay is the model's (s at V_ref) at the run's airspeed (PreparedRun::delay_here).
template <class S>
struct Forcing {
  const PreparedRun& r;
  DelayTerm kind = DelayTerm::absent;
  S delay{};  // the delay on this run, when kind is estimated
  ArrayHistory<double> h{};
  Forcing(const PreparedRun& run, const CoefficientModel<S, Cap>& m, DelayTerm d) : r(run), kind(d) {
    if (d == DelayTerm::estimated) {
      delay = run.delay_here(m.delay_s);
      h = ArrayHistory<double>{run.t.data(), run.x.data(), static_cast<int>(run.x.size())};
    }
  }
  S at(std::size_t k) const {
    // Why the branch: without a delay the forcing angle is the sample itself (no search).
    if (kind == DelayTerm::absent) return S(r.x[k]);
    return delayed_angle(h, r.t[k], delay);
  }
  // The spline ends at sample k. Why the branch: without a delay both angles are data, passed
  // as plain doubles so that an autodiff S does no derivative work on them (same values, see
  // indicial::spline_antiderivative).
  void ends_at(const CoefficientModel<S, Cap>& m, std::size_t k, StepEnd<S, Cap>* end) const {
    if (kind == DelayTerm::absent) evaluate_step_end(m, r.x[k], r.x[k], end);
    else evaluate_step_end(m, r.x[k], at(k), end);
  }
};

// Whether the run's last sample repeats the first (a closed cycle) -- then the cycle closes at
// the last sample; otherwise one more step (PreparedRun::wrap_step_s) from the last sample back
// to the first.
bool closes_on_last_sample(const PreparedRun& r) {
  return std::abs(r.x.back() - r.x.front()) <= 1e-9;
}

// Periodic steady state of every lag; false when some lag has no periodic solution
// (Phi >= 1: the time constant is not positive on average over the cycle).
template <class S>
bool periodic_state(const CoefficientModel<S, Cap>& m, const PreparedRun& r, DelayTerm d, S* y0) {
  const Forcing<S> f(r, m, d);
  S ya[Cap::max_lags], yb[Cap::max_lags];
  for (int j = 0; j < m.n_lags; ++j) {
    ya[j] = S(0);
    yb[j] = S(1);
  }
  const std::size_t n = r.x.size();
  const bool closed = closes_on_last_sample(r);
  const std::size_t steps = closed ? n - 1 : n;
  // The spline ends of a step are those of the next step's start: evaluated once per sample
  // and shared by both propagations (what advance_lags would compute, bit for bit).
  StepEnd<S, Cap> end0{}, end1{};
  f.ends_at(m, 0, &end0);
  for (std::size_t k = 0; k < steps; ++k) {
    const std::size_t k1 = (k + 1 == n) ? 0 : k + 1;
    // With a delay the cycle's start uses the first sample's angle before it (delayed_angle's
    // rule), not the previous cycle's end: a small approximation for periodic runs.
    const double dt_s = k + 1 == n ? r.wrap_step_s() : r.step_s(k);
    const StepGeometry<S> g{S(r.x[k]), S(r.x[k1]), f.at(k), f.at(k1), S(dt_s), S(r.time_scale)};
    f.ends_at(m, k1, &end1);
    advance_lags_between(m, g, end0, end1, ya);
    advance_lags_between(m, g, end0, end1, yb);
    end0 = end1;
  }
  for (int j = 0; j < m.n_lags; ++j) {
    const S phi = yb[j] - ya[j];
    // Why: 1 - Phi <= 0 means the homogeneous solution does not decay over a cycle, so no
    // periodic steady state exists (and the division would blow up or flip sign).
    if (!(phi < S(1 - 1e-12))) return false;
    y0[j] = ya[j] / (S(1) - phi);
  }
  return true;
}

// Propagates run r from state y (in/out, n_lags values) and calls emit(i, y) per sample.
template <class S, class Emit>
void propagate(const CoefficientModel<S, Cap>& m, const PreparedRun& r, DelayTerm d, S* y,
               Emit&& emit) {
  const Forcing<S> f(r, m, d);
  S xf0 = f.at(0);
  emit(std::size_t{0}, static_cast<const S*>(y));
  // As the runtime does: each sample's spline ends are evaluated once and serve as the end of
  // one step and the start of the next (bit-identical to advance_lags, half the spline work,
  // which dominates the sensitivities' cost).
  StepEnd<S, Cap> end0{}, end1{};
  f.ends_at(m, 0, &end0);
  for (std::size_t k = 0; k + 1 < r.x.size(); ++k) {
    const S xf1 = f.at(k + 1);
    const StepGeometry<S> g{S(r.x[k]), S(r.x[k + 1]), xf0, xf1, S(r.step_s(k)), S(r.time_scale)};
    f.ends_at(m, k + 1, &end1);
    advance_lags_between(m, g, end0, end1, y);
    end0 = end1;
    xf0 = xf1;
    emit(k + 1, static_cast<const S*>(y));
  }
}

// The dynamic-stall states of run r (model.hpp "Dynamic stall"), sample by sample: emit(i, s)
// with the state at sample i. A run starts at stall_steady_state of its first sample; a
// periodic run at its periodic state instead (periodic_stall.hpp: exact for any time constant,
// with derivatives for an autodiff S; predict --periodic takes the same). The stall states do
// not depend on the lags (both are driven by the angle only), so they are propagated apart and
// their output added: C = coefficient_output(lags) + stall_output, the runtime's sum
// (runtime.hpp), bit for bit.

template <class S>
void advance_stall_cycle(const StallModel<S, Cap>& m, const PreparedRun& r, StallState<S>* s) {
  const std::size_t n = r.x.size();
  auto step = [&](std::size_t k0, std::size_t k1, double dt_s) {
    advance_stall(m, StallStep<S>{S(r.x[k0]), S(r.x[k1]), S(dt_s), S(r.l_over_v_s)}, s);
  };
  for (std::size_t k = 0; k + 1 < n; ++k) step(k, k + 1, r.step_s(k));
  if (!closes_on_last_sample(r)) step(n - 1, 0, r.wrap_step_s());
}

template <class S, class Emit>
void propagate_stall(const StallModel<S, Cap>& m, const PreparedRun& r, Emit&& emit) {
  StallState<S> s;
  stall_steady_state(m, S(r.x[0]), &s);
  if (r.periodic) {
    const StallPeriodicStates live = stall_periodic_states(m);
    periodic_stall_state<1>(&live, 1, &s, [&](const StallState<S>* start, StallState<S>* end) {
      *end = *start;
      advance_stall_cycle(m, r, end);
    });
  }
  const std::size_t n = r.x.size();
  emit(std::size_t{0}, static_cast<const StallState<S>&>(s));
  for (std::size_t k = 0; k + 1 < n; ++k) {
    advance_stall(m, StallStep<S>{S(r.x[k]), S(r.x[k + 1]), S(r.step_s(k)), S(r.l_over_v_s)}, &s);
    emit(k + 1, static_cast<const StallState<S>&>(s));
  }
}

// The stall output of every sample of run r (zeros without families); the state at sample 0
// in *initial when given.
std::vector<double> stall_output_series(const CoefficientModel<double, Cap>& m, const PreparedRun& r,
                                        StallState<double>* initial = nullptr) {
  std::vector<double> out(r.x.size(), 0.0);
  if (m.stall.families == StallFamilies::none) return out;
  propagate_stall(m.stall, r, [&](std::size_t i, const StallState<double>& s) {
    if (i == 0 && initial) *initial = s;
    out[i] = stall_output(m.stall, r.x[i], s);
  });
  return out;
}

// A periodic run's cycle in s: its span, plus the wrap step unless the last sample closes it.
double cycle_s(const PreparedRun& r) {
  return r.t.back() - r.t.front() + (closes_on_last_sample(r) ? 0.0 : r.wrap_step_s());
}

// The longest dynamic-stall time constant a fit of periodic runs may reach (l / V units):
// the shortest periodic cycle / ln 10, where a state keeps 0.1 of its value over that cycle
// (fit_warnings' slow-state floor). +inf without periodic runs.
double stall_time_constant_limit(const std::vector<PreparedRun>& runs) {
  double cycle = std::numeric_limits<double>::infinity();
  for (const PreparedRun& r : runs) {
    if (!r.periodic || r.t.size() < 2 || !(r.l_over_v_s > 0.0)) continue;
    cycle = std::min(cycle, cycle_s(r) / r.l_over_v_s);
  }
  return cycle / std::log(10.0);
}

// The slowest decay a lag of a fit of periodic runs may have anywhere on the envelope (1/s at
// V_ref): one e-fold over the longest periodic cycle (b acts at V / V_ref on a run at V; the
// cycle counts its closing step). 0 without periodic runs (the runtime's b_j(x) > 0 alone).
// Why: a lag that hardly decays over any cycle of the data is an integrator there; its periodic
// state is about (its forcing's cycle mean) / b, an offset of a size the data cannot tell from
// b, which a cycle that stays where b is small predicts with no bound. Measured on the
// development set's three-cycle diagnoses (docs/periodic-stall.md, "lag floor"): report-start
// fits with b1(x) = 1.6e-5 1/s below a knot at 21 deg and con = 0.0096 1/s predicted held-out
// cycles below the knot at 4.7e3 and 1.5e4 times the quasi-steady RMS. The floor is loose on
// purpose: the report's Model II reaches b1 = 1.5 1/s on cycles of 1-4 s (floor 0.25 1/s); a
// floor of ln 10 per SHORTEST cycle (the stall time constants' limit) refused it.
double lag_decay_floor(const std::vector<PreparedRun>& runs) {
  double longest = 0.0;
  for (const PreparedRun& r : runs) {
    if (!r.periodic || r.t.size() < 2) continue;
    longest = std::max(longest, cycle_s(r) * r.time_scale);
  }
  return longest > 0.0 ? 1.0 / longest : 0.0;
}

// Whether every lag of m decays at least at `floor` everywhere on the envelope [lo, hi]
// (floor 0: the runtime's b_j(x) > 0).
bool lag_decay_above(const CoefficientModel<double, Cap>& m, double lo, double hi, double floor) {
  if (!(floor > 0.0)) return lag_decay_positive(m, lo, hi);
  for (int j = 0; j < m.n_lags; ++j)
    if (!(min_lag_decay(m, j, lo, hi) >= floor)) return false;
  return true;
}

// Whether parameter kind k of layout L is a decay time constant the limit applies to (T2 only
// as a first-order lag's; a delay T2 is not a decay).
bool is_limited_time_constant(const ParameterLayout& L, ParamKind k) {
  return k == ParamKind::stall_tau1 || k == ParamKind::stall_tau1_reattach || k == ParamKind::vortex_decay ||
         (k == ParamKind::stall_tau2 && L.structure().stall.forcing_lag == ForcingLag::first_order);
}

// The estimated time constants of theta within the limit (held ones are the user's).
bool stall_time_constants_within(const ParameterLayout& L, double limit, const Eigen::VectorXd& theta) {
  for (int i = 0; i < L.size(); ++i)
    if (is_limited_time_constant(L, L.ids()[static_cast<std::size_t>(i)].kind) && theta(i) > limit) return false;
  return true;
}

// A start beyond the limit at 0.9 of it (what the solver's feasible set refuses).
void project_stall_time_constants(const ParameterLayout& L, double limit, Eigen::VectorXd& theta) {
  for (int i = 0; i < L.size(); ++i)
    if (is_limited_time_constant(L, L.ids()[static_cast<std::size_t>(i)].kind) && theta(i) > limit)
      theta(i) = 0.9 * limit;
}

// The output-error problem for the Levenberg-Marquardt solver: theta in ParameterLayout order,
// residual v = C - C_model with C_model from model.hpp's coefficient_output of the model at
// theta (model_at), the lag states propagated by the runtime's update.
class OutputErrorProblem final : public numerics::LeastSquaresProblem {
 public:
  // stall_limit: the longest estimated stall time constant (stall_time_constant_limit).
  OutputErrorProblem(const ParameterLayout& L, const OutputErrorData& d, const FeasibilityPredicate& feasible,
                     double stall_limit = std::numeric_limits<double>::infinity())
      : L_(L), d_(d), feasible_(feasible), stall_limit_(stall_limit) {
    starts_.push_back(0);
    for (const PreparedRun& r : d.runs) starts_.push_back(starts_.back() + r.x.size());
    // The output terms' regressors come from coefficient_output itself: the output is linear
    // in them, so each column is the output of a model holding only that term, at 1.
    const ParameterLayout::Range out = L.output();
    for (int k = out.begin; k < out.end; ++k)
      unit_models_.push_back(unit_output_model(L.ids()[static_cast<std::size_t>(k)]));
    // The structural parameters apart: the lags' (seeded in the lag chain) and the stall
    // families' (seeded in the stall chain), each chain's derivative slots its own.
    const int ns = L.structural().size();
    lag_slot_.assign(static_cast<std::size_t>(ns), -1);
    for (int k = 0; k < ns; ++k) {
      if (is_stall_parameter(L.ids()[static_cast<std::size_t>(k)])) stall_params_.push_back(k);
      else lag_slot_[static_cast<std::size_t>(k)] = n_lag_params_++;
    }
    for (std::size_t j = 0; j < stall_params_.size(); ++j)
      if (!is_stall_output_parameter(L.ids()[static_cast<std::size_t>(stall_params_[j])]))
        stall_state_slots_.push_back(static_cast<int>(j));
    for (std::size_t j = 0; j < stall_params_.size(); ++j) all_stall_slots_.push_back(static_cast<int>(j));
  }
  int num_parameters() const override { return L_.size(); }
  int num_residuals() const override { return static_cast<int>(starts_.back()); }
  const std::vector<std::size_t>& starts() const { return starts_; }
  bool residuals(const Eigen::VectorXd& theta, Eigen::VectorXd& v) const override {
    return evaluate(theta, v, nullptr);
  }
  bool feasible(const Eigen::VectorXd& theta) const override {
    if (!stall_time_constants_within(L_, stall_limit_, theta)) return false;
    return !feasible_ || feasible_(model_at(L_, theta, d_.known));
  }
  // The lag chain's derivative size: the smallest of 8, 16, 32 or 64 that holds its structural
  // parameters and one run's y0 (the stall chains' sizes: stall_sensitivities). A fixed size
  // costs its full width in every operation, whatever the parameters (64 for 17 parameters:
  // 2.5x the time of 24 on a diagnose of measured cycles; docs/diagnose-speed.md).
  bool jacobian(const Eigen::VectorXd& theta, Eigen::VectorXd& v, Eigen::MatrixXd& J) const override {
    const int nd = n_lag_params_ + L_.y0_per_run();
    if (nd <= 8) return jacobian_n<8>(theta, v, J);
    if (nd <= 16) return jacobian_n<16>(theta, v, J);
    if (nd <= 32) return jacobian_n<32>(theta, v, J);
    return jacobian_n<kMaxDerivatives>(theta, v, J);
  }
  // Residuals at theta, and the lag sum per run when y_model is given. False if the model
  // cannot be propagated (no periodic state) or produces non-finite values.
  bool evaluate(const Eigen::VectorXd& theta, Eigen::VectorXd& v,
                std::vector<std::vector<double>>* y_model) const;

 private:
  template <int N>
  bool jacobian_n(const Eigen::VectorXd& theta, Eigen::VectorXd& v, Eigen::MatrixXd& J) const;
  // The stall output's derivatives on run r, D(i, j) = d stall_output_i / d theta(stall_params_[j]),
  // in two steps: the states' derivatives with respect to the parameters that drive them
  // (stall_state_slots_), then the output's with respect to every stall parameter.
  void stall_sensitivities(const Eigen::VectorXd& theta, const PreparedRun& r, Eigen::MatrixXd& D) const;
  template <int N>
  void stall_state_sensitivities_n(const Eigen::VectorXd& theta, const PreparedRun& r, Eigen::MatrixXd& S) const;
  template <int N>
  void stall_output_sensitivities_n(const Eigen::VectorXd& theta, const PreparedRun& r, const Eigen::MatrixXd& S,
                                    Eigen::MatrixXd& D) const;
  // A model whose parameters in `slots` (slots of stall_params_) carry derivatives 0, 1, ...
  template <class ADN>
  void stall_model_seeded(const Eigen::VectorXd& theta, const std::vector<int>& slots,
                          CoefficientModel<ADN, Cap>& m) const;

  const ParameterLayout& L_;
  const OutputErrorData& d_;
  const FeasibilityPredicate& feasible_;
  double stall_limit_;
  std::vector<std::size_t> starts_;  // first sample of each run, then the total
  std::vector<CoefficientModel<double, Cap>> unit_models_;
  std::vector<int> lag_slot_;      // per structural parameter: its lag-chain slot, or -1 (stall)
  std::vector<int> stall_params_;  // the stall parameters' indices in theta, in slot order
  std::vector<int> all_stall_slots_;    // 0, 1, ..., stall_params_.size() - 1
  std::vector<int> stall_state_slots_;  // the slots of the parameters the stall states depend on
  int n_lag_params_ = 0;
};

double lag_sum(const double* y, int n_lags) {
  double s = y[0];
  for (int j = 1; j < n_lags; ++j) s = s + y[j];
  return s;
}

bool OutputErrorProblem::evaluate(const Eigen::VectorXd& theta, Eigen::VectorXd& v,
                                  std::vector<std::vector<double>>* y_model) const {
  const CoefficientModel<double, Cap> m = model_at(L_, theta, d_.known);
  const DelayTerm delay = L_.structure().delay;
  v.resize(num_residuals());
  if (y_model) y_model->assign(d_.runs.size(), {});
  for (std::size_t ri = 0; ri < d_.runs.size(); ++ri) {
    const PreparedRun& r = d_.runs[ri];
    double y[Cap::max_lags] = {};
    const int off = L_.y0_offset(ri);
    if (off < 0) {
      if (!periodic_state(m, r, delay, y)) return false;
    } else {
      for (int j = 0; j < L_.y0_per_run(); ++j) y[j] = theta(off + j);
    }
    const auto base = static_cast<Eigen::Index>(starts_[ri]);
    if (y_model) (*y_model)[ri].resize(r.x.size());
    const std::vector<double> stall = stall_output_series(m, r);
    propagate(m, r, delay, y, [&](std::size_t i, const double* yi) {
      v(base + static_cast<Eigen::Index>(i)) =
          r.coef[i] - (coefficient_output(m, r.x[i], r.rate[i], r.l_over_v_s, yi) + stall[i]);
      // With dynamic-stall families the unsteady part is the lags plus the stall output.
      if (y_model) (*y_model)[ri][i] = lag_sum(yi, m.n_lags) + stall[i];
    });
  }
  return v.allFinite();
}

// Residuals and Jacobian dv/dtheta with forward autodiff, in chains of their own: the lags
// (driven by a(x), b(x), con, the gains, the delay and a run's y0) and the stall families
// (driven by their own parameters and the angle only: model.hpp "Dynamic stall";
// is_stall_parameter; their states and output apart, stall_sensitivities), each with a
// derivative vector of its own parameters. Per run the lag chain's vector holds its structural
// parameters and that run's own y0 (n_lag_params_ + y0_per_run entries), mapped into the global
// columns afterwards, so the derivative size does not grow with the number of runs. The
// columns are those of one chain over every parameter (the other chain's derivative there is
// exactly 0), so the Jacobian is the single-chain one, bit for bit.
//
// Why fixed-size derivative vectors (N = 8, 16, 32 or 64, the smallest that holds them) rather
// than Eigen::Dynamic with a maximum: with dynamic derivatives a constant such as the first
// lag's gain Scalar(1) carries an EMPTY derivative vector, and Eigen's AutoDiff only makes
// sizes coherent when a plain (non-expression) operand is the empty one; an expression such as
// -gain * forcing_integral then combines vectors of different sizes, which asserts in debug
// builds and silently yields wrong sensitivities under NDEBUG. A fixed-size vector is
// zero-filled for every constant, so any expression the shared model writes is exact.
template <int N>
using AutoDiffN = Eigen::AutoDiffScalar<Eigen::Matrix<double, N, 1>>;

template <int N>
AutoDiffN<N> seeded(double value, int index) {
  AutoDiffN<N> a(value);
  a.derivatives().setZero();
  a.derivatives()(index) = 1.0;
  return a;
}

// The stall chain's derivative sizes: the states' (T1, T2, T1r, the f0 correction, C_N1, T_v,
// T_vl: 5-8 in the usual models) and the output's (those and k0..k2, c_v, x_v: 10-13), each
// the smallest of 8, 12, 16 or 64 that holds them. The states are propagated through a
// periodic run's periodic state (its secant cycles, periodic_stall.hpp) and the run; the
// output only at the samples.
void OutputErrorProblem::stall_sensitivities(const Eigen::VectorXd& theta, const PreparedRun& r,
                                             Eigen::MatrixXd& D) const {
  Eigen::MatrixXd S;
  const std::size_t ns = stall_state_slots_.size(), n = stall_params_.size();
  if (ns <= 8) stall_state_sensitivities_n<8>(theta, r, S);
  else if (ns <= 16) stall_state_sensitivities_n<16>(theta, r, S);
  else stall_state_sensitivities_n<kMaxDerivatives>(theta, r, S);
  if (n <= 8) return stall_output_sensitivities_n<8>(theta, r, S, D);
  if (n <= 12) return stall_output_sensitivities_n<12>(theta, r, S, D);
  if (n <= 16) return stall_output_sensitivities_n<16>(theta, r, S, D);
  return stall_output_sensitivities_n<kMaxDerivatives>(theta, r, S, D);
}

template <class ADN>
void OutputErrorProblem::stall_model_seeded(const Eigen::VectorXd& theta, const std::vector<int>& slots,
                                            CoefficientModel<ADN, Cap>& m) const {
  const int ns = L_.structural().size();
  std::vector<ADN> th(static_cast<std::size_t>(ns));
  for (int k = 0; k < ns; ++k) th[static_cast<std::size_t>(k)] = ADN(theta(k));  // derivative 0
  for (std::size_t j = 0; j < slots.size(); ++j) {
    const int k = stall_params_[static_cast<std::size_t>(slots[j])];
    th[static_cast<std::size_t>(k)].derivatives()(static_cast<Eigen::Index>(j)) = 1.0;
  }
  L_.build_unsteady(th.data(), m);
}

// S: per sample i and state c (f, v, tau_v, x_e), row kStallStates i + c: the value, then the
// derivatives with respect to stall_state_slots_'s parameters.
constexpr int kStallStates = 4;

template <int N>
void OutputErrorProblem::stall_state_sensitivities_n(const Eigen::VectorXd& theta, const PreparedRun& r,
                                                     Eigen::MatrixXd& S) const {
  using ADN = AutoDiffN<N>;
  CoefficientModel<ADN, Cap> m;
  stall_model_seeded(theta, stall_state_slots_, m);
  const auto n = static_cast<Eigen::Index>(stall_state_slots_.size());
  S.resize(static_cast<Eigen::Index>(r.x.size()) * kStallStates, 1 + n);
  propagate_stall(m.stall, r, [&](std::size_t i, const StallState<ADN>& s) {
    const ADN* states[kStallStates] = {&s.separation_point, &s.vortex_lift, &s.vortex_clock_semichords,
                                       &s.forcing_angle_rad};
    for (int c = 0; c < kStallStates; ++c) {
      const Eigen::Index row = static_cast<Eigen::Index>(i) * kStallStates + c;
      S(row, 0) = states[c]->value();
      S.row(row).tail(n) = states[c]->derivatives().head(n).transpose();
    }
  });
}

template <int N>
void OutputErrorProblem::stall_output_sensitivities_n(const Eigen::VectorXd& theta, const PreparedRun& r,
                                                      const Eigen::MatrixXd& S, Eigen::MatrixXd& D) const {
  using ADN = AutoDiffN<N>;
  CoefficientModel<ADN, Cap> m;
  stall_model_seeded(theta, all_stall_slots_, m);
  const auto n = static_cast<Eigen::Index>(stall_params_.size());
  D.resize(static_cast<Eigen::Index>(r.x.size()), n);
  for (std::size_t i = 0; i < r.x.size(); ++i) {
    StallState<ADN> s;
    ADN* states[kStallStates] = {&s.separation_point, &s.vortex_lift, &s.vortex_clock_semichords,
                                 &s.forcing_angle_rad};
    for (int c = 0; c < kStallStates; ++c) {
      const Eigen::Index row = static_cast<Eigen::Index>(i) * kStallStates + c;
      *states[c] = ADN(S(row, 0));
      for (std::size_t j = 0; j < stall_state_slots_.size(); ++j)
        states[c]->derivatives()(stall_state_slots_[j]) = S(row, 1 + static_cast<Eigen::Index>(j));
    }
    const ADN out = stall_output(m.stall, ADN(r.x[i]), s);
    D.row(static_cast<Eigen::Index>(i)) = out.derivatives().head(n).transpose();
  }
}

template <int N>
bool OutputErrorProblem::jacobian_n(const Eigen::VectorXd& theta, Eigen::VectorXd& v,
                                    Eigen::MatrixXd& J) const {
  using ADN = AutoDiffN<N>;
  const int ns = L_.structural().size();
  const ParameterLayout::Range out = L_.output();
  std::vector<ADN> th(static_cast<std::size_t>(ns));
  for (int k = 0; k < ns; ++k) {
    const int slot = lag_slot_[static_cast<std::size_t>(k)];
    th[static_cast<std::size_t>(k)] = slot >= 0 ? seeded<N>(theta(k), slot) : ADN(theta(k));
  }
  CoefficientModel<ADN, Cap> m;
  L_.build_unsteady(th.data(), m);
  const CoefficientModel<double, Cap> md = model_at(L_, theta, d_.known);
  const DelayTerm delay = L_.structure().delay;
  const double zero_state[Cap::max_lags] = {};
  const bool has_stall = md.stall.families != StallFamilies::none && !stall_params_.empty();
  Eigen::MatrixXd stall_d;
  v.resize(num_residuals());
  J.setZero(num_residuals(), L_.size());
  for (std::size_t ri = 0; ri < d_.runs.size(); ++ri) {
    const PreparedRun& r = d_.runs[ri];
    ADN y[Cap::max_lags];
    for (int j = 0; j < Cap::max_lags; ++j) y[j] = ADN(0.0);
    const int off = L_.y0_offset(ri);
    if (off < 0) {
      if (!periodic_state(m, r, delay, y)) return false;
    } else {
      for (int j = 0; j < L_.y0_per_run(); ++j) y[j] = seeded<N>(theta(off + j), n_lag_params_ + j);
    }
    const auto base = static_cast<Eigen::Index>(starts_[ri]);
    // The stall output's value from the double model, as evaluate() computes it, and its
    // sensitivities from the stall chain.
    const std::vector<double> stall = stall_output_series(md, r);
    if (has_stall) stall_sensitivities(theta, r, stall_d);
    propagate(m, r, delay, y, [&](std::size_t i, const ADN* yi) {
      const Eigen::Index row = base + static_cast<Eigen::Index>(i);
      double y_value[Cap::max_lags] = {};
      ADN sum = yi[0];
      for (int j = 1; j < m.n_lags; ++j) sum = sum + yi[j];
      for (int j = 0; j < m.n_lags; ++j) y_value[j] = yi[j].value();
      v(row) = r.coef[i] - (coefficient_output(md, r.x[i], r.rate[i], r.l_over_v_s, y_value) + stall[i]);
      const auto& d = sum.derivatives();
      for (int k = 0; k < ns; ++k) {
        const int slot = lag_slot_[static_cast<std::size_t>(k)];
        if (slot >= 0) J(row, k) = -d(slot);
      }
      if (has_stall)
        for (std::size_t j = 0; j < stall_params_.size(); ++j)
          J(row, stall_params_[j]) = -stall_d(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j));
      for (int k = out.begin; k < out.end; ++k)
        J(row, k) = -coefficient_output(unit_models_[static_cast<std::size_t>(k - out.begin)],
                                        r.x[i], r.rate[i], r.l_over_v_s, zero_state);
      if (off >= 0)
        for (int j = 0; j < L_.y0_per_run(); ++j) J(row, off + j) = -d(n_lag_params_ + j);
    });
  }
  return v.allFinite() && J.allFinite();
}

// The output-error problem with a priori values (FitOptions::stall_prior): the residuals v of
// `base`, then one row per prior term, w_i (theta_i - mean_i) with w_i = s_ref / sigma_i
// (OutputErrorData::prior, stall_prior_scale), so that the solver minimises
// 0.5 |v|^2 + 0.5 sum w_i^2 (theta_i - mean_i)^2: maximum a posteriori for Gaussian noise of
// the fit's variance s^2 and a prior of spread sigma_i s / s_ref. The feasible set is base's.
class PriorProblem final : public numerics::LeastSquaresProblem {
 public:
  PriorProblem(const OutputErrorProblem& base, std::vector<int> index, std::vector<double> mean,
               std::vector<double> weight)
      : base_(base), index_(std::move(index)), mean_(std::move(mean)), weight_(std::move(weight)) {}
  int num_parameters() const override { return base_.num_parameters(); }
  int num_residuals() const override { return base_.num_residuals() + static_cast<int>(index_.size()); }
  bool residuals(const Eigen::VectorXd& theta, Eigen::VectorXd& r) const override {
    Eigen::VectorXd v;
    if (!base_.residuals(theta, v)) return false;
    r.resize(num_residuals());
    r.head(v.size()) = v;
    for (std::size_t k = 0; k < index_.size(); ++k)
      r(v.size() + static_cast<Eigen::Index>(k)) = weight_[k] * (theta(index_[k]) - mean_[k]);
    return true;
  }
  bool jacobian(const Eigen::VectorXd& theta, Eigen::VectorXd& r, Eigen::MatrixXd& J) const override {
    Eigen::VectorXd v;
    Eigen::MatrixXd Jv;
    if (!base_.jacobian(theta, v, Jv)) return false;
    const Eigen::Index n = v.size();
    r.resize(num_residuals());
    J.setZero(num_residuals(), num_parameters());
    r.head(n) = v;
    J.topRows(n) = Jv;
    for (std::size_t k = 0; k < index_.size(); ++k) {
      const Eigen::Index row = n + static_cast<Eigen::Index>(k);
      r(row) = weight_[k] * (theta(index_[k]) - mean_[k]);
      J(row, index_[k]) = weight_[k];
    }
    return true;
  }
  bool feasible(const Eigen::VectorXd& theta) const override { return base_.feasible(theta); }
  // The prior's information, diag(w_i^2) in theta's order (added to J'J for the bounds).
  Eigen::VectorXd information() const {
    Eigen::VectorXd d = Eigen::VectorXd::Zero(base_.num_parameters());
    for (std::size_t k = 0; k < index_.size(); ++k) d(index_[k]) = weight_[k] * weight_[k];
    return d;
  }

 private:
  const OutputErrorProblem& base_;
  std::vector<int> index_;     // the prior terms' indices in theta
  std::vector<double> mean_;   // their a priori values
  std::vector<double> weight_;  // s_ref / sigma
};

// The prior problem of d.prior's terms that L estimates (a held or absent parameter has none),
// weighted with residual scale `scale`; nullptr when none applies or the scale is not > 0.
std::unique_ptr<PriorProblem> prior_problem(const OutputErrorProblem& base, const ParameterLayout& L,
                                            const OutputErrorData& d, double scale) {
  if (!d.prior || !(scale > 0.0) || !std::isfinite(scale)) return nullptr;
  std::vector<int> index;
  std::vector<double> mean, weight;
  for (const PriorTerm& t : *d.prior) {
    const int k = L.find(t.id);
    if (k < 0 || !(t.sigma > 0.0)) continue;
    index.push_back(k);
    mean.push_back(t.mean);
    weight.push_back(scale / t.sigma);
  }
  if (index.empty()) return nullptr;
  return std::make_unique<PriorProblem>(base, std::move(index), std::move(mean), std::move(weight));
}

// The prior never stronger than at the fit's own residual level: the first solve weights it
// with a tenth of the quasi-steady RMS error (stall_prior_scale: no fit yet); when the
// estimate's s(v) is below that by more than a factor 1.5 (a model that explains more than 93 %
// of the quasi-steady error: clean data) the prior is reweighted with s(v) and the fit solved
// again from the estimate, once. Above it (measured cycles, whose residual is model error:
// s(v) / quasi-steady 0.2-0.5) the first weighting is kept: a prior weaker than the posterior's
// at s(v) (spreads 2-5 times the stated ones), and no second solve. Why one-sided: with the
// prior at s(v) both ways (every spread exactly as stated) 108 of the development set's
// three-cycle diagnoses predicted their held-out cycles worse in 33 changed models and better
// in 23, and took 1.37 times as long (docs/periodic-stall.md, run 5).
// On success *rescaled is the reweighted problem and *lm and theta are its solve's
// (iterations, log and infeasible trials summed over both); otherwise *rescaled stays empty.
void rescale_prior(const OutputErrorProblem& problem, const ParameterLayout& L, const OutputErrorData& d,
                   const numerics::LevenbergMarquardt::Options& options, std::unique_ptr<PriorProblem>* rescaled,
                   numerics::LevenbergMarquardt::Summary& lm, Eigen::VectorXd& theta) {
  Eigen::VectorXd v;
  if (!std::isfinite(lm.cost) || !problem.evaluate(theta, v, nullptr) || v.size() == 0) return;
  const double s_fit = std::sqrt(v.squaredNorm() / static_cast<double>(v.size()));
  const double s0 = stall_prior_scale(d.runs);
  if (!(s_fit > 0.0) || s_fit >= s0 / 1.5) return;
  std::unique_ptr<PriorProblem> again = prior_problem(problem, L, d, s_fit);
  if (!again) return;
  Eigen::VectorXd t = theta;
  numerics::LevenbergMarquardt solver(*again);
  numerics::LevenbergMarquardt::Summary second = solver.Solve(options, t);
  if (!std::isfinite(second.cost)) return;
  for (numerics::LevenbergMarquardt::Step& st : second.log) st.iteration += lm.iterations;
  second.log.insert(second.log.begin(), lm.log.begin(), lm.log.end());
  second.iterations += lm.iterations;
  second.infeasible_trials += lm.infeasible_trials;
  lm = std::move(second);
  theta = t;
  *rescaled = std::move(again);
}

void check_sizes(const ParameterLayout& L, const Eigen::VectorXd& theta0, std::size_t n_samples,
                 const std::string& file) {
  const int nd = L.structural().size() + L.y0_per_run();
  if (nd > kMaxDerivatives)
    throw InputError(file, 0, fmt::format("{} model parameters; the output-error fitter "
                                          "handles at most {}", L.structural().size(),
                                          kMaxDerivatives - L.y0_per_run()));
  if (theta0.size() != L.size())
    throw std::logic_error("fit_output_error: start vector has the wrong size");
  if (static_cast<std::size_t>(L.size()) >= n_samples)
    throw InputError(file, 0, fmt::format("{} samples for {} output-error parameters: need more "
                                          "samples than parameters", n_samples, L.size()));
}

numerics::LevenbergMarquardt::Options solver_options(const FitOptions& o) {
  numerics::LevenbergMarquardt::Options lm;
  lm.max_iterations = o.max_iterations;
  lm.cost_tolerance = o.cost_tolerance;
  lm.step_tolerance = o.step_tolerance;
  lm.max_damping = o.max_damping;
  lm.sv_cutoff = o.sv_cutoff;
  return lm;
}

// The fit's termination for the solver's status (invalid options are refused before).
Termination termination_of(numerics::LevenbergMarquardt::Status s) {
  using Status = numerics::LevenbergMarquardt::Status;
  switch (s) {
    case Status::converged: return Termination::converged;
    case Status::iteration_limit: return Termination::iteration_limit;
    case Status::start_not_evaluable:
    case Status::jacobian_not_finite:
    case Status::damping_limit:
    case Status::invalid_options: return Termination::diverged;
  }
  return Termination::diverged;
}

// One line on what the solver did (fit.json's output_error message; empty when converged).
std::string solver_message(const numerics::LevenbergMarquardt::Summary& s,
                           const numerics::LevenbergMarquardt::Options& o) {
  using Status = numerics::LevenbergMarquardt::Status;
  switch (s.status) {
    case Status::converged: return "";
    case Status::iteration_limit:
      return fmt::format("iteration limit ({}) reached before convergence; best estimate kept", o.max_iterations);
    case Status::start_not_evaluable:
      return "the start point cannot be evaluated (non-finite residuals); nothing estimated";
    case Status::jacobian_not_finite: return "sensitivities became non-finite; best estimate kept";
    case Status::damping_limit:
      return "no damped Gauss-Newton step lowered the cost (damping above its limit); best estimate kept";
    case Status::invalid_options: return "solver options refused: " + s.options_error;
  }
  return "";
}

// Cramer-Rao bounds (white and colored) at the estimate, identifiability and the final
// message. res.theta is the estimate; cov are NaN where the information is missing.
// prior_information: diag(w_i^2) of the a priori values (PriorProblem::information), empty
// without; it is added to J'J (the posterior's information), and sum.cost is the data's part.
void estimate_covariance(const OutputErrorProblem& problem, const FitOptions& o, MLResult& res,
                         const Eigen::VectorXd& prior_information = {}) {
  OutputErrorSummary& sum = res.summary;
  Eigen::VectorXd v;
  Eigen::MatrixXd J;
  // Final sensitivities at the estimate (the solver's last Jacobian is at the previous point
  // when the last step was accepted).
  if (!problem.jacobian(res.theta, v, J)) {
    sum.termination = Termination::diverged;
    sum.message = "sensitivities are non-finite at the estimate";
    return;
  }
  problem.evaluate(res.theta, v, &res.y_model);
  const double s2 = v.squaredNorm() / static_cast<double>(v.size());
  sum.fit_error = std::sqrt(s2);
  numerics::Covariance info(static_cast<int>(J.cols()), numerics::Covariance::Options{o.sv_cutoff, 0.01});
  Eigen::MatrixXd information = J.transpose() * J;
  if (prior_information.size() == information.rows()) {
    information.diagonal() += prior_information;
    sum.cost = 0.5 * v.squaredNorm();
  }
  info.Compute(information);
  sum.rank = info.rank();
  // Cramer-Rao: M = J'J / s^2, bounds sqrt(diag(M^-1)).
  Eigen::MatrixXd cw = info.white(s2);
  sum.correlation_lag = choose_correlation_lag(v, problem.starts(), o);
  Eigen::MatrixXd cc =
      info.colored(numerics::Covariance::correlated_middle(J, v, problem.starts(), sum.correlation_lag));
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (Eigen::Index i = 0; i < cw.rows(); ++i) {
    if (!info.in_null_space(static_cast<int>(i))) continue;
    res.identifiability[static_cast<std::size_t>(i)] = Identifiability::not_identifiable;
    sum.unidentifiable.push_back(res.names[static_cast<std::size_t>(i)]);
    // Why NaN: a null-space direction has no finite variance; printing the pseudo-inverse's
    // number (or a huge one) would pretend to an accuracy that does not exist.
    cw.row(i).setConstant(nan);
    cw.col(i).setConstant(nan);
    cc.row(i).setConstant(nan);
    cc.col(i).setConstant(nan);
  }
  res.cov_white = cw;
  res.cov_colored = cc;
  if (!sum.unidentifiable.empty()) {
    std::string list;
    for (const auto& n : sum.unidentifiable) list += (list.empty() ? "" : ", ") + n;
    sum.message = fmt::format("information matrix is rank deficient (rank {} of {}); not "
                              "identifiable: {}{}", info.rank(), cw.rows(), list,
                              sum.message.empty() ? "" : "; " + sum.message);
    sum.termination = Termination::rank_deficient;
  } else if (sum.termination == Termination::converged) {
    sum.message = fmt::format("converged in {} iterations, s(v) = {:.4g}", sum.iterations,
                              sum.fit_error);
  }
}

// Why the start values cannot be propagated, naming the values (issue 12: an exit 4 must say
// which start value failed; what to do is the front end's to say, from
// OutputErrorSummary::start). Checks, in order: a non-finite start value, a
// lag decay rate not positive on the envelope (the b_j terms' start values), the first run
// without a periodic steady state or with a non-finite output.
std::string start_failure_message(const ParameterLayout& L, const OutputErrorData& d, const Eigen::VectorXd& theta,
                                  double lo, double hi) {
  const std::string what_to_do = "; nothing estimated";
  const std::vector<std::string> names = L.names();
  for (Eigen::Index k = 0; k < theta.size(); ++k)
    if (!std::isfinite(theta(k)))
      return fmt::format("the start value {} = {} is not finite (the equation-error regression failed){}",
                         names[static_cast<std::size_t>(k)], theta(k), what_to_do);
  const CoefficientModel<double, Cap> m = model_at(L, theta, d.known);
  for (int j = 0; j < m.n_lags; ++j) {
    const double lowest = min_lag_decay(m, j, lo, hi);
    if (lowest > 0.0) continue;
    std::string terms;
    for (std::size_t k = 0; k < names.size(); ++k) {
      const ParamId& id = L.ids()[k];
      if ((id.kind == ParamKind::b_power || id.kind == ParamKind::b_knot) && id.lag == j)
        terms += fmt::format("{}{} = {:.6g}", terms.empty() ? "" : ", ", names[k], theta(static_cast<Eigen::Index>(k)));
    }
    return fmt::format("the start values give b{}(x) <= 0 on the envelope (min {:.6g}; start values {}): the lag "
                       "does not decay, so the model cannot be propagated{}",
                       j + 1, lowest, terms, what_to_do);
  }
  const DelayTerm delay = L.structure().delay;
  for (std::size_t ri = 0; ri < d.runs.size(); ++ri) {
    const PreparedRun& r = d.runs[ri];
    double y[Cap::max_lags] = {};
    if (L.y0_offset(ri) < 0 && !periodic_state(m, r, delay, y))
      return fmt::format("the start values give no periodic steady state for run '{}' (the lag does not decay over "
                         "its cycle){}", r.path, what_to_do);
  }
  // Which start value: the first whose reset to 0 alone gives a finite output.
  const FeasibilityPredicate any;
  const OutputErrorProblem problem(L, d, any);
  Eigen::VectorXd v;
  for (Eigen::Index k = 0; k < theta.size(); ++k) {
    if (theta(k) == 0.0) continue;
    Eigen::VectorXd t = theta;
    t(k) = 0.0;
    if (problem.evaluate(t, v, nullptr))
      return fmt::format("the start value {} = {:.6g} gives a model with a non-finite output (too large: see the "
                         "equation error's estimates in fit.json){}",
                         names[static_cast<std::size_t>(k)], theta(k), what_to_do);
  }
  return "the start values give a model with a non-finite output (a start value too large: see the equation "
         "error's estimates in fit.json)" + what_to_do;
}

// Ten decays over the longest run, in its own time (b acts at V / V_ref on a run at V; a
// periodic cycle counts its closing step), in 1/s at V_ref: the second projection's floor.
double ten_decays_over_longest_run(const OutputErrorData& d) {
  double longest = 0.0;
  for (const PreparedRun& r : d.runs) {
    if (r.t.size() < 2) continue;
    const double span = r.t.back() - r.t.front() + (r.periodic ? r.wrap_step_s() : 0.0);
    longest = std::max(longest, span * r.time_scale);
  }
  return longest > 0.0 ? 10.0 / longest : 0.0;
}

// Where a projected b_j(x) starts: its minimum on the envelope raised to a tenth of max |b_j|
// (1 1/s if that is 0), or to at least ten decays over the longest run. fit_output_error runs
// the second too when it differs and keeps the lower cost. Why two: a tenth of max |b_j| is no
// decay at all when the equation error's b_j is ~0 everywhere -- on digitized C_m cycles (a
// user's trial, 2026-11-27) b1_0 = -0.0038 was projected to 0.00038 1/s, a time constant of
// 2600 s against cycles of 0.4-0.9 s; the LM, on the feasible set's boundary, took no step and
// stopped at its start ("converged", every stall parameter at its start value). From ten decays
// it reached s(v) 0.0280 against 0.0526 (from one decay, 0.0500). Ten decays alone is not
// better everywhere: on docs/validation-real.md's three-run C_m studies it reached another
// minimum (sweep C_m 0.08579 against 0.08576) and diagnose then took another path whose
// held-out error was higher (stall cycles at <= 0.5x quasi-steady 33 -> 28 of 163).
enum class DecayFloor { relative, ten_run_decays };

// Projects an infeasible start onto the feasible set: for every lag whose b_j(x) is not
// positive everywhere on the envelope, or below decay_floor (lag_decay_floor) somewhere, its
// constant term b_j_0 is raised until the minimum is the floor above (at least twice
// decay_floor, inside the feasible set). Why the constant term: it moves b_j(x) uniformly, the smallest change that
// restores b_j > 0 without reshaping the spline.
// A negative delay_s (a --start-value) is projected to 0, the runtime's limit.
// Returns what was done (empty when nothing), or why a lag could not be projected (no
// constant term in the structure).
std::string project_start(const ParameterLayout& L, const OutputErrorData& d, double lo, double hi,
                          DecayFloor choice, double decay_floor, Eigen::VectorXd& theta) {
  std::string said;
  const CoefficientModel<double, Cap> m = model_at(L, theta, d.known);
  for (int j = 0; j < m.n_lags; ++j) {
    const double lowest = min_lag_decay(m, j, lo, hi);
    if (lowest > 0.0 && lowest >= decay_floor) continue;
    ParamId c0;
    c0.kind = ParamKind::b_power;
    c0.lag = j;
    c0.power = 0;
    const int k = L.find(c0);
    if (k < 0 || !std::isfinite(lowest)) {
      said += fmt::format("{}the start has b{}(x) <= 0 on the envelope and no b{}_0 term to raise", said.empty() ? "" : "; ",
                          j + 1, j + 1);
      continue;
    }
    double largest = 0.0;
    for (int i = 0; i <= 64; ++i) largest = std::max(largest, std::fabs(spline_value(m.lags[j].b, lo + (hi - lo) * i / 64.0)));
    const double relative = largest > 0.0 ? 0.1 * largest : 1.0;
    const double floor = std::max(
        2.0 * decay_floor,
        choice == DecayFloor::relative ? relative : std::max(relative, ten_decays_over_longest_run(d)));
    const double before = theta(k);
    theta(k) += floor - lowest;
    const std::string why = lowest > 0.0 ? fmt::format("{:.6g} on the envelope, below {:.6g} 1/s (one decay over "
                                                       "the longest cycle)", lowest, decay_floor)
                                         : fmt::format("{:.6g} <= 0 on the envelope", lowest);
    said += fmt::format("{}start projected: b{}_0 raised from {:.6g} to {:.6g} (the equation-error start had "
                        "min b{}(x) = {})",
                        said.empty() ? "" : "; ", j + 1, before, theta(k), j + 1, why);
  }
  // A negative delay (a --start-value) is not a delay: projected to 0.
  const int kd = L.find(param_id(ParamKind::delay));
  if (kd >= 0 && !(theta(kd) >= 0.0)) {
    said += fmt::format("{}start projected: delay_s raised from {:.6g} to 0 (a delay is >= 0)", said.empty() ? "" : "; ",
                        theta(kd));
    theta(kd) = 0.0;
  }
  return said;
}

}  // namespace

double stall_prior_scale(const std::vector<PreparedRun>& runs) {
  double sum = 0.0;
  std::size_t n = 0;
  for (const PreparedRun& r : runs)
    for (double y : r.y_e) {
      sum += y * y;
      ++n;
    }
  return n > 0 ? 0.1 * std::sqrt(sum / static_cast<double>(n)) : 0.0;
}

CoefficientModel<double, Cap> model_at(const ParameterLayout& L, const Eigen::VectorXd& theta,
                                       const CoefficientModel<double, Cap>& known) {
  CoefficientModel<double, Cap> m = known;
  L.build_unsteady(theta.data(), m);
  L.add_output_terms(theta.data(), m);
  return m;
}

std::vector<double> stall_outputs(const CoefficientModel<double, Cap>& m, const PreparedRun& r,
                                  StallState<double>* initial) {
  return stall_output_series(m, r, initial);
}

bool output_error_residuals(const ParameterLayout& L, const OutputErrorData& d,
                            const Eigen::VectorXd& theta, Eigen::VectorXd& v) {
  const FeasibilityPredicate any;
  return OutputErrorProblem(L, d, any).residuals(theta, v);
}

bool output_error_jacobian(const ParameterLayout& L, const OutputErrorData& d,
                           const Eigen::VectorXd& theta, Eigen::VectorXd& v, Eigen::MatrixXd& J) {
  const FeasibilityPredicate any;
  return OutputErrorProblem(L, d, any).jacobian(theta, v, J);
}

ParameterEstimate MLResult::estimate(int i) const {
  const auto k = static_cast<std::size_t>(i);
  ParameterEstimate pe;
  pe.id = ids[k];
  pe.name = names[k];
  pe.value = theta(i);
  pe.cr_bound = std::sqrt(cov_white(i, i));
  pe.cr_bound_colored = std::sqrt(cov_colored(i, i));
  pe.identifiability = identifiability[k];
  return pe;
}

MLResult fit_output_error(const UnsteadyStructure& s, const OutputErrorData& d,
                          const Eigen::VectorXd& theta0, const FitOptions& o,
                          const FeasibilityPredicate& feasible) {
  check_capacity(s, d.context_file);
  const ParameterLayout L(s, d.runs);
  // Positive decay rates by construction (issue 12): a trial step to a model with b_j(x) <= 0
  // anywhere on the envelope (the runtime's own validation grid: runtime_limits.hpp
  // min_lag_decay), or below lag_decay_floor with periodic runs, is rejected like a cost
  // increase; an infeasible start is projected first.
  const double lo = d.envelope.min_rad, hi = d.envelope.max_rad;
  const double stall_limit = stall_time_constant_limit(d.runs);
  const double decay_floor = lag_decay_floor(d.runs);
  const FeasibilityPredicate decaying = [&](const CoefficientModel<double, Cap>& m) {
    // The runtime's feasible set of the stall families (positive time constants, f0 in [0, 1])
    // and of the delay (model_check.hpp: a delay >= 0, not a prediction; a negative one would
    // be estimated and then refused when model.coef is written).
    return lag_decay_above(m, lo, hi, decay_floor) && check_stall_parameters(m.stall) == StallCheck::valid &&
           m.delay_s >= 0.0 && (!feasible || feasible(m));
  };
  OutputErrorProblem problem(L, d, decaying, stall_limit);
  check_sizes(L, theta0, static_cast<std::size_t>(problem.num_residuals()), d.context_file);
  const std::unique_ptr<PriorProblem> with_prior = prior_problem(problem, L, d, stall_prior_scale(d.runs));
  const numerics::LeastSquaresProblem& solved =
      with_prior ? static_cast<const numerics::LeastSquaresProblem&>(*with_prior) : problem;
  MLResult res;
  res.structure = s;
  res.ids = L.ids();
  res.names = L.names();
  res.theta = theta0;
  project_stall_time_constants(L, stall_limit, res.theta);
  std::string projected = project_start(L, d, lo, hi, DecayFloor::relative, decay_floor, res.theta);
  const Eigen::VectorXd first_start = res.theta;  // (Solve moves res.theta to the estimate)
  const numerics::LevenbergMarquardt::Options lm_options = solver_options(o);
  numerics::LevenbergMarquardt solver(solved);
  numerics::LevenbergMarquardt::Summary lm = solver.Solve(lm_options, res.theta);
  // A projected start is a guess: the other projection too, when it differs (DecayFloor).
  Eigen::VectorXd other = theta0;
  const std::string other_projected = projected.empty() ? std::string()
                                                        : project_start(L, d, lo, hi, DecayFloor::ten_run_decays, decay_floor, other);
  project_stall_time_constants(L, stall_limit, other);
  if (!other_projected.empty() && other != first_start) {
    numerics::LevenbergMarquardt other_solver(solved);
    const numerics::LevenbergMarquardt::Summary other_lm = other_solver.Solve(lm_options, other);
    if (std::isfinite(other_lm.cost) && !(lm.cost <= other_lm.cost)) {
      lm = other_lm;
      res.theta = other;
      projected = other_projected;
    }
    projected += " (the other projected start, a tenth of max |b| or ten decays over the longest run, ended "
                 "at a higher cost)";
  }
  std::unique_ptr<PriorProblem> rescaled;  // (the first stays alive: the solvers above refer to it)
  if (with_prior) rescale_prior(problem, L, d, lm_options, &rescaled, lm, res.theta);
  const PriorProblem* final_prior = rescaled ? rescaled.get() : with_prior.get();
  if (lm.status == numerics::LevenbergMarquardt::Status::invalid_options)
    throw InputError(d.context_file, 0, "output-error solver options: " + lm.options_error);
  OutputErrorSummary& sum = res.summary;
  sum.n_samples = static_cast<std::size_t>(problem.num_residuals());
  sum.n_parameters = L.size();
  sum.termination = termination_of(lm.status);
  sum.iterations = lm.iterations;
  sum.cost = lm.cost;
  for (const numerics::LevenbergMarquardt::Step& st : lm.log)
    sum.log.push_back({st.iteration, st.cost, st.damping, st.max_step_in_bounds});
  sum.message = solver_message(lm, lm_options);
  sum.boundary = lm.boundary == numerics::LevenbergMarquardt::Boundary::active ? FeasibilityBoundary::active
                                                                                 : FeasibilityBoundary::interior;
  sum.infeasible_trials = lm.infeasible_trials;
  if (!projected.empty()) sum.message = projected + (sum.message.empty() ? "" : "; " + sum.message);
  const Eigen::Index P = L.size();
  res.cov_white = Eigen::MatrixXd::Constant(P, P, std::numeric_limits<double>::quiet_NaN());
  res.cov_colored = res.cov_white;
  res.identifiability.assign(static_cast<std::size_t>(P), Identifiability::identified);
  if (!std::isfinite(lm.cost)) {
    sum.start = StartOutcome::not_propagated;
    sum.message = start_failure_message(L, d, res.theta, lo, hi);
    if (!projected.empty()) sum.message = projected + "; " + sum.message;
    sum.fit_error = std::numeric_limits<double>::quiet_NaN();
    for (auto& id : res.identifiability) id = Identifiability::not_identifiable;
    return res;
  }
  estimate_covariance(problem, o, res, final_prior ? final_prior->information() : Eigen::VectorXd());
  // The covariance step words the final message; a projected start must stay in it.
  if (!projected.empty() && res.summary.message.find(projected) == std::string::npos)
    res.summary.message = projected + "; " + res.summary.message;
  return res;
}

}  // namespace indicial::fit_detail
