// numerics/levenberg_marquardt.hpp -- a small dense Levenberg-Marquardt least-squares solver,
// shaped like Ceres' include/ceres/tiny_solver.h: the problem apart from the loop, Options
// that Solve validates (IsValid), a Summary with a Status, every matrix of the iteration
// allocated once.
//
// What it is for
// --------------
// The maximum-likelihood output-error fit (estimate/fit_output_error.cpp) minimises
// 0.5 |r(x)|^2 over the model parameters with exact sensitivities. This solver is that loop
// and nothing else: it knows residuals, a Jacobian and an admissibility predicate, not the
// model, the fitter's options or its messages. Its Status says what happened; the caller words
// it (and a command line turns it into advice).
//
// Usage
// -----
//   struct MyProblem : numerics::LeastSquaresProblem { ... };   // residuals, jacobian
//   numerics::LevenbergMarquardt lm(problem);                    // workspace sized here
//   numerics::LevenbergMarquardt::Options o;                     // documented defaults
//   Eigen::VectorXd x = start;
//   const numerics::LevenbergMarquardt::Summary& s = lm.Solve(o, x);   // x: the best point
//   if (s.status == numerics::LevenbergMarquardt::Status::invalid_options) ... s.options_error
//
// One outer iteration: the Jacobian at x, A = J'J, g = J'r, the Cramer-Rao bounds from A's
// pseudo-inverse (numerics/covariance.hpp); then damped steps (A + lambda diag(A)) d = -g,
// lambda times 10 after each rejection and divided by 10 (not below 1e-10) after an
// acceptance. Converged: an accepted step with relative cost change below cost_tolerance AND
// every parameter step below step_tolerance bounds, or a first (least-damped) trial already
// below step_tolerance bounds that does not lower the cost (the cost cannot decrease further
// within round-off).
//
// Warnings
// --------
// 1. Convergence is judged in Cramer-Rao bounds: the step of parameter i is compared with
//    sqrt(s^2 [(J'J)^+]_ii), s^2 = 2 cost / (number of residuals) -- the statistics of a
//    maximum-likelihood fit with white residuals, not a scale-free tolerance.
// 2. A trial point the problem calls infeasible (LeastSquaresProblem::feasible) is rejected
//    like a cost increase: the damping grows and the step shrinks. The solution may then sit
//    on the feasibility boundary; Summary::boundary says so. The start point is not checked.
// 3. Non-finite residuals at a trial point also reject it; non-finite ones at the start point
//    end the solve (Status::start_not_evaluable, cost = inf, x unchanged).
// 4. No heap allocation per iteration: the constructor sizes the workspace, Solve reserves
//    the log for max_iterations steps before the first; the iterations allocate nothing of
//    their own (test_alloc.cpp counts it). The problem's residuals and jacobian are the
//    caller's: they allocate or not.
#pragma once

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include <string>
#include <vector>

#include "numerics/covariance.hpp"

namespace indicial::numerics {

// r(x) and J = dr/dx. residuals/jacobian return false when x cannot be evaluated (the solver
// treats that like an infinite cost).
class LeastSquaresProblem {
 public:
  virtual ~LeastSquaresProblem() = default;
  virtual int num_parameters() const = 0;
  virtual int num_residuals() const = 0;
  virtual bool residuals(const Eigen::VectorXd& x, Eigen::VectorXd& r) const = 0;
  virtual bool jacobian(const Eigen::VectorXd& x, Eigen::VectorXd& r, Eigen::MatrixXd& J) const = 0;
  // Whether x is admissible (e.g. a model whose lags decay everywhere on the envelope).
  virtual bool feasible(const Eigen::VectorXd& /*x*/) const { return true; }
};

class LevenbergMarquardt {
 public:
  struct Options {
    int max_iterations = 50;       // accepted or rejected outer iterations (Jacobians)
    double cost_tolerance = 1e-8;  // converged: relative cost change below this AND ...
    double step_tolerance = 1e-3;  // ... every parameter step below this many CR bounds
    double initial_damping = 1e-3;
    double max_damping = 1e12;     // damping_limit: it grows above this without a descent
    double sv_cutoff = 1e-8;       // rank decision of the information matrix (covariance.hpp)
    bool IsValid(std::string* error) const;
  };

  enum class Status {
    converged,            // the convergence tests passed
    iteration_limit,      // max_iterations reached; the best point is kept
    start_not_evaluable,  // non-finite residuals at the start; nothing done
    jacobian_not_finite,  // the Jacobian became non-finite; the best point is kept
    damping_limit,        // no damped step lowered the cost before max_damping; best kept
    invalid_options       // Options::IsValid failed (Summary::options_error); nothing done
  };

  // Whether the last steps tried from the solution went to infeasible points.
  enum class Boundary { interior, active };

  struct Step {
    int iteration = 0;
    double cost = 0.0;                // 0.5 |r|^2 after the step
    double damping = 0.0;             // lambda of the accepted step
    double max_step_in_bounds = 0.0;  // max |dx_i| / CR bound_i
  };

  struct Summary {
    Status status = Status::converged;
    int iterations = 0;
    double initial_cost = 0.0;
    double cost = 0.0;              // 0.5 |r|^2 at the returned x
    std::vector<Step> log;          // accepted steps
    int infeasible_trials = 0;      // trial steps rejected as infeasible
    Boundary boundary = Boundary::interior;
    std::string options_error;      // Status::invalid_options: which option and why
  };

  explicit LevenbergMarquardt(const LeastSquaresProblem& p);
  // Minimises 0.5 |r(x)|^2 from x; x is replaced by the best point found. The summary lives
  // until the next Solve.
  const Summary& Solve(const Options& o, Eigen::VectorXd& x);

 private:
  enum class Outcome { stepped, finished };
  Outcome iterate(const Options& o, int iteration, Eigen::VectorXd& x);
  bool try_step(const Eigen::VectorXd& x, double* trial_cost);

  const LeastSquaresProblem& problem_;
  Summary summary_;
  // Workspace, sized once.
  Eigen::VectorXd r_, r_trial_, g_, diag_, bound_, delta_, trial_;
  Eigen::MatrixXd J_, A_, A_damped_;
  Eigen::LDLT<Eigen::MatrixXd> ldlt_;
  Covariance information_;
  double cost_ = 0.0;
  double lambda_ = 0.0;
};

}  // namespace indicial::numerics
