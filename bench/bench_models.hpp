// bench/bench_models.hpp -- the model sets and the motion every runtime benchmark uses.
//
// What it is for
// --------------
// The benchmarks time the runtime on the report's Example 1 structures in pitch, C_L and C_m
// together (one model set, two coefficients):
//   * Model I:   a(x) with 3 powers + 2 knots (power 2), b1 constant           (Table I)
//   * Model II:  the same a(x), b1(x) = 1 power + 4 knots (power 1)            (Table I)
//   * two lags:  Model II plus a second lag with its own b2(x) (1 power + 2 knots) and gain c2
//   * stall2:    Model II plus both dynamic-stall families on C_L and on C_m (issue 22)
// C_m is Table I exactly. The report gives no C_L model for Example 1, so C_L uses the same
// structure with plausible delta-wing numbers: the cost of a step depends on the structure
// (number of powers, knots, lags), not on the values, as long as the angle crosses the knots the
// way a real motion does. The motion is the report's: alpha = 35 + 35 sin(2 pi f t) deg.
//
// Usage
// -----
//   auto set = indicial::bench::make_model_set<double>(indicial::bench::ModelKind::model_ii);
//   indicial::bench::Motion<double> motion(1000.0);   // 1 kHz samples of a 1 Hz oscillation
//   double alpha = motion.angle_rad(i), q = motion.rate_radps(i);
//
// Warnings
// --------
// 1. These structures are for timing only; tests and examples take their models from the
//    coefficient files and the simulator, never from here.
// 2. The motion table holds exactly one period, so index i wraps with i % size().
#pragma once

#include <cmath>
#include <cstddef>
#include <vector>

#include "indicial/fitter/tailless_model.hpp"
#include "indicial/model.hpp"

namespace indicial {
namespace bench {

using Cap = DefaultCapacity;

// model_ii_stall_hysteresis: model_ii_stall with the static hysteresis (dxr = 3 deg, model.hpp)
// on both coefficients: every family the step has.
enum class ModelKind : int { model_i = 0, model_ii = 1, two_lags = 2, model_ii_stall = 3, model_ii_stall_hysteresis = 4 };

inline const char* model_kind_name(ModelKind k) {
  return k == ModelKind::model_i ? "model1" : k == ModelKind::model_ii ? "model2"
         : k == ModelKind::two_lags ? "twolag" : k == ModelKind::model_ii_stall ? "stall2" : "stall2h";
}

constexpr double kReferenceLengthM = tailless_reference_length_m;  // l / V = 0.02131 s (Table I)
constexpr double kAirspeedMps = tailless_airspeed_mps;

namespace detail {
template <class Scalar, int P, int K>
void set_poly(Spline<Scalar, P, K>& s, std::initializer_list<double> c) {
  s.n_powers = 0;
  for (double v : c) s.power_coef[s.n_powers++] = Scalar(v);
}
template <class Scalar, int P, int K>
void add_knot(Spline<Scalar, P, K>& s, double knot_rad, int power, double coef) {
  s.knot_rad[s.n_knots] = static_cast<typename KnotStorage<Scalar>::type>(knot_rad);
  s.knot_power[s.n_knots] = power;
  s.knot_coef[s.n_knots] = Scalar(coef);
  ++s.n_knots;
}

// Both dynamic-stall families (model.hpp's StallModel, issue 22) with Leishman & Beddoes'
// NACA 0012 constants (C_Na 6.47 -- here 2.6 for this wing's C_L --, f0 with its break at
// 15.25 deg, T1 = 3, T2 = 1.7, C_N1 = 1.31, T_v = 6, T_vl = 7; C_m's centre of pressure K0,
// K1, K2 = 0.0025, -0.135, 0.04 and vortex travel 0.2), the f0 table every 2 deg over the
// motion's 0..70 deg (36 rows), so the motion crosses separation, shedding and reattachment.
template <class Scalar>
void add_stall_families(StallModel<Scalar, Cap>& st, bool lift) {
  const double pi = 3.14159265358979323846;
  st.families = StallFamilies::separation_and_vortex;
  auto& p = st.separation;
  p.normal_force_slope_per_rad = Scalar(lift ? 2.6 : 6.47);
  p.n_f0 = 36;
  for (int i = 0; i < p.n_f0; ++i) {
    const double a_deg = 2.0 * i;
    p.f0_x_rad[i] = static_cast<typename KnotStorage<Scalar>::type>(a_deg * pi / 180.0);
    p.f0_value[i] = Scalar(a_deg <= 15.25 ? 1.0 - 0.3 * std::exp((a_deg - 15.25) / 3.0)
                                          : 0.04 + 0.66 * std::exp((15.25 - a_deg) / 2.3));
  }
  p.tau1_semichords = Scalar(3.0);
  p.tau2_semichords = Scalar(1.7);
  p.cp_k0 = Scalar(lift ? 1.0 : 0.0025);
  p.cp_k1 = Scalar(lift ? 0.0 : -0.135);
  p.cp_k2 = Scalar(lift ? 0.0 : 0.04);
  st.vortex.shedding_threshold = Scalar(1.31);
  st.vortex.decay_semichords = Scalar(6.0);
  st.vortex.travel_semichords = Scalar(7.0);
  st.vortex.lift_gain = Scalar(lift ? 1.0 : 0.0);
  st.vortex.cp_travel = Scalar(lift ? 0.0 : 0.2);
}

// C_m is Table I (tailless_model.hpp); C_L takes Table I's structure with its own values and
// C_m's b1 (the cost of a step depends on the structure, not the values).
template <class Scalar>
void fill_coefficient(CoefficientModel<Scalar, Cap>& m, const char* name, bool lift,
                      ModelKind kind) {
  tailless_pitching_moment(kind == ModelKind::model_i ? TaillessModel::model_1 : TaillessModel::model_2, &m);
  for (int i = 0; i < 8; ++i) m.name[i] = '\0';
  for (int i = 0; name[i] != '\0' && i < 7; ++i) m.name[i] = name[i];
  if (lift) {
    // Plausible delta-wing C_L(alpha): slope 2.6/rad, stall-like rounding near 40-50 deg.
    set_poly(m.static_curve.polynomial, {0.0, 2.6, 0.9, -2.1, 0.6});
    set_poly(m.rotary, {1.5, 0.0, -1.0});
    set_poly(m.a, {0.0, -1.1, 4.0});
    m.a.knot_coef[0] = Scalar(-9.0);
    m.a.knot_coef[1] = Scalar(7.0);
  }
  if (kind == ModelKind::model_ii_stall || kind == ModelKind::model_ii_stall_hysteresis) add_stall_families(m.stall, lift);
  if (kind == ModelKind::model_ii_stall_hysteresis) m.stall.separation.reattach_shift_rad = Scalar(3.0 * 3.14159265358979323846 / 180.0);
  if (kind == ModelKind::two_lags) {
    m.n_lags = 2;
    set_poly(m.lags[1].b, {15.0});
    add_knot(m.lags[1].b, 0.6, 1, -6.0);
    add_knot(m.lags[1].b, 0.9, 1, 6.0);
    m.lags[1].gain = Scalar(lift ? 0.4 : 0.3);
  }
}
}  // namespace detail

template <class Scalar>
ModelSet<Scalar, Cap> make_model_set(ModelKind kind) {
  ModelSet<Scalar, Cap> set;
  set.axis = Axis::pitch;
  set.reference_length_m = kReferenceLengthM;
  set.airspeed_mps = kAirspeedMps;
  set.alpha0_rad = 0.0;
  set.x_min_rad = -0.05;
  set.x_max_rad = 1.30;
  set.n_coefficients = 2;
  detail::fill_coefficient(set.coefficients[0], "CL", true, kind);
  detail::fill_coefficient(set.coefficients[1], "Cm", false, kind);
  return set;
}

// One period of alpha = 35 + 35 sin(2 pi f t) deg sampled at rate_hz, and its rate q.
template <class Scalar>
class Motion {
  static constexpr double kDegToRad = 3.14159265358979323846 / 180.0;

 public:
  explicit Motion(double rate_hz, double frequency_hz = 1.0)
      : Motion(rate_hz, 35.0 * kDegToRad, 35.0 * kDegToRad, frequency_hz) {}
  // mean + amplitude sin(2 pi f t), one cycle sampled at rate_hz (hil --model: a user's model
  // moved over its own envelope).
  Motion(double rate_hz, double mean_rad, double amplitude_rad, double frequency_hz) {
    const double pi = 3.14159265358979323846;
    const std::size_t n = static_cast<std::size_t>(std::lround(rate_hz / frequency_hz));
    const double w = 2.0 * pi * frequency_hz;
    angle_.resize(n);
    rate_.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      const double t = static_cast<double>(i) / rate_hz;
      angle_[i] = Scalar(mean_rad + amplitude_rad * std::sin(w * t));
      rate_[i] = Scalar(amplitude_rad * w * std::cos(w * t));
    }
  }
  std::size_t size() const { return angle_.size(); }
  Scalar angle_rad(std::size_t i) const { return angle_[i % angle_.size()]; }
  Scalar rate_radps(std::size_t i) const { return rate_[i % rate_.size()]; }

 private:
  std::vector<Scalar> angle_;
  std::vector<Scalar> rate_;
};

}  // namespace bench
}  // namespace indicial
