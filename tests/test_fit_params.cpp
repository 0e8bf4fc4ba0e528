// Parameter identity (ParamId: names made and read in one place each) and the output-error
// solver's feasibility hook (fitter/src/estimate/fit_levenberg_marquardt.hpp).
#include <doctest/doctest.h>

#include <Eigen/Core>
#include <cmath>
#include <string>
#include <unordered_map>
#include <vector>

#include "estimate/fit_levenberg_marquardt.hpp"
#include "indicial/fitter/fit.hpp"

using namespace indicial;

namespace {

ParamId id_of(ParamKind kind, int lag = 0, int power = 0, int knot = 0, double knot_rad = 0.0,
              int run = 0) {
  ParamId id;
  id.kind = kind;
  id.lag = lag;
  id.power = power;
  id.knot = knot;
  id.knot_rad = knot_rad;
  id.run = run;
  return id;
}

}  // namespace

TEST_CASE("parameter names: the contract spelling, and parse_parameter_name inverts it") {
  struct Row { ParamId id; const char* name; };
  const Row rows[] = {
      {id_of(ParamKind::a_power, 0, 2), "a2"},
      {id_of(ParamKind::a_knot, 0, 2, 1, 0.9), "A2"},
      {id_of(ParamKind::b_power, 0, 0), "b1_0"},
      {id_of(ParamKind::b_knot, 0, 1, 3, 0.5), "B4"},
      {id_of(ParamKind::b_power, 2, 1), "b3_1"},
      {id_of(ParamKind::b_knot, 1, 1, 0, 0.5), "B2_1"},
      {id_of(ParamKind::con), "con"},
      {id_of(ParamKind::gain, 1), "c2"},
      {id_of(ParamKind::delay), "delay_s"},
      {id_of(ParamKind::rotary_power, 0, 2), "Caq_2"},
      {id_of(ParamKind::rotary_knot, 0, 1, 0, 0.3), "CaqK1"},
      {id_of(ParamKind::static_power, 0, 1), "dCa_1"},
      {id_of(ParamKind::static_knot, 0, 2, 1, 0.7), "dCaK2"},
      {id_of(ParamKind::initial_state, 0, 0, 0, 0.0, 2), "y0_3"},
      {id_of(ParamKind::initial_state, 1, 0, 0, 0.0, 2), "y0_3_2"},
  };
  for (const Row& r : rows) {
    CAPTURE(r.name);
    CHECK(parameter_name(r.id) == r.name);
    ParamId back;
    REQUIRE(parse_parameter_name(r.name, &back));
    CHECK(back.kind == r.id.kind);
    CHECK(back.lag == r.id.lag);
    CHECK(back.knot == r.id.knot);
    CHECK(back.run == r.id.run);
    CHECK(parameter_name(back) == r.name);
  }
  for (const char* bad : {"", "a", "A0", "b1", "b1_01", "B1_2", "c1", "c", "y0_0", "y0_1_1",
                          "Caq", "con2", "delay", "x1", "a-1", "b0_0"}) {
    CAPTURE(bad);
    ParamId id;
    CHECK_FALSE(parse_parameter_name(bad, &id));
  }
}

TEST_CASE("parameter identity: a knot is where it is, not its number") {
  const ParamId a_at_05_first = id_of(ParamKind::a_knot, 0, 2, 0, 0.5);
  const ParamId a_at_05_second = id_of(ParamKind::a_knot, 0, 2, 1, 0.5);  // renumbered
  const ParamId a_at_06 = id_of(ParamKind::a_knot, 0, 2, 0, 0.6);
  CHECK(a_at_05_first == a_at_05_second);
  CHECK(ParamIdHash{}(a_at_05_first) == ParamIdHash{}(a_at_05_second));
  CHECK(a_at_05_first != a_at_06);
  CHECK(parameter_name(a_at_05_first) != parameter_name(a_at_05_second));
  CHECK(id_of(ParamKind::b_power, 0, 0) != id_of(ParamKind::b_power, 1, 0));
  CHECK(id_of(ParamKind::initial_state, 0, 0, 0, 0, 1) != id_of(ParamKind::initial_state, 0, 0, 0, 0, 2));
  CHECK((a_at_05_first < a_at_06) != (a_at_06 < a_at_05_first));
  std::unordered_map<ParamId, int, ParamIdHash> m;
  m[a_at_05_first] = 1;
  m[a_at_05_second] += 1;
  m[a_at_06] = 5;
  CHECK(m.size() == 2);
  CHECK(m[a_at_05_first] == 2);
}

namespace {

// r_i = x - target_i: the least-squares minimum is the mean of the targets (3.05 here).
struct MeanProblem final : fit_detail::LeastSquaresProblem {
  std::vector<double> targets{2.9, 3.1, 3.0, 3.2, 3.05, 2.95, 3.1, 3.0, 3.15, 3.05};
  double upper = 0.0;  // feasible: x <= upper (0: no limit)
  int num_parameters() const override { return 1; }
  int num_residuals() const override { return static_cast<int>(targets.size()); }
  bool residuals(const Eigen::VectorXd& x, Eigen::VectorXd& r) const override {
    r.resize(num_residuals());
    for (int i = 0; i < num_residuals(); ++i) r(i) = x(0) - targets[static_cast<std::size_t>(i)];
    return true;
  }
  bool jacobian(const Eigen::VectorXd& x, Eigen::VectorXd& r, Eigen::MatrixXd& J) const override {
    J = Eigen::MatrixXd::Ones(num_residuals(), 1);
    return residuals(x, r);
  }
  bool feasible(const Eigen::VectorXd& x) const override { return upper == 0.0 || x(0) <= upper; }
};

}  // namespace

TEST_CASE("Levenberg-Marquardt: options are validated, the minimum is found") {
  fit_detail::LevenbergMarquardtOptions o;
  std::string why;
  CHECK(o.IsValid(&why));
  o.max_damping = o.initial_damping / 2;
  CHECK_FALSE(o.IsValid(&why));
  CHECK(why.find("max_damping") != std::string::npos);

  MeanProblem p;
  fit_detail::LevenbergMarquardt lm(p);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(1);
  const auto s = lm.Solve(fit_detail::LevenbergMarquardtOptions{}, x);
  CHECK(s.termination == Termination::converged);
  CHECK(x(0) == doctest::Approx(3.05).epsilon(1e-9));
  CHECK(s.infeasible_trials == 0);
  CHECK(s.boundary == FeasibilityBoundary::interior);
}

TEST_CASE("Levenberg-Marquardt: an infeasible trial is rejected like a cost increase") {
  MeanProblem p;
  p.upper = 2.0;  // the unconstrained minimum 3.05 is not admissible
  fit_detail::LevenbergMarquardt lm(p);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(1);
  const auto s = lm.Solve(fit_detail::LevenbergMarquardtOptions{}, x);
  INFO("x = " << x(0) << ", " << s.message);
  CHECK(x(0) <= 2.0);          // never left the admissible set
  CHECK(x(0) > 2.0 - 1e-3);    // and went as far as it allows
  CHECK(s.infeasible_trials > 0);
  CHECK(s.boundary == FeasibilityBoundary::active);
  CHECK(s.cost < s.initial_cost);
  // An interior start with the limit beyond the minimum: never on the boundary.
  p.upper = 10.0;
  fit_detail::LevenbergMarquardt lm2(p);
  Eigen::VectorXd x2 = Eigen::VectorXd::Zero(1);
  const auto s2 = lm2.Solve(fit_detail::LevenbergMarquardtOptions{}, x2);
  CHECK(s2.boundary == FeasibilityBoundary::interior);
  CHECK(x2(0) == doctest::Approx(3.05).epsilon(1e-9));
}
