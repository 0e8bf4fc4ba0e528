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
// 5. The delayed forcing angle x_f = x(t - delay) is obtained ONLY through delayed_angle()
//    (linear interpolation in time over stored samples, the first sample's angle before
//    them; see its comment) and goes into StepGeometry::forcing_x0_rad / forcing_x1_rad.
//    The delay (CoefficientModel::delay_s) is in seconds at V_ref; at airspeed V it is
//    delay_s * V_ref / V (delay_at_airspeed).
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <type_traits>

namespace indicial {

// ------------------------------------------------------------------------------------------
// Capacity: compile-time limits shared by the model structures, the runtime and the file
// parser. The runtime refuses (LoadStatus::over_capacity) a file that needs more.
// ------------------------------------------------------------------------------------------
// MaxDelaySamples (last, defaulted so that Capacity<P, K, L, T, C> keeps compiling) is the
// number of past (time, model angle) samples the runtime keeps for a delayed forcing
// (Predictor's ring buffer): at a fixed step dt it serves delays up to
// (MaxDelaySamples - 2) dt at the current airspeed (Predictor::history_samples_needed).
template <int MaxPowers, int MaxKnots, int MaxLags, int MaxTablePoints, int MaxCoefficients,
          int MaxDelaySamples = 256>
struct Capacity {
  static_assert(MaxPowers >= 1 && MaxPowers <= 16,
                "MaxPowers counts x^0..x^(n-1) terms of a spline: 1..16");
  static_assert(MaxKnots >= 0 && MaxKnots <= 32, "MaxKnots must be 0..32");
  static_assert(MaxLags >= 1 && MaxLags <= 4, "MaxLags (exponentials in h(t; x)) must be 1..4");
  static_assert(MaxTablePoints >= 2 && MaxTablePoints <= 512,
                "MaxTablePoints (static table rows) must be 2..512");
  static_assert(MaxCoefficients >= 1 && MaxCoefficients <= 3,
                "MaxCoefficients: one model set holds 1..3 coefficients (CL+Cm, CY+Cl+Cn)");
  static_assert(MaxDelaySamples >= 2 && MaxDelaySamples <= 65536,
                "MaxDelaySamples (the runtime's delay history) must be 2..65536: the two "
                "samples of the current step are always kept");
  static constexpr int max_powers = MaxPowers;
  static constexpr int max_knots = MaxKnots;
  static constexpr int max_lags = MaxLags;
  static constexpr int max_table_points = MaxTablePoints;
  static constexpr int max_coefficients = MaxCoefficients;
  static constexpr int max_delay_samples = MaxDelaySamples;
};

// Enough for the report's models (a(x): 3 powers + 2 knots; b1(x): 2 powers + 4 knots;
// C_Lq: 3 powers + 2 knots) with room for diagnose's extensions; 256 delay samples serve a
// delay of 0.254 s at 1 kHz (2.54 s at 100 Hz) at the reference airspeed.
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
// The type a spline keeps its knot positions in. Knots are structure, not parameters
// (warning 4): double whatever the coefficient type (an autodiff Scalar carries no derivative
// for them) -- except in a float spline (the float runtime's), which keeps each knot as the
// float that every evaluation converted it to anyway: the same values, without a
// double-to-float conversion per knot and evaluation, which a single-precision FPU
// (Cortex-M4F) makes a library call (12 per step of Model II C_L + C_m).
template <class Scalar>
struct KnotStorage {
  using type = double;
};
template <>
struct KnotStorage<float> {
  using type = float;
};

template <class Scalar, int MaxPowers, int MaxKnots>
struct Spline {
  int n_powers = 0;
  Scalar power_coef[MaxPowers] = {};
  int n_knots = 0;
  typename KnotStorage<Scalar>::type knot_rad[MaxKnots > 0 ? MaxKnots : 1] = {};
  int knot_power[MaxKnots > 0 ? MaxKnots : 1] = {};
  Scalar knot_coef[MaxKnots > 0 ? MaxKnots : 1] = {};
};

namespace detail {
// u^p for small non-negative integer p without pow(): pow() of an autodiff type at u = 0 has
// an undefined derivative for p < 1 and is slower for all p.
// `one` is the unit of u's type (Scalar(1), or every lane 1 for a lane vector).
template <class T>
inline T int_power_from(const T& one, const T& u, int p) {
  T r = one;
  for (int i = 0; i < p; ++i) r = r * u;
  return r;
}
// v / n for an antiderivative's small integer divisor n = p + 1 >= 1. Why the branch: for n a
// power of two (1, 2, 4, 8: a cubic knot term's 4, a linear one's 2) the product with the exact
// reciprocal 1 / n is the same number as the quotient, bit for bit (scaling by a power of two
// rounds nothing, and where it does, into the subnormals, both round the same exact value),
// and on the runtime step's dependent chain (angle -> B_j(x) -> decay -> output) a multiply
// costs about 4 cycles of latency where a divide costs 13-20 (bench_step, state/model2). Other
// n keep the division. The branch is on the model's integer, never on a value; the
// reciprocals are constants (computing 1.0 / n at run time was a soft-float double division on
// the Cortex-M4F: 651 -> 955 instructions per float step, tools/run-cortex-m.sh).
template <class Scalar, class T>
inline T over_small_int(const T& v, int n) {
  switch (n) {
    case 1: return v;
    case 2: return v * Scalar(0.5);
    case 4: return v * Scalar(0.25);
    case 8: return v * Scalar(0.125);
    default: return v / Scalar(n);
  }
}

template <class Scalar>
inline Scalar int_power(const Scalar& u, int p) {
  return int_power_from(Scalar(1), u, p);
}
}  // namespace detail

// The step's hottest bodies are inlined whatever GCC's size heuristics decide: written once on
// a policy they are one call level deeper than the scalar code was, and an out-of-line call per
// coefficient costs the scalar step instructions (bench_step's callgrind count).
// INDICIAL_PLAIN_INLINING leaves every inlining and layout decision to the compiler: these four
// macros become plain `inline` / nothing (no always_inline, flatten, noinline or branch hint;
// batch.hpp's INDICIAL_LANE_INLINE / _FLATTEN too, though its AVX2 kernel keeps its own
// flatten). tools/run-sanitizers.sh defines it: the forced inlining of every step into every
// caller made the instrumented build compile a third longer (tests/test_runtime_families.cpp
// 58 -> 39 s under ASan + UBSan at -O1), and the step's speed is not what that build checks.
// Define it for every translation unit of a program or for none (the inline functions must be
// the same everywhere); the results are the same bits where the compiler does not contract
// a * b + c into a fused multiply-add (x86-64 without -mfma; elsewhere -ffp-contract=off).
#if (defined(__GNUC__) || defined(__clang__)) && !defined(INDICIAL_PLAIN_INLINING)
#define INDICIAL_HOT_INLINE inline __attribute__((always_inline))
#define INDICIAL_HOT_LAMBDA __attribute__((always_inline))
// The usual outcome of a branch, for the code's layout only (the other side out of line).
#define INDICIAL_LIKELY(c) __builtin_expect(static_cast<bool>(c), 1)
// Every call in the function's body inlined, recursively (GCC's and Clang's `flatten`): for the
// one step a real-time loop calls (runtime.hpp's State step), see there.
#define INDICIAL_FLATTEN __attribute__((flatten))
// Kept out of line, also under INDICIAL_FLATTEN: a branch a model takes or never takes, whose
// body would otherwise weigh on the register allocation of every step (model.hpp's
// stall_filtered_angles).
#define INDICIAL_NOINLINE __attribute__((noinline))
#else
#define INDICIAL_HOT_INLINE inline
#define INDICIAL_HOT_LAMBDA
#define INDICIAL_LIKELY(c) (c)
#define INDICIAL_FLATTEN
#define INDICIAL_NOINLINE
#endif

// ------------------------------------------------------------------------------------------
// Evaluation policies: the spline sums and the update below are written ONCE, on a policy Ops,
// and evaluated either on one Scalar (ScalarOps: double, float, the fitter's autodiff type) or
// on W instances at once (the runtime's step_batch; batch.hpp's BatchLanes). A policy gives
//   using Scalar = ...;  the coefficient type;   using V = ...;  the value type (Scalar, or W
//                        lanes of Scalar: + - * / with V or Scalar on either side, unary -,
//                        comparisons with a Scalar giving a Mask)
//   static V constant(Scalar);                 the value in every lane
//   template <class X> static X one(const X&);             1 of the angle type X
//   template <class X> static auto lift(const X&, double); a model constant (a knot) as X's
//                                                          element type
//   static void add_where(Mask, Acc* acc, F term);  *acc += term() where the mask holds
//   static V choose(Mask, Fa a, Fb b);         mask ? a() : b()
//   static bool any(Mask);
//   static Mask abs_less(const V&, double);    |v| < threshold
//   static void table_value(curve, x, V*);     a static TABLE's value (static_value)
// ScalarOps BRANCHES: add_where skips a term (an autodiff type does none of its work), choose
// evaluates one side. A lane policy SELECTS: both sides are computed in every lane and merged,
// so no lane's value steers the control flow; the result in each lane is the scalar form's at
// that lane's arguments, bit for bit (the same expressions in the same order).
template <class S>
struct ScalarOps {
  using Scalar = S;
  using V = S;
  static S constant(const S& c) { return c; }
  template <class X> static X one(const X&) { return X(1); }
  template <class X> static X lift(const X&, double c) { return X(c); }
  template <class Acc, class F> static void add_where(bool mask, Acc* acc, F term) {
    if (mask) *acc = *acc + term();
  }
  template <class Fa, class Fb> static S choose(bool mask, Fa a, Fb b) {
    if (mask) return a();
    return b();
  }
  static bool any(bool mask) { return mask; }
  static bool abs_less(const S& v, double threshold) {
    using std::abs;
    return abs(v) < S(threshold);
  }
  template <class Curve> static void table_value(const Curve& c, const S& x, S* r) {
    *r = static_value(c, x);
  }
};

// ------------------------------------------------------------------------------------------
// The spline basis: the ONE definition of a spline term and its antiderivative. spline_value
// and spline_antiderivative below sum it (the powers by Horner's rule), the fitter's
// regressors evaluate it term by term. To add a kind of basis term, add it here and to Spline.
//   power term  x^i            antiderivative  x^(i+1) / (i+1)
//   knot term   (x - k)_+^p    antiderivative  (x - k)_+^(p+1) / (p+1)      ((u)_+ = max(u, 0))
// The argument type X may differ from Scalar (a plain double angle with an autodiff Scalar,
// see spline_antiderivative). The plus function branches on the value only, so an autodiff
// type carries the derivative of whichever side it is on.
// ------------------------------------------------------------------------------------------
enum class BasisKind : int { power = 0, knot = 1 };

struct BasisTerm {
  BasisKind kind = BasisKind::power;
  int power = 0;          // i of x^i, or p of (x - k)_+^p
  double knot_rad = 0.0;  // k (knot terms)
};

template <class Scalar, class X>
inline Scalar basis_value(const BasisTerm& t, const X& x) {
  if (t.kind == BasisKind::power) return Scalar(detail::int_power(x, t.power));
  const X u = x - X(t.knot_rad);
  return u > X(0) ? Scalar(detail::int_power(u, t.power)) : Scalar(0);
}

// coef times the term's antiderivative, rounded as (coef * u^(p+1)) / (p+1) (over_small_int): the
// form the runtime has always evaluated (spline_antiderivative), kept so that its results do not
// move.
template <class Scalar, class X>
inline Scalar scaled_basis_antiderivative(const BasisTerm& t, const X& x, const Scalar& coef) {
  const X u = t.kind == BasisKind::power ? x : x - X(t.knot_rad);
  if (t.kind == BasisKind::knot && !(u > X(0))) return Scalar(0);
  return detail::over_small_int<Scalar>(Scalar(coef * detail::int_power(u, t.power + 1)), t.power + 1);
}

template <class Scalar, class X>
inline Scalar basis_antiderivative(const BasisTerm& t, const X& x) {
  return scaled_basis_antiderivative(t, x, Scalar(1));
}

template <class Scalar, int P, int K>
inline BasisTerm knot_term(const Spline<Scalar, P, K>& s, int j) {
  return BasisTerm{BasisKind::knot, s.knot_power[j], s.knot_rad[j]};
}

namespace detail {
// Which sum a knot term belongs to: spline_value's coef u^p or spline_antiderivative's
// (coef u^(p+1)) / (p+1).
enum class KnotSum : int { value = 0, antiderivative = 1 };

// *acc += each knot term of s where x > knot. Why the branch (ScalarOps) / select (lanes): a
// term below its knot is 0; skipping it saves an autodiff type the work. The antiderivative
// term is rounded as (coef * u^(p+1)) / (p+1), scaled_basis_antiderivative's form.
template <class Ops, class Acc, class X, int P, int K>
inline void add_knot_terms(const Spline<typename Ops::Scalar, P, K>& s, const X& x,
                           KnotSum sum_kind, Acc* acc) {
  using Scalar = typename Ops::Scalar;
  for (int j = 0; j < s.n_knots; ++j) {
    Ops::add_where(x > Ops::lift(x, s.knot_rad[j]), acc, [&] {
      const X u = x - Ops::lift(x, s.knot_rad[j]);
      const int p = s.knot_power[j];
      if (sum_kind == KnotSum::value) return Acc(s.knot_coef[j] * int_power_from(Ops::one(u), u, p));
      return Acc(over_small_int<Scalar>(Acc(s.knot_coef[j] * int_power_from(Ops::one(u), u, p + 1)), p + 1));
    });
  }
}
}  // namespace detail

// Value s(x) on a policy (see ScalarOps): *r = s(x).
template <class Ops, int P, int K>
inline typename Ops::V spline_value_with(const Spline<typename Ops::Scalar, P, K>& s,
                                         const typename Ops::V& x) {
  using V = typename Ops::V;
  V acc = Ops::constant(typename Ops::Scalar(0));
  // Horner from the highest power: sum_i power_coef[i] x^i.
  for (int i = s.n_powers - 1; i >= 0; --i) acc = acc * x + s.power_coef[i];
  detail::add_knot_terms<Ops>(s, x, detail::KnotSum::value, &acc);
  return acc;
}

// Value s(x).
template <class Scalar, int P, int K>
inline Scalar spline_value(const Spline<Scalar, P, K>& s, const Scalar& x) {
  return spline_value_with<ScalarOps<Scalar>>(s, x);
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
//
// The angle type X is Scalar (the runtime, and the fitter when the angle depends on the
// parameters, e.g. a delayed forcing angle) or double while Scalar is an autodiff type: the
// fitter's data angle carries no derivative, and a plain double skips the derivative work of
// its powers, which dominates the sensitivities' cost. The expressions are the same for both,
// so with X = Scalar = double the result is bit-identical to the runtime's.
//
// On a policy: *r = S(x); X is Ops::V, or double with ScalarOps of an autodiff Scalar.
template <class Ops, int P, int K, class X>
inline typename Ops::V spline_antiderivative_with(const Spline<typename Ops::Scalar, P, K>& s,
                                                  const X& x) {
  using Scalar = typename Ops::Scalar;
  using V = typename Ops::V;
  V acc = Ops::constant(Scalar(0));
  for (int i = s.n_powers - 1; i >= 0; --i) acc = acc * x + s.power_coef[i] / Scalar(i + 1);
  acc = acc * x;
  detail::add_knot_terms<Ops>(s, x, detail::KnotSum::antiderivative, &acc);
  return acc;
}

template <class Scalar, int P, int K, class X>
inline Scalar spline_antiderivative(const Spline<Scalar, P, K>& s, const X& x) {
  return spline_antiderivative_with<ScalarOps<Scalar>>(s, x);
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

namespace detail {
// The plain number of a Scalar, for an index guess only (never in a result): the value itself,
// or an autodiff type's value() (Eigen::AutoDiffScalar, the fitter's).
inline double plain_value(double v) { return v; }
inline float plain_value(float v) { return v; }
template <class T>
inline double plain_value(const T& v) { return static_cast<double>(v.value()); }
// The type of that guess: float for float (a single-precision FPU has no double arithmetic:
// on the Cortex-M4F each double operation is a library call), double otherwise.
template <class Scalar>
struct guess_type { using type = double; };
template <>
struct guess_type<float> { using type = float; };

// The row of a table with rows x_rad[0..n) (strictly increasing, n >= 2) that brackets x:
// the last lo with Scalar(x_rad[lo]) <= x, so that x < Scalar(x_rad[lo + 1]). The caller has
// clamped: Scalar(x_rad[0]) < x < Scalar(x_rad[n - 1]). The comparisons are made in Scalar,
// as the interpolation's (a float table may round two rows to one float: the last of them is
// still the one row), so the row -- hence the value -- is unique however it is found.
// Why not bisection alone: tables are evenly spaced as a rule (the f0 tables, polars every 1
// or 2 deg), and then x's position in the table's range names the row with one division;
// two comparisons confirm it (one more finds a neighbour, for rounding or a slightly uneven
// table), and bisection between the confirmed bounds takes over for an uneven table. Measured
// (bench_step, callgrind): six f0 lookups per step of the dynamic-stall model, 36 rows.
template <class Scalar, class Key>
inline int table_row_from_position(const Key* x_rad, int n, const Scalar& x) {
  using G = typename guess_type<Scalar>::type;
  const G first = G(x_rad[0]);
  const G position = (G(plain_value(x)) - first) / (G(x_rad[n - 1]) - first) * G(n - 1);
  int lo = position > G(0) ? (position < G(n - 2) ? static_cast<int>(position) : n - 2) : 0;
  int hi = n - 1;
  if (x < Scalar(x_rad[lo])) {         // the guess is above x (lo >= 1: x > x_rad[0])
    if (!(x < Scalar(x_rad[lo - 1]))) return lo - 1;
    hi = lo - 1;
    lo = 0;
  } else if (!(x < Scalar(x_rad[lo + 1]))) {  // below x (lo + 2 <= n - 1: x < x_rad[n - 1])
    if (x < Scalar(x_rad[lo + 2])) return lo + 1;
    lo = lo + 2;
  } else {
    return lo;
  }
  while (hi - lo > 1) {  // bisection: Scalar(x_rad[lo]) <= x < Scalar(x_rad[hi])
    const int mid = (lo + hi) / 2;
    if (x < Scalar(x_rad[mid])) hi = mid; else lo = mid;
  }
  return lo;
}

// Inline, except in float: the float runtime's targets flatten their calls (the Cortex-M4F
// firmware), and inlined at every lookup of its model check the guess cost 1.4 KB of flash
// (its step got shorter out of line too: 914 instead of 924 instructions under QEMU).
template <class Scalar>
inline int table_row(const double* x_rad, int n, const Scalar& x) {
  return table_row_from_position(x_rad, n, x);
}
template <>
#if defined(__GNUC__) || defined(__clang__)
__attribute__((noinline))
#endif
inline int table_row<float>(const double* x_rad, int n, const float& x) {
  return table_row_from_position(x_rad, n, x);
}
// A float table's rows stored as float (a float model's f0 table, KnotStorage): the same row
// as for the rows as double, since the comparisons are made in float either way.
#if defined(__GNUC__) || defined(__clang__)
__attribute__((noinline))
#endif
inline int table_row(const float* x_rad, int n, const float& x) {
  return table_row_from_position(x_rad, n, x);
}
}  // namespace detail

template <class Scalar, int P, int K, int T>
inline Scalar static_value(const StaticCurve<Scalar, P, K, T>& c, const Scalar& x) {
  if (c.kind == StaticKind::polynomial) return spline_value(c.polynomial, x);
  const int n = c.n_table;
  // Clamp to the table: a cubic extrapolated beyond measured static data is not data.
  if (!(x > Scalar(c.table_x_rad[0]))) return c.table_value[0];
  if (!(x < Scalar(c.table_x_rad[n - 1]))) return c.table_value[n - 1];
  const int lo = detail::table_row(c.table_x_rad, n, x);
  const int hi = lo + 1;
  const Scalar h = Scalar(c.table_x_rad[hi] - c.table_x_rad[lo]);
  const Scalar A = (Scalar(c.table_x_rad[hi]) - x) / h;
  const Scalar B = Scalar(1) - A;
  return A * c.table_value[lo] + B * c.table_value[hi] +
         ((A * A * A - A) * c.table_second_derivative[lo] +
          (B * B * B - B) * c.table_second_derivative[hi]) * (h * h) / Scalar(6);
}

// ------------------------------------------------------------------------------------------
// Dynamic stall: the separation and leading-edge-vortex families (issue 22). PARAMETERS here
// (they are part of CoefficientModel); the STATE, the discrete update, the continuous
// derivatives and the output maps are at the end of this file, under "Dynamic stall:
// equations", whose essay gives the equations, units and choices.
// ------------------------------------------------------------------------------------------
// Which families a coefficient carries. The vortex is fed by the separation state, so it
// never comes alone. none: the report's model, exactly as before (no state is stepped).
enum class StallFamilies : int { none = 0, separation = 1, separation_and_vortex = 2 };

inline constexpr const char* stall_families_name(StallFamilies f) {
  return f == StallFamilies::none ? "none"
         : f == StallFamilies::separation ? "separation" : "separation_and_vortex";
}

// How T2 lags the angle that forces the separation point and the shedding criterion (x_e in
// "Dynamic stall: equations" below):
//   delay        x_e = x - T2 (l/V) x'               a time shift of the angle to first order;
//                                                  on a sinusoid of reduced frequency k (in l/V)
//                                                  the phase lag atan(k T2) and the amplitude
//                                                  times sqrt(1 + (k T2)^2): it OVERSHOOTS
//   first_order  T2 (l/V) x_e' + x_e = x             a first-order filter (a state): the same
//                                                  phase lag, the amplitude times
//                                                  1 / sqrt(1 + (k T2)^2), as the lagged normal
//                                                  force C_N' of Beddoes-Leishman (their T_p);
//                                                  on a ramp both give x - T2 (l/V) x'.
// Why both: delay is what models fitted before this choice existed mean (the default; a
// coefficient file without sep_forcing_lag). With delay a fast cycle's lagged angle peaks
// above the angle's own peak (k = 0.15, T2 = 3: 10 deg of amplitude become 11), so a cycle
// that stays attached in the tunnel separates in the model.
enum class ForcingLag : int { delay = 0, first_order = 1 };

inline constexpr const char* forcing_lag_name(ForcingLag l) {
  return l == ForcingLag::delay ? "delay" : "first_order";
}

// The largest static-hysteresis shift dxr (SeparationParameters::reattach_shift_rad) of the
// feasible set: 20 deg. A flow that reattaches only 20 deg below where it separated has no
// static polar worth the name; the bound keeps a fit's trial steps off such models.
inline constexpr double kMaxReattachShiftRad = 0.3490658503988659;

// The largest lag limit D (SeparationParameters::lag_limit_rad) of the feasible set: 20 deg.
// Beyond it the limit does not act on any lag a real motion gives (T2 (l/V) x' is a few deg
// at k = 0.1); the bound keeps a fit's trial steps where D still means something.
inline constexpr double kMaxLagLimitRad = 0.3490658503988659;

// The separation-point family (Goman-Khrabrov state, Kirchhoff output).
//   parameter                       unit           fitter name   coefficient-file key
//   normal_force_slope_per_rad      1/rad          (polar)       sep_polar C_Na alpha0_rad
//   zero_lift_angle_rad             rad            (polar)       sep_polar
//   f0 table (x_rad, value)         rad, 1         (polar)       sep_f0_point x_rad f0 (rows)
//   f0_correction spline            1, x in rad    f0c_{i}, f0cK{j}  sep_f0_corr_poly / _knot
//   tau1_semichords  T1             l/V            T1            sep_time_constants T1 T2
//   tau2_semichords  T2             l/V            T2            sep_time_constants
//   forcing_lag                     (structure)    (structure)   sep_forcing_lag first_order (optional)
//   tau1_reattach_semichords T1r    l/V            T1r           sep_reattachment T1r (optional)
//   reattach_shift_rad  dxr         rad            dxr           sep_hysteresis dxr_rad (optional)
//   lag_limit_rad       D           rad            dxl           sep_lag_limit D_rad (optional)
//   cp_k0, cp_k1, cp_k2             1              k0, k1, k2    sep_cp k0 k1 k2
// The polar items are derived from the static lift polar (kirchhoff_separation, below) and
// are not fitted; T1, T2, the f0 correction and k0..k2 are.
template <class Scalar, class Cap>
struct SeparationParameters {
  using SplineT = Spline<Scalar, Cap::max_powers, Cap::max_knots>;
  Scalar normal_force_slope_per_rad = Scalar(0);  // C_Na of the attached polar
  Scalar zero_lift_angle_rad = Scalar(0);         // alpha_0 of the attached polar
  int n_f0 = 0;                                   // rows of the static separation table
  // Strictly increasing (checked on the double model). Float in a float model, as a spline's
  // knots (KnotStorage): the row search and interpolation are then float only (on the
  // Cortex-M4F each double comparison, subtraction or conversion is a libgcc call: 3,050 ->
  // 2,439 instructions per stall step). Rows that round to one float are harmless: the search
  // compares in float, so such a row never brackets x (table_row) and no width is 0.
  typename KnotStorage<Scalar>::type f0_x_rad[Cap::max_table_points] = {};
  Scalar f0_value[Cap::max_table_points] = {};    // in [0, 1]; linear between rows
  SplineT f0_correction;                          // fitted, ADDED to the table, then clipped
  Scalar tau1_semichords = Scalar(3);             // T1 > 0: relaxation of f
  Scalar tau2_semichords = Scalar(0);             // T2 >= 0: lag of the forcing angle
  ForcingLag forcing_lag = ForcingLag::delay;     // how T2 lags it (structure, not fitted)
  // T1r >= 0: the relaxation of f while the flow REATTACHES (the forcing above f); 0: T1 both
  // ways (one time constant, the default; the coefficient file then has no sep_reattachment).
  Scalar tau1_reattach_semichords = Scalar(0);
  // dxr >= 0: the static hysteresis of stall (see the essay): while the flow reattaches, f
  // relaxes toward the static separation dxr further from alpha_0, f0c(x_e + dxr sgn(x_e -
  // alpha_0)), and holds between that and f0c(x_e); 0: no hysteresis (the default; the
  // coefficient file then has no sep_hysteresis).
  Scalar reattach_shift_rad = Scalar(0);
  // D >= 0: the limit of the forcing angle's lag with ForcingLag::delay (see the essay): x_e =
  // x - D tanh(T2 (l/V) x' / D); 0: no limit (the default; the coefficient file then has no
  // sep_lag_limit). Not with first_order (check_stall_parameters).
  Scalar lag_limit_rad = Scalar(0);
  Scalar cp_k0 = Scalar(0);                       // output shape h(f) = k0 + k1 (1 - f)
  Scalar cp_k1 = Scalar(0);                       //              + k2 4 f^2 (1 - f^2)
  Scalar cp_k2 = Scalar(0);
};

// The leading-edge-vortex family (Beddoes-Leishman vortex lift, smooth switches).
//   parameter                 unit        fitter name   coefficient-file key
//   shedding_threshold  C_N1  1           CN1           vortex_shedding C_N1 width
//   shedding_width            1 (C_N)     (structure)   vortex_shedding
//   decay_semichords    T_v   l/V         Tv            vortex_time_constants Tv Tvl
//   travel_semichords   T_vl  l/V         Tvl           vortex_time_constants
//   clock_width_semichords    l/V         (structure)   vortex_clock width reset
//   clock_reset_semichords    l/V         (structure)   vortex_clock
//   lift_gain           c_v   1           cv            vortex_output c_v x_v
//   cp_travel           x_v   1 (chords)  xv            vortex_output
template <class Scalar>
struct VortexParameters {
  Scalar shedding_threshold = Scalar(1.3);    // C_N1 > 0: |C_N'| above it sheds
  double shedding_width = 0.05;               // > 0: width of the shedding switch, in C_N
  Scalar decay_semichords = Scalar(6);        // T_v > 0: decay of the vortex lift
  Scalar travel_semichords = Scalar(7);       // T_vl > 0: time to convect over the chord
  double clock_width_semichords = 0.5;        // > 0: width of the at-the-trailing-edge switch
  double clock_reset_semichords = 1.0;        // > 0: the clock's return to 0 off the criterion
  Scalar lift_gain = Scalar(0);               // c_v: the vortex lift's weight in the output
  Scalar cp_travel = Scalar(0);               // x_v: centre-of-pressure travel of the vortex
};

template <class Scalar, class Cap>
struct StallModel {
  StallFamilies families = StallFamilies::none;
  SeparationParameters<Scalar, Cap> separation;
  VortexParameters<Scalar> vortex;
};

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
  StallModel<Scalar, Cap> stall;  // dynamic-stall families (none by default)
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
// The model angle from a precomputed axis factor: x = asin(sin(motion) * factor) in roll and
// yaw, x = motion in pitch. The factor (model_angle_factor) is sin(alpha0) in roll and
// -cos(alpha0) in yaw; the runtime computes it once per model instead of once per step.
inline double model_angle_factor(Axis axis, double alpha0_rad) {
  return axis == Axis::roll ? std::sin(alpha0_rad) : axis == Axis::yaw ? -std::cos(alpha0_rad) : 1.0;
}

template <class Scalar>
inline Scalar model_angle_from_factor(Axis axis, const Scalar& factor,
                                      const Scalar& motion_angle_rad) {
  using std::asin;
  using std::sin;
  if (axis == Axis::pitch) return motion_angle_rad;
  return asin(sin(motion_angle_rad) * factor);
}

// The model angle x from the motion angle: alpha in pitch, beta from phi (roll) or psi (yaw).
// (-sin(psi) cos(alpha0) is sin(psi) (-cos(alpha0)) bit for bit: negation is exact.)
template <class Scalar>
inline Scalar model_angle(Axis axis, double alpha0_rad, const Scalar& motion_angle_rad) {
  return model_angle_from_factor(axis, Scalar(model_angle_factor(axis, alpha0_rad)),
                                 motion_angle_rad);
}

// ------------------------------------------------------------------------------------------
// Airspeed scaling (warning 2): the one place V / V_ref and l / V are computed.
// ------------------------------------------------------------------------------------------
// At airspeed V the model runs in the non-dimensional time s = V t / l, so the rates b_j and
// con, given at V_ref, are multiplied by time_scale = V / V_ref (StepGeometry::time_scale),
// and the rotary term carries l / V (coefficient_output's l_over_v_s). The runtime (which
// caches both per airspeed), the fitter, the predictor, the frequency response and the
// reference simulator all take them from here, so they agree bit for bit.
template <class Scalar>
struct AirspeedScaling {
  Scalar time_scale;  // V / V_ref
  Scalar l_over_v_s;  // l / V, in s
};

template <class Scalar>
inline AirspeedScaling<Scalar> airspeed_scaling(const Scalar& reference_airspeed_mps,
                                                const Scalar& reference_length_m,
                                                const Scalar& airspeed_mps) {
  return {airspeed_mps / reference_airspeed_mps, reference_length_m / airspeed_mps};
}

// ------------------------------------------------------------------------------------------
// The discrete state update.
// ------------------------------------------------------------------------------------------
// The exponential of the float step, written once for every place a float step runs: the
// single step (the lags' and the stall families' exps: detail::step_exp below), the batch's
// lanes (batch.hpp's lane_exp, float and double) and every target (host, Cortex-M4F). Why
// not std::exp in float: the C libraries' expf differ in the last bit (glibc's vs newlib's),
// and phi1's 1 - exp(-z) amplifies that bit by 1/z (z = b dt is 1e-3..1e-2 at kHz rates)
// into 1e-5..1e-4 relative differences in the lag states; with this one function the float
// batch gives the single step's bits, and a float firmware the host's
// (firmware/cortex-m/README.md). Double steps keep std::exp (the fitter's, bit for bit).
//
// exp(x) = 2^n exp(r), x = n ln2 + r, |r| <= ln(2)/2 (Cody and Waite: ln 2 in two parts,
// n * hi exact for every n in range), exp(r) by its Taylor polynomial (Estrin) to a degree
// whose truncation error on |r| <= ln(2)/2 is below a hundredth of an ulp (0.35^14 / 14! =
// 4e-18 for double, 0.35^8 / 8! = 5e-9 for float), 2^n built in the exponent bits as two
// factors 2^n1 2^n2, n1 + n2 = n, so that a subnormal result is rounded once and no factor
// leaves the normal range. Rounding to an integer adds and subtracts 1.5 * 2^mantissa_bits
// (never under -ffast-math, batch.hpp refuses it). Inf above the overflow end, 0 below the
// underflow end, NaN for NaN. Within 1 ulp of the C library's (tests/test_lane_exp.cpp).
// Written by hand: no maintained library offers one exp for scalars and vector lanes alike.
template <class S>
struct ExpConstants;
template <>
struct ExpConstants<double> {
  using Bits = std::uint64_t;
  static constexpr int mantissa_bits = 52;
  static constexpr Bits exponent_bias = 1023;
  static constexpr double shifter = 6755399441055744.0;  // 1.5 * 2^52
  static constexpr double log2e = 1.4426950408889634074;
  static constexpr double ln2_hi = 0.693145751953125;            // Cephes' C1
  static constexpr double ln2_lo = 1.42860682030941723212e-6;    // Cephes' C2
  static constexpr double overflow_above = 709.782712893384;     // exp > DBL_MAX: Inf
  static constexpr double underflow_below = -745.1332191019412;  // exp < DBL_TRUE_MIN / 2: 0
  static constexpr int degree = 13;
};
template <>
struct ExpConstants<float> {
  using Bits = std::uint32_t;
  static constexpr int mantissa_bits = 23;
  static constexpr Bits exponent_bias = 127;
  static constexpr float shifter = 12582912.0f;  // 1.5 * 2^23
  static constexpr float log2e = 1.44269504088896341f;
  static constexpr float ln2_hi = 0.693359375f;       // Cephes' expf C1
  static constexpr float ln2_lo = -2.12194440e-4f;    // Cephes' expf C2
  static constexpr float overflow_above = 88.72283935546875f;
  static constexpr float underflow_below = -103.97208404541015625f;
  static constexpr int degree = 7;
};

namespace detail {
// A scalar's bit pattern and back (exp_on's BitCast for one value; batch.hpp has the lane one).
template <class S>
struct ScalarBitCast {
  using Bits = typename ExpConstants<S>::Bits;
  static void to(const S& v, Bits* b) { std::memcpy(b, &v, sizeof *b); }
  static void from(const Bits& b, S* v) { std::memcpy(v, &b, sizeof *v); }
};
}  // namespace detail

// *r = exp of v, v one S or a vector of S (GCC/Clang vector extension: the same operators, a
// comparison gives a lane mask and ?: selects lane by lane). BitCast converts between Part
// and its bit pattern (BitCast::Bits, one unsigned integer per element): to(part, &bits),
// from(bits, &part). (Out parameters: a vector returned by value would change the ABI with
// the register width, -Wpsabi.)
template <class S, class Part, class BitCast>
INDICIAL_HOT_INLINE void exp_on(const Part& v, Part* r) {
  using C = ExpConstants<S>;
  using Bits = typename BitCast::Bits;
  S inverse_factorial[C::degree + 1];
  inverse_factorial[0] = S(1);
#pragma GCC unroll 16
  for (int k = 1; k <= C::degree; ++k) inverse_factorial[k] = inverse_factorial[k - 1] / S(k);
  const Part shifter = Part{} + C::shifter;
  const Bits bias = Bits{} + C::exponent_bias;
  const Part shifted = v * C::log2e + shifter;
  const Part n = shifted - shifter;  // round(x / ln 2)
  const Part reduced = (v - n * C::ln2_hi) - n * C::ln2_lo;
  // 1 + r (1 + r q(r)), q(r) = 1/2! + r/3! + ... by Estrin's scheme (pairs c_2i + c_2i+1 r,
  // then pairs of those with r^2, r^4, ...): a shorter chain of dependent operations than
  // Horner's (a real-time step waits for it), with Horner's last two steps, which keep the
  // rounding error within the ulp that the test asks (Estrin to the end gives 2 ulp). The
  // unroll pragmas: at -O2 (a firmware's usual level) GCC would keep the loops and the terms
  // in memory: 200 more instructions per Cortex-M4 step (measured under QEMU).
  Part terms[C::degree - 1];
#pragma GCC unroll 16
  for (int d = 0; d < C::degree - 1; ++d) terms[d] = Part{} + inverse_factorial[d + 2];
  Part power = reduced;
#pragma GCC unroll 8
  for (int count = C::degree - 1; count > 1; count = (count + 1) / 2) {
#pragma GCC unroll 8
    for (int i = 0; i < count / 2; ++i) terms[i] = terms[2 * i] + power * terms[2 * i + 1];
    if (count % 2 == 1) terms[count / 2] = terms[count - 1];
    power = power * power;
  }
  const Part one = Part{} + S(1);
  const Part poly = one + reduced * (one + reduced * terms[0]);
  const Part half_shifted = n * S(0.5) + shifter;  // n1 = round(n / 2), n2 = n - n1
  const Part n2 = n - (half_shifted - shifter);
  Bits half_shifted_bits, n2_shifted_bits, shifter_bits;
  BitCast::to(half_shifted, &half_shifted_bits);
  BitCast::to(n2 + shifter, &n2_shifted_bits);
  BitCast::to(shifter, &shifter_bits);
  const Bits n1_bits = half_shifted_bits - shifter_bits;  // n1 modulo 2^bits
  const Bits n2_bits = n2_shifted_bits - shifter_bits;
  Part two_n1, two_n2;
  BitCast::from((n1_bits + bias) << C::mantissa_bits, &two_n1);
  BitCast::from((n2_bits + bias) << C::mantissa_bits, &two_n2);
  Part e = poly * two_n1 * two_n2;
  e = v > C::overflow_above ? Part{} + std::numeric_limits<S>::infinity() : e;
  e = v < C::underflow_below ? Part{} : e;
  e = v != v ? v + v : e;
  *r = e;
}

namespace detail {
// The exponential of a step (lag and stall decays, stall switches): exp_on for float (see
// above), std::exp (or an autodiff type's exp, by argument-dependent lookup) otherwise.
template <class Scalar>
inline Scalar step_exp(const Scalar& x) {
  using std::exp;
  return exp(x);
}
INDICIAL_HOT_INLINE float step_exp(const float& x) {
  float r;
  exp_on<float, float, ScalarBitCast<float>>(x, &r);
  return r;
}
}  // namespace detail

// phi1(z) = (1 - exp(-z)) / z, the weight of a forcing spread evenly over a step of
// decay z = b dt. The caller passes exp(-z), which it needs anyway for the free decay: one
// exp() per lag per step instead of two (the compiler cannot merge them under -fmath-errno).
template <class Ops>
inline void phi1_with(const typename Ops::V& z, const typename Ops::V& exp_minus_z,
                      typename Ops::V* r) {
  using Scalar = typename Ops::Scalar;
  using V = typename Ops::V;
  // Why the branch: (1 - exp(-z)) / z is 0/0 at z = 0 and loses all digits for |z| < 1e-8
  // (1 - exp(-z) cancels). Below |z| = 1e-3 the 4-term Taylor series 1 - z/2 + z^2/6 - z^3/24
  // has truncation error z^4/120 < 1e-14, and, being a polynomial, it also gives an autodiff
  // type the exact derivative -1/2 + z/3 - z^2/8 (no 0/0 in the dual part either). Above it
  // the cancellation costs at most ~1e-13 relative. Both branches agree to 1e-14 at the seam.
  // Why times 1 / z rather than over z: z is known before exp(-z) is, so the division runs
  // while exp does and only a multiply is left on the step's dependent chain (one rounding
  // more: within about an ulp of the quotient, far below the cancellation above).
  // bench_step: with the interval mean's 1 / dx (below) and the knot terms' over_small_int,
  // state/model2/double 1.48x -> 1.32-1.34x its floor by time (medians of 8 interleaved runs).
  *r = Ops::choose(
      Ops::abs_less(z, 1e-3),
      [&] { return V(Scalar(1) + z * (Scalar(-0.5) + z * (Scalar(1.0 / 6.0) + z * Scalar(-1.0 / 24.0)))); },
      [&] { return V((Scalar(1) - exp_minus_z) * (Scalar(1) / z)); });
}

template <class Scalar>
inline Scalar phi1(const Scalar& z, const Scalar& exp_minus_z) {
  Scalar r;
  phi1_with<ScalarOps<Scalar>>(z, exp_minus_z, &r);
  return r;
}

template <class Scalar>
inline Scalar phi1(const Scalar& z) {
  using std::exp;
  return phi1(z, Scalar(exp(-z)));
}

namespace detail {
// decay_weights' Taylor polynomial: its degrees and the largest z each serves, per precision.
template <class Scalar>
struct decay_series {
  static constexpr int degree = 12;
  static constexpr double max_z = 0.25;
  static constexpr int small_degree = 9;  // for z <= small_max_z
  static constexpr double small_max_z = 0.0625;
};
template <>
struct decay_series<float> {
  static constexpr int degree = 7;
  static constexpr double max_z = 0.25;
  static constexpr int small_degree = 5;
  static constexpr double small_max_z = 0.0625;
};

// The coefficients (-1)^k / k!, each rounded once (k! is exact in double up to 22!).
constexpr double decay_coefficient[13] = {
    1.0,          -1.0,         1.0 / 2.0,       -1.0 / 6.0,         1.0 / 24.0,        -1.0 / 120.0,     1.0 / 720.0,
    -1.0 / 5040.0, 1.0 / 40320.0, -1.0 / 362880.0, 1.0 / 3628800.0, -1.0 / 39916800.0, 1.0 / 479001600.0};

// exp(-z) = 1 - z phi1(z), phi1(z) = 1 - z T(z): the tail T(z) = c2 + c3 z + ... + c_n z^(n-2)
// of the degree-n Taylor polynomial (decay_weights) by Estrin's scheme: pairs t_2i + z t_2i+1,
// then pairs of those with z^2, z^4, z^8 (4 levels of one multiply and one add for n = 12, 3
// for n = 9, instead of n - 2 dependent Horner steps).
template <class Scalar, int Degree>
INDICIAL_HOT_INLINE Scalar decay_tail(const Scalar& z) {
  static_assert(Degree < 13 && Degree >= 3, "decay_tail: more coefficients needed");
  constexpr int tail = Degree - 1;
  Scalar t[tail];
#pragma GCC unroll 16
  for (int i = 0; i < tail; ++i) t[i] = Scalar(decay_coefficient[i + 2]);
  Scalar power = z;
#pragma GCC unroll 8
  for (int count = tail; count > 1; count = (count + 1) / 2) {
#pragma GCC unroll 8
    for (int i = 0; i < count / 2; ++i) {
      const Scalar pair = t[2 * i] + power * t[2 * i + 1];
      t[i] = pair;
    }
    if (count % 2 == 1) t[count / 2] = t[count - 1];
    if (count > 2) power = power * power;
  }
  return t[0];
}
}  // namespace detail

// exp(-z) and phi1(z) for the decay z >= 0 of one step of the dynamic-stall families (their
// f, clock and vortex decays and first_order's filter; model.hpp's stall stages), written once
// for the fitter (every Scalar, an autodiff type included) and the runtime. Why not step_exp:
// at real-time rates a step's decay is small (z = h / T, h = dt V / l: 0.016..0.05 in
// bench_step's stall2), where the Taylor polynomial of exp(-z) is a third of a call to glibc's
// exp, and a call makes x86-64 spill every live floating-point register around it (issue 22
// item 6: state/stall2/double 2144 -> 1974 instructions, float 2189 -> 2022, bench_step's
// callgrind count). Why both at once: the polynomial's last two Horner steps are
// exp(-z) = 1 - z phi1(z) with phi1(z) = 1 - z T(z) (T: decay_tail), so phi1 comes from the
// polynomial with no division, no branch and no cancellation, where phi1_with's (1 - exp(-z)) /
// z loses about log2(1 / z) bits to 1 - exp(-z) (6 at z = 0.016), and it is ready before
// exp(-z) is (the families' updates wait for it). Degree n = 12 for z <= 1/4, n = 9 for z <=
// 1/16 (float: 7 and 5), the tail by Estrin's scheme (decay_tail; Horner's dependent steps
// are two long waits of each vortex update: issue 22 item 6, bench_step's state/stall2/double
// 160 -> 150 ns median for 43 more instructions), the last two steps by Horner's, whose roundings dominate
// the error (Estrin to the end gives 2 ulp, Horner's last step alone 1.04, measured). Error
// bound (tests/test_stall_model.cpp): the truncation error of exp(-z) is z^(n+1) / (n+1)! <=
// 0.25^13 / 13! = 2.4e-18 (double, n = 12; 0.0625^10 / 10! = 2.5e-19 for n = 9) and 0.25^8 /
// 8! = 3.8e-10 (float, n = 7; 0.0625^6 / 6! = 8.3e-11 for n = 5), and with the roundings
// exp(-z) is within 1 ulp of the exact value (measured 0.80 ulp in double and 0.76 in float
// over the test's 2e5 points; glibc's exp is within 0.51; Horner to the end gave 0.78 and
// 0.77), phi1(z) within 1 ulp of the exact phi1 (measured 0.79 and 0.73; phi1_with's quotient
// of glibc's exp errs by up to 480 ulp there, near z = 1e-3): the families' results are not
// glibc's bits but differ from them by about an ulp per step; the fitter and the runtime
// share this function, so they agree as before (tests/test_runtime_families.cpp). Above
// max_z, or for a NaN: step_exp and phi1_with's quotient. z = 0 gives exactly 1 and 1. The branches compare values only, so an
// autodiff type takes the same side as a double at the same point (and the polynomial's
// derivative, within an ulp of -exp(-z)).
template <class Scalar>
struct DecayWeights {
  Scalar decay;   // exp(-z)
  Scalar weight;  // phi1(z) = (1 - exp(-z)) / z
};
template <class Scalar>
INDICIAL_HOT_INLINE DecayWeights<Scalar> decay_weights(const Scalar& z) {
  using C = detail::decay_series<Scalar>;
  if (!(z <= Scalar(C::max_z))) {
    const Scalar e = detail::step_exp(Scalar(-z));
    return {e, phi1(z, e)};
  }
  const Scalar tail = z <= Scalar(C::small_max_z) ? detail::decay_tail<Scalar, C::small_degree>(z)
                                                   : detail::decay_tail<Scalar, C::degree>(z);
  const Scalar weight = Scalar(1) - z * tail;
  return {Scalar(1) - z * weight, weight};
}

namespace detail {
// Below this angle step the mean of b over [x0, x1] is taken as b at the midpoint (see
// interval_mean). Chosen per precision: the difference quotient (B(x1) - B(x0)) / dx loses
// about eps |B| / dx to cancellation, the midpoint value errs by at most |jump of b'| dx / 8
// at a knot; the threshold roughly balances the two (double: ~1e-9 relative, float: ~1e-4).
template <class Scalar>
struct interval_mean_threshold { static constexpr double value = 1e-7; };
template <>
struct interval_mean_threshold<float> { static constexpr double value = 3e-4; };
}  // namespace detail

// The mean of spline s over the angle interval [x0, x1], given its antiderivative S at both
// ends: (S(x1) - S(x0)) / (x1 - x0). Why the branch: the quotient is 0/0 when the angle does
// not move; there the mean IS the value at the (common) point, and the midpoint value is the
// smooth continuation (same value and first derivatives for an autodiff type).
// On a policy: the midpoint value is evaluated only when some lane needs it (a branch on the
// block, not on a lane; with ScalarOps the plain branch). Why times 1 / dx rather than over
// dx: dx is known as soon as the angle is, so the division runs while the spline sums do and
// only a multiply waits for S(x1) on the step's dependent chain (phi1_with says what it
// bought; one rounding more: within about an ulp of the quotient).
template <class Ops, int P, int K>
inline void interval_mean_with(const Spline<typename Ops::Scalar, P, K>& s,
                               const typename Ops::V& x0, const typename Ops::V& x1,
                               const typename Ops::V& antiderivative_x0,
                               const typename Ops::V& antiderivative_x1, typename Ops::V* mean) {
  using Scalar = typename Ops::Scalar;
  using V = typename Ops::V;
  const V dx = x1 - x0;
  const auto small = Ops::abs_less(dx, detail::interval_mean_threshold<Scalar>::value);
  const auto quotient = [&] { return V((antiderivative_x1 - antiderivative_x0) * (Scalar(1) / dx)); };
  // (Likely: only a step that barely moves takes the midpoint; GCC guessed the other way.)
  if (INDICIAL_LIKELY(!Ops::any(small))) {
    *mean = quotient();
    return;
  }
  const auto midpoint_value = [&] {
    return spline_value_with<Ops>(s, V(Scalar(0.5) * (x0 + x1)));
  };
  *mean = Ops::choose(small, midpoint_value, quotient);
}

template <class Scalar, int P, int K>
inline Scalar interval_mean(const Spline<Scalar, P, K>& s, const Scalar& x0, const Scalar& x1,
                            const Scalar& antiderivative_x0, const Scalar& antiderivative_x1) {
  Scalar mean;
  interval_mean_with<ScalarOps<Scalar>>(s, x0, x1, antiderivative_x0, antiderivative_x1, &mean);
  return mean;
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

// ------------------------------------------------------------------------------------------
// The delayed forcing angle x_f(t) = x(t - delay): the one definition, used by the fitter
// (over a run's arrays) and by the runtime (over its ring buffer).
// ------------------------------------------------------------------------------------------
// The model angle is known only at stored samples, so x(t - delay) is interpolated LINEARLY
// in time between the two samples around t - delay. Why linear:
//   * it is exact at the samples and as fine as the data's own resolution: no angle between
//     samples is invented beyond the straight line (a higher-order interpolant would
//     overshoot at the corners of a ramp and at the start of a motion from rest);
//   * it is monotone between samples: the delayed angle never leaves the range of the two
//     samples around it, so it stays inside the envelope when the samples do;
//   * it is differentiable with respect to the delay inside every segment, with
//     d x_f / d delay = -(slope of x in time on that segment), so an autodiff Scalar delay
//     carries the sensitivity the fitter needs to estimate the delay. (At a delay that lands
//     exactly on a sample time the derivative is the NEWER segment's, i.e. the right-hand
//     derivative in the delay; at delay 0 that is -(x_0 - x_1) / (t_0 - t_1), not 0, so an
//     estimate started at 0 can move.)
//   * it is second order overall: the interpolation error is O(dt^2) and smooth in time, and
//     advance_lags uses only differences of A(x_f), which telescope, so the delayed update
//     keeps the order 2 of the undelayed one (tests/test_advance_lags.cpp measures it).
//
// A History is any object with
//   int    size() const;          // number of stored samples, >= 1
//   double time_s(int i) const;   // i = 0 the NEWEST sample; strictly decreasing in i
//   X      x_rad(int i) const;    // the model angle at that sample (X converts to Scalar)
// Samples newer than t_now_s may be present (the fitter passes a whole run); they are used
// only where t_now_s - delay_s lands among them (a negative delay).
//
// Rules at the ends (no extrapolation):
//   * t_now_s - delay_s before the OLDEST sample: that sample's angle. Why: histories start
//     at rest -- the runtime's reset() is a steady state, a run starts from rest (the reference
//     simulator holds the motion at its first angle before t = 0) -- so the angle there is
//     the first sample's. The derivative with respect to the delay is 0 there. A caller
//     whose history does not reach back to rest must check the coverage itself (the runtime
//     returns StepStatus::delay_exceeds_history instead of calling with too short a history).
//   * t_now_s - delay_s after the NEWEST sample (a negative delay): the newest sample's angle.
//     Why: the future is not known; a fitter should keep the delay >= 0 by construction.
//
// Times are double (the delay is a small difference of large times: computing t - delay in
// float would lose it); the delay is Scalar so that autodiff types carry d/d delay. Ages
// t_now - t_i are formed in double and only then converted. No heap, no exceptions: a binary
// search over the history, O(log size) evaluations of the accessor.
template <class Scalar, class History>
inline Scalar delayed_angle(const History& h, double t_now_s, const Scalar& delay_s) {
  const int n = h.size();
  // Why: an empty history has no angle at all; callers always hold >= 1 sample (the
  // runtime's reset sample, a run's first sample). Return 0 rather than read out of bounds.
  if (n < 1) return Scalar(0);
  const double age_newest = t_now_s - h.time_s(0);
  // Why strict <: at delay == age_newest (delay 0 with t_now the newest time) the newest
  // segment is used below, with weight 0 on its older end: the value is x_0 exactly and the
  // derivative is the segment's, not 0.
  if (n == 1 || delay_s < Scalar(age_newest)) return Scalar(h.x_rad(0));
  const double age_oldest = t_now_s - h.time_s(n - 1);
  if (delay_s > Scalar(age_oldest)) return Scalar(h.x_rad(n - 1));  // at rest before it
  // Binary search for the segment [newer, older] with age_newer < delay <= age_older (or
  // newer = 0 when delay == age_newest). Invariant: age(lo) <= delay <= age(hi).
  int lo = 0;
  int hi = n - 1;
  while (hi - lo > 1) {
    const int mid = lo + (hi - lo) / 2;
    if (Scalar(t_now_s - h.time_s(mid)) >= delay_s) hi = mid; else lo = mid;
  }
  const double age_lo = t_now_s - h.time_s(lo);
  // The span from the same two ages the delay is compared with (not t_lo - t_hi, which
  // rounds differently): a delay equal to a sample's age then gives w = 1 or 0 exactly,
  // i.e. exactly the stored angle.
  const double span = (t_now_s - h.time_s(hi)) - age_lo;
  // Why: a history with two samples at the same time (not strictly decreasing, a caller's
  // error) has no slope to interpolate; take the older one instead of dividing by 0.
  if (!(span > 0.0)) return Scalar(h.x_rad(hi));
  // One operation per named Scalar: autodiff types whose constants carry an empty
  // derivative vector (Eigen::AutoDiffScalar<VectorXd>) are made coherent only between
  // plain scalars, not inside nested expressions.
  const Scalar offset = delay_s - Scalar(age_lo);
  const Scalar w = offset / Scalar(span);  // 0 at the newer sample, 1 at the older
  const Scalar w_newer = Scalar(1) - w;
  const Scalar part_newer = w_newer * Scalar(h.x_rad(lo));
  const Scalar part_older = w * Scalar(h.x_rad(hi));
  // (1 - w) a + w b rather than a + w (b - a): exact at both ends (w = 0 gives a, w = 1 b).
  return part_newer + part_older;
}

// A History over oldest-first arrays (e.g. a run's time_s and its model angle x(t) computed
// with model_angle), seen newest-first as delayed_angle expects. `count` samples, index
// count - 1 the newest. The arrays must outlive the view; nothing is copied.
//   indicial::ArrayHistory<double> h{run.time_s.data(), x_rad.data(), int(run.size())};
//   x_f = indicial::delayed_angle(h, run.time_s[k], delay_eff_s);   // any k: the future
//                                                                   // samples do not matter
template <class X>
struct ArrayHistory {
  const double* time_s_oldest_first = nullptr;
  const X* x_rad_oldest_first = nullptr;
  int count = 0;
  int size() const { return count; }
  double time_s(int i) const { return time_s_oldest_first[count - 1 - i]; }
  X x_rad(int i) const { return x_rad_oldest_first[count - 1 - i]; }
};

// The delay in seconds at airspeed V: delay_s is given at V_ref and, like every time of the
// model, scales with the non-dimensional time s = V t / l: at V it is delay_s * V_ref / V.
template <class Scalar>
inline Scalar delay_at_airspeed(const Scalar& delay_s, double reference_airspeed_mps,
                                double airspeed_mps) {
  return delay_s * Scalar(reference_airspeed_mps / airspeed_mps);
}

// The spline quantities the update needs at one end of a step: A(x_f), the antiderivative of
// a(x) at the forcing angle, and B_j(x), the antiderivative of b_j(x) at the model angle.
// A step's end k+1 is the next step's end k, so a caller stepping forward (the runtime) can
// keep the StepEnd of the last sample and evaluate only the new one: bit-identical results,
// half the spline work (the runtime does this; the fitter and tests call advance_lags).
// No default member initializers: a step's scratch StepEnd is written before it is read, and
// zeroing it first cost the runtime's step instructions; value-initialise (`StepEnd e{}`, or
// `= {}` as the runtime's State does) for zeros.
template <class Scalar, class Cap>
struct StepEnd {
  Scalar forcing_antiderivative;
  Scalar b_antiderivative[Cap::max_lags];
};

// X and XF (the angle and the forcing angle) are Scalar or, in the fitter, double where the
// angle is data (see spline_antiderivative).
// The terms one at a time (evaluate_step_end and advance_lags_to).
template <class Scalar, class Cap, class XF>
INDICIAL_HOT_INLINE Scalar step_end_forcing(const CoefficientModel<Scalar, Cap>& m, const XF& forcing_x_rad) {
  return spline_antiderivative(m.a, forcing_x_rad);
}
template <class Scalar, class Cap, class X>
INDICIAL_HOT_INLINE Scalar step_end_b(const CoefficientModel<Scalar, Cap>& m, int j, const X& x_rad) {
  return spline_antiderivative(m.lags[j].b, x_rad);
}

template <class Scalar, class Cap, class X, class XF>
INDICIAL_HOT_INLINE void evaluate_step_end(const CoefficientModel<Scalar, Cap>& m, const X& x_rad,
                              const XF& forcing_x_rad, StepEnd<Scalar, Cap>* end) {
  end->forcing_antiderivative = step_end_forcing(m, forcing_x_rad);
  for (int j = 0; j < m.n_lags; ++j) end->b_antiderivative[j] = step_end_b(m, j, x_rad);
}

// Advances every lag state of one coefficient over one step, in place (y has n_lags entries):
//
//   y_j(k+1) = exp(-z_j) y_j(k) + phi1(z_j) (-c_j [A(xf1) - A(xf0)] + con dt time_scale)
//   z_j      = bbar_j dt time_scale,   bbar_j = [B_j(x1) - B_j(x0)] / (x1 - x0)
//
// with A and B_j the antiderivatives of a(x) and b_j(x). Why this form: it is the exact
// solution of y' = -bbar y + f when b is constant (bbar) over the step and the forcing f is
// spread evenly over it. Both integrals over the step are taken in the ANGLE, exactly:
//   * the forcing integral a(x) x' dt = A(x1) - A(x0), whatever the motion between samples,
//     so no rate is ever differentiated;
//   * bbar is the mean of b over the angle swept, (B(x1) - B(x0)) / (x1 - x0); for a motion
//     that is linear in time over the step this is the exact time mean of b, so the decay
//     exponent integral b dt is exact to O(dt^3) even across a knot of b(x), where a
//     trapezoid (b(x0) + b(x1)) / 2 is not (measured at dt = 1 ms on the report's Model II,
//     35 deg / 1 Hz: max error 8.6e-7 with the angle mean, 1.4e-6 and an irregular order with
//     the trapezoid).
// The even spread costs O(dt^3) per step, so the method is second order
// (tests/test_advance_lags.cpp measures it). It is unconditionally stable for b > 0 and
// exact as b dt -> 0 (phi1 -> 1, no 0/0 branch).
//
// The update is split in two per lag so that a batch of instances (the runtime's step_batch)
// can take exp(-z_j) of many instances at once between them: lag_exponent gives z_j,
// lag_update applies the update given z_j and exp(-z_j). advance_lags_between is the two
// with std::exp between, the one sequence every caller runs.
// On a policy: lag j's z from the angles, the antiderivatives B_j at both ends and
// time_scale * dt_s; lag_update_with updates *y in place.
template <class Ops, class Cap>
inline void lag_exponent_with(const CoefficientModel<typename Ops::Scalar, Cap>& m, int j,
                              const typename Ops::V& x0, const typename Ops::V& x1,
                              const typename Ops::V& b_antiderivative_x0,
                              const typename Ops::V& b_antiderivative_x1,
                              const typename Ops::V& time_scale_dt, typename Ops::V* z) {
  typename Ops::V b_mean;
  interval_mean_with<Ops>(m.lags[j].b, x0, x1, b_antiderivative_x0, b_antiderivative_x1, &b_mean);
  *z = b_mean * time_scale_dt;
}

namespace detail {
// The smallest normal number of a state's type: float's for float, double's otherwise (double
// and the fitter's autodiff scalars, whose values are doubles).
template <class S>
struct smallest_normal {
  static constexpr double value = std::numeric_limits<double>::min();
};
template <>
struct smallest_normal<float> {
  static constexpr double value = static_cast<double>(std::numeric_limits<float>::min());
};
}  // namespace detail

// A decaying state below the smallest normal number becomes 0 (+0). Why: a lag (or a vortex
// state, or the separation point where the static f0 is clipped to 0) held still decays
// toward 0 and reaches the subnormal range after ~700 / z steps; with a decay exp(-z) near 1
// it then stays there (a few ulp of the smallest subnormal times 0.997 rounds back to
// itself), and subnormal arithmetic costs x86 ~100 cycles an operation:
// a trial's HIL loop measured the step 120 -> 161 ns median after 400 s of holding an angle
// at 1 kHz, for as long as the hold lasted. The flush changes a state by less than the
// smallest normal (2.2e-308 double, 1.2e-38 float) and is the same operation in the fitter,
// the single step, the batch's lanes and every target (the same bits everywhere).
// Plain floating-point states only: an autodiff state whose value is 0 (a lag of gain 0) still
// carries derivatives the fitter's information matrix needs, and an autodiff value below
// the normal range is never stepped as such (the runtime steps double and float).
template <class Ops>
INDICIAL_HOT_INLINE void flush_below_normal(typename Ops::V* v) {
  using V = typename Ops::V;
  if constexpr (std::is_floating_point<typename Ops::Scalar>::value) {
    const V kept = *v;
    *v = Ops::choose(Ops::abs_less(kept, detail::smallest_normal<typename Ops::Scalar>::value),
                     [] { return V(Ops::constant(typename Ops::Scalar(0))); }, [&kept] { return kept; });
  } else {
    (void)v;
  }
}

template <class Ops, class Cap>
inline void lag_update_with(const CoefficientModel<typename Ops::Scalar, Cap>& m, int j,
                            const typename Ops::V& forcing_integral,
                            const typename Ops::V& time_scale_dt, const typename Ops::V& z,
                            const typename Ops::V& decay, typename Ops::V* y) {
  using V = typename Ops::V;
  V drive = (j == 0) ? V(-forcing_integral) : V(-m.lags[j].gain * forcing_integral);
  if (j == 0) drive = drive + m.con * time_scale_dt;
  V phi;
  phi1_with<Ops>(z, decay, &phi);
  *y = decay * *y + phi * drive;
  flush_below_normal<Ops>(y);
}

template <class Scalar, class Cap>
inline Scalar lag_exponent(const CoefficientModel<Scalar, Cap>& m, const StepGeometry<Scalar>& g,
                           const StepEnd<Scalar, Cap>& end0, const StepEnd<Scalar, Cap>& end1,
                           int j) {
  Scalar z;
  lag_exponent_with<ScalarOps<Scalar>>(m, j, g.x0_rad, g.x1_rad, end0.b_antiderivative[j],
                                       end1.b_antiderivative[j], Scalar(g.time_scale * g.dt_s), &z);
  return z;
}

template <class Scalar, class Cap>
inline void lag_update(const CoefficientModel<Scalar, Cap>& m, const StepGeometry<Scalar>& g,
                       const Scalar& forcing_integral, const Scalar& z, const Scalar& decay, int j,
                       Scalar* y) {
  lag_update_with<ScalarOps<Scalar>>(m, j, forcing_integral, Scalar(g.time_scale * g.dt_s), z,
                                     decay, &y[j]);
}

// Lag j over the step, given both ends: z_j, exp(-z_j), the update of y[j].
template <class Scalar, class Cap>
INDICIAL_HOT_INLINE void advance_lag(const CoefficientModel<Scalar, Cap>& m, const StepGeometry<Scalar>& g,
                                     const StepEnd<Scalar, Cap>& end0, const StepEnd<Scalar, Cap>& end1,
                                     const Scalar& forcing_integral, int j, Scalar* y) {
  const Scalar z = lag_exponent(m, g, end0, end1, j);
  const Scalar decay = detail::step_exp(Scalar(-z));
  lag_update(m, g, forcing_integral, z, decay, j, y);
}

template <class Scalar, class Cap>
INDICIAL_HOT_INLINE void advance_lags_between(const CoefficientModel<Scalar, Cap>& m,
                                 const StepGeometry<Scalar>& g, const StepEnd<Scalar, Cap>& end0,
                                 const StepEnd<Scalar, Cap>& end1, Scalar* y) {
  const Scalar forcing_integral = end1.forcing_antiderivative - end0.forcing_antiderivative;
  for (int j = 0; j < m.n_lags; ++j) advance_lag(m, g, end0, end1, forcing_integral, j, y);
}

// evaluate_step_end at the step's new end (g.x1_rad, g.forcing_x1_rad) into *end1, then
// advance_lags_between, with the two loops over the lags made one (the runtime's step: one
// loop fewer per coefficient). The same numbers, bit for bit. Needs m.n_lags >= 1 (every
// model the runtime accepts: model_check.hpp refuses fewer). Lag 0 is taken before the loop
// where the step's exp is a library call (double), so that a model with one lag per
// coefficient (the report's Models I and II) runs no loop and no j == 0 test: 33 instructions
// fewer per double step (bench_step's callgrind count). Not in float: there the exp is
// exp_on, inlined, and a second copy of it cost the Cortex-M4F 768 bytes of flash and 12
// instructions per step (tools/run-cortex-m.sh). The new end's angles x1_rad and
// forcing_x1_rad are g's, passed apart as references to the caller's variables: the spline
// evaluations take their angle by reference, and taking it from g would keep the whole
// StepGeometry in memory (7 instructions per double step, bench_step's callgrind count).
template <class Scalar>
struct peel_first_lag : std::integral_constant<bool, !std::is_same<Scalar, float>::value> {};

template <class Scalar, class Cap>
INDICIAL_HOT_INLINE void advance_lags_to(const CoefficientModel<Scalar, Cap>& m, const StepGeometry<Scalar>& g,
                                         const Scalar& x1_rad, const Scalar& forcing_x1_rad,
                                         const StepEnd<Scalar, Cap>& end0, StepEnd<Scalar, Cap>* end1,
                                         Scalar* y) {
  end1->forcing_antiderivative = step_end_forcing(m, forcing_x1_rad);
  const Scalar forcing_integral = end1->forcing_antiderivative - end0.forcing_antiderivative;
  int first = 0;
  if (peel_first_lag<Scalar>::value) {
    end1->b_antiderivative[0] = step_end_b(m, 0, x1_rad);
    advance_lag(m, g, end0, *end1, forcing_integral, 0, y);
    first = 1;
  }
  for (int j = first; j < m.n_lags; ++j) {
    end1->b_antiderivative[j] = step_end_b(m, j, x1_rad);
    advance_lag(m, g, end0, *end1, forcing_integral, j, y);
  }
}

// sum + y_0 + ... + y_(n_lags - 1) after advance_lags_to (coefficient_output's sum, in its
// order): lag 0 before the loop where advance_lags_to took it so (same precondition, n_lags
// >= 1), so that the one-lag case tests nothing.
template <class Scalar, class Cap>
INDICIAL_HOT_INLINE Scalar add_stepped_lag_states(const CoefficientModel<Scalar, Cap>& m, Scalar sum,
                                                  const Scalar* y) {
  int first = 0;
  if (peel_first_lag<Scalar>::value) {
    sum = sum + y[0];
    first = 1;
  }
  for (int j = first; j < m.n_lags; ++j) sum = sum + y[j];
  return sum;
}

template <class Scalar, class Cap>
inline void advance_lags(const CoefficientModel<Scalar, Cap>& m, const StepGeometry<Scalar>& g,
                         Scalar* y) {
  StepEnd<Scalar, Cap> end0{}, end1{};
  evaluate_step_end(m, g.x0_rad, g.forcing_x0_rad, &end0);
  evaluate_step_end(m, g.x1_rad, g.forcing_x1_rad, &end1);
  advance_lags_between(m, g, end0, end1, y);
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
//
// Two angles, for a model angle outside the fitted envelope (the runtime's warning 3): x_rad
// is the angle clamped to the envelope, at which every fitted term is evaluated (a polynomial
// static curve, the static correction, the rotary term); table_x_rad is the model angle
// itself, at which a static TABLE is evaluated over its own rows (measured data; beyond its
// first/last row it is held at that row, static_value). Why: a cycle that leaves the training
// cycles' range must see the measured static curve where the angle really is, not frozen at
// the envelope's edge; a polynomial has no range of its own in the model but the envelope it
// was fitted or checked in. Inside the envelope both angles are the same.
// fitted_terms_with is the first part (static + correction + rotary), coefficient_output_with
// adds the lag states to it in order. Why apart: the runtime's step evaluates the fitted terms
// before it advances the lags (independent work, hence the same bits) and adds the new lag
// states while they are still in registers (add_stepped_lag_states; 6 instructions per double
// step, bench_step's callgrind count).
template <class Ops, class Cap>
INDICIAL_HOT_INLINE typename Ops::V fitted_terms_with(const CoefficientModel<typename Ops::Scalar, Cap>& m,
                                                      const typename Ops::V& x_rad,
                                                      const typename Ops::V& table_x_rad,
                                                      const typename Ops::V& rate_radps,
                                                      const typename Ops::V& l_over_v_s) {
  using V = typename Ops::V;
  V curve;
  if (m.static_curve.kind == StaticKind::polynomial) {
    curve = spline_value_with<Ops>(m.static_curve.polynomial, x_rad);
  } else {
    Ops::table_value(m.static_curve, table_x_rad, &curve);
  }
  // Why the test: most models have no static correction, whose value is 0 (curve + 0 is
  // curve); a call to learn that costs the step ~30 instructions per coefficient. (| rather
  // than +: the counts are never negative, and the test is one instruction shorter.)
  if ((m.static_correction.n_powers | m.static_correction.n_knots) != 0)
    curve = curve + spline_value_with<Ops>(m.static_correction, x_rad);
  return curve + l_over_v_s * spline_value_with<Ops>(m.rotary, x_rad) * rate_radps;
}

template <class Ops, class Cap>
INDICIAL_HOT_INLINE typename Ops::V coefficient_output_with(const CoefficientModel<typename Ops::Scalar, Cap>& m,
                                               const typename Ops::V& x_rad,
                                               const typename Ops::V& table_x_rad,
                                               const typename Ops::V& rate_radps,
                                               const typename Ops::V& l_over_v_s,
                                               const typename Ops::V* y) {
  typename Ops::V sum = fitted_terms_with<Ops>(m, x_rad, table_x_rad, rate_radps, l_over_v_s);
  for (int j = 0; j < m.n_lags; ++j) sum = sum + y[j];
  return sum;
}

// Inside the envelope: one angle for every term.
template <class Scalar, class Cap>
INDICIAL_HOT_INLINE Scalar coefficient_output(const CoefficientModel<Scalar, Cap>& m, const Scalar& x_rad,
                                 const Scalar& rate_radps, const Scalar& l_over_v_s,
                                 const Scalar* y) {
  return coefficient_output_with<ScalarOps<Scalar>>(m, x_rad, x_rad, rate_radps, l_over_v_s, y);
}

// Anywhere: x_rad clamped to the envelope, table_x_rad the model angle itself (see above).
template <class Scalar, class Cap>
INDICIAL_HOT_INLINE Scalar coefficient_output(const CoefficientModel<Scalar, Cap>& m, const Scalar& x_rad,
                                 const Scalar& table_x_rad, const Scalar& rate_radps,
                                 const Scalar& l_over_v_s, const Scalar* y) {
  return coefficient_output_with<ScalarOps<Scalar>>(m, x_rad, table_x_rad, rate_radps, l_over_v_s, y);
}

// The quasi-steady part only (static + correction + rotary), for comparisons; the two angles
// as coefficient_output's (table_x_rad defaults to x_rad, inside the envelope).
template <class Scalar, class Cap>
inline Scalar quasi_steady_output(const CoefficientModel<Scalar, Cap>& m, const Scalar& x_rad,
                                  const Scalar& rate_radps, const Scalar& l_over_v_s) {
  return static_value(m.static_curve, x_rad) + spline_value(m.static_correction, x_rad) +
         l_over_v_s * spline_value(m.rotary, x_rad) * rate_radps;
}
template <class Scalar, class Cap>
inline Scalar quasi_steady_output(const CoefficientModel<Scalar, Cap>& m, const Scalar& x_rad,
                                  const Scalar& table_x_rad, const Scalar& rate_radps, const Scalar& l_over_v_s) {
  const Scalar curve = m.static_curve.kind == StaticKind::polynomial ? static_value(m.static_curve, x_rad)
                                                                    : static_value(m.static_curve, table_x_rad);
  return curve + spline_value(m.static_correction, x_rad) + l_over_v_s * spline_value(m.rotary, x_rad) * rate_radps;
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


// ==========================================================================================
// Dynamic stall: equations (issue 22)
// ==========================================================================================
// Two families of states join the report's model of one coefficient, as a DELTA on top of it:
//
//   C(t) = C_a(x) + dC_a(x) + (l/V) C_aq(x) rate + sum_j y_j            (the report's model)
//        + N(x) [ K(f) h(f) - K(f0(x)) h(f0(x)) ]                       (separation family)
//        + C_v,lift (c_v - x_v xi(tau_v))                               (vortex family)
//
// Separation (Goman & Khrabrov 1994; the Kirchhoff output of Leishman & Beddoes 1989):
//   T1 (l/V) f' + f = f0c(x_e)                                          (state f in [0, 1])
//   x_e = x - T2 (l/V) x'  (ForcingLag::delay, the default)  or  T2 (l/V) x_e' + x_e = x
//   (ForcingLag::first_order: a fourth state; see ForcingLag above for the difference)
//   with T1 replaced by T1r while f0c(x_e) > f (the flow reattaching), when T1r > 0: the slow
//   reattachment of the downstroke (Beddoes-Leishman lengthen T_f there too). The right-hand
//   side (f0c - f) / T stays continuous where the two meet (both are 0 at f = f0c). T1r = 0:
//   one time constant both ways (the default). Measured on the Glasgow fit cycles of
//   tools/validate_stall.py (the extended model, the start grid): for C_L T1r fitted to 10.8
//   against T1 = 2.7, the fit error 0.1066 -> 0.1051 and the held-out RMS against the
//   Beddoes-Leishman peer 0.83x -> 0.78x (light stall 1.06x -> 0.87x; a first trial with
//   T1r = 4 T1 held, one start, gave the same); for C_m the fit with T1r ended higher (0.0342
//   against 0.0312) and held-out worse (0.79x against 0.74x). Hence a parameter of its own
//   (model.stall_reattachment = "estimated", diagnose's slow_reattachment), not a fixed ratio.
//   Static hysteresis (dxr > 0; model.stall_hysteresis = "estimated", diagnose's
//   static_hysteresis): the flow that has separated reattaches only at an angle dxr closer to
//   alpha_0 than where it separated, at any rate (a play operator on f, Preisach's simplest):
//     u = f0c(x_e), r = min(u, f0c(x_e + dxr sgn(x_e - alpha_0)))     (r <= u)
//     f > u: T1 (l/V) f' = u - f         (separating, as above)
//     f < r: T1r (l/V) f' = r - f        (reattaching; T1 when T1r = 0)
//     else:  f' = 0                      (held inside the band [r, u])
//   dxr = 0 is the model above exactly (r = u, the band empty). Why: the Glasgow quasi-static
//   cycles (k <= 0.015) read C_L 1.36 on the upstroke and 0.82 on the downstroke at 15 deg,
//   1.24 against 0.95 at 13 deg: a loop that a time lag (T1, T1r) makes only in proportion to
//   the rate. Measured on tools/validate_stall.py's fit and held-out cycles (the extended C_L
//   model, dxr held at 0, 1.5, 3, 5 deg, everything else fitted): fit error 0.1051, 0.1017,
//   0.0993, 0.0998, held-out RMS 0.78x, 0.75x, 0.73x, 0.76x the Beddoes-Leishman peer; the
//   C_m fit rose with it (0.0313 -> 0.0326 at 3 deg), so it is a parameter of its own.
//   Lag limit (D > 0, ForcingLag::delay only; model.stall_lag_limit = "estimated", diagnose's
//   lag_limit): the forcing angle's lag saturates with the rate,
//     x_e = x - D tanh(T2 (l/V) x' / D)          (x - T2 (l/V) x' for |T2 (l/V) x'| << D)
//   so a slow motion is delayed by T2 as before and a fast one by at most D: the onset of
//   separation moves past the static stall angle with the rate, less and less (as Sheng,
//   Galbraith & Coton's stall-onset angle of Glasgow ramp tests levels off with the rate).
//   D = 0: no limit, the delay above exactly. In the step the lag over the step, T2 (x1 - x0)
//   / h, is limited so, the same for x_e0 and x_e1 (tanh(u) = 2 S(2u) - 1 with the logistic S
//   below: no exp overflow, an autodiff derivative everywhere; an absolute error of an ulp of
//   D, nothing in a lag of a degree). Why: on the Glasgow light-stall cycles at k >= 0.1 the
//   delay form separates after the peak where the measurement barely does. Measured on
//   tools/validate_stall.py's fit and held-out cycles (the extended C_L model with dxr, D
//   held at 1.5, 3, 6, 10 deg in a scratch build, and none, everything else fitted): fit error 0.1028, 0.0997,
//   0.0979, 0.0981, 0.0984, held-out RMS 0.75x, 0.72x, 0.71x, 0.73x, 0.74x the
//   Beddoes-Leishman peer (light stall 0.87x, 0.82x, 0.78x, 0.89x, 0.88x): the fit cycles'
//   error is lowest where the held-out error is, so D is a parameter the fit chooses.
//   Estimated (stall_lag_limit = "estimated", 2026-12-01, the same fit cycles): C_L D = 6.35
//   +- 0.19 deg, fit error 0.09793, held out 0.71x (light stall 0.78x). C_m: the fit ended at
//   D = 20 deg (the bound) with error 0.0391 against 0.0313 without D, held out 1.01x: a poor
//   start, which a nested trial from the fit without D (as dxr's) would avoid; not yet built.
//   f0c(x) = clip_[0,1]( f0(x) + df0(x) )      f0: the static table, df0: a fitted spline
//   N(x)   = C_Na (x - alpha_0)                the attached normal force (a line)
//   K(f)   = ((1 + sqrt f) / 2)^2              Kirchhoff's flow factor
//   h(f)   = k0 + k1 (1 - f) + k2 4 f^2 (1 - f^2)    the output's shape: for a lift
//            coefficient k0 ~ 1 (k1, k2 small corrections); for a moment about the quarter
//            chord C_m = C_N x_cp(f), x_cp(f) = k0 + k1 (1 - f) + k2 4 f^2 (1 - f^2), the
//            centre-of-pressure travel of Leishman & Beddoes (their K0, K1, K2). Deviation:
//            their bump sin(pi f^2) is replaced by the polynomial 4 f^2 (1 - f^2), which has
//            the same zeros (f = 0, 1), the same peak (1 at f^2 = 1/2) and differs by < 0.06;
//            k2 is fitted, and a polynomial costs the runtime's step no sin() (issue 22 item 6).
// The output is ZERO at f = f0c(x): at steady state (x' = 0, f -> f0c(x)) the static curve
// C_a(x) stays exact and the report's model is unchanged; the family only adds what the lag of
// the separation point does. Every coefficient carries its own f (identified from its own
// measurement; the C_L and C_m blocks of one model set are fitted apart, as their lags are).
//
// The static separation f0(x) (Kirchhoff inversion, kirchhoff_separation below): from the
// static lift polar C(x) and its attached line N(x) = C_Na (x - alpha_0),
//   f0 = (2 sqrt(C / N) - 1)^2,  with C / N clipped to [1/4, 1] first  (so f0 in [0, 1]):
//   C / N >= 1 (at or above the line: attached) gives 1, C / N <= 1/4 (K(0) = 1/4: the
//   fully separated Kirchhoff lift, or a polar of the other sign than its line) gives 0;
//   |x - alpha_0| below 1e-6 rad (N ~ 0, C / N is 0/0) gives 1: the flow there is attached.
// C_Na and alpha_0 are the least-squares line through the polar's ATTACHED part (the fitter:
// the rows with |x| <= the experiment's attached_max_deg, default 8 deg; docs/formats.md), and
// those rows are f0 = 1 (attached by that assumption: near alpha_0 the inversion only returns
// the polar's noise, f0 moving by about 2 dC / N as N -> 0). The inversion is done once, offline, into the f0 table (rows at the polar's angles); the
// runtime interpolates it LINEARLY (monotone between rows: a table in [0, 1] stays in it; the
// angle is clamped to the first / last row). The fitted correction df0(x) is an ordinary
// Spline; the sum is clipped to [0, 1] (zero derivative where clipped).
//
// Vortex (Beddoes & Leishman, with smooth switches):
//   C_N'   = N(x_e)                    the lagged attached normal force (T2 plays the role of
//                                      Beddoes-Leishman's pressure lag T_p)
//   g      = S((|C_N'| - C_N1) / w)    the SHEDDING CRITERION |C_N'| > C_N1, as a logistic
//                                      switch S(u) = 1 / (1 + e^-u) of width w (C_N units)
//   tau_v' = (V/l) [ g - (1 - g) tau_v / T_r ]   the vortex clock, in semichords: runs while
//                                      the criterion holds, returns to 0 (time T_r) off it
//   C_v    = N(x) (1 - K(f))           attached minus separated circulatory normal force
//   v'     = g s dC_v/dt - (V/l) (2 - s) v / T_v,   s = S((T_vl - tau_v) / w_t)
//            the vortex lift: fed by the growth of C_v while the criterion holds and the
//            vortex is over the chord (tau_v < T_vl), decaying with T_v, twice as fast once
//            it has passed the trailing edge (Leishman & Beddoes' T_v / 2; 2 - s = 1 + S(-u))
//   xi     = 3 r^2 - 2 r^3,  r = clamp(tau_v / T_vl, 0, 1)    (C1-smooth at r = 0 and 1)
//   output: v (c_v - x_v xi(tau_v)); for the lift c_v ~ 1, x_v = 0; for the moment about the
//           quarter chord c_v ~ 0 and x_v ~ 0.4: the moment break as the vortex convects aft.
//           Deviation: Beddoes-Leishman's x_cp,v = 0.2 (1 - cos(pi r)) is x_v (1 - cos(pi r))
//           / 2 with x_v = 0.4; the smoothstep 3 r^2 - 2 r^3 has the same ends, slopes 0 at
//           both, the same midpoint, differs by < 0.01, and costs no cos().
// Why smooth switches rather than the Beddoes-Leishman state machine (a clock reset, a feed
// cut-off, a decay doubled by if's): the fitter identifies C_N1, T_v and T_vl by output error
// (Levenberg-Marquardt with autodiff sensitivities); a discrete switch gives a piecewise-
// constant cost in C_N1 and T_vl with zero derivative almost everywhere. The widths w, w_t and
// the reset time T_r are structure (plain double, not fitted; defaults 0.05, 0.5 and 1.0,
// written in the coefficient file). As w, w_t, T_r -> 0 the equations become the state
// machine's. At steady state v -> 0 (C_v is constant), so the static curve stays exact.
//
// Units and time scaling. T1, T2, T_v, T_vl, T_r, w_t are DIMENSIONLESS, in semichord times
// l / V (l = the model set's reference_length_m, c / 2 in pitch; V the CURRENT airspeed): a
// cycle at reduced frequency k = omega l / V is the same curve at every airspeed. The step
// works in h = dt V / l = dt_s / l_over_v_s (AirspeedScaling::l_over_v_s). x' is taken as the
// angle's slope over the step, (x1 - x0) / dt (the angle is piecewise linear in time between
// samples, as everywhere in this model), so no rate input is needed and the lag of the forcing
// angle over the step is T2 (x1 - x0) / h.
//
// The discrete update (advance_stall), order 2, explicit, in this sequence:
//   f:     EXACT for a forcing u = f0c(x_e) linear in time over the step (u0, u1 at its ends,
//          x_e = x - T2 (x1 - x0) / h, or with first_order x_e0 the state and x_e1 its exact
//          update for x linear over the step, stall_lagged_angles):
//          f1 = e f0 + (phi1(z) - e) u0 + (1 - phi1(z)) u1,
//          z = h / T1, e = exp(-z). The three weights are >= 0 and sum to 1: f1 is a convex
//          combination of f0, u0, u1 and stays in [0, 1] without clipping. With T1r > 0, z =
//          h / T1r when (u0 + u1) / 2 > f0 (reattaching over the step, decided at its start:
//          an O(h^2) local error at the step where the two meet, where f' is near 0 anyway).
//          With dxr > 0, when reattaching so decided: the same update toward r0, r1 (the
//          reattachment targets at x_e0, x_e1) when (r0 + r1) / 2 > f0, else f1 = f0 (held).
//   tau_v: exponential integrator with the shedding switch at the step's midpoint (g at the
//          mean lagged angle, (x_e0 + x_e1) / 2: the midpoint rule):
//          z_c = h (1 - g) / T_r, tau1 = exp(-z_c) tau0 + phi1(z_c) h g.
//   v:     as advance_lags: v1 = exp(-z_v) v0 + phi1(z_v) G (C_v(x1, f1) - C_v(x0, f0)),
//          the feed integral taken exactly as the difference of C_v, the feed gate
//          G = g s and the decay z_v = h (2 - s) / T_v at the mid clock (tau0 + tau1) / 2,
//          s = S((T_vl - tau_mid) / w_t) (1 + S(-u) = 2 - S(u): one exponential).
//   The decays exp(-z) above (f's e, the clock's exp(-z_c), the vortex's exp(-z_v)) and
//          their phi1(z) are decay_weights(z): for z <= 1/4 (a real-time step) exp's Taylor
//          polynomial, exp(-z) = 1 - z phi1(z), within 1 ulp of the exact exp(-z) (glibc's exp:
//          0.51 ulp) and phi1 from the same polynomial (no division, no 1 - exp(-z)
//          cancellation); above, exp itself and (1 - exp(-z)) / z. Deviation from exp's bits
//          (issue 22 item 6), not from the equations: about an ulp per step. The switches
//          S(u) keep exp (their u is not small).
//   Operation forms (issue 22 item 6: the vortex update is one dependent chain per coefficient,
//          angle -> g -> tau1 -> s -> v1, and a step waits for it): a division by a parameter
//          or a structural constant is a multiplication by its reciprocal or quotient computed
//          from the parameter and h alone, which the processor computes beside the chain:
//          the lag (x1 - x0) (T2 / h), the switches' arguments (|C_N'| - C_N1) (1 / w) and
//          (T_vl - tau) (1 / w_t), the decays z_c = (h / T_r) (1 - g) and z_v = (h / T_v) (2 -
//          s); the updates' last products group the chain's value last: phi1(z_c) (h g),
//          phi1(z_v) (G dC_v). Each rounds differently from the quotient written above (within
//          an ulp of it).
// Local error O(h^3) (the forcing's curvature over the step, the midpoint gates), so global
// order 2 (tests/test_stall_model.cpp measures it against Boost.Odeint of stall_derivatives).
// Cost: 5 exponentials (2 exp calls, 3 decay_weights polynomials; first_order a 6th, its
// filter's) and 4 sqrt per coefficient and step (update and output); no sin / cos.
// Non-smooth points: the clipping of f0c, |C_N'| at C_N' = 0, the clamp in xi (C1 there) and
// sqrt f at f = 0 (K is evaluated with sqrt f := 0 for f <= 0, so an autodiff type gets a
// finite derivative there).
//
// State: StallState, four Scalars per coefficient (f, v, tau_v and the forcing angle x_e, used
// with ForcingLag::first_order only). reset: stall_steady_state (f = f0c(x), v = 0, tau_v = 0,
// x_e = x). Feasible set (check_stall_parameters): T1 > 0, T2 >= 0, T1r >= 0,
// T_v > 0, T_vl > 0, C_N1 > 0, the widths and T_r > 0, an f0 table of >= 2 strictly
// increasing rows with values in [0, 1], everything finite.
// The coefficient-file keys and fitter names are in the parameter structs' tables above.
template <class Scalar>
struct StallState {
  Scalar separation_point = Scalar(1);         // f, in [0, 1] (1 attached, 0 separated)
  Scalar vortex_lift = Scalar(0);              // v = C_N,v, dimensionless normal force
  Scalar vortex_clock_semichords = Scalar(0);  // tau_v, in l / V
  // x_e, rad, with ForcingLag::first_order (the filtered forcing angle); delay computes x_e from
  // the step and leaves this at the reset angle. Costs FamilyState<double, DefaultCapacity> 24
  // bytes (runtime.hpp: 256 bytes in all).
  Scalar forcing_angle_rad = Scalar(0);
};

// The two outputs apart (diagnose's signatures, plots); stall_output is their sum.
template <class Scalar>
struct StallOutput {
  Scalar separation = Scalar(0);
  Scalar vortex = Scalar(0);
};

namespace detail {
// S(u) = 1 / (1 + exp(-u)), written so that exp never overflows (no inf / inf, and an autodiff
// type gets a finite derivative for every finite u).
// Beyond saturates_above<Scalar>, 1 + exp(-u) rounds to 1 (exp(-u) < half an ulp of 1), so S(u)
// IS 1 and a plain floating-point type skips the exp (same bits; issue 22 item 6: the shedding
// switch sits there for whole stretches of a stall cycle). An autodiff type keeps the exp
// (its derivative there is tiny but not 0).
template <class Scalar>
struct saturates_above { static constexpr double value = 37.0; };  // e^-37 < 2^-53
template <>
struct saturates_above<float> { static constexpr double value = 17.0; };  // e^-17 < 2^-24
template <class Scalar>
inline Scalar logistic(const Scalar& u) {
  if (std::is_floating_point<Scalar>::value && u >= Scalar(saturates_above<Scalar>::value))
    return Scalar(1);
  if (u >= Scalar(0)) return Scalar(1) / (Scalar(1) + step_exp(Scalar(-u)));
  const Scalar e = step_exp(u);
  return e / (Scalar(1) + e);
}
// sqrt f for f > 0, 0 otherwise (see the essay: finite derivative at f = 0).
template <class Scalar>
inline Scalar sqrt_nonnegative(const Scalar& f) {
  using std::sqrt;
  if (f > Scalar(0)) return sqrt(f);
  return Scalar(0);
}
template <class Scalar>
inline Scalar clip_unit(const Scalar& f) {
  if (f < Scalar(0)) return Scalar(0);
  if (f > Scalar(1)) return Scalar(1);
  return f;
}
template <class Scalar>
inline Scalar abs_value(const Scalar& v) {
  if (v < Scalar(0)) return -v;
  return v;
}
}  // namespace detail

// K(f) = ((1 + sqrt f) / 2)^2.
template <class Scalar>
inline Scalar kirchhoff_factor(const Scalar& f) {
  const Scalar r = (Scalar(1) + detail::sqrt_nonnegative(f)) * Scalar(0.5);
  return r * r;
}

// The Kirchhoff inversion of one static-polar row (offline; see the essay): f0 in [0, 1].
inline double kirchhoff_separation(double coefficient, double normal_force_slope_per_rad,
                                   double alpha_rad, double zero_lift_angle_rad) {
  const double da = alpha_rad - zero_lift_angle_rad;
  const double n = normal_force_slope_per_rad * da;
  if (std::abs(da) < 1e-6 || !(std::abs(n) > 0.0)) return 1.0;
  double ratio = coefficient / n;
  ratio = ratio < 0.25 ? 0.25 : (ratio > 1.0 ? 1.0 : ratio);
  const double s = 2.0 * std::sqrt(ratio) - 1.0;
  return s * s;
}

// The static separation table f0(x), linear between rows, clamped at the ends; *row: the row
// that brackets x (-1 if clamped). Tried first: `hint`, a row that brackets a nearby angle
// (-1: none). Why: a step looks the table up at both ends of its lagged interval, which lie
// x1 - x0 apart, in the same row as a rule (stall_table_lookups); two comparisons confirm it
// instead of table_row's search. The bracketing row is unique (table_row), so the value is the
// same bits however the row is found.
template <class Scalar, class Cap>
INDICIAL_HOT_INLINE Scalar separation_table_value_near(const SeparationParameters<Scalar, Cap>& p, const Scalar& x,
                                                       int hint, int* row) {
  const int n = p.n_f0;
  *row = -1;
  if (n < 1) return Scalar(1);
  if (!(x > Scalar(p.f0_x_rad[0]))) return p.f0_value[0];
  if (!(x < Scalar(p.f0_x_rad[n - 1]))) return p.f0_value[n - 1];
  const int lo = hint >= 0 && !(x < Scalar(p.f0_x_rad[hint])) && x < Scalar(p.f0_x_rad[hint + 1])
                     ? hint
                     : detail::table_row(p.f0_x_rad, n, x);
  *row = lo;
  const int hi = lo + 1;
  const Scalar w = (x - Scalar(p.f0_x_rad[lo])) / Scalar(p.f0_x_rad[hi] - p.f0_x_rad[lo]);
  return (Scalar(1) - w) * p.f0_value[lo] + w * p.f0_value[hi];
}

// The static separation table f0(x), linear between rows, clamped at the ends.
template <class Scalar, class Cap>
inline Scalar separation_table_value(const SeparationParameters<Scalar, Cap>& p, const Scalar& x) {
  int row;
  return separation_table_value_near(p, x, -1, &row);
}

// f0c(x) = clip_[0,1](f0(x) + df0(x)), given the table's value f0(x) (a runtime whose
// coefficients share the table looks it up once: StallLookups below).
template <class Scalar, class Cap>
INDICIAL_HOT_INLINE Scalar static_separation_from_table(const SeparationParameters<Scalar, Cap>& p, const Scalar& x,
                                           const Scalar& table_value) {
  // (No call for an empty correction, as coefficient_output's static correction.)
  if (p.f0_correction.n_powers + p.f0_correction.n_knots == 0) return detail::clip_unit(table_value);
  return detail::clip_unit(Scalar(table_value + spline_value(p.f0_correction, x)));
}

// f0c(x) = clip_[0,1](f0(x) + df0(x)).
template <class Scalar, class Cap>
inline Scalar static_separation(const SeparationParameters<Scalar, Cap>& p, const Scalar& x) {
  return static_separation_from_table(p, x, Scalar(separation_table_value(p, x)));
}

// N(x) = C_Na (x - alpha_0).
template <class Scalar, class Cap>
inline Scalar attached_normal_force(const SeparationParameters<Scalar, Cap>& p, const Scalar& x) {
  return p.normal_force_slope_per_rad * (x - p.zero_lift_angle_rad);
}

// K(f) h(f), the separation output per unit N, given K(f) (a step computes K(f1) once for
// the vortex feed and this output).
template <class Scalar, class Cap>
INDICIAL_HOT_INLINE Scalar separation_shape_from_factor(const SeparationParameters<Scalar, Cap>& p, const Scalar& f,
                                                        const Scalar& kirchhoff) {
  const Scalar f2 = f * f;
  const Scalar h = p.cp_k0 + p.cp_k1 * (Scalar(1) - f) + p.cp_k2 * Scalar(4) * f2 * (Scalar(1) - f2);
  return kirchhoff * h;
}

// K(f) h(f), the separation output per unit N.
template <class Scalar, class Cap>
inline Scalar separation_shape(const SeparationParameters<Scalar, Cap>& p, const Scalar& f) {
  return separation_shape_from_factor(p, f, kirchhoff_factor(f));
}

// g = S((|C_N'| - C_N1) / w) at the lagged angle x_e.
template <class Scalar, class Cap>
inline Scalar shedding_switch(const StallModel<Scalar, Cap>& m, const Scalar& lagged_x_rad) {
  const Scalar cn = attached_normal_force(m.separation, lagged_x_rad);
  const Scalar per_width = Scalar(1) / Scalar(m.vortex.shedding_width);  // off the angle's chain
  return detail::logistic(Scalar((detail::abs_value(cn) - m.vortex.shedding_threshold) * per_width));
}

// The feed gate s = S((T_vl - tau_v) / w_t); the decay factor is 1 + S(-u) = 2 - s.
template <class Scalar>
inline Scalar vortex_on_chord(const VortexParameters<Scalar>& p, const Scalar& clock) {
  const Scalar per_width = Scalar(1) / Scalar(p.clock_width_semichords);  // off the clock's chain
  return detail::logistic(Scalar((p.travel_semichords - clock) * per_width));
}

// xi(tau_v) = 3 r^2 - 2 r^3, r = clamp(tau_v / T_vl, 0, 1).
template <class Scalar>
inline Scalar vortex_position(const VortexParameters<Scalar>& p, const Scalar& clock) {
  Scalar r = clock / p.travel_semichords;
  if (r > Scalar(1)) r = Scalar(1);
  if (r < Scalar(0)) r = Scalar(0);
  return r * r * (Scalar(3) - Scalar(2) * r);
}

// C_v = N(x) (1 - K(f)), given K(f).
template <class Scalar, class Cap>
INDICIAL_HOT_INLINE Scalar vortex_feed_from_factor(const SeparationParameters<Scalar, Cap>& p, const Scalar& x,
                                                   const Scalar& kirchhoff) {
  return attached_normal_force(p, x) * (Scalar(1) - kirchhoff);
}

// C_v = N(x) (1 - K(f)).
template <class Scalar, class Cap>
inline Scalar vortex_feed(const SeparationParameters<Scalar, Cap>& p, const Scalar& x,
                          const Scalar& f) {
  return vortex_feed_from_factor(p, x, kirchhoff_factor(f));
}

// The steady state at angle x (reset): f = f0c(x), no vortex, clock at 0.
template <class Scalar, class Cap>
inline void stall_steady_state(const StallModel<Scalar, Cap>& m, const Scalar& x_rad,
                               StallState<Scalar>* s) {
  s->separation_point = static_separation(m.separation, x_rad);
  s->vortex_lift = Scalar(0);
  s->vortex_clock_semichords = Scalar(0);
  s->forcing_angle_rad = x_rad;
}

// One step of the stall states. l_over_v_s = l / V at the step's airspeed (airspeed_scaling).
template <class Scalar>
struct StallStep {
  Scalar x0_rad;
  Scalar x1_rad;
  Scalar dt_s;        // > 0 (the runtime checks it before stepping)
  Scalar l_over_v_s;  // > 0
};

// What one step of a coefficient's families looks up in its f0 table and exponentiates, apart
// from the update that uses it, so that a runtime whose coefficients share a table, T2 or T1
// computes each once per step (runtime.hpp's StallSharing; issue 22 item 6: the lookups and
// exps are most of the families' cost). advance_stall computes them itself: the same
// operations in the same order either way, hence the same bits.
//   h                 the step in semichords, dt V / l
//   x_e0, x_e1        the lagged angles x - T2 (x1 - x0) / h at the step's ends
//   table_e0, _e1     the table's f0 at x_e0, x_e1 (before the correction and the clip)
//   decay, weight     exp(-h / T1) and phi1(h / T1)
template <class Scalar>
struct StallLookups {
  Scalar lagged_x0_rad;
  Scalar lagged_x1_rad;
  Scalar table_e0;
  Scalar table_e1;
  Scalar decay;
  Scalar weight;
};

template <class Scalar>
inline Scalar stall_step_semichords(const StallStep<Scalar>& g) {
  return g.dt_s / g.l_over_v_s;
}

// x_e0 and x_e1 into *k: with ForcingLag::delay they depend on T2 and the step only; with
// first_order x_e0 is the state's forcing angle (*forcing, the StallState's forcing_angle_rad)
// and x_e1 its exact update for an angle linear in time over the step (as f's: x_e1 = e x_e0 +
// (phi1(z) - e) x0 + (1 - phi1(z)) x1, z = h / T2, a convex combination), T2 = 0 the angle
// itself; x_e1 is written back to *forcing (delay leaves it alone). A step refused after this
// restores it with the other family states (the runtime's FamilyBackup).
template <class Scalar>
struct FilteredAngles {
  Scalar x0_rad;  // x_e at the step's start and end
  Scalar x1_rad;
};

// first_order's x_e0, x_e1 from the state's x_e0 (stall_lagged_angles). Why out of line and
// by value: inlined into the runtime's flattened step, or given pointers into the step's
// lookups, this branch that a delay model never takes cost its stall step about 50
// instructions (callgrind, state/stall2/double 1974 -> 2024-2040: the lookups kept in memory
// and values spilled around the exp); a call costs a first_order step a few.
template <class Scalar, class Cap>
INDICIAL_NOINLINE FilteredAngles<Scalar> stall_filtered_angles(const SeparationParameters<Scalar, Cap>& p,
                                                               Scalar x0_rad, Scalar x1_rad, Scalar h,
                                                               Scalar forcing0_rad) {
  if (!(p.tau2_semichords > Scalar(0))) return {x0_rad, x1_rad};
  const Scalar z = h / p.tau2_semichords;
  const DecayWeights<Scalar> d = decay_weights(z);
  const Scalar e = d.decay, w = d.weight;
  return {forcing0_rad, Scalar(e * forcing0_rad + (w - e) * x0_rad + (Scalar(1) - w) * x1_rad)};
}

// The forcing angle's lag x - x_e, T2 (l/V) x' (lag_rad), limited to D = lag_limit_rad:
// D tanh(lag_rad / D); lag_rad itself when D = 0 (the essay's lag limit). Taken on |lag_rad|
// and signed after, so that an upstroke and a downstroke at opposite rates get opposite lags
// to the bit (the logistic's two branches round differently).
template <class Scalar, class Cap>
inline Scalar limited_lag(const SeparationParameters<Scalar, Cap>& p, const Scalar& lag_rad) {
  if (!(p.lag_limit_rad > Scalar(0))) return lag_rad;
  const Scalar d = p.lag_limit_rad;
  const bool negative = lag_rad < Scalar(0);
  const Scalar magnitude = negative ? Scalar(-lag_rad) : lag_rad;
  const Scalar limited = d * (Scalar(2) * detail::logistic(Scalar(Scalar(2) * magnitude / d)) - Scalar(1));
  return negative ? Scalar(-limited) : limited;
}

template <class Scalar, class Cap>
inline void stall_lagged_angles(const SeparationParameters<Scalar, Cap>& p, const StallStep<Scalar>& g,
                                const Scalar& h, Scalar* forcing, StallLookups<Scalar>* k) {
  if (p.forcing_lag == ForcingLag::first_order) {
    const FilteredAngles<Scalar> a = stall_filtered_angles(p, g.x0_rad, g.x1_rad, h, *forcing);
    k->lagged_x0_rad = a.x0_rad;
    k->lagged_x1_rad = a.x1_rad;
    *forcing = a.x1_rad;
    return;
  }
  Scalar lag = (g.x1_rad - g.x0_rad) * (p.tau2_semichords / h);
  if (p.lag_limit_rad > Scalar(0)) lag = limited_lag(p, lag);
  k->lagged_x0_rad = g.x0_rad - lag;
  k->lagged_x1_rad = g.x1_rad - lag;
}

// The table's values at the lagged angles (stall_lagged_angles first).
// (x_e1's row is searched from x_e0's: separation_table_value_near.)
template <class Scalar, class Cap>
inline void stall_table_lookups(const SeparationParameters<Scalar, Cap>& p, StallLookups<Scalar>* k) {
  int row = -1;
  k->table_e0 = separation_table_value_near(p, k->lagged_x0_rad, -1, &row);
  k->table_e1 = separation_table_value_near(p, k->lagged_x1_rad, row, &row);
}

// exp(-h / T1) and phi1(h / T1) (T1 and the step only).
template <class Scalar, class Cap>
INDICIAL_HOT_INLINE void stall_decay(const SeparationParameters<Scalar, Cap>& p, const Scalar& h,
                        StallLookups<Scalar>* k) {
  const Scalar z = h / p.tau1_semichords;
  const DecayWeights<Scalar> d = decay_weights(z);
  k->decay = d.decay;
  k->weight = d.weight;
}

// The update of one step in stages (advance_stall_with runs them in order), so that a runtime
// stepping several coefficients can interleave them: each stage's exp waits for the previous
// stage's, and those waits are most of a step's time (the chain gate -> clock -> feed gate ->
// vortex decay is four exps long per coefficient); two coefficients' chains issued side by
// side overlap (runtime.hpp's advance_families). The same operations on the same values in
// either order, hence the same bits. StallProgress carries what a later stage needs.
template <class Scalar>
struct StallProgress {
  Scalar f0;         // the separation point before the step
  Scalar kirchhoff0; // K(f0), K(f1): vortex_feed's (and stall_output's K(f1))
  Scalar kirchhoff1;
  Scalar gate;       // the shedding switch g at the step's midpoint
  Scalar clock0;     // tau_v before the step
  Scalar on_chord;   // the feed gate's s at the mid clock
};

// The reattachment target r(x) = min(u, f0c(x + dxr sgn(x - alpha_0))), u = f0c(x) (the
// essay's static hysteresis).
template <class Scalar, class Cap>
inline Scalar reattachment_target(const SeparationParameters<Scalar, Cap>& p, const Scalar& x_rad,
                                  const Scalar& u) {
  const Scalar side = x_rad - p.zero_lift_angle_rad;
  const Scalar shifted = side > Scalar(0)   ? Scalar(x_rad + p.reattach_shift_rad)
                         : side < Scalar(0) ? Scalar(x_rad - p.reattach_shift_rad)
                                            : x_rad;
  const Scalar r = static_separation(p, shifted);
  return r < u ? r : u;
}

// Stage 1 with the static hysteresis (dxr > 0): as stall_separation_stage, but a step that
// reattaches (u0 + u1 > 2 f0) goes toward the reattachment targets r0, r1 (T1r, or T1) when
// their mean is above f0, else f holds (f1 = f0). Inlined, unlike stall_filtered_angles: a
// call here (any call: every xmm register is caller-saved) cost the runtime's flattened step
// of a model WITHOUT hysteresis 40-45 instructions of spills (callgrind, state/stall2/double
// 1952 -> 1995, with the branch to it at the stage's start or inside its reattaching branch);
// inlined it costs that step nothing measurable (1952) and a model with it 2006
// (state/stall2h/double; 2082 with the call).
template <class Scalar, class Cap>
INDICIAL_HOT_INLINE void stall_separation_stage_hysteresis(const SeparationParameters<Scalar, Cap>& p, Scalar h,
                                                         const StallLookups<Scalar>& k, StallState<Scalar>* s) {
  const Scalar u0 = static_separation_from_table(p, k.lagged_x0_rad, k.table_e0);
  const Scalar u1 = static_separation_from_table(p, k.lagged_x1_rad, k.table_e1);
  const Scalar f0 = s->separation_point;
  Scalar t0 = u0, t1 = u1, e = k.decay, w = k.weight;
  if (u0 + u1 > f0 + f0) {  // reattaching, or held
    t0 = reattachment_target(p, k.lagged_x0_rad, u0);
    t1 = reattachment_target(p, k.lagged_x1_rad, u1);
    if (!(t0 + t1 > f0 + f0)) return;  // held: f1 = f0
    if (p.tau1_reattach_semichords > Scalar(0)) {
      const DecayWeights<Scalar> d = decay_weights(Scalar(h / p.tau1_reattach_semichords));
      e = d.decay;
      w = d.weight;
    }
  }
  s->separation_point = e * f0 + (w - e) * t0 + (Scalar(1) - w) * t1;
  flush_below_normal<ScalarOps<Scalar>>(&s->separation_point);
}

// Stage 1: f over the step (T1, or T1r while reattaching; held inside the hysteresis band);
// f1 into s.
template <class Scalar, class Cap>
INDICIAL_HOT_INLINE void stall_separation_stage(const StallModel<Scalar, Cap>& m, const Scalar& h,
                                                const StallLookups<Scalar>& k, StallState<Scalar>* s,
                                                StallProgress<Scalar>* q) {
  const SeparationParameters<Scalar, Cap>& p = m.separation;
  q->f0 = s->separation_point;
  if (p.reattach_shift_rad > Scalar(0)) return stall_separation_stage_hysteresis(p, h, k, s);
  const Scalar u0 = static_separation_from_table(p, k.lagged_x0_rad, k.table_e0);
  const Scalar u1 = static_separation_from_table(p, k.lagged_x1_rad, k.table_e1);
  Scalar e = k.decay;
  Scalar w = k.weight;
  const Scalar f0 = s->separation_point;
  if (p.tau1_reattach_semichords > Scalar(0) && u0 + u1 > f0 + f0) {  // reattaching: T1r
    const Scalar z = h / p.tau1_reattach_semichords;
    const DecayWeights<Scalar> d = decay_weights(z);
    e = d.decay;
    w = d.weight;
  }
  s->separation_point = e * f0 + (w - e) * u0 + (Scalar(1) - w) * u1;
  // Decays as e^k f0 where the static f0 is clipped to 0 (deep stall held).
  flush_below_normal<ScalarOps<Scalar>>(&s->separation_point);
}

// Stage 2 (vortex): the shedding switch g at the mean lagged angle.
template <class Scalar, class Cap>
INDICIAL_HOT_INLINE void stall_shedding_stage(const StallModel<Scalar, Cap>& m, const StallLookups<Scalar>& k,
                                              StallProgress<Scalar>* q) {
  q->gate = shedding_switch(m, Scalar((k.lagged_x0_rad + k.lagged_x1_rad) * Scalar(0.5)));
}

// Stage 3 (vortex): the clock tau_v over the step; tau1 into s.
template <class Scalar, class Cap>
INDICIAL_HOT_INLINE void stall_clock_stage(const StallModel<Scalar, Cap>& m, const Scalar& h,
                                           StallState<Scalar>* s, StallProgress<Scalar>* q) {
  const Scalar gate = q->gate;
  const Scalar clock0 = s->vortex_clock_semichords;
  const Scalar zc = h / Scalar(m.vortex.clock_reset_semichords) * (Scalar(1) - gate);
  // Why the branch: while the shedding switch is saturated (gate == 1) zc is 0 and e^-0 is 1
  // exactly; a plain floating-point type skips the exp (same bits), an autodiff type keeps it.
  const DecayWeights<Scalar> d = std::is_floating_point<Scalar>::value && zc == Scalar(0)
                                     ? DecayWeights<Scalar>{Scalar(1), Scalar(1)}
                                     : decay_weights(zc);
  q->clock0 = clock0;
  s->vortex_clock_semichords = d.decay * clock0 + d.weight * (h * gate);
  flush_below_normal<ScalarOps<Scalar>>(&s->vortex_clock_semichords);
}

// Stage 4 (vortex): the feed gate s at the mid clock.
template <class Scalar, class Cap>
INDICIAL_HOT_INLINE void stall_feed_gate_stage(const StallModel<Scalar, Cap>& m, const StallState<Scalar>& s,
                                               StallProgress<Scalar>* q) {
  q->on_chord = vortex_on_chord(m.vortex, Scalar((q->clock0 + s.vortex_clock_semichords) * Scalar(0.5)));
}

// Stage 5 (vortex): v over the step (the Kirchhoff factors K(f0), K(f1) into q first:
// stall_kirchhoff_stage); v1 into s.
template <class Scalar, class Cap>
INDICIAL_HOT_INLINE void stall_vortex_stage(const StallModel<Scalar, Cap>& m, const StallStep<Scalar>& g,
                                            const Scalar& h, StallState<Scalar>* s,
                                            const StallProgress<Scalar>& q) {
  const Scalar feed_gate = q.gate * q.on_chord;
  const Scalar zv = h / m.vortex.decay_semichords * (Scalar(2) - q.on_chord);
  const DecayWeights<Scalar> d = decay_weights(zv);
  const SeparationParameters<Scalar, Cap>& p = m.separation;
  const Scalar feed = vortex_feed_from_factor(p, g.x1_rad, q.kirchhoff1) -
                      vortex_feed_from_factor(p, g.x0_rad, q.kirchhoff0);
  s->vortex_lift = d.decay * s->vortex_lift + d.weight * (feed_gate * feed);
  flush_below_normal<ScalarOps<Scalar>>(&s->vortex_lift);
}

// K(f0) and K(f1) into q (stall_separation_stage first): vortex_feed's factors.
template <class Scalar>
INDICIAL_HOT_INLINE void stall_kirchhoff_stage(const StallState<Scalar>& s, StallProgress<Scalar>* q) {
  q->kirchhoff0 = kirchhoff_factor(q->f0);
  q->kirchhoff1 = kirchhoff_factor(s.separation_point);
}

// Advances f, tau_v and v over one step, in place, with the step's lookups k (see the essay
// and StallLookups): the stages above in order. families == none: nothing.
template <class Scalar, class Cap>
INDICIAL_HOT_INLINE void advance_stall_with(const StallModel<Scalar, Cap>& m, const StallStep<Scalar>& g,
                               const Scalar& h, const StallLookups<Scalar>& k, StallState<Scalar>* s) {
  if (m.families == StallFamilies::none) return;
  StallProgress<Scalar> q;
  stall_separation_stage(m, h, k, s, &q);
  if (m.families != StallFamilies::separation_and_vortex) return;
  stall_shedding_stage(m, k, &q);
  stall_clock_stage(m, h, s, &q);
  stall_feed_gate_stage(m, *s, &q);
  stall_kirchhoff_stage(*s, &q);
  stall_vortex_stage(m, g, h, s, q);
}

// Advances f, tau_v and v over one step, in place (see the essay). families == none: nothing.
template <class Scalar, class Cap>
inline void advance_stall(const StallModel<Scalar, Cap>& m, const StallStep<Scalar>& g,
                          StallState<Scalar>* s) {
  if (m.families == StallFamilies::none) return;
  const Scalar h = stall_step_semichords(g);
  StallLookups<Scalar> k;
  stall_lagged_angles(m.separation, g, h, &s->forcing_angle_rad, &k);
  stall_table_lookups(m.separation, &k);
  stall_decay(m.separation, h, &k);
  advance_stall_with(m, g, h, k, s);
}

// The outputs at angle x with state s, apart (a delta on top of the report's model), given
// the static separation f0c(x) at x_rad, its Kirchhoff factor K(f0c(x)) (a runtime whose
// coefficients share the separation update computes them once: runtime.hpp's
// advance_families) and K(f) of the state's f (a step has it from its vortex update:
// StallProgress).
template <class Scalar, class Cap>
INDICIAL_HOT_INLINE StallOutput<Scalar> stall_output_parts_from_static(const StallModel<Scalar, Cap>& m, const Scalar& x_rad,
                                                                       const Scalar& f_static,
                                                                       const Scalar& kirchhoff_static,
                                                                       const Scalar& kirchhoff,
                                                                       const StallState<Scalar>& s) {
  StallOutput<Scalar> o;
  if (m.families == StallFamilies::none) return o;
  const SeparationParameters<Scalar, Cap>& p = m.separation;
  o.separation = attached_normal_force(p, x_rad) * (separation_shape_from_factor(p, s.separation_point, kirchhoff) -
                                                    separation_shape_from_factor(p, f_static, kirchhoff_static));
  if (m.families != StallFamilies::separation_and_vortex) return o;
  o.vortex = s.vortex_lift * (m.vortex.lift_gain -
                              m.vortex.cp_travel * vortex_position(m.vortex, s.vortex_clock_semichords));
  return o;
}

// The same given the f0 table's value at x_rad (a runtime whose coefficients share the table:
// StallLookups) instead of f0c(x) and its K.
template <class Scalar, class Cap>
INDICIAL_HOT_INLINE StallOutput<Scalar> stall_output_parts_from_factor(const StallModel<Scalar, Cap>& m, const Scalar& x_rad,
                                                          const Scalar& table_value, const Scalar& kirchhoff,
                                                          const StallState<Scalar>& s) {
  if (m.families == StallFamilies::none) return StallOutput<Scalar>{};
  const Scalar f_static = static_separation_from_table(m.separation, x_rad, table_value);
  return stall_output_parts_from_static(m, x_rad, f_static, kirchhoff_factor(f_static), kirchhoff, s);
}

// The outputs at angle x with state s, apart, given the f0 table's value at x_rad.
template <class Scalar, class Cap>
INDICIAL_HOT_INLINE StallOutput<Scalar> stall_output_parts_from_table(const StallModel<Scalar, Cap>& m, const Scalar& x_rad,
                                                         const Scalar& table_value,
                                                         const StallState<Scalar>& s) {
  if (m.families == StallFamilies::none) return StallOutput<Scalar>{};
  return stall_output_parts_from_factor(m, x_rad, table_value, kirchhoff_factor(s.separation_point), s);
}

// The outputs at angle x with state s, apart.
template <class Scalar, class Cap>
inline StallOutput<Scalar> stall_output_parts(const StallModel<Scalar, Cap>& m, const Scalar& x_rad,
                                              const StallState<Scalar>& s) {
  if (m.families == StallFamilies::none) return StallOutput<Scalar>{};
  return stall_output_parts_from_table(m, x_rad, Scalar(separation_table_value(m.separation, x_rad)), s);
}

template <class Scalar, class Cap>
inline Scalar stall_output(const StallModel<Scalar, Cap>& m, const Scalar& x_rad,
                           const StallState<Scalar>& s) {
  const StallOutput<Scalar> o = stall_output_parts(m, x_rad, s);
  return o.separation + o.vortex;
}

// The continuous-time right-hand side, for reference integrators and tests only: d/dt of
// (f, v, tau_v) given the angle, its rate and l / V. Meant for f > 0 (K'(f) is infinite at 0;
// there it is taken as 0).
template <class Scalar, class Cap>
inline void stall_derivatives(const StallModel<Scalar, Cap>& m, const Scalar& x_rad,
                              const Scalar& xdot_radps, const Scalar& l_over_v_s,
                              const StallState<Scalar>& s, StallState<Scalar>* ds) {
  const SeparationParameters<Scalar, Cap>& p = m.separation;
  const Scalar per_s = Scalar(1) / l_over_v_s;  // V / l
  const bool filtered = p.forcing_lag == ForcingLag::first_order && p.tau2_semichords > Scalar(0);
  const Scalar xe = p.forcing_lag == ForcingLag::first_order
                        ? (filtered ? s.forcing_angle_rad : x_rad)
                        : Scalar(x_rad - limited_lag(p, Scalar(p.tau2_semichords * l_over_v_s * xdot_radps)));
  const Scalar f = s.separation_point;
  const Scalar u = static_separation(p, xe);
  const Scalar r = p.reattach_shift_rad > Scalar(0) ? reattachment_target(p, xe, u) : u;
  const Scalar t1r = p.tau1_reattach_semichords > Scalar(0) ? p.tau1_reattach_semichords : p.tau1_semichords;
  const Scalar fdot = f > u ? Scalar((u - f) * per_s / p.tau1_semichords)
                      : f < r ? Scalar((r - f) * per_s / t1r)
                              : Scalar(0);
  *ds = StallState<Scalar>{Scalar(0), Scalar(0), Scalar(0), Scalar(0)};
  if (m.families == StallFamilies::none) return;
  if (p.forcing_lag == ForcingLag::first_order)
    ds->forcing_angle_rad = filtered ? Scalar((x_rad - xe) * per_s / p.tau2_semichords) : xdot_radps;
  ds->separation_point = fdot;
  if (m.families != StallFamilies::separation_and_vortex) return;
  const VortexParameters<Scalar>& v = m.vortex;
  const Scalar gate = shedding_switch(m, xe);
  const Scalar clock = s.vortex_clock_semichords;
  ds->vortex_clock_semichords =
      per_s * (gate - (Scalar(1) - gate) * clock / Scalar(v.clock_reset_semichords));
  const Scalar sq = detail::sqrt_nonnegative(f);
  const Scalar dk_df = sq > Scalar(0) ? Scalar((Scalar(1) + Scalar(1) / sq) * Scalar(0.25)) : Scalar(0);
  const Scalar feed_rate = p.normal_force_slope_per_rad * xdot_radps * (Scalar(1) - kirchhoff_factor(f)) -
                           attached_normal_force(p, x_rad) * dk_df * fdot;
  const Scalar on_chord = vortex_on_chord(v, clock);
  ds->vortex_lift = gate * on_chord * feed_rate -
                    per_s * (Scalar(2) - on_chord) * s.vortex_lift / v.decay_semichords;
}

// The runtime's feasible set (see the essay); the fitter keeps its trial models inside it.
enum class StallCheck : int {
  valid = 0,
  nonpositive_time_constant,  // T1, T_v, T_vl <= 0, T2 or T1r < 0, or a width / reset <= 0
  nonpositive_threshold,      // C_N1 <= 0
  bad_separation_table,       // < 2 rows, rows not strictly increasing, a value outside [0, 1]
  bad_hysteresis,             // dxr < 0 or > kMaxReattachShiftRad
  bad_lag_limit,              // D < 0 or > kMaxLagLimitRad, or D > 0 with ForcingLag::first_order
  not_finite                  // a NaN or infinite parameter
};

template <class Scalar, class Cap>
inline StallCheck check_stall_parameters(const StallModel<Scalar, Cap>& m) {
  using std::isfinite;
  if (m.families == StallFamilies::none) return StallCheck::valid;
  const SeparationParameters<Scalar, Cap>& p = m.separation;
  const double vals[] = {double(p.normal_force_slope_per_rad), double(p.zero_lift_angle_rad),
                         double(p.tau1_semichords), double(p.tau2_semichords), double(p.cp_k0),
                         double(p.cp_k1), double(p.cp_k2), double(p.tau1_reattach_semichords),
                         double(p.reattach_shift_rad), double(p.lag_limit_rad)};
  for (double d : vals) if (!isfinite(d)) return StallCheck::not_finite;
  if (!(p.tau1_semichords > Scalar(0)) || p.tau2_semichords < Scalar(0) || p.tau1_reattach_semichords < Scalar(0))
    return StallCheck::nonpositive_time_constant;
  if (p.reattach_shift_rad < Scalar(0) || p.reattach_shift_rad > Scalar(kMaxReattachShiftRad))
    return StallCheck::bad_hysteresis;
  if (p.lag_limit_rad < Scalar(0) || p.lag_limit_rad > Scalar(kMaxLagLimitRad) ||
      (p.lag_limit_rad > Scalar(0) && p.forcing_lag != ForcingLag::delay))
    return StallCheck::bad_lag_limit;
  if (p.n_f0 < 2 || p.n_f0 > Cap::max_table_points) return StallCheck::bad_separation_table;
  for (int i = 0; i < p.n_f0; ++i) {
    if (!isfinite(p.f0_x_rad[i]) || !isfinite(double(p.f0_value[i]))) return StallCheck::not_finite;
    if (p.f0_value[i] < Scalar(0) || p.f0_value[i] > Scalar(1)) return StallCheck::bad_separation_table;
    if (i > 0 && !(p.f0_x_rad[i] > p.f0_x_rad[i - 1])) return StallCheck::bad_separation_table;
  }
  if (m.families != StallFamilies::separation_and_vortex) return StallCheck::valid;
  const VortexParameters<Scalar>& v = m.vortex;
  const double vv[] = {double(v.shedding_threshold), v.shedding_width, double(v.decay_semichords),
                       double(v.travel_semichords), v.clock_width_semichords,
                       v.clock_reset_semichords, double(v.lift_gain), double(v.cp_travel)};
  for (double d : vv) if (!isfinite(d)) return StallCheck::not_finite;
  if (!(v.decay_semichords > Scalar(0)) || !(v.travel_semichords > Scalar(0)) ||
      !(v.shedding_width > 0.0) || !(v.clock_width_semichords > 0.0) ||
      !(v.clock_reset_semichords > 0.0))
    return StallCheck::nonpositive_time_constant;
  if (!(v.shedding_threshold > Scalar(0))) return StallCheck::nonpositive_threshold;
  return StallCheck::valid;
}


}  // namespace indicial
