// stall_truth_data.hpp -- the dynamic-stall families' seeded truth for the fitter tests
// (test_fit_stall.cpp, test_fit_stall_recovery.cpp): the report's lag plus separation and
// vortex, all integrated by Boost.Odeint's Dormand-Prince 5(4) at 1e-11 from lag_derivatives
// and stall_derivatives, never by the fitter's advance_stall, with parameters drawn from a seed
// (fixed before the fitter was first run on it, not tuned); phase-averaged periodic cycles with
// white noise.
#pragma once

#include <doctest/doctest.h>

#include <array>
#include <boost/numeric/odeint.hpp>
#include <cmath>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "estimate/fit_internal.hpp"
#include "fit_test_data.hpp"
#include "indicial/fitter/fit.hpp"
#include "indicial/model.hpp"

namespace indicial::testing {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;
constexpr double kLength = 0.275, kVref = 30.0;
constexpr double kNoiseSigma = 0.01;  // the recovery tests' white noise, 1% of the lift's scale

// A NACA 0012-like static lift polar (Kirchhoff with Leishman-Beddoes' f0), the static table.
inline double polar_f0(double x) {
  const double a = std::abs(x) / kDeg;
  return a <= 15.25 ? 1.0 - 0.3 * std::exp((a - 15.25) / 3.0) : 0.04 + 0.66 * std::exp((15.25 - a) / 2.3);
}
inline double polar_lift(double x) { return 6.3 * x * kirchhoff_factor(polar_f0(x)); }

struct Truth {
  CoefficientModel<double, FitCapacity> cm;  // lag (a0, b1_0) and stall parameters
};

// One periodic cycle of `n` samples (open: the wrap step closes it) after 6 settling cycles.
inline Run cycle(const Truth& t, double mean_deg, double amp_deg, double k, double airspeed, int n = 128) {
  using State = std::array<double, 5>;  // y, f, v, tau_v, the forcing angle
  namespace odeint = boost::numeric::odeint;
  const double l_over_v = kLength / airspeed, omega = k / l_over_v, period = 2 * kPi / omega;
  const double time_scale = airspeed / kVref;
  auto alpha = [&](double s) { return (mean_deg - amp_deg * std::cos(omega * s)) * kDeg; };
  auto alphadot = [&](double s) { return amp_deg * kDeg * omega * std::sin(omega * s); };
  StallState<double> s0;
  stall_steady_state(t.cm.stall, alpha(0), &s0);
  State x{0.0, s0.separation_point, 0.0, 0.0, s0.forcing_angle_rad};
  auto rhs = [&](const State& z, State& dz, double s) {
    const double xs = alpha(s), xd = alphadot(s);
    double y[FitCapacity::max_lags] = {z[0]}, yd[FitCapacity::max_lags] = {};
    lag_derivatives(t.cm, xs, xs, xd, time_scale, y, yd);
    StallState<double> d;
    stall_derivatives(t.cm.stall, xs, xd, l_over_v, StallState<double>{z[1], z[2], z[3], z[4]}, &d);
    dz = {yd[0], d.separation_point, d.vortex_lift, d.vortex_clock_semichords, d.forcing_angle_rad};
  };
  auto stepper = odeint::make_controlled(1e-11, 1e-11, odeint::runge_kutta_dopri5<State>());
  odeint::integrate_adaptive(stepper, rhs, x, 0.0, 6 * period, period / 512);
  Run r;
  r.path = "cycle";
  r.periodic = true;
  r.airspeed_mps = airspeed;
  r.frequency_hz = 1.0 / period;
  for (int i = 0; i < n; ++i) {
    const double s = 6 * period + period * i / n;
    if (i > 0) odeint::integrate_adaptive(stepper, rhs, x, s - period / n, s, period / 512);
    const double xs = alpha(s);
    double y[FitCapacity::max_lags] = {x[0]};
    const double c = coefficient_output(t.cm, xs, 0.0, l_over_v, y) +
                     stall_output(t.cm.stall, xs, StallState<double>{x[1], x[2], x[3], x[4]});
    r.time_s.push_back(period * i / n);
    r.motion_angle_rad.push_back(xs);
    r.rate_radps.push_back(alphadot(s));
    r.coefficient.push_back(c);
  }
  return r;
}

// The experiment of the recovery tests: the truth (seeded, below) and its noisy cycles.
struct TruthExperiment {
  Experiment e;
  Truth t;
};

// Which cycles: the recovery tests' twelve (two airspeeds, three mean angles, two reduced
// frequencies, 128 samples each), or fewer for a cheaper fit (the sanitizer build's).
struct TruthDesign {
  std::vector<double> airspeeds_mps{30.0, 40.0};
  std::vector<double> means_deg{10.0, 14.0, 18.0};
  std::vector<double> reduced_frequencies{0.05, 0.1};
  int samples_per_cycle = 128;
};

inline TruthExperiment truth_experiment(const std::function<void(StallModel<double, FitCapacity>&)>& adjust = {},
                                        const TruthDesign& design = {}) {
  TruthExperiment te;
  Experiment& e = te.e;
  Truth& t = te.t;
  e = testing::pitch_table_experiment("stall.toml", "CL", kLength, kVref, -12.0, 36.0, polar_lift);
  StallConfig& sc = e.model.stall;
  sc.families = StallFamilies::separation_and_vortex;
  sc.polar_x_rad = e.static_curve.table_x_rad;
  sc.polar_lift = e.static_curve.table_value;

  // The truth: the polar's static part as the fitter derives it (stall_polar.cpp), the rest
  // drawn from seed 20221 (uniform ranges around the Beddoes-Leishman constants).
  const fit_detail::StallStructure st = fit_detail::stall_structure(sc, e.path);
  fit_detail::shape_stall(st, t.cm.stall);
  std::mt19937_64 rng(20221u);
  auto u = [&](double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); };
  auto& p = t.cm.stall.separation;
  p.tau1_semichords = u(2.0, 4.5);
  p.tau2_semichords = u(0.5, 2.5);
  p.cp_k0 = u(0.85, 1.05);
  p.cp_k1 = u(-0.2, 0.2);
  p.cp_k2 = u(-0.1, 0.1);
  auto& v = t.cm.stall.vortex;
  v.shedding_threshold = st.shedding_threshold_start * u(0.85, 1.15);
  v.decay_semichords = u(4.0, 8.0);
  v.travel_semichords = u(5.0, 9.0);
  v.lift_gain = u(0.7, 1.2);
  v.cp_travel = u(0.0, 0.4);
  // The static table as the fitter interpolates it (natural cubic spline through the rows).
  t.cm.static_curve.kind = StaticKind::table;
  t.cm.static_curve.n_table = static_cast<int>(e.static_curve.table_x_rad.size());
  for (int i = 0; i < t.cm.static_curve.n_table; ++i) {
    t.cm.static_curve.table_x_rad[i] = e.static_curve.table_x_rad[static_cast<std::size_t>(i)];
    t.cm.static_curve.table_value[i] = e.static_curve.table_value[static_cast<std::size_t>(i)];
  }
  prepare_static_table(t.cm.static_curve);
  t.cm.n_lags = 1;
  t.cm.a.n_powers = 1;
  t.cm.a.power_coef[0] = u(0.5, 1.5);
  t.cm.lags[0].b.n_powers = 1;
  t.cm.lags[0].b.power_coef[0] = u(0.2, 0.4) * kVref / kLength;  // 1/s at V_ref
  if (adjust) adjust(t.cm.stall);

  for (double airspeed : design.airspeeds_mps)
    for (double mean : design.means_deg)
      for (double k : design.reduced_frequencies)
        e.runs.push_back(cycle(t, mean, 9.0, k, airspeed, design.samples_per_cycle));
  std::mt19937_64 noise(7u);
  std::normal_distribution<double> g(0.0, kNoiseSigma);
  for (Run& r : e.runs)
    for (double& c : r.coefficient) c += g(noise);
  set_data_range(e);

  return te;
}

// Each named estimate of `fit` within 3 Cramer-Rao bounds of its true value.
struct TruthValue {
  const char* name;
  double value;
};
inline void check_within_3_bounds(const FitResult& fit, const std::vector<TruthValue>& truth) {
  for (const TruthValue& tr : truth) {
    const ParameterEstimate* est = nullptr;
    for (const auto& q : fit.parameters)
      if (q.name == tr.name) est = &q;
    REQUIRE(est != nullptr);
    MESSAGE(std::string(tr.name) << " = " << est->value << " +- " << est->cr_bound << ", truth " << tr.value);
    CHECK(std::abs(est->value - tr.value) < 3.0 * est->cr_bound);
  }
}

}  // namespace indicial::testing
