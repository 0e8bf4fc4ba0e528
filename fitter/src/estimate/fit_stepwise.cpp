// fit_stepwise.cpp -- stepwise regression for model structure (Klein & Morelli, "Aircraft
// System Identification", ch. 5): forward entry by the largest partial F above F_in, a
// backward check that removes the weakest term below F_out after each entry, and the model
// finally kept is the one with the minimum predicted squared error
//   PSE = SSE / N + sigma_max^2 * p / N,   sigma_max^2 = sum (z - mean z)^2 / N.
// Written by hand: no library we use does stepwise regression.
//
// Colored residuals (issue 12, item 4). The partial F of one term is its t statistic squared,
// estimate^2 / (s^2 (X'X)^-1_jj), which assumes white residuals; with residuals correlated
// over many samples (tunnel data, AR(1) noise) the true variance of the estimate is larger
// and F accepts nearly every candidate. With StepwiseSignificance::colored_residuals (the
// default) each F is multiplied by var_white / var_colored of the term's estimate in the fit
// that holds it, var_colored being Morelli & Klein's sandwich (fit_common.cpp's
// colored_middle, the lags by choose_correlation_lag): F_c = estimate^2 / var_colored. When
// the residuals show no significant autocorrelation (lag window 0) F is left bit-identical.
#include <Eigen/Cholesky>
#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <limits>

#include "estimate/fit_internal.hpp"

namespace indicial::fit_detail {

namespace {

// Residual sum of squares of z on the columns `set` from the Gram matrix G = X'X and c = X'z.
// Columns are unit-norm scaled so G is a correlation-like matrix.
double subset_sse(const Eigen::MatrixXd& G, const Eigen::VectorXd& c, double zz,
                  const std::vector<int>& set) {
  if (set.empty()) return zz;
  const auto k = static_cast<Eigen::Index>(set.size());
  Eigen::MatrixXd Gs(k, k);
  Eigen::VectorXd cs(k);
  for (Eigen::Index i = 0; i < k; ++i) {
    cs(i) = c(set[static_cast<std::size_t>(i)]);
    for (Eigen::Index j = 0; j < k; ++j)
      Gs(i, j) = G(set[static_cast<std::size_t>(i)], set[static_cast<std::size_t>(j)]);
  }
  Eigen::LDLT<Eigen::MatrixXd> ldlt(Gs);
  const double sse = zz - cs.dot(ldlt.solve(cs));
  // Why the clamp: with a near-perfect fit the subtraction can round below zero.
  return std::max(sse, 0.0);
}

// Squared norm of column j after projecting out the columns of `set` (unit-norm columns):
// near zero means j is (numerically) a combination of them and must not enter.
double independent_part(const Eigen::MatrixXd& G, const std::vector<int>& set, int j) {
  if (set.empty()) return G(j, j);
  const auto k = static_cast<Eigen::Index>(set.size());
  Eigen::MatrixXd Gs(k, k);
  Eigen::VectorXd gj(k);
  for (Eigen::Index a = 0; a < k; ++a) {
    gj(a) = G(set[static_cast<std::size_t>(a)], j);
    for (Eigen::Index b = 0; b < k; ++b)
      Gs(a, b) = G(set[static_cast<std::size_t>(a)], set[static_cast<std::size_t>(b)]);
  }
  return G(j, j) - gj.dot(Eigen::LDLT<Eigen::MatrixXd>(Gs).solve(gj));
}

// var_white / var_colored of every estimate of the least-squares fit of z on the columns
// `set` of the unit-norm columns Xs (Gram matrix G, c = Xs'z): the factor that turns each
// term's white partial F into the colored one. All 1 when the residuals are white (lag 0) or
// the white test is asked for.
Eigen::VectorXd colored_factors(const Eigen::MatrixXd& Xs, const Eigen::MatrixXd& G,
                                const Eigen::VectorXd& c, const Eigen::VectorXd& z,
                                const std::vector<int>& set, const std::vector<std::size_t>& starts,
                                const FitOptions& o) {
  const auto k = static_cast<Eigen::Index>(set.size());
  Eigen::VectorXd factor = Eigen::VectorXd::Ones(k);
  if (o.stepwise_significance == StepwiseSignificance::white_residuals || k == 0) return factor;
  Eigen::MatrixXd Gs(k, k), Xset(Xs.rows(), k);
  Eigen::VectorXd cs(k);
  for (Eigen::Index i = 0; i < k; ++i) {
    const int ci = set[static_cast<std::size_t>(i)];
    cs(i) = c(ci);
    Xset.col(i) = Xs.col(ci);
    for (Eigen::Index j = 0; j < k; ++j) Gs(i, j) = G(ci, set[static_cast<std::size_t>(j)]);
  }
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(Gs);
  const Eigen::VectorXd residual = z - Xset * ldlt.solve(cs);
  const int lag = choose_correlation_lag(residual, starts, o);
  if (lag == 0) return factor;
  const Eigen::MatrixXd Ginv = ldlt.solve(Eigen::MatrixXd::Identity(k, k));
  const double n = static_cast<double>(Xs.rows());
  const double s2 = residual.squaredNorm() / (n - static_cast<double>(k));
  for (Eigen::Index i = 0; i < k; ++i) {
    // var_colored of estimate i is w' M w, w = (X'X)^-1 e_i, M the sandwich's middle; as
    // colored_middle of the single column X w (n x lag work, not n x k^2 x lag). Scaled by
    // N / (N - k) like s^2, as least_squares does.
    const Eigen::MatrixXd u = Xset * Ginv.col(i);
    const double var_c = colored_middle(u, residual, starts, lag)(0, 0) * n / (n - static_cast<double>(k));
    const double var_w = s2 * Ginv(i, i);
    if (var_c > 0.0 && var_w > 0.0) factor(i) = var_w / var_c;
  }
  return factor;
}

}  // namespace

std::vector<int> stepwise_select(const Eigen::MatrixXd& X, const Eigen::VectorXd& z,
                                 const std::vector<std::size_t>& starts,
                                 const std::vector<std::string>& names, const FitOptions& o,
                                 StepwiseResult& log) {
  const Eigen::Index n = X.rows();
  const int pool = static_cast<int>(X.cols());
  const double nd = static_cast<double>(n);
  Eigen::VectorXd scale = X.colwise().norm().transpose();
  for (Eigen::Index j = 0; j < scale.size(); ++j)
    if (scale(j) == 0.0) scale(j) = 1.0;  // zero columns are refused before we get here
  const Eigen::MatrixXd Xs = X * scale.cwiseInverse().asDiagonal();
  const Eigen::MatrixXd G = Xs.transpose() * Xs;
  const Eigen::VectorXd c = Xs.transpose() * z;
  const double zz = z.squaredNorm();
  const double zbar = z.mean();
  const double sst = (z.array() - zbar).square().sum();
  log = StepwiseResult{};
  log.n_samples = static_cast<std::size_t>(n);
  log.sigma_max_squared = sst / nd;

  auto pse_of = [&](double sse, std::size_t p) {
    return sse / nd + log.sigma_max_squared * static_cast<double>(p) / nd;
  };
  auto r2_of = [&](double sse) { return sst > 0.0 ? 1.0 - sse / sst : 0.0; };

  std::vector<int> in;
  double sse = zz;
  // The empty model is a candidate too (PSE with p = 0).
  double best_pse = pse_of(sse, 0);
  std::vector<int> best_set;
  const int max_steps = 4 * pool + 4;  // guard against entry/removal cycles
  int just_entered = -1;
  // Logs the step that just entered or removed `term` (the model is now `in` with `sse`) and
  // keeps the set of least PSE.
  auto log_step = [&](int term, StepwiseAction action, double f, double f_white) {
    StepwiseStep s;
    s.step = static_cast<int>(log.steps.size()) + 1;
    s.term = names[static_cast<std::size_t>(term)];
    s.action = action;
    s.partial_f = f;
    s.partial_f_white = f_white;
    s.r_squared = r2_of(sse);
    s.pse = pse_of(sse, in.size());
    s.n_terms = static_cast<int>(in.size());
    log.steps.push_back(s);
    if (s.pse < best_pse) {
      best_pse = s.pse;
      best_set = in;
    }
  };
  // Backward: remove the weakest term (not `protect`, the one just entered) while its partial
  // F is below F_out.
  auto backward = [&](int protect) {
    while (in.size() >= 2) {
      int worst = -1;
      double worst_f = std::numeric_limits<double>::max(), worst_sse = sse, worst_white = worst_f;
      const double dof = nd - static_cast<double>(in.size());
      const Eigen::VectorXd factor = colored_factors(Xs, G, c, z, in, starts, o);
      for (std::size_t ti = 0; ti < in.size(); ++ti) {
        const int t = in[ti];
        if (t == protect) continue;
        std::vector<int> trial;
        for (int u : in)
          if (u != t) trial.push_back(u);
        const double s0 = subset_sse(G, c, zz, trial);
        const double f_white = sse > 0.0 ? (s0 - sse) / (sse / dof) : std::numeric_limits<double>::max();
        const double f = f_white * factor(static_cast<Eigen::Index>(ti));
        if (f < worst_f) {
          worst_f = f;
          worst_white = f_white;
          worst = t;
          worst_sse = s0;
        }
      }
      if (worst < 0 || worst_f >= o.f_to_remove) return;
      in.erase(std::find(in.begin(), in.end(), worst));
      sse = worst_sse;
      log_step(worst, StepwiseAction::removed, worst_f, worst_white);
    }
  };
  for (int step = 0; step < max_steps; ++step) {
    // Forward: the candidate with the largest partial F.
    int best_j = -1;
    double best_f = -1.0, best_sse = sse, best_white = best_f;
    for (int j = 0; j < pool; ++j) {
      if (std::find(in.begin(), in.end(), j) != in.end()) continue;
      // Why: a column (numerically) in the span of the entered ones adds nothing but
      // round-off; letting it in would make the next solves singular.
      if (independent_part(G, in, j) < 1e-10) continue;
      std::vector<int> trial = in;
      trial.push_back(j);
      const double s1 = subset_sse(G, c, zz, trial);
      const double dof = nd - static_cast<double>(trial.size());
      if (dof <= 0.0) continue;
      const double f_white = s1 > 0.0 ? (sse - s1) / (s1 / dof) : std::numeric_limits<double>::max();
      // The candidate is the last column of `trial`.
      const double f = f_white * colored_factors(Xs, G, c, z, trial, starts, o)(static_cast<Eigen::Index>(in.size()));
      if (f > best_f) {
        best_f = f;
        best_white = f_white;
        best_j = j;
        best_sse = s1;
      }
    }
    if (best_j < 0 || best_f < o.f_to_enter) break;
    in.push_back(best_j);
    just_entered = best_j;
    sse = best_sse;
    log_step(best_j, StepwiseAction::entered, best_f, best_white);
    backward(just_entered);
  }
  // A last backward pass: a term that entered early may have lost its significance to later
  // ones without a removal being triggered yet.
  backward(-1);
  std::sort(best_set.begin(), best_set.end());
  log.min_pse = best_pse;
  for (int j : best_set) log.selected.push_back(names[static_cast<std::size_t>(j)]);
  return best_set;
}

}  // namespace indicial::fit_detail
