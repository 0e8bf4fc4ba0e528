// tests/runtime_test_models.hpp -- model sets built in code for the runtime and coefficient
// file tests: the report's Table I (Model I and Model II) and small multi-coefficient sets.
// Header-only and heap-free so that the -fno-exceptions test can use it too.
#pragma once

#include "indicial/fitter/tailless_model.hpp"
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

}  // namespace indicial::test_models
