// indicial/runtime.hpp -- the embedded runtime: run a fitted model in a real-time loop.
//
// What it is for
// --------------
// A flight simulator (or a wind-tunnel controller) feeds the motion of the aircraft, one
// sample at a time, and needs the aerodynamic coefficients at that sample, including the
// unsteady (lag) part identified by the fitter. Predictor does that with a fixed-size state,
// no heap, no exceptions and no RTTI; every call returns a status enum. The equations are
// those of indicial/model.hpp (advance_lags, coefficient_output, steady_state): the runtime
// adds input checks, clamping and bookkeeping, never equations of its own.
//
// Usage
// -----
//   indicial::Predictor<> p;                                   // double, DefaultCapacity
//   if (p.load(text, text_length) != indicial::LoadStatus::ok) { /* refuse to fly */ }
//   p.reset(alpha_rad, airspeed_mps);                          // steady state at alpha
//   indicial::Predictor<>::Outputs out;
//   for (;;) {                                                 // every dt_s
//     indicial::MotionInput in{alpha_rad, q_radps, airspeed_mps};
//     indicial::StepStatus s = p.step(in, dt_s, &out);         // out.value[0] = CL, [1] = Cm
//     if (s != indicial::StepStatus::ok && s != indicial::StepStatus::angle_clamped) { ... }
//   }
//   // or, with a header made by `indicial codegen model.coef --out model.hpp --name my_model`:
//   p.load(my_model);                                          // no parsing at all
//
// Inputs per axis: pitch: motion angle alpha, rate q; roll: phi, p; yaw: psi, r. The model
// angle x is alpha in pitch and beta = asin(sin phi sin alpha0) (roll) or
// beta = asin(-sin psi cos alpha0) (yaw), computed by indicial::model_angle.
//
// Airspeed scaling: b_j(x) and con are rates in 1/s at the model's reference airspeed V_ref
// (the file's airspeed_mps). At airspeed V they are multiplied by V / V_ref and the rotary
// term uses l / V, so the model is a function of the non-dimensional time s = V t / l: at
// another airspeed every time constant scales by V / l (twice the airspeed, half the time
// constants). Example: the response at 2 V to a motion played twice as fast equals the
// response at V (tests/test_runtime.cpp checks it).
//
// Warnings
// --------
// 1. load() parses into a local ModelSet<double, Cap> and copies it in only when valid: the
//    text overload keeps up to three ModelSets on the stack at once (parser's local, the
//    parsed model, the Scalar conversion): sizeof(ModelSet<double, DefaultCapacity>) is
//    9176 bytes with GCC 12 on x86-64, so about 28 KB.
//    Load at initialisation, not from an interrupt. A refused load leaves the predictor as it
//    was (old model, old state).
// 2. After a successful load, step() refuses (StepStatus::not_reset) until reset() sets the
//    steady state: the lag states have no meaningful initial value otherwise.
// 3. An angle outside the fitted envelope [x_min_rad, x_max_rad] is clamped to it and
//    reported as StepStatus::angle_clamped; outputs are still produced (with the clamped
//    angle; the rate is used as given). The unsteady forcing stops while clamped.
// 4. Bad input (NaN, Inf, dt_s <= 0, dt_s > max_dt_s, airspeed <= 0) returns its own status
//    and changes neither the state nor *out. If finite input would produce a non-finite
//    output (absurd magnitudes, e.g. airspeed 1e-300), step() returns non_finite_result and
//    also leaves everything untouched: NaN never comes out.
// 5. Outputs::name points into the predictor's model; it stays valid until the next load().
// 6. A Snapshot belongs to the model it was taken with; restoring it after loading another
//    model gives meaningless (but finite) states.
#pragma once

#include <cmath>
#include <cstddef>
#include <limits>
#include <type_traits>

#include "indicial/coef_file.hpp"
#include "indicial/model.hpp"

namespace indicial {

// What one step() or reset() did. Every value other than ok and angle_clamped means nothing
// was changed.
enum class StepStatus : int {
  ok = 0,
  angle_clamped,         // done, but the model angle was outside the envelope and was clamped
  not_loaded,            // no model loaded
  not_reset,             // loaded, but reset() was never called since the load
  null_output,           // out == nullptr
  non_finite_input,      // an input (angle, rate, airspeed, dt) is NaN or Inf
  non_positive_dt,       // dt_s <= 0
  dt_too_large,          // dt_s > max_dt_s (almost certainly a unit error: ms for s)
  non_positive_airspeed, // airspeed_mps <= 0
  non_finite_result,     // finite but absurd input would give a non-finite output; refused
};

inline constexpr const char* to_string(StepStatus s) {
  switch (s) {
    case StepStatus::ok: return "ok";
    case StepStatus::angle_clamped: return "angle_clamped";
    case StepStatus::not_loaded: return "not_loaded";
    case StepStatus::not_reset: return "not_reset";
    case StepStatus::null_output: return "null_output";
    case StepStatus::non_finite_input: return "non_finite_input";
    case StepStatus::non_positive_dt: return "non_positive_dt";
    case StepStatus::dt_too_large: return "dt_too_large";
    case StepStatus::non_positive_airspeed: return "non_positive_airspeed";
    case StepStatus::non_finite_result: return "non_finite_result";
  }
  return "unknown_step_status";
}

// One sample of the motion. motion_angle_rad is alpha (pitch), phi (roll) or psi (yaw);
// rate_radps is q, p or r.
struct MotionInput {
  double motion_angle_rad = 0.0;
  double rate_radps = 0.0;
  double airspeed_mps = 0.0;
};

// Where the predictor is in its life: nothing loaded, loaded but not reset, running.
enum class PredictorPhase : int { empty = 0, loaded = 1, running = 2 };

// Number of evenly spaced samples (plus every knot) at which validate_for_runtime checks
// b_j(x) > 0 and finite values over the envelope.
inline constexpr int validation_samples = 4096;

namespace detail {
template <class T>
struct is_capacity : std::false_type {};
template <int P, int K, int L, int T, int C>
struct is_capacity<Capacity<P, K, L, T, C>> : std::true_type {};

template <class Cap>
inline bool model_values_finite(const CoefficientModel<double, Cap>& cm, double x) {
  double y[Cap::max_lags] = {};
  for (int j = 0; j < cm.n_lags; ++j) {
    if (!std::isfinite(spline_value(cm.lags[j].b, x))) return false;
  }
  return std::isfinite(coefficient_output(cm, x, 1.0, 1.0, y)) &&
         std::isfinite(spline_value(cm.a, x)) &&
         std::isfinite(spline_antiderivative(cm.a, x));
}
}  // namespace detail

// Everything the runtime requires of a model: validate_model_set (structure, finite values,
// capacity) plus, for every coefficient and lag j, b_j(x) > 0 over the whole envelope (so the
// lag state decays: the model is stable) and finite outputs there. b_j is sampled at
// validation_samples evenly spaced angles, at both envelope ends and just either side of each
// of its knots inside the envelope (where a step or kink can put its minimum).
template <class Cap>
inline LoadStatus validate_for_runtime(const ModelSet<double, Cap>& m, ParseDiagnostic* diag) {
  const LoadStatus s = validate_model_set(m, diag);
  if (s != LoadStatus::ok) return s;
  const double lo = m.x_min_rad;
  const double hi = m.x_max_rad;
  for (int c = 0; c < m.n_coefficients; ++c) {
    const CoefficientModel<double, Cap>& cm = m.coefficients[c];
    for (int i = 0; i <= validation_samples; ++i) {
      const double x = lo + (hi - lo) * (static_cast<double>(i) / validation_samples);
      if (!detail::model_values_finite(cm, x))
        return detail::refuse(diag, 0, "model value is not finite inside the envelope",
                              LoadStatus::invalid_value);
      for (int j = 0; j < cm.n_lags; ++j) {
        if (!(spline_value(cm.lags[j].b, x) > 0.0))
          return detail::refuse(diag, 0, "b_j(x) <= 0 inside the envelope: the lag would not decay",
                                LoadStatus::unstable_lag);
      }
    }
    for (int j = 0; j < cm.n_lags; ++j) {
      const auto& b = cm.lags[j].b;
      for (int k = 0; k < b.n_knots; ++k) {
        const double kx[2] = {std::nextafter(b.knot_rad[k], -HUGE_VAL),
                              std::nextafter(b.knot_rad[k], HUGE_VAL)};
        for (double x : kx) {
          if (x < lo || x > hi) continue;
          if (!(spline_value(b, x) > 0.0))
            return detail::refuse(diag, 0,
                                  "b_j(x) <= 0 inside the envelope: the lag would not decay",
                                  LoadStatus::unstable_lag);
        }
      }
    }
  }
  return LoadStatus::ok;
}

template <class Scalar = double, class Cap = DefaultCapacity>
class Predictor {
  static_assert(std::is_floating_point<Scalar>::value,
                "Predictor<Scalar, Cap>: Scalar must be float, double or long double "
                "(autodiff types belong to the fitter, not the runtime)");
  static_assert(detail::is_capacity<Cap>::value,
                "Predictor<Scalar, Cap>: Cap must be an indicial::Capacity<MaxPowers, MaxKnots, "
                "MaxLags, MaxTablePoints, MaxCoefficients>");

 public:
  static constexpr int max_coefficients = Cap::max_coefficients;
  static constexpr int max_lags = Cap::max_lags;
  // Largest accepted step. The update is stable for any dt, but a step over 1 s at a
  // real-time rate is almost certainly a unit error (milliseconds passed as seconds).
  static constexpr double max_dt_s = 1.0;

  struct Outputs {
    int count = 0;                        // number of coefficients (1..max_coefficients)
    Scalar value[Cap::max_coefficients] = {};
    const char* name[Cap::max_coefficients] = {};  // "CL", "Cm", ... in file order
  };

  // The whole mutable state. Laid out without padding for double and float so that two
  // snapshots can be compared bytewise.
  struct Snapshot {
    Scalar y[Cap::max_coefficients][Cap::max_lags] = {};  // lag states
    Scalar x_prev_rad = Scalar(0);  // the (clamped) model angle of the previous sample
    int phase = 0;                  // PredictorPhase as int
    int reserved = 0;               // keeps the struct free of padding bytes
  };

  using Model = ModelSet<Scalar, Cap>;

  // Parses (no heap) and validates a coefficient file; on success replaces the model and
  // leaves the predictor in PredictorPhase::loaded (reset() next).
  LoadStatus load(const char* text, std::size_t length, ParseDiagnostic* diag = nullptr) {
    ModelSet<double, Cap> parsed;
    const LoadStatus s = parse_coef_file(text, length, &parsed, diag);
    if (s != LoadStatus::ok) return s;
    return load(parsed, diag);
  }

  // Loads a model built in code or by `indicial codegen` (validated exactly like a file;
  // the static table's spline is recomputed so a hand-built model need not prepare it).
  LoadStatus load(const ModelSet<double, Cap>& model, ParseDiagnostic* diag = nullptr) {
    const LoadStatus s = validate_for_runtime(model, diag);
    if (s != LoadStatus::ok) return s;
    Model converted;
    if (!convert(model, &converted))
      return detail::refuse(diag, 0, "a model value does not fit the Scalar type",
                            LoadStatus::invalid_value);
    model_ = converted;
    state_ = Snapshot{};
    state_.phase = static_cast<int>(PredictorPhase::loaded);
    return LoadStatus::ok;
  }

  // Sets every lag state to the steady state at the given motion angle (x' = 0).
  StepStatus reset(double motion_angle_rad, double airspeed_mps) {
    if (phase() == PredictorPhase::empty) return StepStatus::not_loaded;
    if (!std::isfinite(motion_angle_rad) || !std::isfinite(airspeed_mps))
      return StepStatus::non_finite_input;
    if (!(airspeed_mps > 0.0)) return StepStatus::non_positive_airspeed;
    ClampResult clamp = clamp_model_angle(motion_angle_rad);
    Snapshot next = state_;
    for (int c = 0; c < model_.n_coefficients; ++c) {
      steady_state(model_.coefficients[c], clamp.x_rad, next.y[c]);
      for (int j = 0; j < model_.coefficients[c].n_lags; ++j) {
        if (!std::isfinite(next.y[c][j])) return StepStatus::non_finite_result;
      }
    }
    next.x_prev_rad = clamp.x_rad;
    next.phase = static_cast<int>(PredictorPhase::running);
    state_ = next;
    return clamp.clamped ? StepStatus::angle_clamped : StepStatus::ok;
  }

  // Advances the lag states from the previous sample to this one (dt_s later) and writes the
  // coefficients at this sample to *out.
  StepStatus step(const MotionInput& in, double dt_s, Outputs* out) {
    if (phase() == PredictorPhase::empty) return StepStatus::not_loaded;
    if (phase() == PredictorPhase::loaded) return StepStatus::not_reset;
    if (out == nullptr) return StepStatus::null_output;
    if (!std::isfinite(in.motion_angle_rad) || !std::isfinite(in.rate_radps) ||
        !std::isfinite(in.airspeed_mps) || !std::isfinite(dt_s))
      return StepStatus::non_finite_input;
    if (!(dt_s > 0.0)) return StepStatus::non_positive_dt;
    if (dt_s > max_dt_s) return StepStatus::dt_too_large;
    if (!(in.airspeed_mps > 0.0)) return StepStatus::non_positive_airspeed;

    const ClampResult clamp = clamp_model_angle(in.motion_angle_rad);
    const Scalar x1 = clamp.x_rad;
    const Scalar time_scale = Scalar(in.airspeed_mps / model_.airspeed_mps);
    const Scalar l_over_v_s = Scalar(model_.reference_length_m / in.airspeed_mps);
    const Scalar rate = Scalar(in.rate_radps);
    const StepGeometry<Scalar> g{state_.x_prev_rad, x1, state_.x_prev_rad, x1, Scalar(dt_s),
                                 time_scale};
    // Work on a copy; commit only if every number is finite (warning 4).
    Snapshot next = state_;
    Outputs result;
    result.count = model_.n_coefficients;
    for (int c = 0; c < model_.n_coefficients; ++c) {
      const CoefficientModel<Scalar, Cap>& cm = model_.coefficients[c];
      advance_lags(cm, g, next.y[c]);
      result.value[c] = coefficient_output(cm, x1, rate, l_over_v_s, next.y[c]);
      result.name[c] = cm.name;
      if (!std::isfinite(result.value[c])) return StepStatus::non_finite_result;
      for (int j = 0; j < cm.n_lags; ++j) {
        if (!std::isfinite(next.y[c][j])) return StepStatus::non_finite_result;
      }
    }
    next.x_prev_rad = x1;
    state_ = next;
    *out = result;
    return clamp.clamped ? StepStatus::angle_clamped : StepStatus::ok;
  }

  Snapshot snapshot() const { return state_; }

  // Restores a snapshot of this predictor (same model). Ignored while nothing is loaded.
  void restore(const Snapshot& s) {
    if (phase() == PredictorPhase::empty) return;
    state_ = s;
    // A snapshot can never bring back the empty phase over a loaded model.
    if (state_.phase != static_cast<int>(PredictorPhase::running))
      state_.phase = static_cast<int>(PredictorPhase::loaded);
  }

  PredictorPhase phase() const { return static_cast<PredictorPhase>(state_.phase); }
  const Model& model() const { return model_; }
  Axis axis() const { return model_.axis; }
  int coefficient_count() const { return model_.n_coefficients; }

 private:
  struct ClampResult {
    Scalar x_rad;
    bool clamped;
  };

  // Model angle in double (the envelope is double), clamped, then converted to Scalar.
  ClampResult clamp_model_angle(double motion_angle_rad) const {
    double x = model_angle<double>(model_.axis, model_.alpha0_rad, motion_angle_rad);
    bool clamped = false;
    // Why the clamp: the splines are fitted inside the envelope only; outside it a polynomial
    // extrapolates without data behind it.
    if (x < model_.x_min_rad) {
      x = model_.x_min_rad;
      clamped = true;
    } else if (x > model_.x_max_rad) {
      x = model_.x_max_rad;
      clamped = true;
    }
    return ClampResult{Scalar(x), clamped};
  }

  static bool fits(double v) {
    return std::isfinite(static_cast<Scalar>(v)) || !std::isfinite(v);
  }

  template <int P, int K>
  static bool convert_spline(const Spline<double, P, K>& in, Spline<Scalar, P, K>* out) {
    out->n_powers = in.n_powers;
    out->n_knots = in.n_knots;
    bool ok = true;
    for (int i = 0; i < P; ++i) {
      out->power_coef[i] = static_cast<Scalar>(in.power_coef[i]);
      ok = ok && fits(in.power_coef[i]);
    }
    for (int j = 0; j < (K > 0 ? K : 1); ++j) {
      out->knot_rad[j] = in.knot_rad[j];
      out->knot_power[j] = in.knot_power[j];
      out->knot_coef[j] = static_cast<Scalar>(in.knot_coef[j]);
      ok = ok && fits(in.knot_coef[j]);
    }
    return ok;
  }

  static bool convert(const ModelSet<double, Cap>& in, Model* out) {
    out->axis = in.axis;
    out->reference_length_m = in.reference_length_m;
    out->airspeed_mps = in.airspeed_mps;
    out->alpha0_rad = in.alpha0_rad;
    out->x_min_rad = in.x_min_rad;
    out->x_max_rad = in.x_max_rad;
    out->n_coefficients = in.n_coefficients;
    bool ok = true;
    for (int c = 0; c < Cap::max_coefficients; ++c) {
      const CoefficientModel<double, Cap>& a = in.coefficients[c];
      CoefficientModel<Scalar, Cap>& b = out->coefficients[c];
      for (std::size_t i = 0; i < sizeof a.name; ++i) b.name[i] = a.name[i];
      b.static_curve.kind = a.static_curve.kind;
      ok = convert_spline(a.static_curve.polynomial, &b.static_curve.polynomial) && ok;
      b.static_curve.n_table = a.static_curve.n_table;
      for (int i = 0; i < Cap::max_table_points; ++i) {
        b.static_curve.table_x_rad[i] = a.static_curve.table_x_rad[i];
        b.static_curve.table_value[i] = static_cast<Scalar>(a.static_curve.table_value[i]);
        ok = ok && fits(a.static_curve.table_value[i]);
      }
      ok = convert_spline(a.static_correction, &b.static_correction) && ok;
      ok = convert_spline(a.rotary, &b.rotary) && ok;
      ok = convert_spline(a.a, &b.a) && ok;
      b.n_lags = a.n_lags;
      for (int j = 0; j < Cap::max_lags; ++j) {
        ok = convert_spline(a.lags[j].b, &b.lags[j].b) && ok;
        b.lags[j].gain = static_cast<Scalar>(a.lags[j].gain);
        ok = ok && fits(a.lags[j].gain);
      }
      b.con = static_cast<Scalar>(a.con);
      b.delay_s = static_cast<Scalar>(a.delay_s);
      ok = ok && fits(a.con);
      // The natural-spline second derivatives, recomputed in Scalar by the one function that
      // defines them (a hand-built or generated model need not carry them).
      if (c < in.n_coefficients && b.static_curve.kind == StaticKind::table)
        prepare_static_table(b.static_curve);
    }
    return ok;
  }

  Model model_{};
  Snapshot state_{};
};

}  // namespace indicial
