// Linearised frequency response. See indicial/fitter/freqresp.hpp for the derivation.
#include "indicial/fitter/freqresp.hpp"

#include <cmath>
#include <memory>

#include "indicial/fitter/error.hpp"
#include "indicial/fitter/io.hpp"

namespace indicial {
namespace {

constexpr double kPi = 3.14159265358979323846;

// dx/dm at m0: 1 in pitch; roll x = asin(sin m sin a0); yaw x = asin(-sin m cos a0).
double model_angle_derivative(Axis axis, double alpha0_rad, double m0) {
  switch (axis) {
    case Axis::pitch: return 1.0;
    case Axis::roll: {
      const double s = std::sin(m0) * std::sin(alpha0_rad);
      return std::cos(m0) * std::sin(alpha0_rad) / std::sqrt(1.0 - s * s);
    }
    case Axis::yaw: {
      const double s = -std::sin(m0) * std::cos(alpha0_rad);
      return -std::cos(m0) * std::cos(alpha0_rad) / std::sqrt(1.0 - s * s);
    }
  }
  return 1.0;
}

}  // namespace

double static_curve_slope(const CoefficientModel<double, FitCapacity>& cm, double x_rad) {
  const auto& c = cm.static_curve;
  if (c.kind == StaticKind::polynomial) return spline_derivative(c.polynomial, x_rad);
  const int n = c.n_table;
  // Why: the runtime clamps the angle to the table, so the curve is flat outside it.
  if (!(x_rad > c.table_x_rad[0]) || !(x_rad < c.table_x_rad[n - 1])) return 0.0;
  // The natural-spline second derivatives, recomputed by the one function that defines them.
  auto copy = std::make_unique<StaticCurve<double, FitCapacity::max_powers, FitCapacity::max_knots,
                                           FitCapacity::max_table_points>>(c);
  prepare_static_table(*copy);
  int lo = 0, hi = n - 1;
  while (hi - lo > 1) {
    const int mid = (lo + hi) / 2;
    if (x_rad < c.table_x_rad[mid]) hi = mid; else lo = mid;
  }
  const double h = c.table_x_rad[hi] - c.table_x_rad[lo];
  const double A = (c.table_x_rad[hi] - x_rad) / h;
  const double B = 1.0 - A;
  // Derivative of static_value's cubic (model.hpp) with dA/dx = -1/h, dB/dx = 1/h.
  return (c.table_value[hi] - c.table_value[lo]) / h -
         (3.0 * A * A - 1.0) / 6.0 * h * copy->table_second_derivative[lo] +
         (3.0 * B * B - 1.0) / 6.0 * h * copy->table_second_derivative[hi];
}

std::vector<FrequencyResponse> linearised_response(const ModelSet<double, FitCapacity>& model,
                                                   double motion_angle0_rad,
                                                   const std::vector<double>& k_list,
                                                   double airspeed_mps) {
  if (!(airspeed_mps > 0.0)) throw InputError("--airspeed-mps", 0, "must be > 0");
  const double x0 = model_angle<double>(model.axis, model.alpha0_rad, motion_angle0_rad);
  if (!(x0 >= model.x_min_rad && x0 <= model.x_max_rad))
    throw InputError("mean angle", 0,
                     "the model angle " + format_double(x0 * 180.0 / kPi) +
                         " deg is outside the model's envelope [" +
                         format_double(model.x_min_rad * 180.0 / kPi) + ", " +
                         format_double(model.x_max_rad * 180.0 / kPi) + "] deg");
  for (double k : k_list)
    if (!(k >= 0.0) || !std::isfinite(k)) throw InputError("--k-list", 0, "reduced frequencies must be finite and >= 0");
  const double xm = model_angle_derivative(model.axis, model.alpha0_rad, motion_angle0_rad);
  const AirspeedScaling<double> scaling = airspeed_scaling(model.airspeed_mps, model.reference_length_m, airspeed_mps);
  const double time_scale = scaling.time_scale;
  const double l_over_v = scaling.l_over_v_s;
  const std::complex<double> I(0.0, 1.0);

  std::vector<FrequencyResponse> out;
  for (int c = 0; c < model.n_coefficients; ++c) {
    const auto& cm = model.coefficients[c];
    FrequencyResponse r;
    r.coefficient = cm.name;
    r.motion_angle0_rad = motion_angle0_rad;
    r.x0_rad = x0;
    r.dx_dmotion = xm;
    r.static_slope = static_curve_slope(cm, x0) + spline_derivative(cm.static_correction, x0);
    r.rotary = spline_value(cm.rotary, x0);
    const double a0 = spline_value(cm.a, x0);
    // Steady state of lag 1 (model.hpp steady_state: con / b_1, with both scaled alike).
    const double b1 = spline_value(cm.lags[0].b, x0);
    const double y1_star = (cm.con != 0.0 && b1 > 0.0) ? cm.con / b1 : 0.0;
    // A pure delay of the forcing (x_f = x(t - tau)) multiplies the forcing term by e^{-i w tau};
    // b_j(x) sees the undelayed angle, so the steady-state term is not delayed.
    const double tau = delay_at_airspeed(cm.delay_s, model.airspeed_mps, airspeed_mps);
    auto h_at = [&](double w) {
      const std::complex<double> delay_factor = std::exp(-I * w * tau);
      std::complex<double> lag_sum(0.0, 0.0);
      for (int j = 0; j < cm.n_lags; ++j) {
        const double gain = j == 0 ? 1.0 : cm.lags[j].gain;
        const double bj = spline_value(cm.lags[j].b, x0) * time_scale;
        const double dbj = spline_derivative(cm.lags[j].b, x0) * time_scale;
        const double ystar = j == 0 ? y1_star : 0.0;
        lag_sum += (gain * a0 * I * w * delay_factor + dbj * ystar) / (I * w + bj);
      }
      return xm * (r.static_slope - lag_sum) + l_over_v * r.rotary * I * w;
    };
    r.steady_state_slope = h_at(0.0).real();
    for (double k : k_list) {
      FrequencyPoint p;
      p.k = k;
      p.omega_radps = k / l_over_v;
      p.freq_hz = p.omega_radps / (2.0 * kPi);
      p.h = h_at(p.omega_radps);
      p.in_phase = p.h.real();
      // Why the branch: at k = 0 the out-of-phase derivative Im H / k is 0/0; its limit is
      // finite but it carries no damping information at zero frequency, so report 0.
      p.out_of_phase = k > 0.0 ? p.h.imag() / k : 0.0;
      p.magnitude = std::abs(p.h);
      p.phase_deg = std::arg(p.h) * 180.0 / kPi;
      r.points.push_back(p);
    }
    out.push_back(r);
  }
  return out;
}

}  // namespace indicial
