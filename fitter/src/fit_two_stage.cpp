// fit_two_stage.cpp -- the whole procedure (report Figure 1): equation error (stepwise when
// configured) for start values, ML output error, and -- when rotary.estimate = true -- the
// two-stage loop of eqs. 25-26; then the FitResult with the model, estimates and series.
#include <Eigen/Core>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fmt/format.h>
#include <limits>

#include "fit_internal.hpp"
#include "indicial/fitter/error.hpp"

namespace indicial {

namespace {

using namespace fit_detail;

double plus_pow(double u, int p) {
  if (!(u > 0.0)) return 0.0;
  double r = 1.0;
  for (int i = 0; i < p; ++i) r *= u;
  return r;
}

// Start vector for the ML step from the equation-error estimates (by name), further lags'
// defaults, and y0 = y_E at each run's first sample.
Eigen::VectorXd start_values(const UnsteadyStructure& s, const std::vector<PreparedRun>& runs,
                             const std::vector<ParameterEstimate>& ee, double delay_start_s) {
  const std::vector<std::string> names = parameter_names(s, runs);
  Eigen::VectorXd th = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(names.size()));
  double b1_0 = 1.0;
  for (const auto& p : ee)
    if (p.name == "b1_0") b1_0 = p.value;
  for (std::size_t i = 0; i < names.size(); ++i) {
    const std::string& n = names[i];
    double v = 0.0;
    bool found = false;
    for (const auto& p : ee)
      if (p.name == n) {
        v = p.value;
        found = true;
      }
    if (!found) {
      // Why these defaults: a further lag starts faster than lag 1 (k times b1_0) with a small
      // gain, so its sensitivities are non-zero and distinct from lag 1's at the start.
      if (n.size() > 1 && n[0] == 'b' && n[1] != '1' && n.back() == '0' && n.find('_') != std::string::npos)
        v = 4.0 * std::abs(b1_0) * (n[1] - '0');
      else if (n.size() > 1 && n[0] == 'c') v = 0.1;
      else if (n == "delay_s") v = delay_start_s;
    }
    th(static_cast<Eigen::Index>(i)) = v;
  }
  // y0 follow the structural and the jointly estimated output terms (rotary, static).
  std::size_t k = static_cast<std::size_t>(s.n_struct()) + s.rotary.size() + s.static_corr.size();
  for (const PreparedRun& r : runs) {
    if (r.periodic) continue;
    th(static_cast<Eigen::Index>(k)) = r.y_e.front();
    k += static_cast<std::size_t>(s.y0_per_run());
  }
  return th;
}

// Regression of z = C - C_a(x) - y_model on the C_aq candidates (eq. 26), stepwise.
struct RotaryStage {
  SplineD rotary;
  std::vector<ParameterEstimate> params;
  StepwiseResult stepwise;
};

RotaryStage rotary_stage(const std::vector<PreparedRun>& runs, const MLResult& ml,
                         const SplineTerms& pool, double l_over_v, const FitOptions& o,
                         const std::string& file) {
  const std::vector<Term> terms = rotary_terms(pool);
  std::size_t n = 0;
  for (const auto& r : runs) n += r.x.size();
  Eigen::MatrixXd X(static_cast<Eigen::Index>(n), static_cast<Eigen::Index>(terms.size()));
  Eigen::VectorXd z(static_cast<Eigen::Index>(n));
  std::vector<std::size_t> starts{0};
  std::vector<std::string> names;
  for (const auto& t : terms) names.push_back(t.name);
  Eigen::Index row = 0;
  for (std::size_t ri = 0; ri < runs.size(); ++ri) {
    const PreparedRun& r = runs[ri];
    for (std::size_t i = 0; i < r.x.size(); ++i, ++row) {
      z(row) = r.coef[i] - r.static_value[i] - ml.y_model[ri][i];  // eq. 25
      for (std::size_t j = 0; j < terms.size(); ++j) {
        const Term& t = terms[j];
        const double g = t.kind == TermKind::rotary_power ? std::pow(r.x[i], t.power)
                                                          : plus_pow(r.x[i] - t.knot_rad, t.power);
        X(row, static_cast<Eigen::Index>(j)) = l_over_v * g * r.rate[i];
      }
    }
    starts.push_back(static_cast<std::size_t>(row));
  }
  refuse_zero_columns(X, names, file);
  RotaryStage st;
  std::vector<int> idx = stepwise_select(X, z, names, o, st.stepwise);
  Eigen::MatrixXd Xs(X.rows(), static_cast<Eigen::Index>(idx.size()));
  std::vector<std::string> chosen;
  for (std::size_t k = 0; k < idx.size(); ++k) {
    Xs.col(static_cast<Eigen::Index>(k)) = X.col(idx[k]);
    chosen.push_back(names[static_cast<std::size_t>(idx[k])]);
  }
  int n_powers = 0;
  for (int p : pool.powers) n_powers = std::max(n_powers, p + 1);
  st.rotary.n_powers = n_powers;
  st.rotary.n_knots = static_cast<int>(pool.knots_rad.size());
  for (std::size_t j = 0; j < pool.knots_rad.size(); ++j) {
    st.rotary.knot_rad[j] = pool.knots_rad[j];
    st.rotary.knot_power[j] = pool.knot_power;
  }
  if (idx.empty()) return st;  // nothing significant: C_aq = 0
  const LinearFit f = least_squares(Xs, z, starts, chosen, o, file);
  for (std::size_t k = 0; k < idx.size(); ++k) {
    const Term& t = terms[static_cast<std::size_t>(idx[k])];
    const auto kk = static_cast<Eigen::Index>(k);
    if (t.kind == TermKind::rotary_power) st.rotary.power_coef[t.power] = f.beta(kk);
    else st.rotary.knot_coef[t.index] = f.beta(kk);
    ParameterEstimate pe;
    pe.name = t.name;
    pe.value = f.beta(kk);
    pe.cr_bound = std::sqrt(f.cov_white(kk, kk));
    pe.cr_bound_colored = std::sqrt(std::max(0.0, f.cov_colored(kk, kk)));
    st.params.push_back(pe);
  }
  return st;
}

}  // namespace

FitResult fit_experiment(const Experiment& e, const FitOptions& o) {
  const auto t_start = std::chrono::steady_clock::now();
  if (e.runs.empty()) throw InputError(e.path, 0, "the experiment names no runs");
  if (!(e.airspeed_mps > 0.0) || !(e.reference_length_m > 0.0))
    throw InputError(e.path, 0, "airspeed_mps and reference_length_m must be positive");
  for (const Run& r : e.runs)
    if (r.size() < 3 || !(r.dt_s() > 0.0))
      throw InputError(r.path, 0, "run has fewer than 3 samples or a non-positive time step");

  FitResult res;
  ModelSet<double, Cap> model = base_model_set(e);
  std::vector<PreparedRun> runs = prepare_runs(e, model);
  const double l_over_v = e.l_over_v_s();

  // 1-2. Equation error (stepwise when configured): structure and start values.
  UnsteadyStructure pool = structure_from_config(e.model);
  pool.l_over_v_s = l_over_v;
  if (e.rotary.estimate && pool.rotary.size() > 0)
    throw InputError(e.path, 0, "rotary correction terms (diagnose's rotary_alpha) need "
                                "rotary.estimate = false: the two-stage loop owns C_aq otherwise");
  if (e.model.delay == DelayEstimation::estimated && !std::isfinite(e.model.delay_start_s))
    throw InputError(e.path, 0, "the delay's start value is not finite");
  UnsteadyStructure s;
  res.equation_error = run_equation_error(runs, pool, e.model.structure, o, e.path, s);

  // 3. ML output error.
  Eigen::VectorXd theta0 = start_values(s, runs, res.equation_error.parameters,
                                        e.model.delay_start_s);
  {
    const std::vector<std::string> names = parameter_names(s, runs);
    for (const auto& [name, value] : o.start_values) {
      const auto it = std::find(names.begin(), names.end(), name);
      if (it == names.end())
        throw InputError(e.path, 0, fmt::format("start value for {}: the model has no such "
                                                "parameter", name));
      theta0(it - names.begin()) = value;
    }
  }
  MLResult ml = fit_output_error(s, runs, theta0, o, e.path);
  if (e.model.structure == StructureMode::stepwise &&
      o.stepwise_refinement == StepwiseRefinement::output_error && std::isfinite(ml.summary.cost)) {
    ml = refine_structure_output_error(pool, runs, std::move(ml), o, e.path, &res.output_error_stepwise);
    s = ml.structure;
  }
  SplineD rotary = model.coefficients[0].rotary;
  std::vector<ParameterEstimate> rotary_params;

  // 4. Two-stage loop.
  if (e.rotary.estimate && std::isfinite(ml.summary.cost)) {
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
    for (int it = 1; it <= o.max_two_stage_iterations; ++it) {
      RotaryStage st = rotary_stage(runs, ml, rpool, l_over_v, o, e.path);
      std::vector<PreparedRun> trial_runs = runs;
      MLResult trial;
      std::vector<ParameterEstimate> trial_rotary_params;
      if (o.rotary_refinement == RotaryRefinement::joint_ml) {
        // The regression picked the terms and start values; ML refines them with the rest.
        UnsteadyStructure sr = s;
        sr.l_over_v_s = l_over_v;
        sr.rotary.knot_power = rpool.knot_power;
        std::vector<double> rstart;
        for (const Term& t : rotary_terms(rpool)) {
          for (const auto& p : st.params) {
            if (p.name != t.name) continue;
            if (t.kind == TermKind::rotary_power) sr.rotary.powers.push_back(t.power);
            else sr.rotary.knots_rad.push_back(t.knot_rad);
            rstart.push_back(p.value);
          }
        }
        // Powers first, then knots (rotary_terms order), matching rstart's order by
        // construction since rotary_terms lists powers before knots.
        const int ns = s.n_struct();
        const auto n_prev_rot = static_cast<Eigen::Index>(ml.structure.rotary.size());
        const Eigen::Index n_y0 = ml.theta.size() - ns - n_prev_rot;
        Eigen::VectorXd th0(ns + static_cast<Eigen::Index>(rstart.size()) + n_y0);
        th0.head(ns) = ml.theta.head(ns);
        for (std::size_t k = 0; k < rstart.size(); ++k)
          th0(ns + static_cast<Eigen::Index>(k)) = rstart[k];
        th0.tail(n_y0) = ml.theta.tail(n_y0);
        trial = fit_output_error(sr, trial_runs, th0, o, e.path);
        // The estimated C_aq as a spline over the pool's shape, and y_E recomputed with it.
        SplineD rot = st.rotary;
        for (int i = 0; i < rot.n_powers; ++i) rot.power_coef[i] = 0.0;
        for (int j = 0; j < rot.n_knots; ++j) rot.knot_coef[j] = 0.0;
        const std::vector<Term> rts = rotary_terms(sr.rotary);
        for (std::size_t k = 0; k < rts.size(); ++k) {
          const double val = trial.theta(ns + static_cast<Eigen::Index>(k));
          if (rts[k].kind == TermKind::rotary_power) {
            rot.power_coef[rts[k].power] = val;
          } else {
            for (int j = 0; j < rot.n_knots; ++j)
              if (rot.knot_rad[j] == rts[k].knot_rad) rot.knot_coef[j] = val;
          }
          ParameterEstimate pe;
          const auto ix = ns + static_cast<Eigen::Index>(k);
          pe.name = rts[k].name;
          pe.value = val;
          pe.cr_bound = std::sqrt(trial.cov_white(ix, ix));
          pe.cr_bound_colored = std::sqrt(trial.cov_colored(ix, ix));
          pe.identifiability = trial.identifiability[static_cast<std::size_t>(ix)];
          trial_rotary_params.push_back(pe);
        }
        st.rotary = rot;
        update_rotary(trial_runs, st.rotary, l_over_v);
      } else {
        update_rotary(trial_runs, st.rotary, l_over_v);
        UnsteadyStructure sr = s;
        const int ns = s.n_struct();
        const Eigen::Index n_y0 = ml.theta.size() - ns;
        Eigen::VectorXd th0(ns + n_y0);
        th0.head(ns) = ml.theta.head(ns);
        th0.tail(n_y0) = ml.theta.tail(n_y0);
        trial = fit_output_error(sr, trial_runs, th0, o, e.path);
        trial_rotary_params = st.params;
      }
      TwoStageIteration log;
      log.iteration = it;
      log.cost = trial.summary.cost;
      log.fit_error = trial.summary.fit_error;
      for (int i = 0; i < st.rotary.n_powers; ++i) log.rotary.push_back(st.rotary.power_coef[i]);
      for (int j = 0; j < st.rotary.n_knots; ++j) log.rotary_knot_coef.push_back(st.rotary.knot_coef[j]);
      log.rotary_parameters = trial_rotary_params;
      log.stepwise = st.stepwise;
      res.two_stage.push_back(log);
      const double prev = ml.summary.cost;
      if (!(trial.summary.cost < prev)) break;  // no improvement: keep the previous estimates
      runs = std::move(trial_runs);
      ml = std::move(trial);
      rotary = st.rotary;
      // joint_ml: the rotary estimates are ML parameters already (in ml.names).
      rotary_params = o.rotary_refinement == RotaryRefinement::joint_ml
                          ? std::vector<ParameterEstimate>{}
                          : trial_rotary_params;
      if ((prev - ml.summary.cost) / prev < o.two_stage_tolerance) break;
    }
  }

  // 5. The result.
  CoefficientModel<double, Cap>& cm = model.coefficients[0];
  set_unsteady(s, ml.theta.data(), cm);
  cm.rotary = rotary;
  // Diagnose's extensions: correcting rotary terms and static-correction terms (the two-stage
  // loop's replacing rotary terms are already in `rotary`).
  UnsteadyStructure extension = ml.structure;
  if (extension.rotary_role == RotaryRole::replaces_a_priori) extension.rotary = SplineTerms{};
  const bool extended = extension.rotary.size() + extension.static_corr.size() > 0;
  if (extended) {
    // add_output_terms reads theta by the layout of ml.structure; rebuild it with the
    // replacing rotary coefficients removed (they are not in theta as correcting terms).
    Eigen::VectorXd th = ml.theta;
    const auto ns = static_cast<Eigen::Index>(s.n_struct());
    const auto nrep = static_cast<Eigen::Index>(ml.structure.rotary.size() - extension.rotary.size());
    if (nrep > 0) {
      Eigen::VectorXd t2(th.size() - nrep);
      t2 << th.head(ns), th.tail(th.size() - ns - nrep);
      th = t2;
    }
    add_output_terms(extension, th.data(), cm);
  }
  res.model = model;
  res.output_error = ml.summary;
  res.fit_error = ml.summary.fit_error;
  const int n_struct = s.n_struct();
  const auto P = static_cast<Eigen::Index>(ml.names.size());
  const auto R = static_cast<Eigen::Index>(rotary_params.size());
  // Order: structural, rotary, then y0.
  std::vector<Eigen::Index> order;
  for (Eigen::Index i = 0; i < n_struct; ++i) order.push_back(i);
  const Eigen::Index total = P + R;
  res.covariance = Eigen::MatrixXd::Zero(total, total);
  res.covariance_colored = Eigen::MatrixXd::Zero(total, total);
  auto ml_param = [&](Eigen::Index i) {
    ParameterEstimate pe;
    pe.name = ml.names[static_cast<std::size_t>(i)];
    pe.value = ml.theta(i);
    pe.cr_bound = std::sqrt(ml.cov_white(i, i));
    pe.cr_bound_colored = std::sqrt(ml.cov_colored(i, i));
    pe.identifiability = ml.identifiability[static_cast<std::size_t>(i)];
    return pe;
  };
  // Map from output position to ML index (-1 for rotary entries).
  std::vector<Eigen::Index> ml_index;
  for (Eigen::Index i = 0; i < n_struct; ++i) {
    res.parameters.push_back(ml_param(i));
    ml_index.push_back(i);
  }
  for (Eigen::Index k = 0; k < R; ++k) {
    res.parameters.push_back(rotary_params[static_cast<std::size_t>(k)]);
    ml_index.push_back(-1);
  }
  for (Eigen::Index i = n_struct; i < P; ++i) {
    res.parameters.push_back(ml_param(i));
    ml_index.push_back(i);
  }
  for (Eigen::Index a = 0; a < total; ++a)
    for (Eigen::Index b = 0; b < total; ++b) {
      const Eigen::Index ia = ml_index[static_cast<std::size_t>(a)];
      const Eigen::Index ib = ml_index[static_cast<std::size_t>(b)];
      if (ia >= 0 && ib >= 0) {
        res.covariance(a, b) = ml.cov_white(ia, ib);
        res.covariance_colored(a, b) = ml.cov_colored(ia, ib);
      } else if (ia < 0 && ib < 0 && a == b) {
        // The rotary regression's own covariance is not kept across terms here; the diagonal
        // is what bands need to first order (cross terms with the ML block are not estimated).
        const auto& rp = res.parameters[static_cast<std::size_t>(a)];
        res.covariance(a, b) = rp.cr_bound * rp.cr_bound;
        res.covariance_colored(a, b) = rp.cr_bound_colored * rp.cr_bound_colored;
      }
    }

  for (std::size_t ri = 0; ri < runs.size(); ++ri) {
    const PreparedRun& r = runs[ri];
    RunSeries rs;
    rs.path = r.path;
    rs.time_s = r.t;
    rs.x_rad = r.x;
    rs.rate_radps = r.rate;
    rs.measured = r.coef;
    rs.y_measured = r.y_e;
    const std::size_t n = r.x.size();
    rs.y_model = ml.y_model.empty() ? std::vector<double>(n, std::numeric_limits<double>::quiet_NaN())
                                    : ml.y_model[ri];
    rs.model.resize(n);
    rs.quasi_steady.resize(n);
    rs.residual.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      rs.quasi_steady[i] = r.static_value[i] + r.rotary_value[i];
      if (extended) {
        // The fitted corrections are part of the quasi-steady curve and of y_E (eq. 12).
        rs.quasi_steady[i] = quasi_steady_output(cm, r.x[i], r.rate[i], l_over_v);
        rs.y_measured[i] = r.coef[i] - rs.quasi_steady[i];
      }
      rs.model[i] = rs.quasi_steady[i] + rs.y_model[i];
      rs.residual[i] = rs.measured[i] - rs.model[i];
    }
    res.runs.push_back(std::move(rs));
  }
  res.elapsed_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  return res;
}

FunctionBand function_band(const FitResult& r, ModelFunction f, double x_rad, BoundKind kind) {
  const CoefficientModel<double, FitCapacity>& cm = r.model.coefficients[0];
  const auto& sp = f == ModelFunction::a ? cm.a : f == ModelFunction::b1 ? cm.lags[0].b : cm.rotary;
  const std::string pp = f == ModelFunction::a ? "a" : f == ModelFunction::b1 ? "b1_" : "Caq_";
  const std::string kp = f == ModelFunction::a ? "A" : f == ModelFunction::b1 ? "B" : "CaqK";
  FunctionBand band;
  band.value = spline_value(sp, x_rad);
  const auto P = static_cast<Eigen::Index>(r.parameters.size());
  Eigen::VectorXd g = Eigen::VectorXd::Zero(P);
  for (Eigen::Index i = 0; i < P; ++i) {
    const std::string& n = r.parameters[static_cast<std::size_t>(i)].name;
    if (n.rfind(pp, 0) == 0 && n.size() > pp.size() &&
        n.find_first_not_of("0123456789", pp.size()) == std::string::npos) {
      g(i) = std::pow(x_rad, std::stoi(n.substr(pp.size())));
    } else if (n.rfind(kp, 0) == 0 && n.size() > kp.size() &&
               n.find_first_not_of("0123456789", kp.size()) == std::string::npos) {
      const int j = std::stoi(n.substr(kp.size())) - 1;
      if (j >= 0 && j < sp.n_knots) g(i) = plus_pow(x_rad - sp.knot_rad[j], sp.knot_power[j]);
    }
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
