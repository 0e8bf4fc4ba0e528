// The Levenberg-Marquardt solver (fitter/src/numerics/levenberg_marquardt.hpp), after Ceres'
// internal/ceres/tiny_solver_test.cc: Solve validates its options, finds known minima, rejects
// infeasible trials, and reports each way of stopping with its Status. Its allocations are
// counted in test_alloc.cpp.
#include <doctest/doctest.h>

#include <Eigen/Core>
#include <string>

#include "levenberg_marquardt_problems.hpp"
#include "numerics/levenberg_marquardt.hpp"

TEST_SUITE_BEGIN("unit");  // the ctest label (tests/CMakeLists.txt)

using indicial::numerics::LevenbergMarquardt;
using indicial::testing::MeanProblem;
using indicial::testing::RosenbrockProblem;
using Status = LevenbergMarquardt::Status;

TEST_CASE("Levenberg-Marquardt: IsValid names the option, Solve refuses invalid options") {
  LevenbergMarquardt::Options o;
  std::string why;
  CHECK(o.IsValid(&why));
  o.max_damping = o.initial_damping / 2;
  CHECK_FALSE(o.IsValid(&why));
  CHECK(why.find("max_damping") != std::string::npos);

  MeanProblem p;
  LevenbergMarquardt lm(p);
  Eigen::VectorXd x = Eigen::VectorXd::Constant(1, 7.0);
  using Breaker = void (*)(LevenbergMarquardt::Options&);
  const Breaker breakers[] = {[](LevenbergMarquardt::Options& b) { b.max_iterations = -1; },
                              [](LevenbergMarquardt::Options& b) { b.sv_cutoff = 0.0; },
                              [](LevenbergMarquardt::Options& b) { b.initial_damping = -1.0; },
                              [](LevenbergMarquardt::Options& b) { b.cost_tolerance = -1.0; }};
  for (Breaker bad : breakers) {
    LevenbergMarquardt::Options b;
    bad(b);
    const LevenbergMarquardt::Summary& s = lm.Solve(b, x);
    CHECK(s.status == Status::invalid_options);
    CHECK_FALSE(s.options_error.empty());
    CHECK(s.iterations == 0);
    CHECK(x(0) == 7.0);  // nothing done
  }
}

TEST_CASE("Levenberg-Marquardt: the minimum of a linear problem is found") {
  MeanProblem p;
  LevenbergMarquardt lm(p);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(1);
  const LevenbergMarquardt::Summary& s = lm.Solve(LevenbergMarquardt::Options{}, x);
  CHECK(s.status == Status::converged);
  CHECK(x(0) == doctest::Approx(3.05).epsilon(1e-9));
  CHECK(s.infeasible_trials == 0);
  CHECK(s.boundary == LevenbergMarquardt::Boundary::interior);
  CHECK(s.cost < s.initial_cost);
  REQUIRE_FALSE(s.log.empty());
  CHECK(s.log.back().cost == doctest::Approx(s.cost));
}

TEST_CASE("Levenberg-Marquardt: Rosenbrock's valley, from tiny_solver_test's start") {
  RosenbrockProblem p;
  LevenbergMarquardt lm(p);
  Eigen::VectorXd x(2);
  x << -1.2, 1.0;
  LevenbergMarquardt::Options o;
  o.max_iterations = 200;
  const LevenbergMarquardt::Summary& s = lm.Solve(o, x);
  INFO("iterations " << s.iterations << ", x = " << x.transpose());
  CHECK(s.status == Status::converged);
  CHECK(x(0) == doctest::Approx(1.0).epsilon(1e-6));
  CHECK(x(1) == doctest::Approx(1.0).epsilon(1e-6));
  CHECK(s.cost < 1e-12);
  CHECK(s.iterations > 5);  // a curved valley: not a one-step problem
}

TEST_CASE("Levenberg-Marquardt: the iteration limit keeps the best point") {
  RosenbrockProblem p;
  LevenbergMarquardt lm(p);
  Eigen::VectorXd x(2);
  x << -1.2, 1.0;
  LevenbergMarquardt::Options o;
  o.max_iterations = 3;
  const LevenbergMarquardt::Summary& s = lm.Solve(o, x);
  CHECK(s.status == Status::iteration_limit);
  CHECK(s.iterations == 3);
  CHECK(s.cost < s.initial_cost);
}

TEST_CASE("Levenberg-Marquardt: an unevaluable start is reported, x unchanged") {
  RosenbrockProblem p;
  p.not_evaluable_below = 0.0;
  LevenbergMarquardt lm(p);
  Eigen::VectorXd x(2);
  x << -1.2, 1.0;
  const LevenbergMarquardt::Summary& s = lm.Solve(LevenbergMarquardt::Options{}, x);
  CHECK(s.status == Status::start_not_evaluable);
  CHECK(x(0) == -1.2);
  CHECK(x(1) == 1.0);
}

TEST_CASE("Levenberg-Marquardt: an infeasible trial is rejected like a cost increase") {
  MeanProblem p;
  p.upper = 2.0;  // the unconstrained minimum 3.05 is not admissible
  LevenbergMarquardt lm(p);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(1);
  const LevenbergMarquardt::Summary& s = lm.Solve(LevenbergMarquardt::Options{}, x);
  INFO("x = " << x(0));
  CHECK(x(0) <= 2.0);          // never left the admissible set
  CHECK(x(0) > 2.0 - 1e-3);    // and went as far as it allows
  CHECK(s.infeasible_trials > 0);
  CHECK(s.boundary == LevenbergMarquardt::Boundary::active);
  CHECK(s.cost < s.initial_cost);
  // An interior start with the limit beyond the minimum: never on the boundary.
  p.upper = 10.0;
  LevenbergMarquardt lm2(p);
  Eigen::VectorXd x2 = Eigen::VectorXd::Zero(1);
  const LevenbergMarquardt::Summary& s2 = lm2.Solve(LevenbergMarquardt::Options{}, x2);
  CHECK(s2.boundary == LevenbergMarquardt::Boundary::interior);
  CHECK(x2(0) == doctest::Approx(3.05).epsilon(1e-9));
}
