// stall_test_model.hpp -- the dynamic-stall model of the unit tests of model.hpp's families
// (test_stall_model.cpp) and of their periodic state (test_periodic_stall.cpp): every
// parameter set by hand, Beddoes-Leishman-like; not fitted to anything.
#pragma once

#include <cmath>

#include "indicial/model.hpp"
#include "test_support.hpp"

namespace indicial::test_models {

constexpr double kDeg = indicial::testing::kPi / 180.0;

// Leishman & Beddoes' exponential static separation (NACA 0012, alpha1 = 15.25 deg), as the
// static table of the tests, every 0.5 deg from -12 to 40 deg.
inline double bl_f0(double alpha_rad) {
  const double a = std::abs(alpha_rad) / kDeg;
  if (a <= 15.25) return 1.0 - 0.3 * std::exp((a - 15.25) / 3.0);
  return 0.04 + 0.66 * std::exp((15.25 - a) / 2.3);
}

template <class S>
inline indicial::StallModel<S, indicial::FitCapacity> test_model(indicial::StallFamilies families) {
  indicial::StallModel<S, indicial::FitCapacity> m;
  m.families = families;
  auto& p = m.separation;
  p.normal_force_slope_per_rad = S(6.28);
  p.zero_lift_angle_rad = S(0.2 * kDeg);
  p.n_f0 = 0;
  for (double a = -12.0; a <= 40.0 + 1e-9; a += 0.5) {
    p.f0_x_rad[p.n_f0] = static_cast<typename indicial::KnotStorage<S>::type>(a * kDeg);
    p.f0_value[p.n_f0] = S(bl_f0(a * kDeg));
    ++p.n_f0;
  }
  p.f0_correction.n_powers = 2;
  p.f0_correction.power_coef[0] = S(0.01);
  p.f0_correction.power_coef[1] = S(-0.05);
  p.tau1_semichords = S(3.0);
  p.tau2_semichords = S(1.7);
  p.cp_k0 = S(1.0);
  p.cp_k1 = S(-0.1);
  p.cp_k2 = S(0.05);
  m.vortex.shedding_threshold = S(1.3);
  m.vortex.decay_semichords = S(6.0);
  m.vortex.travel_semichords = S(7.0);
  m.vortex.lift_gain = S(1.0);
  m.vortex.cp_travel = S(0.4);
  return m;
}

}  // namespace indicial::test_models
