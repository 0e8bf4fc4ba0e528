// lane_exp (indicial/batch.hpp): the batch's hand-written vectorised exp against the C
// library's, in ulps, over the whole range, at the range ends and on special values, for
// double and float and for every register width the batch's kernels use; and the float
// single step's exponential (model.hpp's exp_on on one float) against the lanes, bit for bit.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>

#include "indicial/batch.hpp"

namespace {

namespace bd = indicial::batch_detail;

// |a - b| in units of the last place of b (the spacing of S at b), 0 if both are the same
// non-finite value or both NaN.
template <class S>
double ulps(S a, S b) {
  if (std::isnan(a) && std::isnan(b)) return 0.0;
  if (!std::isfinite(b) || !std::isfinite(a)) return a == b ? 0.0 : std::numeric_limits<double>::infinity();
  const S spacing = std::nextafter(std::fabs(b), std::numeric_limits<S>::infinity()) - std::fabs(b);
  return std::fabs(double(a) - double(b)) / double(spacing);
}

// The worst ulp distance of lane_exp<S, R> from std::exp over `args`, evaluated 8 at a time.
template <class S, int R>
double worst_ulps(const std::vector<S>& args, S* worst_arg) {
  double worst = 0.0;
  for (std::size_t b = 0; b < args.size(); b += indicial::batch_block) {
    bd::LaneArray<S, R> x;
    for (int i = 0; i < indicial::batch_block; ++i) x[i] = args[(b + std::size_t(i)) % args.size()];
    const bd::LaneArray<S, R> e = bd::lane_exp(x);
    for (int i = 0; i < indicial::batch_block; ++i) {
      const double u = ulps<S>(e[i], std::exp(x[i]));
      if (u > worst) {
        worst = u;
        *worst_arg = x[i];
      }
    }
  }
  return worst;
}

template <class S>
std::vector<S> test_arguments(S low, S high) {
  std::mt19937_64 random(20261123);
  std::uniform_real_distribution<double> whole{double(low), double(high)};
  std::uniform_real_distribution<double> step_sized{-2.0, 0.0};  // exp(-z), z = b dt: the batch's use
  std::vector<S> args;
  for (int i = 0; i < 200000; ++i) args.push_back(S(whole(random)));
  for (int i = 0; i < 200000; ++i) args.push_back(S(step_sized(random)));
  // Near the reduction's seams (x = (n + 1/2) ln 2) and near 0.
  for (int n = -20; n <= 20; ++n) {
    const S seam = S((n + 0.5) * 0.69314718055994530942);
    args.push_back(seam);
    args.push_back(std::nextafter(seam, S(0)));
    args.push_back(std::nextafter(seam, S(1000)));
  }
  for (int e = -40; e <= -1; ++e) {
    args.push_back(S(std::ldexp(1.0, e)));
    args.push_back(S(-std::ldexp(1.0, e)));
  }
  return args;
}

template <class S, int R>
void check_special_values() {
  using L = std::numeric_limits<S>;
  const S values[8] = {S(0), S(-0.0), L::infinity(), -L::infinity(), L::quiet_NaN(), S(1e30f),
                       S(-1e30f), L::min()};
  bd::LaneArray<S, R> x;
  for (int i = 0; i < 8; ++i) x[i] = values[i];
  const bd::LaneArray<S, R> e = bd::lane_exp(x);
  CHECK(e[0] == S(1));
  CHECK(e[1] == S(1));
  CHECK(e[2] == L::infinity());
  CHECK(e[3] == S(0));
  CHECK(std::isnan(e[4]));
  CHECK(e[5] == L::infinity());
  CHECK(e[6] == S(0));
  CHECK(e[7] == S(1));
}

}  // namespace

TEST_CASE("lane_exp (double) is within 1 ulp of std::exp over the whole range") {
  const std::vector<double> args = test_arguments<double>(-745.2, 709.8);
  double at16 = 0.0, at32 = 0.0, at64 = 0.0;
  const double w16 = worst_ulps<double, 16>(args, &at16);
  const double w32 = worst_ulps<double, 32>(args, &at32);
  const double w64 = worst_ulps<double, 64>(args, &at64);
  MESSAGE("double: worst ", w16, " ulp at x = ", at16, " (", args.size(), " arguments)");
  // Measured 1 ulp (std::exp is itself within 1 ulp of exp; the two round differently).
  CHECK(w16 <= 1.0);
  // The register width changes how the lanes are grouped, never a result.
  CHECK(w32 == w16);
  CHECK(w64 == w16);
  check_special_values<double, 16>();
  check_special_values<double, 32>();
}

TEST_CASE("lane_exp (double): the range ends, subnormal results and the underflow to 0") {
  const double ends[8] = {709.782712893384, 709.7827128933841, 709.0, -708.3964185322641,
                          -708.5, -740.0, -745.1332191019411, -745.2};
  bd::LaneArray<double, 16> x;
  for (int i = 0; i < 8; ++i) x[i] = ends[i];
  const bd::LaneArray<double, 16> e = bd::lane_exp(x);
  for (int i = 0; i < 8; ++i) {
    INFO("x = ", ends[i]);
    const double ref = std::exp(ends[i]);
    // Subnormal results have fewer digits: compare in the absolute spacing of the smallest
    // subnormal there, elsewhere in ulps.
    if (ref != 0.0 && ref < std::numeric_limits<double>::min())
      CHECK(std::fabs(e[i] - ref) <= std::numeric_limits<double>::denorm_min());
    else
      CHECK(ulps(e[i], ref) <= 1.0);
  }
  CHECK(e[1] == std::numeric_limits<double>::infinity());
  CHECK(e[7] == 0.0);
}

TEST_CASE("lane_exp (float) is within 1 ulp of std::exp over the whole range") {
  const std::vector<float> args = test_arguments<float>(-103.9f, 88.7f);
  float at16 = 0.0f, at32 = 0.0f;
  const double w16 = worst_ulps<float, 16>(args, &at16);
  const double w32 = worst_ulps<float, 32>(args, &at32);
  MESSAGE("float: worst ", w16, " ulp at x = ", at16);
  CHECK(w16 <= 1.0);
  CHECK(w32 == w16);
  check_special_values<float, 16>();
  check_special_values<float, 32>();
}

// The float single step (indicial::detail::step_exp) and the float lanes run the same
// exponential: a float batch gives the single step's bits (tests/test_runtime_batch.cpp).
template <class S, int R>
long count_lane_scalar_differences(const std::vector<S>& args) {
  long differ = 0;
  for (std::size_t b = 0; b < args.size(); b += indicial::batch_block) {
    bd::LaneArray<S, R> x;
    for (int i = 0; i < indicial::batch_block; ++i) x[i] = args[(b + std::size_t(i)) % args.size()];
    const bd::LaneArray<S, R> e = bd::lane_exp(x);
    for (int i = 0; i < indicial::batch_block; ++i) {
      S one;
      indicial::exp_on<S, S, indicial::detail::ScalarBitCast<S>>(x[i], &one);
      const S lane = e[i];
      if (std::memcmp(&one, &lane, sizeof one) != 0 && !(std::isnan(one) && std::isnan(lane))) ++differ;
    }
  }
  return differ;
}

TEST_CASE("exp_on: one float (the single step's exp) gives each lane's bits") {
  std::vector<float> args = test_arguments<float>(-103.9f, 88.7f);
  for (float v : {0.0f, -0.0f, 1e30f, -1e30f, std::numeric_limits<float>::infinity(),
                  -std::numeric_limits<float>::infinity(), std::numeric_limits<float>::quiet_NaN()})
    args.push_back(v);
  CHECK(count_lane_scalar_differences<float, 16>(args) == 0);
  CHECK(count_lane_scalar_differences<float, 32>(args) == 0);
  for (float z : {1e-3f, 2.5e-3f, 0.1f}) {
    bd::LaneArray<float, 16> x;
    for (int i = 0; i < indicial::batch_block; ++i) x[i] = -z;
    CHECK(indicial::detail::step_exp(-z) == bd::lane_exp(x)[0]);
  }
  const std::vector<double> args_d = test_arguments<double>(-745.2, 709.8);
  CHECK(count_lane_scalar_differences<double, 16>(args_d) == 0);
}
