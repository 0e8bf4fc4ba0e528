// tests/runtime_test_models.hpp -- model sets built in code for the runtime and coefficient
// file tests: the report's Table I (Model I and Model II) and small multi-coefficient sets.
// Header-only and heap-free so that the -fno-exceptions test can use it too.
#pragma once

#include "indicial/fitter/tailless_model.hpp"
#include <cmath>

#include "indicial/model.hpp"

namespace indicial::test_models {

using Set = ModelSet<double, DefaultCapacity>;

// Table I, tailless aircraft, Model I (b1 = 2.5 1/s) and Model II (b1(alpha) with 4 knots):
// the one definition in fitter/include/indicial/fitter/tailless_model.hpp.
inline Set table_one_model_one() { return tailless_model_set<DefaultCapacity>(TaillessModel::model_1); }

inline Set table_one_model_two() { return tailless_model_set<DefaultCapacity>(TaillessModel::model_2); }

// Pitch, two coefficients: CL with a static table (0..60 deg, a stall-like curve) and two lag
// states with a bias, then Model II's Cm.
inline Set lift_and_moment() {
  Set m = table_one_model_two();
  m.n_coefficients = 2;
  m.coefficients[1] = m.coefficients[0];  // Cm second, in file order
  auto& c = m.coefficients[0];
  c = CoefficientModel<double, DefaultCapacity>{};
  c.name[0] = 'C';
  c.name[1] = 'L';
  c.static_curve.kind = StaticKind::table;
  const double x_deg[9] = {0, 8, 16, 24, 32, 40, 50, 60, 70};
  const double cl[9] = {0.02, 0.45, 0.86, 1.12, 1.2, 1.05, 0.98, 0.9, 0.8};
  c.static_curve.n_table = 9;
  for (int i = 0; i < 9; ++i) {
    c.static_curve.table_x_rad[i] = x_deg[i] * 0.017453292519943295;
    c.static_curve.table_value[i] = cl[i];
  }
  c.rotary.n_powers = 1;
  c.rotary.power_coef[0] = 3.1;
  c.a.n_powers = 2;
  c.a.power_coef[0] = 0.5;
  c.a.power_coef[1] = -1.25;
  c.a.n_knots = 1;
  c.a.knot_rad[0] = 0.5;
  c.a.knot_power[0] = 2;
  c.a.knot_coef[0] = 3.0;
  c.n_lags = 2;
  c.lags[0].b.n_powers = 2;
  c.lags[0].b.power_coef[0] = 4.0;
  c.lags[0].b.power_coef[1] = -1.5;
  c.lags[1].b.n_powers = 1;
  c.lags[1].b.power_coef[0] = 0.7;
  c.lags[1].gain = -0.35;
  c.con = 0.125;
  return m;
}

// Roll at alpha0 = 30 deg: CY, Cl, Cn (model angle beta = asin(sin phi sin alpha0)).
inline Set roll_three() {
  Set m{};
  m.axis = Axis::roll;
  m.reference_length_m = 0.5;
  m.airspeed_mps = 20.0;
  m.alpha0_rad = 0.5235987755982988;
  m.x_min_rad = -0.5;
  m.x_max_rad = 0.5;
  m.n_coefficients = 3;
  const char* names[3] = {"CY", "Cl", "Cn"};
  for (int k = 0; k < 3; ++k) {
    auto& c = m.coefficients[k];
    c.name[0] = names[k][0];
    c.name[1] = names[k][1];
    const double s = 1.0 + 0.5 * k;
    c.static_curve.polynomial.n_powers = 2;
    c.static_curve.polynomial.power_coef[0] = 0.0;
    c.static_curve.polynomial.power_coef[1] = -0.3 * s;
    c.rotary.n_powers = 1;
    c.rotary.power_coef[0] = -0.4 * s;
    c.a.n_powers = 3;
    c.a.power_coef[0] = 0.1 * s;
    c.a.power_coef[1] = 0.0;
    c.a.power_coef[2] = -0.8 * s;
    c.lags[0].b.n_powers = 3;
    c.lags[0].b.power_coef[0] = 3.0 * s;
    c.lags[0].b.power_coef[1] = 0.0;
    c.lags[0].b.power_coef[2] = -2.0;
  }
  return m;
}

// Pitch, C_L and C_m of a NACA 0012-like section with both dynamic-stall families on both
// coefficients (model.hpp's StallModel), Leishman & Beddoes' published NACA 0012 constants
// (M = 0.3, rounded, as fitter/include/indicial/fitter/dynamic_stall.hpp's truth): C_Na 6.47,
// the static separation f0 = 1 - 0.3 exp((a - 15.25 deg) / 3 deg) below 15.25 deg and
// 0.04 + 0.66 exp((15.25 deg - a) / 2.3 deg) above (rows every degree, 0..26 deg), T1 = 3,
// T2 = 1.7, centre of pressure K0 = 0.0025, K1 = -0.135, K2 = 0.04, C_N1 = 1.31, T_v = 6,
// T_vl = 7. The static curves are the Kirchhoff polar of the same f0 (tables); a small lag
// of the report's kind rides on each. For the runtime, file and codegen tests and the
// benchmark; not fitted to anything.
inline Set lift_and_moment_stall() {
  Set m{};
  m.axis = Axis::pitch;
  m.reference_length_m = 0.15;  // c / 2
  m.airspeed_mps = 30.0;
  m.x_min_rad = 0.0;
  m.x_max_rad = 0.4537856055185257;  // 26 deg
  m.n_coefficients = 2;
  const double deg = 0.017453292519943295;
  const double slope = 6.47;
  const int rows = 27;
  const char* names[2] = {"CL", "Cm"};
  for (int k = 0; k < 2; ++k) {
    CoefficientModel<double, DefaultCapacity>& c = m.coefficients[k];
    c.name[0] = names[k][0];
    c.name[1] = names[k][1];
    StallModel<double, DefaultCapacity>& st = c.stall;
    st.families = StallFamilies::separation_and_vortex;
    SeparationParameters<double, DefaultCapacity>& p = st.separation;
    p.normal_force_slope_per_rad = slope;
    p.zero_lift_angle_rad = 0.0;
    p.n_f0 = rows;
    p.tau1_semichords = 3.0;
    p.tau2_semichords = 1.7;
    if (k == 0) {
      p.cp_k0 = 1.0;
    } else {
      p.cp_k0 = 0.0025;
      p.cp_k1 = -0.135;
      p.cp_k2 = 0.04;
    }
    st.vortex.shedding_threshold = 1.31;
    st.vortex.decay_semichords = 6.0;
    st.vortex.travel_semichords = 7.0;
    st.vortex.lift_gain = k == 0 ? 1.0 : 0.0;
    st.vortex.cp_travel = k == 0 ? 0.0 : 0.2;
    c.static_curve.kind = StaticKind::table;
    c.static_curve.n_table = rows;
    for (int i = 0; i < rows; ++i) {
      const double a_deg = i;
      const double f0 = a_deg <= 15.25 ? 1.0 - 0.3 * std::exp((a_deg - 15.25) / 3.0)
                                       : 0.04 + 0.66 * std::exp((15.25 - a_deg) / 2.3);
      p.f0_x_rad[i] = a_deg * deg;
      p.f0_value[i] = f0;
      const double n = slope * a_deg * deg;
      const double r = (1.0 + std::sqrt(f0)) * 0.5;
      const double x_cp = p.cp_k0 + p.cp_k1 * (1.0 - f0) + p.cp_k2 * std::sin(3.141592653589793 * f0 * f0);
      c.static_curve.table_x_rad[i] = a_deg * deg;
      c.static_curve.table_value[i] = n * r * r * x_cp;
    }
    c.a.n_powers = 1;
    c.a.power_coef[0] = k == 0 ? 0.4 : -0.05;
    c.lags[0].b.n_powers = 1;
    c.lags[0].b.power_coef[0] = 40.0;
  }
  return m;
}

}  // namespace indicial::test_models
