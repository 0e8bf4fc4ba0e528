// The reference simulator. See indicial/fitter/simulate.hpp.
#include "indicial/fitter/simulate.hpp"

#include <algorithm>
#include <boost/math/interpolators/cardinal_cubic_b_spline.hpp>
#include <boost/numeric/odeint.hpp>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <sstream>

#include "indicial/fitter/error.hpp"
#include "indicial/coef_file.hpp"
#include "indicial/fitter/tailless_model.hpp"
#include "indicial/fitter/io.hpp"
#include "simulate/spec_keys.hpp"

namespace indicial {
namespace {

constexpr double kPi = 3.14159265358979323846;

// The motion angle and its rate at any time, plus the times where the motion has a kink.
class MotionFunction {
 public:
  explicit MotionFunction(const MotionSpec& m) : m_(m) {
    if (m.kind == MotionKind::samples) {
      const std::size_t n = m.angle_rad.size();
      if (n < 4 || m.time_s.size() != n) {
        throw InputError(m.source, 0, "a sampled motion needs at least 4 samples");
      }
      t0_ = m.time_s.front();
      dt_ = (m.time_s.back() - m.time_s.front()) / static_cast<double>(n - 1);
      t_end_ = m.time_s.back();
      spline_ = std::make_unique<boost::math::interpolators::cardinal_cubic_b_spline<double>>(
          m.angle_rad.data(), n, t0_, dt_);
    } else if (m.kind == MotionKind::ramp) {
      ramp_s_ = std::abs(m.to_rad - m.from_rad) / m.rate_radps;
    }
  }

  double start_time() const { return m_.kind == MotionKind::samples ? t0_ : 0.0; }

  // angle and d(angle)/dt at t; before the start the motion is at rest at its first angle.
  void eval(double t, double& angle, double& rate) const {
    switch (m_.kind) {
      case MotionKind::sine: {
        if (t <= 0.0) {  // at rest before the start: angle(0), zero rate (continuous)
          angle = m_.mean_rad - m_.amplitude_rad;
          rate = 0.0;
          return;
        }
        const double w = 2.0 * kPi * m_.freq_hz;
        angle = m_.mean_rad - m_.amplitude_rad * std::cos(w * t);
        rate = m_.amplitude_rad * w * std::sin(w * t);
        return;
      }
      case MotionKind::ramp: {
        const double t1 = m_.hold_before_s;
        const double t2 = t1 + ramp_s_;
        const double sign = m_.to_rad >= m_.from_rad ? 1.0 : -1.0;
        if (t <= t1) {
          angle = m_.from_rad;
          rate = 0.0;
        } else if (t < t2) {
          angle = m_.from_rad + sign * m_.rate_radps * (t - t1);
          rate = sign * m_.rate_radps;
        } else {
          angle = m_.to_rad;
          rate = 0.0;
        }
        return;
      }
      case MotionKind::samples: {
        // Why the clamp: the spline is data only inside the record; before it the model is at
        // rest (warning 1 of the header), after it nothing is asked (outputs end there).
        // At t0 itself the spline's own derivative is used (the right-hand limit, which is
        // what a step starting at t0 needs; t0 is an integration break point).
        if (t < t0_) {
          angle = m_.angle_rad.front();
          rate = 0.0;
          return;
        }
        const double tc = std::min(t, t_end_);
        angle = (*spline_)(tc);
        rate = spline_->prime(tc);
        return;
      }
    }
  }

  // Times where the angle's derivative jumps (integration must not step across them).
  std::vector<double> kinks() const {
    if (m_.kind == MotionKind::ramp) return {m_.hold_before_s, m_.hold_before_s + ramp_s_};
    if (m_.kind == MotionKind::samples) return {t0_};  // rate jumps from 0 (rest) to spline'
    return {};
  }

 private:
  const MotionSpec& m_;
  double t0_ = 0.0, dt_ = 0.0, t_end_ = 0.0, ramp_s_ = 0.0;
  std::unique_ptr<boost::math::interpolators::cardinal_cubic_b_spline<double>> spline_;
};

// Model angle and its time derivative from the motion angle (eqs. 17, 20, chain rule).
void model_angle_and_rate(Axis axis, double alpha0_rad, double angle, double rate, double& x,
                          double& xdot) {
  x = model_angle(axis, alpha0_rad, angle);
  switch (axis) {
    case Axis::pitch: xdot = rate; return;
    case Axis::roll: {
      // beta = asin(sin(phi) sin(a0)):  beta' = cos(phi) sin(a0) phi' / cos(beta)
      xdot = std::cos(angle) * std::sin(alpha0_rad) * rate / std::cos(x);
      return;
    }
    case Axis::yaw: {
      // beta = asin(-sin(psi) cos(a0)): beta' = -cos(psi) cos(a0) psi' / cos(beta)
      xdot = -std::cos(angle) * std::cos(alpha0_rad) * rate / std::cos(x);
      return;
    }
  }
}

}  // namespace

std::vector<double> motion_sample_times(const MotionSpec& m) {
  if (m.kind == MotionKind::samples) return m.time_s;
  if (!m.output_times_s.empty()) return m.output_times_s;
  const double duration = m.kind == MotionKind::sine
                              ? m.cycles / m.freq_hz
                              : m.hold_before_s + std::abs(m.to_rad - m.from_rad) / m.rate_radps +
                                    m.hold_after_s;
  // Why the 1e-9: cycles / (f dt) is an integer up to rounding for the usual specs; the last
  // sample at exactly the end must not be lost to 2.9999999 cycles.
  const auto n = static_cast<std::size_t>(std::floor(duration / m.dt_s + 1e-9)) + 1;
  std::vector<double> t(n);
  for (std::size_t k = 0; k < n; ++k) t[k] = static_cast<double>(k) * m.dt_s;
  return t;
}

// ==========================================================================================
// Reference integration
// ==========================================================================================
namespace {

// The continuous model of every coefficient as one ODE system for Odeint: per coefficient its
// lag states y_1..y_n and, with dynamic-stall families, the three stall states (f, v, tau_v)
// of model.hpp's stall_derivatives (for the separation family alone v and tau_v stay 0).
class ReferenceSystem {
 public:
  using State = std::vector<double>;

  ReferenceSystem(const TruthModel& model, const MotionSpec& motion, const MotionFunction& f)
      : model_(model), f_(f) {
    const int nc = model.n_coefficients;
    int next = 0;
    for (int c = 0; c < nc; ++c) {
      const auto& m = model.coefficients[c];
      lag_offset_.push_back(next);
      next += m.n_lags;
      stall_offset_.push_back(m.stall.families != StallFamilies::none ? next : -1);
      if (m.stall.families != StallFamilies::none) next += 3;
    }
    size_ = static_cast<std::size_t>(next);
    airspeed_mps_ = motion.airspeed_mps > 0.0 ? motion.airspeed_mps : model.airspeed_mps;
    const AirspeedScaling<double> scaling = airspeed_scaling(model.airspeed_mps, model.reference_length_m, airspeed_mps_);
    l_over_v_ = scaling.l_over_v_s;
    time_scale_ = scaling.time_scale;
    for (int c = 0; c < nc; ++c)
      delay_s_.push_back(delay_at_airspeed(model.coefficients[c].delay_s, model.airspeed_mps, airspeed_mps_));
  }

  double l_over_v_s() const { return l_over_v_; }
  double delay_s(int c) const { return delay_s_[static_cast<std::size_t>(c)]; }
  int coefficients() const { return model_.n_coefficients; }

  void model_angle_at(double t, double& angle, double& rate, double& x, double& xdot) const {
    f_.eval(t, angle, rate);
    model_angle_and_rate(model_.axis, model_.alpha0_rad, angle, rate, x, xdot);
  }

  // At rest at the first angle (simulate.hpp warning 1): every lag and the stall states at
  // their steady state there, the state the runtime's reset() sets.
  State initial_state(double t0) const {
    State y(size_, 0.0);
    double angle = 0, rate = 0, x = 0, xdot = 0;
    model_angle_at(t0, angle, rate, x, xdot);
    for (int c = 0; c < model_.n_coefficients; ++c) {
      const auto& m = model_.coefficients[c];
      steady_state(m, x, y.data() + lag_offset_[static_cast<std::size_t>(c)]);
      if (stall_offset_[static_cast<std::size_t>(c)] < 0) continue;
      StallState<double> s;
      stall_steady_state(m.stall, x, &s);
      set_stall(y, c, s);
    }
    return y;
  }

  void operator()(const State& y, State& dydt, double t) const {
    double angle = 0, rate = 0, x = 0, xdot = 0;
    model_angle_at(t, angle, rate, x, xdot);
    for (int c = 0; c < model_.n_coefficients; ++c) {
      const auto& m = model_.coefficients[c];
      double xf = x, xfdot = xdot;
      // Why the branch: only a delayed coefficient needs the motion at another time.
      if (delay_s(c) != 0.0) {
        double af = 0, rf = 0;
        model_angle_at(t - delay_s(c), af, rf, xf, xfdot);
      }
      const auto o = static_cast<std::size_t>(lag_offset_[static_cast<std::size_t>(c)]);
      lag_derivatives(m, x, xf, xfdot, time_scale_, y.data() + o, dydt.data() + o);
      const int so = stall_offset_[static_cast<std::size_t>(c)];
      if (so < 0) continue;
      // The stall states see the undelayed angle and its rate (the runtime's advance_stall
      // steps on the sample angles, its x' the slope over the step).
      StallState<double> d;
      stall_derivatives(m.stall, x, xdot, l_over_v_, stall(y, c), &d);
      const auto u = static_cast<std::size_t>(so);
      dydt[u] = d.separation_point;
      dydt[u + 1] = d.vortex_lift;
      dydt[u + 2] = d.vortex_clock_semichords;
    }
  }

  // Sample k of `out` from the state y at time t.
  void record(const State& y, double t, std::size_t k, SimulatedRun& out) const {
    double angle = 0, rate = 0, x = 0, xdot = 0;
    model_angle_at(t, angle, rate, x, xdot);
    out.motion_angle_rad[k] = angle;
    out.rate_radps[k] = rate;
    out.x_rad[k] = x;
    out.xdot_radps[k] = xdot;
    for (int c = 0; c < model_.n_coefficients; ++c) {
      const auto cc = static_cast<std::size_t>(c);
      const auto o = static_cast<std::size_t>(lag_offset_[cc]);
      const auto& m = model_.coefficients[c];
      double ysum = 0.0;
      for (int j = 0; j < m.n_lags; ++j) {
        out.lag_states[cc][static_cast<std::size_t>(j)][k] = y[o + static_cast<std::size_t>(j)];
        ysum += y[o + static_cast<std::size_t>(j)];
      }
      double value = coefficient_output(m, x, rate, l_over_v_, y.data() + o);
      if (stall_offset_[cc] >= 0) {
        const StallState<double> s = stall(y, c);
        out.stall_states[cc][k] = s;
        const double delta = stall_output(m.stall, x, s);
        ysum += delta;
        value += delta;
      }
      out.y_true[cc][k] = ysum;
      out.coefficient_true[cc][k] = value;
    }
  }

 private:
  StallState<double> stall(const State& y, int c) const {
    const auto u = static_cast<std::size_t>(stall_offset_[static_cast<std::size_t>(c)]);
    return StallState<double>{y[u], y[u + 1], y[u + 2]};
  }
  void set_stall(State& y, int c, const StallState<double>& s) const {
    const auto u = static_cast<std::size_t>(stall_offset_[static_cast<std::size_t>(c)]);
    y[u] = s.separation_point;
    y[u + 1] = s.vortex_lift;
    y[u + 2] = s.vortex_clock_semichords;
  }

  const TruthModel& model_;
  const MotionFunction& f_;
  std::vector<int> lag_offset_, stall_offset_;
  std::vector<double> delay_s_;
  std::size_t size_ = 0;
  double airspeed_mps_ = 0.0, l_over_v_ = 0.0, time_scale_ = 1.0;
};

// The output arrays of a run of n samples.
SimulatedRun sized_run(const TruthModel& model, const std::vector<double>& times) {
  const std::size_t n = times.size();
  const auto nc = static_cast<std::size_t>(model.n_coefficients);
  SimulatedRun out;
  out.time_s = times;
  out.motion_angle_rad.resize(n);
  out.rate_radps.resize(n);
  out.x_rad.resize(n);
  out.xdot_radps.resize(n);
  out.lag_states.resize(nc);
  out.stall_states.resize(nc);
  out.y_true.assign(nc, std::vector<double>(n, 0.0));
  out.coefficient_true.assign(nc, std::vector<double>(n, 0.0));
  for (std::size_t c = 0; c < nc; ++c) {
    const auto& m = model.coefficients[static_cast<int>(c)];
    out.lag_states[c].assign(static_cast<std::size_t>(m.n_lags), std::vector<double>(n, 0.0));
    if (m.stall.families != StallFamilies::none) out.stall_states[c].resize(n);
  }
  return out;
}

}  // namespace

SimulatedRun simulate_reference(const TruthModel& model, const MotionSpec& motion,
                                const ReferenceTolerance& tolerance) {
  namespace odeint = boost::numeric::odeint;
  using State = ReferenceSystem::State;
  const MotionFunction f(motion);
  const ReferenceSystem system(model, motion, f);
  const std::vector<double> times = motion_sample_times(motion);
  const std::size_t n = times.size();
  // Break points: the motion's kinks and, per delayed coefficient, the same kinks shifted. A
  // kink is a jump of the rate: there the stall family's lagged angle x - T2 (l/V) x' and the
  // shedding switch jump too, so every discontinuity of the right-hand side is a break point.
  std::vector<double> breaks = f.kinks();
  for (int c = 0; c < system.coefficients(); ++c) {
    const double d = system.delay_s(c);
    if (d == 0.0) continue;
    breaks.push_back(f.start_time() + d);
    for (double k : f.kinks()) breaks.push_back(k + d);
  }
  std::sort(breaks.begin(), breaks.end());

  SimulatedRun out = sized_run(model, times);
  State y = system.initial_state(times.front());
  auto stepper = odeint::make_controlled(tolerance.abs, tolerance.rel,
                                         odeint::runge_kutta_dopri5<State>());
  system.record(y, times.front(), 0, out);
  for (std::size_t k = 0; k + 1 < n; ++k) {
    double t = times[k];
    const double t_next = times[k + 1];
    // Integrate piecewise across any break point inside (t, t_next).
    auto it = std::upper_bound(breaks.begin(), breaks.end(), t);
    for (; it != breaks.end() && *it < t_next; ++it) {
      odeint::integrate_adaptive(stepper, std::cref(system), y, t, *it, std::min(1e-3, *it - t));
      t = *it;
    }
    odeint::integrate_adaptive(stepper, std::cref(system), y, t, t_next, std::min(1e-3, t_next - t));
    system.record(y, times[k + 1], k + 1, out);
  }
  out.coefficient_measured = out.coefficient_true;
  return out;
}

}  // namespace indicial
