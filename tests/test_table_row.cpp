// detail::table_row (indicial/model.hpp): the row of a static table or an f0 table that brackets
// an angle, found from the angle's position in the table's range and confirmed by comparisons,
// must be the row plain bisection finds -- the last row at or below the angle in the Scalar's
// comparisons -- for evenly spaced tables, uneven ones, float tables whose rows round to the
// same float, and angles on, just beside and between the rows; so static_value and
// separation_table_value give the same bits as before the lookup changed.
#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "indicial/model.hpp"

TEST_SUITE_BEGIN("unit");  // the ctest label (tests/CMakeLists.txt)

namespace {

// The reference: bisection with the invariant Scalar(x_rad[lo]) <= x < Scalar(x_rad[hi]).
template <class Scalar>
int bisection_row(const std::vector<double>& x_rad, const Scalar& x) {
  int lo = 0, hi = static_cast<int>(x_rad.size()) - 1;
  while (hi - lo > 1) {
    const int mid = (lo + hi) / 2;
    if (x < Scalar(x_rad[mid])) hi = mid; else lo = mid;
  }
  return lo;
}

// Every probe strictly inside the table's range (as the callers clamp first): the rows, their
// neighbouring representable values, midpoints and uniform random angles.
template <class Scalar>
int check_table(const std::vector<double>& x_rad, std::mt19937* rng) {
  const int n = static_cast<int>(x_rad.size());
  const Scalar first = Scalar(x_rad.front()), last = Scalar(x_rad.back());
  std::vector<Scalar> probes;
  const Scalar inf = std::numeric_limits<Scalar>::infinity();
  for (int i = 0; i < n; ++i) {
    const Scalar r = Scalar(x_rad[i]);
    probes.push_back(r);
    probes.push_back(std::nextafter(r, -inf));
    probes.push_back(std::nextafter(r, inf));
    if (i + 1 < n) probes.push_back(Scalar(0.5 * (x_rad[i] + x_rad[i + 1])));
  }
  std::uniform_real_distribution<double> u(x_rad.front(), x_rad.back());
  for (int k = 0; k < 2000; ++k) probes.push_back(Scalar(u(*rng)));
  int checked = 0;
  for (const Scalar x : probes) {
    if (!(x > first) || !(x < last)) continue;
    const int row = indicial::detail::table_row(x_rad.data(), n, x);
    CHECK(row == bisection_row(x_rad, x));
    REQUIRE(row >= 0);
    REQUIRE(row + 1 < n);
    CHECK(!(x < Scalar(x_rad[row])));
    CHECK(x < Scalar(x_rad[row + 1]));
    ++checked;
  }
  return checked;
}

std::vector<double> even_table(int n, double first, double step) {
  std::vector<double> x(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) x[static_cast<std::size_t>(i)] = first + step * i;
  return x;
}

// Strictly increasing rows with random gaps spanning four orders of magnitude.
std::vector<double> uneven_table(int n, std::mt19937* rng) {
  std::uniform_real_distribution<double> log_gap(-4.0, 0.0);
  std::vector<double> x{-0.3};
  while (static_cast<int>(x.size()) < n) x.push_back(x.back() + 0.05 * std::pow(10.0, log_gap(*rng)));
  return x;
}

template <class Scalar>
void check_all_tables() {
  std::mt19937 rng(25);
  int checked = 0;
  checked += check_table<Scalar>(even_table(2, -0.1, 0.2), &rng);
  checked += check_table<Scalar>(even_table(36, -0.2, 2.0 * 3.14159265358979 / 180.0), &rng);
  checked += check_table<Scalar>(even_table(64, -1.0, 1.0 / 31.5), &rng);
  for (int t = 0; t < 20; ++t) checked += check_table<Scalar>(uneven_table(3 + t * 3, &rng), &rng);
  // One wide gap among fine rows: the position guess lands many rows off (bisection takes over).
  std::vector<double> skewed = even_table(30, 0.0, 1e-4);
  skewed.push_back(1.0);
  checked += check_table<Scalar>(skewed, &rng);
  // Rows closer than a float's spacing: several round to one float (the last of them is the row).
  checked += check_table<Scalar>({0.1, 0.1 + 1e-12, 0.1 + 2e-12, 0.2, 0.2 + 1e-13, 0.3}, &rng);
  CHECK(checked > 20000);
}

}  // namespace

TEST_CASE("table_row: the bracketing row of bisection, double") { check_all_tables<double>(); }

TEST_CASE("table_row: the bracketing row of bisection, float") { check_all_tables<float>(); }
