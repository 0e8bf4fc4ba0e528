// The output-error fit's sensitivities (fit_output_error.cpp): the Jacobian its solver and its
// Cramer-Rao bounds use, computed by forward autodiff in chains of their own (the lags'
// parameters with each run's y0; the stall states' parameters; the stall output's), against
// central finite differences of the residuals, on models that mix every kind of structural
// parameter: a(x) with a knot, two lags (gain, y0 per run), con, a delay, the separation and
// vortex families with T1r, a first-order forcing lag and an f0 correction, and output terms;
// one periodic and one non-periodic run. A parameter put in the wrong chain (is_stall_parameter,
// is_stall_output_parameter) loses part of its column and fails here. Two sizes of each chain
// are reached (lags 16 and 8; stall states 8 and 16; stall output 16 and 64), and a held stall
// parameter (model.stall_known) leaves the vector.
#include <doctest/doctest.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "estimate/fit_internal.hpp"
#include "indicial/fitter/fit.hpp"
#include "indicial/model.hpp"

TEST_SUITE_BEGIN("unit");  // the ctest label (tests/CMakeLists.txt)

using namespace indicial;
using namespace indicial::fit_detail;

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

// A NACA 0012-like separation (Leishman-Beddoes' f0), as stall_truth_data.hpp's polar.
double polar_f0(double x) {
  const double a = std::abs(x) / kDeg;
  return a <= 15.25 ? 1.0 - 0.3 * std::exp((a - 15.25) / 3.0) : 0.04 + 0.66 * std::exp((15.25 - a) / 2.3);
}

// One run of n samples at 30 m/s (l = 0.275 m), the angle mean +- amplitude at reduced
// frequency k; periodic (an open cycle) or not (1.3 cycles from a phase of 0.4 rad).
PreparedRun run(double mean_deg, double amp_deg, double k, bool periodic, int n) {
  PreparedRun r;
  r.path = periodic ? "periodic.csv" : "transient.csv";
  r.periodic = periodic;
  r.airspeed_mps = r.reference_airspeed_mps = 30.0;
  r.l_over_v_s = 0.275 / 30.0;
  const double omega = k / r.l_over_v_s;
  const double span_s = (periodic ? 1.0 : 1.3) * 2 * kPi / omega;
  r.dt_s = span_s / n;
  for (int i = 0; i < n; ++i) {
    const double t = i * r.dt_s, phase = omega * t + (periodic ? 0.0 : 0.4);
    r.t.push_back(t);
    r.x.push_back((mean_deg + amp_deg * std::sin(phase)) * kDeg);
    r.xdot.push_back(amp_deg * kDeg * omega * std::cos(phase));
    r.rate.push_back(r.xdot.back());
    r.coef.push_back(0.3 * std::sin(phase + 0.5));  // any measurement: v's derivative ignores it
  }
  return r;
}

StallStructure stall(const std::vector<double>& f0_knots_deg) {
  StallStructure s;
  s.families = StallFamilies::separation_and_vortex;
  s.normal_force_slope_per_rad = 6.3;
  s.zero_lift_angle_rad = 0.0;
  for (int a = -5; a <= 35; ++a) {
    s.f0_x_rad.push_back(a * kDeg);
    s.f0_value.push_back(polar_f0(a * kDeg));
  }
  s.f0_correction.powers = {0, 1};
  for (double k : f0_knots_deg) s.f0_correction.knots_rad.push_back(k * kDeg);
  s.reattachment = StallReattachment::estimated;
  s.hysteresis = StallHysteresis::estimated;
  s.forcing_lag = ForcingLag::first_order;
  return s;
}

// A value for every parameter, inside the feasible set, away from the model's non-smooth
// points (f0 + correction inside (0, 1) where it is not 1, the vortex shedding on the cycles).
double value_of(const ParamId& id) {
  switch (id.kind) {
    case ParamKind::a_power: return id.power == 0 ? 3.0 : 1.5;
    case ParamKind::a_knot: return -2.0;
    case ParamKind::b_power: return id.lag == 0 ? (id.power == 0 ? 12.0 : 4.0) : 40.0;
    case ParamKind::b_knot: return 6.0;
    case ParamKind::con: return 0.2;
    case ParamKind::gain: return -0.3;
    case ParamKind::delay: return 0.004;
    case ParamKind::rotary_power: return -2.0;
    case ParamKind::rotary_knot: return 1.0;
    case ParamKind::static_power: return 0.01;
    case ParamKind::static_knot: return -0.02;
    case ParamKind::initial_state: return 0.02 * (id.lag + 1);
    case ParamKind::stall_tau1: return 3.0;
    case ParamKind::stall_tau2: return 1.5;
    case ParamKind::stall_tau1_reattach: return 5.0;
    case ParamKind::stall_reattach_shift: return 0.05;
    case ParamKind::stall_lag_limit: return 0.02;  // 1.1 deg: the lag on these cycles reaches 2
    case ParamKind::f0_power: return id.power == 0 ? -0.02 : 0.05;
    case ParamKind::f0_knot: return 0.01;
    case ParamKind::stall_cp: return id.power == 0 ? 0.01 : id.power == 1 ? -0.1 : 0.05;
    case ParamKind::shedding_threshold: return 1.2;
    case ParamKind::vortex_decay: return 6.0;
    case ParamKind::vortex_travel: return 7.0;
    case ParamKind::vortex_lift: return 0.8;
    case ParamKind::vortex_cp: return 0.3;
  }
  return 0.0;
}

struct Case {
  UnsteadyStructure structure;
  std::vector<PreparedRun> runs;
};

// Checks the autodiff Jacobian against central differences, column by column: every column
// nonzero (each parameter moves the output) and within 1e-6 of its largest entry.
void check_against_finite_differences(const Case& c) {
  const ParameterLayout L(c.structure, c.runs);
  const CoefficientModel<double, Cap> known{};
  const std::string file = "experiment.toml";
  const OutputErrorData d{c.runs, known, file, AngleRange{-10 * kDeg, 35 * kDeg}};
  Eigen::VectorXd theta(L.size());
  for (int k = 0; k < L.size(); ++k) theta(k) = value_of(L.ids()[static_cast<std::size_t>(k)]);
  Eigen::VectorXd v, v_plain, vp, vm;
  Eigen::MatrixXd J;
  REQUIRE(output_error_jacobian(L, d, theta, v, J));
  REQUIRE(output_error_residuals(L, d, theta, v_plain));
  CHECK((v - v_plain).cwiseAbs().maxCoeff() == 0.0);  // the two evaluations agree bit for bit
  const std::vector<std::string> names = L.names();
  for (int k = 0; k < L.size(); ++k) {
    const double h = 1e-6 * std::max(1.0, std::abs(theta(k)));
    Eigen::VectorXd tp = theta, tm = theta;
    tp(k) += h;
    tm(k) -= h;
    REQUIRE(output_error_residuals(L, d, tp, vp));
    REQUIRE(output_error_residuals(L, d, tm, vm));
    const Eigen::VectorXd fd = (vp - vm) / (2 * h);
    const double scale = J.col(k).cwiseAbs().maxCoeff();
    INFO("parameter ", names[static_cast<std::size_t>(k)], ": largest |dv/dtheta| ", scale);
    CHECK(scale > 0.0);
    CHECK((J.col(k) - fd).cwiseAbs().maxCoeff() <= 1e-6 * scale);
  }
}

}  // namespace

TEST_CASE("output-error sensitivities match finite differences (lags, delay, stall, y0 per run)") {
  Case c;
  c.structure.a.powers = {0, 1};
  c.structure.a.knots_rad = {12 * kDeg};
  c.structure.b = {SplineTerms{{0, 1}, {}, 1}, SplineTerms{{0}, {}, 1}};  // two lags
  c.structure.con = Bias::present;
  c.structure.delay = DelayTerm::estimated;
  c.structure.rotary.powers = {0};
  c.structure.static_corr.powers = {1};
  c.structure.stall = stall({});
  c.runs = {run(14.0, 9.0, 0.1, true, 96), run(12.0, 8.0, 0.07, false, 80)};
  const ParameterLayout L(c.structure, c.runs);
  int n_stall = 0, n_lag = 0;
  for (int k = 0; k < L.structural().size(); ++k)
    (is_stall_parameter(L.ids()[static_cast<std::size_t>(k)]) ? n_stall : n_lag) += 1;
  CHECK(n_stall == 14);                             // the stall output's 16 (its states, 9: 16)
  CHECK(n_lag + c.structure.y0_per_run() == 11);    // the lag chain's 16
  check_against_finite_differences(c);
}

// The delay form with its lag limit D estimated (model.hpp's lag limit; first_order takes none).
TEST_CASE("output-error sensitivities match finite differences (the delay form's lag limit)") {
  Case c;
  c.structure.a.powers = {0};
  c.structure.b = {SplineTerms{{0}, {}, 1}};
  c.structure.stall = stall({});
  c.structure.stall.forcing_lag = ForcingLag::delay;
  c.structure.stall.lag_limit = StallLagLimit::estimated;
  c.runs = {run(14.0, 9.0, 0.1, true, 96), run(12.0, 8.0, 0.07, false, 80)};
  const ParameterLayout L(c.structure, c.runs);
  CHECK(L.find(param_id(ParamKind::stall_lag_limit)) >= 0);
  check_against_finite_differences(c);
}

TEST_CASE("output-error sensitivities match finite differences (many stall parameters, one held)") {
  Case c;
  c.structure.a.powers = {0};
  c.structure.b = {SplineTerms{{0}, {}, 1}};
  c.structure.stall = stall({10, 12, 14, 16, 18, 20, 22});
  ParamId held;
  held.kind = ParamKind::vortex_cp;
  c.structure.stall.known = {{held, 0.25}};
  c.runs = {run(15.0, 10.0, 0.12, true, 96), run(10.0, 9.0, 0.05, false, 96)};
  const ParameterLayout L(c.structure, c.runs);
  CHECK(L.find(held) < 0);  // held: not in the vector
  int n_stall = 0;
  for (int k = 0; k < L.structural().size(); ++k) n_stall += is_stall_parameter(L.ids()[static_cast<std::size_t>(k)]);
  CHECK(n_stall == 20);  // the stall output's 64 (its states, 16: 16); the lags' 2 + 1 y0: 8
  check_against_finite_differences(c);
}
