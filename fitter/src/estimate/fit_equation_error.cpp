// fit_equation_error.cpp -- the equation-error (least-squares) step of eq. 22:
//
//   y_E'(i) = -b1(x_i) y_E(i) - a(x_i) x'(i) + con + e(i)
//
// linear in the coefficients of b1(x), a(x) and con. Two ways to get the left side:
//  * smoothed_difference: y_E' by the Savitzky-Golay derivative (io.hpp smooth_derivative);
//  * modulating_function (report ref. 12; Shinbrot's method): multiply the equation by a
//    function phi that vanishes with its derivative at both ends of a window and integrate;
//    integration by parts moves every derivative onto phi, so neither y_E nor x is
//    differentiated:  -int phi' y_E dt = -int phi b1(x) y_E dt + int phi' G_a(x) dt
//    + con int phi dt, with G_a the antiderivative of a. phi(t) = sin^2(pi (t - t0) / T).
#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <string>

#include "estimate/fit_internal.hpp"
#include "indicial/fitter/error.hpp"

namespace indicial::fit_detail {

namespace {

// Equation-error terms: everything of lag 1 (further lags are output-error only).
std::vector<ParamId> ee_terms(const UnsteadyStructure& s) {
  std::vector<ParamId> out;
  for (const ParamId& t : structural_terms(s))
    // Lag 1's a(x), b1(x) and con: the equation error's regressors (eq. 22). The further lags,
    // the delay and the dynamic-stall parameters are estimated by output error only.
    if (t.lag == 0 && (t.kind == ParamKind::a_power || t.kind == ParamKind::a_knot ||
                       t.kind == ParamKind::b_power || t.kind == ParamKind::b_knot || t.kind == ParamKind::con))
      out.push_back(t);
  return out;
}

// The regressor of term t at sample i of eq. 22 (smoothed-difference form). b1 and con are
// rates at V_ref: on a run at V they act times time_scale = V / V_ref (model.hpp warning 2;
// exactly 1 at V_ref).
double regressor(const ParamId& t, const PreparedRun& r, std::size_t i) {
  switch (t.kind) {
    case ParamKind::a_power:
    case ParamKind::a_knot: return -basis_value<double>(term_basis(t), r.x[i]) * r.xdot[i];
    case ParamKind::b_power:
    case ParamKind::b_knot: return -basis_value<double>(term_basis(t), r.x[i]) * r.y_e[i] * r.time_scale;
    default: return r.time_scale;  // con
  }
}

// The integrand of term t's modulating-function regressor at sample i: weight w, phi and phi'.
double modulated_regressor(const ParamId& t, const PreparedRun& r, std::size_t i, double w,
                           double phi, double dphi) {
  switch (t.kind) {
    case ParamKind::a_power:
    case ParamKind::a_knot: return w * dphi * basis_antiderivative<double>(term_basis(t), r.x[i]);
    case ParamKind::b_power:
    case ParamKind::b_knot:
      return -w * phi * basis_value<double>(term_basis(t), r.x[i]) * r.y_e[i] * r.time_scale;
    default: return w * phi * r.time_scale;  // con
  }
}

}  // namespace

namespace {

// Rows of the smoothed-difference form for one run.
void smoothed_rows(const PreparedRun& r, const std::vector<ParamId>& terms, const FitOptions& o,
                   std::vector<std::vector<double>>& rows, std::vector<double>& zs) {
  const std::size_t n = r.x.size();
  const std::size_t need = 2 * static_cast<std::size_t>(o.derivative_half_window) + 1;  // >= 1: IsValid
  if (n < need)
    throw InputError(r.path, 0, fmt::format("run has {} samples; the Savitzky-Golay "
                                            "derivative of y_E needs at least {}", n, need));
  const std::vector<double> ydot = y_e_derivative(r, o.derivative_half_window, o.derivative_order);
  for (std::size_t i = 0; i < n; ++i) {
    std::vector<double> row(terms.size());
    for (std::size_t j = 0; j < terms.size(); ++j) row[j] = regressor(terms[j], r, i);
    rows.push_back(std::move(row));
    zs.push_back(ydot[i]);
  }
}

// The modulating function phi(t) = sin^2(pi (t - t0) / T) over m samples from s0, its
// derivative and the trapezoid weights of the integrals, on the run's actual times. On a
// uniform grid they do not depend on s0 and are those of tau = k dt, T = (m - 1) dt.
struct ModulatingWindow {
  std::vector<double> phi, dphi, w;
  explicit ModulatingWindow(std::size_t m) : phi(m), dphi(m), w(m) {}
  void place(const PreparedRun& r, std::size_t s0) {
    const std::size_t m = phi.size();
    const bool uniform = r.time_grid == TimeGrid::uniform;
    const double T = uniform ? static_cast<double>(m - 1) * r.dt_s : r.t[s0 + m - 1] - r.t[s0];
    for (std::size_t k = 0; k < m; ++k) {
      const double tau = uniform ? static_cast<double>(k) * r.dt_s : r.t[s0 + k] - r.t[s0];
      const double sn = std::sin(M_PI * tau / T);
      phi[k] = sn * sn;
      dphi[k] = (M_PI / T) * std::sin(2.0 * M_PI * tau / T);
      // Trapezoid weights: half the steps either side (phi and phi' vanish at the ends).
      if (uniform) {
        w[k] = (k == 0 || k + 1 == m) ? 0.5 * r.dt_s : r.dt_s;
      } else {
        const double before = k > 0 ? r.t[s0 + k] - r.t[s0 + k - 1] : 0.0;
        const double after = k + 1 < m ? r.t[s0 + k + 1] - r.t[s0 + k] : 0.0;
        w[k] = 0.5 * (before + after);
      }
    }
  }
};

// Rows of the modulating-function form for one run: one per window position.
void modulated_rows(const PreparedRun& r, const std::vector<ParamId>& terms, const FitOptions& o,
                    std::vector<std::vector<double>>& rows, std::vector<double>& zs) {
  const std::size_t n = r.x.size();
  // Why the clamp: a window longer than the run cannot be placed; use the whole run. (The window
  // is >= 5 samples and the shift >= 1: FitOptions::IsValid.)
  const std::size_t m = std::min<std::size_t>(n, static_cast<std::size_t>(o.modulating_window));
  const std::size_t shift = static_cast<std::size_t>(o.modulating_shift);
  ModulatingWindow win(m);
  if (r.time_grid == TimeGrid::uniform) win.place(r, 0);  // the same at every position
  for (std::size_t s0 = 0; s0 + m <= n; s0 += shift) {
    if (r.time_grid == TimeGrid::nonuniform) win.place(r, s0);
    std::vector<double> row(terms.size(), 0.0);
    double z = 0.0;
    for (std::size_t k = 0; k < m; ++k) {
      const std::size_t i = s0 + k;
      z += -win.w[k] * win.dphi[k] * r.y_e[i];
      for (std::size_t j = 0; j < terms.size(); ++j)
        row[j] += modulated_regressor(terms[j], r, i, win.w[k], win.phi[k], win.dphi[k]);
    }
    rows.push_back(std::move(row));
    zs.push_back(z);
  }
}

}  // namespace

EquationErrorProblem equation_error_problem(const std::vector<PreparedRun>& runs,
                                            const UnsteadyStructure& s, const FitOptions& o) {
  EquationErrorProblem p;
  p.terms = ee_terms(s);
  for (const ParamId& t : p.terms) p.names.push_back(parameter_name(t));
  std::vector<std::vector<double>> rows;
  std::vector<double> zs;
  p.starts.push_back(0);
  for (const PreparedRun& r : runs) {
    if (o.state_derivative == StateDerivative::smoothed_difference) smoothed_rows(r, p.terms, o, rows, zs);
    else modulated_rows(r, p.terms, o, rows, zs);
    p.starts.push_back(rows.size());
  }
  const auto nt = static_cast<Eigen::Index>(p.terms.size());
  p.X.resize(static_cast<Eigen::Index>(rows.size()), nt);
  p.z.resize(static_cast<Eigen::Index>(rows.size()));
  for (std::size_t i = 0; i < rows.size(); ++i) {
    for (Eigen::Index j = 0; j < nt; ++j)
      p.X(static_cast<Eigen::Index>(i), j) = rows[i][static_cast<std::size_t>(j)];
    p.z(static_cast<Eigen::Index>(i)) = zs[i];
  }
  return p;
}

EquationErrorResult run_equation_error(const std::vector<PreparedRun>& runs,
                                       const UnsteadyStructure& pool, StructureMode mode,
                                       const FitOptions& o, const std::string& context_file,
                                       UnsteadyStructure& selected) {
  EquationErrorProblem prob = equation_error_problem(runs, pool, o);
  EquationErrorResult res;
  res.state_derivative = o.state_derivative;
  res.n_samples = static_cast<std::size_t>(prob.X.rows());
  if (prob.X.cols() == 0) throw InputError(context_file, 0, "the model has no a(x) or b1(x) terms");
  refuse_zero_columns(prob.X, prob.names, context_file);
  std::vector<int> chosen(static_cast<std::size_t>(prob.X.cols()));
  for (std::size_t k = 0; k < chosen.size(); ++k) chosen[k] = static_cast<int>(k);
  if (mode == StructureMode::stepwise) {
    chosen = stepwise_select(prob.X, prob.z, prob.starts, prob.names, o, res.stepwise);
    // Nothing selected: the output-error fallback (fit_two_stage.cpp) starts from the lowest
    // a(x) and b1(x) terms; without it there is nothing to estimate.
    if (chosen.empty() && o.stepwise_fallback == StepwiseFallback::automatic)
      chosen = fallback_start_columns(prob.terms);
    if (chosen.empty())
      throw InputError(context_file, 0,
                       "stepwise regression selected no term: the data show no unsteady effect "
                       "above the F-to-enter threshold");
    Eigen::MatrixXd Xs(prob.X.rows(), static_cast<Eigen::Index>(chosen.size()));
    for (std::size_t k = 0; k < chosen.size(); ++k)
      Xs.col(static_cast<Eigen::Index>(k)) = prob.X.col(chosen[k]);
    prob.X = std::move(Xs);
  }
  std::vector<ParamId> ids;
  std::vector<std::string> names;
  for (int j : chosen) {
    ids.push_back(prob.terms[static_cast<std::size_t>(j)]);
    names.push_back(prob.names[static_cast<std::size_t>(j)]);
  }
  selected = select_terms(pool, ids);
  const LinearFit f = least_squares(prob.X, prob.z, prob.starts, names, o, context_file);
  for (std::size_t k = 0; k < ids.size(); ++k) {
    const auto kk = static_cast<Eigen::Index>(k);
    ParameterEstimate pe;
    pe.id = ids[k];
    pe.name = names[k];
    pe.value = f.beta(kk);
    pe.cr_bound = std::sqrt(f.cov_white(kk, kk));
    pe.cr_bound_colored = std::sqrt(std::max(0.0, f.cov_colored(kk, kk)));
    res.parameters.push_back(pe);
  }
  const double dof = static_cast<double>(prob.X.rows() - prob.X.cols());
  res.fit_error = std::sqrt(f.sse / dof);
  res.r_squared = f.r_squared;
  res.correlation_lag = f.lag;
  return res;
}

}  // namespace indicial::fit_detail

namespace indicial {

EquationErrorResult fit_equation_error(const Experiment& e, const FitOptions& o) {
  if (std::string bad; !o.IsValid(&bad)) throw InputError(bad);  // first, as fit_experiment
  const ModelSet<double, FitCapacity> base = base_model_set(e);
  const std::vector<fit_detail::PreparedRun> runs = fit_detail::prepare_runs(e, base);
  fit_detail::UnsteadyStructure selected;
  return fit_detail::run_equation_error(runs, fit_detail::structure_from_config(e.model),
                                        e.model.structure, o, e.path, selected);
}

}  // namespace indicial
