// Built-in simulation cases beyond the report's Example 1: the F-16XL-like pitch models of
// Example 2 (report Tables V and VI) and a lateral (roll and yaw) pair. Registered by
// simulation_cases() in cases.cpp (declared in cases_internal.hpp); see indicial/fitter/simulate.hpp.
//
// f16xl-like-CL, f16xl-like-Cm
//   a(x), b1(x), con: Table V. Eq. 29 calls a(x)'s constant and linear terms a_1 and a_2, so the
//   C_L row's a_1 = 9.8 is the CONSTANT and a_2 = -31.0 the linear term:
//     C_L: a(x) = 9.8 - 31.0 x + 50 (x - 20 deg)_+^2 - 22 (x - 47.5 deg)_+^2
//          b1(x) = b_0 - 16.1 x + 49 (x - 45 deg)_+ - 32 (x - 55 deg)_+,  con = -0.14
//     C_m: a(x) = -0.52 + 5.1 x - 9.7 x^2 + 18 (x - 26 deg)_+^2 - 11 (x - 46 deg)_+^2
//          b1 = 7.1,  con = 0.07
//   STABILITY: with the printed b_0 = 12.6, b1(45 deg) = 12.6 - 16.1 * 0.7854 = -0.045 1/s: the
//   lag would not decay there and the runtime refuses the model (unstable_lag). We use
//   b_0 = 13.5, two Cramer-Rao bounds (0.45) above the printed value, so b1 >= 0.855 1/s
//   (minimum at 45 deg). This is our choice, not the report's.
//   Rotary terms: Table VI's a priori values. C_mq = -1.245 - 0.3806 x + 1.5557 x^2. C_Lq =
//   -0.424 below 20 deg and -2.0 + 5.7 x - 3.4 x^2 from 20 deg on; written continuous as
//   -0.424 + 3.32635 (x - 20 deg)_+ - 3.4 (x - 20 deg)_+^2 (the Taylor expansion of the upper
//   branch at 20 deg; it differs from the printed upper polynomial by its jump at 20 deg,
//   -0.4246 vs -0.424, i.e. 6e-4 everywhere above the knot).
//   STATIC CURVES ARE ASSUMED: the report gives no analytic static curves. We use smooth,
//   plausible delta-wing curves (C_L rising with slope ~2.1/rad to a maximum of ~1.24 near
//   40 deg then falling to ~0.93 at 70 deg; C_m near zero to 30 deg then falling to -0.2 at
//   70 deg), least-squares polynomials through hand-picked points. They are NOT measured.
//   V = 17.52 m/s, mean chord 0.753 m (l = c / 2), alpha = 35 - 35 cos(2 pi f t) at 0.25,
//   0.42, 0.75 and 1.00 Hz, three cycles, dt = 0.01 s.
//
// lateral-roll-Cl, lateral-yaw-Cn (our own plausible lateral models; not from the report)
//   Roll: phi = -35 cos(2 pi f t) deg at alpha0 = 30 deg, beta = asin(sin phi sin alpha0) (eq. 17)
//     C_l(beta) = -0.18 beta + 0.25 beta^3, C_lp = -0.35, a(beta) = 0.6 - 4 beta^2,
//     b1(beta) = 3 + 25 beta^2 (1/s).
//   Yaw: psi = -20 cos(2 pi f t) deg at alpha0 = 30 deg, beta = asin(-sin psi cos alpha0) (eq. 20)
//     C_n(beta) = 0.09 beta - 0.6 beta^3, C_nr = -0.3, a(beta) = 0.35 + 2 beta^2, b1 = 2.5 1/s.
//   l = 0.49 m (span / 2 of a 10 %-scale F-16XL-like model), V = 17.52 m/s; 0.25, 0.5, 1.0 Hz.
#include <cstdio>
#include <string>
#include <vector>

#include "indicial/fitter/simulate.hpp"
#include "simulate/cases_internal.hpp"

namespace indicial {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

template <class S>
void set_poly(S& s, std::initializer_list<double> coefs) {
  s.n_powers = 0;
  for (double c : coefs) s.power_coef[s.n_powers++] = c;
}
template <class S>
void add_knot(S& s, double knot_rad, int power, double coef) {
  s.knot_rad[s.n_knots] = knot_rad;
  s.knot_power[s.n_knots] = power;
  s.knot_coef[s.n_knots] = coef;
  ++s.n_knots;
}
void set_name(CoefficientModel<double, FitCapacity>& m, const char* name) {
  for (int i = 0; i < 7 && name[i] != '\0'; ++i) m.name[i] = name[i];
}

MotionSpec sine(double mean_rad, double amplitude_rad, double freq_hz) {
  MotionSpec s;
  s.kind = MotionKind::sine;
  s.mean_rad = mean_rad;
  s.amplitude_rad = amplitude_rad;
  s.freq_hz = freq_hz;
  s.cycles = 3.0;
  s.dt_s = 0.01;
  return s;
}

std::string freq_file(double f) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "run_f%.2f.csv", f);
  return buf;
}

enum class F16xlCoefficient { lift, pitching_moment };

SimulationCase f16xl_case(F16xlCoefficient which) {
  const bool lift = which == F16xlCoefficient::lift;
  SimulationCase c;
  c.name = lift ? "f16xl-like-CL" : "f16xl-like-Cm";
  c.description = lift ? "report Tables V-VI, C_L (b_0 raised to 13.5 for a decaying lag); STATIC CURVE "
                         "ASSUMED, not measured (the report gives none); the a priori C_Lq's knot terms "
                         "are [rotary] prior_knots_deg in experiment.toml"
                       : "report Tables V-VI, C_m; STATIC CURVE ASSUMED, not measured (the report gives "
                         "none)";
  TruthModel& t = c.truth;
  t.axis = Axis::pitch;
  t.reference_length_m = 0.753 / 2.0;
  t.airspeed_mps = 17.52;
  t.alpha0_rad = 0.0;
  t.x_min_rad = -5.0 * kDeg;
  t.x_max_rad = 75.0 * kDeg;
  t.n_coefficients = 1;
  auto& m = t.coefficients[0];
  m.static_curve.kind = StaticKind::polynomial;
  m.n_lags = 1;
  std::vector<double> static_poly, rotary_poly;
  if (lift) {
    set_name(m, "CL");
    static_poly = {0.002, 2.089, 2.259, -4.598, 0.367, 0.943};
    rotary_poly = {-0.424};
    set_poly(m.rotary, {-0.424});
    add_knot(m.rotary, 20.0 * kDeg, 1, 3.32635);
    add_knot(m.rotary, 20.0 * kDeg, 2, -3.4);
    set_poly(m.a, {9.8, -31.0});
    add_knot(m.a, 20.0 * kDeg, 2, 50.0);
    add_knot(m.a, 47.5 * kDeg, 2, -22.0);
    set_poly(m.lags[0].b, {13.5, -16.1});
    add_knot(m.lags[0].b, 45.0 * kDeg, 1, 49.0);
    add_knot(m.lags[0].b, 55.0 * kDeg, 1, -32.0);
    m.con = -0.14;
  } else {
    set_name(m, "Cm");
    static_poly = {0.001, -0.339, 1.344, -1.984, 0.819};
    rotary_poly = {-1.245, -0.3806, 1.5557};
    set_poly(m.rotary, {-1.245, -0.3806, 1.5557});
    set_poly(m.a, {-0.52, 5.1, -9.7});
    add_knot(m.a, 26.0 * kDeg, 2, 18.0);
    add_knot(m.a, 46.0 * kDeg, 2, -11.0);
    set_poly(m.lags[0].b, {7.1});
    m.con = 0.07;
  }
  m.static_curve.polynomial.n_powers = 0;
  for (double v : static_poly) m.static_curve.polynomial.power_coef[m.static_curve.polynomial.n_powers++] = v;

  for (double f : {0.25, 0.42, 0.75, 1.00}) {
    c.motions.push_back(sine(35.0 * kDeg, 35.0 * kDeg, f));
    c.run_files.push_back(freq_file(f));
  }

  Experiment& e = c.experiment;
  e.axis = Axis::pitch;
  e.coefficient = lift ? "CL" : "Cm";
  e.reference_length_m = t.reference_length_m;
  e.airspeed_mps = t.airspeed_mps;
  e.static_curve.kind = StaticKind::polynomial;
  e.static_curve.polynomial = static_poly;
  // The a priori C_aq is the truth's, knot terms included (C_Lq's break at 20 deg).
  e.rotary.polynomial = rotary_poly;
  for (int j = 0; j < t.coefficients[0].rotary.n_knots; ++j) {
    e.rotary.prior_knots_rad.push_back(t.coefficients[0].rotary.knot_rad[j]);
    e.rotary.prior_knot_powers.push_back(t.coefficients[0].rotary.knot_power[j]);
    e.rotary.prior_knot_coefficients.push_back(t.coefficients[0].rotary.knot_coef[j]);
  }
  e.rotary.estimate = false;
  e.model.structure = StructureMode::fixed;
  e.model.bias = true;
  if (lift) {
    e.model.a = SplineConfig{{0, 1}, {20.0 * kDeg, 47.5 * kDeg}, 2};
    e.model.b1 = SplineConfig{{0, 1}, {45.0 * kDeg, 55.0 * kDeg}, 1};
  } else {
    e.model.a = SplineConfig{{0, 1, 2}, {26.0 * kDeg, 46.0 * kDeg}, 2};
    e.model.b1 = SplineConfig{{0}, {}, 1};
  }
  list_case_runs(c);
  return c;
}

enum class LateralAxis { roll, yaw };

SimulationCase lateral_case(LateralAxis which) {
  const bool roll = which == LateralAxis::roll;
  SimulationCase c;
  c.name = roll ? "lateral-roll-Cl" : "lateral-yaw-Cn";
  c.description = roll ? "roll oscillation phi = +-35 deg at alpha0 = 30 deg; plausible C_l model (ours, "
                         "not the report's)"
                       : "yaw oscillation psi = +-20 deg at alpha0 = 30 deg; plausible C_n model (ours, "
                         "not the report's)";
  TruthModel& t = c.truth;
  t.axis = roll ? Axis::roll : Axis::yaw;
  t.reference_length_m = 0.49;
  t.airspeed_mps = 17.52;
  t.alpha0_rad = 30.0 * kDeg;
  t.x_min_rad = -25.0 * kDeg;
  t.x_max_rad = 25.0 * kDeg;
  t.n_coefficients = 1;
  auto& m = t.coefficients[0];
  m.static_curve.kind = StaticKind::polynomial;
  m.n_lags = 1;
  std::vector<double> static_poly, rotary_poly;
  if (roll) {
    set_name(m, "Cl");
    static_poly = {0.0, -0.18, 0.0, 0.25};
    rotary_poly = {-0.35};
    set_poly(m.a, {0.6, 0.0, -4.0});
    set_poly(m.lags[0].b, {3.0, 0.0, 25.0});
  } else {
    set_name(m, "Cn");
    static_poly = {0.0, 0.09, 0.0, -0.6};
    rotary_poly = {-0.3};
    set_poly(m.a, {0.35, 0.0, 2.0});
    set_poly(m.lags[0].b, {2.5});
  }
  m.static_curve.polynomial.n_powers = 0;
  for (double v : static_poly) m.static_curve.polynomial.power_coef[m.static_curve.polynomial.n_powers++] = v;
  m.rotary.n_powers = 0;
  for (double v : rotary_poly) m.rotary.power_coef[m.rotary.n_powers++] = v;

  const double amplitude = (roll ? 35.0 : 20.0) * kDeg;
  for (double f : {0.25, 0.5, 1.0}) {
    c.motions.push_back(sine(0.0, amplitude, f));
    c.run_files.push_back(freq_file(f));
  }

  Experiment& e = c.experiment;
  e.axis = t.axis;
  e.coefficient = m.name;
  e.reference_length_m = t.reference_length_m;
  e.airspeed_mps = t.airspeed_mps;
  e.alpha0_rad = t.alpha0_rad;
  e.static_curve.kind = StaticKind::polynomial;
  e.static_curve.polynomial = static_poly;
  e.rotary.polynomial = rotary_poly;
  e.rotary.estimate = false;
  e.model.structure = StructureMode::fixed;
  e.model.bias = false;
  e.model.a = SplineConfig{{0, 2}, {}, 2};
  e.model.b1 = roll ? SplineConfig{{0, 2}, {}, 1} : SplineConfig{{0}, {}, 1};
  list_case_runs(c);
  return c;
}

}  // namespace

std::vector<SimulationCase> f16xl_like_cases() {
  return {f16xl_case(F16xlCoefficient::lift), f16xl_case(F16xlCoefficient::pitching_moment)};
}

std::vector<SimulationCase> lateral_cases() {
  return {lateral_case(LateralAxis::roll), lateral_case(LateralAxis::yaw)};
}

}  // namespace indicial
