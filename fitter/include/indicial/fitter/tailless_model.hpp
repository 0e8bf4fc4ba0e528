// indicial/fitter/tailless_model.hpp -- the report's Table I model, written once.
//
// What it is for
// --------------
// Klein & Murphy's Example 1 (Table I) is the tailless aircraft's pitching moment in two
// variants, Model I (b1 constant) and Model II (b1(alpha) a spline with four knots). The
// simulator's built-in cases, the runtime tests, the benchmarks and the committed
// examples/tailless-model-*.coef (checked byte for byte by tests/test_coef_file.cpp) all take
// it from here. Header-only, constexpr, no heap, no exceptions, depending on model.hpp only,
// so that the -fno-exceptions runtime tests and the benchmarks can use it too.
//
//   C_m(alpha) = 0.42 a + 0.34 a^2 - a^3 + 0.40 a^4,   C_mq = -2 + 0.8 a^2,
//   a(alpha)   = 0.28 a - 3.2 a^2 + 8 (a - 0.4363)_+^2 - 7.4 (a - 0.9599)_+^2,
//   b1         = 2.5 1/s (Model I), or
//   b1(alpha)  = 2.5 - 5.73 (a - 0.349)_+ + 5.73 (a - 0.5236)_+ + 5.73 (a - 0.827)_+
//                - 5.73 (a - 1.0472)_+ (Model II),
//   l / V = 0.3765 / 17.667762 = 0.02131 s, envelope 0..70 deg (a = alpha in rad).
//
// Usage
// -----
//   constexpr auto m = indicial::tailless_model_set<indicial::DefaultCapacity>(
//       indicial::TaillessModel::model_2);
//   indicial::CoefficientModel<double, Cap> cm{};
//   indicial::tailless_pitching_moment(indicial::TaillessModel::model_1, &cm);   // C_m only
//
// Warnings
// --------
// 1. The report gives l / V = 0.02131 s, not V: the committed files use V = 17.667762 m/s
//    (tailless_airspeed_mps); the simulator's cases use 0.3765 / 0.02131 exactly (pass it
//    as the airspeed). The two differ by 2e-8 relative.
// 2. Angles in rad; the knots are the report's degrees converted and rounded as it gives them.
#pragma once

#include "indicial/model.hpp"

namespace indicial {

enum class TaillessModel : int { model_1 = 0, model_2 = 1 };

inline constexpr double tailless_reference_length_m = 0.3765;
inline constexpr double tailless_l_over_v_s = 0.02131;
inline constexpr double tailless_airspeed_mps = 17.667762;
inline constexpr double tailless_envelope_max_rad = 1.2217304763960306;  // 70 deg

namespace tailless_detail {
template <class Scalar, int P, int K>
constexpr void add_knot(Spline<Scalar, P, K>* s, double knot_rad, int power, double coef) {
  s->knot_rad[s->n_knots] = static_cast<typename KnotStorage<Scalar>::type>(knot_rad);
  s->knot_power[s->n_knots] = power;
  s->knot_coef[s->n_knots] = Scalar(coef);
  ++s->n_knots;
}
}  // namespace tailless_detail

// Table I's C_m into *m (name "Cm", one lag).
template <class Scalar, class Cap>
constexpr void tailless_pitching_moment(TaillessModel kind, CoefficientModel<Scalar, Cap>* m) {
  using tailless_detail::add_knot;
  m->name[0] = 'C';
  m->name[1] = 'm';
  m->name[2] = '\0';
  m->static_curve.kind = StaticKind::polynomial;
  auto& st = m->static_curve.polynomial;
  const double static_coef[5] = {0.0, 0.42, 0.34, -1.0, 0.40};
  st.n_powers = 5;
  for (int i = 0; i < 5; ++i) st.power_coef[i] = Scalar(static_coef[i]);
  m->rotary.n_powers = 3;
  m->rotary.power_coef[0] = Scalar(-2.0);
  m->rotary.power_coef[1] = Scalar(0.0);
  m->rotary.power_coef[2] = Scalar(0.8);
  m->a.n_powers = 3;
  m->a.power_coef[0] = Scalar(0.0);
  m->a.power_coef[1] = Scalar(0.28);
  m->a.power_coef[2] = Scalar(-3.2);
  add_knot(&m->a, 0.4363, 2, 8.0);
  add_knot(&m->a, 0.9599, 2, -7.4);
  m->n_lags = 1;
  m->lags[0].b.n_powers = 1;
  m->lags[0].b.power_coef[0] = Scalar(2.5);
  if (kind == TaillessModel::model_2) {
    add_knot(&m->lags[0].b, 0.349, 1, -5.73);
    add_knot(&m->lags[0].b, 0.5236, 1, 5.73);
    add_knot(&m->lags[0].b, 0.827, 1, 5.73);
    add_knot(&m->lags[0].b, 1.0472, 1, -5.73);
  }
}

// The whole model set: pitch, l = 0.3765 m, envelope 0..70 deg, C_m of Table I.
template <class Cap>
constexpr ModelSet<double, Cap> tailless_model_set(TaillessModel kind,
                                                   double airspeed_mps = tailless_airspeed_mps) {
  ModelSet<double, Cap> m{};
  m.axis = Axis::pitch;
  m.reference_length_m = tailless_reference_length_m;
  m.airspeed_mps = airspeed_mps;
  m.alpha0_rad = 0.0;
  m.x_min_rad = 0.0;
  m.x_max_rad = tailless_envelope_max_rad;
  m.n_coefficients = 1;
  tailless_pitching_moment(kind, &m.coefficients[0]);
  return m;
}

}  // namespace indicial
