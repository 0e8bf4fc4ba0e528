// The dynamic-stall families of shared/include/indicial/model.hpp (issue 22): the Kirchhoff
// inversion and its clipping, the steady state (the static curve stays exact), f in [0, 1]
// for any step, the discrete update advance_stall against a Boost.Odeint Dormand-Prince
// integration of stall_derivatives (error and measured order), double against float, the
// autodiff sensitivities the fitter uses against central finite differences, the feasible set,
// the logistic switch's saturation, the static hysteresis's loop, the lag limit.
#include <doctest/doctest.h>

#include <Eigen/Core>
#include <unsupported/Eigen/AutoDiff>
#include <array>
#include <boost/numeric/odeint.hpp>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include "indicial/model.hpp"
#include "stall_test_model.hpp"
#include "test_support.hpp"

TEST_SUITE_BEGIN("unit");  // the ctest label (tests/CMakeLists.txt)

namespace {

using indicial::testing::kPi;
using indicial::test_models::bl_f0;
using indicial::test_models::kDeg;
using indicial::test_models::test_model;
using Cap = indicial::FitCapacity;

struct Motion {
  double mean_rad = 12.0 * kDeg;
  double amplitude_rad = 10.0 * kDeg;
  double omega_radps = 0.0;
  double alpha(double t) const { return mean_rad - amplitude_rad * std::cos(omega_radps * t); }
  double alphadot(double t) const { return amplitude_rad * omega_radps * std::sin(omega_radps * t); }
};

// Reference: Dormand-Prince 5(4), abs/rel 1e-12, to each sample time.
std::vector<indicial::StallState<double>> reference(const indicial::StallModel<double, Cap>& m,
                                                    const Motion& mo, double l_over_v_s,
                                                    double dt_s, int n) {
  using State = std::array<double, 4>;
  namespace odeint = boost::numeric::odeint;
  indicial::StallState<double> s0;
  indicial::stall_steady_state(m, mo.alpha(0.0), &s0);
  State y{s0.separation_point, s0.vortex_lift, s0.vortex_clock_semichords, s0.forcing_angle_rad};
  std::vector<indicial::StallState<double>> out{s0};
  auto rhs = [&](const State& x, State& dxdt, double t) {
    const indicial::StallState<double> s{x[0], x[1], x[2], x[3]};
    indicial::StallState<double> d;
    indicial::stall_derivatives(m, mo.alpha(t), mo.alphadot(t), l_over_v_s, s, &d);
    dxdt = {d.separation_point, d.vortex_lift, d.vortex_clock_semichords, d.forcing_angle_rad};
  };
  auto stepper = odeint::make_controlled(1e-12, 1e-12, odeint::runge_kutta_dopri5<State>());
  for (int k = 0; k < n; ++k) {
    odeint::integrate_adaptive(stepper, rhs, y, k * dt_s, (k + 1) * dt_s, dt_s / 4);
    out.push_back({y[0], y[1], y[2], y[3]});
  }
  return out;
}

template <class S>
std::vector<indicial::StallState<S>> discrete(const indicial::StallModel<S, Cap>& m,
                                              const Motion& mo, double l_over_v_s, double dt_s,
                                              int n) {
  indicial::StallState<S> s;
  indicial::stall_steady_state(m, S(mo.alpha(0.0)), &s);
  std::vector<indicial::StallState<S>> out{s};
  for (int k = 0; k < n; ++k) {
    const indicial::StallStep<S> g{S(mo.alpha(k * dt_s)), S(mo.alpha((k + 1) * dt_s)), S(dt_s),
                                   S(l_over_v_s)};
    indicial::advance_stall(m, g, &s);
    out.push_back(s);
  }
  return out;
}

// Max over the samples of |output_d - output_ref| (the coefficient, what a user sees).
double max_output_error(const indicial::StallModel<double, Cap>& m, const Motion& mo,
                        double l_over_v_s, double dt_s, int n) {
  const auto ref = reference(m, mo, l_over_v_s, dt_s, n);
  const auto dis = discrete(m, mo, l_over_v_s, dt_s, n);
  double err = 0.0;
  for (int k = 0; k <= n; ++k) {
    const double x = mo.alpha(k * dt_s);
    err = std::max(err, std::abs(indicial::stall_output(m, x, dis[static_cast<std::size_t>(k)]) -
                                 indicial::stall_output(m, x, ref[static_cast<std::size_t>(k)])));
  }
  return err;
}

// The sensitivity tests' objective: the outputs over 384 steps of dt (1.5 cycles of their
// motion's 256 steps) from the steady state, weighted by sin(0.05 k) to mix the samples; in the
// model's scalar (double, or the autodiff type whose derivatives are checked).
template <class T>
T weighted_output_sum(const indicial::StallModel<T, Cap>& m, const Motion& mo, double dt, double l_over_v) {
  indicial::StallState<T> s;
  indicial::stall_steady_state(m, T(mo.alpha(0)), &s);
  T sum = T(0);
  for (int k = 0; k < 384; ++k) {
    indicial::advance_stall(m, {T(mo.alpha(k * dt)), T(mo.alpha((k + 1) * dt)), T(dt), T(l_over_v)}, &s);
    sum = sum + T(std::sin(0.05 * k)) * indicial::stall_output(m, T(mo.alpha((k + 1) * dt)), s);
  }
  return sum;
}

}  // namespace

TEST_CASE("kirchhoff inversion recovers f and clips to the unit interval") {
  const double cna = 6.28, a0 = 0.5 * kDeg;
  for (double f = 0.0; f <= 1.0; f += 0.05) {
    for (double a : {-8.0, 5.0, 14.0, 25.0}) {
      const double x = a * kDeg;
      const double c = cna * (x - a0) * indicial::kirchhoff_factor(f);
      CHECK(indicial::kirchhoff_separation(c, cna, x, a0) == doctest::Approx(f).epsilon(1e-9));
    }
  }
  const double x = 10.0 * kDeg;
  CHECK(indicial::kirchhoff_separation(2.0 * cna * (x - a0), cna, x, a0) == 1.0);  // above line
  CHECK(indicial::kirchhoff_separation(0.1 * cna * (x - a0), cna, x, a0) == 0.0);  // below K(0)
  CHECK(indicial::kirchhoff_separation(-1.0, cna, x, a0) == 0.0);                   // other sign
  CHECK(indicial::kirchhoff_separation(0.3, cna, a0, a0) == 1.0);                   // N = 0
}

TEST_CASE_TEMPLATE("stall steady state keeps the static curve exact", S, double, float) {
  for (auto fam : {indicial::StallFamilies::separation, indicial::StallFamilies::separation_and_vortex}) {
    const auto m = test_model<S>(fam);
    for (double a : {-5.0, 8.0, 16.0, 22.0, 35.0}) {
      const S x = S(a * kDeg);
      indicial::StallState<S> s;
      indicial::stall_steady_state(m, x, &s);
      CHECK(indicial::stall_output(m, x, s) == S(0));
      for (int k = 0; k < 500; ++k) indicial::advance_stall(m, {x, x, S(0.001), S(0.01)}, &s);
      // f stays at f0c(x) to rounding, no vortex lift is fed at a fixed angle.
      CHECK(std::abs(double(s.separation_point - indicial::static_separation(m.separation, x))) < 1e-6);
      // The feed is the difference of C_v at two f equal to rounding.
      CHECK(std::abs(double(s.vortex_lift)) < (sizeof(S) == 8 ? 1e-12 : 1e-5));
      CHECK(std::abs(double(indicial::stall_output(m, x, s))) < 1e-5);
    }
  }
  // No family: nothing is stepped, the output is 0.
  auto none = test_model<S>(indicial::StallFamilies::none);
  indicial::StallState<S> s{S(0.3), S(0.2), S(1.0)};
  indicial::advance_stall(none, {S(0.1), S(0.3), S(0.01), S(0.01)}, &s);
  CHECK(s.separation_point == S(0.3));
  CHECK(indicial::stall_output(none, S(0.2), s) == S(0));
}

TEST_CASE_TEMPLATE("stall separation point stays in the unit interval for any step", S, double, float) {
  const auto m = test_model<S>(indicial::StallFamilies::separation_and_vortex);
  unsigned seed = 12345u;
  auto uniform = [&seed]() {
    seed = seed * 1664525u + 1013904223u;
    return (seed >> 8) / double(1u << 24);
  };
  indicial::StallState<S> s;
  indicial::stall_steady_state(m, S(0.0), &s);
  double x0 = 0.0;
  for (int k = 0; k < 20000; ++k) {
    const double x1 = (-15.0 + 60.0 * uniform()) * kDeg;
    const double dt = std::pow(10.0, -5.0 + 5.0 * uniform());
    indicial::advance_stall(m, {S(x0), S(x1), S(dt), S(0.01)}, &s);
    REQUIRE(s.separation_point >= S(0));
    REQUIRE(s.separation_point <= S(1));
    REQUIRE(std::isfinite(double(s.vortex_lift)));
    REQUIRE(s.vortex_clock_semichords >= S(0));
    x0 = x1;
  }
}

// Deep stall (mean 15, amplitude 10 deg, k = 0.1) at 30 m/s with l = 0.275 m: the vortex is
// shed and convected every cycle. The discrete update against the reference, over two cycles.
TEST_CASE("advance stall is second order against an odeint integration") {
  const double l_over_v = 0.275 / 30.0;
  Motion mo;
  mo.mean_rad = 15.0 * kDeg;
  mo.omega_radps = 0.1 / l_over_v;
  const double period = 2.0 * kPi / mo.omega_radps;
  // The third case: a reattachment time constant of its own (T1r = 3 T1, model.hpp): the update
  // switches its decay at the step where the forcing crosses f, still order 2. The fourth: the
  // forcing angle as a first-order filter (ForcingLag::first_order, a fourth state). The fifth
  // and sixth: a static hysteresis of 3 deg (dxr, model.hpp): f held inside its band, the
  // update deciding at each step's start whether it separates, reattaches or holds. The
  // seventh: the forcing lag limited to D = 1 deg (model.hpp's lag limit; the lag T2 (l/V) x'
  // reaches 1.7 x 0.1 x 10 = 1.7 deg here, so the limit acts).
  using indicial::ForcingLag;
  struct Case { indicial::StallFamilies fam; double t1r; ForcingLag lag; double dxr_deg; double limit_deg; };
  for (const Case c : {Case{indicial::StallFamilies::separation, 0.0, ForcingLag::delay, 0.0, 0.0},
                       Case{indicial::StallFamilies::separation_and_vortex, 0.0, ForcingLag::delay, 0.0, 0.0},
                       Case{indicial::StallFamilies::separation_and_vortex, 9.0, ForcingLag::delay, 0.0, 0.0},
                       Case{indicial::StallFamilies::separation_and_vortex, 9.0, ForcingLag::first_order, 0.0, 0.0},
                       Case{indicial::StallFamilies::separation_and_vortex, 0.0, ForcingLag::delay, 3.0, 0.0},
                       Case{indicial::StallFamilies::separation_and_vortex, 9.0, ForcingLag::first_order, 3.0, 0.0},
                       Case{indicial::StallFamilies::separation_and_vortex, 9.0, ForcingLag::delay, 0.0, 1.0}}) {
    const indicial::StallFamilies fam = c.fam;
    auto m = test_model<double>(fam);
    m.separation.tau1_reattach_semichords = c.t1r;
    m.separation.forcing_lag = c.lag;
    m.separation.reattach_shift_rad = c.dxr_deg * kDeg;
    m.separation.lag_limit_rad = c.limit_deg * kDeg;
    // The vortex really is shed: the clock passes T_vl and the vortex lift is not small.
    if (fam == indicial::StallFamilies::separation_and_vortex) {
      const auto states = discrete(m, mo, l_over_v, period / 2000, 4000);
      double vmax = 0, cmax = 0;
      for (const auto& s : states) {
        vmax = std::max(vmax, s.vortex_lift);
        cmax = std::max(cmax, s.vortex_clock_semichords);
      }
      CHECK(vmax > 0.2);
      CHECK(cmax > 7.0);
    }
    // The hysteresis is really there: its output moves from the same model's without it.
    if (c.dxr_deg > 0.0 || c.limit_deg > 0.0) {
      auto none = m;
      none.separation.reattach_shift_rad = 0.0;
      none.separation.lag_limit_rad = 0.0;
      const auto with = discrete(m, mo, l_over_v, period / 2000, 4000);
      const auto without = discrete(none, mo, l_over_v, period / 2000, 4000);
      double moved = 0.0;
      for (std::size_t k = 0; k < with.size(); ++k) {
        const double x = mo.alpha(static_cast<double>(k) * period / 2000);
        moved = std::max(moved, std::abs(indicial::stall_output(m, x, with[k]) - indicial::stall_output(none, x, without[k])));
      }
      std::printf("stall dxr %g deg, D %g deg: output moved by up to %.3f from neither\n", c.dxr_deg, c.limit_deg, moved);
      CHECK(moved > 0.05);
    }
    std::vector<double> err;
    for (int n : {500, 1000, 2000, 4000}) err.push_back(max_output_error(m, mo, l_over_v, 2 * period / n, n));
    for (std::size_t i = 0; i < err.size(); ++i) std::printf("stall %s T1r %g %s dxr %g deg D %g deg n=%d err %.3e\n",
        indicial::stall_families_name(fam), c.t1r, indicial::forcing_lag_name(c.lag), c.dxr_deg, c.limit_deg,
        500 << i, err[i]);
    CHECK(err.back() < 2e-5);
    // The order over the three halvings: single halvings scatter (2.2 .. 1.5) because the
    // forcing has kinks (the linear f0 table's rows every 0.5 deg, the clipping), where one
    // step's error is O(h^2) with a constant that depends on where the kink falls in the step.
    const double order = std::log2(err.front() / err.back()) / 3.0;
    std::printf("  measured order over three halvings %.2f\n", order);
    CHECK(order > 1.8);
  }
}

// The static hysteresis (dxr, model.hpp): on a cycle slow enough that the lag T1 is nothing
// (k = 0.0005, 0.00025: a lag of T1 = 3 semichords there moves f by < 0.005), f follows f0c(x) on the upstroke and f0c(x + dxr) on the downstroke, at
// either rate (a loop that does not close as the rate falls); without it (dxr = 0) the
// downstroke retraces the upstroke. Separation family, T2 = 0 (no lag of the forcing).
TEST_CASE("static hysteresis: the quasi-static loop is f0c on the upstroke, f0c(x + dxr) on the downstroke") {
  const double l_over_v = 0.275 / 40.0;
  const double dxr = 3.0 * kDeg;
  auto run = [&](double k, double shift_rad, bool downstroke, double x_deg) {
    auto m = test_model<double>(indicial::StallFamilies::separation);
    m.separation.tau2_semichords = 0.0;
    m.separation.reattach_shift_rad = shift_rad;
    Motion mo;
    mo.mean_rad = 15.0 * kDeg;
    mo.omega_radps = k / l_over_v;
    const double period = 2.0 * kPi / mo.omega_radps;
    const int n = 20000;  // per cycle; the angle at sample i of the second cycle
    const auto states = discrete(m, mo, l_over_v, period / n, 2 * n);
    // The sample of the second cycle nearest x_deg on the chosen stroke (alpha = mean - amp cos).
    const double c = (mo.mean_rad - x_deg * kDeg) / mo.amplitude_rad;
    const double phase = std::acos(c);
    const double t = (downstroke ? 2.0 * kPi - phase : phase) / mo.omega_radps + period;
    const auto i = static_cast<std::size_t>(std::lround(t / (period / n)));
    return std::pair<double, double>{states[i].separation_point, mo.alpha(static_cast<double>(i) * period / n)};
  };
  for (double x_deg : {12.0, 14.0, 16.0, 18.0}) {
    for (double k : {0.0005, 0.00025}) {
      const auto up = run(k, dxr, false, x_deg);
      const auto down = run(k, dxr, true, x_deg);
      const auto down0 = run(k, 0.0, true, x_deg);
      auto m = test_model<double>(indicial::StallFamilies::separation);
      m.separation.reattach_shift_rad = dxr;
      const double u_up = indicial::static_separation(m.separation, up.second);
      const double u_down = indicial::static_separation(m.separation, down.second);
      const double r_down = indicial::reattachment_target(m.separation, down.second, u_down);
      INFO("x " << x_deg << " deg, k " << k << ": up f " << up.first << " (f0c " << u_up << "), down f "
                << down.first << " (f0c(x + dxr) " << r_down << ", f0c " << u_down << "), without dxr "
                << down0.first);
      CHECK(std::abs(up.first - u_up) < 0.01);
      CHECK(std::abs(down.first - r_down) < 0.01);
      CHECK(std::abs(down0.first - u_down) < 0.01);
      CHECK(u_down - r_down > 0.05);  // a loop worth testing at this angle
    }
  }
}

// ForcingLag::first_order: the lagged angle of a sinusoid of reduced frequency k (in l / V) is
// the sinusoid filtered by 1 / (1 + i k T2): amplitude 1 / sqrt(1 + (k T2)^2), phase lag
// atan(k T2); delay's x - T2 (l/V) x' has the phase lag atan(k T2) too but AMPLIFIES it,
// sqrt(1 + (k T2)^2). Measured on the periodic
// state of the discrete update (the runtime's and the fitter's), against the analytic value.
TEST_CASE("first-order forcing lag filters a sinusoid's amplitude, delay amplifies it") {
  const double l_over_v = 0.275 / 40.0;
  for (const double k : {0.05, 0.15}) {
    Motion mo;
    mo.mean_rad = 8.0 * kDeg;
    mo.omega_radps = k / l_over_v;
    const double period = 2.0 * kPi / mo.omega_radps;
    const int n = 512;
    for (const indicial::ForcingLag lag : {indicial::ForcingLag::delay, indicial::ForcingLag::first_order}) {
      auto m = test_model<double>(indicial::StallFamilies::separation);
      m.separation.forcing_lag = lag;
      indicial::StallState<double> s;
      indicial::stall_steady_state(m, mo.alpha(0.0), &s);
      double lo = 1e9, hi = -1e9;
      for (int i = 0; i < 6 * n; ++i) {  // five cycles to settle (T2 = 1.7 semichords), the sixth measured
        const double dt = period / n;
        const indicial::StallStep<double> g{mo.alpha(i * dt), mo.alpha((i + 1) * dt), dt, l_over_v};
        const double h = dt / l_over_v;
        indicial::StallLookups<double> lk;
        double forcing = s.forcing_angle_rad;
        indicial::stall_lagged_angles(m.separation, g, h, &forcing, &lk);
        indicial::advance_stall(m, g, &s);
        CHECK(s.forcing_angle_rad == forcing);  // first_order: x_e1; delay: untouched
        if (i >= 5 * n) {
          lo = std::min(lo, lk.lagged_x1_rad);
          hi = std::max(hi, lk.lagged_x1_rad);
        }
      }
      const double amplitude = (hi - lo) / 2 / mo.amplitude_rad;
      const double kt = k * 1.7;
      const double gain = std::sqrt(1.0 + kt * kt);
      const double expected = lag == indicial::ForcingLag::delay ? gain : 1.0 / gain;
      INFO("k ", k, " ", indicial::forcing_lag_name(lag), ": amplitude ratio ", amplitude);
      CHECK(amplitude == doctest::Approx(expected).epsilon(1e-3));
      CHECK((hi + lo) / 2 == doctest::Approx(mo.mean_rad).epsilon(1e-6));
    }
  }
  // T2 = 0: the angle itself, whatever the state held.
  auto m = test_model<double>(indicial::StallFamilies::separation);
  m.separation.forcing_lag = indicial::ForcingLag::first_order;
  m.separation.tau2_semichords = 0.0;
  indicial::StallLookups<double> lk;
  double forcing = 0.5;
  indicial::stall_lagged_angles(m.separation, indicial::StallStep<double>{0.1, 0.2, 0.001, 0.01}, 0.1, &forcing, &lk);
  CHECK(lk.lagged_x0_rad == 0.1);
  CHECK(lk.lagged_x1_rad == 0.2);
  CHECK(forcing == 0.2);
}

TEST_CASE("stall update in float follows double") {
  const double l_over_v = 0.275 / 40.0;
  Motion mo;
  mo.omega_radps = 0.05 / l_over_v;
  const double period = 2.0 * kPi / mo.omega_radps;
  const auto md = test_model<double>(indicial::StallFamilies::separation_and_vortex);
  const auto mf = test_model<float>(indicial::StallFamilies::separation_and_vortex);
  const int n = 2000;
  const auto d = discrete(md, mo, l_over_v, period / 1000, n);
  const auto f = discrete(mf, mo, l_over_v, period / 1000, n);
  double err = 0.0;
  for (int k = 0; k <= n; ++k) {
    const double x = mo.alpha(k * period / 1000);
    err = std::max(err, std::abs(indicial::stall_output(md, x, d[std::size_t(k)]) -
                                 double(indicial::stall_output(mf, float(x), f[std::size_t(k)]))));
  }
  std::printf("stall float vs double: max output difference %.2e\n", err);
  CHECK(err < 1e-4);
}

// The fitter's sensitivities: Eigen forward autodiff through advance_stall and stall_output,
// against central differences of the double code, for every fitted parameter.
TEST_CASE("stall autodiff sensitivities match finite differences") {
  using AD = Eigen::AutoDiffScalar<Eigen::Matrix<double, 12, 1>>;
  const double l_over_v = 0.275 / 30.0;
  Motion mo;
  mo.mean_rad = 14.0 * kDeg;
  mo.omega_radps = 0.08 / l_over_v;
  const double dt = 2.0 * kPi / mo.omega_radps / 256;
  const auto base = test_model<double>(indicial::StallFamilies::separation_and_vortex);
  // Parameter i of the vector -> its slot in a model of scalar T.
  auto set = [](auto& m, int i, const auto& v) {
    auto& p = m.separation;
    switch (i) {
      case 0: p.tau1_semichords = v; break;
      case 1: p.tau2_semichords = v; break;
      case 2: p.cp_k0 = v; break;
      case 3: p.cp_k1 = v; break;
      case 4: p.cp_k2 = v; break;
      case 5: p.f0_correction.power_coef[1] = v; break;
      case 6: m.vortex.shedding_threshold = v; break;
      case 7: m.vortex.decay_semichords = v; break;
      case 8: m.vortex.travel_semichords = v; break;
      case 9: m.vortex.lift_gain = v; break;
      case 10: m.vortex.cp_travel = v; break;
      default: p.f0_correction.power_coef[0] = v; break;
    }
  };
  const double theta[12] = {3.0, 1.7, 1.0, -0.1, 0.05, -0.05, 1.3, 6.0, 7.0, 1.0, 0.4, 0.01};
  auto objective = [&](const auto& m) { return weighted_output_sum(m, mo, dt, l_over_v); };
  indicial::StallModel<AD, Cap> ma;
  // Convert the double model, then seed the parameters.
  ma.families = base.families;
  ma.separation.normal_force_slope_per_rad = AD(base.separation.normal_force_slope_per_rad);
  ma.separation.zero_lift_angle_rad = AD(base.separation.zero_lift_angle_rad);
  ma.separation.n_f0 = base.separation.n_f0;
  for (int i = 0; i < base.separation.n_f0; ++i) {
    ma.separation.f0_x_rad[i] = base.separation.f0_x_rad[i];
    ma.separation.f0_value[i] = AD(base.separation.f0_value[i]);
  }
  ma.separation.f0_correction.n_powers = 2;
  for (int i = 0; i < 12; ++i) {
    AD a(theta[i]);
    a.derivatives().setZero();
    a.derivatives()(i) = 1.0;
    set(ma, i, a);
  }
  // Zero-fill the derivative vectors of the constants the model holds (fixed size: they are).
  const AD j = objective(ma);
  for (int i = 0; i < 12; ++i) {
    const double hstep = 1e-6 * std::max(1.0, std::abs(theta[i]));
    auto mp = base, mm = base;
    set(mp, i, theta[i] + hstep);
    set(mm, i, theta[i] - hstep);
    const double fd = (objective(mp) - objective(mm)) / (2 * hstep);
    INFO("parameter " << i << " autodiff " << j.derivatives()(i) << " fd " << fd);
    CHECK(j.derivatives()(i) == doctest::Approx(fd).epsilon(1e-5).scale(1.0));
  }
}

// dxr's derivative (the fitter's sensitivity of the static hysteresis) against central finite
// differences: the band's edges move with dxr, f's path with them, on a cycle that separates,
// holds and reattaches.
TEST_CASE("stall autodiff sensitivity to the static hysteresis matches finite differences") {
  using AD = Eigen::AutoDiffScalar<Eigen::Matrix<double, 1, 1>>;
  const double l_over_v = 0.275 / 30.0;
  Motion mo;
  mo.mean_rad = 15.0 * kDeg;
  mo.omega_radps = 0.05 / l_over_v;
  const double dt = 2.0 * kPi / mo.omega_radps / 256;
  auto objective = [&](const auto& m) { return weighted_output_sum(m, mo, dt, l_over_v); };
  auto base = test_model<double>(indicial::StallFamilies::separation_and_vortex);
  auto ma = test_model<AD>(indicial::StallFamilies::separation_and_vortex);
  for (double dxr_deg : {1.0, 3.0}) {
    const double dxr = dxr_deg * kDeg;
    AD a(dxr);
    a.derivatives()(0) = 1.0;
    ma.separation.reattach_shift_rad = a;
    const AD j = objective(ma);
    const double h = 1e-7;
    auto mp = base, mm = base;
    mp.separation.reattach_shift_rad = dxr + h;
    mm.separation.reattach_shift_rad = dxr - h;
    const double fd = (objective(mp) - objective(mm)) / (2 * h);
    INFO("dxr " << dxr_deg << " deg: autodiff " << j.derivatives()(0) << " fd " << fd);
    CHECK(std::abs(fd) > 0.1);  // the cycle does see dxr
    CHECK(j.derivatives()(0) == doctest::Approx(fd).epsilon(1e-5).scale(1.0));
  }
}

// The lag limit D (model.hpp): on sinusoids of growing rate the forcing angle's largest lag
// behind the angle, max |x - x_e|, is the delay's T2 (l/V) max|x'| while that is small against
// D, and never reaches D however fast the motion; D = 0 is the delay itself, bit for bit.
TEST_CASE("lag limit: the forcing angle's lag is the delay's at low rates and stays below D") {
  const double l_over_v = 0.275 / 40.0;
  const double limit = 2.0 * kDeg;
  for (const double k : {0.005, 0.05, 0.15, 0.5}) {
    Motion mo;
    mo.mean_rad = 8.0 * kDeg;
    mo.omega_radps = k / l_over_v;
    const double period = 2.0 * kPi / mo.omega_radps;
    const int n = 512;
    auto m = test_model<double>(indicial::StallFamilies::separation);
    auto unlimited = m;
    m.separation.lag_limit_rad = limit;
    double lag_max = 0.0, delay_max = 0.0;
    for (int i = 0; i < n; ++i) {
      const double dt = period / n;
      const indicial::StallStep<double> g{mo.alpha(i * dt), mo.alpha((i + 1) * dt), dt, l_over_v};
      double forcing = 0.0;
      indicial::StallLookups<double> lk, lu;
      indicial::stall_lagged_angles(m.separation, g, dt / l_over_v, &forcing, &lk);
      indicial::stall_lagged_angles(unlimited.separation, g, dt / l_over_v, &forcing, &lu);
      lag_max = std::max(lag_max, std::abs(g.x1_rad - lk.lagged_x1_rad));
      delay_max = std::max(delay_max, std::abs(g.x1_rad - lu.lagged_x1_rad));
      // The continuous form at the step's start: the same limited lag of T2 (l/V) x'.
      const double xdot = mo.amplitude_rad * mo.omega_radps * std::sin(mo.omega_radps * i * dt);
      const double expect = limit * std::tanh(m.separation.tau2_semichords * l_over_v * xdot / limit);
      CHECK(indicial::limited_lag(m.separation, m.separation.tau2_semichords * l_over_v * xdot) ==
            doctest::Approx(expect).epsilon(1e-12).scale(limit));
    }
    INFO("k " << k << ": largest lag " << lag_max / kDeg << " deg, delay's " << delay_max / kDeg << " deg");
    CHECK(lag_max < limit);
    CHECK(lag_max <= delay_max);
    if (delay_max < 0.1 * limit) CHECK(lag_max == doctest::Approx(delay_max).epsilon(0.005));
    if (delay_max > 3.0 * limit) CHECK(lag_max > 0.99 * limit);
  }
  // D = 0: no limit, the same bits as the delay.
  auto m = test_model<double>(indicial::StallFamilies::separation);
  CHECK(indicial::limited_lag(m.separation, 0.0123) == 0.0123);
  // Odd, and finite at any rate (no exp overflow).
  m.separation.lag_limit_rad = limit;
  CHECK(indicial::limited_lag(m.separation, -0.0123) == -indicial::limited_lag(m.separation, 0.0123));
  CHECK(indicial::limited_lag(m.separation, 1e300) == limit);
  CHECK(indicial::limited_lag(m.separation, -1e300) == -limit);
}

// D's derivative (the fitter's sensitivity of the lag limit) against central finite
// differences, on a deep-stall cycle fast enough for the limit to act.
TEST_CASE("stall autodiff sensitivity to the lag limit matches finite differences") {
  using AD = Eigen::AutoDiffScalar<Eigen::Matrix<double, 1, 1>>;
  const double l_over_v = 0.275 / 30.0;
  Motion mo;
  mo.mean_rad = 15.0 * kDeg;
  mo.omega_radps = 0.1 / l_over_v;
  const double dt = 2.0 * kPi / mo.omega_radps / 256;
  auto objective = [&](const auto& m) { return weighted_output_sum(m, mo, dt, l_over_v); };
  auto base = test_model<double>(indicial::StallFamilies::separation_and_vortex);
  auto ma = test_model<AD>(indicial::StallFamilies::separation_and_vortex);
  for (double limit_deg : {1.0, 3.0}) {
    const double limit = limit_deg * kDeg;
    AD a(limit);
    a.derivatives()(0) = 1.0;
    ma.separation.lag_limit_rad = a;
    const AD j = objective(ma);
    const double h = 1e-7;
    auto mp = base, mm = base;
    mp.separation.lag_limit_rad = limit + h;
    mm.separation.lag_limit_rad = limit - h;
    const double fd = (objective(mp) - objective(mm)) / (2 * h);
    INFO("D " << limit_deg << " deg: autodiff " << j.derivatives()(0) << " fd " << fd);
    CHECK(std::abs(fd) > 0.1);  // the cycle does see D
    CHECK(j.derivatives()(0) == doctest::Approx(fd).epsilon(1e-5).scale(1.0));
  }
}

// The switch skips its exp where 1 + e^-u rounds to 1 (issue 22 item 6): the same bits as the
// full expression there, and the full expression just below the threshold.
// (The step's exponential is step_exp: std::exp in double, model.hpp's exp_on in float, the
// same bits on every target; the C library's saturates at the same threshold.)
TEST_CASE_TEMPLATE("logistic saturates exactly where its exp is skipped", S, double, float) {
  using std::exp;
  const double threshold = indicial::detail::saturates_above<S>::value;
  for (double u = 0.0; u < 2.0 * threshold; u += threshold / 997.0) {
    const S su = S(u);
    const S full = S(1) / (S(1) + indicial::detail::step_exp(S(-su)));
    INFO("u = " << u);
    CHECK(indicial::detail::logistic(su) == full);
    if (u >= threshold) {
      CHECK(full == S(1));
      CHECK(S(1) / (S(1) + exp(-su)) == S(1));
    }
  }
}

// decay_weights (the families' decays, issue 22 item 6): exp(-z) by its Taylor polynomial
// within 1 ulp of the exact exp(-z) (long double) on [0, max_z] -- the bound model.hpp states
// --, on both sides of small_max_z (the two degrees), and phi1(z) from the same polynomial
// within 1 ulp of the exact (1 - exp(-z)) / z; exactly 1 and 1 at 0, step_exp's bits and
// phi1's quotient above max_z, and an autodiff type's value the double's bits with the
// derivative within an ulp of -exp(-z).
namespace {
template <class S>
long double ulp_of(long double exact) {
  int binade;
  std::frexp(exact, &binade);
  return std::ldexp(1.0L, binade - std::numeric_limits<S>::digits);
}
}  // namespace

TEST_CASE_TEMPLATE("decay weights are within an ulp of exp and phi1 and step exp beyond their range", S, double, float) {
  using C = indicial::detail::decay_series<S>;
  CHECK(indicial::decay_weights(S(0)).decay == S(1));
  CHECK(indicial::decay_weights(S(0)).weight == S(1));
  const int n = 200000;
  double worst_ulp = 0.0, worst_phi1_ulp = 0.0;
  for (int i = 0; i <= n; ++i) {
    const S z = S(C::max_z * i / n);
    const indicial::DecayWeights<S> d = indicial::decay_weights(z);
    const long double lz = static_cast<long double>(z);
    const long double exact = std::exp(-lz);
    const double err = static_cast<double>(std::fabs(static_cast<long double>(d.decay) - exact) / ulp_of<S>(exact));
    worst_ulp = err > worst_ulp ? err : worst_ulp;
    if (i == 0) continue;
    const long double exact_phi1 = -std::expm1(-lz) / lz;
    const double err_phi1 =
        static_cast<double>(std::fabs(static_cast<long double>(d.weight) - exact_phi1) / ulp_of<S>(exact_phi1));
    worst_phi1_ulp = err_phi1 > worst_phi1_ulp ? err_phi1 : worst_phi1_ulp;
  }
  MESSAGE("decay_weights worst error: exp " << worst_ulp << " ulp, phi1 " << worst_phi1_ulp << " ulp");
  CHECK(worst_ulp <= 1.0);
  CHECK(worst_phi1_ulp <= 1.0);
  for (double z : {C::max_z * 1.0000001, 0.3, 1.0, 7.5, 40.0}) {
    const S sz = S(z);
    if (!(sz > S(C::max_z))) continue;
    const indicial::DecayWeights<S> d = indicial::decay_weights(sz);
    CHECK(d.decay == indicial::detail::step_exp(S(-sz)));
    CHECK(d.weight == indicial::phi1(sz, d.decay));
  }
}

TEST_CASE("decay weights of an autodiff type have the double's values and the exact derivatives") {
  using Jet = Eigen::AutoDiffScalar<Eigen::VectorXd>;
  for (double z : {0.0, 1e-4, 0.016, 0.05, 0.0625, 0.07, 0.2, 0.25, 0.3, 2.0}) {
    INFO("z = " << z);
    const Jet j(z, 1, 0);
    const indicial::DecayWeights<Jet> d = indicial::decay_weights(j);
    const indicial::DecayWeights<double> v = indicial::decay_weights(z);
    CHECK(d.decay.value() == v.decay);
    CHECK(d.weight.value() == v.weight);
    CHECK(d.decay.derivatives()(0) == doctest::Approx(-std::exp(-z)).epsilon(1e-15));
    // phi1'(z) = (e^-z (1 + z) - 1) / z^2 (long double; its series -1/2 + z/3 - z^2/8 + z^3/30
    // below 1e-3, where the quotient cancels): the fitter's sensitivities of the weight.
    const long double lz = z;
    const long double exact = z < 1e-3 ? -0.5L + lz / 3.0L - lz * lz / 8.0L + lz * lz * lz / 30.0L
                                        : (std::exp(-lz) * (1.0L + lz) - 1.0L) / (lz * lz);
    CHECK(d.weight.derivatives()(0) == doctest::Approx(static_cast<double>(exact)).epsilon(1e-13));
  }
}

TEST_CASE("check stall parameters names the infeasible models") {
  using indicial::StallCheck;
  auto m = test_model<double>(indicial::StallFamilies::separation_and_vortex);
  CHECK(indicial::check_stall_parameters(m) == StallCheck::valid);
  auto b = m;
  b.separation.tau1_semichords = 0.0;
  CHECK(indicial::check_stall_parameters(b) == StallCheck::nonpositive_time_constant);
  b = m;
  b.separation.tau2_semichords = -0.1;
  CHECK(indicial::check_stall_parameters(b) == StallCheck::nonpositive_time_constant);
  b = m;
  b.separation.tau1_reattach_semichords = -0.5;  // 0 (T1 both ways) and > 0 are feasible
  CHECK(indicial::check_stall_parameters(b) == StallCheck::nonpositive_time_constant);
  b.separation.tau1_reattach_semichords = 5.0;
  CHECK(indicial::check_stall_parameters(b) == StallCheck::valid);
  b.separation.tau1_reattach_semichords = std::nan("");
  CHECK(indicial::check_stall_parameters(b) == StallCheck::not_finite);
  b = m;
  b.separation.reattach_shift_rad = -1e-3;  // 0 (no hysteresis) to 20 deg are feasible
  CHECK(indicial::check_stall_parameters(b) == StallCheck::bad_hysteresis);
  b.separation.reattach_shift_rad = indicial::kMaxReattachShiftRad;
  CHECK(indicial::check_stall_parameters(b) == StallCheck::valid);
  b.separation.reattach_shift_rad = 0.35;
  CHECK(indicial::check_stall_parameters(b) == StallCheck::bad_hysteresis);
  b.separation.reattach_shift_rad = std::nan("");
  CHECK(indicial::check_stall_parameters(b) == StallCheck::not_finite);
  b = m;
  b.separation.lag_limit_rad = -1e-3;  // 0 (no limit) to 20 deg are feasible, with the delay form
  CHECK(indicial::check_stall_parameters(b) == StallCheck::bad_lag_limit);
  b.separation.lag_limit_rad = indicial::kMaxLagLimitRad;
  CHECK(indicial::check_stall_parameters(b) == StallCheck::valid);
  b.separation.lag_limit_rad = 0.35;
  CHECK(indicial::check_stall_parameters(b) == StallCheck::bad_lag_limit);
  b.separation.lag_limit_rad = 0.05;
  b.separation.forcing_lag = indicial::ForcingLag::first_order;
  CHECK(indicial::check_stall_parameters(b) == StallCheck::bad_lag_limit);
  b.separation.lag_limit_rad = std::nan("");
  CHECK(indicial::check_stall_parameters(b) == StallCheck::not_finite);
  b = m;
  b.vortex.travel_semichords = -1.0;
  CHECK(indicial::check_stall_parameters(b) == StallCheck::nonpositive_time_constant);
  b = m;
  b.vortex.shedding_threshold = 0.0;
  CHECK(indicial::check_stall_parameters(b) == StallCheck::nonpositive_threshold);
  b = m;
  b.separation.f0_value[3] = 1.2;
  CHECK(indicial::check_stall_parameters(b) == StallCheck::bad_separation_table);
  b = m;
  b.separation.f0_x_rad[4] = b.separation.f0_x_rad[3];
  CHECK(indicial::check_stall_parameters(b) == StallCheck::bad_separation_table);
  b = m;
  b.separation.n_f0 = 1;
  CHECK(indicial::check_stall_parameters(b) == StallCheck::bad_separation_table);
  b = m;
  b.separation.cp_k1 = std::nan("");
  CHECK(indicial::check_stall_parameters(b) == StallCheck::not_finite);
  // The vortex's parameters do not matter to a separation-only model.
  b = m;
  b.families = indicial::StallFamilies::separation;
  b.vortex.decay_semichords = -1.0;
  CHECK(indicial::check_stall_parameters(b) == StallCheck::valid);
}
