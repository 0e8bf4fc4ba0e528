// numerics/levenberg_marquardt.cpp -- the Levenberg-Marquardt loop (see the header).
#include "numerics/levenberg_marquardt.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace indicial::numerics {

bool LevenbergMarquardt::Options::IsValid(std::string* error) const {
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

LevenbergMarquardt::LevenbergMarquardt(const LeastSquaresProblem& p)
    : problem_(p), ldlt_(p.num_parameters()), information_(p.num_parameters(), Covariance::Options{}) {
  const Eigen::Index n = p.num_parameters(), m = p.num_residuals();
  r_.resize(m);
  r_trial_.resize(m);
  J_.resize(m, n);
  for (Eigen::VectorXd* v : {&g_, &diag_, &bound_, &delta_, &trial_}) v->resize(n);
  A_.resize(n, n);
  A_damped_.resize(n, n);
}

const LevenbergMarquardt::Summary& LevenbergMarquardt::Solve(const Options& o, Eigen::VectorXd& x) {
  summary_.status = Status::converged;
  summary_.iterations = 0;
  summary_.log.clear();
  summary_.infeasible_trials = 0;
  summary_.boundary = Boundary::interior;
  summary_.options_error.clear();
  cost_ = std::numeric_limits<double>::infinity();
  if (!o.IsValid(&summary_.options_error)) {
    summary_.status = Status::invalid_options;
    summary_.initial_cost = summary_.cost = cost_;
    return summary_;
  }
  information_ = Covariance(problem_.num_parameters(), Covariance::Options{o.sv_cutoff, 0.01});
  summary_.log.reserve(static_cast<std::size_t>(o.max_iterations));
  if (problem_.residuals(x, r_)) cost_ = 0.5 * r_.squaredNorm();
  summary_.initial_cost = cost_;
  summary_.cost = cost_;
  if (!std::isfinite(cost_)) {
    summary_.status = Status::start_not_evaluable;
    return summary_;
  }
  lambda_ = o.initial_damping;
  for (int iteration = 1;; ++iteration) {
    if (iteration > o.max_iterations) {
      summary_.status = Status::iteration_limit;
      break;
    }
    summary_.iterations = iteration;
    const int infeasible_before = summary_.infeasible_trials;
    const std::size_t accepted_before = summary_.log.size();
    const Outcome out = iterate(o, iteration, x);
    // On the boundary: the last steps tried from the solution went to infeasible points.
    if (summary_.log.size() > accepted_before) summary_.boundary = Boundary::interior;
    else if (summary_.infeasible_trials > infeasible_before) summary_.boundary = Boundary::active;
    if (out != Outcome::stepped) break;
  }
  summary_.cost = cost_;
  return summary_;
}

// One outer iteration: `stepped` after an accepted step that did not pass the convergence
// tests, otherwise `finished` with summary_.status set.
LevenbergMarquardt::Outcome LevenbergMarquardt::iterate(const Options& o, int iteration,
                                                        Eigen::VectorXd& x) {
  if (!problem_.jacobian(x, r_, J_)) {
    summary_.status = Status::jacobian_not_finite;
    return Outcome::finished;
  }
  A_.noalias() = J_.transpose() * J_;
  g_.noalias() = J_.transpose() * r_;
  information_.Compute(A_);
  const Eigen::MatrixXd& pinv = information_.pseudo_inverse();
  const double s2 = 2.0 * cost_ / static_cast<double>(problem_.num_residuals());
  for (Eigen::Index i = 0; i < bound_.size(); ++i)
    bound_(i) = std::sqrt(std::max(0.0, s2 * pinv(i, i)));
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
      if (!information_.in_null_space(static_cast<int>(i)) && bound_(i) > 0.0)
        step_in_bounds = std::max(step_in_bounds, std::abs(delta_(i)) / bound_(i));
    double trial_cost = std::numeric_limits<double>::infinity();
    if (try_step(x, &trial_cost) && trial_cost < cost_) {
      const double rel = (cost_ - trial_cost) / cost_;
      x = trial_;
      cost_ = trial_cost;
      summary_.log.push_back({iteration, cost_, lambda_, step_in_bounds});
      lambda_ = std::max(lambda_ * 0.1, 1e-10);
      if (rel < o.cost_tolerance && step_in_bounds < o.step_tolerance) {
        summary_.status = Status::converged;
        return Outcome::finished;
      }
      return Outcome::stepped;
    }
    // Why: when even the least-damped step is already negligible against the bounds, the
    // cost cannot go lower within round-off: we are at the minimum.
    if (first_trial && step_in_bounds < o.step_tolerance) {
      summary_.status = Status::converged;
      return Outcome::finished;
    }
    lambda_ *= 10.0;
    if (lambda_ > o.max_damping) {
      summary_.status = Status::damping_limit;
      return Outcome::finished;
    }
  }
}

// Whether x + delta_ could be evaluated (a finite step to a feasible point with residuals);
// then *trial_cost is its cost. trial_ holds the point.
bool LevenbergMarquardt::try_step(const Eigen::VectorXd& x, double* trial_cost) {
  trial_ = x + delta_;
  if (!delta_.allFinite()) return false;
  if (!problem_.feasible(trial_)) {
    ++summary_.infeasible_trials;
    return false;
  }
  if (!problem_.residuals(trial_, r_trial_)) return false;
  *trial_cost = 0.5 * r_trial_.squaredNorm();
  return true;
}

}  // namespace indicial::numerics
