// Splines and the static curve of shared/include/indicial/model.hpp against hand-computed
// numbers, and explicit instantiation of the model templates for double, float and
// Eigen::AutoDiffScalar.
#include <doctest/doctest.h>

#include <Eigen/Core>
#include <unsupported/Eigen/AutoDiff>
#include <boost/math/quadrature/gauss_kronrod.hpp>
#include <cmath>
#include <cstdio>

#include "indicial/model.hpp"

TEST_SUITE_BEGIN("unit");  // the ctest label (tests/CMakeLists.txt)

using AD = Eigen::AutoDiffScalar<Eigen::VectorXd>;

// Explicit instantiation: every template of the model must compile for each scalar type.
template struct indicial::Spline<double, 8, 8>;
template struct indicial::Spline<float, 8, 8>;
template struct indicial::Spline<AD, 8, 8>;
template struct indicial::StaticCurve<float, 8, 8, 64>;
template struct indicial::StaticCurve<AD, 8, 8, 64>;
template struct indicial::CoefficientModel<double, indicial::DefaultCapacity>;
template struct indicial::CoefficientModel<float, indicial::DefaultCapacity>;
template struct indicial::CoefficientModel<AD, indicial::DefaultCapacity>;
template struct indicial::ModelSet<float, indicial::DefaultCapacity>;
template struct indicial::ModelSet<AD, indicial::FitCapacity>;
template float indicial::spline_value(const indicial::Spline<float, 8, 8>&, const float&);
template float indicial::spline_derivative(const indicial::Spline<float, 8, 8>&, const float&);
template float indicial::spline_antiderivative(const indicial::Spline<float, 8, 8>&, const float&);
template AD indicial::spline_value(const indicial::Spline<AD, 8, 8>&, const AD&);
template AD indicial::spline_derivative(const indicial::Spline<AD, 8, 8>&, const AD&);
template AD indicial::spline_antiderivative(const indicial::Spline<AD, 8, 8>&, const AD&);
template float indicial::phi1(const float&);
template AD indicial::phi1(const AD&);
template float indicial::model_angle(indicial::Axis, double, const float&);
template AD indicial::model_angle(indicial::Axis, double, const AD&);
template void indicial::prepare_static_table(indicial::StaticCurve<float, 8, 8, 64>&);
template float indicial::static_value(const indicial::StaticCurve<float, 8, 8, 64>&, const float&);
template void indicial::advance_lags(const indicial::CoefficientModel<float, indicial::DefaultCapacity>&,
                                     const indicial::StepGeometry<float>&, float*);
template void indicial::advance_lags(const indicial::CoefficientModel<AD, indicial::DefaultCapacity>&,
                                     const indicial::StepGeometry<AD>&, AD*);
template float indicial::coefficient_output(const indicial::CoefficientModel<float, indicial::DefaultCapacity>&,
                                            const float&, const float&, const float&, const float*);
template void indicial::lag_derivatives(const indicial::CoefficientModel<float, indicial::DefaultCapacity>&,
                                        const float&, const float&, const float&, const float&,
                                        const float*, float*);

namespace {

// s(x) = 1 + 2 x - 0.5 x^2 + 3 (x - 0.5)_+ + 4 (x - 1)_+^2
template <class S>
indicial::Spline<S, 8, 8> hand_spline() {
  indicial::Spline<S, 8, 8> s;
  s.n_powers = 3;
  s.power_coef[0] = S(1);
  s.power_coef[1] = S(2);
  s.power_coef[2] = S(-0.5);
  s.n_knots = 2;
  s.knot_rad[0] = 0.5;
  s.knot_power[0] = 1;
  s.knot_coef[0] = S(3);
  s.knot_rad[1] = 1.0;
  s.knot_power[1] = 2;
  s.knot_coef[1] = S(4);
  return s;
}

}  // namespace

TEST_CASE("spline value, derivative and antiderivative against hand arithmetic") {
  const auto s = hand_spline<double>();
  // x = 0.25, below both knots:
  //   s  = 1 + 2(0.25) - 0.5(0.0625)            = 1 + 0.5 - 0.03125        = 1.46875
  //   s' = 2 - 2(0.5)(0.25)                      = 2 - 0.25                 = 1.75
  //   S  = x + x^2 - x^3/6 = 0.25 + 0.0625 - 0.015625/6 = 0.3125 - 0.0026041666.. = 0.30989583333..
  CHECK(indicial::spline_value(s, 0.25) == doctest::Approx(1.46875).epsilon(1e-15));
  CHECK(indicial::spline_derivative(s, 0.25) == doctest::Approx(1.75).epsilon(1e-15));
  CHECK(indicial::spline_antiderivative(s, 0.25) == doctest::Approx(0.3098958333333333).epsilon(1e-15));
  // x = 0.75, past the power-1 knot only (u = 0.25):
  //   s  = 1 + 1.5 - 0.5(0.5625) + 3(0.25)       = 2.21875 + 0.75           = 2.96875
  //   s' = 2 - 0.75 + 3                          = 4.25
  //   S  = 0.75 + 0.5625 - 0.421875/6 + 3(0.25^2)/2 = 1.2421875 + 0.09375     = 1.3359375
  CHECK(indicial::spline_value(s, 0.75) == doctest::Approx(2.96875).epsilon(1e-15));
  CHECK(indicial::spline_derivative(s, 0.75) == doctest::Approx(4.25).epsilon(1e-15));
  CHECK(indicial::spline_antiderivative(s, 0.75) == doctest::Approx(1.3359375).epsilon(1e-15));
  // x = 1.5, past both knots (u1 = 1, u2 = 0.5):
  //   s  = 1 + 3 - 0.5(2.25) + 3(1) + 4(0.25)    = 2.875 + 3 + 1            = 6.875
  //   s' = 2 - 1.5 + 3 + 2(4)(0.5)               = 0.5 + 3 + 4              = 7.5
  //   S  = 1.5 + 2.25 - 3.375/6 + 3(1)/2 + 4(0.125)/3
  //      = 3.1875 + 1.5 + 0.1666666..                                      = 4.8541666666..
  CHECK(indicial::spline_value(s, 1.5) == doctest::Approx(6.875).epsilon(1e-15));
  CHECK(indicial::spline_derivative(s, 1.5) == doctest::Approx(7.5).epsilon(1e-15));
  CHECK(indicial::spline_antiderivative(s, 1.5) == doctest::Approx(4.854166666666667).epsilon(1e-15));
  // Exactly at a knot the plus term is 0 (u > 0 is false); continuity from the right:
  //   s(0.5) = 1 + 1 - 0.125 = 1.875; s(0.5 + 1e-9) = 1.875 + (1.5 + 3) 1e-9 (to first order)
  CHECK(indicial::spline_value(s, 0.5) == doctest::Approx(1.875).epsilon(1e-15));
  // Relative (scale 0): with doctest's default scale 1, epsilon(1e-6) was an absolute 1e-6 on a
  // 4.5e-9 difference and passed any slope, the left one (1.5) too. Rounding of 0.5 + 1e-9 and
  // of the difference is ~1e-7 of it.
  CHECK(indicial::spline_value(s, 0.5 + 1e-9) - 1.875 == doctest::Approx(4.5e-9).epsilon(1e-6).scale(0));
  // Left / right derivatives at the power-1 knot: 1.5 and 4.5 (a kink of size 3);
  // at the power-2 knot the derivative is continuous: s'(1) = 2 - 1 + 3 = 4 on both sides.
  CHECK(indicial::spline_derivative(s, 0.5 - 1e-12) == doctest::Approx(1.5).epsilon(1e-9));
  CHECK(indicial::spline_derivative(s, 0.5 + 1e-12) == doctest::Approx(4.5).epsilon(1e-9));
  CHECK(indicial::spline_derivative(s, 1.0 - 1e-12) == doctest::Approx(4.0).epsilon(1e-9));
  CHECK(indicial::spline_derivative(s, 1.0 + 1e-12) == doctest::Approx(4.0).epsilon(1e-9));
  // Negative x: s(-1) = 1 - 2 - 0.5 = -1.5; S(-1) = -1 + 1 + 1/6 = 0.1666..
  CHECK(indicial::spline_value(s, -1.0) == doctest::Approx(-1.5).epsilon(1e-15));
  CHECK(indicial::spline_antiderivative(s, -1.0) == doctest::Approx(1.0 / 6.0).epsilon(1e-15));
}

TEST_CASE("antiderivative differences are exact integrals across knots (Gauss-Kronrod check)") {
  const auto s = hand_spline<double>();
  auto f = [&](double x) { return indicial::spline_value(s, x); };
  const double pairs[][2] = {{0.1, 0.4}, {0.2, 0.9}, {0.7, 1.4}, {-0.3, 1.8}, {1.8, -0.3}};
  for (const auto& p : pairs) {
    // Split at the knots so the quadrature sees only polynomials (and is then exact).
    double lo = std::min(p[0], p[1]), hi = std::max(p[0], p[1]);
    double q = 0.0, a = lo;
    for (double k : {0.5, 1.0, hi}) {
      const double b = std::min(k, hi);
      if (b > a) {
        q += boost::math::quadrature::gauss_kronrod<double, 15>::integrate(f, a, b);
        a = b;
      }
    }
    if (p[0] > p[1]) q = -q;
    const double d = indicial::spline_antiderivative(s, p[1]) - indicial::spline_antiderivative(s, p[0]);
    CHECK(d == doctest::Approx(q).epsilon(1e-14));
  }
}

TEST_CASE("float and autodiff evaluate the same spline") {
  const auto sf = hand_spline<float>();
  CHECK(indicial::spline_value(sf, 1.5f) == doctest::Approx(6.875).epsilon(1e-6));
  CHECK(indicial::spline_antiderivative(sf, 1.5f) == doctest::Approx(4.854166666666667).epsilon(1e-6));
  // Autodiff: seed x; the derivative part must equal spline_derivative (7.5 at x = 1.5).
  auto sa = hand_spline<AD>();
  for (int i = 0; i < 3; ++i) sa.power_coef[i].derivatives() = Eigen::VectorXd::Zero(1);
  for (int j = 0; j < 2; ++j) sa.knot_coef[j].derivatives() = Eigen::VectorXd::Zero(1);
  const AD x(1.5, Eigen::VectorXd::Unit(1, 0));
  const AD v = indicial::spline_value(sa, x);
  CHECK(v.value() == doctest::Approx(6.875).epsilon(1e-15));
  CHECK(v.derivatives()(0) == doctest::Approx(7.5).epsilon(1e-15));
  const AD S = indicial::spline_antiderivative(sa, x);
  CHECK(S.derivatives()(0) == doctest::Approx(6.875).epsilon(1e-15));  // dS/dx = s
  // Float model step and output compile and run.
  indicial::CoefficientModel<float, indicial::DefaultCapacity> m;
  m.a.n_powers = 2;
  m.a.power_coef[1] = 0.5f;
  m.lags[0].b.n_powers = 1;
  m.lags[0].b.power_coef[0] = 2.5f;
  float y[indicial::DefaultCapacity::max_lags] = {};
  const indicial::StepGeometry<float> g{0.1f, 0.2f, 0.1f, 0.2f, 0.01f, 1.0f};
  indicial::advance_lags(m, g, y);
  // y = phi1(0.025) * -(A(0.2) - A(0.1)), A = 0.25 x^2: -(0.01 - 0.0025) = -0.0075;
  // phi1(0.025) = (1 - e^-0.025)/0.025 = 0.98760351...  ->  y = -0.00740702...
  // Relative 1e-5 (scale 0; the former absolute 1e-6 was 1.4e-4 of y and passed the first-order
  // phi1 = 1 - z/2 = 0.9875): float's exp(-z) rounding (6e-8) divided by 1 - exp(-z) = 0.025
  // costs ~2.4e-6 relative.
  CHECK(y[0] == doctest::Approx(-0.0075 * 0.9876035157).epsilon(1e-5).scale(0));
}

TEST_CASE("static table: natural cubic spline") {
  using Curve = indicial::StaticCurve<double, 8, 8, 64>;
  // A linear table (no curvature anywhere): the natural spline's second derivatives are all
  // zero and it reproduces the line exactly, also on a non-uniform grid.
  Curve lin;
  lin.kind = indicial::StaticKind::table;
  const double xs[] = {-0.2, 0.0, 0.1, 0.35, 0.5, 0.9, 1.3};
  lin.n_table = 7;
  for (int i = 0; i < 7; ++i) {
    lin.table_x_rad[i] = xs[i];
    lin.table_value[i] = 2.0 - 3.0 * xs[i];
  }
  indicial::prepare_static_table(lin);
  for (int i = 0; i < 7; ++i) CHECK(std::abs(lin.table_second_derivative[i]) < 1e-13);
  for (double x = -0.2; x <= 1.3; x += 0.0137) {
    CHECK(indicial::static_value(lin, x) == doctest::Approx(2.0 - 3.0 * x).epsilon(1e-14));
  }
  // Clamped outside the table: first / last row value.
  CHECK(indicial::static_value(lin, -1.0) == doctest::Approx(2.6));
  CHECK(indicial::static_value(lin, 5.0) == doctest::Approx(2.0 - 3.9));

  // Hand check of one interior second derivative, 3 rows (0,0), (1,1), (2,0), h = 1:
  //   2 (h0 + h1) M1 = 6 [(0 - 1)/1 - (1 - 0)/1] -> 4 M1 = -12 -> M1 = -3.
  //   s(0.5) = 0.5 * 0 + 0.5 * 1 + ((0.125 - 0.5) * 0 + (0.125 - 0.5) * (-3)) / 6
  //          = 0.5 + 1.125 / 6 = 0.6875
  Curve tri;
  tri.kind = indicial::StaticKind::table;
  tri.n_table = 3;
  tri.table_x_rad[0] = 0; tri.table_x_rad[1] = 1; tri.table_x_rad[2] = 2;
  tri.table_value[0] = 0; tri.table_value[1] = 1; tri.table_value[2] = 0;
  indicial::prepare_static_table(tri);
  CHECK(tri.table_second_derivative[1] == doctest::Approx(-3.0).epsilon(1e-15));
  CHECK(indicial::static_value(tri, 0.5) == doctest::Approx(0.6875).epsilon(1e-15));

  // A smooth function: the report's static Cm(alpha) on 36 rows over 0..70 deg (2 deg apart).
  // Natural end conditions (zero curvature) differ from the function's, which costs O(h^2)
  // in the first and last intervals and decays fast inside.
  auto cm = [](double x) { return 0.42 * x + 0.34 * x * x - x * x * x + 0.40 * x * x * x * x; };
  Curve t;
  t.kind = indicial::StaticKind::table;
  t.n_table = 36;
  const double h = 2.0 * 3.14159265358979323846 / 180.0;
  for (int i = 0; i < 36; ++i) {
    t.table_x_rad[i] = i * h;
    t.table_value[i] = cm(i * h);
  }
  indicial::prepare_static_table(t);
  double err_all = 0, err_inner = 0;
  for (int k = 0; k <= 3500; ++k) {
    const double x = 35.0 * h * k / 3500.0;
    const double e = std::abs(indicial::static_value(t, x) - cm(x));
    err_all = std::max(err_all, e);
    if (x > 5 * h && x < 30 * h) err_inner = std::max(err_inner, e);
  }
  std::printf("static table (36 rows, 2 deg): max error %.2e overall, %.2e inside rows 5..30\n",
              err_all, err_inner);
  CHECK(err_all < 1e-4);
  CHECK(err_inner < 2e-7);  // measured 9.1e-8
}
