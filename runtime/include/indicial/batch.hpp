// indicial/batch.hpp -- step many instances that share one model.
//
// What it is for
// --------------
// A Monte Carlo batch, a many-aircraft simulation or a vectorised FMU steps N independent
// states of one model with the same dt. step_batch does that block by block
// (batch_block instances at a time): the per-instance spline work is runtime.hpp's, and the
// exponentials exp(-z_j) of a whole block are taken at once on a structure of arrays with
// Eigen's vectorised array exp (fixed-size arrays: header-only, no heap). Results equal N
// single steps (indicial::step) to about 1 ulp of the exponential: within 1e-12 relative in
// double, relative to max(|value|, 0.01) where a coefficient crosses zero (measured 4.4e-16
// absolute over 45,000 outputs; tests/test_runtime_batch.cpp checks it).
//
// Usage
// -----
//   #include "indicial/batch.hpp"
//   indicial::State<double, indicial::DefaultCapacity> states[1024];   // reset each one first
//   double out[1024 * 2];                                           // n rows of n_coefficients
//   indicial::StepStatus s = indicial::step_batch(model, states, 1024, angle_rad, rate_radps,
//                                                  airspeed_mps, dt_s, out);
//
// Warnings
// --------
// 1. Needs Eigen 3.4 headers (only here: runtime.hpp alone does not). Without Eigen, loop over
//    indicial::step.
// 2. Each instance keeps its own status: a refused instance (bad input, not reset) is left
//    unchanged and its out row untouched; the others step. The return value is the first
//    refusal's status, else angle_clamped if any instance was clamped, else ok; pass
//    `status` (n entries) to get every instance's.
// 3. A model with a delay is stepped one instance at a time (DelayedState overload): the
//    history lookups do not vectorise.
#pragma once

#include <Eigen/Core>
#include <cstddef>

#include "indicial/runtime.hpp"

namespace indicial {

// Instances per block of step_batch: its structure-of-arrays working set stays in L1.
inline constexpr int batch_block = 8;

namespace detail {
template <class Scalar, class Cap>
using BlockArray = Eigen::Array<Scalar, batch_block, 1>;

// One instance of a block: its inputs after the checks and the work before the commit.
template <class Scalar, class Cap>
struct BatchLane {
  StepStatus status;  // ok / angle_clamped while active, else the refusal
  Scalar x1_rad;
  Scalar rate;
  AirspeedTerms<Scalar> v;
  StepResult<Scalar, Cap> r;
};

inline bool lane_active(StepStatus s) { return s == StepStatus::ok || s == StepStatus::angle_clamped; }

// The new end of coefficient c and its lag exponents z_j, per lane (runtime.hpp's sequence,
// minus the exponential).
template <class Scalar, class Cap>
inline void block_exponents(const RuntimeModel<Scalar, Cap>& m, int c, const State<Scalar, Cap>* s,
                            BatchLane<Scalar, Cap>* lane, int k, Scalar dt_s,
                            BlockArray<Scalar, Cap>* z) {
  const CoefficientModel<Scalar, Cap>& cm = m.set.coefficients[c];
  for (int i = 0; i < k; ++i) {
    if (!lane_active(lane[i].status)) continue;
    const StepGeometry<Scalar> g{s[i].x_prev_rad, lane[i].x1_rad, s[i].x_prev_rad, lane[i].x1_rad,
                                 dt_s, lane[i].v.time_scale};
    evaluate_step_end(cm, g.x1_rad, g.forcing_x1_rad, &lane[i].r.end[c]);
    for (int j = 0; j < cm.n_lags; ++j) z[j](i) = lag_exponent(cm, g, s[i].end[c], lane[i].r.end[c], j);
  }
}

// The lag updates and the output of coefficient c, per lane, given exp(-z_j).
template <class Scalar, class Cap>
inline void block_updates(const RuntimeModel<Scalar, Cap>& m, int c, const State<Scalar, Cap>* s,
                          BatchLane<Scalar, Cap>* lane, int k, Scalar dt_s,
                          const BlockArray<Scalar, Cap>* z, const BlockArray<Scalar, Cap>* decay) {
  const CoefficientModel<Scalar, Cap>& cm = m.set.coefficients[c];
  for (int i = 0; i < k; ++i) {
    if (!lane_active(lane[i].status)) continue;
    StepResult<Scalar, Cap>& r = lane[i].r;
    const StepGeometry<Scalar> g{s[i].x_prev_rad, lane[i].x1_rad, s[i].x_prev_rad, lane[i].x1_rad,
                                 dt_s, lane[i].v.time_scale};
    for (int j = 0; j < Cap::max_lags; ++j) r.y[c][j] = s[i].y[c][j];
    const Scalar forcing_integral =
        r.end[c].forcing_antiderivative - s[i].end[c].forcing_antiderivative;
    for (int j = 0; j < cm.n_lags; ++j) lag_update(cm, g, forcing_integral, z[j](i), decay[j](i), j, r.y[c]);
    r.value[c] = coefficient_output(cm, lane[i].x1_rad, lane[i].rate, lane[i].v.l_over_v_s, r.y[c]);
    bool finite = std::isfinite(r.value[c]);
    for (int j = 0; j < cm.n_lags; ++j) finite = finite && std::isfinite(r.y[c][j]);
    if (!finite) lane[i].status = StepStatus::non_finite_result;
  }
}

// One block of k <= batch_block instances.
template <class Scalar, class Cap>
inline void step_block(const RuntimeModel<Scalar, Cap>& m, State<Scalar, Cap>* s, int k,
                       const double* angle_rad, const double* rate_radps,
                       const double* airspeed_mps, double dt_s, Scalar* out, StepStatus* status) {
  BatchLane<Scalar, Cap> lane[batch_block];
  for (int i = 0; i < k; ++i) {
    const MotionInput in{angle_rad[i], rate_radps[i], airspeed_mps[i]};
    lane[i].status = check_step_input(s[i].phase, in, dt_s, out);
    if (lane[i].status != StepStatus::ok) continue;
    const Clamped<Scalar> clamp = clamp_model_angle(m, in.motion_angle_rad);
    lane[i].status = clamp.status;
    lane[i].x1_rad = clamp.x_rad;
    lane[i].rate = Scalar(in.rate_radps);
    lane[i].v = airspeed_terms(m, s[i], in.airspeed_mps);
  }
  const Scalar dt = Scalar(dt_s);
  for (int c = 0; c < m.set.n_coefficients; ++c) {
    BlockArray<Scalar, Cap> z[Cap::max_lags];
    BlockArray<Scalar, Cap> decay[Cap::max_lags];
    for (int j = 0; j < Cap::max_lags; ++j) z[j].setZero();
    block_exponents(m, c, s, lane, k, dt, z);
    for (int j = 0; j < m.set.coefficients[c].n_lags; ++j) decay[j] = (-z[j]).exp();
    block_updates(m, c, s, lane, k, dt, z, decay);
  }
  const int n_out = m.set.n_coefficients;
  for (int i = 0; i < k; ++i) {
    if (status != nullptr) status[i] = lane[i].status;
    if (lane_active(lane[i].status)) commit(m, lane[i].r, lane[i].x1_rad, lane[i].v, &s[i], out + i * n_out);
  }
}

inline bool batch_arguments_given(const void* states, const double* angle_rad, const double* rate_radps,
                                  const double* airspeed_mps, const void* out) {
  return states != nullptr && angle_rad != nullptr && rate_radps != nullptr &&
         airspeed_mps != nullptr && out != nullptr;
}

// The batch's status so far combined with one instance's: the first refusal wins, then
// angle_clamped, then ok.
inline StepStatus combine(StepStatus so_far, StepStatus lane) {
  if (!lane_active(so_far)) return so_far;
  if (!lane_active(lane)) return lane;
  return so_far == StepStatus::angle_clamped ? so_far : lane;
}
}  // namespace detail

// Steps n states of one undelayed model with a common dt_s; out receives n rows of
// m.set.n_coefficients values. See the warnings above for statuses.
template <class Scalar, class Cap>
inline StepStatus step_batch(const RuntimeModel<Scalar, Cap>& m, State<Scalar, Cap>* states, std::size_t n,
                             const double* angle_rad, const double* rate_radps,
                             const double* airspeed_mps, double dt_s, Scalar* out,
                             StepStatus* status = nullptr) {
  if (n == 0) return StepStatus::ok;
  if (!detail::batch_arguments_given(states, angle_rad, rate_radps, airspeed_mps, out))
    return StepStatus::null_output;
  if (m.delay != DelayUse::none) return StepStatus::delay_needs_history;
  StepStatus result = StepStatus::ok;
  const std::size_t n_out = static_cast<std::size_t>(m.set.n_coefficients);
  for (std::size_t b = 0; b < n; b += batch_block) {
    const int k = n - b < static_cast<std::size_t>(batch_block) ? static_cast<int>(n - b) : batch_block;
    StepStatus lane_status[batch_block];
    detail::step_block(m, states + b, k, angle_rad + b, rate_radps + b, airspeed_mps + b, dt_s,
                       out + b * n_out, lane_status);
    for (int i = 0; i < k; ++i) {
      if (status != nullptr) status[b + static_cast<std::size_t>(i)] = lane_status[i];
      result = detail::combine(result, lane_status[i]);
    }
  }
  return result;
}

// The same for DelayedStates (any model): one indicial::step per instance.
template <class Scalar, class Cap>
inline StepStatus step_batch(const RuntimeModel<Scalar, Cap>& m, DelayedState<Scalar, Cap>* states,
                             std::size_t n, const double* angle_rad, const double* rate_radps,
                             const double* airspeed_mps, double dt_s, Scalar* out,
                             StepStatus* status = nullptr) {
  if (n == 0) return StepStatus::ok;
  if (!detail::batch_arguments_given(states, angle_rad, rate_radps, airspeed_mps, out))
    return StepStatus::null_output;
  StepStatus result = StepStatus::ok;
  const std::size_t n_out = static_cast<std::size_t>(m.set.n_coefficients);
  for (std::size_t i = 0; i < n; ++i) {
    const StepStatus s = step(m, states[i], MotionInput{angle_rad[i], rate_radps[i], airspeed_mps[i]},
                              dt_s, out + i * n_out);
    if (status != nullptr) status[i] = s;
    result = detail::combine(result, s);
  }
  return result;
}

}  // namespace indicial
