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
// response at V (tests/test_runtime.cpp checks it). A delay (the file's delay_s, at V_ref)
// is delay_s * V_ref / V at airspeed V, the airspeed of the current step.
//
// Delayed forcing: a coefficient with delay_s > 0 drives its lag states with the angle
// x(t - delay) instead of x(t) (model.hpp, delayed_angle: linear interpolation in time of the
// stored samples). The predictor keeps a ring of the last Cap::max_delay_samples (time,
// clamped model angle) samples for that, in the Snapshot (so snapshot/restore replays bit for
// bit); reset() starts it "at rest at the reset angle since forever".
//
// What a step costs: the spline quantities at the previous sample (model.hpp's StepEnd: the
// antiderivatives B_j(x0) of b_j and A(x0) of a) were computed by the previous step as its new
// end, for the same spline at the same (clamped) angle; the predictor keeps them and evaluates
// only the new end (advance_lags_between), which gives bit for bit what advance_lags gives.
// They are a pure function of the Snapshot (x_prev_rad) and the model, so they are kept
// beside it, not in it, and rebuilt by reset() and restore(). A delayed coefficient
// recomputes A at the old end every step (x(t0 - d) moves when the airspeed, hence d,
// changes). The airspeed ratios (V / V_ref, l / V, the delay at V) are recomputed only when
// the airspeed changes.
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
//    model gives meaningless (but finite) states. With DefaultCapacity and double it is
//    4184 bytes (the delay history is 4 KB of it), so keep snapshots out of tight loops.
// 7. A delay needs history: at a fixed step dt and airspeed V a delayed model needs
//    2 + ceil(delay_s * V_ref / V / dt) samples (history_samples_needed(dt, V); 256 with
//    DefaultCapacity serve 0.254 s at 1 kHz). Until the ring has wrapped after reset() any
//    delay is served (before the first sample the motion was at rest); after that a step
//    whose t - delay falls before the oldest kept sample returns
//    StepStatus::delay_exceeds_history and changes nothing (choose a larger
//    Capacity<..., MaxDelaySamples>, a larger dt, or check history_samples_needed at start).
//    load() refuses (over_capacity) a delay_s that no step at V_ref could serve:
//    delay_s > (MaxDelaySamples - 2) * max_dt_s.
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
  delay_exceeds_history, // a delayed coefficient needs the angle further back than the
                         // history ring holds at this dt and airspeed (see warning 7)
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
    case StepStatus::delay_exceeds_history: return "delay_exceeds_history";
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
template <int P, int K, int L, int T, int C, int D>
struct is_capacity<Capacity<P, K, L, T, C, D>> : std::true_type {};

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

// Where the delay history's record begins (Predictor::Snapshot::history_origin).
enum class HistoryOrigin : int {
  rest_before_oldest = 0,  // nothing dropped since reset(): before the oldest sample the
                           // angle was the reset angle (at rest), so any delay is served
  samples_dropped = 1,     // the ring wrapped: angles older than the oldest sample are gone
};

template <class Scalar = double, class Cap = DefaultCapacity>
class Predictor {
  static_assert(std::is_floating_point<Scalar>::value,
                "Predictor<Scalar, Cap>: Scalar must be float, double or long double "
                "(autodiff types belong to the fitter, not the runtime)");
  static_assert(detail::is_capacity<Cap>::value,
                "Predictor<Scalar, Cap>: Cap must be an indicial::Capacity<MaxPowers, MaxKnots, "
                "MaxLags, MaxTablePoints, MaxCoefficients[, MaxDelaySamples]>");

 public:
  static constexpr int max_coefficients = Cap::max_coefficients;
  static constexpr int max_lags = Cap::max_lags;
  // Samples of (time, model angle) kept for delayed coefficients, the current one included.
  static constexpr int history_capacity = Cap::max_delay_samples;
  // Largest accepted step. The update is stable for any dt, but a step over 1 s at a
  // real-time rate is almost certainly a unit error (milliseconds passed as seconds).
  static constexpr double max_dt_s = 1.0;

  struct Outputs {
    int count = 0;                        // number of coefficients (1..max_coefficients)
    Scalar value[Cap::max_coefficients] = {};
    const char* name[Cap::max_coefficients] = {};  // "CL", "Cm", ... in file order
  };

 private:
  // Number of int words that make Snapshot free of padding for double and float: the
  // 4-byte words (ints, and the Scalars when Scalar is float) must fill whole 8-byte units
  // after the leading doubles. At least 1 (no zero-length arrays).
  static constexpr int snapshot_scalar_count =
      Cap::max_coefficients * Cap::max_lags + 1 + Cap::max_delay_samples;
  static constexpr int snapshot_int_count = 4;  // phase, newest, count, origin
  static constexpr int snapshot_four_byte_words =
      (sizeof(Scalar) == 4 ? snapshot_scalar_count : 0) + snapshot_int_count;
  static constexpr int snapshot_pad_ints = (snapshot_four_byte_words % 2 == 0) ? 2 : 1;

 public:
  // The whole mutable state. Laid out without padding for double and float so that two
  // snapshots can be compared bytewise (doubles first, then Scalars, then ints).
  struct Snapshot {
    double time_s = 0.0;  // time of the newest sample, counted from reset() (t = 0)
    // The delay history: a ring of the last history_count samples, newest at slot
    // history_newest, older ones at decreasing slots (modulo history_capacity). Unused slots
    // are 0. Kept for every model (delayed or not) so that a snapshot is always complete.
    double history_time_s[Cap::max_delay_samples] = {};
    Scalar y[Cap::max_coefficients][Cap::max_lags] = {};  // lag states
    Scalar x_prev_rad = Scalar(0);  // the (clamped) model angle of the previous sample
    Scalar history_x_rad[Cap::max_delay_samples] = {};    // the (clamped) model angles
    int phase = 0;                  // PredictorPhase as int
    int history_newest = 0;         // slot of the newest sample
    int history_count = 0;          // samples held: 1..history_capacity once running
    int history_origin = 0;         // HistoryOrigin as int
    int reserved[snapshot_pad_ints] = {};  // keeps the struct free of padding bytes
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
    for (int c = 0; c < model.n_coefficients; ++c) {
      // Why: at the reference airspeed the ring serves (history_capacity - 2) steps of at
      // most max_dt_s; a longer delay could never be served by any accepted step.
      if (model.coefficients[c].delay_s > (history_capacity - 2) * max_dt_s)
        return detail::refuse(diag, 0,
                              "delay_s is longer than the runtime's delay history can hold "
                              "even at max_dt_s (raise Capacity's MaxDelaySamples)",
                              LoadStatus::over_capacity);
    }
    Model converted;
    if (!convert(model, &converted))
      return detail::refuse(diag, 0, "a model value does not fit the Scalar type",
                            LoadStatus::invalid_value);
    model_ = converted;
    state_ = Snapshot{};
    state_.phase = static_cast<int>(PredictorPhase::loaded);
    ends_ = Ends{};
    airspeed_ = AirspeedTerms{};
    return LoadStatus::ok;
  }

  // Sets every lag state to the steady state at the given motion angle (x' = 0), and the
  // delay history to "at rest at that angle since forever": one sample at t = 0, the other
  // slots cleared, origin rest_before_oldest.
  StepStatus reset(double motion_angle_rad, double airspeed_mps) {
    if (phase() == PredictorPhase::empty) return StepStatus::not_loaded;
    if (!std::isfinite(motion_angle_rad) || !std::isfinite(airspeed_mps))
      return StepStatus::non_finite_input;
    if (!(airspeed_mps > 0.0)) return StepStatus::non_positive_airspeed;
    ClampResult clamp = clamp_model_angle(motion_angle_rad);
    Scalar y[Cap::max_coefficients][Cap::max_lags] = {};
    for (int c = 0; c < model_.n_coefficients; ++c) {
      steady_state(model_.coefficients[c], clamp.x_rad, y[c]);
      for (int j = 0; j < model_.coefficients[c].n_lags; ++j) {
        if (!std::isfinite(y[c][j])) return StepStatus::non_finite_result;
      }
    }
    for (int c = 0; c < Cap::max_coefficients; ++c)
      for (int j = 0; j < Cap::max_lags; ++j) state_.y[c][j] = y[c][j];
    for (int i = 0; i < history_capacity; ++i) {
      state_.history_time_s[i] = 0.0;
      state_.history_x_rad[i] = Scalar(0);
    }
    state_.time_s = 0.0;
    state_.history_x_rad[0] = clamp.x_rad;
    state_.history_newest = 0;
    state_.history_count = 1;
    state_.history_origin = static_cast<int>(HistoryOrigin::rest_before_oldest);
    state_.x_prev_rad = clamp.x_rad;
    state_.phase = static_cast<int>(PredictorPhase::running);
    // At rest the forcing angle is the model angle, delay or not (delayed_angle of a one-sample
    // history is that sample).
    evaluate_ends();
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
    // The same divisions as ever, done once per airspeed (bit-identical: same operands).
    const AirspeedTerms& v = airspeed_terms(in.airspeed_mps);
    const Scalar time_scale = v.time_scale;
    const Scalar l_over_v_s = v.l_over_v_s;
    const Scalar rate = Scalar(in.rate_radps);
    const double t0_s = state_.time_s;
    const double t1_s = t0_s + dt_s;
    // The history as it will be after this step: the new sample on top of the ring (whose
    // oldest sample drops out if the ring is full). Nothing is written until the commit.
    const bool ring_full = state_.history_count >= history_capacity;
    const HistoryView view{&state_, t1_s, x1,
                           ring_full ? history_capacity : state_.history_count + 1};
    const bool rest_before_oldest =
        !ring_full &&
        state_.history_origin == static_cast<int>(HistoryOrigin::rest_before_oldest);

    // Work on copies; commit only if every number is finite (warning 4).
    Scalar y[Cap::max_coefficients][Cap::max_lags];
    Ends new_ends;  // the spline quantities at this sample: the next step's old end
    Outputs result;
    result.count = model_.n_coefficients;
    for (int c = 0; c < model_.n_coefficients; ++c) {
      const CoefficientModel<Scalar, Cap>& cm = model_.coefficients[c];
      for (int j = 0; j < Cap::max_lags; ++j) y[c][j] = state_.y[c][j];
      StepGeometry<Scalar> g{state_.x_prev_rad, x1, state_.x_prev_rad, x1, Scalar(dt_s),
                             time_scale};
      // The old end as the previous step (or reset/restore) left it: B_j(x_prev) and, without
      // a delay, A(x_prev) -- bit for bit what advance_lags would evaluate again.
      const StepEnd<Scalar, Cap>* end0 = &ends_.end[c];
      StepEnd<Scalar, Cap> delayed_end0;
      // Why the branch: an undelayed coefficient uses the sample angles themselves, exactly
      // as before delays existed (bit for bit); only a delayed one reads the history.
      if (cm.delay_s != Scalar(0)) {
        // Times in double (model.hpp warning 5): the delay at this airspeed, then x(t - d)
        // at both ends of the step by the shared interpolation.
        const double d_s = v.delay_s[c];
        // Why: t0 - d before the oldest kept sample, with older samples already dropped, is
        // an angle the runtime no longer knows; refuse rather than guess (warning 7). The
        // comparison is delayed_angle's own (age of the oldest sample < delay).
        if (!rest_before_oldest && !(d_s <= t0_s - view.time_s(view.size() - 1)))
          return StepStatus::delay_exceeds_history;
        g.forcing_x0_rad = Scalar(delayed_angle(view, t0_s, d_s));
        g.forcing_x1_rad = Scalar(delayed_angle(view, t1_s, d_s));
        // Why recomputed: x(t0 - d) is the previous step's x(t1 - d) only while d (i.e. the
        // airspeed) is unchanged; evaluating A there every step is always exact. B_j(x0) stays
        // valid: x0 is the previous clamped model angle whatever the delay.
        delayed_end0 = *end0;
        delayed_end0.forcing_antiderivative = spline_antiderivative(cm.a, g.forcing_x0_rad);
        end0 = &delayed_end0;
      }
      evaluate_step_end(cm, g.x1_rad, g.forcing_x1_rad, &new_ends.end[c]);
      advance_lags_between(cm, g, *end0, new_ends.end[c], y[c]);
      result.value[c] = coefficient_output(cm, x1, rate, l_over_v_s, y[c]);
      result.name[c] = cm.name;
      if (!std::isfinite(result.value[c])) return StepStatus::non_finite_result;
      for (int j = 0; j < cm.n_lags; ++j) {
        if (!std::isfinite(y[c][j])) return StepStatus::non_finite_result;
      }
    }
    // Commit.
    for (int c = 0; c < model_.n_coefficients; ++c)
      for (int j = 0; j < Cap::max_lags; ++j) state_.y[c][j] = y[c][j];
    const int slot = state_.history_newest + 1 == history_capacity ? 0 : state_.history_newest + 1;
    state_.history_time_s[slot] = t1_s;
    state_.history_x_rad[slot] = x1;
    state_.history_newest = slot;
    if (ring_full) state_.history_origin = static_cast<int>(HistoryOrigin::samples_dropped);
    else ++state_.history_count;
    state_.time_s = t1_s;
    state_.x_prev_rad = x1;
    for (int c = 0; c < model_.n_coefficients; ++c) ends_.end[c] = new_ends.end[c];
    *out = result;
    return clamp.clamped ? StepStatus::angle_clamped : StepStatus::ok;
  }

  // How many history samples a run at a fixed step dt_s and airspeed needs so that no step
  // returns delay_exceeds_history: 2 + ceil(d / dt_s) with d the longest delay of the model
  // at that airspeed (2 without a delay: the two samples of the step). Compare it with
  // history_capacity at initialisation. Conservative by one sample when d / dt_s is an exact
  // integer (accumulated sample times round either way). 0 when nothing is loaded or dt_s /
  // airspeed_mps is not finite and > 0; saturates at INT_MAX for absurd ratios.
  int history_samples_needed(double dt_s, double airspeed_mps) const {
    if (phase() == PredictorPhase::empty) return 0;
    if (!std::isfinite(dt_s) || !(dt_s > 0.0) || !std::isfinite(airspeed_mps) ||
        !(airspeed_mps > 0.0))
      return 0;
    double longest_s = 0.0;
    for (int c = 0; c < model_.n_coefficients; ++c) {
      const double d = delay_at_airspeed(static_cast<double>(model_.coefficients[c].delay_s),
                                         model_.airspeed_mps, airspeed_mps);
      if (d > longest_s) longest_s = d;
    }
    const double steps = std::ceil(longest_s / dt_s * (1.0 + 1e-9));
    // Why the saturation: the ratio may exceed int's range (tiny dt, tiny airspeed).
    if (!(steps < static_cast<double>(std::numeric_limits<int>::max() - 2)))
      return std::numeric_limits<int>::max();
    return 2 + static_cast<int>(steps);
  }

  Snapshot snapshot() const { return state_; }

  // Restores a snapshot of this predictor (same model). Ignored while nothing is loaded.
  void restore(const Snapshot& s) {
    if (phase() == PredictorPhase::empty) return;
    state_ = s;
    // A snapshot can never bring back the empty phase over a loaded model.
    if (state_.phase != static_cast<int>(PredictorPhase::running))
      state_.phase = static_cast<int>(PredictorPhase::loaded);
    // The cached old end is a function of the restored x_prev_rad (see the essay): rebuilt,
    // so a restored predictor steps bit for bit like the one the snapshot was taken from.
    else
      evaluate_ends();
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

  // The spline quantities at the previous sample, per coefficient (model.hpp's StepEnd).
  struct Ends {
    StepEnd<Scalar, Cap> end[Cap::max_coefficients];
  };

  // Per-airspeed constants of step(). airspeed_mps = 0 means "none cached": step() accepts
  // only airspeeds > 0, so it never matches.
  struct AirspeedTerms {
    double airspeed_mps = 0.0;
    Scalar time_scale = Scalar(0);  // V / V_ref
    Scalar l_over_v_s = Scalar(0);  // l / V
    double delay_s[Cap::max_coefficients] = {};  // each coefficient's delay at V
  };

  const AirspeedTerms& airspeed_terms(double airspeed_mps) {
    // Why the exact comparison: the cached values are the same expressions of the same
    // operand, so reusing them for an equal airspeed is bit-identical; any other airspeed
    // recomputes.
    if (airspeed_mps != airspeed_.airspeed_mps) {
      airspeed_.airspeed_mps = airspeed_mps;
      airspeed_.time_scale = Scalar(airspeed_mps / model_.airspeed_mps);
      airspeed_.l_over_v_s = Scalar(model_.reference_length_m / airspeed_mps);
      for (int c = 0; c < model_.n_coefficients; ++c)
        airspeed_.delay_s[c] = delay_at_airspeed(static_cast<double>(model_.coefficients[c].delay_s),
                                                 model_.airspeed_mps, airspeed_mps);
    }
    return airspeed_;
  }

  // The old end of the next step at the current x_prev_rad, the forcing angle taken equal to
  // it (right for every undelayed coefficient; a delayed one recomputes its A each step).
  void evaluate_ends() {
    for (int c = 0; c < model_.n_coefficients; ++c)
      evaluate_step_end(model_.coefficients[c], state_.x_prev_rad, state_.x_prev_rad,
                        &ends_.end[c]);
  }

  // The delay history seen newest-first by indicial::delayed_angle (model.hpp): index 0 is
  // the pending new sample, index i >= 1 the ring's (i-1)-th newest. Reads only.
  struct HistoryView {
    const Snapshot* s;
    double new_time_s;
    Scalar new_x_rad;
    int n;
    int size() const { return n; }
    int slot(int i) const {
      const int k = s->history_newest - (i - 1);
      return k < 0 ? k + history_capacity : k;
    }
    double time_s(int i) const { return i == 0 ? new_time_s : s->history_time_s[slot(i)]; }
    Scalar x_rad(int i) const { return i == 0 ? new_x_rad : s->history_x_rad[slot(i)]; }
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
      ok = ok && fits(a.con) && fits(a.delay_s);
      // The natural-spline second derivatives, recomputed in Scalar by the one function that
      // defines them (a hand-built or generated model need not carry them).
      if (c < in.n_coefficients && b.static_curve.kind == StaticKind::table)
        prepare_static_table(b.static_curve);
    }
    return ok;
  }

  Model model_{};
  Snapshot state_{};
  Ends ends_{};              // derived from state_ and model_ (rebuilt by reset, restore)
  AirspeedTerms airspeed_{};  // derived from model_ and the last airspeed
};

}  // namespace indicial
