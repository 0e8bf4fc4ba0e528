// The periodic state of the dynamic-stall states (shared/include/indicial/periodic_stall.hpp):
// a fixed point of one cycle for every family and forcing lag (the secant of a piecewise f
// with T1r included), the state a long warm-up reaches where the states forget their start, a
// periodic state where a slow vortex decay keeps three warm-up cycles far from it, the
// autodiff derivatives of the fixed point against central differences of the double solver,
// and the clock of a saturated shedding switch reported unresolved.
#include <doctest/doctest.h>

#include <Eigen/Core>
#include <unsupported/Eigen/AutoDiff>
#include <algorithm>
#include <cmath>
#include <cstdio>

#include "indicial/periodic_stall.hpp"
#include "stall_test_model.hpp"

TEST_SUITE_BEGIN("unit");  // the ctest label (tests/CMakeLists.txt)

namespace {

using indicial::StallFamilies;
using indicial::StallState;
using indicial::test_models::kDeg;
using indicial::test_models::test_model;
using Cap = indicial::FitCapacity;

// A closed sinusoidal cycle, mean - amplitude cos(omega t), in kSamples steps, at reduced
// frequency k = omega l / V (l / V = 0.005 s).
struct Cycle {
  static constexpr int kSamples = 200;
  double mean_rad = 12.0 * kDeg;
  double amplitude_rad = 10.0 * kDeg;
  double reduced_frequency = 0.1;
  double l_over_v_s = 0.005;
  double omega() const { return reduced_frequency / l_over_v_s; }
  double dt_s() const { return 2.0 * indicial::testing::kPi / omega() / kSamples; }
  double alpha(int k) const { return mean_rad - amplitude_rad * std::cos(omega() * k * dt_s()); }
};

template <class S>
void advance_cycle(const indicial::StallModel<S, Cap>& m, const Cycle& c, StallState<S>* s) {
  for (int k = 0; k < Cycle::kSamples; ++k)
    indicial::advance_stall(m, indicial::StallStep<S>{S(c.alpha(k)), S(c.alpha(k + 1)), S(c.dt_s()), S(c.l_over_v_s)},
                            s);
}

template <class S>
indicial::PeriodicStallResult solve(const indicial::StallModel<S, Cap>& m, const Cycle& c, StallState<S>* s) {
  indicial::stall_steady_state(m, S(c.alpha(0)), s);
  const indicial::StallPeriodicStates live = indicial::stall_periodic_states(m);
  return indicial::periodic_stall_state<1>(&live, 1, s, [&](const StallState<S>* a, StallState<S>* e) {
    *e = *a;
    advance_cycle(m, c, e);
  });
}

// max over the four states of |b - a| / max(1, |a|)
double state_difference(const StallState<double>& a, const StallState<double>& b) {
  const double x[4][2] = {{a.separation_point, b.separation_point},
                          {a.vortex_lift, b.vortex_lift},
                          {a.vortex_clock_semichords, b.vortex_clock_semichords},
                          {a.forcing_angle_rad, b.forcing_angle_rad}};
  double d = 0.0;
  for (const auto& p : x) d = std::max(d, std::abs(p[1] - p[0]) / std::max(1.0, std::abs(p[0])));
  return d;
}

// One cycle from s: how far from s it ends.
double cycle_residual(const indicial::StallModel<double, Cap>& m, const Cycle& c, const StallState<double>& s) {
  StallState<double> e = s;
  advance_cycle(m, c, &e);
  return state_difference(s, e);
}

struct Variant {
  const char* name;
  StallFamilies families;
  indicial::ForcingLag lag;
  double t1r_semichords;
  double dxr_deg = 0.0;  // the static hysteresis (model.hpp's dxr): f piecewise too
};

constexpr Variant kVariants[] = {
    {"separation", StallFamilies::separation, indicial::ForcingLag::delay, 0.0},
    {"separation and vortex", StallFamilies::separation_and_vortex, indicial::ForcingLag::delay, 0.0},
    {"first-order forcing lag", StallFamilies::separation_and_vortex, indicial::ForcingLag::first_order, 0.0},
    {"reattachment constant", StallFamilies::separation_and_vortex, indicial::ForcingLag::delay, 10.0},
    {"both", StallFamilies::separation_and_vortex, indicial::ForcingLag::first_order, 30.0},
    {"static hysteresis", StallFamilies::separation_and_vortex, indicial::ForcingLag::delay, 0.0, 3.0},
    {"hysteresis and T1r", StallFamilies::separation_and_vortex, indicial::ForcingLag::first_order, 10.0, 3.0},
};

indicial::StallModel<double, Cap> variant_model(const Variant& v) {
  auto m = test_model<double>(v.families);
  m.separation.forcing_lag = v.lag;
  m.separation.tau1_reattach_semichords = v.t1r_semichords;
  m.separation.reattach_shift_rad = v.dxr_deg * indicial::test_models::kDeg;
  return m;
}

}  // namespace

TEST_CASE("periodic stall state is a fixed point of one cycle for every family and forcing lag") {
  for (const Variant& v : kVariants) {
    for (double k : {0.02, 0.1, 0.2}) {
      Cycle c;
      c.reduced_frequency = k;
      const auto m = variant_model(v);
      StallState<double> s;
      const indicial::PeriodicStallResult r = solve(m, c, &s);
      const double residual = cycle_residual(m, c, s);
      INFO(v.name, ", k ", k, ": ", r.cycles, " cycles, ", r.secants, " further secants, residual ", residual);
      CHECK(r.unresolved == 0);
      CHECK(residual < 1e-12);
      // Two cycles per group, x_e's only with its state; further ones only for a piecewise f.
      const int groups = (v.lag == indicial::ForcingLag::first_order ? 1 : 0) + 1 +
                         (v.families == StallFamilies::separation_and_vortex ? 1 : 0);
      if (v.t1r_semichords == 0.0 && v.dxr_deg == 0.0) CHECK(r.cycles == 2 * groups);
      CHECK(r.secants < indicial::kPeriodicStallMaxSecants - 1);
    }
  }
}

TEST_CASE("periodic stall state is the state a long warm-up reaches when the states forget their start") {
  for (const Variant& v : kVariants) {
    Cycle c;
    const auto m = variant_model(v);
    StallState<double> s, w;
    solve(m, c, &s);
    indicial::stall_steady_state(m, c.alpha(0), &w);
    for (int i = 0; i < 60; ++i) advance_cycle(m, c, &w);  // T <= 30 semichords, 63 per cycle
    INFO(v.name, ": difference ", state_difference(s, w));
    CHECK(state_difference(s, w) < 1e-11);
  }
}

TEST_CASE("periodic stall state holds where a slow vortex decay keeps three warm-up cycles far from it") {
  Cycle c;
  auto m = test_model<double>(StallFamilies::separation_and_vortex);
  m.vortex.decay_semichords = 1e5;  // a fitted T_v of the kind measured cycles gave (1e4-1e6)
  StallState<double> s, w;
  const indicial::PeriodicStallResult r = solve(m, c, &s);
  indicial::stall_steady_state(m, c.alpha(0), &w);
  for (int i = 0; i < 3; ++i) advance_cycle(m, c, &w);
  std::printf("slow vortex decay: residual after 3 warm-up cycles %.2e, periodic state %.2e (v %.4g against %.4g)\n",
              cycle_residual(m, c, w), cycle_residual(m, c, s), w.vortex_lift, s.vortex_lift);
  CHECK(r.unresolved == 0);
  CHECK(cycle_residual(m, c, w) > 1e-4);
  CHECK(cycle_residual(m, c, s) < 1e-10);
}

// The fitter's sensitivities of a periodic run (fit_output_error.cpp) come from this solver run
// on an autodiff scalar: d s* / d theta against central differences of the double solver, for
// the time constants and the shedding threshold, with a piecewise f (T1r, the static
// hysteresis) and without.
TEST_CASE("periodic stall state derivatives match central differences") {
  using AD = Eigen::AutoDiffScalar<Eigen::Matrix<double, 6, 1>>;
  auto set = [](auto& m, int i, const auto& value) {
    switch (i) {
      case 0: m.separation.tau1_semichords = value; break;
      case 1: m.separation.tau2_semichords = value; break;
      case 2: m.vortex.decay_semichords = value; break;
      case 3: m.vortex.shedding_threshold = value; break;
      case 4: m.separation.tau1_reattach_semichords = value; break;
      default: m.separation.reattach_shift_rad = value; break;
    }
  };
  for (const Variant& v : kVariants) {
    const auto base = variant_model(v);
    const double theta[6] = {3.0, 1.7, 40.0, 1.3, v.t1r_semichords, base.separation.reattach_shift_rad};
    std::vector<int> active = {0, 1, 2, 3};  // T1r and dxr where the variant has them
    if (v.t1r_semichords > 0.0) active.push_back(4);
    if (v.dxr_deg > 0.0) active.push_back(5);
    auto ad = test_model<AD>(v.families);
    ad.separation.forcing_lag = v.lag;
    for (int i = 0; i < 6; ++i) {
      AD x(theta[i]);
      x.derivatives().setZero();
      if (std::find(active.begin(), active.end(), i) != active.end()) x.derivatives()(i) = 1.0;
      set(ad, i, x);
    }
    Cycle c;
    StallState<AD> sa;
    solve(ad, c, &sa);
    for (int i : active) {
      const double h = 1e-6 * theta[i];
      auto plus = base, minus = base;
      for (int j = 0; j < 6; ++j) {
        set(plus, j, theta[j]);
        set(minus, j, theta[j]);
      }
      set(plus, i, theta[i] + h);
      set(minus, i, theta[i] - h);
      StallState<double> sp, sm;
      solve(plus, c, &sp);
      solve(minus, c, &sm);
      const double fd[4] = {(sp.separation_point - sm.separation_point) / (2 * h),
                            (sp.vortex_lift - sm.vortex_lift) / (2 * h),
                            (sp.vortex_clock_semichords - sm.vortex_clock_semichords) / (2 * h),
                            (sp.forcing_angle_rad - sm.forcing_angle_rad) / (2 * h)};
      const double exact[4] = {sa.separation_point.derivatives()(i), sa.vortex_lift.derivatives()(i),
                               sa.vortex_clock_semichords.derivatives()(i), sa.forcing_angle_rad.derivatives()(i)};
      for (int q = 0; q < 4; ++q) {
        INFO(v.name, ": parameter ", i, ", state ", q, ": autodiff ", exact[q], ", central difference ", fd[q]);
        CHECK(std::abs(exact[q] - fd[q]) <= 1e-5 * std::max(1.0, std::abs(fd[q])));
      }
    }
  }
}

TEST_CASE("periodic stall state reports a clock whose shedding switch never releases as unresolved") {
  Cycle c;
  c.mean_rad = 30.0 * kDeg;  // the lagged attached normal force stays above the threshold
  c.amplitude_rad = 2.0 * kDeg;
  auto m = test_model<double>(StallFamilies::separation_and_vortex);
  m.vortex.shedding_threshold = 0.5;  // switch saturated (exactly 1 in double) all cycle
  StallState<double> s;
  const indicial::PeriodicStallResult r = solve(m, c, &s);
  CHECK(r.unresolved == 1);  // the clock; f and v have their periodic values
  CHECK(std::isfinite(s.vortex_clock_semichords));
  // Its value one cycle on from the steady start's 0: the cycle's length in semichords.
  CHECK(s.vortex_clock_semichords == doctest::Approx(2.0 * indicial::testing::kPi / c.reduced_frequency).epsilon(1e-9));
  StallState<double> e = s;
  advance_cycle(m, c, &e);
  CHECK(std::abs(e.separation_point - s.separation_point) < 1e-12);
  CHECK(std::abs(e.vortex_lift - s.vortex_lift) < 1e-12);
}
