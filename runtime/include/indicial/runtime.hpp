// indicial/runtime.hpp -- the embedded runtime: run a fitted model in a real-time loop.
//
// What it is for
// --------------
// A flight simulator (or a wind-tunnel controller, a Monte Carlo batch) feeds the motion of
// the aircraft, one sample at a time, and needs the aerodynamic coefficients at that sample,
// including the unsteady (lag) part identified by the fitter. This header does that with no
// heap, no exceptions and no RTTI; every call returns a status enum. The equations are those
// of indicial/model.hpp (advance_lags_between, coefficient_output, steady_state): the runtime
// adds input checks, clamping and bookkeeping, never equations of its own.
//
// Two pieces, kept apart:
//   * RuntimeModel<Scalar, Cap>: immutable (the validated ModelSet in Scalar plus a few
//     per-model constants). Constexpr-constructible -- `indicial codegen` emits one that lives
//     in read-only memory (flash) and is used in place -- and shared by any number of states.
//   * State<Scalar, Cap>: per instance, only what changes (lag states, the previous sample's
//     cached spline ends, the last airspeed's terms): 160 bytes for double and
//     DefaultCapacity (up to 3 coefficients, 2 lags). FamilyState adds the dynamic-stall
//     family states (below), DelayedState the history ring that a model with a delay needs
//     (about 4 KB with DefaultCapacity).
// The stateless core is reset(model, state, angle, airspeed) and
// step(model, state, input, dt, out); step_batch steps N states of one model. Predictor is
// the convenience of one instance: a model (its own copy, or a shared one by reference) and a
// DelayedState behind member functions.
//
// Which header for what
// ---------------------
//   indicial/runtime.hpp      this file: models, states, step, Predictor (no parser, no
//                             <charconv>): all a codegen-only firmware includes.
//   indicial/coef_file.hpp    the coefficient-file parser and writer, Predictor::load(text)
//                             and load_runtime_model(text): include it to load text.
//   indicial/model_check.hpp  LoadStatus, ParseDiagnostic, validate_model_set (included here).
//   indicial/batch.hpp        step_batch: N states of one model on lane vectors (SIMD), a
//                             portable and, on x86-64, a run-time-chosen AVX2 kernel.
//   indicial/indicial.h       the C99 interface (library indicial::c).
//
// Usage
// -----
//   // One instance, from a file's text (#include "indicial/coef_file.hpp" for load(text)):
//   indicial::Predictor<> p;                                   // double, DefaultCapacity
//   if (p.load(text, text_length) != indicial::LoadStatus::ok) { /* refuse to fly */ }
//   p.reset(alpha_rad, airspeed_mps);                          // steady state at alpha
//   indicial::Predictor<>::Outputs out;
//   for (;;) {                                                 // every dt_s
//     indicial::MotionInput in{alpha_rad, q_radps, airspeed_mps};
//     indicial::StepStatus s = p.step(in, dt_s, &out);         // out.value[0] = CL, [1] = Cm
//     if (s != indicial::StepStatus::ok && s != indicial::StepStatus::angle_clamped) { ... }
//   }
//
//   // Many instances of one generated model (`indicial codegen model.coef --out model.hpp
//   // --name my_model`, namespace indicial_generated), the model never copied:
//   #include "model.hpp"                                       // and runtime.hpp, nothing else
//   using namespace indicial;
//   if (check_runtime_model(indicial_generated::my_model) != LoadStatus::ok) { ... }  // once
//   State<double, DefaultCapacity> s[64];
//   for (auto& si : s) reset(indicial_generated::my_model, si, alpha_rad, airspeed_mps);
//   double c[DefaultCapacity::max_coefficients];
//   step(indicial_generated::my_model, s[0], MotionInput{alpha_rad, q_radps, v_mps}, dt_s, c);
//
// Inputs per axis: pitch: motion angle alpha, rate q; roll: phi, p; yaw: psi, r. The model
// angle x is alpha in pitch and beta = asin(sin phi sin alpha0) (roll) or
// beta = asin(-sin psi cos alpha0) (yaw), computed by indicial::model_angle_from_factor with
// the factor kept in the RuntimeModel.
//
// Airspeed scaling: b_j(x) and con are rates in 1/s at the model's reference airspeed V_ref
// (the file's airspeed_mps). At airspeed V they are multiplied by V / V_ref and the rotary
// term uses l / V, so the model is a function of the non-dimensional time s = V t / l: at
// another airspeed every time constant scales by V / l (twice the airspeed, half the time
// constants). A delay (the file's delay_s, at V_ref) is delay_s * V_ref / V at airspeed V.
//
// Delayed forcing: a coefficient with delay_s > 0 drives its lag states with the angle
// x(t - delay) instead of x(t) (model.hpp, delayed_angle: linear interpolation in time of the
// stored samples). A DelayedState keeps a ring of the last Cap::max_delay_samples (time,
// clamped model angle) samples for that; reset() starts it "at rest at the reset angle since
// forever". An undelayed model never touches the ring.
//
// What a step costs: the spline quantities at the previous sample (model.hpp's StepEnd: the
// antiderivatives B_j(x0) of b_j and A(x0) of a) were computed by the previous step as its new
// end; the state keeps them and a step evaluates only the new end (advance_lags_between),
// which gives bit for bit what advance_lags gives. The step works in place on the State after
// one block copy of what it overwrites (StepBackup), tests every number it keeps with one
// isfinite (finite_test), and copies the block back if one is not finite; its input checks
// are tests of the inputs' bit patterns. The State's step runs the coefficients unrolled
// over the capacity (detail::CoefficientLoop). A delayed coefficient recomputes A at the
// old end every step. The airspeed ratios (V / V_ref, l / V, the delay at V) are recomputed
// only when the airspeed changes. With Scalar = float every per-step operation is in float
// (clamp, axis factor, airspeed ratios), except the delayed path's clock, which is double.
//
// Dynamic-stall families (issue 22)
// ---------------------------------
// A coefficient may carry model.hpp's separation and leading-edge-vortex families
// (CoefficientModel::stall; the equations, units and feasible set are model.hpp's essay
// "Dynamic stall: equations"). The runtime steps them and adds nothing of its own:
//   * the state: model.hpp's StallState per coefficient (separation point, vortex lift,
//     vortex clock, forcing angle) in a FamilyState, a State plus those (256 bytes for double,
//     136 for float with DefaultCapacity; 184 and 96 for C_L + C_m in a two-coefficient
//     capacity). Why a state type of its own rather than room in every State or a
//     Capacity parameter: a model without families pays nothing (its State stays 160 / 88
//     bytes) under the same Capacity that codegen and the C API use, as the delay ring lives
//     only in DelayedState -- which derives from FamilyState, so the Predictor's Snapshot
//     carries the family states too (Snapshot::stall[c]).
//   * the step: after each coefficient's lags, advance_stall(cm.stall, StallStep{x0, x1, dt,
//     l / V}, &state) on the step's clamped angles, and value = coefficient_output(...) +
//     stall_output(cm.stall, x1, state) -- the fitter's sum, so they agree bit for bit -- all
//     in place, restored unless every number is finite; reset sets stall_steady_state.
//     A family model stepped with a plain State returns StepStatus::families_need_state
//     (RuntimeModel::stall says whether a model has families).
//   * shared lookups (issue 22 item 6): a coefficient whose f0 table (and T2, and T1) equal an
//     earlier coefficient's, bit for bit, takes that coefficient's table values and decay
//     (model.hpp's StallLookups) instead of computing them again: the same numbers, hence the
//     same bits. Which coefficient repeats which is a step constant (RuntimeModel::
//     stall_sharing, derive_stall_sharing). Coefficients fitted from one lift polar share
//     the f0 table (the output's lookup at x1, and the lagged ones with the same T2); a C_m
//     whose T1 and T2 are held at the C_L fit's values (model.stall_known, as Beddoes-
//     Leishman's moment takes its separation dynamics from the lift, tools/validate_stall.py)
//     shares every lookup: three of six table lookups and one of two exp(-h / T1) per step,
//     and, with the same T1r and f0 correction, the separation update itself while the two
//     separation points are the same bits (StallSharing::separation: f1, K(f0), K(f1), f0c(x1)
//     and its K computed once).
//   * validation: validate_model_set applies model.hpp's check_stall_parameters (the feasible
//     set: positive time constants, f0 in [0, 1], ...); validate_for_runtime also checks the
//     family outputs finite over the envelope.
//   * the coefficient file: version 2 keys sep_* and vortex_* (coef_file.hpp,
//     docs/architecture.md), written only for a model with a family.
//
// Warnings
// --------
// 1. A model is validated once: make_runtime_model / Predictor::load validate and convert;
//    a RuntimeModel built elsewhere (codegen) must pass check_runtime_model before its first
//    step (step() itself trusts the model). Loading from text keeps up to three ModelSets on
//    the stack (about 40 KB with DefaultCapacity, double): load at initialisation, not from
//    an interrupt. A refused load leaves the predictor as it was (old model, old state).
// 2. After a load, step() refuses (StepStatus::not_reset) until reset() sets the steady
//    state; a default-constructed State is "never reset" too.
// 3. An angle outside the fitted envelope [x_min_rad, x_max_rad] is reported as
//    StepStatus::angle_clamped and outputs are still produced (finite, never NaN): the
//    unsteady term is held at the envelope's edge (its forcing a(x) x' stops while outside, so
//    the lags relax toward their steady state at the edge with b_j(edge)); every fitted term
//    (a polynomial static curve, the static correction, the rotary term) is evaluated at the
//    edge; a static TABLE is evaluated at the true angle over its own rows (held at its first
//    or last row beyond them). The rate is used as given. Decided in model.hpp's
//    coefficient_output; the batch, the C API, predict and the fit's replay all step here.
// 4. Bad input (NaN, Inf, dt_s <= 0, dt_s > max_step_dt_s, airspeed <= 0) returns its own
//    status and changes neither the state nor the outputs. If finite input would produce a
//    non-finite output (absurd magnitudes, e.g. airspeed 1e-300), step() returns
//    non_finite_result and also leaves everything untouched: NaN never comes out.
// 5. Outputs::name points into the model; it stays valid until the next load(). A model
//    used in place (Predictor::use, the free functions) must outlive its states' use of it.
// 6. A state (Snapshot) belongs to the model it was reset with; stepping it with another
//    model gives meaningless (but finite) states. A Predictor's Snapshot is a DelayedState
//    (4.3 KB with DefaultCapacity and double): keep snapshots out of tight loops.
// 7. A delay needs history: at a fixed step dt and airspeed V a delayed model needs
//    2 + ceil(delay_s * V_ref / V / dt) samples (history_samples_needed(dt, V); 256 with
//    DefaultCapacity serve 0.254 s at 1 kHz). Until the ring has wrapped after reset() any
//    delay is served (before the first sample the motion was at rest); after that a step
//    whose t - delay falls before the oldest kept sample returns
//    StepStatus::delay_exceeds_history and changes nothing (choose a larger
//    Capacity<..., MaxDelaySamples>, a larger dt, or check history_samples_needed at start).
//    Loading refuses (over_capacity) a delay_s that no step at V_ref could serve:
//    delay_s > (MaxDelaySamples - 2) * max_step_dt_s. Stepping a delayed model with a plain
//    State returns StepStatus::delay_needs_history.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <type_traits>

#include "indicial/model.hpp"
#include "indicial/model_check.hpp"

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
  delay_needs_history,   // a model with a delay stepped with a State (no ring): use a
                         // DelayedState (or Predictor) for it
  families_need_state,   // a model with dynamic-stall families stepped with a State (no
                         // family states): use a FamilyState, DelayedState or Predictor
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
    case StepStatus::delay_needs_history: return "delay_needs_history";
    case StepStatus::families_need_state: return "families_need_state";
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

// Where a predictor (or a State) is in its life: nothing loaded, loaded but not reset,
// running. A State knows only loaded (never reset) and running.
enum class PredictorPhase : int { empty = 0, loaded = 1, running = 2 };

// Whether a model has a delayed coefficient (then it needs a DelayedState).
enum class DelayUse : int { none = 0, delayed = 1 };

// Whether a model has a coefficient with dynamic-stall families (then it needs a FamilyState
// or a DelayedState: a plain State has no room for the family states).
enum class StallUse : int { none = 0, families = 1 };

// Which earlier coefficient's dynamic-stall lookups (model.hpp's StallLookups) a coefficient
// with families repeats: the index of the first earlier coefficient with families and the same
// f0 table (table: the table's value at the step's angle), the same table and T2 (forcing: the
// same lagged angles and table values), the same T1 (decay: exp(-h / T1) and phi1), or
// no_sharing (compute its own). Same means bit for bit; derive_stall_sharing derives it.
// separation: the first earlier coefficient with the same families whose separation update
// and static separation are the same (the forcing and decay above, T1r and the f0 correction):
// from the same separation point it reaches the same new one, and at the step's angle the same
// f0c(x) (issue 22 item 6: the C_L and C_m of one polar, as Beddoes-Leishman's moment takes its
// separation from the lift). A step repeats that update only when the two separation points
// are the same bits before it (advance_families), so the numbers are the unshared ones.
struct StallSharing {
  static constexpr int no_sharing = -1;
  int table = no_sharing;
  int forcing = no_sharing;
  int decay = no_sharing;
  int separation = no_sharing;
};

// Largest accepted step. The update is stable for any dt, but a step over 1 s at a real-time
// rate is almost certainly a unit error (milliseconds passed as seconds).
inline constexpr double max_step_dt_s = 1.0;

// Number of evenly spaced samples (plus every knot) at which validate_for_runtime checks
// b_j(x) > 0 and finite values over the envelope.
inline constexpr int validation_samples = 4096;

namespace detail {
template <class T>
struct is_capacity : std::false_type {};
template <int P, int K, int L, int T, int C, int D>
struct is_capacity<Capacity<P, K, L, T, C, D>> : std::true_type {};

// The families' outputs at angle x for the ends of the separation state (f = 0 and 1, a unit
// vortex over the chord and past it) and the static separation there.
template <class Scalar, class Cap>
inline bool stall_values_finite(const StallModel<Scalar, Cap>& st, Scalar x) {
  if (st.families == StallFamilies::none) return true;
  if (!std::isfinite(static_separation(st.separation, x))) return false;
  const StallState<Scalar> ends[2] = {{Scalar(0), Scalar(1), Scalar(0)},
                                      {Scalar(1), Scalar(1), st.vortex.travel_semichords}};
  for (const StallState<Scalar>& e : ends)
    if (!std::isfinite(stall_output(st, x, e))) return false;
  return true;
}

template <class Scalar, class Cap>
inline bool model_values_finite(const CoefficientModel<Scalar, Cap>& cm, Scalar x) {
  Scalar y[Cap::max_lags] = {};
  for (int j = 0; j < cm.n_lags; ++j) {
    if (!std::isfinite(spline_value(cm.lags[j].b, x))) return false;
  }
  return std::isfinite(coefficient_output(cm, x, Scalar(1), Scalar(1), y)) &&
         std::isfinite(spline_value(cm.a, x)) && std::isfinite(spline_antiderivative(cm.a, x)) &&
         stall_values_finite(cm.stall, x);
}

template <class Scalar, class Cap>
inline LoadStatus check_lags_decay(const CoefficientModel<Scalar, Cap>& cm, double lo, double hi,
                                   ParseDiagnostic* diag) {
  for (int i = 0; i <= validation_samples; ++i) {
    const Scalar x = Scalar(lo + (hi - lo) * (static_cast<double>(i) / validation_samples));
    if (!model_values_finite(cm, x))
      return refuse(diag, 0, "model value is not finite inside the envelope",
                    LoadStatus::invalid_value);
    for (int j = 0; j < cm.n_lags; ++j) {
      if (!(spline_value(cm.lags[j].b, x) > Scalar(0)))
        return refuse(diag, 0, "b_j(x) <= 0 inside the envelope: the lag would not decay",
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
        if (!(spline_value(b, Scalar(x)) > Scalar(0)))
          return refuse(diag, 0, "b_j(x) <= 0 inside the envelope: the lag would not decay",
                        LoadStatus::unstable_lag);
      }
    }
  }
  return LoadStatus::ok;
}
}  // namespace detail

// Everything the runtime requires of a model: validate_model_set (structure, finite values,
// capacity) plus, for every coefficient and lag j, b_j(x) > 0 over the whole envelope (so the
// lag state decays: the model is stable) and finite outputs there. b_j is sampled at
// validation_samples evenly spaced angles, at both envelope ends and just either side of each
// of its knots inside the envelope (where a step or kink can put its minimum).
template <class Scalar, class Cap>
inline LoadStatus validate_for_runtime(const ModelSet<Scalar, Cap>& m, ParseDiagnostic* diag) {
  const LoadStatus s = validate_model_set(m, diag);
  if (s != LoadStatus::ok) return s;
  for (int c = 0; c < m.n_coefficients; ++c) {
    const LoadStatus d = detail::check_lags_decay(m.coefficients[c], m.x_min_rad, m.x_max_rad, diag);
    if (d != LoadStatus::ok) return d;
  }
  return LoadStatus::ok;
}

// ------------------------------------------------------------------------------------------
// The immutable model: a validated ModelSet in the step's scalar type plus the per-model
// constants a step needs, so that a step does no double arithmetic for Scalar = float and no
// trigonometry of alpha0. Constexpr-constructible (indicial codegen emits one), shareable by
// any number of states, placeable in read-only memory. Build it with make_runtime_model (from
// a ModelSet<double>) or, for a generated one, check it once with check_runtime_model.
// ------------------------------------------------------------------------------------------
template <class Scalar, class Cap>
struct RuntimeModel {
  ModelSet<Scalar, Cap> set;
  Scalar x_min_rad = Scalar(0);     // the envelope, in Scalar (the step clamps in Scalar)
  Scalar x_max_rad = Scalar(0);
  Scalar angle_factor = Scalar(1);  // model_angle_factor(axis, alpha0_rad)
  Scalar reference_length_m = Scalar(1);
  Scalar airspeed_mps = Scalar(1);  // V_ref
  DelayUse delay = DelayUse::none;
  StallUse stall = StallUse::none;
  StallSharing stall_sharing[Cap::max_coefficients] = {};  // derive_stall_sharing
};

namespace detail {
// Bit for bit (== would take -0.0 for +0.0, and a shared step must give the unshared one's
// bits): the sharing below is decided on the numbers' representations.
template <class T>
inline bool same_bits(const T& a, const T& b) {
  return std::memcmp(&a, &b, sizeof(T)) == 0;
}

template <class Scalar, class Cap>
inline bool same_f0_table(const SeparationParameters<Scalar, Cap>& a, const SeparationParameters<Scalar, Cap>& b) {
  if (a.n_f0 != b.n_f0) return false;
  for (int i = 0; i < a.n_f0; ++i)
    if (!same_bits(a.f0_x_rad[i], b.f0_x_rad[i]) || !same_bits(a.f0_value[i], b.f0_value[i])) return false;
  return true;
}

template <class Scalar, int P, int K>
inline bool same_spline(const Spline<Scalar, P, K>& a, const Spline<Scalar, P, K>& b) {
  if (a.n_powers != b.n_powers || a.n_knots != b.n_knots) return false;
  for (int i = 0; i < a.n_powers; ++i)
    if (!same_bits(a.power_coef[i], b.power_coef[i])) return false;
  for (int j = 0; j < a.n_knots; ++j)
    if (!same_bits(a.knot_rad[j], b.knot_rad[j]) || a.knot_power[j] != b.knot_power[j] ||
        !same_bits(a.knot_coef[j], b.knot_coef[j]))
      return false;
  return true;
}
}  // namespace detail

// RuntimeModel::stall_sharing of a set: for each coefficient with families, the first earlier
// one with families whose table / table and T2 / T1 are the same, bit for bit (same_bits).
template <class Scalar, class Cap>
inline void derive_stall_sharing(const ModelSet<Scalar, Cap>& s, StallSharing* sharing) {
  for (int c = 0; c < Cap::max_coefficients; ++c) sharing[c] = StallSharing{};
  for (int c = 0; c < s.n_coefficients; ++c) {
    const StallModel<Scalar, Cap>& a = s.coefficients[c].stall;
    if (a.families == StallFamilies::none) continue;
    for (int e = c - 1; e >= 0; --e) {  // downwards: the first such coefficient wins
      const StallModel<Scalar, Cap>& b = s.coefficients[e].stall;
      if (b.families == StallFamilies::none) continue;
      const bool table = detail::same_f0_table(a.separation, b.separation);
      if (table) sharing[c].table = e;
      // first_order: the lagged angles are each coefficient's own state's (look_up_families)
      if (table && a.separation.forcing_lag == ForcingLag::delay && b.separation.forcing_lag == ForcingLag::delay &&
          detail::same_bits(a.separation.tau2_semichords, b.separation.tau2_semichords) &&
          detail::same_bits(a.separation.lag_limit_rad, b.separation.lag_limit_rad))
        sharing[c].forcing = e;
      if (detail::same_bits(a.separation.tau1_semichords, b.separation.tau1_semichords)) sharing[c].decay = e;
      if (sharing[c].forcing == e && sharing[c].decay == e && a.families == b.families &&
          detail::same_bits(a.separation.tau1_reattach_semichords, b.separation.tau1_reattach_semichords) &&
          detail::same_bits(a.separation.reattach_shift_rad, b.separation.reattach_shift_rad) &&
          detail::same_spline(a.separation.f0_correction, b.separation.f0_correction))
        sharing[c].separation = e;
    }
  }
}

// The per-model constants of a RuntimeModel, derived from its set (the one definition, used
// by make_runtime_model, check_runtime_model and indicial codegen).
template <class Scalar, class Cap>
inline void derive_step_constants(RuntimeModel<Scalar, Cap>* m) {
  const ModelSet<Scalar, Cap>& s = m->set;
  m->x_min_rad = Scalar(s.x_min_rad);
  m->x_max_rad = Scalar(s.x_max_rad);
  m->angle_factor = Scalar(model_angle_factor(s.axis, s.alpha0_rad));
  m->reference_length_m = Scalar(s.reference_length_m);
  m->airspeed_mps = Scalar(s.airspeed_mps);
  m->delay = DelayUse::none;
  m->stall = StallUse::none;
  for (int c = 0; c < s.n_coefficients; ++c) {
    if (s.coefficients[c].delay_s != Scalar(0)) m->delay = DelayUse::delayed;
    if (s.coefficients[c].stall.families != StallFamilies::none) m->stall = StallUse::families;
  }
  derive_stall_sharing(s, m->stall_sharing);
}

namespace detail {
template <class Scalar>
inline bool fits(double v) {
  return std::isfinite(static_cast<Scalar>(v)) || !std::isfinite(v);
}

template <class Scalar, int P, int K>
inline bool convert_spline(const Spline<double, P, K>& in, Spline<Scalar, P, K>* out) {
  out->n_powers = in.n_powers;
  out->n_knots = in.n_knots;
  bool ok = true;
  for (int i = 0; i < P; ++i) {
    out->power_coef[i] = static_cast<Scalar>(in.power_coef[i]);
    ok = ok && fits<Scalar>(in.power_coef[i]);
  }
  for (int j = 0; j < (K > 0 ? K : 1); ++j) {
    out->knot_rad[j] = static_cast<typename KnotStorage<Scalar>::type>(in.knot_rad[j]);
    out->knot_power[j] = in.knot_power[j];
    out->knot_coef[j] = static_cast<Scalar>(in.knot_coef[j]);
    ok = ok && fits<Scalar>(in.knot_coef[j]);
  }
  return ok;
}

// The dynamic-stall parameters in Scalar (the structure -- family choice, switch widths --
// stays double, as model.hpp declares it; the table angles are KnotStorage, float in float).
template <class Scalar, class Cap>
inline bool convert_stall(const StallModel<double, Cap>& a, StallModel<Scalar, Cap>* out) {
  StallModel<Scalar, Cap>& b = *out;
  b.families = a.families;
  const auto& sa = a.separation;
  auto& sb = b.separation;
  const double values[] = {sa.normal_force_slope_per_rad, sa.zero_lift_angle_rad, sa.tau1_semichords,
                           sa.tau2_semichords, sa.cp_k0, sa.cp_k1, sa.cp_k2, sa.tau1_reattach_semichords,
                           sa.reattach_shift_rad, sa.lag_limit_rad, a.vortex.shedding_threshold, a.vortex.decay_semichords,
                           a.vortex.travel_semichords, a.vortex.lift_gain, a.vortex.cp_travel};
  bool ok = true;
  for (double v : values) ok = ok && fits<Scalar>(v);
  sb.normal_force_slope_per_rad = static_cast<Scalar>(sa.normal_force_slope_per_rad);
  sb.zero_lift_angle_rad = static_cast<Scalar>(sa.zero_lift_angle_rad);
  sb.n_f0 = sa.n_f0;
  for (int i = 0; i < Cap::max_table_points; ++i) {
    sb.f0_x_rad[i] = static_cast<typename KnotStorage<Scalar>::type>(sa.f0_x_rad[i]);
    sb.f0_value[i] = static_cast<Scalar>(sa.f0_value[i]);
  }
  ok = convert_spline(sa.f0_correction, &sb.f0_correction) && ok;
  sb.tau1_semichords = static_cast<Scalar>(sa.tau1_semichords);
  sb.tau2_semichords = static_cast<Scalar>(sa.tau2_semichords);
  sb.forcing_lag = sa.forcing_lag;
  sb.tau1_reattach_semichords = static_cast<Scalar>(sa.tau1_reattach_semichords);
  sb.reattach_shift_rad = static_cast<Scalar>(sa.reattach_shift_rad);
  sb.lag_limit_rad = static_cast<Scalar>(sa.lag_limit_rad);
  sb.cp_k0 = static_cast<Scalar>(sa.cp_k0);
  sb.cp_k1 = static_cast<Scalar>(sa.cp_k1);
  sb.cp_k2 = static_cast<Scalar>(sa.cp_k2);
  const auto& va = a.vortex;
  auto& vb = b.vortex;
  vb.shedding_threshold = static_cast<Scalar>(va.shedding_threshold);
  vb.shedding_width = va.shedding_width;
  vb.decay_semichords = static_cast<Scalar>(va.decay_semichords);
  vb.travel_semichords = static_cast<Scalar>(va.travel_semichords);
  vb.clock_width_semichords = va.clock_width_semichords;
  vb.clock_reset_semichords = va.clock_reset_semichords;
  vb.lift_gain = static_cast<Scalar>(va.lift_gain);
  vb.cp_travel = static_cast<Scalar>(va.cp_travel);
  return ok;
}

template <class Scalar, class Cap>
inline bool convert_coefficient(const CoefficientModel<double, Cap>& a,
                                CoefficientModel<Scalar, Cap>* out) {
  CoefficientModel<Scalar, Cap>& b = *out;
  for (std::size_t i = 0; i < sizeof a.name; ++i) b.name[i] = a.name[i];
  b.static_curve.kind = a.static_curve.kind;
  bool ok = convert_spline(a.static_curve.polynomial, &b.static_curve.polynomial);
  b.static_curve.n_table = a.static_curve.n_table;
  for (int i = 0; i < Cap::max_table_points; ++i) {
    b.static_curve.table_x_rad[i] = a.static_curve.table_x_rad[i];
    b.static_curve.table_value[i] = static_cast<Scalar>(a.static_curve.table_value[i]);
    ok = ok && fits<Scalar>(a.static_curve.table_value[i]);
  }
  ok = convert_spline(a.static_correction, &b.static_correction) && ok;
  ok = convert_spline(a.rotary, &b.rotary) && ok;
  ok = convert_spline(a.a, &b.a) && ok;
  b.n_lags = a.n_lags;
  for (int j = 0; j < Cap::max_lags; ++j) {
    ok = convert_spline(a.lags[j].b, &b.lags[j].b) && ok;
    b.lags[j].gain = static_cast<Scalar>(a.lags[j].gain);
    ok = ok && fits<Scalar>(a.lags[j].gain);
  }
  b.con = static_cast<Scalar>(a.con);
  b.delay_s = static_cast<Scalar>(a.delay_s);
  ok = convert_stall(a.stall, &b.stall) && ok;
  return ok && fits<Scalar>(a.con) && fits<Scalar>(a.delay_s);
}

// The ModelSet in Scalar, the natural-spline second derivatives of a static table recomputed
// in Scalar by the one function that defines them (a hand-built model need not carry them).
template <class Scalar, class Cap>
inline bool convert_model_set(const ModelSet<double, Cap>& in, ModelSet<Scalar, Cap>* out) {
  out->axis = in.axis;
  out->reference_length_m = in.reference_length_m;
  out->airspeed_mps = in.airspeed_mps;
  out->alpha0_rad = in.alpha0_rad;
  out->x_min_rad = in.x_min_rad;
  out->x_max_rad = in.x_max_rad;
  out->n_coefficients = in.n_coefficients;
  bool ok = true;
  for (int c = 0; c < Cap::max_coefficients; ++c) {
    ok = convert_coefficient(in.coefficients[c], &out->coefficients[c]) && ok;
    if (c < in.n_coefficients && out->coefficients[c].static_curve.kind == StaticKind::table)
      prepare_static_table(out->coefficients[c].static_curve);
  }
  return ok;
}

template <class Scalar, class Cap>
inline LoadStatus check_delay_capacity(const ModelSet<Scalar, Cap>& m, ParseDiagnostic* diag) {
  for (int c = 0; c < m.n_coefficients; ++c) {
    // Why: at the reference airspeed the ring serves (max_delay_samples - 2) steps of at
    // most max_step_dt_s; a longer delay could never be served by any accepted step.
    if (static_cast<double>(m.coefficients[c].delay_s) > (Cap::max_delay_samples - 2) * max_step_dt_s)
      return refuse(diag, 0,
                    "delay_s is longer than the runtime's delay history can hold even at "
                    "max_dt_s (raise Capacity's MaxDelaySamples)",
                    LoadStatus::over_capacity);
  }
  return LoadStatus::ok;
}
}  // namespace detail

// Validates a model (validate_for_runtime, the delay against the history capacity), converts
// it to Scalar and derives the step constants; *out is written only on success. Keeps one
// RuntimeModel<Scalar, Cap> on the stack (about 13 KB for double and DefaultCapacity).
template <class Scalar, class Cap>
inline LoadStatus make_runtime_model(const ModelSet<double, Cap>& in, RuntimeModel<Scalar, Cap>* out,
                                     ParseDiagnostic* diag = nullptr) {
  static_assert(std::is_floating_point<Scalar>::value,
                "RuntimeModel<Scalar, Cap>: Scalar must be float, double or long double");
  static_assert(detail::is_capacity<Cap>::value, "Cap must be an indicial::Capacity<...>");
  if (out == nullptr) return detail::refuse(diag, 0, "no output model given", LoadStatus::null_argument);
  LoadStatus s = validate_for_runtime(in, diag);
  if (s == LoadStatus::ok) s = detail::check_delay_capacity(in, diag);
  if (s != LoadStatus::ok) return s;
  RuntimeModel<Scalar, Cap> m{};
  if (!detail::convert_model_set(in, &m.set))
    return detail::refuse(diag, 0, "a model value does not fit the Scalar type",
                          LoadStatus::invalid_value);
  derive_step_constants(&m);
  *out = m;
  return LoadStatus::ok;
}

// Checks a RuntimeModel built elsewhere (a constexpr one from `indicial codegen`) once before
// stepping it in place: the set passes validate_for_runtime and the delay capacity check, a
// static table's second derivatives are the ones prepare_static_table gives, and the step
// constants are derive_step_constants' (bit for bit). Nothing is copied except one static
// curve at a time (about 1.5 KB of stack with DefaultCapacity).
template <class Scalar, class Cap>
inline LoadStatus check_runtime_model(const RuntimeModel<Scalar, Cap>& m,
                                      ParseDiagnostic* diag = nullptr) {
  LoadStatus s = validate_for_runtime(m.set, diag);
  if (s == LoadStatus::ok) s = detail::check_delay_capacity(m.set, diag);
  if (s != LoadStatus::ok) return s;
  for (int c = 0; c < m.set.n_coefficients; ++c) {
    const auto& curve = m.set.coefficients[c].static_curve;
    if (curve.kind != StaticKind::table) continue;
    auto prepared = curve;
    prepare_static_table(prepared);
    for (int i = 0; i < curve.n_table; ++i)
      if (!(prepared.table_second_derivative[i] == curve.table_second_derivative[i]))
        return detail::refuse(diag, 0, "static table second derivatives are not prepared",
                              LoadStatus::invalid_value);
  }
  RuntimeModel<Scalar, Cap> derived{};
  derived.set.axis = m.set.axis;
  derived.set.alpha0_rad = m.set.alpha0_rad;
  derived.set.x_min_rad = m.set.x_min_rad;
  derived.set.x_max_rad = m.set.x_max_rad;
  derived.set.reference_length_m = m.set.reference_length_m;
  derived.set.airspeed_mps = m.set.airspeed_mps;
  derived.set.n_coefficients = 0;  // the delay use is checked below, per coefficient
  derive_step_constants(&derived);
  DelayUse delay = DelayUse::none;
  StallUse stall = StallUse::none;
  for (int c = 0; c < m.set.n_coefficients; ++c) {
    if (m.set.coefficients[c].delay_s != 0.0) delay = DelayUse::delayed;
    if (m.set.coefficients[c].stall.families != StallFamilies::none) stall = StallUse::families;
  }
  if (!(derived.x_min_rad == m.x_min_rad && derived.x_max_rad == m.x_max_rad &&
        derived.angle_factor == m.angle_factor &&
        derived.reference_length_m == m.reference_length_m &&
        derived.airspeed_mps == m.airspeed_mps && delay == m.delay && stall == m.stall))
    return detail::refuse(diag, 0, "step constants differ from derive_step_constants",
                          LoadStatus::invalid_value);
  StallSharing sharing[Cap::max_coefficients];
  derive_stall_sharing(m.set, sharing);
  for (int c = 0; c < Cap::max_coefficients; ++c)
    if (!(sharing[c].table == m.stall_sharing[c].table && sharing[c].forcing == m.stall_sharing[c].forcing &&
          sharing[c].decay == m.stall_sharing[c].decay && sharing[c].separation == m.stall_sharing[c].separation))
      return detail::refuse(diag, 0, "stall_sharing differs from derive_stall_sharing",
                            LoadStatus::invalid_value);
  return LoadStatus::ok;
}

// ------------------------------------------------------------------------------------------
// The per-instance state: only what changes. Plain data, no padding for double and float
// (bytewise comparison is meaningful), copied whole by snapshot/restore.
// ------------------------------------------------------------------------------------------
namespace detail {
// Number of int words that make a struct free of padding for double and float: the 4-byte
// words (ints, and the Scalars when Scalar is float) must fill whole 8-byte units after the
// 8-byte members. At least 1 (no zero-length arrays).
template <class Scalar>
constexpr int pad_ints(int scalar_count, int int_count) {
  return (((sizeof(Scalar) == 4 ? scalar_count : 0) + int_count) % 2 == 0) ? 2 : 1;
}
}  // namespace detail

template <class Scalar, class Cap>
struct State {
  static constexpr int scalar_count = Cap::max_coefficients * Cap::max_lags +
                                      Cap::max_coefficients * (1 + Cap::max_lags) + 4;
  Scalar y[Cap::max_coefficients][Cap::max_lags] = {};  // lag states
  // The spline quantities at the previous sample, per coefficient (model.hpp's StepEnd): a
  // pure function of the previous angle and the model, kept so that a step evaluates only its new end.
  StepEnd<Scalar, Cap> end[Cap::max_coefficients] = {};
  // The model angle of the previous sample, not clamped: a static table's angle (warning 3).
  // The clamped angle the splines and lags use is derived from it (detail::clamp_to_envelope, the
  // envelope's clamp: the same two comparisons as the step's, hence the same bits). Why only
  // this one: the C API's evaluate needs the angle itself (a reset outside the envelope held a
  // static table at the envelope's edge where a step and predict evaluate it at the angle: a
  // user's trial, 2026-11-27, 0.6708 against 0.9259), and keeping the clamped one as well cost
  // every instance 8 bytes (FamilyState<double, DefaultCapacity> 264 -> 256 without it: issue
  // 22 item 4's limit) for two comparisons a step.
  Scalar model_x_prev_rad = Scalar(0);
  // The airspeed terms of the last step (recomputed only when the airspeed changes).
  Scalar airspeed_mps = Scalar(0);  // 0: none cached (steps accept only airspeeds > 0)
  Scalar time_scale = Scalar(0);    // V / V_ref
  Scalar l_over_v_s = Scalar(0);    // l / V
  int phase = 0;  // PredictorPhase as int: loaded (never reset) or running
  static constexpr int pad_count = detail::pad_ints<Scalar>(scalar_count, 1);
  int reserved[pad_count] = {};  // keeps it free of padding
};

// Where the delay history's record begins (DelayedState::history_origin).
enum class HistoryOrigin : int {
  rest_before_oldest = 0,  // nothing dropped since reset(): before the oldest sample the
                           // angle was the reset angle (at rest), so any delay is served
  samples_dropped = 1,     // the ring wrapped: angles older than the oldest sample are gone
};

// A State plus the dynamic-stall family states of every coefficient (model.hpp's StallState:
// separation point, vortex lift, vortex clock), for a model whose coefficients carry families
// (RuntimeModel::stall). Why a type of its own rather than room in every State: a model
// without families pays nothing (State<double, DefaultCapacity> stays 160 bytes, the float
// one 88), with the same Capacity (codegen and the C API keep DefaultCapacity), as the delay
// ring lives only in DelayedState. 256 bytes for double and DefaultCapacity, 136 for float
// (issue 22 item 4: at most 256 for C_L + C_m with every family; 272 and 144 until the State
// stopped keeping the clamped angle beside the angle and the padding word went).
template <class Scalar, class Cap>
struct FamilyState : State<Scalar, Cap> {
  // No padding word: a StallState is four Scalars, whole 8-byte units for double and float.
  static_assert(sizeof(StallState<Scalar>) == 4 * sizeof(Scalar), "StallState: four Scalars, no padding");
  StallState<Scalar> stall[Cap::max_coefficients] = {};
};

// A FamilyState plus the delay ring of the last Cap::max_delay_samples (time, clamped model
// angle) samples, for a model with a delayed coefficient (with or without families). Times are
// double (model.hpp warning 5: a delay is a small difference of large times), whatever Scalar
// is.
template <class Scalar, class Cap>
struct DelayedState : FamilyState<Scalar, Cap> {
  static constexpr int history_capacity = Cap::max_delay_samples;
  double time_s = 0.0;  // time of the newest sample, counted from reset() (t = 0)
  double delay_airspeed_mps = 0.0;                       // airspeed of the cached delays
  double delay_at_airspeed_s[Cap::max_coefficients] = {};  // each coefficient's delay there
  // The ring: the last history_count samples, newest at slot history_newest, older ones at
  // decreasing slots (modulo history_capacity). Unused slots are 0.
  double history_time_s[Cap::max_delay_samples] = {};
  Scalar history_x_rad[Cap::max_delay_samples] = {};
  int history_newest = 0;  // slot of the newest sample
  int history_count = 0;   // samples held: 1..history_capacity once running
  int history_origin = 0;  // HistoryOrigin as int
  static constexpr int history_pad_count = detail::pad_ints<Scalar>(Cap::max_delay_samples, 3);
  int history_reserved[history_pad_count] = {};
};

namespace detail {
template <class Scalar>
struct Clamped {
  Scalar x_rad;       // the model angle clamped to the envelope (the unsteady term's)
  StepStatus status;  // ok or angle_clamped
  Scalar model_x_rad; // the model angle itself (a static table's, model.hpp coefficient_output)
};

// Model angle from the motion angle (not yet clamped), in Scalar.
template <class Scalar, class Cap>
inline Scalar model_angle_of(const RuntimeModel<Scalar, Cap>& m, double motion_angle_rad) {
  const Scalar motion = Scalar(motion_angle_rad);
  // Why the branch: a finite double beyond Scalar's range (1e300 for float) becomes Inf, whose
  // sine is NaN; roll and yaw are periodic in the motion angle, so take that rare angle's
  // model angle in double. (Pitch needs nothing: Inf clamps to the envelope's end.)
  return m.set.axis == Axis::pitch || std::isfinite(motion)
             ? model_angle_from_factor(m.set.axis, m.angle_factor, motion)
             : Scalar(model_angle<double>(m.set.axis, m.set.alpha0_rad, motion_angle_rad));
}

// A model angle clamped to the envelope of the fitted unsteady term: the one rule of the step,
// the reset and the previous angle (batch.hpp's clamp_lanes_to_envelope is its lane form).
// Why the clamp: the splines are fitted inside the envelope only; outside it a polynomial
// extrapolates without data behind it. An angle inside comes back as it is (its sign of zero too).
template <class Scalar, class Cap>
inline Scalar clamp_to_envelope(const RuntimeModel<Scalar, Cap>& m, Scalar x_rad) {
  if (x_rad < m.x_min_rad) return m.x_min_rad;
  if (x_rad > m.x_max_rad) return m.x_max_rad;
  return x_rad;
}

// Model angle from the motion angle, clamped to the envelope, all in Scalar.
template <class Scalar, class Cap>
inline Clamped<Scalar> clamp_model_angle(const RuntimeModel<Scalar, Cap>& m, double motion_angle_rad) {
  const Scalar x = model_angle_of(m, motion_angle_rad);
  const bool inside = !(x < m.x_min_rad) && !(x > m.x_max_rad);
  return {clamp_to_envelope(m, x), inside ? StepStatus::ok : StepStatus::angle_clamped, x};
}

template <class Scalar>
struct AirspeedTerms {
  Scalar airspeed_mps;
  Scalar time_scale;  // V / V_ref
  Scalar l_over_v_s;  // l / V
};

// Why the exact comparison: the cached values are the same expressions of the same operand,
// so reusing them for an equal airspeed is bit-identical; any other airspeed recomputes.
template <class Scalar, class Cap>
inline AirspeedTerms<Scalar> airspeed_terms(const RuntimeModel<Scalar, Cap>& m,
                                            const State<Scalar, Cap>& s, double airspeed_mps) {
  const Scalar v = Scalar(airspeed_mps);
  if (v == s.airspeed_mps) return {v, s.time_scale, s.l_over_v_s};
  const AirspeedScaling<Scalar> scaling = airspeed_scaling(m.airspeed_mps, m.reference_length_m, v);
  return {v, scaling.time_scale, scaling.l_over_v_s};
}

// The double inputs checked on their IEEE 754 binary64 bit patterns. Why not isfinite and
// double comparisons: on a single-precision FPU (Cortex-M4F) each of those is a library call
// of 15-30 instructions, 14 of them per step, more than a third of a float step there
// (firmware/cortex-m/README.md); the bit pattern answers the same questions with integer
// operations on any machine. A double is finite iff its exponent field is not all ones; a
// finite double read as a signed 64-bit integer is > 0 iff the double is > 0 (-0 is the most
// negative pattern, +0 is 0), and two finite positive doubles compare as their patterns do.
inline std::int64_t double_bits(double v) {
  std::int64_t b;
  std::memcpy(&b, &v, sizeof b);
  return b;
}
inline bool finite_bits(std::int64_t b) {
  const std::int64_t exponent = 0x7FF0000000000000;
  return (b & exponent) != exponent;
}

// The status of a refused step's input: the checks one by one, in order (out of line: only a
// refused step runs it).
#if defined(__GNUC__) || defined(__clang__)
__attribute__((noinline))
#endif
inline StepStatus refused_step_input(int phase, const MotionInput& in, double dt_s, const void* out) {
  if (phase != static_cast<int>(PredictorPhase::running)) return StepStatus::not_reset;
  if (out == nullptr) return StepStatus::null_output;
  const std::int64_t dt = double_bits(dt_s);
  const std::int64_t airspeed = double_bits(in.airspeed_mps);
  if (!finite_bits(double_bits(in.motion_angle_rad)) || !finite_bits(double_bits(in.rate_radps)) ||
      !finite_bits(airspeed) || !finite_bits(dt))
    return StepStatus::non_finite_input;
  if (!(dt > 0)) return StepStatus::non_positive_dt;                   // dt_s > 0.0
  if (dt > double_bits(max_step_dt_s)) return StepStatus::dt_too_large;  // dt_s > max_step_dt_s
  if (!(airspeed > 0)) return StepStatus::non_positive_airspeed;       // airspeed_mps > 0.0
  return StepStatus::ok;
}

// The checks every step makes before touching anything. Why two passes: a good step answers
// each question with one test of a bit pattern (angle and rate finite, 0 < dt_s <=
// max_step_dt_s and 0 < airspeed_mps < Inf, each a range of the pattern read unsigned) and
// one branch, never taken in a good run; only a refused step asks them again for its status
// (refused_step_input, the same questions). Why a branch per question rather than one on
// all the answers combined: 4 instructions fewer per double step, 7 per float one
// (bench_step's callgrind count).
INDICIAL_HOT_INLINE StepStatus check_step_input(int phase, const MotionInput& in, double dt_s, const void* out) {
  const std::uint64_t exponent = 0x7FF0000000000000u;
  const std::uint64_t a = static_cast<std::uint64_t>(double_bits(in.motion_angle_rad));
  const std::uint64_t r = static_cast<std::uint64_t>(double_bits(in.rate_radps));
  const std::uint64_t v = static_cast<std::uint64_t>(double_bits(in.airspeed_mps));
  const std::uint64_t d = static_cast<std::uint64_t>(double_bits(dt_s));
  const std::uint64_t max_dt = static_cast<std::uint64_t>(double_bits(max_step_dt_s));
  if ((a & exponent) != exponent && (r & exponent) != exponent && v - 1u < exponent - 1u &&
      d - 1u < max_dt && phase == static_cast<int>(PredictorPhase::running) && out != nullptr)
    return StepStatus::ok;
  return refused_step_input(phase, in, dt_s, out);
}

// The forcing angles of delayed coefficients at both ends of a step (x(t - d)).
template <class Scalar, class Cap>
struct DelayedForcing {
  Scalar x0_rad[Cap::max_coefficients];
  Scalar x1_rad[Cap::max_coefficients];
};

// What a step overwrites in place, saved before it: the lag states and step ends of every
// coefficient (and, with families, their states). A step whose result is not finite copies
// them back, so the State keeps its bytes (commit-only-if-finite). Why in place with a copy
// rather than into a scratch result committed afterwards: the copy is one fixed-size block
// move, the scratch commit a loop per coefficient and lag (bench_step's callgrind count).
template <class Scalar, class Cap>
struct StepBackup {
  Scalar y[Cap::max_coefficients][Cap::max_lags];
  StepEnd<Scalar, Cap> end[Cap::max_coefficients];
};

template <class Scalar, class Cap>
INDICIAL_HOT_INLINE void save(const State<Scalar, Cap>& s, StepBackup<Scalar, Cap>* b) {
  std::memcpy(b->y, s.y, sizeof b->y);
  std::memcpy(b->end, s.end, sizeof b->end);
}

template <class Scalar, class Cap>
inline void restore(const StepBackup<Scalar, Cap>& b, State<Scalar, Cap>* s) {
  std::memcpy(s->y, b.y, sizeof b.y);
  std::memcpy(s->end, b.end, sizeof b.end);
}

// v - v: 0 for a finite v, NaN for an infinite or NaN one. A step sums these over what it
// keeps and tests the sum once (isfinite): the commit-only-if-finite test in one branch.
template <class Scalar>
INDICIAL_HOT_INLINE Scalar finite_test(const Scalar& v) {
  return v - v;
}

#if defined(__GNUC__) || defined(__clang__)
#define INDICIAL_UNROLL _Pragma("GCC unroll 16")
#else
#define INDICIAL_UNROLL
#endif

// f(c) for c = 0 .. n - 1, unrolled over the capacity (the copies after n skipped): each
// copy's c is a constant, so per-coefficient arrays of the caller stay in registers.
template <class Cap, class F>
INDICIAL_HOT_INLINE void for_each_coefficient(int n, const F& f) {
  INDICIAL_UNROLL
  for (int c = 0; c < Cap::max_coefficients; ++c) {
    if (c == n) break;
    f(c);
  }
}

// a[e] for an earlier coefficient e (0 <= e < c) named at run time (RuntimeModel::stall_sharing),
// as selections between constant indices: after for_each_coefficient's unrolling c is a
// constant, and a scratch array read so can stay in registers (indexed by e, it lives in
// memory). Issue 22 item 6, with the first stage's clearing below: state/stall2/double 2194 ->
// 2174 instructions, float 2213 -> 2205 (bench_step's callgrind count).
template <class T>
INDICIAL_HOT_INLINE T earlier_entry(const T* a, int c, int e) {
  T r = a[0];
  for (int i = 1; i < c; ++i)
    if (e == i) r = a[i];
  return r;
}

// The families' lookups of one step (model.hpp's StallLookups), of each coefficient's own or
// copied from the one it shares them with (RuntimeModel::stall_sharing): the lookups are of
// the step's own angles and airspeed. Coefficients are looked up in order, 0 first.
// With ForcingLag::first_order the lagged angles come from the coefficient's own state's
// forcing angle, which stall_lagged_angles advances (such a coefficient shares no forcing:
// derive_stall_sharing).
template <class Scalar, class Cap>
INDICIAL_HOT_INLINE void look_up_families(const RuntimeModel<Scalar, Cap>& m, const StallStep<Scalar>& g,
                                          const Scalar& h, StallState<Scalar>* s, StallLookups<Scalar>* k) {
  for_each_coefficient<Cap>(m.set.n_coefficients, [&](int c) INDICIAL_HOT_LAMBDA {
    const StallModel<Scalar, Cap>& st = m.set.coefficients[c].stall;
    if (st.families == StallFamilies::none) return;
    const StallSharing& sh = m.stall_sharing[c];
    if (sh.forcing != StallSharing::no_sharing) {
      k[c] = earlier_entry(k, c, sh.forcing);
    } else {
      stall_lagged_angles(st.separation, g, h, &s[c].forcing_angle_rad, &k[c]);
      stall_table_lookups(st.separation, &k[c]);
    }
    if (sh.decay != StallSharing::no_sharing) {
      const StallLookups<Scalar> from = earlier_entry(k, c, sh.decay);
      k[c].decay = from.decay;
      k[c].weight = from.weight;
    } else {
      stall_decay(st.separation, h, &k[c]);
    }
  });
}

// Every coefficient's dynamic-stall families over the step (model.hpp's advance_stall, in
// place) and their outputs (stall_output) added to the report's values; the sum of their
// finite_tests. The one families step, of the single step (advance_coefficients) and the batch
// (batch.hpp's advance_lane_families) alike. The same numbers as advance_stall and
// stall_output (model.hpp splits them for this: the same operations, or copies of the same
// operations on equal parameters), hence the same bits as the fitter's loop.
// Why stage by stage over the coefficients rather than one coefficient after the other: each
// coefficient's vortex update is a chain of four exps (model.hpp's stages: gate, clock, feed
// gate, decay), and a step waits for it; with the coefficients' stages side by side the
// processor runs their chains at the same time (in a loop over coefficients one after the
// other, the second chain started some thousand instructions after the first, beyond the
// reach of out-of-order execution).
// Coefficients that share the separation update (RuntimeModel::stall_sharing's separation: C_L
// and C_m of one polar) compute it once when their separation points are the same bits before
// the step, as they are from a reset on: f1, K(f0), K(f1), and f0c(x1) with its K (issue 22
// item 6: state/stall2/double 2174 -> 2114 instructions, float 2205 -> 2153, bench_step's
// callgrind count). Otherwise each computes its own: the numbers are the same either way.
template <class Scalar, class Cap>
INDICIAL_HOT_INLINE Scalar advance_families(const RuntimeModel<Scalar, Cap>& m, const StallStep<Scalar>& g,
                                            StallState<Scalar>* s, Scalar* value) {
  const int n = m.set.n_coefficients;
  const ModelSet<Scalar, Cap>& set = m.set;
  const Scalar h = stall_step_semichords(g);
  // (k, same_f and the arrays below cleared: a later loop reads what an earlier loop, or an
  // earlier coefficient, wrote under the same condition, which GCC's -Wmaybe-uninitialized does
  // not follow. q is cleared coefficient by coefficient in the first stage's loop, over the
  // whole capacity, instead: the same for the warning, and no block clear of 144 bytes.)
  StallLookups<Scalar> k[Cap::max_coefficients] = {};
  look_up_families(m, g, h, s, k);
  StallProgress<Scalar> q[Cap::max_coefficients];
  // same_f[c]: c repeats the separation update of e = stall_sharing[c].separation, whose
  // separation point was the same bits as c's before the step (then f1, K(f0) and K(f1) are).
  bool same_f[Cap::max_coefficients] = {};
  const auto vortex = [&](int c) INDICIAL_HOT_LAMBDA {
    return set.coefficients[c].stall.families == StallFamilies::separation_and_vortex;
  };
  INDICIAL_UNROLL
  for (int c = 0; c < Cap::max_coefficients; ++c) {
    q[c] = StallProgress<Scalar>{};
    if (c >= n || set.coefficients[c].stall.families == StallFamilies::none) continue;
    const int e = m.stall_sharing[c].separation;
    same_f[c] = e != StallSharing::no_sharing && same_bits(s[c].separation_point, earlier_entry(q, c, e).f0);
    if (same_f[c]) {
      q[c].f0 = earlier_entry(q, c, e).f0;
      s[c].separation_point = earlier_entry(s, c, e).separation_point;
    } else {
      stall_separation_stage(set.coefficients[c].stall, h, k[c], &s[c], &q[c]);
    }
    if (vortex(c)) stall_shedding_stage(set.coefficients[c].stall, k[c], &q[c]);
  }
  for_each_coefficient<Cap>(n, [&](int c) INDICIAL_HOT_LAMBDA {
    if (vortex(c)) stall_clock_stage(set.coefficients[c].stall, h, &s[c], &q[c]);
  });
  for_each_coefficient<Cap>(n, [&](int c) INDICIAL_HOT_LAMBDA {
    if (vortex(c)) stall_feed_gate_stage(set.coefficients[c].stall, s[c], &q[c]);
  });
  for_each_coefficient<Cap>(n, [&](int c) INDICIAL_HOT_LAMBDA {
    if (!vortex(c)) return;
    if (same_f[c]) {
      const int e = m.stall_sharing[c].separation;
      q[c].kirchhoff0 = earlier_entry(q, c, e).kirchhoff0;
      q[c].kirchhoff1 = earlier_entry(q, c, e).kirchhoff1;
    } else {
      stall_kirchhoff_stage(s[c], &q[c]);
    }
    stall_vortex_stage(set.coefficients[c].stall, g, h, &s[c], q[c]);
  });
  Scalar table_x1[Cap::max_coefficients] = {};
  Scalar f_static[Cap::max_coefficients] = {};
  Scalar kirchhoff_static[Cap::max_coefficients] = {};
  Scalar test = Scalar(0);
  for_each_coefficient<Cap>(n, [&](int c) INDICIAL_HOT_LAMBDA {
    const StallModel<Scalar, Cap>& st = set.coefficients[c].stall;
    if (st.families == StallFamilies::none) return;
    const StallSharing& sh = m.stall_sharing[c];
    table_x1[c] = sh.table != StallSharing::no_sharing ? earlier_entry(table_x1, c, sh.table)
                                                       : separation_table_value(st.separation, g.x1_rad);
    if (sh.separation != StallSharing::no_sharing) {  // the same f0c(x1), hence its K
      f_static[c] = earlier_entry(f_static, c, sh.separation);
      kirchhoff_static[c] = earlier_entry(kirchhoff_static, c, sh.separation);
    } else {
      f_static[c] = static_separation_from_table(st.separation, g.x1_rad, table_x1[c]);
      kirchhoff_static[c] = kirchhoff_factor(f_static[c]);
    }
    if (!vortex(c))
      q[c].kirchhoff1 = same_f[c] ? earlier_entry(q, c, sh.separation).kirchhoff1 : kirchhoff_factor(s[c].separation_point);
    const StallOutput<Scalar> o = stall_output_parts_from_static(st, g.x1_rad, f_static[c], kirchhoff_static[c],
                                                                 q[c].kirchhoff1, s[c]);
    value[c] = value[c] + (o.separation + o.vortex);
    // (The forcing angle is not tested: a convex combination of the finite angles and itself.)
    test = test + (finite_test(s[c].separation_point) + finite_test(s[c].vortex_lift) +
                   finite_test(s[c].vortex_clock_semichords));
  });
  return test;
}

// One coefficient's lags over the step (model.hpp's advance_lags_between, y in place, the new
// step end into *end1) and its output; g's forcing angles are the coefficient's own. The
// finite_test of the output, which sums the lag states: a lag state that is not finite makes
// the output not finite.
template <class Scalar, class Cap>
INDICIAL_HOT_INLINE Scalar advance_coefficient(const CoefficientModel<Scalar, Cap>& cm,
                                               const StepGeometry<Scalar>& g, const Scalar& x1,
                                               const Scalar& forcing_x1,
                                               const StepEnd<Scalar, Cap>& end0, const Scalar& table_x1,
                                               Scalar rate, Scalar l_over_v_s,
                                               StepEnd<Scalar, Cap>* end1, Scalar* y, Scalar* value) {
  const Scalar fitted = fitted_terms_with<ScalarOps<Scalar>>(cm, x1, table_x1, rate, l_over_v_s);
  advance_lags_to(cm, g, x1, forcing_x1, end0, end1, y);
  *value = add_stepped_lag_states(cm, fitted, y);
  return finite_test(*value);
}

// How advance_coefficients runs over the coefficients: in a loop, or unrolled over the
// capacity (a copy of the coefficient's step per Cap::max_coefficients, the copies after
// n_coefficients skipped). Why unrolled for the State's step: no loop counter or
// per-coefficient pointers live across the spline calls (state/model2/double 925 -> 905
// instructions, bench_step's callgrind count), and a model known at compile time (indicial
// codegen) is folded into each copy (the Cortex-M4F step 912 -> 660 instructions, flash 128 B
// less, tools/run-cortex-m.sh). The cost: a Predictor or a parsed model, not known at compile
// time, carries the copies (flash +1.5 KB and +3.4 KB on the Cortex-M4F, whose steps are
// still 6% and 3% fewer instructions). The families' step is unrolled too (issue 22 item 6:
// state/stall2/double 2326 -> 2252 instructions, float 2294 -> 2269, bench_step's callgrind
// count); why not the delayed step: more copies in every Predictor's flash, and no goal asks.
enum class CoefficientLoop : int { rolled = 0, unrolled = 1 };

// The model equations over one step for every coefficient, in place on s (whose lag states
// and step ends `before` holds) and on the family states `stall` (nullptr: the model has
// none); the outputs into value. Returns the sum of the finite_tests (0 if every number the
// step keeps is finite). forcing == nullptr: no delay (the forcing angle is the angle).
template <CoefficientLoop Loop, class Scalar, class Cap>
INDICIAL_HOT_INLINE Scalar advance_coefficients(const RuntimeModel<Scalar, Cap>& m, State<Scalar, Cap>& s,
                                                const StepBackup<Scalar, Cap>& before, const Scalar& x1,
                                                const Scalar& table_x1, Scalar rate, Scalar dt_s,
                                                const AirspeedTerms<Scalar>& v,
                                                const DelayedForcing<Scalar, Cap>* forcing,
                                                StallState<Scalar>* stall, Scalar* value) {
  const Scalar x0 = clamp_to_envelope(m, s.model_x_prev_rad);
  const StepGeometry<Scalar> g{x0, x1, x0, x1, dt_s, v.time_scale};
  const auto coefficient = [&](int c) INDICIAL_HOT_LAMBDA -> Scalar {
    const CoefficientModel<Scalar, Cap>& cm = m.set.coefficients[c];
    Scalar test;
    // Why the branch: an undelayed coefficient uses the sample angles themselves; only a
    // delayed one has forcing angles of its own, and recomputes A at the old end (x(t0 - d)
    // moves when the airspeed, hence d, changes). B_j(x0) stays valid whatever the delay.
    if (forcing != nullptr && cm.delay_s != Scalar(0)) {
      StepGeometry<Scalar> gd = g;
      gd.forcing_x0_rad = forcing->x0_rad[c];
      gd.forcing_x1_rad = forcing->x1_rad[c];
      StepEnd<Scalar, Cap> delayed_end0 = before.end[c];
      delayed_end0.forcing_antiderivative = spline_antiderivative(cm.a, gd.forcing_x0_rad);
      test = advance_coefficient(cm, gd, x1, forcing->x1_rad[c], delayed_end0, table_x1, rate,
                                 v.l_over_v_s, &s.end[c], s.y[c], &value[c]);
    } else {
      // The old end as the previous step (or reset) left it: B_j(x_prev) and A(x_prev) --
      // bit for bit what advance_lags would evaluate again.
      test = advance_coefficient(cm, g, x1, x1, before.end[c], table_x1, rate, v.l_over_v_s,
                                 &s.end[c], s.y[c], &value[c]);
    }
    return test;
  };
  Scalar test = Scalar(0);
  if (Loop == CoefficientLoop::unrolled) {
    INDICIAL_UNROLL
    for (int c = 0; c < Cap::max_coefficients; ++c) {
      if (c == m.set.n_coefficients) break;
      const Scalar t = coefficient(c);
      test = c == 0 ? t : test + t;  // (0 + t is t only for t != -0: the compiler keeps the add)
    }
  } else {
    for (int c = 0; c < m.set.n_coefficients; ++c) test = test + coefficient(c);
  }
  if (stall != nullptr)
    test = test + advance_families(m, StallStep<Scalar>{g.x0_rad, x1, dt_s, v.l_over_v_s}, stall, value);
  return test;
}

// The rest of a step whose numbers are all finite: the angle, the airspeed terms, the outputs.
template <class Scalar, class Cap>
INDICIAL_HOT_INLINE void commit(const RuntimeModel<Scalar, Cap>& m, const Scalar* value, Scalar model_x1,
                                const AirspeedTerms<Scalar>& v, State<Scalar, Cap>* s, Scalar* out) {
  // (Over the capacity, not n_coefficients: GCC makes the shorter loop a memcpy call.)
  for (int c = 0; c < Cap::max_coefficients; ++c)
    if (c < m.set.n_coefficients) out[c] = value[c];
  s->model_x_prev_rad = model_x1;
  s->airspeed_mps = v.airspeed_mps;
  s->time_scale = v.time_scale;
  s->l_over_v_s = v.l_over_v_s;
}

// The delay history seen newest-first by indicial::delayed_angle (model.hpp): index 0 is the
// pending new sample, index i >= 1 the ring's (i-1)-th newest. Reads only.
template <class Scalar, class Cap>
struct HistoryView {
  const DelayedState<Scalar, Cap>* s;
  double new_time_s;
  Scalar new_x_rad;
  int n;
  int size() const { return n; }
  int slot(int i) const {
    const int k = s->history_newest - (i - 1);
    return k < 0 ? k + Cap::max_delay_samples : k;
  }
  double time_s(int i) const { return i == 0 ? new_time_s : s->history_time_s[slot(i)]; }
  Scalar x_rad(int i) const { return i == 0 ? new_x_rad : s->history_x_rad[slot(i)]; }
};
}  // namespace detail

// ------------------------------------------------------------------------------------------
// The stateless core: reset and step of one State against a shared model.
// ------------------------------------------------------------------------------------------

// Sets every lag state to the steady state at the given motion angle (x' = 0) and caches the
// spline quantities there and the airspeed terms. Refused (nothing changed) on non-finite
// input, airspeed <= 0, or a non-finite steady state.
template <class Scalar, class Cap>
inline StepStatus reset(const RuntimeModel<Scalar, Cap>& m, State<Scalar, Cap>& s,
                        double motion_angle_rad, double airspeed_mps) {
  if (!std::isfinite(motion_angle_rad) || !std::isfinite(airspeed_mps))
    return StepStatus::non_finite_input;
  if (!(airspeed_mps > 0.0)) return StepStatus::non_positive_airspeed;
  const detail::Clamped<Scalar> clamp = detail::clamp_model_angle(m, motion_angle_rad);
  State<Scalar, Cap> n{};
  for (int c = 0; c < m.set.n_coefficients; ++c) {
    const CoefficientModel<Scalar, Cap>& cm = m.set.coefficients[c];
    steady_state(cm, clamp.x_rad, n.y[c]);
    for (int j = 0; j < cm.n_lags; ++j)
      if (!std::isfinite(n.y[c][j])) return StepStatus::non_finite_result;
    // At rest the forcing angle is the model angle, delay or not.
    evaluate_step_end(cm, clamp.x_rad, clamp.x_rad, &n.end[c]);
  }
  n.model_x_prev_rad = clamp.model_x_rad;
  const detail::AirspeedTerms<Scalar> v = detail::airspeed_terms(m, n, airspeed_mps);
  n.airspeed_mps = v.airspeed_mps;
  n.time_scale = v.time_scale;
  n.l_over_v_s = v.l_over_v_s;
  n.phase = static_cast<int>(PredictorPhase::running);
  s = n;
  return clamp.status;
}

// A FamilyState's reset also sets the family states at rest at the (clamped) angle
// (model.hpp's stall_steady_state: f = f0c(x), no vortex); a non-finite one refuses the whole
// reset and restores the State as it was.
template <class Scalar, class Cap>
inline StepStatus reset(const RuntimeModel<Scalar, Cap>& m, FamilyState<Scalar, Cap>& s,
                        double motion_angle_rad, double airspeed_mps) {
  const State<Scalar, Cap> before = s;
  State<Scalar, Cap>& base = s;
  const StepStatus st = reset(m, base, motion_angle_rad, airspeed_mps);
  if (st != StepStatus::ok && st != StepStatus::angle_clamped) return st;
  StallState<Scalar> rest[Cap::max_coefficients] = {};
  for (int c = 0; c < m.set.n_coefficients; ++c) {
    stall_steady_state(m.set.coefficients[c].stall, detail::clamp_to_envelope(m, s.model_x_prev_rad), &rest[c]);
    if (!std::isfinite(rest[c].separation_point)) {
      base = before;
      return StepStatus::non_finite_result;
    }
  }
  for (int c = 0; c < Cap::max_coefficients; ++c) s.stall[c] = rest[c];
  return st;
}

// A DelayedState's reset also sets its history to "at rest at that angle since forever":
// one sample at t = 0, the other slots cleared, origin rest_before_oldest.
template <class Scalar, class Cap>
inline StepStatus reset(const RuntimeModel<Scalar, Cap>& m, DelayedState<Scalar, Cap>& s,
                        double motion_angle_rad, double airspeed_mps) {
  const StepStatus st = reset(m, static_cast<FamilyState<Scalar, Cap>&>(s), motion_angle_rad, airspeed_mps);
  if (st != StepStatus::ok && st != StepStatus::angle_clamped) return st;
  for (int i = 0; i < Cap::max_delay_samples; ++i) {
    s.history_time_s[i] = 0.0;
    s.history_x_rad[i] = Scalar(0);
  }
  s.time_s = 0.0;
  s.delay_airspeed_mps = 0.0;
  for (int c = 0; c < Cap::max_coefficients; ++c) s.delay_at_airspeed_s[c] = 0.0;
  s.history_x_rad[0] = detail::clamp_to_envelope(m, s.model_x_prev_rad);
  s.history_newest = 0;
  s.history_count = 1;
  s.history_origin = static_cast<int>(HistoryOrigin::rest_before_oldest);
  return st;
}

namespace detail {
// The family states a step with families overwrites in place, saved before it (as
// StepBackup); nothing at all for the State's step (StallUse::none).
template <StallUse Families, class Scalar, class Cap>
struct FamilyBackup {
  StallState<Scalar> stall[Cap::max_coefficients];
  void save(const FamilyState<Scalar, Cap>* f) { std::memcpy(stall, f->stall, sizeof stall); }
  void restore(FamilyState<Scalar, Cap>* f) const { std::memcpy(f->stall, stall, sizeof stall); }
};
template <class Scalar, class Cap>
struct FamilyBackup<StallUse::none, Scalar, Cap> {
  void save(const FamilyState<Scalar, Cap>*) {}
  void restore(FamilyState<Scalar, Cap>*) const {}
};

// The undelayed step of a State, with the family states of `families` (nullptr: a model
// without families). Why a template on whether there are families rather than a branch on
// the pointer: the State's step then holds none of the families' code, and with it fewer
// values live across the spline calls (bench_step's callgrind count).
template <StallUse Families, class Scalar, class Cap>
inline StepStatus step_undelayed(const RuntimeModel<Scalar, Cap>& m, State<Scalar, Cap>& s,
                                 FamilyState<Scalar, Cap>* families, const MotionInput& in,
                                 double dt_s, Scalar* out) {
  const StepStatus checked = check_step_input(s.phase, in, dt_s, out);
  if (checked != StepStatus::ok) return checked;
  if (m.delay != DelayUse::none) return StepStatus::delay_needs_history;
  if (Families == StallUse::none && m.stall != StallUse::none) return StepStatus::families_need_state;
  const Clamped<Scalar> clamp = clamp_model_angle(m, in.motion_angle_rad);
  // Copies: the spline evaluations take their angle by reference, and a reference into the
  // Clamped would keep all of it in memory (3 instructions per step, bench_step's count).
  const Scalar x1 = clamp.x_rad;
  const Scalar table_x1 = clamp.model_x_rad;
  const AirspeedTerms<Scalar> v = airspeed_terms(m, s, in.airspeed_mps);
  StepBackup<Scalar, Cap> before;
  save(s, &before);
  Scalar value[Cap::max_coefficients];
  // (Cleared with families: the lag loop writes value[c] and the families' loops read it, for
  // the same c < n, which GCC's -Wmaybe-uninitialized does not follow from one loop to the next.)
  if (Families != StallUse::none) std::memset(value, 0, sizeof value);
  FamilyBackup<Families, Scalar, Cap> stall_before;
  stall_before.save(families);
  const Scalar test = advance_coefficients<CoefficientLoop::unrolled>(m, s, before, x1, table_x1,
                                           Scalar(in.rate_radps), Scalar(dt_s), v,
                                           static_cast<const DelayedForcing<Scalar, Cap>*>(nullptr),
                                           Families != StallUse::none ? families->stall : nullptr, value);
  if (!std::isfinite(test)) {
    restore(before, &s);
    stall_before.restore(families);
    return StepStatus::non_finite_result;
  }
  commit(m, value, clamp.model_x_rad, v, &s, out);
  return clamp.status;
}

// The State's step (a model without families or delay), flattened: the spline sums, the
// static table and the lag update are inlined into it whatever the caller's translation unit
// makes of model.hpp's functions. Why: the step is a dependent chain (the next angle waits for
// this output, in a control loop as in bench_step), and out-of-line spline calls on it cost
// about 6 ns of 64 on x86-64 and 42 instructions (bench_step state/model2/double, interleaved
// with floor/, medians of 6 runs: 1.38x -> 1.23x its floor, 63.5 -> 57.7 ns; 914 -> 872
// instructions). The C library's indicial_step got the same code from GCC's heuristics
// already. Why not the delayed step: its body is 2-3x larger, and no goal asks (the families'
// step is flattened too: step_families below).
template <class Scalar, class Cap>
INDICIAL_FLATTEN inline StepStatus step_state(const RuntimeModel<Scalar, Cap>& m, State<Scalar, Cap>& s,
                                              const MotionInput& in, double dt_s, Scalar* out) {
  return step_undelayed<StallUse::none>(m, s, static_cast<FamilyState<Scalar, Cap>*>(nullptr), in, dt_s, out);
}
// The step of a FamilyState with families, flattened as step_state: the spline sums, the
// static table and the lag update inlined, as in the State's step (issue 22 item 6, whose goal
// compares the two: state/stall2/double 2247 -> 2194 instructions, float 2242 -> 2213,
// bench_step's callgrind count; with the families' loop cut off the step was 950
// instructions against step_state's 874, now 889). Tried in an earlier code and dropped then
// (2326 -> 2343): the families' exps are calls either way; what it inlines now is the model's.
template <class Scalar, class Cap>
INDICIAL_FLATTEN inline StepStatus step_families(const RuntimeModel<Scalar, Cap>& m, FamilyState<Scalar, Cap>& s,
                                                 const MotionInput& in, double dt_s, Scalar* out) {
  return step_undelayed<StallUse::families>(m, s, &s, in, dt_s, out);
}
}  // namespace detail

namespace detail {
// The outputs of a state at its last sample, without stepping it (evaluate, below); stall:
// the family states, or nullptr for a plain State.
template <class Scalar, class Cap>
inline StepStatus evaluate_state(const RuntimeModel<Scalar, Cap>& m, const State<Scalar, Cap>& s,
                                 const StallState<Scalar>* stall, double rate_radps, double airspeed_mps,
                                 Scalar* out) {
  const StepStatus checked = check_step_input(s.phase, MotionInput{0.0, rate_radps, airspeed_mps}, 1.0, out);
  if (checked != StepStatus::ok) return checked;
  if (stall == nullptr && m.stall != StallUse::none) return StepStatus::families_need_state;
  const AirspeedTerms<Scalar> v = airspeed_terms(m, s, airspeed_mps);
  Scalar value[Cap::max_coefficients] = {};
  const Scalar x0 = clamp_to_envelope(m, s.model_x_prev_rad);
  for (int c = 0; c < m.set.n_coefficients; ++c) {
    const CoefficientModel<Scalar, Cap>& cm = m.set.coefficients[c];
    value[c] = coefficient_output(cm, x0, s.model_x_prev_rad, Scalar(rate_radps), v.l_over_v_s, s.y[c]);
    if (stall != nullptr && cm.stall.families != StallFamilies::none)
      value[c] = value[c] + stall_output(cm.stall, x0, stall[c]);
    if (!std::isfinite(value[c])) return StepStatus::non_finite_result;
  }
  for (int c = 0; c < m.set.n_coefficients; ++c) out[c] = value[c];
  return StepStatus::ok;
}
}  // namespace detail

// The coefficients of a state at its last sample (after reset: the reset's steady state),
// at this rate and airspeed, without stepping it: what a step to that sample wrote, and what
// `indicial predict` writes at its first sample. The same angles as the step (warning 3: a
// static table at the angle itself, the rest at the envelope's edge). Changes nothing; on a
// refusal out is untouched. A model with dynamic-stall families needs its FamilyState (or
// DelayedState): a plain State returns families_need_state.
template <class Scalar, class Cap>
inline StepStatus evaluate(const RuntimeModel<Scalar, Cap>& m, const State<Scalar, Cap>& s, double rate_radps,
                           double airspeed_mps, Scalar* out) {
  return detail::evaluate_state(m, s, static_cast<const StallState<Scalar>*>(nullptr), rate_radps, airspeed_mps, out);
}
template <class Scalar, class Cap>
inline StepStatus evaluate(const RuntimeModel<Scalar, Cap>& m, const FamilyState<Scalar, Cap>& s, double rate_radps,
                           double airspeed_mps, Scalar* out) {
  return detail::evaluate_state(m, s, m.stall != StallUse::none ? s.stall : nullptr, rate_radps, airspeed_mps, out);
}

// The model angle of a state's last sample, clamped to the envelope: the angle its splines and
// lags were evaluated at (the unsteady term's, warning 3; State::model_x_prev_rad is the angle
// itself). What State::x_prev_rad held until it was derived (CHANGELOG). Only meaningful after
// a reset (a never-reset state reads 0 clamped).
template <class Scalar, class Cap>
inline Scalar clamped_previous_angle_rad(const RuntimeModel<Scalar, Cap>& m, const State<Scalar, Cap>& s) {
  return detail::clamp_to_envelope(m, s.model_x_prev_rad);
}

// Advances the lag states from the previous sample to this one (dt_s later) and writes the
// m.set.n_coefficients coefficients at this sample to out[0..]. Anything but ok or
// angle_clamped changes neither s nor out. A model with a delay needs a DelayedState, one
// with dynamic-stall families a FamilyState (or a DelayedState).
template <class Scalar, class Cap>
inline StepStatus step(const RuntimeModel<Scalar, Cap>& m, State<Scalar, Cap>& s,
                       const MotionInput& in, double dt_s, Scalar* out) {
  return detail::step_state(m, s, in, dt_s, out);
}

// The step of a FamilyState: a model without families steps exactly as with a State (the
// family states are left alone); with families, model.hpp's advance_stall runs after each
// coefficient's lags and stall_output adds to its value, in place, and restored (with the
// lag states) unless every number is finite.
template <class Scalar, class Cap>
inline StepStatus step(const RuntimeModel<Scalar, Cap>& m, FamilyState<Scalar, Cap>& s,
                       const MotionInput& in, double dt_s, Scalar* out) {
  if (m.stall == StallUse::none) return step(m, static_cast<State<Scalar, Cap>&>(s), in, dt_s, out);
  return detail::step_families(m, s, in, dt_s, out);
}

namespace detail {
// The delays at this airspeed (double, as delay_at_airspeed gives them), cached per airspeed.
template <class Scalar, class Cap>
inline void delays_at(const RuntimeModel<Scalar, Cap>& m, const DelayedState<Scalar, Cap>& s,
                      double airspeed_mps, double* d) {
  for (int c = 0; c < m.set.n_coefficients; ++c)
    d[c] = airspeed_mps == s.delay_airspeed_mps
               ? s.delay_at_airspeed_s[c]
               : delay_at_airspeed(static_cast<double>(m.set.coefficients[c].delay_s),
                                   m.set.airspeed_mps, airspeed_mps);
}

template <class Scalar, class Cap>
inline void commit_history(double t1_s, Scalar x1, bool ring_full, DelayedState<Scalar, Cap>* s) {
  const int slot = s->history_newest + 1 == Cap::max_delay_samples ? 0 : s->history_newest + 1;
  s->history_time_s[slot] = t1_s;
  s->history_x_rad[slot] = x1;
  s->history_newest = slot;
  if (ring_full) s->history_origin = static_cast<int>(HistoryOrigin::samples_dropped);
  else ++s->history_count;
  s->time_s = t1_s;
}
}  // namespace detail

// The step of a DelayedState: an undelayed model steps exactly as with a State (the ring is
// left alone); a delayed one drives each delayed coefficient with x(t - d) from the ring.
template <class Scalar, class Cap>
inline StepStatus step(const RuntimeModel<Scalar, Cap>& m, DelayedState<Scalar, Cap>& s,
                       const MotionInput& in, double dt_s, Scalar* out) {
  if (m.delay == DelayUse::none) return step(m, static_cast<FamilyState<Scalar, Cap>&>(s), in, dt_s, out);
  const StepStatus checked = detail::check_step_input(s.phase, in, dt_s, out);
  if (checked != StepStatus::ok) return checked;
  const detail::Clamped<Scalar> clamp = detail::clamp_model_angle(m, in.motion_angle_rad);
  const detail::AirspeedTerms<Scalar> v = detail::airspeed_terms(m, s, in.airspeed_mps);
  double d_s[Cap::max_coefficients] = {};
  detail::delays_at(m, s, in.airspeed_mps, d_s);
  const double t0_s = s.time_s;
  const double t1_s = t0_s + dt_s;
  // The history as it will be after this step: the new sample on top of the ring (whose
  // oldest sample drops out if the ring is full). Nothing is written until the commit.
  const bool ring_full = s.history_count >= Cap::max_delay_samples;
  const detail::HistoryView<Scalar, Cap> view{&s, t1_s, clamp.x_rad,
                                              ring_full ? Cap::max_delay_samples : s.history_count + 1};
  const bool rest_before_oldest =
      !ring_full && s.history_origin == static_cast<int>(HistoryOrigin::rest_before_oldest);
  detail::DelayedForcing<Scalar, Cap> forcing{};
  for (int c = 0; c < m.set.n_coefficients; ++c) {
    if (m.set.coefficients[c].delay_s == Scalar(0)) continue;
    // Why: t0 - d before the oldest kept sample, with older samples already dropped, is an
    // angle the runtime no longer knows; refuse rather than guess (runtime.hpp warning 7).
    if (!rest_before_oldest && !(d_s[c] <= t0_s - view.time_s(view.size() - 1)))
      return StepStatus::delay_exceeds_history;
    forcing.x0_rad[c] = Scalar(delayed_angle(view, t0_s, d_s[c]));
    forcing.x1_rad[c] = Scalar(delayed_angle(view, t1_s, d_s[c]));
  }
  detail::StepBackup<Scalar, Cap> before;
  detail::save(s, &before);
  StallState<Scalar> stall_before[Cap::max_coefficients];
  std::memcpy(stall_before, s.stall, sizeof stall_before);
  Scalar value[Cap::max_coefficients];
  const bool families = m.stall != StallUse::none;
  const Scalar test = detail::advance_coefficients<detail::CoefficientLoop::rolled>(m, s, before, clamp.x_rad, clamp.model_x_rad,
                                                   Scalar(in.rate_radps), Scalar(dt_s), v, &forcing,
                                                   families ? s.stall : nullptr, value);
  if (!std::isfinite(test)) {
    detail::restore(before, &s);
    std::memcpy(s.stall, stall_before, sizeof stall_before);
    return StepStatus::non_finite_result;
  }
  detail::commit(m, value, clamp.model_x_rad, v, &s, out);
  detail::commit_history(t1_s, clamp.x_rad, ring_full, &s);
  s.delay_airspeed_mps = in.airspeed_mps;
  for (int c = 0; c < Cap::max_coefficients; ++c) s.delay_at_airspeed_s[c] = d_s[c];
  return clamp.status;
}

// How many history samples a run at a fixed step dt_s and airspeed needs so that no step
// returns delay_exceeds_history: 2 + ceil(d / dt_s) with d the longest delay of the model at
// that airspeed (2 without a delay: the two samples of the step). Compare it with
// Cap::max_delay_samples at initialisation. Conservative by one sample when d / dt_s is an
// exact integer (accumulated sample times round either way). 0 when dt_s / airspeed_mps is
// not finite and > 0; saturates at INT_MAX for absurd ratios.
template <class Scalar, class Cap>
inline int history_samples_needed(const RuntimeModel<Scalar, Cap>& m, double dt_s, double airspeed_mps) {
  if (!std::isfinite(dt_s) || !(dt_s > 0.0) || !std::isfinite(airspeed_mps) || !(airspeed_mps > 0.0))
    return 0;
  double longest_s = 0.0;
  for (int c = 0; c < m.set.n_coefficients; ++c) {
    const double d = delay_at_airspeed(static_cast<double>(m.set.coefficients[c].delay_s),
                                       m.set.airspeed_mps, airspeed_mps);
    if (d > longest_s) longest_s = d;
  }
  const double steps = std::ceil(longest_s / dt_s * (1.0 + 1e-9));
  // Why the saturation: the ratio may exceed int's range (tiny dt, tiny airspeed).
  if (!(steps < static_cast<double>(std::numeric_limits<int>::max() - 2)))
    return std::numeric_limits<int>::max();
  return 2 + static_cast<int>(steps);
}

// ------------------------------------------------------------------------------------------
// Predictor: the convenience of one instance -- a model (its own, loaded from text or a
// ModelSet, or a shared one used in place) and a DelayedState, behind member functions.
// ------------------------------------------------------------------------------------------
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
  static constexpr double max_dt_s = max_step_dt_s;

  struct Outputs {
    int count = 0;                        // number of coefficients (1..max_coefficients)
    Scalar value[Cap::max_coefficients] = {};
    const char* name[Cap::max_coefficients] = {};  // "CL", "Cm", ... in file order
  };

  // The whole mutable state (lag states, cached step ends and airspeed terms, delay ring).
  using Snapshot = DelayedState<Scalar, Cap>;
  using Model = ModelSet<Scalar, Cap>;
  using Runtime = RuntimeModel<Scalar, Cap>;

  // Parses (no heap) and validates a coefficient file; on success replaces the model and
  // leaves the predictor in PredictorPhase::loaded (reset() next). Defined in coef_file.hpp
  // (the parser): include "indicial/coef_file.hpp" to call it.
  LoadStatus load(const char* text, std::size_t length, ParseDiagnostic* diag = nullptr);

  // Loads a model built in code (validated exactly like a file; the static table's spline is
  // recomputed so a hand-built model need not prepare it) into the predictor's own storage.
  LoadStatus load(const ModelSet<double, Cap>& model, ParseDiagnostic* diag = nullptr) {
    const LoadStatus s = make_runtime_model(model, &own_, diag);
    if (s != LoadStatus::ok) return s;
    source_ = Source::owned;
    external_ = nullptr;
    state_ = Snapshot();
    state_.phase = static_cast<int>(PredictorPhase::loaded);
    return LoadStatus::ok;
  }

  // A generated model (`indicial codegen`) copied into the predictor (the old spelling; use()
  // avoids the copy).
  LoadStatus load(const RuntimeModel<double, Cap>& model, ParseDiagnostic* diag = nullptr) {
    return load(model.set, diag);
  }

  // Uses a shared model in place (no copy): checked once by check_runtime_model; it must
  // outlive the predictor's use of it (until the next load or use).
  LoadStatus use(const Runtime& model, ParseDiagnostic* diag = nullptr) {
    const LoadStatus s = check_runtime_model(model, diag);
    if (s != LoadStatus::ok) return s;
    source_ = Source::external;
    external_ = &model;
    state_ = Snapshot();
    state_.phase = static_cast<int>(PredictorPhase::loaded);
    return LoadStatus::ok;
  }

  // Sets every lag state to the steady state at the given motion angle (x' = 0), and the
  // delay history to "at rest at that angle since forever".
  StepStatus reset(double motion_angle_rad, double airspeed_mps) {
    if (source_ == Source::none) return StepStatus::not_loaded;
    return indicial::reset(runtime(), state_, motion_angle_rad, airspeed_mps);
  }

  // Advances the lag states from the previous sample to this one (dt_s later) and writes the
  // coefficients at this sample to *out.
  StepStatus step(const MotionInput& in, double dt_s, Outputs* out) {
    if (source_ == Source::none) return StepStatus::not_loaded;
    if (state_.phase != static_cast<int>(PredictorPhase::running)) return StepStatus::not_reset;
    if (out == nullptr) return StepStatus::null_output;
    const Runtime& m = runtime();
    // Straight into *out: indicial::step writes out->value only when it steps (a refusal
    // leaves *out as it was), and no copy of the Outputs lengthens the caller's chain.
    const StepStatus s = indicial::step(m, state_, in, dt_s, out->value);
    if (s != StepStatus::ok && s != StepStatus::angle_clamped) return s;
    // Entries a previous, larger model left beyond the new count are cleared (a branch never
    // taken in a loop over one model).
    if (out->count != m.set.n_coefficients) {
      for (int c = 0; c < Cap::max_coefficients; ++c) {
        if (c < m.set.n_coefficients) continue;
        out->value[c] = Scalar(0);
        out->name[c] = nullptr;
      }
    }
    out->count = m.set.n_coefficients;
    for (int c = 0; c < m.set.n_coefficients; ++c) out->name[c] = m.set.coefficients[c].name;
    return s;
  }

  // See indicial::history_samples_needed; 0 when nothing is loaded.
  int history_samples_needed(double dt_s, double airspeed_mps) const {
    if (source_ == Source::none) return 0;
    return indicial::history_samples_needed(runtime(), dt_s, airspeed_mps);
  }

  Snapshot snapshot() const { return state_; }

  // Restores a snapshot of this predictor (same model). Ignored while nothing is loaded. The
  // cached step ends and airspeed terms travel in the snapshot, so a restored predictor
  // steps bit for bit like the one the snapshot was taken from.
  void restore(const Snapshot& s) {
    if (source_ == Source::none) return;
    state_ = s;
    // A snapshot can never bring back the empty phase over a loaded model.
    if (state_.phase != static_cast<int>(PredictorPhase::running))
      state_.phase = static_cast<int>(PredictorPhase::loaded);
  }

  PredictorPhase phase() const {
    if (source_ == Source::none) return PredictorPhase::empty;
    return static_cast<PredictorPhase>(state_.phase);
  }
  const Runtime& runtime() const { return external_ != nullptr ? *external_ : own_; }
  const Model& model() const { return runtime().set; }
  Axis axis() const { return runtime().set.axis; }
  int coefficient_count() const { return source_ == Source::none ? 0 : runtime().set.n_coefficients; }

 private:
  enum class Source : int { none = 0, owned = 1, external = 2 };
  Runtime own_{};
  const Runtime* external_ = nullptr;
  Source source_ = Source::none;
  Snapshot state_{};
};

}  // namespace indicial
