// indicial/batch.hpp -- step many instances that share one model.
//
// What it is for
// --------------
// A Monte Carlo batch, a many-aircraft simulation or a vectorised FMU steps N independent
// states of one model with the same dt. step_batch does that block by block (batch_block = 8
// instances, the lanes): it gathers the block's states into a structure of arrays, evaluates
// the whole step on lane vectors -- the clamp (as selects), the airspeed terms, the spline
// antiderivatives A(x) and B_j(x) with their plus-function knots (a select per knot),
// b_j's interval mean, the exponentials (Eigen's vectorised array exp), phi1, the lag update,
// the static / correction / rotary output -- with model.hpp's `*_with<Ops>` bodies (the model's
// expressions written once, called here with the lane policy BatchLanes and by the scalar step
// with ScalarOps), then merges
// each lane's new state with its old one by its status and scatters the block back. With GCC
// and Clang the lane type is a vector extension, so every one of those operations is a SIMD
// instruction (SSE2 by default, AVX-512 with -march=native) whatever the auto-vectoriser does.
//
// Results equal N single steps (indicial::step) but for the exponential (Eigen's and the C
// library's differ by about an ulp): within 1e-12 relative in double, relative to
// max(|value|, 0.01) where a coefficient crosses zero (measured 3e-14;
// tests/test_runtime_batch.cpp checks it on every status path). In float the ulp of exp,
// amplified by phi1's 1 - exp(-z), gives about 1e-4 relative after a few hundred steps.
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
// 2. Each instance keeps its own status: a refused instance (bad input, not reset, a
//    non-finite result) is left bytewise unchanged and its out row untouched; the others step.
//    The return value is the first refusal's status, else angle_clamped if any instance was
//    clamped, else ok; pass `status` (n entries) to get every instance's.
// 3. A model with a delay is stepped one instance at a time (DelayedState overload): the
//    history lookups do not vectorise. A static TABLE curve is evaluated lane by lane (its
//    binary search); everything else of the step is vectorised.
// 4. Compile every translation unit of a program with the same target flags: the lane
//    functions are inline templates, and the linker keeps one copy of each.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstddef>

#include "indicial/runtime.hpp"

namespace indicial {

// Instances per block of step_batch (lanes): its structure-of-arrays working set (about 2 KB
// for double) stays in L1, and 8 doubles are one AVX-512 vector, four SSE2 ones.
inline constexpr int batch_block = 8;

namespace detail {
inline bool lane_active(StepStatus s) { return s == StepStatus::ok || s == StepStatus::angle_clamped; }

// The lane type of step_batch: batch_block Scalars with element-wise arithmetic. With GCC and
// Clang its storage is an array of vector-extension registers of the target's width (SSE2:
// 16 bytes, AVX: 32, AVX-512: 64), so that every operation, comparison and select is compiled
// to SIMD instructions (four SSE2 or one AVX-512 instruction on 8 doubles) whatever the
// auto-vectoriser decides; other compilers get plain loops. (A single 64-byte vector on an
// SSE2 target is lowered through memory: the register-width parts avoid that.) A struct, so
// that passing one by value never depends on the target's vector ABI (-Wpsabi).
#if defined(__GNUC__) || defined(__clang__)
#if defined(__AVX512F__)
inline constexpr int lane_register_bytes = 64;
#elif defined(__AVX__)
inline constexpr int lane_register_bytes = 32;
#else
inline constexpr int lane_register_bytes = 16;
#endif
template <class S>
struct LaneArray {
  static constexpr int bytes = batch_block * static_cast<int>(sizeof(S));
  static constexpr int part_bytes = bytes < lane_register_bytes ? bytes : lane_register_bytes;
  static constexpr int parts = bytes / part_bytes;
  typedef S Part __attribute__((vector_size(part_bytes)));
  Part p[parts];
  // GCC and Clang let a vector alias its element type.
  S& operator[](int i) { return reinterpret_cast<S*>(p)[i]; }
  const S& operator[](int i) const { return reinterpret_cast<const S*>(p)[i]; }
};

template <class S>
struct LaneMask {
  typedef decltype(typename LaneArray<S>::Part{} < typename LaneArray<S>::Part{}) Part;
  Part p[LaneArray<S>::parts];
  static constexpr int per_part = batch_block / LaneArray<S>::parts;
  bool operator[](int i) const { return p[i / per_part][i % per_part] != 0; }
};

#define INDICIAL_LANE_BINARY(op)                                                                 \
  template <class S> inline LaneArray<S> operator op(const LaneArray<S>& a, const LaneArray<S>& b) { \
    LaneArray<S> r; for (int k = 0; k < LaneArray<S>::parts; ++k) r.p[k] = a.p[k] op b.p[k]; return r; } \
  template <class S> inline LaneArray<S> operator op(const LaneArray<S>& a, S b) {                \
    LaneArray<S> r; for (int k = 0; k < LaneArray<S>::parts; ++k) r.p[k] = a.p[k] op b; return r; } \
  template <class S> inline LaneArray<S> operator op(S a, const LaneArray<S>& b) {                \
    LaneArray<S> r; for (int k = 0; k < LaneArray<S>::parts; ++k) r.p[k] = a op b.p[k]; return r; }
#define INDICIAL_LANE_COMPARE(op)                                                                \
  template <class S> inline LaneMask<S> operator op(const LaneArray<S>& a, S b) {                 \
    LaneMask<S> r; for (int k = 0; k < LaneArray<S>::parts; ++k) r.p[k] = a.p[k] op b; return r; } \
  template <class S> inline LaneMask<S> operator op(const LaneArray<S>& a, const LaneArray<S>& b) { \
    LaneMask<S> r; for (int k = 0; k < LaneArray<S>::parts; ++k) r.p[k] = a.p[k] op b.p[k]; return r; }
template <class S> inline LaneArray<S> operator-(const LaneArray<S>& a) {
  LaneArray<S> r;
  for (int k = 0; k < LaneArray<S>::parts; ++k) r.p[k] = -a.p[k];
  return r;
}
// As bit operations (a mask lane is all ones or all zeros).
template <class S>
inline LaneArray<S> lane_select(const LaneMask<S>& m, const LaneArray<S>& a, const LaneArray<S>& b) {
  using Part = typename LaneArray<S>::Part;
  using Bits = typename LaneMask<S>::Part;
  LaneArray<S> r;
  for (int k = 0; k < LaneArray<S>::parts; ++k)
    r.p[k] = (Part)(((Bits)a.p[k] & m.p[k]) | ((Bits)b.p[k] & ~m.p[k]));
  return r;
}
#else
template <class S>
struct LaneArray {
  S v[batch_block];
  S& operator[](int i) { return v[i]; }
  const S& operator[](int i) const { return v[i]; }
};
template <class S>
struct LaneMask {
  bool m[batch_block];
  bool operator[](int i) const { return m[i]; }
};
#define INDICIAL_LANE_BINARY(op)                                                                 \
  template <class S> inline LaneArray<S> operator op(const LaneArray<S>& a, const LaneArray<S>& b) { \
    LaneArray<S> r; for (int i = 0; i < batch_block; ++i) r.v[i] = a.v[i] op b.v[i]; return r; } \
  template <class S> inline LaneArray<S> operator op(const LaneArray<S>& a, S b) {                \
    LaneArray<S> r; for (int i = 0; i < batch_block; ++i) r.v[i] = a.v[i] op b; return r; }     \
  template <class S> inline LaneArray<S> operator op(S a, const LaneArray<S>& b) {                \
    LaneArray<S> r; for (int i = 0; i < batch_block; ++i) r.v[i] = a op b.v[i]; return r; }
#define INDICIAL_LANE_COMPARE(op)                                                                \
  template <class S> inline LaneMask<S> operator op(const LaneArray<S>& a, S b) {                 \
    LaneMask<S> r; for (int i = 0; i < batch_block; ++i) r.m[i] = a.v[i] op b; return r; }       \
  template <class S> inline LaneMask<S> operator op(const LaneArray<S>& a, const LaneArray<S>& b) { \
    LaneMask<S> r; for (int i = 0; i < batch_block; ++i) r.m[i] = a.v[i] op b.v[i]; return r; }
template <class S> inline LaneArray<S> operator-(const LaneArray<S>& a) {
  LaneArray<S> r;
  for (int i = 0; i < batch_block; ++i) r.v[i] = -a.v[i];
  return r;
}
template <class S>
inline LaneArray<S> lane_select(const LaneMask<S>& m, const LaneArray<S>& a, const LaneArray<S>& b) {
  LaneArray<S> r;
  for (int i = 0; i < batch_block; ++i) r.v[i] = m.m[i] ? a.v[i] : b.v[i];
  return r;
}
#endif
INDICIAL_LANE_BINARY(+)
INDICIAL_LANE_BINARY(-)
INDICIAL_LANE_BINARY(*)
INDICIAL_LANE_BINARY(/)
INDICIAL_LANE_COMPARE(<)
INDICIAL_LANE_COMPARE(>)
INDICIAL_LANE_COMPARE(==)
#undef INDICIAL_LANE_BINARY
#undef INDICIAL_LANE_COMPARE

// The lane policy of model.hpp's `*_with<Ops>` bodies (see ScalarOps there): selects where
// ScalarOps branches.
template <class S>
struct BatchLanes {
  using Scalar = S;
  using V = LaneArray<S>;
  static constexpr int width = batch_block;
  static V constant(S c) {
    V r;
    for (int i = 0; i < width; ++i) r[i] = c;
    return r;
  }
  static V one(const V&) { return constant(S(1)); }
  static S lift(const V&, double c) { return S(c); }
  static V select(const LaneMask<S>& m, const V& a, const V& b) { return lane_select(m, a, b); }
  template <class F> static void add_where(const LaneMask<S>& m, V* acc, F term) {
    const V sum = *acc + term();
    *acc = lane_select(m, sum, *acc);
  }
  template <class Fa, class Fb> static V choose(const LaneMask<S>& m, Fa a, Fb b) {
    return lane_select(m, a(), b());
  }
  static V abs(const V& v) { return lane_select(v < S(0), -v, v); }
  static LaneMask<S> abs_less(const V& v, double threshold) { return abs(v) < S(threshold); }
  static bool any(const LaneMask<S>& m) {
    bool r = false;
    for (int i = 0; i < width; ++i) r = r || m[i];
    return r;
  }
  // Not vectorised: a static TABLE's binary search, lane by lane.
  template <class Curve> static void table_value(const Curve& c, const V& x, V* r) {
    for (int i = 0; i < width; ++i) (*r)[i] = static_value(c, x[i]);
  }
};

// One block of the batch as a structure of arrays: one lane vector per quantity. Lanes past
// the block's count and refused lanes hold harmless finite values; their results are dropped
// by the merge.
template <class Scalar, class Cap>
struct BlockLanes {
  using Ops = BatchLanes<Scalar>;
  using V = typename Ops::V;
  static constexpr int W = batch_block;
  static constexpr int C = Cap::max_coefficients;
  static constexpr int L = Cap::max_lags;
  StepStatus status[W] = {};
  bool keep[W] = {};      // active (ok / angle_clamped) and, after the step, finite
  // Not initialised here (a block is built for every 8 instances): load_lanes fills every lane.
  V x0_rad;             // the state's x_prev_rad
  V x1_rad;             // the new model angle (clamped by prepare_lanes)
  V rate;
  V airspeed_mps;       // airspeed terms of this step
  V time_scale;
  V l_over_v_s;
  V time_scale_dt;      // time_scale * dt_s (StepGeometry's)
  V old_airspeed_mps;   // the state's cached airspeed terms
  V old_time_scale;
  V old_l_over_v_s;
  V forcing_antiderivative[C];  // A(x): the old end in, the new end out
  V b_antiderivative[C][L];     // B_j(x): the old end in, the new end out
  V y[C][L];                    // lag states: old in, new out
  V value[C];
};

// The input stage, per lane: the checks of indicial::step, the model angle, the state's
// cached quantities (a gather from the array of States).
template <class Scalar, class Cap>
inline void load_lanes(const RuntimeModel<Scalar, Cap>& m, const State<Scalar, Cap>* s, int k,
                       const double* angle_rad, const double* rate_radps,
                       const double* airspeed_mps, double dt_s, const void* out,
                       BlockLanes<Scalar, Cap>* b) {
  // Lanes past k (a partial last block): harmless values, never stored.
  for (int i = k; i < batch_block; ++i) {
    b->x0_rad[i] = b->x1_rad[i] = b->rate[i] = Scalar(0);
    b->airspeed_mps[i] = b->old_airspeed_mps[i] = b->old_time_scale[i] = b->old_l_over_v_s[i] = Scalar(1);
    for (int c = 0; c < Cap::max_coefficients; ++c) {
      b->forcing_antiderivative[c][i] = Scalar(0);
      for (int j = 0; j < Cap::max_lags; ++j) b->b_antiderivative[c][j][i] = b->y[c][j][i] = Scalar(0);
    }
  }
  for (int i = 0; i < k; ++i) {
    const MotionInput in{angle_rad[i], rate_radps[i], airspeed_mps[i]};
    b->status[i] = check_step_input(s[i].phase, in, dt_s, out);
    const bool active = b->status[i] == StepStatus::ok;
    b->keep[i] = active;
    // Why the substitutes: a refused lane is computed with the rest of its block and dropped;
    // its inputs may be NaN, so it gets finite ones (angle 0, rate 0, its cached airspeed).
    b->x1_rad[i] = model_angle_of(m, active ? in.motion_angle_rad : 0.0);
    b->rate[i] = Scalar(active ? in.rate_radps : 0.0);
    b->old_airspeed_mps[i] = s[i].airspeed_mps;
    b->old_time_scale[i] = s[i].time_scale;
    b->old_l_over_v_s[i] = s[i].l_over_v_s;
    b->airspeed_mps[i] = active ? Scalar(in.airspeed_mps) : s[i].airspeed_mps;
    b->x0_rad[i] = s[i].x_prev_rad;
    for (int c = 0; c < m.set.n_coefficients; ++c) {
      b->forcing_antiderivative[c][i] = s[i].end[c].forcing_antiderivative;
      for (int j = 0; j < Cap::max_lags; ++j) {
        b->b_antiderivative[c][j][i] = s[i].end[c].b_antiderivative[j];
        b->y[c][j][i] = s[i].y[c][j];
      }
    }
  }
}

// The clamp (clamp_model_angle's comparisons as selects) and the airspeed terms
// (airspeed_terms' cache test as a select), lane-wise.
template <class Scalar, class Cap>
inline void prepare_lanes(const RuntimeModel<Scalar, Cap>& m, Scalar dt_s, BlockLanes<Scalar, Cap>* b) {
  using Ops = BatchLanes<Scalar>;
  using V = typename Ops::V;
  const V x = b->x1_rad;
  const V low = Ops::constant(m.x_min_rad), high = Ops::constant(m.x_max_rad);
  b->x1_rad = Ops::select(x < m.x_min_rad, low, Ops::select(x > m.x_max_rad, high, x));
  for (int i = 0; i < batch_block; ++i) {
    if (b->status[i] == StepStatus::ok && (x[i] < m.x_min_rad || x[i] > m.x_max_rad))
      b->status[i] = StepStatus::angle_clamped;
  }
  const V v = b->airspeed_mps;
  const auto cached = v == b->old_airspeed_mps;
  b->time_scale = Ops::select(cached, b->old_time_scale, v / m.airspeed_mps);
  b->l_over_v_s = Ops::select(cached, b->old_l_over_v_s, m.reference_length_m / v);
  b->time_scale_dt = b->time_scale * dt_s;
}

// The model equations of coefficient c over one step for every lane (model.hpp's `*_with`
// bodies in advance_lags_between's sequence), with the exponentials of the block taken at once
// by Eigen's vectorised array exp. Clears keep where a result is not finite.
template <class Scalar, class Cap>
inline void advance_lanes(const CoefficientModel<Scalar, Cap>& cm, int c, BlockLanes<Scalar, Cap>* b) {
  using Ops = BatchLanes<Scalar>;
  using V = typename Ops::V;
  using Lanes = Eigen::Array<Scalar, batch_block, 1>;
  V end1, z, decay;
  end1 = spline_antiderivative_with<Ops>(cm.a, b->x1_rad);
  const V forcing_integral = end1 - b->forcing_antiderivative[c];
  b->forcing_antiderivative[c] = end1;
  for (int j = 0; j < cm.n_lags; ++j) {
    end1 = spline_antiderivative_with<Ops>(cm.lags[j].b, b->x1_rad);
    lag_exponent_with<Ops>(cm, j, b->x0_rad, b->x1_rad, b->b_antiderivative[c][j], end1,
                            b->time_scale_dt, &z);
    Lanes e;
    for (int i = 0; i < batch_block; ++i) e(i) = -z[i];
    e = e.exp();
    for (int i = 0; i < batch_block; ++i) decay[i] = e(i);
    lag_update_with<Ops>(cm, j, forcing_integral, b->time_scale_dt, z, decay, &b->y[c][j]);
    b->b_antiderivative[c][j] = end1;
  }
  // As advance_lags_between leaves them: B_j of the unused lags is 0 in a new StepEnd.
  for (int j = cm.n_lags; j < Cap::max_lags; ++j) b->b_antiderivative[c][j] = Ops::constant(Scalar(0));
  b->value[c] = coefficient_output_with<Ops>(cm, b->x1_rad, b->rate, b->l_over_v_s, b->y[c]);
  // Finite: x - x is 0 for a finite x, NaN for Inf and NaN.
  V finite_test = b->value[c] - b->value[c];
  for (int j = 0; j < cm.n_lags; ++j) finite_test = finite_test + (b->y[c][j] - b->y[c][j]);
  for (int i = 0; i < batch_block; ++i) b->keep[i] = b->keep[i] && finite_test[i] == Scalar(0);
}

// The commit: a lane that stepped (active, finite) takes its new state and writes its out row;
// any other lane's state is written back as it was read (a per-lane select of old and new, so
// its bytes do not change) and its out row is not touched.
template <class Scalar, class Cap>
inline void store_lanes(const RuntimeModel<Scalar, Cap>& m, int k, const BlockLanes<Scalar, Cap>& b,
                        State<Scalar, Cap>* s, Scalar* out, StepStatus* status) {
  const int n_out = m.set.n_coefficients;
  for (int i = 0; i < k; ++i) {
    const bool keep = b.keep[i];
    status[i] = b.status[i];
    if (lane_active(b.status[i]) && !keep) status[i] = StepStatus::non_finite_result;
    State<Scalar, Cap>& si = s[i];
    for (int c = 0; c < n_out; ++c) {
      si.end[c].forcing_antiderivative = keep ? b.forcing_antiderivative[c][i] : si.end[c].forcing_antiderivative;
      for (int j = 0; j < Cap::max_lags; ++j) {
        si.end[c].b_antiderivative[j] = keep ? b.b_antiderivative[c][j][i] : si.end[c].b_antiderivative[j];
        si.y[c][j] = keep ? b.y[c][j][i] : si.y[c][j];
      }
    }
    si.x_prev_rad = keep ? b.x1_rad[i] : si.x_prev_rad;
    si.airspeed_mps = keep ? b.airspeed_mps[i] : si.airspeed_mps;
    si.time_scale = keep ? b.time_scale[i] : si.time_scale;
    si.l_over_v_s = keep ? b.l_over_v_s[i] : si.l_over_v_s;
    if (!keep) continue;
    for (int c = 0; c < n_out; ++c) out[i * n_out + c] = b.value[c][i];
  }
}

// One block of k <= batch_block instances; status receives k statuses.
template <class Scalar, class Cap>
inline void step_block(const RuntimeModel<Scalar, Cap>& m, State<Scalar, Cap>* s, int k,
                       const double* angle_rad, const double* rate_radps,
                       const double* airspeed_mps, double dt_s, Scalar* out, StepStatus* status) {
  BlockLanes<Scalar, Cap> b;
  load_lanes(m, s, k, angle_rad, rate_radps, airspeed_mps, dt_s, out, &b);
  prepare_lanes(m, Scalar(dt_s), &b);
  for (int c = 0; c < m.set.n_coefficients; ++c) advance_lanes(m.set.coefficients[c], c, &b);
  store_lanes(m, k, b, s, out, status);
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
