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

#include "fit_internal.hpp"
#include "indicial/fitter/error.hpp"

namespace indicial::fit_detail {

namespace {

double plus_pow(double u, int p) {
  if (!(u > 0.0)) return 0.0;
  double r = 1.0;
  for (int i = 0; i < p; ++i) r *= u;
  return r;
}

// Basis function g(x) of a term and its antiderivative (for the modulating-function form).
double term_basis(const Term& t, double x) {
  switch (t.kind) {
    case TermKind::a_power:
    case TermKind::b_power:
    case TermKind::rotary_power: return std::pow(x, t.power);
    case TermKind::a_knot:
    case TermKind::b_knot:
    case TermKind::rotary_knot: return plus_pow(x - t.knot_rad, t.power);
    default: return 1.0;
  }
}
double term_antiderivative(const Term& t, double x) {
  if (t.kind == TermKind::a_power) return std::pow(x, t.power + 1) / (t.power + 1);
  return plus_pow(x - t.knot_rad, t.power + 1) / (t.power + 1);
}

// Equation-error terms: everything of lag 1 (further lags are output-error only).
std::vector<Term> ee_terms(const UnsteadyStructure& s) {
  std::vector<Term> out;
  for (const Term& t : structural_terms(s))
    if (t.lag == 0 && t.kind != TermKind::gain && t.kind != TermKind::delay) out.push_back(t);
  return out;
}

}  // namespace

EquationErrorProblem equation_error_problem(const std::vector<PreparedRun>& runs,
                                            const UnsteadyStructure& s, const FitOptions& o) {
  const std::vector<Term> terms = ee_terms(s);
  EquationErrorProblem p;
  for (const Term& t : terms) p.names.push_back(t.name);
  const auto nt = static_cast<Eigen::Index>(terms.size());
  std::vector<std::vector<double>> rows;
  std::vector<double> zs;
  p.starts.push_back(0);
  for (const PreparedRun& r : runs) {
    const std::size_t n = r.x.size();
    if (o.state_derivative == StateDerivative::smoothed_difference) {
      const std::size_t need = 2 * static_cast<std::size_t>(std::max(1, o.derivative_half_window)) + 1;
      if (n < need)
        throw InputError(r.path, 0, fmt::format("run has {} samples; the Savitzky-Golay "
                                                "derivative of y_E needs at least {}", n, need));
      const std::vector<double> ydot =
          sg_derivative(r.y_e, r.dt_s, o.derivative_half_window, o.derivative_order);
      for (std::size_t i = 0; i < n; ++i) {
        std::vector<double> row(static_cast<std::size_t>(nt));
        for (std::size_t j = 0; j < terms.size(); ++j) {
          const Term& t = terms[j];
          switch (t.kind) {
            case TermKind::a_power:
            case TermKind::a_knot: row[j] = -term_basis(t, r.x[i]) * r.xdot[i]; break;
            case TermKind::b_power:
            case TermKind::b_knot: row[j] = -term_basis(t, r.x[i]) * r.y_e[i]; break;
            default: row[j] = 1.0; break;  // con
          }
        }
        rows.push_back(std::move(row));
        zs.push_back(ydot[i]);
      }
    } else {
      // Why the clamp: a window longer than the run cannot be placed; use the whole run.
      const std::size_t m =
          std::min<std::size_t>(n, static_cast<std::size_t>(std::max(5, o.modulating_window)));
      const std::size_t shift = static_cast<std::size_t>(std::max(1, o.modulating_shift));
      const double T = static_cast<double>(m - 1) * r.dt_s;
      std::vector<double> phi(m), dphi(m);
      for (std::size_t k = 0; k < m; ++k) {
        const double tau = static_cast<double>(k) * r.dt_s;
        const double sn = std::sin(M_PI * tau / T);
        phi[k] = sn * sn;
        dphi[k] = (M_PI / T) * std::sin(2.0 * M_PI * tau / T);
      }
      // Trapezoid weights (phi and phi' vanish at the ends except phi' = 0 exactly there too).
      auto w = [&](std::size_t k) { return (k == 0 || k + 1 == m) ? 0.5 * r.dt_s : r.dt_s; };
      for (std::size_t s0 = 0; s0 + m <= n; s0 += shift) {
        std::vector<double> row(static_cast<std::size_t>(nt), 0.0);
        double z = 0.0;
        for (std::size_t k = 0; k < m; ++k) {
          const std::size_t i = s0 + k;
          z += -w(k) * dphi[k] * r.y_e[i];
          for (std::size_t j = 0; j < terms.size(); ++j) {
            const Term& t = terms[j];
            switch (t.kind) {
              case TermKind::a_power:
              case TermKind::a_knot: row[j] += w(k) * dphi[k] * term_antiderivative(t, r.x[i]); break;
              case TermKind::b_power:
              case TermKind::b_knot: row[j] += -w(k) * phi[k] * term_basis(t, r.x[i]) * r.y_e[i]; break;
              default: row[j] += w(k) * phi[k]; break;
            }
          }
        }
        rows.push_back(std::move(row));
        zs.push_back(z);
      }
    }
    p.starts.push_back(rows.size());
  }
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
  std::vector<std::string> chosen = prob.names;
  if (mode == StructureMode::stepwise) {
    const std::vector<int> idx = stepwise_select(prob.X, prob.z, prob.names, o, res.stepwise);
    if (idx.empty())
      throw InputError(context_file, 0,
                       "stepwise regression selected no term: the data show no unsteady effect "
                       "above the F-to-enter threshold");
    chosen.clear();
    Eigen::MatrixXd Xs(prob.X.rows(), static_cast<Eigen::Index>(idx.size()));
    for (std::size_t k = 0; k < idx.size(); ++k) {
      Xs.col(static_cast<Eigen::Index>(k)) = prob.X.col(idx[k]);
      chosen.push_back(prob.names[static_cast<std::size_t>(idx[k])]);
    }
    prob.X = std::move(Xs);
  }
  selected = select_terms(pool, chosen);
  const LinearFit f = least_squares(prob.X, prob.z, prob.starts, chosen, o, context_file);
  for (std::size_t k = 0; k < chosen.size(); ++k) {
    const auto kk = static_cast<Eigen::Index>(k);
    ParameterEstimate pe;
    pe.name = chosen[k];
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
  const ModelSet<double, FitCapacity> base = base_model_set(e);
  const std::vector<fit_detail::PreparedRun> runs = fit_detail::prepare_runs(e, base);
  fit_detail::UnsteadyStructure selected;
  return fit_detail::run_equation_error(runs, fit_detail::structure_from_config(e.model),
                                        e.model.structure, o, e.path, selected);
}

}  // namespace indicial
