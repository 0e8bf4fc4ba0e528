// fit_levenberg_marquardt.cpp -- the Levenberg-Marquardt loop (see the header).
//
// One outer iteration: the Jacobian at x, A = J'J, g = J'r, the Cramer-Rao bounds from A's
// pseudo-inverse; then damped steps (A + lambda diag(A)) d = -g, lambda times 10 after each
// rejection and divided by 10 after an acceptance. Converged: an accepted step with relative
// cost change below cost_tolerance AND every parameter step below step_tolerance bounds, or a
// first (least-damped) trial already below step_tolerance bounds that does not lower the cost
// (the cost cannot decrease further within round-off).
#include "estimate/fit_levenberg_marquardt.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <limits>

namespace indicial::fit_detail {

bool LevenbergMarquardtOptions::IsValid(std::string* error) const {
  auto fail = [&](const char* what) {
    if (error) *error = what;
    return false;
  };
  if (max_iterations < 0) return fail("max_iterations must be >= 0");
  if (!(cost_tolerance >= 0.0)) return fail("cost_tolerance must be >= 0");
  if (!(step_tolerance >= 0.0)) return fail("step_tolerance must be >= 0");
  if (!(initial_damping > 0.0) || !std::isfinite(initial_damping))
    return fail("initial_damping must be positive and finite");
  if (!(max_damping >= initial_damping)) return fail("max_damping must be >= initial_damping");
  if (!(sv_cutoff > 0.0 && sv_cutoff < 1.0)) return fail("sv_cutoff must be in (0, 1)");
  return true;
}

InfoAnalysis analyse_information(const Eigen::MatrixXd& A, double sv_cutoff) {
  const Eigen::Index p = A.rows();
  InfoAnalysis r;
  r.in_null_space.assign(static_cast<std::size_t>(p), false);
  Eigen::VectorXd d = A.diagonal().cwiseMax(0.0).cwiseSqrt();
  Eigen::VectorXd dinv(p);
  for (Eigen::Index i = 0; i < p; ++i) dinv(i) = d(i) > 0.0 ? 1.0 / d(i) : 0.0;
  Eigen::MatrixXd As = dinv.asDiagonal() * A * dinv.asDiagonal();
  // Why: a parameter whose column of J is exactly zero has no information at all; give it a
  // unit diagonal so the eigen-analysis puts it (alone) in the null space.
  for (Eigen::Index i = 0; i < p; ++i)
    if (d(i) == 0.0) As(i, i) = 0.0;
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(As);
  const Eigen::VectorXd& ev = es.eigenvalues();  // ascending
  const double emax = ev(p - 1);
  // Cut-off on singular values of the scaled J = sqrt(eigenvalues of the scaled A).
  const double cut = sv_cutoff * sv_cutoff * emax;
  Eigen::MatrixXd pin = Eigen::MatrixXd::Zero(p, p);
  for (Eigen::Index k = 0; k < p; ++k) {
    const Eigen::VectorXd vk = es.eigenvectors().col(k);
    if (ev(k) > cut && emax > 0.0) {
      pin += vk * vk.transpose() / ev(k);
      ++r.rank;
    } else {
      for (Eigen::Index i = 0; i < p; ++i)
        if (vk(i) * vk(i) > 0.01) r.in_null_space[static_cast<std::size_t>(i)] = true;
    }
  }
  for (Eigen::Index i = 0; i < p; ++i)
    if (d(i) == 0.0) r.in_null_space[static_cast<std::size_t>(i)] = true;
  r.pinv = dinv.asDiagonal() * pin * dinv.asDiagonal();
  return r;
}

LevenbergMarquardt::LevenbergMarquardt(const LeastSquaresProblem& p)
    : problem_(p), ldlt_(p.num_parameters()) {
  const Eigen::Index n = p.num_parameters(), m = p.num_residuals();
  r_.resize(m);
  r_trial_.resize(m);
  J_.resize(m, n);
  for (Eigen::VectorXd* v : {&g_, &diag_, &bound_, &delta_, &trial_}) v->resize(n);
  A_.resize(n, n);
  A_damped_.resize(n, n);
}

LevenbergMarquardtSummary LevenbergMarquardt::Solve(const LevenbergMarquardtOptions& o,
                                                    Eigen::VectorXd& x) {
  LevenbergMarquardtSummary s;
  cost_ = std::numeric_limits<double>::infinity();
  if (problem_.residuals(x, r_)) cost_ = 0.5 * r_.squaredNorm();
  s.initial_cost = cost_;
  s.cost = cost_;
  if (!std::isfinite(cost_)) {
    s.termination = Termination::diverged;
    s.message = "the start point cannot be evaluated (non-finite residuals); nothing estimated";
    return s;
  }
  lambda_ = o.initial_damping;
  for (int iteration = 1;; ++iteration) {
    if (iteration > o.max_iterations) {
      s.termination = Termination::iteration_limit;
      s.message = fmt::format("iteration limit ({}) reached before convergence; best estimate "
                              "kept", o.max_iterations);
      break;
    }
    s.iterations = iteration;
    const int infeasible_before = s.infeasible_trials;
    const std::size_t accepted_before = s.log.size();
    const Outcome out = iterate(o, iteration, x, s);
    // On the boundary: the last steps tried from the solution went to infeasible points.
    if (s.log.size() > accepted_before) s.boundary = FeasibilityBoundary::interior;
    else if (s.infeasible_trials > infeasible_before) s.boundary = FeasibilityBoundary::active;
    if (out != Outcome::stepped) break;
  }
  s.cost = cost_;
  return s;
}

// One outer iteration: `stepped` after an accepted step that did not pass the convergence
// tests, otherwise the termination (set in s).
LevenbergMarquardt::Outcome LevenbergMarquardt::iterate(const LevenbergMarquardtOptions& o,
                                                        int iteration, Eigen::VectorXd& x,
                                                        LevenbergMarquardtSummary& s) {
  if (!problem_.jacobian(x, r_, J_)) {
    s.termination = Termination::diverged;
    s.message = "sensitivities became non-finite; best estimate kept";
    return Outcome::diverged;
  }
  A_.noalias() = J_.transpose() * J_;
  g_.noalias() = J_.transpose() * r_;
  const InfoAnalysis info = analyse_information(A_, o.sv_cutoff);
  const double s2 = 2.0 * cost_ / static_cast<double>(problem_.num_residuals());
  for (Eigen::Index i = 0; i < bound_.size(); ++i)
    bound_(i) = std::sqrt(std::max(0.0, s2 * info.pinv(i, i)));
  diag_ = A_.diagonal();
  const double dmax = diag_.maxCoeff();
  // Why the floor: a zero column (unidentifiable parameter) would make the damped matrix
  // singular; a tiny floor keeps the solve defined and the step in that direction ~0.
  for (Eigen::Index i = 0; i < diag_.size(); ++i) diag_(i) = std::max(diag_(i), 1e-12 * dmax + 1e-300);
  for (bool first_trial = true;; first_trial = false) {
    A_damped_ = A_;
    A_damped_.diagonal() += lambda_ * diag_;
    ldlt_.compute(A_damped_);
    delta_ = ldlt_.solve(-g_);
    double step_in_bounds = 0.0;
    for (Eigen::Index i = 0; i < delta_.size(); ++i)
      if (!info.in_null_space[static_cast<std::size_t>(i)] && bound_(i) > 0.0)
        step_in_bounds = std::max(step_in_bounds, std::abs(delta_(i)) / bound_(i));
    double trial_cost = std::numeric_limits<double>::infinity();
    try_step(x, s, &trial_cost);
    if (trial_cost < cost_) {
      const double rel = (cost_ - trial_cost) / cost_;
      x = trial_;
      cost_ = trial_cost;
      s.log.push_back({iteration, cost_, lambda_, step_in_bounds});
      lambda_ = std::max(lambda_ * 0.1, 1e-10);
      if (rel < o.cost_tolerance && step_in_bounds < o.step_tolerance) {
        s.termination = Termination::converged;
        return Outcome::converged;
      }
      return Outcome::stepped;
    }
    // Why: when even the least-damped step is already negligible against the bounds, the
    // cost cannot go lower within round-off: we are at the minimum.
    if (first_trial && step_in_bounds < o.step_tolerance) {
      s.termination = Termination::converged;
      return Outcome::converged;
    }
    lambda_ *= 10.0;
    if (lambda_ > o.max_damping) {
      s.termination = Termination::diverged;
      s.message = "no damped Gauss-Newton step lowered the cost (damping above its limit); "
                  "best estimate kept";
      return Outcome::diverged;
    }
  }
}

// The cost at x + delta_ (infinite when the step is not finite, the point infeasible or not
// evaluable); trial_ holds the point.
bool LevenbergMarquardt::try_step(const Eigen::VectorXd& x, LevenbergMarquardtSummary& s,
                                  double* trial_cost) {
  trial_ = x + delta_;
  if (!delta_.allFinite()) return false;
  if (!problem_.feasible(trial_)) {
    ++s.infeasible_trials;
    return false;
  }
  if (!problem_.residuals(trial_, r_trial_)) return false;
  *trial_cost = 0.5 * r_trial_.squaredNorm();
  return true;
}

}  // namespace indicial::fit_detail
