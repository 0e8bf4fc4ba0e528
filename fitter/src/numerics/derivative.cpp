// Savitzky-Golay differentiation on uniform and non-uniform grids. See
// indicial/fitter/derivative.hpp. Written by hand: neither Eigen nor Boost 1.74 has a
// Savitzky-Golay filter; Eigen does the least squares that gives the weights.
#include "indicial/fitter/derivative.hpp"

#include <Eigen/Core>
#include <Eigen/QR>
#include <cstddef>
#include <stdexcept>

namespace indicial {

std::vector<double> smooth_derivative(const std::vector<double>& values, double dt_s,
                                      int half_window, int poly_degree) {
  if (half_window < 1) throw std::invalid_argument("smooth_derivative: half_window must be >= 1");
  const int width = 2 * half_window + 1;
  if (poly_degree < 1 || poly_degree >= width) {
    throw std::invalid_argument("smooth_derivative: need 1 <= poly_degree <= 2 * half_window");
  }
  if (!(dt_s > 0.0)) throw std::invalid_argument("smooth_derivative: dt_s must be > 0");
  const std::size_t n = values.size();
  if (n < static_cast<std::size_t>(width)) {
    throw std::invalid_argument("smooth_derivative: fewer values than one window");
  }
  // weights(e, k): the derivative at window position e (0..width-1) as a combination of the
  // window's values k. The local abscissa u = (k - e) / half_window keeps the Vandermonde
  // matrix well conditioned; d/dt = (1 / (half_window dt)) d/du.
  Eigen::MatrixXd weights(width, width);
  for (int e = 0; e < width; ++e) {
    Eigen::MatrixXd V(width, poly_degree + 1);
    for (int k = 0; k < width; ++k) {
      const double u = static_cast<double>(k - e) / half_window;
      double pw = 1.0;
      for (int p = 0; p <= poly_degree; ++p) {
        V(k, p) = pw;
        pw *= u;
      }
    }
    // Least-squares coefficients c = pinv(V) v; the derivative at u = 0 is c_1.
    const Eigen::MatrixXd pinv =
        V.colPivHouseholderQr().solve(Eigen::MatrixXd::Identity(width, width));
    weights.row(e) = pinv.row(1) / (half_window * dt_s);
  }
  std::vector<double> d(n);
  const std::size_t hw = static_cast<std::size_t>(half_window);
  for (std::size_t i = 0; i < n; ++i) {
    // Why the clamp: near the ends the centred window does not fit, so the first / last full
    // window is used with the evaluation point moved off-centre (the same local polynomial).
    std::size_t lo = i >= hw ? i - hw : 0;
    if (lo + static_cast<std::size_t>(width) > n) lo = n - static_cast<std::size_t>(width);
    const auto e = static_cast<Eigen::Index>(i - lo);
    double s = 0.0;
    for (int k = 0; k < width; ++k) s += weights(e, k) * values[lo + static_cast<std::size_t>(k)];
    d[i] = s;
  }
  return d;
}

std::vector<double> smooth_derivative_nonuniform(const std::vector<double>& time_s,
                                                 const std::vector<double>& values,
                                                 int half_window, int poly_degree) {
  if (half_window < 1) throw std::invalid_argument("smooth_derivative_nonuniform: half_window must be >= 1");
  const int width = 2 * half_window + 1;
  if (poly_degree < 1 || poly_degree >= width)
    throw std::invalid_argument("smooth_derivative_nonuniform: need 1 <= poly_degree <= 2 * half_window");
  const std::size_t n = values.size();
  if (time_s.size() != n) throw std::invalid_argument("smooth_derivative_nonuniform: lengths differ");
  if (n < static_cast<std::size_t>(width))
    throw std::invalid_argument("smooth_derivative_nonuniform: fewer values than one window");
  for (std::size_t i = 1; i < n; ++i)
    if (!(time_s[i] > time_s[i - 1]))
      throw std::invalid_argument("smooth_derivative_nonuniform: time is not strictly increasing");
  const std::size_t hw = static_cast<std::size_t>(half_window);
  std::vector<double> d(n);
  Eigen::MatrixXd V(width, poly_degree + 1);
  Eigen::VectorXd v(width);
  for (std::size_t i = 0; i < n; ++i) {
    std::size_t lo = i >= hw ? i - hw : 0;
    if (lo + static_cast<std::size_t>(width) > n) lo = n - static_cast<std::size_t>(width);
    // Why the scaling: the local abscissa u = (t - t_i) / h with h the window's half span keeps
    // the Vandermonde matrix as well conditioned as the uniform case's; d/dt = (1 / h) d/du.
    const double h = 0.5 * (time_s[lo + static_cast<std::size_t>(width) - 1] - time_s[lo]);
    for (int k = 0; k < width; ++k) {
      const std::size_t s = lo + static_cast<std::size_t>(k);
      const double u = (time_s[s] - time_s[i]) / h;
      double pw = 1.0;
      for (int p = 0; p <= poly_degree; ++p) {
        V(k, p) = pw;
        pw *= u;
      }
      v(k) = values[s];
    }
    const Eigen::VectorXd c = V.colPivHouseholderQr().solve(v);
    d[i] = c(1) / h;
  }
  return d;
}

}  // namespace indicial
