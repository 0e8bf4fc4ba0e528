// stall_polar.cpp -- the dynamic-stall families' static part, from the static lift polar:
// the attached line N(x) = C_Na (x - alpha_0) and the Kirchhoff separation table f0(x)
// (model.hpp, "Dynamic stall: equations"). Done once per fit; nothing here is estimated.
//
// The attached part: the polar's rows with |x| <= attached_max_deg (experiment key
// model.stall_attached_max_deg, default 8 deg; at least 3 rows). C_Na and alpha_0 are the
// least-squares line through them (slope C_Na > 0 required). The table: one row per polar row,
// f0 = 1 on the attached part's rows (attached by that assumption), elsewhere
// f0 = kirchhoff_separation(C, C_Na, x, alpha_0) (clipped to [0, 1]); when the polar has more
// rows than the runtime's table holds (DefaultCapacity::max_table_points), the polar is
// sampled at that many equally spaced angles over its range (linear interpolation between its
// rows), so the written model loads in the default runtime.
#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <stdexcept>

#include "estimate/fit_internal.hpp"
#include "indicial/fitter/error.hpp"

namespace indicial::fit_detail {

namespace {
constexpr double kDeg = 3.14159265358979323846 / 180.0;

double interpolate(const std::vector<double>& x, const std::vector<double>& y, double at) {
  if (at <= x.front()) return y.front();
  if (at >= x.back()) return y.back();
  const auto it = std::upper_bound(x.begin(), x.end(), at);
  const std::size_t hi = static_cast<std::size_t>(it - x.begin()), lo = hi - 1;
  const double w = (at - x[lo]) / (x[hi] - x[lo]);
  return (1.0 - w) * y[lo] + w * y[hi];
}
}  // namespace

StallStructure stall_structure(const StallConfig& c, const std::string& context_file) {
  StallStructure s;
  s.families = c.families;
  s.reattachment = c.reattachment;
  s.hysteresis = c.hysteresis;
  s.lag_limit = c.lag_limit;
  s.forcing_lag = c.forcing_lag;
  s.f0_correction.powers = c.f0_correction.powers;
  s.f0_correction.knots_rad = c.f0_correction.knots_rad;
  s.f0_correction.knot_power = c.f0_correction.knot_power;
  if (c.families == StallFamilies::none) return s;
  for (const auto& [name, value] : c.known) {
    ParamId id;
    if (!parse_parameter_name(name, &id))  // experiment_toml.cpp admits only stall names
      throw std::logic_error("stall_structure: known parameter '" + name + "' has no identity");
    s.known.emplace_back(id, value);
  }
  const std::string where = c.polar_path.empty() ? context_file : c.polar_path;
  const std::size_t n = c.polar_x_rad.size();
  if (n < 2 || c.polar_lift.size() != n)
    throw InputError(where, 0, "the dynamic-stall families need a static lift polar of at least 2 rows "
                               "(model.stall_polar, column model.stall_polar_column)");
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  int m = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (std::abs(c.polar_x_rad[i]) > c.attached_max_deg * kDeg) continue;
    sx += c.polar_x_rad[i];
    sy += c.polar_lift[i];
    sxx += c.polar_x_rad[i] * c.polar_x_rad[i];
    sxy += c.polar_x_rad[i] * c.polar_lift[i];
    ++m;
  }
  const double det = m * sxx - sx * sx;
  if (m < 3 || !(det > 0.0))
    throw InputError(where, 0, fmt::format("the lift polar has {} rows with |angle| <= {} deg "
                                           "(model.stall_attached_max_deg): need at least 3 for its "
                                           "attached line", m, c.attached_max_deg));
  const double slope = (m * sxy - sx * sy) / det;
  const double intercept = (sy - slope * sx) / m;
  if (!(slope > 0.0))
    throw InputError(where, 0, fmt::format("the lift polar's attached line has slope {:.6g} per rad: "
                                           "a lift polar rises with the angle (is model.stall_polar_column "
                                           "the lift?)", slope));
  s.normal_force_slope_per_rad = slope;
  s.zero_lift_angle_rad = -intercept / slope;
  const auto rows = static_cast<std::size_t>(DefaultCapacity::max_table_points);
  std::vector<double> xs = c.polar_x_rad;
  if (n > rows) {
    xs.resize(rows);
    for (std::size_t i = 0; i < rows; ++i)
      xs[i] = c.polar_x_rad.front() +
              (c.polar_x_rad.back() - c.polar_x_rad.front()) * static_cast<double>(i) / static_cast<double>(rows - 1);
  }
  // Rows of the attached part are attached (f0 = 1): the assumption that fitted the line. The
  // inversion there would only return the polar's noise: f0 = (2 sqrt(C / N) - 1)^2 moves by
  // about 2 dC / N, and N -> 0 at alpha_0 (a measured NACA 0012 polar, 1 deg above alpha_0:
  // C = 0.036 against N = 0.051 gave f0 = 0.47, and a shedding threshold start of 0.05).
  const double attached_rad = c.attached_max_deg * kDeg;
  for (double x : xs) {
    s.f0_x_rad.push_back(x);
    s.f0_value.push_back(std::abs(x) <= attached_rad
                             ? 1.0
                             : kirchhoff_separation(interpolate(c.polar_x_rad, c.polar_lift, x), slope, x,
                                                    s.zero_lift_angle_rad));
  }
  // The shedding threshold's start: the attached normal force where the static separation
  // first falls below 0.7 above alpha_0 (Beddoes-Leishman's alpha_1: f0(alpha_1) = 0.7).
  s.shedding_threshold_start = c.shedding_threshold_start;
  if (!(s.shedding_threshold_start > 0.0)) {
    s.shedding_threshold_start = 1.0;
    for (std::size_t i = 0; i < s.f0_x_rad.size(); ++i)
      if (s.f0_x_rad[i] > s.zero_lift_angle_rad && s.f0_value[i] < 0.7) {
        s.shedding_threshold_start = slope * (s.f0_x_rad[i] - s.zero_lift_angle_rad);
        break;
      }
  }
  return s;
}

}  // namespace indicial::fit_detail
