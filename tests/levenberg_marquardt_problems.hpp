// levenberg_marquardt_problems.hpp -- small least-squares problems for the solver's tests
// (test_levenberg_marquardt.cpp, test_alloc.cpp), after Ceres' tiny_solver_test.cc. Their
// residuals and Jacobians write into the caller's vectors without allocating (the vectors
// come sized from the solver), so an allocation counted around Solve is the solver's.
#pragma once

#include <Eigen/Core>

#include <vector>

#include "numerics/levenberg_marquardt.hpp"

namespace indicial::testing {

// r_i = x - target_i: the least-squares minimum is the mean of the targets (3.05 here).
// feasible: x <= upper (0: no limit).
struct MeanProblem final : numerics::LeastSquaresProblem {
  std::vector<double> targets{2.9, 3.1, 3.0, 3.2, 3.05, 2.95, 3.1, 3.0, 3.15, 3.05};
  double upper = 0.0;
  int num_parameters() const override { return 1; }
  int num_residuals() const override { return static_cast<int>(targets.size()); }
  bool residuals(const Eigen::VectorXd& x, Eigen::VectorXd& r) const override {
    r.resize(num_residuals());
    for (int i = 0; i < num_residuals(); ++i) r(i) = x(0) - targets[static_cast<std::size_t>(i)];
    return true;
  }
  bool jacobian(const Eigen::VectorXd& x, Eigen::VectorXd& r, Eigen::MatrixXd& J) const override {
    J.resize(num_residuals(), 1);
    J.setOnes();
    return residuals(x, r);
  }
  bool feasible(const Eigen::VectorXd& x) const override { return upper == 0.0 || x(0) <= upper; }
};

// Rosenbrock's function as least squares: r = (10 (x1 - x0^2), 1 - x0), minimum (1, 1) with
// cost 0, a curved valley that takes the solver many iterations from (-1.2, 1).
// not_evaluable_below: residuals fail for x0 below it (to test an unevaluable start).
struct RosenbrockProblem final : numerics::LeastSquaresProblem {
  double not_evaluable_below = -1e300;
  int num_parameters() const override { return 2; }
  int num_residuals() const override { return 2; }
  bool residuals(const Eigen::VectorXd& x, Eigen::VectorXd& r) const override {
    if (x(0) < not_evaluable_below) return false;
    r.resize(2);
    r(0) = 10.0 * (x(1) - x(0) * x(0));
    r(1) = 1.0 - x(0);
    return true;
  }
  bool jacobian(const Eigen::VectorXd& x, Eigen::VectorXd& r, Eigen::MatrixXd& J) const override {
    J.resize(2, 2);
    J(0, 0) = -20.0 * x(0);
    J(0, 1) = 10.0;
    J(1, 0) = -1.0;
    J(1, 1) = 0.0;
    return residuals(x, r);
  }
};

}  // namespace indicial::testing
