// fit_common.cpp -- prepared runs (eq. 12), least squares (its white and colored covariances
// from numerics::Covariance::linear_least_squares), shared by the equation-error, stepwise, output-error and two-stage steps.
#include <Eigen/Core>
#include <Eigen/SVD>
#include <unsupported/Eigen/AutoDiff>

#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <limits>

#include "estimate/fit_internal.hpp"
#include "indicial/fitter/error.hpp"
#include "indicial/fitter/io.hpp"

namespace indicial::fit_detail {

// ------------------------------------------------------------------------------------------
std::vector<double> y_e_derivative(const PreparedRun& r, int half_window, int order) {
  if (r.time_grid == TimeGrid::uniform) return smooth_derivative(r.y_e, r.dt_s, half_window, order);
  return smooth_derivative_nonuniform(r.t, r.y_e, half_window, order);
}

std::vector<PreparedRun> prepare_runs(const Experiment& e, const ModelSet<double, Cap>& base) {
  using Dual = Eigen::AutoDiffScalar<Eigen::Matrix<double, 1, 1>>;
  const CoefficientModel<double, Cap>& cm = base.coefficients[0];
  std::vector<PreparedRun> out;
  out.reserve(e.runs.size());
  for (const Run& r : e.runs) {
    PreparedRun p;
    p.path = r.path;
    p.dt_s = r.dt_s();
    p.time_grid = r.time_grid;
    p.periodic = r.periodic;
    // A Run built in code has airspeed 0: the experiment's (load_experiment fills it).
    p.airspeed_mps = r.airspeed_mps > 0.0 ? r.airspeed_mps : e.airspeed_mps;
    p.reference_airspeed_mps = e.airspeed_mps;
    const AirspeedScaling<double> scaling = airspeed_scaling(e.airspeed_mps, e.reference_length_m, p.airspeed_mps);
    p.time_scale = scaling.time_scale;
    p.l_over_v_s = scaling.l_over_v_s;
    const std::size_t n = r.size();
    if (r.coefficient.size() != n || r.motion_angle_rad.size() != n || r.rate_radps.size() != n)
      throw InputError(r.path, 0, "run has columns of different lengths");
    p.t = r.time_s;
    p.rate = r.rate_radps;
    p.coef = r.coefficient;
    p.x.resize(n);
    p.xdot.resize(n);
    p.static_value.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      // x' = dx/d(motion angle) * motion rate, the derivative taken through model_angle itself
      // (pitch: 1; roll and yaw: the chain rule of eqs. 17 and 20).
      const Dual m(r.motion_angle_rad[i], Eigen::Matrix<double, 1, 1>::Ones());
      const Dual x = model_angle(e.axis, e.alpha0_rad, m);
      p.x[i] = x.value();
      p.xdot[i] = x.derivatives()(0) * r.rate_radps[i];
      p.static_value[i] =
          static_value(cm.static_curve, p.x[i]) + spline_value(cm.static_correction, p.x[i]);
    }
    out.push_back(std::move(p));
  }
  update_rotary(out, cm.rotary);
  return out;
}

void update_rotary(std::vector<PreparedRun>& runs, const SplineD& rotary) {
  for (PreparedRun& p : runs) {
    const std::size_t n = p.x.size();
    p.rotary_value.resize(n);
    p.y_e.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      p.rotary_value[i] = p.l_over_v_s * spline_value(rotary, p.x[i]) * p.rate[i];
      p.y_e[i] = p.coef[i] - p.static_value[i] - p.rotary_value[i];  // eq. 12
    }
  }
}

void refuse_zero_columns(const Eigen::MatrixXd& X, const std::vector<std::string>& names,
                         const std::string& context_file) {
  for (Eigen::Index j = 0; j < X.cols(); ++j) {
    if (X.col(j).squaredNorm() == 0.0) {
      throw InputError(context_file, 0,
                       fmt::format("regressor of term {} is zero at every sample (a knot at or "
                                   "beyond the data's angle range?); remove the term",
                                   names[static_cast<std::size_t>(j)]));
    }
  }
}

LinearFit least_squares(const Eigen::MatrixXd& X, const Eigen::VectorXd& z,
                        const std::vector<std::size_t>& starts,
                        const std::vector<std::string>& names, const FitOptions& o,
                        const std::string& context_file) {
  const Eigen::Index n = X.rows(), p = X.cols();
  if (n <= p) {
    throw InputError(context_file, 0,
                     fmt::format("{} samples for {} parameters: need more samples than "
                                 "parameters", n, p));
  }
  refuse_zero_columns(X, names, context_file);
  // Why the scaling: the singular-value cut-off should judge collinearity, not units, so the
  // columns are scaled to unit norm before the SVD and the solution scaled back.
  Eigen::VectorXd scale = X.colwise().norm().transpose();
  Eigen::MatrixXd Xs = X * scale.cwiseInverse().asDiagonal();
  // Why JacobiSVD (with its default column-pivoting QR preconditioner, so the n x p problem
  // becomes a p x p one): the regressors have few columns, and for fewer than 16 Eigen's
  // BDCSVD falls back to exactly this; spelling it out skips compiling the divide-and-conquer
  // path (half this file's build time) and keeps the most accurate SVD for every p.
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(Xs, Eigen::ComputeThinU | Eigen::ComputeThinV);
  const Eigen::VectorXd& sv = svd.singularValues();
  const double cut = o.sv_cutoff * sv(0);
  int rank = 0;
  for (Eigen::Index i = 0; i < sv.size(); ++i)
    if (sv(i) > cut) ++rank;
  if (rank < p) {
    // Name the terms that take part in the null space.
    const Eigen::MatrixXd& V = svd.matrixV();
    std::string list;
    for (Eigen::Index j = 0; j < p; ++j) {
      const double w = V.row(j).tail(p - rank).squaredNorm();
      if (w > 0.01) list += (list.empty() ? "" : ", ") + names[static_cast<std::size_t>(j)];
    }
    throw InputError(context_file, 0,
                     fmt::format("regressors are linearly dependent (rank {} of {}): terms {} "
                                 "cannot be told apart on these data; remove one",
                                 rank, p, list));
  }
  LinearFit f;
  Eigen::VectorXd beta_s = svd.solve(z);
  f.beta = scale.cwiseInverse().asDiagonal() * beta_s;
  f.residual = z - X * f.beta;
  f.sse = f.residual.squaredNorm();
  const double zbar = z.mean();
  const double sst = (z.array() - zbar).square().sum();
  f.r_squared = sst > 0.0 ? 1.0 - f.sse / sst : 0.0;
  f.lag = choose_correlation_lag(f.residual, starts, o);
  numerics::Covariance::LinearEstimate cov = numerics::Covariance::linear_least_squares(
      X, scale, sv, svd.matrixV(), f.residual, f.sse, starts, f.lag);
  f.cov_white = std::move(cov.white);
  f.cov_colored = std::move(cov.colored);
  return f;
}

}  // namespace indicial::fit_detail

// ------------------------------------------------------------------------------------------
// Public helpers.
// ------------------------------------------------------------------------------------------
namespace indicial {

ModelSet<double, FitCapacity> base_model_set(const Experiment& e) {
  using fit_detail::Cap;
  ModelSet<double, Cap> ms;
  ms.axis = e.axis;
  ms.reference_length_m = e.reference_length_m;
  ms.airspeed_mps = e.airspeed_mps;
  ms.alpha0_rad = e.alpha0_rad;
  ms.n_coefficients = 1;
  CoefficientModel<double, Cap>& cm = ms.coefficients[0];
  const std::size_t name_len = std::min<std::size_t>(e.coefficient.size(), sizeof(cm.name) - 1);
  for (std::size_t i = 0; i < name_len; ++i) cm.name[i] = e.coefficient[i];
  auto& sc = cm.static_curve;
  if (e.static_curve.kind == StaticKind::polynomial) {
    sc.kind = StaticKind::polynomial;
    if (static_cast<int>(e.static_curve.polynomial.size()) > Cap::max_powers)
      throw InputError(e.path, 0, fmt::format("static polynomial has {} terms; at most {}",
                                              e.static_curve.polynomial.size(), Cap::max_powers));
    sc.polynomial.n_powers = static_cast<int>(e.static_curve.polynomial.size());
    for (int i = 0; i < sc.polynomial.n_powers; ++i)
      sc.polynomial.power_coef[i] = e.static_curve.polynomial[static_cast<std::size_t>(i)];
  } else {
    sc.kind = StaticKind::table;
    const auto& tx = e.static_curve.table_x_rad;
    const auto& tv = e.static_curve.table_value;
    if (tx.size() != tv.size() || tx.size() < 2)
      throw InputError(e.path, 0, "static table needs at least 2 rows");
    if (static_cast<int>(tx.size()) > Cap::max_table_points)
      throw InputError(e.path, 0, fmt::format("static table has {} rows; at most {}", tx.size(),
                                              Cap::max_table_points));
    for (std::size_t i = 1; i < tx.size(); ++i)
      if (!(tx[i] > tx[i - 1]))
        throw InputError(e.path, 0, "static table angles are not strictly increasing");
    sc.n_table = static_cast<int>(tx.size());
    for (std::size_t i = 0; i < tx.size(); ++i) {
      sc.table_x_rad[i] = tx[i];
      sc.table_value[i] = tv[i];
    }
    prepare_static_table(sc);
  }
  if (static_cast<int>(e.rotary.polynomial.size()) > Cap::max_powers)
    throw InputError(e.path, 0, "rotary polynomial has too many terms");
  cm.rotary.n_powers = static_cast<int>(e.rotary.polynomial.size());
  for (int i = 0; i < cm.rotary.n_powers; ++i)
    cm.rotary.power_coef[i] = e.rotary.polynomial[static_cast<std::size_t>(i)];
  const std::size_t n_prior = e.rotary.prior_knots_rad.size();
  if (n_prior > static_cast<std::size_t>(Cap::max_knots) ||
      e.rotary.prior_knot_coefficients.size() != n_prior ||
      (!e.rotary.prior_knot_powers.empty() && e.rotary.prior_knot_powers.size() != n_prior))
    throw InputError(e.path, 0, "rotary prior knots: too many, or not one power and coefficient per knot");
  cm.rotary.n_knots = static_cast<int>(n_prior);
  for (std::size_t j = 0; j < n_prior; ++j) {
    cm.rotary.knot_rad[j] = e.rotary.prior_knots_rad[j];
    // Default (x - k)_+, as C_aq's estimated knot terms (eq. 28).
    cm.rotary.knot_power[j] = e.rotary.prior_knot_powers.empty() ? 1 : e.rotary.prior_knot_powers[j];
    cm.rotary.knot_coef[j] = e.rotary.prior_knot_coefficients[j];
  }
  // Envelope: the model-angle range of the data.
  const AngleRange range = model_angle_range(e);
  if (!range.empty()) {
    ms.x_min_rad = range.min_rad;
    ms.x_max_rad = range.max_rad;
  }
  return ms;
}

}  // namespace indicial
