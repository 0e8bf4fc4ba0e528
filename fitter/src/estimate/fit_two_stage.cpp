// fit_two_stage.cpp -- the whole procedure (report Figure 1): equation error (stepwise when
// configured) for start values, ML output error, and -- when rotary.estimate = true -- the
// two-stage loop of eqs. 25-26; then the FitResult with the model, estimates and series.
#include <Eigen/Core>
#include <Eigen/QR>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fmt/format.h>
#include <string>
#include <limits>

#include "estimate/fit_internal.hpp"
#include "numerics/parallel_for.hpp"
#include "indicial/fitter/error.hpp"

namespace indicial {

namespace {

using namespace fit_detail;

void check_experiment(const Experiment& e) {
  if (e.runs.empty()) throw InputError(e.path, 0, "the experiment names no runs");
  if (!(e.airspeed_mps > 0.0) || !(e.reference_length_m > 0.0))
    throw InputError(e.path, 0, "airspeed_mps and reference_length_m must be positive");
  for (const Run& r : e.runs)
    if (r.size() < 3 || !(r.dt_s() > 0.0))
      throw InputError(r.path, 0, "run has fewer than 3 samples or a non-positive time step");
  const SplineConfig& rc = e.model.rotary_correction;
  if (e.rotary.estimate && rc.powers.size() + rc.knots_rad.size() > 0)
    throw InputError(e.path, 0, "rotary correction terms (diagnose's rotary_alpha) need "
                                "rotary.estimate = false: the two-stage loop owns C_aq otherwise");
  if (e.model.delay == DelayEstimation::estimated && !std::isfinite(e.model.delay_start_s))
    throw InputError(e.path, 0, "the delay's start value is not finite");
}

// The default start value of a parameter the equation error does not estimate.
// Why these defaults: a further lag starts faster than lag 1 (k times b1_0) with a small gain,
// so its sensitivities are non-zero and distinct from lag 1's at the start; y0 starts at y_E of
// the run's first sample (the other lags at rest).
// The dynamic-stall parameters start at the Beddoes-Leishman NACA 0012 constants (in semichord
// times l / V, so the same at every airspeed; experiment keys stall_*_start), C_N1 where the
// static separation falls below 0.7 (stall_polar.cpp), and the output terms at the form's own
// shape: a lift (CL) k0 = 1, c_v = 1; a moment (Cm) Beddoes-Leishman's K1 = -0.135,
// K2 = 0.04 and x_v = 0.4 (their x_cp,v); any other coefficient 0.
double default_start(const ParamId& id, double b1_0, const std::vector<PreparedRun>& runs,
                     const Experiment& e, const StallStructure& stall) {
  const bool lift = e.coefficient == "CL";
  const bool moment = e.coefficient == "Cm";
  const StallConfig& sc = e.model.stall;
  switch (id.kind) {
    case ParamKind::stall_tau1: return sc.tau1_start;
    case ParamKind::stall_tau2: return sc.tau2_start;
    // T1r starts at T1's start unless given: the model with one time constant both ways.
    case ParamKind::stall_tau1_reattach: return sc.tau1_reattach_start > 0.0 ? sc.tau1_reattach_start : sc.tau1_start;
    case ParamKind::stall_reattach_shift: return sc.reattach_shift_start_rad;
    case ParamKind::stall_lag_limit: return sc.lag_limit_start_rad;
    case ParamKind::stall_cp:
      return id.power == 0 ? (lift ? 1.0 : 0.0)
                           : !moment ? 0.0 : id.power == 1 ? -0.135 : 0.04;
    case ParamKind::shedding_threshold: return stall.shedding_threshold_start;
    case ParamKind::vortex_decay: return sc.decay_start;
    case ParamKind::vortex_travel: return sc.travel_start;
    case ParamKind::vortex_lift: return lift ? 1.0 : 0.0;
    case ParamKind::vortex_cp: return moment ? 0.4 : 0.0;
    default: break;
  }
  const double delay_start_s = e.model.delay_start_s;
  switch (id.kind) {
    case ParamKind::b_power:
      return id.lag > 0 && id.power == 0 ? 4.0 * std::abs(b1_0) * (id.lag + 1) : 0.0;
    case ParamKind::gain: return 0.1;
    case ParamKind::delay: return delay_start_s;
    case ParamKind::initial_state:
      return id.lag == 0 ? runs[static_cast<std::size_t>(id.run)].y_e.front() : 0.0;
    default: return 0.0;
  }
}

// The a priori values of the dynamic-stall parameters (FitOptions::stall_prior; docs/formats.md,
// "A priori values of the dynamic-stall parameters"): each at its default start (above), with
// the spread sigma: a time constant its own default (at least 1 l/V), C_N1 0.5, the output
// terms k0, k1, k2, c_v, x_v 1 (coefficient units per unit of the family's state: a lift's
// k0 ~ 1, a moment's centre-of-pressure terms within a chord). The f0 correction has none.
// Empty without families or with StallPrior::none.
std::vector<PriorTerm> stall_prior_terms(const Experiment& e, const FitOptions& o, const UnsteadyStructure& s,
                                         const std::vector<PreparedRun>& runs) {
  std::vector<PriorTerm> prior;
  if (o.stall_prior == StallPrior::none || s.stall.families == StallFamilies::none) return prior;
  // (default_start's b1_0 is for the further lags' starts only: any value serves here.)
  auto add = [&](const ParamId& id, double sigma) { prior.push_back({id, default_start(id, 1.0, runs, e, s.stall), sigma}); };
  for (ParamKind k : {ParamKind::stall_tau1, ParamKind::stall_tau2, ParamKind::stall_tau1_reattach,
                      ParamKind::vortex_decay, ParamKind::vortex_travel}) {
    const ParamId id = param_id(k);
    add(id, std::max(1.0, default_start(id, 1.0, runs, e, s.stall)));
  }
  add(param_id(ParamKind::shedding_threshold), 0.5);
  for (int k = 0; k < 3; ++k) add(param_id(ParamKind::stall_cp, 0, k), 1.0);
  add(param_id(ParamKind::vortex_lift), 1.0);
  add(param_id(ParamKind::vortex_cp), 1.0);
  return prior;
}

// Start vector for the ML step: the equation-error estimates by identity, defaults for the
// rest, then FitOptions::start_values (by name: converted here, once; an unknown name is an
// InputError).
Eigen::VectorXd start_values(const ParameterLayout& L, const std::vector<PreparedRun>& runs,
                             const std::vector<ParameterEstimate>& ee, const Experiment& e,
                             const FitOptions& o) {
  double b1_0 = 1.0;
  for (const auto& p : ee)
    if (p.id.kind == ParamKind::b_power && p.id.lag == 0 && p.id.power == 0) b1_0 = p.value;
  Eigen::VectorXd th = Eigen::VectorXd::Zero(L.size());
  for (int i = 0; i < L.size(); ++i) {
    const ParamId& id = L.ids()[static_cast<std::size_t>(i)];
    const auto it = std::find_if(ee.begin(), ee.end(), [&](const ParameterEstimate& p) { return p.id == id; });
    th(i) = it != ee.end() ? it->value : default_start(id, b1_0, runs, e, L.structure().stall);
  }
  const std::vector<std::string> names = L.names();
  for (const auto& [name, value] : o.start_values) {
    const auto it = std::find(names.begin(), names.end(), name);
    if (it == names.end()) {
      for (const auto& held : e.model.stall.known)
        if (held.first == name)
          throw InputError(e.path, 0, fmt::format("start value for {}: it is held at {} by model.stall_known, "
                                                  "not estimated", name, held.second));
      throw InputError(e.path, 0, fmt::format("start value for {}: the model has no such "
                                              "parameter", name));
    }
    th(it - names.begin()) = value;
  }
  return th;
}

// Why a stepwise fit falls back to the output-error stepwise (FitOptions::stepwise_fallback);
// empty when it does not. The rule: the regression selected no term, or its R^2 is below
// fallback_r_squared (the equation error explains little of y_E': a smoothed derivative of
// strongly colored or phase-averaged data, or dynamics outside the model class), so its
// selection and start values are not to be trusted, while the output error, which needs no
// derivative of the data, still is.
std::string fallback_reason(const Experiment& e, const FitOptions& o, const EquationErrorResult& ee) {
  if (e.model.structure != StructureMode::stepwise || o.stepwise_fallback == StepwiseFallback::off ||
      o.stepwise_refinement == StepwiseRefinement::output_error)
    return "";
  if (ee.stepwise.selected.empty())
    return fmt::format("the equation-error stepwise selected no term (F to enter {}); the output-error stepwise "
                       "selected the structure, starting from {}",
                       o.f_to_enter, ee.parameters.size() == 2 ? ee.parameters[0].name + " and " + ee.parameters[1].name
                                                               : std::string("the lowest a(x) and b1(x) terms"));
  if (ee.r_squared < o.fallback_r_squared)
    return fmt::format("the equation-error regression explains little (R^2 = {:.3g} < {}); the output-error "
                       "stepwise selected the structure, starting from the regression's",
                       ee.r_squared, o.fallback_r_squared);
  return "";
}

// ------------------------------------------------------------------------------------------
// The two-stage loop (eqs. 25-26).
// ------------------------------------------------------------------------------------------
SplineTerms rotary_pool(const Experiment& e) {
  SplineTerms rpool;
  rpool.powers = e.rotary.candidates.powers;
  rpool.knots_rad = e.rotary.candidates.knots_rad;
  std::sort(rpool.knots_rad.begin(), rpool.knots_rad.end());
  rpool.knot_power = e.rotary.candidates.knot_power;
  if (rpool.powers.empty() && rpool.knots_rad.empty()) {
    // Why: with no candidates configured, the pool is the powers of the a priori polynomial
    // (at least 0..2, the report's C_mq form).
    const int deg = std::max<int>(2, static_cast<int>(e.rotary.polynomial.size()) - 1);
    for (int i = 0; i <= deg; ++i) rpool.powers.push_back(i);
  }
  std::sort(rpool.powers.begin(), rpool.powers.end());
  return rpool;
}

// C_aq as a spline over the pool's shape, coefficients from `params` (by identity), 0 else.
SplineD rotary_spline(const SplineTerms& pool, const std::vector<ParameterEstimate>& params) {
  SplineD sp;
  shape_spline(pool, sp);
  for (const ParamId& t : rotary_terms(pool))
    for (const ParameterEstimate& p : params)
      if (p.id == t) {
        if (t.kind == ParamKind::rotary_power) sp.power_coef[t.power] = p.value;
        else sp.knot_coef[t.knot] = p.value;
      }
  return sp;
}

// Regression of z = C - C_a(x) - y_model on the C_aq candidates (eq. 26), stepwise; the
// regressors are the rotary output terms, from coefficient_output.
struct RotaryStage {
  SplineD rotary;
  std::vector<ParameterEstimate> params;
  StepwiseResult stepwise;
};

RotaryStage rotary_stage(const std::vector<PreparedRun>& runs, const MLResult& ml,
                         const SplineTerms& pool, const FitOptions& o,
                         const std::string& file) {
  const std::vector<ParamId> terms = rotary_terms(pool);
  std::vector<CoefficientModel<double, Cap>> unit;
  std::vector<std::string> names;
  for (const ParamId& t : terms) {
    unit.push_back(unit_output_model(t));
    names.push_back(parameter_name(t));
  }
  std::size_t n = 0;
  for (const auto& r : runs) n += r.x.size();
  Eigen::MatrixXd X(static_cast<Eigen::Index>(n), static_cast<Eigen::Index>(terms.size()));
  Eigen::VectorXd z(static_cast<Eigen::Index>(n));
  std::vector<std::size_t> starts{0};
  const double zero_state[Cap::max_lags] = {};
  Eigen::Index row = 0;
  for (std::size_t ri = 0; ri < runs.size(); ++ri) {
    const PreparedRun& r = runs[ri];
    for (std::size_t i = 0; i < r.x.size(); ++i, ++row) {
      z(row) = r.coef[i] - r.static_value[i] - ml.y_model[ri][i];  // eq. 25
      for (std::size_t j = 0; j < terms.size(); ++j)
        X(row, static_cast<Eigen::Index>(j)) =
            coefficient_output(unit[j], r.x[i], r.rate[i], r.l_over_v_s, zero_state);
    }
    starts.push_back(static_cast<std::size_t>(row));
  }
  refuse_zero_columns(X, names, file);
  RotaryStage st;
  const std::vector<int> idx = stepwise_select(X, z, starts, names, o, st.stepwise);
  if (!idx.empty()) {
    Eigen::MatrixXd Xs(X.rows(), static_cast<Eigen::Index>(idx.size()));
    std::vector<std::string> chosen;
    for (std::size_t k = 0; k < idx.size(); ++k) {
      Xs.col(static_cast<Eigen::Index>(k)) = X.col(idx[k]);
      chosen.push_back(names[static_cast<std::size_t>(idx[k])]);
    }
    const LinearFit f = least_squares(Xs, z, starts, chosen, o, file);
    for (std::size_t k = 0; k < idx.size(); ++k) {
      const auto kk = static_cast<Eigen::Index>(k);
      ParameterEstimate pe;
      pe.id = terms[static_cast<std::size_t>(idx[k])];
      pe.name = chosen[k];
      pe.value = f.beta(kk);
      pe.cr_bound = std::sqrt(f.cov_white(kk, kk));
      pe.cr_bound_colored = std::sqrt(std::max(0.0, f.cov_colored(kk, kk)));
      st.params.push_back(pe);
    }
  }
  st.rotary = rotary_spline(pool, st.params);  // nothing significant: C_aq = 0
  return st;
}

// Everything one fit_output_error call needs besides the structure.
struct FitContext {
  const Experiment& e;
  const FitOptions& o;
  CoefficientModel<double, Cap> base;  // static curve, the a priori C_aq
  AngleRange envelope;                 // the model's (base_model_set's) envelope
  MLResult fit(const UnsteadyStructure& s, const std::vector<PreparedRun>& runs,
               const SplineD& rotary, const Eigen::VectorXd& theta0) const {
    CoefficientModel<double, Cap> known = base;
    known.rotary = rotary;
    const std::vector<PriorTerm> prior = stall_prior_terms(e, o, s, runs);
    return fit_output_error(s, OutputErrorData{runs, known, e.path, envelope, &prior}, theta0, o);
  }
};

// The start vector of structure `s` from a previous fit (by identity), `extra` overriding.
Eigen::VectorXd carried_start(const UnsteadyStructure& s, const std::vector<PreparedRun>& runs,
                              const MLResult& from, const std::vector<ParameterEstimate>& extra) {
  const ParameterLayout L(s, runs);
  Eigen::VectorXd th = Eigen::VectorXd::Zero(L.size());
  for (std::size_t i = 0; i < from.ids.size(); ++i) {
    const int k = L.find(from.ids[i]);
    if (k >= 0) th(k) = from.theta(static_cast<Eigen::Index>(i));
  }
  for (const ParameterEstimate& p : extra) {
    const int k = L.find(p.id);
    if (k >= 0) th(k) = p.value;
  }
  return th;
}

struct TwoStageTrial {
  std::vector<PreparedRun> runs;  // y_E with the trial's C_aq
  MLResult ml;
  SplineD rotary;
  std::vector<ParameterEstimate> rotary_params;
};

// joint_ml: the regression picked the terms and start values; ML refines them with the rest.
TwoStageTrial joint_trial(const FitContext& c, const UnsteadyStructure& s,
                          const std::vector<PreparedRun>& runs, const MLResult& ml,
                          const SplineTerms& rpool, const RotaryStage& st) {
  UnsteadyStructure sr = s;
  sr.rotary = SplineTerms{{}, {}, rpool.knot_power};
  for (const ParameterEstimate& p : st.params) {
    if (p.id.kind == ParamKind::rotary_power) sr.rotary.powers.push_back(p.id.power);
    else sr.rotary.knots_rad.push_back(p.id.knot_rad);
  }
  std::sort(sr.rotary.powers.begin(), sr.rotary.powers.end());
  std::sort(sr.rotary.knots_rad.begin(), sr.rotary.knots_rad.end());
  TwoStageTrial t;
  t.runs = runs;
  t.ml = c.fit(sr, t.runs, st.rotary, carried_start(sr, runs, ml, st.params));
  // The estimated C_aq as a spline over the pool's shape, and y_E recomputed with it.
  const ParameterLayout::Range out = ParameterLayout(sr, runs).output();
  for (int k = out.begin; k < out.end; ++k) t.rotary_params.push_back(t.ml.estimate(k));
  t.rotary = rotary_spline(rpool, t.rotary_params);
  update_rotary(t.runs, t.rotary);
  return t;
}

// regression_only: C_aq fixed at the regression's estimate, ML on the rest.
TwoStageTrial regression_trial(const FitContext& c, const UnsteadyStructure& s,
                               const std::vector<PreparedRun>& runs, const MLResult& ml,
                               const RotaryStage& st) {
  TwoStageTrial t;
  t.runs = runs;
  update_rotary(t.runs, st.rotary);
  t.ml = c.fit(s, t.runs, st.rotary, ml.theta);
  t.rotary = st.rotary;
  t.rotary_params = st.params;
  return t;
}

TwoStageIteration iteration_log(int it, const TwoStageTrial& t, const RotaryStage& st) {
  TwoStageIteration log;
  log.iteration = it;
  log.cost = t.ml.summary.cost;
  log.fit_error = t.ml.summary.fit_error;
  log.rotary.assign(t.rotary.power_coef, t.rotary.power_coef + t.rotary.n_powers);
  log.rotary_knot_coef.assign(t.rotary.knot_coef, t.rotary.knot_coef + t.rotary.n_knots);
  log.rotary_parameters = t.rotary_params;
  log.stepwise = st.stepwise;
  return log;
}

// The state of the procedure that the two-stage loop advances.
struct Estimate {
  UnsteadyStructure s;
  std::vector<PreparedRun> runs;
  MLResult ml;
  SplineD rotary;                                 // the C_aq in effect
  std::vector<ParameterEstimate> rotary_params;   // regression_only: the regression's C_aq
};

void two_stage_loop(const FitContext& c, Estimate& est, std::vector<TwoStageIteration>& log) {
  const SplineTerms rpool = rotary_pool(c.e);
  for (int it = 1; it <= c.o.max_two_stage_iterations; ++it) {
    const RotaryStage st = rotary_stage(est.runs, est.ml, rpool, c.o, c.e.path);
    TwoStageTrial t = c.o.rotary_refinement == RotaryRefinement::joint_ml
                          ? joint_trial(c, est.s, est.runs, est.ml, rpool, st)
                          : regression_trial(c, est.s, est.runs, est.ml, st);
    log.push_back(iteration_log(it, t, st));
    const double prev = est.ml.summary.cost;
    if (!(t.ml.summary.cost < prev)) break;  // no improvement: keep the previous estimates
    est.runs = std::move(t.runs);
    est.ml = std::move(t.ml);
    est.rotary = t.rotary;
    // joint_ml: the rotary estimates are ML parameters already (in ml.ids).
    est.rotary_params = c.o.rotary_refinement == RotaryRefinement::joint_ml
                            ? std::vector<ParameterEstimate>{}
                            : t.rotary_params;
    if ((prev - est.ml.summary.cost) / prev < c.o.two_stage_tolerance) break;
  }
}

// The lowest finite cost among fits (0 when none is finite).
std::size_t lowest_cost(const std::vector<MLResult>& fits) {
  std::size_t best = 0;
  for (std::size_t k = 0; k < fits.size(); ++k)
    if (std::isfinite(fits[k].summary.cost) && !(fits[k].summary.cost >= fits[best].summary.cost)) best = k;
  return best;
}

// The grid's fits of structure s from theta0's grid (the first from theta0 itself unless
// `first` holds it already), in parallel (c.o.threads).
std::vector<MLResult> fit_stall_grid(const FitContext& c, const Estimate& est, const UnsteadyStructure& s,
                                     const std::vector<StallStartGridPoint>& grid, MLResult* first) {
  std::vector<MLResult> fits(grid.size());
  const std::size_t skip = first ? 1 : 0;
  if (first) fits[0] = std::move(*first);
  detail::parallel_for(grid.size() - skip, c.o.threads,
                       [&](std::size_t k) { fits[k + skip] = c.fit(s, est.runs, est.rotary, grid[k + skip].theta); });
  return fits;
}

// A sub-model's parameters (layout Ls) read from the full model's vector theta (layout L), by
// parameter id; and written back into it (embed_into). Every id of Ls is in L (a sub-model
// drops parameters, it adds none).
Eigen::VectorXd restrict_to(const ParameterLayout& Ls, const ParameterLayout& L, const Eigen::VectorXd& theta) {
  Eigen::VectorXd sub(Ls.size());
  for (int i = 0; i < Ls.size(); ++i) sub(i) = theta(L.find(Ls.ids()[static_cast<std::size_t>(i)]));
  return sub;
}

void embed_into(const ParameterLayout& Ls, const Eigen::VectorXd& theta_sub, const ParameterLayout& L,
                Eigen::VectorXd* theta) {
  for (int i = 0; i < Ls.size(); ++i) (*theta)(L.find(Ls.ids()[static_cast<std::size_t>(i)])) = theta_sub(i);
}

// A start from a nested sub-model (the symmetric one, the constant-coefficient one, below): the
// sub-model `sub` fitted from its own grid (its start theta0's values by parameter id), and the
// full model's start from its best fit: the sub-model's estimates by id, every other parameter
// at `others`' value. False when no grid fit propagated (*start untouched).
bool nested_start(const FitContext& c, const Estimate& est, const ParameterLayout& L, const Eigen::VectorXd& theta0,
                  const UnsteadyStructure& sub, const Eigen::VectorXd& others, Eigen::VectorXd* start,
                  std::string* said) {
  const ParameterLayout Ls(sub, est.runs);
  const std::vector<MLResult> fits = fit_stall_grid(c, est, sub, stall_start_grid(Ls, restrict_to(Ls, L, theta0)), nullptr);
  const MLResult& best = fits[lowest_cost(fits)];
  if (!std::isfinite(best.summary.cost) || best.theta.size() != Ls.size()) return false;
  *start = others;
  embed_into(Ls, best.theta, L, start);
  *said = fmt::format("{} grid starts, s(v) = {:.6g}", fits.size(), best.summary.fit_error);
  return true;
}

// The trial of a nested start that could not be made: *fit's cost NaN, `why` its origin.
StallStartTrial failed_trial(const char* why, MLResult* fit) {
  fit->summary.cost = fit->summary.fit_error = std::numeric_limits<double>::quiet_NaN();
  StallStartTrial trial;
  trial.fit_error = fit->summary.fit_error;
  trial.origin = why;
  return trial;
}

// With T1r estimated (stall_reattachment = "estimated"): the model nests the symmetric one
// (T1r = T1 is the same model), yet a fit from the grid alone can end above the symmetric
// model's (measured: the Glasgow C_m fit cycles of tools/validate_stall.py, 0.0342 against
// 0.0312). So the symmetric model is fitted from its own grid (the same points without T1r)
// and one more start is its best fit with T1r = its T1: the kept fit can then not end above
// the symmetric fit. Costs one grid more. Returns the trial; *fit is its fit.
StallStartTrial nested_symmetric_trial(const FitContext& c, const Estimate& est, const ParameterLayout& L,
                                       const Eigen::VectorXd& theta0, MLResult* fit) {
  UnsteadyStructure sym = est.s;
  sym.stall.reattachment = StallReattachment::as_separation;
  Eigen::VectorXd start;
  std::string said;
  const int t1 = L.find(param_id(ParamKind::stall_tau1));
  if (t1 < 0 || !nested_start(c, est, L, theta0, sym, theta0, &start, &said))
    return failed_trial("the symmetric model's fit (no T1r) did not propagate from any grid point", fit);
  start(L.find(param_id(ParamKind::stall_tau1_reattach))) = start(t1);
  *fit = c.fit(est.s, est.runs, est.rotary, start);
  StallStartTrial trial;
  trial.start = {{"T1r", start(t1)}};
  trial.fit_error = fit->summary.fit_error;
  trial.origin = fmt::format("from the symmetric model's best fit (no T1r, {}), T1r = its T1", said);
  return trial;
}

// The constant-coefficient sub-model of s: a(x) and b1(x) cut to their first term (a0, b1_0
// as configured); everything else (the stall families, con, the rotary and static corrections,
// further lags, the delay) as in s. Nested: s with the cut terms at 0 is this model. False when
// nothing is cut (a and b1 have one term each).
bool constant_submodel(const UnsteadyStructure& s, UnsteadyStructure* sub) {
  auto cut = [](const SplineTerms& t) {
    SplineTerms one{{}, {}, t.knot_power};
    if (!t.powers.empty()) one.powers.push_back(t.powers.front());
    else if (!t.knots_rad.empty()) one.knots_rad.push_back(t.knots_rad.front());
    return one;
  };
  const auto terms = [](const SplineTerms& t) { return t.powers.size() + t.knots_rad.size(); };
  if (terms(s.a) <= 1 && terms(s.b[0]) <= 1) return false;
  *sub = s;
  sub->a = cut(s.a);
  sub->b[0] = cut(s.b[0]);
  return true;
}

// With stall families and a(x) or b1(x) of more than one term: the model nests its constant-
// coefficient sub-model (constant_submodel), yet its fit from the grid can end above that
// sub-model's. Measured: tools/validate_stall.py's extended C_m model (a(x) of degree 2 with
// knots at 12 and 16 deg, b1 constant) on its 104 fit cycles ended at s(v) 0.03677 with its lag
// at the decay floor, where the same model with a constant a(x) reached 0.03172 (held out: 0.95x
// against 0.75x the Beddoes-Leishman peer's error). So one more start is the sub-model's best
// fit (nested_start) with the cut terms at 0: the kept fit can then not end above the
// sub-model's. Costs one grid of the smaller model. Returns the trial; *fit is its fit.
StallStartTrial nested_constant_trial(const FitContext& c, const Estimate& est, const ParameterLayout& L,
                                      const Eigen::VectorXd& theta0, const UnsteadyStructure& sub, MLResult* fit) {
  Eigen::VectorXd start;
  std::string said;
  if (!nested_start(c, est, L, theta0, sub, Eigen::VectorXd::Zero(L.size()), &start, &said))
    return failed_trial("the constant-coefficient model's fit (a(x), b1(x) cut to their first term) did not "
                        "propagate from any grid point", fit);
  *fit = c.fit(est.s, est.runs, est.rotary, start);
  StallStartTrial trial;
  trial.fit_error = fit->summary.fit_error;
  trial.origin = fmt::format("from the constant-coefficient model's best fit (a(x), b1(x) cut to their first term, "
                             "{}), the cut terms at 0", said);
  return trial;
}

void search_stall_starts(const FitContext& c, Estimate& est, const Eigen::VectorXd& theta0,
                         StallStartSearchResult& out);

// A parameter the model nests away (dxr = 0 is the model without the hysteresis; D at its
// bound is nearly the model without the lag limit), of the start from the model without it:
// that model (`sub`, layout Ls) gets the whole search (search_stall_starts, its nested trials
// included) and one more start is its best fit with the parameter `kind` at `value`: the kept
// fit can then not end above that search but for what the parameter's start moves. Costs that
// search. `what` names what the sub-model lacks ("the hysteresis"). Returns the trial; *fit is its fit.
StallStartTrial nested_without_trial(const FitContext& c, const Estimate& est, const ParameterLayout& L,
                                     const Eigen::VectorXd& theta0, Estimate sub, ParamKind kind, double value,
                                     const char* what, MLResult* fit) {
  const ParameterLayout Ls(sub.s, sub.runs);
  const Eigen::VectorXd theta0_sub = restrict_to(Ls, L, theta0);
  sub.ml = c.fit(sub.s, sub.runs, sub.rotary, theta0_sub);
  StallStartSearchResult sub_search;
  search_stall_starts(c, sub, theta0_sub, sub_search);
  if (!std::isfinite(sub.ml.summary.cost) || sub.ml.theta.size() != Ls.size())
    return failed_trial(fmt::format("the model's fit without {} did not propagate from any start", what).c_str(), fit);
  Eigen::VectorXd start = theta0;
  embed_into(Ls, sub.ml.theta, L, &start);
  const std::string name = parameter_name(param_id(kind));
  start(L.find(param_id(kind))) = value;
  *fit = c.fit(est.s, est.runs, est.rotary, start);
  StallStartTrial trial;
  trial.start = {{name, value}};
  trial.fit_error = fit->summary.fit_error;
  trial.origin = fmt::format("from the best fit without {} (no {}, {} starts, s(v) = {:.6g}), {} = {:g} rad", what, name,
                             sub_search.trials.size(), sub.ml.summary.fit_error, name, value);
  return trial;
}

// With dxr estimated (stall_hysteresis = "estimated"): the model nests the one without the
// hysteresis (dxr = 0), yet a fit from the grid alone can end far above it (measured: the
// Glasgow C_m fit cycles of tools/validate_stall.py, s(v) 0.0376 with dxr -> 1.7e-7 against
// 0.0313 without; and a start from the sub-model's grid alone, without its own nested trials,
// 0.0368). So one more start is the model without it (its whole search) with dxr =
// kHysteresisNestedStartRad (nested_without_trial).
StallStartTrial nested_hysteresis_trial(const FitContext& c, const Estimate& est, const ParameterLayout& L,
                                        const Eigen::VectorXd& theta0, MLResult* fit) {
  Estimate sub = est;
  sub.s.stall.hysteresis = StallHysteresis::none;
  return nested_without_trial(c, est, L, theta0, std::move(sub), ParamKind::stall_reattach_shift,
                              kHysteresisNestedStartRad, "the hysteresis", fit);
}

// With D estimated (stall_lag_limit = "estimated"): the model nests the one without the limit
// (D -> infinity), yet a fit from the grid alone can end far above it (measured:
// tools/validate_stall.py's extended C_m model on its 104 fit cycles ended at D = 20 deg,
// s(v) 0.0391, against 0.0313 without D). So one more start is the model without it (its whole
// search) with D = kLagLimitNestedStartRad (nested_without_trial).
StallStartTrial nested_lag_limit_trial(const FitContext& c, const Estimate& est, const ParameterLayout& L,
                                       const Eigen::VectorXd& theta0, MLResult* fit) {
  Estimate sub = est;
  sub.s.stall.lag_limit = StallLagLimit::none;
  return nested_without_trial(c, est, L, theta0, std::move(sub), ParamKind::stall_lag_limit, kLagLimitNestedStartRad,
                              "the lag limit", fit);
}

// The stall start grid (FitOptions::stall_start_search): est.ml, the fit from the configured
// start theta0, is replaced by the lowest-cost fit of the grid's starts (fitted in parallel,
// c.o.threads), with T1r of the start from the symmetric fit (nested_symmetric_trial), with dxr
// of the start from the fit without the hysteresis (nested_hysteresis_trial), with D of the
// start from the fit without the lag limit (nested_lag_limit_trial), and with
// a(x) or b1(x) of several terms of the start from the constant-coefficient fit
// (nested_constant_trial); every trial is recorded in `out`.
void search_stall_starts(const FitContext& c, Estimate& est, const Eigen::VectorXd& theta0,
                         StallStartSearchResult& out) {
  const ParameterLayout L(est.s, est.runs);
  if (!stall_start_search_runs(L, c.o)) return;
  const std::vector<StallStartGridPoint> grid = stall_start_grid(L, theta0);
  std::vector<MLResult> fits = fit_stall_grid(c, est, est.s, grid, &est.ml);
  for (std::size_t k = 0; k < grid.size(); ++k) out.trials.push_back({grid[k].varied, fits[k].summary.fit_error, ""});
  if (L.find(param_id(ParamKind::stall_tau1_reattach)) >= 0) {
    fits.emplace_back();
    out.trials.push_back(nested_symmetric_trial(c, est, L, theta0, &fits.back()));
  }
  if (L.find(param_id(ParamKind::stall_reattach_shift)) >= 0) {
    fits.emplace_back();
    out.trials.push_back(nested_hysteresis_trial(c, est, L, theta0, &fits.back()));
  }
  if (L.find(param_id(ParamKind::stall_lag_limit)) >= 0) {
    fits.emplace_back();
    out.trials.push_back(nested_lag_limit_trial(c, est, L, theta0, &fits.back()));
  }
  if (UnsteadyStructure sub; constant_submodel(est.s, &sub)) {
    fits.emplace_back();
    out.trials.push_back(nested_constant_trial(c, est, L, theta0, sub, &fits.back()));
  }
  const std::size_t best = lowest_cost(fits);
  out.chosen = static_cast<int>(best);
  est.ml = std::move(fits[best]);
}

// ------------------------------------------------------------------------------------------
// The simple start of the output-error stepwise.
// ------------------------------------------------------------------------------------------
// Why: the output-error stepwise (the fallback, or --stepwise-refinement output_error) refines
// an ML fit; when the regression's start values (or a --start-value) give a model whose output
// is not finite, there is nothing to refine. A plain first-order lag always propagates: the
// pool's lowest a(x) and b1(x) terms (a0 and b1_0 when offered; fallback_start_columns), no
// other a(x), b1(x) or con term, the parameters the stepwise does not select (further lags,
// delay, initial states) at their defaults (default_start), no --start-value. Its values: the
// equation-error least squares of the two terms alone; when that b1 is not positive or a value
// is not finite, b1 = 2 V / l (one decay per unit of reduced time 2 V t / l: faster than the
// Wagner function's poles, 0.09 and 0.6 V / l, so the lag starts near quasi-steady and the ML
// slows it) and the a(x) term by least squares with that b1 held.
struct SimpleStart {
  UnsteadyStructure s;
  Eigen::VectorXd theta0;
  std::string said;  // e.g. "a0 = 0.0123, b1_0 = 2.47 (least squares of a first-order lag)"
};

// False when the pool offers no a(x) or no b1(x) term.
bool simple_start(const FitContext& c, const UnsteadyStructure& pool, const std::vector<PreparedRun>& runs,
                  SimpleStart& out) {
  std::vector<ParamId> lowest;
  for (const ParamId& t : structural_terms(pool))
    if (t.kind == ParamKind::a_power || t.kind == ParamKind::a_knot ||
        ((t.kind == ParamKind::b_power || t.kind == ParamKind::b_knot) && t.lag == 0))
      lowest.push_back(t);
  const std::vector<int> cols = fallback_start_columns(lowest);
  if (cols.empty()) return false;
  out.s = select_terms(pool, {lowest[static_cast<std::size_t>(cols[0])], lowest[static_cast<std::size_t>(cols[1])]});
  const EquationErrorProblem p = equation_error_problem(runs, out.s, c.o);
  const bool a_first = p.terms[0].kind == ParamKind::a_power || p.terms[0].kind == ParamKind::a_knot;
  const Eigen::VectorXd xa = p.X.col(a_first ? 0 : 1), xb = p.X.col(a_first ? 1 : 0);
  const Eigen::VectorXd beta = p.X.colPivHouseholderQr().solve(p.z);
  double a = beta(a_first ? 0 : 1), b1 = beta(a_first ? 1 : 0);
  const char* how = "least squares of a first-order lag";
  if (!(std::isfinite(a) && std::isfinite(b1) && b1 > 0.0)) {
    b1 = 2.0 * c.e.airspeed_mps / c.e.reference_length_m;
    const double xx = xa.squaredNorm();
    a = xx > 0.0 ? xa.dot(p.z - b1 * xb) / xx : 0.0;
    if (!std::isfinite(a)) a = 0.0;
    how = "b1 = 2 V / l, the a(x) term by least squares";
  }
  const ParameterLayout L(out.s, runs);
  out.theta0 = Eigen::VectorXd::Zero(L.size());
  for (int i = 0; i < L.size(); ++i) {
    const ParamId& id = L.ids()[static_cast<std::size_t>(i)];
    out.theta0(i) = id == p.terms[a_first ? 0 : 1]   ? a
                    : id == p.terms[a_first ? 1 : 0] ? b1
                                                     : default_start(id, b1, runs, c.e, out.s.stall);
  }
  out.said = fmt::format("{} = {:.6g}, {} = {:.6g} ({})", p.names[a_first ? 0 : 1], a, p.names[a_first ? 1 : 0], b1, how);
  return true;
}

// Replaces est.ml, whose start cannot be propagated, by the ML fit from the simple start; says
// what it did in `fallback` (FitResult::stepwise_fallback). When the simple start fails too,
// est.ml stays (its message names the start value that failed) with the simple start's failure
// appended, and the fit ends with exit 4.
void restart_simply(const FitContext& c, const UnsteadyStructure& pool, Estimate& est, std::string& fallback) {
  const std::string first = est.ml.summary.message.substr(0, est.ml.summary.message.find("; nothing estimated"));
  SimpleStart ss;
  std::string failed = "the pool offers no a(x) or b1(x) term";
  if (simple_start(c, pool, est.runs, ss)) {
    MLResult ml = c.fit(ss.s, est.runs, est.rotary, ss.theta0);
    if (std::isfinite(ml.summary.cost)) {
      fallback += fmt::format("{}the start values cannot be propagated ({}); the output-error stepwise started "
                              "from the simple start {}",
                              fallback.empty() ? "" : "; ", first, ss.said);
      est.ml = std::move(ml);
      est.s = est.ml.structure;
      return;
    }
    failed = ml.summary.message.substr(0, ml.summary.message.find("; nothing estimated"));
  }
  est.ml.summary.message += fmt::format("; the simple start{} failed too: {}", ss.said.empty() ? "" : " " + ss.said, failed);
  fallback += fmt::format("{}NOT run: the start values cannot be propagated, nor the simple start (see the output "
                          "error's message)", fallback.empty() ? "" : "; ");
}

// ------------------------------------------------------------------------------------------
// The result.
// ------------------------------------------------------------------------------------------
// Estimates in output order -- structural, the regression's rotary terms, then the ML output
// terms and initial states -- and their covariance (the rotary regression's terms: their own
// variance only, no cross terms with the ML block).
void assemble_parameters(const Estimate& est, FitResult& res) {
  const MLResult& ml = est.ml;
  const int ns = ParameterLayout(ml.structure, est.runs).structural().size();
  const auto P = static_cast<Eigen::Index>(ml.ids.size());
  std::vector<Eigen::Index> ml_index;  // per output position: ML index, -1 for the regression's
  for (Eigen::Index i = 0; i < ns; ++i) ml_index.push_back(i);
  for (std::size_t k = 0; k < est.rotary_params.size(); ++k) ml_index.push_back(-1);
  for (Eigen::Index i = ns; i < P; ++i) ml_index.push_back(i);
  const auto total = static_cast<Eigen::Index>(ml_index.size());
  res.covariance = Eigen::MatrixXd::Zero(total, total);
  res.covariance_colored = Eigen::MatrixXd::Zero(total, total);
  std::size_t next_rotary = 0;
  for (Eigen::Index ix : ml_index)
    res.parameters.push_back(ix >= 0 ? ml.estimate(static_cast<int>(ix))
                                     : est.rotary_params[next_rotary++]);
  for (Eigen::Index a = 0; a < total; ++a)
    for (Eigen::Index b = 0; b < total; ++b) {
      const Eigen::Index ia = ml_index[static_cast<std::size_t>(a)];
      const Eigen::Index ib = ml_index[static_cast<std::size_t>(b)];
      if (ia >= 0 && ib >= 0) {
        res.covariance(a, b) = ml.cov_white(ia, ib);
        res.covariance_colored(a, b) = ml.cov_colored(ia, ib);
      } else if (ia < 0 && ib < 0 && a == b) {
        const auto& rp = res.parameters[static_cast<std::size_t>(a)];
        res.covariance(a, b) = rp.cr_bound * rp.cr_bound;
        res.covariance_colored(a, b) = rp.cr_bound_colored * rp.cr_bound_colored;
      }
    }
}

// The fitted coefficient model: the known part, C_aq in effect, and everything ML estimated.
CoefficientModel<double, Cap> final_model(const Estimate& est,
                                          const CoefficientModel<double, Cap>& base) {
  CoefficientModel<double, Cap> known = base;
  known.rotary = est.rotary;
  const ParameterLayout L(est.ml.structure, est.runs);
  CoefficientModel<double, Cap> cm = model_at(L, est.ml.theta, known);
  // The two-stage loop's C_aq is written over its candidate pool's shape (est.rotary holds the
  // same values as the ML terms).
  if (est.ml.structure.rotary.size() > 0 &&
      est.ml.structure.rotary_role == RotaryRole::replaces_a_priori)
    cm.rotary = est.rotary;
  return cm;
}

std::vector<RunSeries> run_series(const Estimate& est, const CoefficientModel<double, Cap>& cm) {
  const UnsteadyStructure& s = est.ml.structure;
  // Diagnose's extensions (correcting rotary terms, static correction) are part of the
  // quasi-steady curve and of y_E (eq. 12).
  const bool extended = (s.rotary.size() > 0 && s.rotary_role == RotaryRole::corrects_a_priori) ||
                        s.static_corr.size() > 0;
  std::vector<RunSeries> out;
  for (std::size_t ri = 0; ri < est.runs.size(); ++ri) {
    const PreparedRun& r = est.runs[ri];
    RunSeries rs;
    rs.path = r.path;
    rs.time_s = r.t;
    rs.x_rad = r.x;
    rs.rate_radps = r.rate;
    rs.measured = r.coef;
    rs.y_measured = r.y_e;
    const std::size_t n = r.x.size();
    stall_outputs(cm, r, &rs.stall_initial);
    rs.y_model = est.ml.y_model.empty()
                     ? std::vector<double>(n, std::numeric_limits<double>::quiet_NaN())
                     : est.ml.y_model[ri];
    rs.model.resize(n);
    rs.quasi_steady.resize(n);
    rs.residual.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      rs.quasi_steady[i] = r.static_value[i] + r.rotary_value[i];
      if (extended) {
        rs.quasi_steady[i] = quasi_steady_output(cm, r.x[i], r.rate[i], r.l_over_v_s);
        rs.y_measured[i] = r.coef[i] - rs.quasi_steady[i];
      }
      rs.model[i] = rs.quasi_steady[i] + rs.y_model[i];
      rs.residual[i] = rs.measured[i] - rs.model[i];
    }
    out.push_back(std::move(rs));
  }
  return out;
}

}  // namespace

FitResult fit_experiment(const Experiment& e, const FitOptions& o) {
  const auto t_start = std::chrono::steady_clock::now();
  if (std::string bad; !o.IsValid(&bad)) throw InputError(bad);  // first, as Ceres' Solve
  check_experiment(e);
  FitResult res;
  ModelSet<double, Cap> model = base_model_set(e);
  const FitContext c{e, o, model.coefficients[0], AngleRange{model.x_min_rad, model.x_max_rad}};
  Estimate est;
  est.runs = prepare_runs(e, model);
  est.rotary = c.base.rotary;

  // 1-2. Equation error (stepwise when configured): structure and start values.
  const UnsteadyStructure pool = structure_from_config(e.model);
  res.equation_error = run_equation_error(est.runs, pool, e.model.structure, o, e.path, est.s);

  // 3. ML output error.
  const Eigen::VectorXd theta0 =
      start_values(ParameterLayout(est.s, est.runs), est.runs, res.equation_error.parameters, e, o);
  est.ml = c.fit(est.s, est.runs, est.rotary, theta0);
  search_stall_starts(c, est, theta0, res.stall_start_search);
  res.stepwise_fallback = fallback_reason(e, o, res.equation_error);
  const bool refine = e.model.structure == StructureMode::stepwise &&
                      (o.stepwise_refinement == StepwiseRefinement::output_error || !res.stepwise_fallback.empty());
  if (refine && !std::isfinite(est.ml.summary.cost)) restart_simply(c, pool, est, res.stepwise_fallback);
  if (refine && std::isfinite(est.ml.summary.cost)) {
    const std::vector<PriorTerm> prior = stall_prior_terms(e, o, pool, est.runs);
    const OutputErrorData d{est.runs, c.base, e.path, c.envelope, &prior};
    est.ml = refine_structure_output_error(pool, d, std::move(est.ml), o, &res.output_error_stepwise);
    est.s = est.ml.structure;
  }

  // 4. Two-stage loop.
  if (e.rotary.estimate && std::isfinite(est.ml.summary.cost)) two_stage_loop(c, est, res.two_stage);

  // 5. The result.
  CoefficientModel<double, Cap>& cm = model.coefficients[0];
  cm = final_model(est, c.base);
  res.model = model;
  res.output_error = est.ml.summary;
  res.fit_error = est.ml.summary.fit_error;
  assemble_parameters(est, res);
  res.runs = run_series(est, cm);
  res.elapsed_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  return res;
}

FunctionBand function_band(const FitResult& r, ModelFunction f, double x_rad, BoundKind kind) {
  const CoefficientModel<double, FitCapacity>& cm = r.model.coefficients[0];
  const auto& sp = f == ModelFunction::a ? cm.a : f == ModelFunction::b1 ? cm.lags[0].b : cm.rotary;
  auto in_function = [f](const ParamId& id) {
    switch (f) {
      case ModelFunction::a: return id.kind == ParamKind::a_power || id.kind == ParamKind::a_knot;
      case ModelFunction::b1:
        return (id.kind == ParamKind::b_power || id.kind == ParamKind::b_knot) && id.lag == 0;
      case ModelFunction::rotary:
        return id.kind == ParamKind::rotary_power || id.kind == ParamKind::rotary_knot;
    }
    return false;
  };
  FunctionBand band;
  band.value = spline_value(sp, x_rad);
  const auto P = static_cast<Eigen::Index>(r.parameters.size());
  Eigen::VectorXd g = Eigen::VectorXd::Zero(P);
  for (Eigen::Index i = 0; i < P; ++i) {
    const ParamId& id = r.parameters[static_cast<std::size_t>(i)].id;
    if (in_function(id)) g(i) = basis_value<double>(term_basis(id), x_rad);
  }
  const Eigen::MatrixXd& C = kind == BoundKind::white ? r.covariance : r.covariance_colored;
  double var = 0.0;
  for (Eigen::Index i = 0; i < P; ++i)
    for (Eigen::Index j = 0; j < P; ++j)
      if (g(i) != 0.0 && g(j) != 0.0) var += g(i) * C(i, j) * g(j);
  band.sigma = std::sqrt(std::max(0.0, var));
  return band;
}

}  // namespace indicial
