// Prediction with the runtime and its metrics (numbers only; the outputs are
// prediction_output.cpp). See indicial/fitter/predict.hpp.
#include "indicial/fitter/predict.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fmt/format.h>
#include <memory>
#include <stdexcept>

#include "indicial/coef_file.hpp"
#include "indicial/fitter/error.hpp"
#include "indicial/fitter/io.hpp"
#include "indicial/fitter/output.hpp"
#include "indicial/periodic_stall.hpp"
#include "indicial/runtime.hpp"

namespace indicial {
namespace {

std::string fmt_num(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

}  // namespace

ErrorMetrics score_prediction(const std::vector<double>& measured,
                              const std::vector<double>& predicted) {
  if (measured.empty() || measured.size() != predicted.size())
    throw std::invalid_argument("score_prediction: measured and predicted differ in length or are empty");
  ErrorMetrics m;
  m.n_samples = measured.size();
  double see = 0.0, smm = 0.0, spp = 0.0, se = 0.0;
  for (std::size_t i = 0; i < measured.size(); ++i) {
    const double e = predicted[i] - measured[i];
    se += e;
    see += e * e;
    smm += measured[i] * measured[i];
    spp += predicted[i] * predicted[i];
    m.max_error = std::max(m.max_error, std::abs(e));
  }
  const double n = static_cast<double>(measured.size());
  m.rms_error = std::sqrt(see / n);
  const double denominator = std::sqrt(smm / n) + std::sqrt(spp / n);
  // Why the branch: both signals identically zero is a perfect (if empty) prediction; the
  // formula would be 0/0.
  m.theil_inequality = denominator > 0.0 ? m.rms_error / denominator : 0.0;
  m.mean_error = se / n;
  // The spread about the mean from a second pass (no cancellation of see / n - mean^2 when
  // the bias dominates).
  double sdd = 0.0;
  for (std::size_t i = 0; i < measured.size(); ++i) {
    const double d = predicted[i] - measured[i] - m.mean_error;
    sdd += d * d;
  }
  m.rms_about_mean = std::sqrt(sdd / n);
  // Why the branch: a perfect prediction has no error to apportion.
  m.bias_proportion = see > 0.0 ? std::min(1.0, m.mean_error * m.mean_error / (see / n)) : 0.0;
  return m;
}

Prediction predict_motion(const ModelSet<double, FitCapacity>& model,
                          const std::vector<double>& time_s,
                          const std::vector<double>& motion_angle_rad,
                          const std::vector<double>& rate_radps, double airspeed_mps,
                          const std::string& model_label) {
  const std::size_t n = time_s.size();
  if (n == 0 || motion_angle_rad.size() != n || rate_radps.size() != n)
    throw std::invalid_argument("predict_motion: time, angle and rate differ in length or are empty");
  // The predictor holds a whole model set with FitCapacity (tens of KB): heap, not stack.
  auto predictor = std::make_unique<Predictor<double, FitCapacity>>();
  ParseDiagnostic diag;
  const LoadStatus ls = predictor->load(model, &diag);
  if (ls != LoadStatus::ok)
    throw InputError(model_label, 0, std::string("the runtime refuses the model: ") + diag.reason +
                                     " (" + to_string(ls) + ")");
  const auto& m = predictor->model();

  Prediction p;
  p.axis = model.axis;
  p.time_s = time_s;
  p.motion_angle_rad = motion_angle_rad;
  p.rate_radps = rate_radps;
  p.x_rad.resize(n);
  p.coefficients.resize(static_cast<std::size_t>(m.n_coefficients));
  for (int c = 0; c < m.n_coefficients; ++c) {
    auto& cp = p.coefficients[static_cast<std::size_t>(c)];
    cp.name = m.coefficients[c].name;
    cp.predicted.resize(n);
    cp.quasi_steady.resize(n);
  }
  const double l_over_v_s = airspeed_scaling(m.airspeed_mps, m.reference_length_m, airspeed_mps).l_over_v_s;
  auto clamp_x = [&](double x) { return std::min(std::max(x, m.x_min_rad), m.x_max_rad); };

  for (std::size_t i = 0; i < n; ++i) {
    const double x = model_angle<double>(m.axis, m.alpha0_rad, motion_angle_rad[i]);
    p.x_rad[i] = x;
    StepStatus st;
    Predictor<double, FitCapacity>::Outputs out;
    if (i == 0) {
      st = predictor->reset(motion_angle_rad[0], airspeed_mps);
      // The runtime's reset() produces no output; the first sample's output is the model at
      // the steady state it set (the same model.hpp function the runtime's step uses).
      const auto snap = predictor->snapshot();
      for (int c = 0; c < m.n_coefficients; ++c) {
        out.value[c] = coefficient_output(m.coefficients[c], clamp_x(x), x, rate_radps[0], l_over_v_s, snap.y[c]);
      }
    } else {
      st = predictor->step(MotionInput{motion_angle_rad[i], rate_radps[i], airspeed_mps},
                           time_s[i] - time_s[i - 1], &out);
    }
    if (st == StepStatus::angle_clamped) {
      ++p.clamped_samples;
    } else if (st != StepStatus::ok) {
      throw InputError(model_label, 0, "the runtime refused sample " + std::to_string(i) + " (t = " +
                                       fmt_num(time_s[i]) + " s): " + to_string(st));
    }
    for (int c = 0; c < m.n_coefficients; ++c) {
      auto& cp = p.coefficients[static_cast<std::size_t>(c)];
      cp.predicted[i] = out.value[c];
      // The quasi-steady model sees the same angles as the runtime (runtime.hpp warning 3).
      cp.quasi_steady[i] = quasi_steady_output(m.coefficients[c], clamp_x(x), x, rate_radps[i], l_over_v_s);
    }
  }
  return p;
}

namespace {

using PeriodicPredictor = Predictor<double, FitCapacity>;

// Steps the predictor once round the cycle from its current state: samples 1..n-1, then (for
// an open cycle) the wrap step back to sample 0. Calls emit(i, outputs) after each step
// (i = 0 for the wrap step or, for a closed cycle, the last sample's step's index).
template <class Emit>
void step_cycle(PeriodicPredictor& p, const std::vector<double>& time_s, const std::vector<double>& angle,
                const std::vector<double>& rate, double airspeed_mps, bool closed, double wrap_dt_s,
                const std::string& label, Emit&& emit) {
  const std::size_t n = time_s.size();
  PeriodicPredictor::Outputs out;
  auto step = [&](std::size_t i, double dt_s) {
    const StepStatus st = p.step(MotionInput{angle[i], rate[i], airspeed_mps}, dt_s, &out);
    if (st != StepStatus::ok && st != StepStatus::angle_clamped)
      throw InputError(label, 0, "the runtime refused sample " + std::to_string(i) + " of the cycle: " + to_string(st));
    emit(i, out);
  };
  for (std::size_t i = 1; i < n; ++i) step(i, time_s[i] - time_s[i - 1]);
  if (!closed) step(0, wrap_dt_s);
}

}  // namespace

Prediction predict_periodic(const ModelSet<double, FitCapacity>& model, const std::vector<double>& time_s,
                            const std::vector<double>& motion_angle_rad, const std::vector<double>& rate_radps,
                            double airspeed_mps, const std::string& model_label) {
  // The quasi-steady part, the model angles and the clamping count do not depend on the state.
  Prediction p = predict_motion(model, time_s, motion_angle_rad, rate_radps, airspeed_mps, model_label);
  const std::size_t n = time_s.size();
  if (n < 3) throw InputError(model_label, 0, "a periodic cycle needs at least 3 samples");
  auto predictor = std::make_unique<PeriodicPredictor>();
  ParseDiagnostic diag;
  if (predictor->load(model, &diag) != LoadStatus::ok)
    throw InputError(model_label, 0, std::string("the runtime refuses the model: ") + diag.reason);
  const auto& m = predictor->model();
  const bool closed = std::abs(model_angle<double>(m.axis, m.alpha0_rad, motion_angle_rad.back()) -
                               model_angle<double>(m.axis, m.alpha0_rad, motion_angle_rad.front())) <= 1e-9;
  const double wrap_dt_s = (time_s.back() - time_s.front()) / static_cast<double>(n - 1);
  auto ignore = [](std::size_t, const PeriodicPredictor::Outputs&) {};
  predictor->reset(motion_angle_rad[0], airspeed_mps);
  // Warm-up cycle: fills a delayed coefficient's history with the cycle's own angles.
  step_cycle(*predictor, time_s, motion_angle_rad, rate_radps, airspeed_mps, closed, wrap_dt_s, model_label, ignore);
  PeriodicPredictor::Snapshot start = predictor->snapshot();
  // The dynamic-stall states at their periodic state (periodic_stall.hpp, as the fitter takes
  // a periodic run's), from the runtime's own cycle; the lags' fixed point below does not
  // depend on them (both are driven by the angle only).
  StallPeriodicStates live[FitCapacity::max_coefficients];
  bool families = false;
  for (int c = 0; c < m.n_coefficients; ++c) {
    live[c] = stall_periodic_states(m.coefficients[c].stall);
    families = families || live[c].separation;
  }
  if (families)
    periodic_stall_state<FitCapacity::max_coefficients>(
        live, m.n_coefficients, start.stall, [&](const StallState<double>* a, StallState<double>* e) {
          PeriodicPredictor::Snapshot s = start;
          for (int c = 0; c < m.n_coefficients; ++c) s.stall[c] = a[c];
          predictor->restore(s);
          step_cycle(*predictor, time_s, motion_angle_rad, rate_radps, airspeed_mps, closed, wrap_dt_s, model_label,
                     ignore);
          const PeriodicPredictor::Snapshot t = predictor->snapshot();
          for (int c = 0; c < m.n_coefficients; ++c) e[c] = t.stall[c];
        });
  auto cycle_end_from = [&](double y_start) {
    PeriodicPredictor::Snapshot s = start;
    for (int c = 0; c < m.n_coefficients; ++c)
      for (int j = 0; j < m.coefficients[c].n_lags; ++j) s.y[c][j] = y_start;
    predictor->restore(s);
    step_cycle(*predictor, time_s, motion_angle_rad, rate_radps, airspeed_mps, closed, wrap_dt_s, model_label, ignore);
    return predictor->snapshot();
  };
  const PeriodicPredictor::Snapshot ya = cycle_end_from(0.0);
  const PeriodicPredictor::Snapshot yb = cycle_end_from(1.0);
  PeriodicPredictor::Snapshot fixed = start;
  for (int c = 0; c < m.n_coefficients; ++c) {
    for (int j = 0; j < m.coefficients[c].n_lags; ++j) {
      const double phi = yb.y[c][j] - ya.y[c][j];
      // Why: 1 - Phi <= 0 means the lag does not decay over the cycle: no periodic state.
      if (!(phi < 1.0 - 1e-12))
        throw InputError(model_label, 0, fmt_num(phi) + " = the cycle's decay factor of lag " + std::to_string(j + 1) +
                                             " of " + m.coefficients[c].name + ": no periodic steady state");
      fixed.y[c][j] = ya.y[c][j] / (1.0 - phi);
    }
  }
  predictor->restore(fixed);
  const double l_over_v_s = airspeed_scaling(m.airspeed_mps, m.reference_length_m, airspeed_mps).l_over_v_s;
  for (int c = 0; c < m.n_coefficients; ++c) {
    // The output at sample 0 at the fixed-point state (a closed cycle's last step gives it too).
    const double x0 = std::min(std::max(p.x_rad[0], m.x_min_rad), m.x_max_rad);
    p.coefficients[static_cast<std::size_t>(c)].predicted[0] =
        coefficient_output(m.coefficients[c], x0, p.x_rad[0], rate_radps[0], l_over_v_s, fixed.y[c]) +
        stall_output(m.coefficients[c].stall, x0, fixed.stall[c]);
  }
  step_cycle(*predictor, time_s, motion_angle_rad, rate_radps, airspeed_mps, closed, wrap_dt_s, model_label,
             [&](std::size_t i, const PeriodicPredictor::Outputs& out) {
               if (!closed && i == 0) return;  // the wrap step only closes the cycle
               for (int c = 0; c < m.n_coefficients; ++c) p.coefficients[static_cast<std::size_t>(c)].predicted[i] = out.value[c];
             });
  return p;
}

void score_coefficients(Prediction& p, double score_from_s, const std::string& option_name) {
  const std::vector<double>& t = p.time_s;
  if (std::isnan(score_from_s)) throw InputError(option_name, 0, "is NaN: give a time in s");
  const std::size_t first =
      static_cast<std::size_t>(std::lower_bound(t.begin(), t.end(), score_from_s) - t.begin());
  const bool given = score_from_s != -std::numeric_limits<double>::infinity();
  if (given && t.size() - first < 2)
    throw InputError(option_name, 0,
                     fmt::format("{} s leaves {} sample(s) to score; the data run from {} to {} s", score_from_s,
                                 t.size() - first, t.empty() ? 0.0 : t.front(), t.empty() ? 0.0 : t.back()));
  p.score_from_s = score_from_s;
  p.first_scored = first;
  p.scored_samples = t.size() - first;
  const auto tail = [first](const std::vector<double>& v) {
    return std::vector<double>(v.begin() + static_cast<std::ptrdiff_t>(std::min(first, v.size())), v.end());
  };
  for (auto& c : p.coefficients) {
    if (c.measured.empty()) {
      c.scored = CoefficientPrediction::Scored::no_measurement;
      continue;
    }
    const std::vector<double> measured = tail(c.measured);
    c.model_metrics = score_prediction(measured, tail(c.predicted));
    c.quasi_steady_metrics = score_prediction(measured, tail(c.quasi_steady));
    c.scored = CoefficientPrediction::Scored::scored;
  }
}

ModelSet<double, FitCapacity> read_model_file(const std::string& path) {
  const std::string text = read_text(path);
  auto m = std::make_unique<ModelSet<double, FitCapacity>>();
  ParseDiagnostic diag;
  const LoadStatus st = parse_coef_file(text.data(), text.size(), m.get(), &diag);
  if (st != LoadStatus::ok)
    throw InputError(path, static_cast<long>(diag.line),
                     std::string(diag.reason) + " (" + to_string(st) + ")");
  return *m;
}

}  // namespace indicial
