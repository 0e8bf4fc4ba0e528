// indicial/model.hpp -- the nonlinear unsteady aerodynamic model, written once.
//
// What it is for
// --------------
// This header is the single definition of the model of Klein & Murphy, "Estimation of
// Aircraft Nonlinear Unsteady Parameters From Wind Tunnel Data" (see docs/model.md):
//
//   C_a(t) = C_a(x) + dC_a(x) + (l/V) C_aq(x) rate(t) + sum_j y_j(t)                (eq. 4b)
//   y_j'   = -b_j(x) y_j - c_j a(x_f) x_f'  (+ con for j = 0)                    (eqs. 14b, 16b)
//
// with x the model angle (alpha in pitch; beta = asin(sin phi sin alpha0) in roll and
// beta = asin(-sin psi cos alpha0) in yaw, eqs. 17 and 20), rate the body rate (q, p or r),
// x_f = x(t - delay) the angle seen by the unsteady forcing, c_0 = 1, and a(x), b_j(x) and
// C_aq(x) polynomial splines with plus-function knots.
//
// Everything is templated on the scalar type so that the embedded runtime (double or float),
// the fitter (double) and the fitter's sensitivities (an autodiff type such as
// Eigen::AutoDiffScalar or ceres::Jet) evaluate exactly the same expressions. The structures
// have fixed capacity and no pointers: the runtime uses them without a heap, the generated
// constexpr header initialises them directly.
//
// Usage
// -----
//   indicial::CoefficientModel<double, indicial::DefaultCapacity> cm;   // filled by a loader
//   double y[indicial::DefaultCapacity::max_lags] = {};
//   indicial::StepGeometry<double> g{alpha0_rad, alpha1_rad, alpha0_rad, alpha1_rad, dt_s, 1.0};
//   indicial::advance_lags(cm, g, y);                                   // one discrete step
//   double c = indicial::coefficient_output(cm, alpha1_rad, q1_radps, l_over_v_s, y);
//
// Warnings
// --------
// 1. Angles inside every polynomial and spline are in radians. Knots are stored in radians;
//    files and reports show degrees only where a name says _deg.
// 2. b_j(x) and con are rates in 1/s at the reference airspeed of the model set. At another
//    airspeed V the time scale is V / V_ref (the model is a function of the non-dimensional
//    time s = V t / l); pass that ratio as StepGeometry::time_scale. a(x) and c_j are
//    dimensionless and do not scale; the rotary term carries its own l / V.
// 3. The discrete update (advance_lags) is the one used by the runtime, the fitter and the
//    tests; do not re-derive it elsewhere. It is an exponential integrator of order 2 whose
//    forcing integral is the exact difference of a(x)'s antiderivative, see its comment.
// 4. Knot positions and plus-function powers are structure, not parameters: they are plain
//    double / int and carry no derivative.
#pragma once

#include <cmath>
#include <cstddef>

namespace indicial {

// ------------------------------------------------------------------------------------------
// Capacity: compile-time limits shared by the model structures, the runtime and the file
// parser. The runtime refuses (LoadStatus::over_capacity) a file that needs more.
// ------------------------------------------------------------------------------------------
template <int MaxPowers, int MaxKnots, int MaxLags, int MaxTablePoints, int MaxCoefficients>
struct Capacity {
  static_assert(MaxPowers >= 1 && MaxPowers <= 16,
                "MaxPowers counts x^0..x^(n-1) terms of a spline: 1..16");
  static_assert(MaxKnots >= 0 && MaxKnots <= 32, "MaxKnots must be 0..32");
  static_assert(MaxLags >= 1 && MaxLags <= 4, "MaxLags (exponentials in h(t; x)) must be 1..4");
  static_assert(MaxTablePoints >= 2 && MaxTablePoints <= 512,
                "MaxTablePoints (static table rows) must be 2..512");
  static_assert(MaxCoefficients >= 1 && MaxCoefficients <= 3,
                "MaxCoefficients: one model set holds 1..3 coefficients (CL+Cm, CY+Cl+Cn)");
  static constexpr int max_powers = MaxPowers;
  static constexpr int max_knots = MaxKnots;
  static constexpr int max_lags = MaxLags;
  static constexpr int max_table_points = MaxTablePoints;
  static constexpr int max_coefficients = MaxCoefficients;
};

// Enough for the report's models (a(x): 3 powers + 2 knots; b1(x): 2 powers + 4 knots;
// C_Lq: 3 powers + 2 knots) with room for diagnose's extensions.
using DefaultCapacity = Capacity<8, 8, 2, 64, 3>;
// The fitter's working capacity: larger candidate pools for stepwise regression.
using FitCapacity = Capacity<10, 16, 3, 256, 3>;

enum class Axis : int { pitch = 0, roll = 1, yaw = 2 };

inline constexpr const char* axis_name(Axis axis) {
  return axis == Axis::pitch ? "pitch" : axis == Axis::roll ? "roll" : "yaw";
}

// ------------------------------------------------------------------------------------------
// Polynomial spline: s(x) = sum_{i<n_powers} power_coef[i] x^i
//                         + sum_{j<n_knots} knot_coef[j] (x - knot_rad[j])_+^knot_power[j]
// with (u)_+ = u for u >= 0 and 0 otherwise (the corrected definition under eq. 28).
// ------------------------------------------------------------------------------------------
template <class Scalar, int MaxPowers, int MaxKnots>
struct Spline {
  int n_powers = 0;
  Scalar power_coef[MaxPowers] = {};
  int n_knots = 0;
  double knot_rad[MaxKnots > 0 ? MaxKnots : 1] = {};
  int knot_power[MaxKnots > 0 ? MaxKnots : 1] = {};
  Scalar knot_coef[MaxKnots > 0 ? MaxKnots : 1] = {};
};

namespace detail {
// u^p for small non-negative integer p without pow(): pow() of an autodiff type at u = 0 has
// an undefined derivative for p < 1 and is slower for all p.
template <class Scalar>
inline Scalar int_power(const Scalar& u, int p) {
  Scalar r = Scalar(1);
  for (int i = 0; i < p; ++i) r = r * u;
  return r;
}
}  // namespace detail

// Value s(x).
template <class Scalar, int P, int K>
inline Scalar spline_value(const Spline<Scalar, P, K>& s, const Scalar& x) {
  Scalar r = Scalar(0);
  // Horner from the highest power.
  for (int i = s.n_powers - 1; i >= 0; --i) r = r * x + s.power_coef[i];
  for (int j = 0; j < s.n_knots; ++j) {
    const Scalar u = x - Scalar(s.knot_rad[j]);
    // The plus function: the branch is on the value only, so an autodiff type carries the
    // derivative of whichever side it is on (both sides agree at u = 0 for power >= 1).
    if (u > Scalar(0)) r = r + s.knot_coef[j] * detail::int_power(u, s.knot_power[j]);
  }
  return r;
}

// Derivative ds/dx. A knot term of power 0 (a step) contributes 0 away from its knot.
template <class Scalar, int P, int K>
inline Scalar spline_derivative(const Spline<Scalar, P, K>& s, const Scalar& x) {
  Scalar r = Scalar(0);
  for (int i = s.n_powers - 1; i >= 1; --i) r = r * x + Scalar(i) * s.power_coef[i];
  for (int j = 0; j < s.n_knots; ++j) {
    const int p = s.knot_power[j];
    if (p == 0) continue;
    const Scalar u = x - Scalar(s.knot_rad[j]);
    if (u > Scalar(0)) r = r + Scalar(p) * s.knot_coef[j] * detail::int_power(u, p - 1);
  }
  return r;
}

// Antiderivative S(x) = integral_0^x s(xi) dxi for the polynomial part, and
// (x - k)_+^(p+1) / (p+1) for each knot term (zero below the knot). The difference
// S(x1) - S(x0) is the exact integral of s over [x0, x1] for any x0, x1.
template <class Scalar, int P, int K>
inline Scalar spline_antiderivative(const Spline<Scalar, P, K>& s, const Scalar& x) {
  Scalar r = Scalar(0);
  for (int i = s.n_powers - 1; i >= 0; --i) r = r * x + s.power_coef[i] / Scalar(i + 1);
  r = r * x;
  for (int j = 0; j < s.n_knots; ++j) {
    const int p = s.knot_power[j];
    const Scalar u = x - Scalar(s.knot_rad[j]);
    if (u > Scalar(0)) r = r + s.knot_coef[j] * detail::int_power(u, p + 1) / Scalar(p + 1);
  }
  return r;
}

// ------------------------------------------------------------------------------------------
// Static curve C_a(x): a polynomial spline, or a table interpolated by a natural cubic spline
// (C2-smooth, exact at the rows, zero curvature at both ends; outside the table the end
// cubic's value is NOT extrapolated: the angle is clamped to the first/last row).
// ------------------------------------------------------------------------------------------
enum class StaticKind : int { polynomial = 0, table = 1 };

template <class Scalar, int P, int K, int T>
struct StaticCurve {
  StaticKind kind = StaticKind::polynomial;
  Spline<Scalar, P, K> polynomial;
  int n_table = 0;
  double table_x_rad[T] = {};
  Scalar table_value[T] = {};
  Scalar table_second_derivative[T] = {};  // filled by prepare_static_table()
};

// Computes the natural-spline second derivatives of a table by the tridiagonal (Thomas)
// algorithm, using the caller-free fixed storage of the curve. Requires strictly increasing
// table_x_rad and n_table >= 2 (validated by the loaders).
template <class Scalar, int P, int K, int T>
inline void prepare_static_table(StaticCurve<Scalar, P, K, T>& c) {
  const int n = c.n_table;
  Scalar* m = c.table_second_derivative;
  for (int i = 0; i < n; ++i) m[i] = Scalar(0);
  if (n < 3) return;
  // Forward sweep; gamma holds the modified super-diagonal.
  Scalar gamma[T];
  gamma[0] = Scalar(0);
  for (int i = 1; i < n - 1; ++i) {
    const double h0 = c.table_x_rad[i] - c.table_x_rad[i - 1];
    const double h1 = c.table_x_rad[i + 1] - c.table_x_rad[i];
    const Scalar rhs = Scalar(6) * ((c.table_value[i + 1] - c.table_value[i]) / Scalar(h1) -
                                    (c.table_value[i] - c.table_value[i - 1]) / Scalar(h0));
    const Scalar diag = Scalar(2 * (h0 + h1)) - Scalar(h0) * gamma[i - 1];
    gamma[i] = Scalar(h1) / diag;
    m[i] = (rhs - Scalar(h0) * m[i - 1]) / diag;
  }
  for (int i = n - 2; i >= 1; --i) m[i] = m[i] - gamma[i] * m[i + 1];
}

template <class Scalar, int P, int K, int T>
inline Scalar static_value(const StaticCurve<Scalar, P, K, T>& c, const Scalar& x) {
  if (c.kind == StaticKind::polynomial) return spline_value(c.polynomial, x);
  const int n = c.n_table;
  // Clamp to the table: a cubic extrapolated beyond measured static data is not data.
  if (!(x > Scalar(c.table_x_rad[0]))) return c.table_value[0];
  if (!(x < Scalar(c.table_x_rad[n - 1]))) return c.table_value[n - 1];
  int lo = 0, hi = n - 1;  // binary search: table_x_rad[lo] <= x < table_x_rad[hi]
  while (hi - lo > 1) {
    const int mid = (lo + hi) / 2;
    if (x < Scalar(c.table_x_rad[mid])) hi = mid; else lo = mid;
  }
  const Scalar h = Scalar(c.table_x_rad[hi] - c.table_x_rad[lo]);
  const Scalar A = (Scalar(c.table_x_rad[hi]) - x) / h;
  const Scalar B = Scalar(1) - A;
  return A * c.table_value[lo] + B * c.table_value[hi] +
         ((A * A * A - A) * c.table_second_derivative[lo] +
          (B * B * B - B) * c.table_second_derivative[hi]) * (h * h) / Scalar(6);
}

// ------------------------------------------------------------------------------------------
// One coefficient's model.
// ------------------------------------------------------------------------------------------
template <class Scalar, class Cap>
struct LagState {
  using SplineT = Spline<Scalar, Cap::max_powers, Cap::max_knots>;
  SplineT b;                 // b_j(x), 1/s at the reference airspeed
  Scalar gain = Scalar(1);   // c_j; the first lag's gain is 1 by definition (a(x) absorbs it)
};

template <class Scalar, class Cap>
struct CoefficientModel {
  using SplineT = Spline<Scalar, Cap::max_powers, Cap::max_knots>;
  char name[8] = {};  // "CL", "Cm", "CY", "Cl", "Cn", "CD"
  StaticCurve<Scalar, Cap::max_powers, Cap::max_knots, Cap::max_table_points> static_curve;
  SplineT static_correction;  // angle-only correction dC_a(x) (diagnose: static_error)
  SplineT rotary;             // C_aq(x) (C_ap, C_ar in roll / yaw)
  SplineT a;                  // a(x), dimensionless per rad
  int n_lags = 1;
  LagState<Scalar, Cap> lags[Cap::max_lags];
  Scalar con = Scalar(0);      // constant in the first state equation, 1/s at V_ref
  Scalar delay_s = Scalar(0);  // pure delay of the unsteady forcing, s at V_ref
};

template <class Scalar, class Cap>
struct ModelSet {
  Axis axis = Axis::pitch;
  double reference_length_m = 1.0;  // l: mean chord / 2 in pitch, span / 2 in roll and yaw
  double airspeed_mps = 1.0;        // V_ref: the airspeed the b_j, con and delay refer to
  double alpha0_rad = 0.0;          // roll and yaw: the fixed angle of attack
  double x_min_rad = -3.2;          // the fitted envelope of the model angle x
  double x_max_rad = 3.2;
  int n_coefficients = 0;
  CoefficientModel<Scalar, Cap> coefficients[Cap::max_coefficients];
};

// ------------------------------------------------------------------------------------------
// Axis geometry (report eqs. 17 and 20).
// ------------------------------------------------------------------------------------------
// The model angle x from the motion angle: alpha in pitch, beta from phi (roll) or psi (yaw).
template <class Scalar>
inline Scalar model_angle(Axis axis, double alpha0_rad, const Scalar& motion_angle_rad) {
  using std::asin;
  using std::cos;
  using std::sin;
  switch (axis) {
    case Axis::pitch: return motion_angle_rad;
    case Axis::roll: return asin(sin(motion_angle_rad) * Scalar(std::sin(alpha0_rad)));
    case Axis::yaw: return asin(-sin(motion_angle_rad) * Scalar(std::cos(alpha0_rad)));
  }
  return motion_angle_rad;
}

// ------------------------------------------------------------------------------------------
// The discrete state update.
// ------------------------------------------------------------------------------------------
// phi1(z) = (1 - exp(-z)) / z, the weight of a forcing spread evenly over a step of
// decay z = b dt.
template <class Scalar>
inline Scalar phi1(const Scalar& z) {
  using std::abs;
  using std::exp;
  // Why the branch: (1 - exp(-z)) / z is 0/0 at z = 0 and loses all digits for |z| < 1e-8
  // (1 - exp(-z) cancels). Below |z| = 1e-3 the 4-term Taylor series 1 - z/2 + z^2/6 - z^3/24
  // has truncation error z^4/120 < 1e-14, and, being a polynomial, it also gives an autodiff
  // type the exact derivative -1/2 + z/3 - z^2/8 (no 0/0 in the dual part either). Above it
  // the cancellation costs at most ~1e-13 relative. Both branches agree to 1e-14 at the seam.
  if (abs(z) < Scalar(1e-3)) {
    return Scalar(1) + z * (Scalar(-0.5) + z * (Scalar(1.0 / 6.0) + z * Scalar(-1.0 / 24.0)));
  }
  return (Scalar(1) - exp(-z)) / z;
}

// Everything the update needs about one step of length dt_s, from sample k to k + 1.
template <class Scalar>
struct StepGeometry {
  Scalar x0_rad;          // model angle at sample k
  Scalar x1_rad;          // model angle at sample k + 1
  Scalar forcing_x0_rad;  // angle seen by the forcing at k (x0 without a delay)
  Scalar forcing_x1_rad;  // angle seen by the forcing at k + 1
  Scalar dt_s;
  Scalar time_scale;      // V / V_ref: 1 at the reference airspeed
};

// Advances every lag state of one coefficient over one step, in place (y has n_lags entries):
//
//   y_j(k+1) = exp(-bbar_j dt) y_j(k) + phi1(bbar_j dt) (-c_j [A(xf1) - A(xf0)] + con dt)
//
// where bbar_j = (b_j(x0) + b_j(x1)) / 2 * time_scale and A is the antiderivative of a(x).
// Why this form: it is the exact solution of y' = -bbar y + f when the forcing f is spread
// evenly over the step and b is constant over it. The forcing integral
// integral a(x) x' dt = A(x1) - A(x0) is exact whatever the motion between samples, so no
// rate is differentiated; the trapezoidal bbar and the even spread each cost O(dt^3) per
// step, so the method is second order (tests/test_discretization.cpp measures it). It is
// unconditionally stable for b > 0 and exact as b dt -> 0 (phi1 -> 1, no 0/0 branch).
template <class Scalar, class Cap>
inline void advance_lags(const CoefficientModel<Scalar, Cap>& m, const StepGeometry<Scalar>& g,
                         Scalar* y) {
  using std::exp;
  const Scalar forcing_integral = spline_antiderivative(m.a, g.forcing_x1_rad) -
                                  spline_antiderivative(m.a, g.forcing_x0_rad);
  for (int j = 0; j < m.n_lags; ++j) {
    const Scalar b0 = spline_value(m.lags[j].b, g.x0_rad);
    const Scalar b1 = spline_value(m.lags[j].b, g.x1_rad);
    const Scalar z = Scalar(0.5) * (b0 + b1) * g.time_scale * g.dt_s;
    const Scalar gain = (j == 0) ? Scalar(1) : m.lags[j].gain;
    Scalar drive = -gain * forcing_integral;
    if (j == 0) drive = drive + m.con * g.time_scale * g.dt_s;
    y[j] = exp(-z) * y[j] + phi1(z) * drive;
  }
}

// Steady state at a fixed angle x (x' = 0): y_0 = con / b_0(x), the other lags 0.
// Why the guard: with con = 0 the answer is 0 whatever b is, including b = 0; with con != 0
// and b(x) <= 0 there is no bounded steady state and the caller gets 0 (validated models
// have b > 0 over their envelope, see validate_model in the runtime).
template <class Scalar, class Cap>
inline void steady_state(const CoefficientModel<Scalar, Cap>& m, const Scalar& x_rad, Scalar* y) {
  for (int j = 0; j < m.n_lags; ++j) y[j] = Scalar(0);
  const Scalar b0 = spline_value(m.lags[0].b, x_rad);
  if (m.con != Scalar(0) && b0 > Scalar(0)) y[0] = m.con / b0;
}

// The coefficient at a sample: static + correction + rotary + the sum of the lag states
// (eq. 4b with the convolution replaced by its states). l_over_v_s = l / V at the current
// airspeed; rate_radps is q, p or r.
template <class Scalar, class Cap>
inline Scalar coefficient_output(const CoefficientModel<Scalar, Cap>& m, const Scalar& x_rad,
                                 const Scalar& rate_radps, const Scalar& l_over_v_s,
                                 const Scalar* y) {
  Scalar c = static_value(m.static_curve, x_rad) + spline_value(m.static_correction, x_rad) +
             l_over_v_s * spline_value(m.rotary, x_rad) * rate_radps;
  for (int j = 0; j < m.n_lags; ++j) c = c + y[j];
  return c;
}

// The quasi-steady part only (static + correction + rotary), for comparisons.
template <class Scalar, class Cap>
inline Scalar quasi_steady_output(const CoefficientModel<Scalar, Cap>& m, const Scalar& x_rad,
                                  const Scalar& rate_radps, const Scalar& l_over_v_s) {
  return static_value(m.static_curve, x_rad) + spline_value(m.static_correction, x_rad) +
         l_over_v_s * spline_value(m.rotary, x_rad) * rate_radps;
}

// The continuous-time right-hand side, for reference integrators and tests only:
// dy_j/dt given the model angle x, its rate x' and the forcing angle and rate (x_f, x_f').
template <class Scalar, class Cap>
inline void lag_derivatives(const CoefficientModel<Scalar, Cap>& m, const Scalar& x_rad,
                            const Scalar& forcing_x_rad, const Scalar& forcing_xdot_radps,
                            const Scalar& time_scale, const Scalar* y, Scalar* ydot) {
  const Scalar forcing = spline_value(m.a, forcing_x_rad) * forcing_xdot_radps;
  for (int j = 0; j < m.n_lags; ++j) {
    const Scalar gain = (j == 0) ? Scalar(1) : m.lags[j].gain;
    ydot[j] = -spline_value(m.lags[j].b, x_rad) * time_scale * y[j] - gain * forcing;
    if (j == 0) ydot[j] = ydot[j] + m.con * time_scale;
  }
}

}  // namespace indicial
