// fit_levenberg_marquardt.hpp -- a small Levenberg-Marquardt least-squares solver in the style
// of Ceres' tiny_solver.h: the problem apart from the loop, Options with IsValid, a Summary
// with a termination type, the iteration's matrices allocated once.
//
// What it is for
// --------------
// The maximum-likelihood output-error fit (fit_output_error.cpp) minimises J = 0.5 |r(x)|^2
// over the model parameters with exact sensitivities. This solver is that loop and nothing
// else: it knows residuals, a Jacobian and an admissibility predicate, not the model.
//
// Usage
// -----
//   struct MyProblem : fit_detail::LeastSquaresProblem { ... };    // residuals, jacobian
//   fit_detail::LevenbergMarquardt lm(problem);
//   fit_detail::LevenbergMarquardtOptions o;                        // documented defaults
//   std::string why;
//   if (!o.IsValid(&why)) ...;
//   Eigen::VectorXd x = start;
//   const fit_detail::LevenbergMarquardtSummary s = lm.Solve(o, x);   // x: the best point
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
//    end the solve (Termination::diverged, cost = inf, x unchanged).
#pragma once

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include <string>
#include <vector>

#include "indicial/fitter/fit.hpp"

namespace indicial::fit_detail {

// r(x) and J = dr/dx. residuals/jacobian return false when x cannot be evaluated (the caller
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

struct LevenbergMarquardtOptions {
  int max_iterations = 50;       // accepted or rejected outer iterations (Jacobians)
  double cost_tolerance = 1e-8;  // converged: relative cost change below this AND ...
  double step_tolerance = 1e-3;  // ... every parameter step below this many CR bounds
  double initial_damping = 1e-3;
  double max_damping = 1e12;     // diverged: the damping grows above this without a descent
  double sv_cutoff = 1e-8;       // rank decision of the information matrix (see fit.hpp)
  bool IsValid(std::string* error) const;
};

struct LevenbergMarquardtSummary {
  Termination termination = Termination::converged;
  int iterations = 0;
  double initial_cost = 0.0;
  double cost = 0.0;                       // 0.5 |r|^2 at the returned x
  std::vector<OutputErrorIteration> log;   // accepted steps
  int infeasible_trials = 0;               // trial steps rejected as infeasible
  // active: steps tried from the solution went to infeasible points (none accepted after).
  FeasibilityBoundary boundary = FeasibilityBoundary::interior;
  std::string message;                     // one line; empty when converged
};

// The information matrix A = J'J analysed on unit-diagonal scaling: the pseudo-inverse on its
// numerical range, the rank, and which parameters touch the null space.
struct InfoAnalysis {
  Eigen::MatrixXd pinv;
  int rank = 0;
  std::vector<bool> in_null_space;
};
InfoAnalysis analyse_information(const Eigen::MatrixXd& A, double sv_cutoff);

class LevenbergMarquardt {
 public:
  explicit LevenbergMarquardt(const LeastSquaresProblem& p);
  // Minimises 0.5 |r(x)|^2 from x; x is replaced by the best point found.
  LevenbergMarquardtSummary Solve(const LevenbergMarquardtOptions& o, Eigen::VectorXd& x);

 private:
  enum class Outcome { stepped, converged, diverged };
  Outcome iterate(const LevenbergMarquardtOptions& o, int iteration, Eigen::VectorXd& x,
                  LevenbergMarquardtSummary& s);
  bool try_step(const Eigen::VectorXd& x, LevenbergMarquardtSummary& s, double* trial_cost);

  const LeastSquaresProblem& problem_;
  // Workspace, sized once.
  Eigen::VectorXd r_, r_trial_, g_, diag_, bound_, delta_, trial_;
  Eigen::MatrixXd J_, A_, A_damped_;
  Eigen::LDLT<Eigen::MatrixXd> ldlt_;
  double cost_ = 0.0;
  double lambda_ = 0.0;
};

}  // namespace indicial::fit_detail
