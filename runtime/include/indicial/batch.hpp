// indicial/batch.hpp -- step many instances that share one model.
//
// What it is for
// --------------
// A Monte Carlo batch, a many-aircraft simulation or a vectorised FMU steps N independent
// states of one model with the same dt. step_batch does that block by block (batch_block = 8
// instances, the lanes): it checks each instance's input, gathers the block's states into a
// structure of arrays, evaluates the whole step on lane vectors -- the clamp (as selects), the
// airspeed terms, the spline antiderivatives A(x) and B_j(x) with their plus-function knots (a
// select per knot), b_j's interval mean, the exponentials, phi1, the lag update, the static /
// correction / rotary output -- with model.hpp's `*_with<Ops>` bodies (the model's expressions
// written once, called here with the lane policy BatchLanes and by the scalar step with
// ScalarOps), and scatters the block back, each instance only if it stepped. With GCC and
// Clang the lane type is a vector extension, so every one of those operations is a SIMD
// instruction whatever the auto-vectoriser does.
//
// Which instructions (BatchKernel)
// --------------------------------
//   portable   the translation unit's own target: SSE2 on x86-64 by default (two doubles per
//              instruction), AVX-512 under -march=native on a machine that has it, NEON on
//              AArch64, scalar code where the target has no vectors.
//   avx2       x86-64 with GCC or Clang, in a translation unit not already compiled for AVX2:
//              the same code compiled a second time for AVX2 (four doubles per instruction,
//              a target attribute on one function), run only on a CPU that has AVX2. No FMA,
//              so its results are bit-identical to the portable kernel's.
//   automatic  (the default) avx2 where it exists and the CPU has it, else portable.
// batch_kernel_in_use(k) says which kernel step_batch(..., k) runs on this CPU.
//
// Results equal N single steps (indicial::step). In float bit for bit: the lanes and the
// single float step take the same exponential (model.hpp's exp_on; within 1 ulp of std::exp,
// tests/test_lane_exp.cpp) and the same expressions in the same order
// (tests/test_runtime_batch.cpp; with the C library's expf in the single step, an ulp of exp
// amplified by phi1's 1 - exp(-z) made them differ by 1e-4 after a few hundred steps). In
// double the single step keeps the C library's exp (the fitter's, bit for bit) and the lanes
// exp_on: within 1e-12 relative, relative to max(|value|, 0.01) where a coefficient crosses
// zero (measured 3e-14; checked on every status path and with every kernel). Bit for bit
// assumes no fused multiply-add contraction (the default x86-64 and AVX2 kernels have none).
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
// 1. Each instance keeps its own status: a refused instance (bad input, not reset, a
//    non-finite result) is left bytewise unchanged and its out row untouched; the others step.
//    The return value is the first refusal's status, else angle_clamped if any instance was
//    clamped, else ok; pass `status` (n entries) to get every instance's.
// 2. A model with a delay is stepped one instance at a time (DelayedState overload): the
//    history lookups do not vectorise. A static TABLE curve is evaluated lane by lane (its
//    binary search), and so are the dynamic-stall families (FamilyState overload: model.hpp's
//    advance_stall branches on values and is not written on the lane policy; their states
//    are bit for bit single steps'); everything else of the step is vectorised.
// 3. Translation units compiled for different targets may be linked together: everything
//    here sits in an inline namespace named after the target (lanes_sse2, lanes_avx2_fma, ...),
//    so the linker never swaps one target's copy of an inline function for another's.
// 4. Not for -ffast-math (an #error below): lane_exp rounds to an integer by adding and
//    subtracting 1.5 * 2^52, which re-association would remove, and the finite checks need
//    IEEE infinities and NaN.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <type_traits>

#include "indicial/runtime.hpp"

#if defined(__FAST_MATH__)
#error "indicial/batch.hpp needs IEEE arithmetic: do not compile it with -ffast-math"
#endif

#if defined(__GNUC__) || defined(__clang__)
#define INDICIAL_LANE_VECTORS 1
#if !defined(INDICIAL_PLAIN_INLINING)  // (model.hpp's INDICIAL_HOT_INLINE says why)
#define INDICIAL_LANE_INLINE inline __attribute__((always_inline))
#define INDICIAL_LANE_FLATTEN __attribute__((flatten))
#else
#define INDICIAL_LANE_INLINE inline
#define INDICIAL_LANE_FLATTEN
#endif
#else
#define INDICIAL_LANE_VECTORS 0
#define INDICIAL_LANE_INLINE inline
#define INDICIAL_LANE_FLATTEN
#endif

// The second, AVX2 kernel: x86-64, GCC or Clang, and a translation unit that is not already
// compiled for AVX2 (then the portable kernel is at least as wide). INDICIAL_NO_AVX2_KERNEL
// turns it off.
#if INDICIAL_LANE_VECTORS && defined(__x86_64__) && !defined(__AVX2__) && \
    !defined(INDICIAL_NO_AVX2_KERNEL)
#define INDICIAL_AVX2_KERNEL 1
#else
#define INDICIAL_AVX2_KERNEL 0
#endif

// The inline namespace of this translation unit's target (warning 3).
#if defined(__AVX512F__)
#define INDICIAL_LANE_ABI lanes_avx512
#elif defined(__AVX2__) && defined(__FMA__)
#define INDICIAL_LANE_ABI lanes_avx2_fma
#elif defined(__AVX2__)
#define INDICIAL_LANE_ABI lanes_avx2
#elif defined(__AVX__)
#define INDICIAL_LANE_ABI lanes_avx
#elif defined(__x86_64__)
#define INDICIAL_LANE_ABI lanes_sse2
#else
#define INDICIAL_LANE_ABI lanes_generic
#endif

namespace indicial {
inline namespace INDICIAL_LANE_ABI {

// Instances per block of step_batch (lanes): its structure-of-arrays working set (about 2 KB
// for double) stays in L1, and 8 doubles are one AVX-512 vector, two AVX2 or four SSE2 ones.
// (Measured on Model II with SSE2: blocks of 4 run 1.15x and of 16 1.4x the time of 8.)
inline constexpr int batch_block = 8;

// Which instructions step_batch uses (see "Which instructions" above).
enum class BatchKernel : int { automatic = 0, portable = 1, avx2 = 2 };

inline const char* to_string(BatchKernel k) {
  return k == BatchKernel::avx2 ? "avx2" : k == BatchKernel::portable ? "portable" : "automatic";
}

// The kernel step_batch(..., requested) runs on this CPU: avx2 only where it was compiled and
// the CPU has it (a request for it elsewhere runs portable), portable when asked for.
inline BatchKernel batch_kernel_in_use(BatchKernel requested = BatchKernel::automatic) {
#if INDICIAL_AVX2_KERNEL
  if (requested != BatchKernel::portable && __builtin_cpu_supports("avx2")) return BatchKernel::avx2;
#endif
  (void)requested;
  return BatchKernel::portable;
}

namespace batch_detail {
inline bool lane_active(StepStatus s) { return s == StepStatus::ok || s == StepStatus::angle_clamped; }

// The widest vector register of this translation unit's target, in bytes.
#if defined(__AVX512F__)
inline constexpr int portable_lane_bytes = 64;
#elif defined(__AVX__)
inline constexpr int portable_lane_bytes = 32;
#else
inline constexpr int portable_lane_bytes = 16;
#endif

// The lane type of step_batch: batch_block Scalars with element-wise arithmetic, stored as
// vector-extension parts of RegisterBytes each (16: SSE2 / NEON, 32: AVX, 64: AVX-512), so
// that every operation, comparison and select is compiled to SIMD instructions (four SSE2 or
// one AVX-512 instruction on 8 doubles) whatever the auto-vectoriser decides; other compilers
// get plain loops. (A single 64-byte vector on an SSE2 target is lowered through memory: the
// register-width parts avoid that.) A struct, so that passing one by value never depends on
// the target's vector ABI (-Wpsabi).
#if INDICIAL_LANE_VECTORS
template <class S, int RegisterBytes>
struct LaneArray {
  static constexpr int bytes = batch_block * static_cast<int>(sizeof(S));
  static constexpr int part_bytes = bytes < RegisterBytes ? bytes : RegisterBytes;
  static constexpr int parts = bytes / part_bytes;
  static constexpr int per_part = batch_block / parts;
  typedef S Part __attribute__((vector_size(part_bytes)));
  Part p[parts];
  // GCC and Clang let a vector alias its element type.
  S& operator[](int i) { return reinterpret_cast<S*>(p)[i]; }
  const S& operator[](int i) const { return reinterpret_cast<const S*>(p)[i]; }
};

template <class S, int RegisterBytes>
struct LaneMask {
  using Lanes = LaneArray<S, RegisterBytes>;
  typedef decltype(typename Lanes::Part{} < typename Lanes::Part{}) Part;
  Part p[Lanes::parts];
  bool operator[](int i) const { return p[i / Lanes::per_part][i % Lanes::per_part] != 0; }
};

#define INDICIAL_LANE_BINARY(op)                                                                   \
  template <class S, int R>                                                                        \
  INDICIAL_LANE_INLINE LaneArray<S, R> operator op(const LaneArray<S, R>& a, const LaneArray<S, R>& b) { \
    LaneArray<S, R> r;                                                                             \
    for (int k = 0; k < LaneArray<S, R>::parts; ++k) r.p[k] = a.p[k] op b.p[k];                    \
    return r;                                                                                      \
  }                                                                                                \
  template <class S, int R>                                                                        \
  INDICIAL_LANE_INLINE LaneArray<S, R> operator op(const LaneArray<S, R>& a, S b) {                \
    LaneArray<S, R> r;                                                                             \
    for (int k = 0; k < LaneArray<S, R>::parts; ++k) r.p[k] = a.p[k] op b;                         \
    return r;                                                                                      \
  }                                                                                                \
  template <class S, int R>                                                                        \
  INDICIAL_LANE_INLINE LaneArray<S, R> operator op(S a, const LaneArray<S, R>& b) {                \
    LaneArray<S, R> r;                                                                             \
    for (int k = 0; k < LaneArray<S, R>::parts; ++k) r.p[k] = a op b.p[k];                         \
    return r;                                                                                      \
  }
#define INDICIAL_LANE_COMPARE(op)                                                                  \
  template <class S, int R>                                                                        \
  INDICIAL_LANE_INLINE LaneMask<S, R> operator op(const LaneArray<S, R>& a, S b) {                 \
    LaneMask<S, R> r;                                                                              \
    for (int k = 0; k < LaneArray<S, R>::parts; ++k) r.p[k] = a.p[k] op b;                         \
    return r;                                                                                      \
  }                                                                                                \
  template <class S, int R>                                                                        \
  INDICIAL_LANE_INLINE LaneMask<S, R> operator op(const LaneArray<S, R>& a, const LaneArray<S, R>& b) { \
    LaneMask<S, R> r;                                                                              \
    for (int k = 0; k < LaneArray<S, R>::parts; ++k) r.p[k] = a.p[k] op b.p[k];                    \
    return r;                                                                                      \
  }
template <class S, int R>
INDICIAL_LANE_INLINE LaneArray<S, R> operator-(const LaneArray<S, R>& a) {
  LaneArray<S, R> r;
  for (int k = 0; k < LaneArray<S, R>::parts; ++k) r.p[k] = -a.p[k];
  return r;
}
template <class S, int R>
INDICIAL_LANE_INLINE LaneMask<S, R> operator|(const LaneMask<S, R>& a, const LaneMask<S, R>& b) {
  LaneMask<S, R> r;
  for (int k = 0; k < LaneArray<S, R>::parts; ++k) r.p[k] = a.p[k] | b.p[k];
  return r;
}
template <class S, int R>
INDICIAL_LANE_INLINE LaneArray<S, R> lane_constant(S c) {
  LaneArray<S, R> r;
  for (int k = 0; k < LaneArray<S, R>::parts; ++k) r.p[k] = typename LaneArray<S, R>::Part{} + c;
  return r;
}
// As bit operations (a mask lane is all ones or all zeros).
template <class S, int R>
INDICIAL_LANE_INLINE LaneArray<S, R> lane_select(const LaneMask<S, R>& m, const LaneArray<S, R>& a,
                                                 const LaneArray<S, R>& b) {
  using Part = typename LaneArray<S, R>::Part;
  using Bits = typename LaneMask<S, R>::Part;
  LaneArray<S, R> r;
  for (int k = 0; k < LaneArray<S, R>::parts; ++k)
    r.p[k] = (Part)(((Bits)a.p[k] & m.p[k]) | ((Bits)b.p[k] & ~m.p[k]));
  return r;
}
// |v|: the sign bit cleared.
template <class S, int R>
INDICIAL_LANE_INLINE LaneArray<S, R> lane_abs(const LaneArray<S, R>& v) {
  using Part = typename LaneArray<S, R>::Part;
  using Bits = typename LaneMask<S, R>::Part;
  const Bits sign = (Bits)(-Part{});  // -0.0 in every lane: the sign bit alone
  LaneArray<S, R> r;
  for (int k = 0; k < LaneArray<S, R>::parts; ++k) r.p[k] = (Part)((Bits)v.p[k] & ~sign);
  return r;
}
template <class S, int R>
INDICIAL_LANE_INLINE bool lane_any(const LaneMask<S, R>& m) {
  typename LaneMask<S, R>::Part all = m.p[0];
  for (int k = 1; k < LaneArray<S, R>::parts; ++k) all = all | m.p[k];
  bool r = false;
  for (int i = 0; i < LaneArray<S, R>::per_part; ++i) r = r || all[i] != 0;
  return r;
}

// A lane vector's bit pattern and back: model.hpp's exp_on on a Part of lanes.
// (Bits is declared here: a vector typedef passed as a template argument loses its vector_size.)
template <class S, class Part>
struct LaneBitCast {
  typedef typename ExpConstants<S>::Bits Bits __attribute__((vector_size(sizeof(Part))));
  INDICIAL_LANE_INLINE static void to(const Part& v, Bits* b) { *b = (Bits)v; }
  INDICIAL_LANE_INLINE static void from(const Bits& b, Part* v) { *v = (Part)b; }
};

// exp lane-wise: model.hpp's exp_on, the float single step's exponential, on each part of
// lanes, so that a float batch gives the single step's bits (within 1 ulp of the C library's
// exp, tests/test_lane_exp.cpp).
//
// Why written by hand (exp_on is the one hand-written function of the batch): Eigen's
// vectorised exp is compiled for the translation unit's target only, so it cannot serve the
// AVX2 kernel of an SSE2 build, and it would make Eigen a dependency of the runtime's header.
template <class S, int R>
INDICIAL_LANE_INLINE LaneArray<S, R> lane_exp(const LaneArray<S, R>& x) {
  using Part = typename LaneArray<S, R>::Part;
  LaneArray<S, R> r;
  for (int k = 0; k < LaneArray<S, R>::parts; ++k) exp_on<S, Part, LaneBitCast<S, Part>>(x.p[k], &r.p[k]);
  return r;
}
#else
template <class S, int RegisterBytes>
struct LaneArray {
  static constexpr int parts = 1;
  S v[batch_block];
  S& operator[](int i) { return v[i]; }
  const S& operator[](int i) const { return v[i]; }
};
template <class S, int RegisterBytes>
struct LaneMask {
  bool m[batch_block];
  bool operator[](int i) const { return m[i]; }
};
#define INDICIAL_LANE_BINARY(op)                                                                   \
  template <class S, int R>                                                                        \
  inline LaneArray<S, R> operator op(const LaneArray<S, R>& a, const LaneArray<S, R>& b) {         \
    LaneArray<S, R> r;                                                                             \
    for (int i = 0; i < batch_block; ++i) r.v[i] = a.v[i] op b.v[i];                               \
    return r;                                                                                      \
  }                                                                                                \
  template <class S, int R>                                                                        \
  inline LaneArray<S, R> operator op(const LaneArray<S, R>& a, S b) {                              \
    LaneArray<S, R> r;                                                                             \
    for (int i = 0; i < batch_block; ++i) r.v[i] = a.v[i] op b;                                    \
    return r;                                                                                      \
  }                                                                                                \
  template <class S, int R>                                                                        \
  inline LaneArray<S, R> operator op(S a, const LaneArray<S, R>& b) {                              \
    LaneArray<S, R> r;                                                                             \
    for (int i = 0; i < batch_block; ++i) r.v[i] = a op b.v[i];                                    \
    return r;                                                                                      \
  }
#define INDICIAL_LANE_COMPARE(op)                                                                  \
  template <class S, int R>                                                                        \
  inline LaneMask<S, R> operator op(const LaneArray<S, R>& a, S b) {                               \
    LaneMask<S, R> r;                                                                              \
    for (int i = 0; i < batch_block; ++i) r.m[i] = a.v[i] op b;                                    \
    return r;                                                                                      \
  }                                                                                                \
  template <class S, int R>                                                                        \
  inline LaneMask<S, R> operator op(const LaneArray<S, R>& a, const LaneArray<S, R>& b) {          \
    LaneMask<S, R> r;                                                                              \
    for (int i = 0; i < batch_block; ++i) r.m[i] = a.v[i] op b.v[i];                               \
    return r;                                                                                      \
  }
template <class S, int R>
inline LaneArray<S, R> operator-(const LaneArray<S, R>& a) {
  LaneArray<S, R> r;
  for (int i = 0; i < batch_block; ++i) r.v[i] = -a.v[i];
  return r;
}
template <class S, int R>
inline LaneMask<S, R> operator|(const LaneMask<S, R>& a, const LaneMask<S, R>& b) {
  LaneMask<S, R> r;
  for (int i = 0; i < batch_block; ++i) r.m[i] = a.m[i] || b.m[i];
  return r;
}
template <class S, int R>
inline LaneArray<S, R> lane_constant(S c) {
  LaneArray<S, R> r;
  for (int i = 0; i < batch_block; ++i) r.v[i] = c;
  return r;
}
template <class S, int R>
inline LaneArray<S, R> lane_select(const LaneMask<S, R>& m, const LaneArray<S, R>& a,
                                   const LaneArray<S, R>& b) {
  LaneArray<S, R> r;
  for (int i = 0; i < batch_block; ++i) r.v[i] = m.m[i] ? a.v[i] : b.v[i];
  return r;
}
template <class S, int R>
inline LaneArray<S, R> lane_abs(const LaneArray<S, R>& a) {
  LaneArray<S, R> r;
  for (int i = 0; i < batch_block; ++i) r.v[i] = std::fabs(a.v[i]);
  return r;
}
template <class S, int R>
inline bool lane_any(const LaneMask<S, R>& m) {
  bool r = false;
  for (int i = 0; i < batch_block; ++i) r = r || m.m[i];
  return r;
}
template <class S, int R>
inline LaneArray<S, R> lane_exp(const LaneArray<S, R>& x) {
  LaneArray<S, R> r;
  for (int i = 0; i < batch_block; ++i) exp_on<S, S, detail::ScalarBitCast<S>>(x.v[i], &r.v[i]);
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
INDICIAL_LANE_COMPARE(!=)
#undef INDICIAL_LANE_BINARY
#undef INDICIAL_LANE_COMPARE

// Fills lane i of *v with f(i) for every lane.
template <class S, int R, class F>
INDICIAL_LANE_INLINE void gather_lanes(LaneArray<S, R>* v, F f) {
#if INDICIAL_LANE_VECTORS
  using Lanes = LaneArray<S, R>;
  for (int k = 0; k < Lanes::parts; ++k) {
    typename Lanes::Part part = {};
    for (int i = 0; i < Lanes::per_part; ++i) part[i] = f(k * Lanes::per_part + i);
    v->p[k] = part;
  }
#else
  for (int i = 0; i < batch_block; ++i) (*v)[i] = f(i);
#endif
}

// The lane policy of model.hpp's `*_with<Ops>` bodies (see ScalarOps there): selects where
// ScalarOps branches.
template <class S, int R>
struct BatchLanes {
  using Scalar = S;
  using V = LaneArray<S, R>;
  using Mask = LaneMask<S, R>;
  static constexpr int width = batch_block;
  INDICIAL_LANE_INLINE static V constant(S c) { return lane_constant<S, R>(c); }
  INDICIAL_LANE_INLINE static V one(const V&) { return constant(S(1)); }
  INDICIAL_LANE_INLINE static S lift(const V&, double c) { return S(c); }
  INDICIAL_LANE_INLINE static V select(const Mask& m, const V& a, const V& b) { return lane_select(m, a, b); }
  template <class F>
  INDICIAL_LANE_INLINE static void add_where(const Mask& m, V* acc, F term) {
    const V sum = *acc + term();
    *acc = lane_select(m, sum, *acc);
  }
  template <class Fa, class Fb>
  INDICIAL_LANE_INLINE static V choose(const Mask& m, Fa a, Fb b) {
    return lane_select(m, a(), b());
  }
  INDICIAL_LANE_INLINE static V abs(const V& v) { return lane_abs(v); }
  INDICIAL_LANE_INLINE static Mask abs_less(const V& v, double threshold) { return lane_abs(v) < S(threshold); }
  INDICIAL_LANE_INLINE static bool any(const Mask& m) { return lane_any(m); }
  // Not vectorised: a static TABLE's binary search, lane by lane.
  template <class Curve>
  static void table_value(const Curve& c, const V& x, V* r) {
    for (int i = 0; i < width; ++i) (*r)[i] = static_value(c, x[i]);
  }
};

// One block of the batch as a structure of arrays: one lane vector per quantity. Refused
// lanes hold harmless finite values; their results are dropped by the scatter.
template <class Scalar, class Cap, int R>
struct BlockLanes {
  using V = LaneArray<Scalar, R>;
  static constexpr int W = batch_block;
  static constexpr int C = Cap::max_coefficients;
  static constexpr int L = Cap::max_lags;
  StepStatus status[W];
  bool active[W];       // ok / angle_clamped after the input checks
  bool all_active;
  // Not initialised here (a block is built for every 8 instances): load_lanes fills them.
  V x0_rad;             // the state's previous angle, clamped (detail::clamp_to_envelope of model_x_prev_rad)
  V x1_rad;             // the new model angle (clamped to the envelope)
  V x1_model_rad;       // the new model angle itself (a static table's, runtime.hpp warning 3)
  V rate;
  V airspeed_mps;       // airspeed terms of this step
  V time_scale;
  V l_over_v_s;
  V time_scale_dt;      // time_scale * dt_s (StepGeometry's)
  V forcing_antiderivative[C];  // A(x): the old end in, the new end out
  V b_antiderivative[C][L];     // B_j(x): the old end in, the new end out
  V y[C][L];                    // lag states: old in, new out
  V value[C];
  V finite_test;                // 0 where every result of the lane is finite, else NaN
};

// runtime.hpp's detail::clamp_to_envelope on every lane (the same two comparisons, hence the same
// bits).
template <class Scalar, class Cap, int R>
INDICIAL_LANE_INLINE LaneArray<Scalar, R> clamp_lanes_to_envelope(const RuntimeModel<Scalar, Cap>& m,
                                                                  const LaneArray<Scalar, R>& x_rad) {
  return lane_select(x_rad < m.x_min_rad, lane_constant<Scalar, R>(m.x_min_rad),
                     lane_select(x_rad > m.x_max_rad, lane_constant<Scalar, R>(m.x_max_rad), x_rad));
}

// The input checks of indicial::step for each lane of a full block, and the model angle with
// its clamp status. A refused lane gets finite substitutes (angle 0, rate 0, its cached
// airspeed): it is computed with its block and dropped.
template <class Scalar, class Cap, int R, class St>
INDICIAL_LANE_INLINE void check_lanes(const RuntimeModel<Scalar, Cap>& m, const St* s,
                                      const double* angle_rad, const double* rate_radps,
                                      const double* airspeed_mps, double dt_s, const void* out,
                                      BlockLanes<Scalar, Cap, R>* b) {
  bool all_active = true;
  Scalar x[batch_block];
  for (int i = 0; i < batch_block; ++i) {
    const StepStatus st = indicial::detail::check_step_input(s[i].phase, {angle_rad[i], rate_radps[i], airspeed_mps[i]},
                                           dt_s, out);
    const bool active = st == StepStatus::ok;
    x[i] = indicial::detail::model_angle_of(m, active ? angle_rad[i] : 0.0);
    const bool clamped = x[i] < m.x_min_rad || x[i] > m.x_max_rad;
    b->status[i] = active && clamped ? StepStatus::angle_clamped : st;
    b->active[i] = active;
    all_active = all_active && active;
  }
  b->all_active = all_active;
  using V = LaneArray<Scalar, R>;
  const V motion = [&] { V v; gather_lanes(&v, [&](int i) { return x[i]; }); return v; }();
  b->x1_model_rad = motion;
  b->x1_rad = clamp_lanes_to_envelope(m, motion);
  gather_lanes(&b->rate, [&](int i) { return Scalar(b->active[i] ? rate_radps[i] : 0.0); });
  gather_lanes(&b->airspeed_mps, [&](int i) {
    return b->active[i] ? Scalar(airspeed_mps[i]) : s[i].airspeed_mps;
  });
}

// The state's quantities the step reads (a gather from the array of States; only the
// coefficients and lags the model has), and the airspeed terms (model.hpp's airspeed_scaling,
// with airspeed_terms' cache test as a select).
template <class Scalar, class Cap, int R, class St>
INDICIAL_LANE_INLINE void load_lanes(const RuntimeModel<Scalar, Cap>& m, const St* s,
                                     Scalar dt_s, BlockLanes<Scalar, Cap, R>* b) {
  using V = LaneArray<Scalar, R>;
  V model_x0;
  gather_lanes(&model_x0, [&](int i) { return s[i].model_x_prev_rad; });
  b->x0_rad = clamp_lanes_to_envelope(m, model_x0);
  V old_airspeed, old_time_scale, old_l_over_v;
  gather_lanes(&old_airspeed, [&](int i) { return s[i].airspeed_mps; });
  gather_lanes(&old_time_scale, [&](int i) { return s[i].time_scale; });
  gather_lanes(&old_l_over_v, [&](int i) { return s[i].l_over_v_s; });
  const V v = b->airspeed_mps;
  const auto cached = v == old_airspeed;
  const AirspeedScaling<V> scaling = airspeed_scaling(lane_constant<Scalar, R>(m.airspeed_mps),
                                                      lane_constant<Scalar, R>(m.reference_length_m), v);
  b->time_scale = lane_select(cached, old_time_scale, scaling.time_scale);
  b->l_over_v_s = lane_select(cached, old_l_over_v, scaling.l_over_v_s);
  b->time_scale_dt = b->time_scale * dt_s;
  for (int c = 0; c < m.set.n_coefficients; ++c) {
    gather_lanes(&b->forcing_antiderivative[c], [&](int i) { return s[i].end[c].forcing_antiderivative; });
    for (int j = 0; j < m.set.coefficients[c].n_lags; ++j) {
      gather_lanes(&b->b_antiderivative[c][j], [&](int i) { return s[i].end[c].b_antiderivative[j]; });
      gather_lanes(&b->y[c][j], [&](int i) { return s[i].y[c][j]; });
    }
  }
}

// The model equations of coefficient c over one step for every lane (model.hpp's `*_with`
// bodies in advance_lags_between's sequence, lane_exp between them). Accumulates the finite
// test of its results.
template <class Scalar, class Cap, int R>
INDICIAL_LANE_INLINE void advance_lanes(const CoefficientModel<Scalar, Cap>& cm, int c,
                                        BlockLanes<Scalar, Cap, R>* b) {
  using Ops = BatchLanes<Scalar, R>;
  using V = typename Ops::V;
  V end1 = spline_antiderivative_with<Ops>(cm.a, b->x1_rad);
  const V forcing_integral = end1 - b->forcing_antiderivative[c];
  b->forcing_antiderivative[c] = end1;
  for (int j = 0; j < cm.n_lags; ++j) {
    end1 = spline_antiderivative_with<Ops>(cm.lags[j].b, b->x1_rad);
    V z;
    lag_exponent_with<Ops>(cm, j, b->x0_rad, b->x1_rad, b->b_antiderivative[c][j], end1,
                           b->time_scale_dt, &z);
    const V decay = lane_exp(-z);
    lag_update_with<Ops>(cm, j, forcing_integral, b->time_scale_dt, z, decay, &b->y[c][j]);
    b->b_antiderivative[c][j] = end1;
    b->finite_test = b->finite_test + (b->y[c][j] - b->y[c][j]);
  }
  b->value[c] = coefficient_output_with<Ops>(cm, b->x1_rad, b->x1_model_rad, b->rate, b->l_over_v_s, b->y[c]);
  // x - x is 0 for a finite x, NaN for Inf and NaN.
  b->finite_test = b->finite_test + (b->value[c] - b->value[c]);
}

// Lane i of a block that stepped into its State and out row: the coefficients and lags the
// model has; B_j of the unused lags is 0, as advance_lags_between leaves it in a new StepEnd.
template <class Scalar, class Cap, int R>
INDICIAL_LANE_INLINE void scatter_lane(const RuntimeModel<Scalar, Cap>& m, const BlockLanes<Scalar, Cap, R>& b,
                                       int i, State<Scalar, Cap>* s, Scalar* out) {
  const int n_out = m.set.n_coefficients;
  for (int c = 0; c < n_out; ++c) {
    const int n_lags = m.set.coefficients[c].n_lags;
    s->end[c].forcing_antiderivative = b.forcing_antiderivative[c][i];
    // Over the capacity (a loop of a constant count, unrolled; over n_lags GCC calls memset).
    for (int j = 0; j < Cap::max_lags; ++j) {
      if (j < n_lags) {
        s->end[c].b_antiderivative[j] = b.b_antiderivative[c][j][i];
        s->y[c][j] = b.y[c][j][i];
      } else {
        s->end[c].b_antiderivative[j] = Scalar(0);
      }
    }
    out[c] = b.value[c][i];
  }
  s->model_x_prev_rad = b.x1_model_rad[i];
  s->airspeed_mps = b.airspeed_mps[i];
  s->time_scale = b.time_scale[i];
  s->l_over_v_s = b.l_over_v_s[i];
}

// The dynamic-stall families of a block (FamilyState only): the single step's
// detail::advance_families (runtime.hpp) lane by lane, on the lanes' own angles and airspeed
// terms, with the lookups its coefficients share (RuntimeModel::stall_sharing) made once per
// lane -- the scalar step's code and exp, so the family states are bit for bit a single step's
// (their update branches on values: it is not on the lane policy); the output joins the
// lane's value. A plain State
// has none: the empty overloads compile to nothing.
template <class St>
struct BlockFamilies {};
template <class Scalar, class Cap>
struct BlockFamilies<FamilyState<Scalar, Cap>> {
  StallState<Scalar> stall[batch_block][Cap::max_coefficients];
};

template <class Scalar, class Cap, int R>
INDICIAL_LANE_INLINE void advance_lane_families(const RuntimeModel<Scalar, Cap>&, const State<Scalar, Cap>*,
                                                Scalar, BlockLanes<Scalar, Cap, R>*,
                                                BlockFamilies<State<Scalar, Cap>>*) {}

template <class Scalar, class Cap, int R>
inline void advance_lane_families(const RuntimeModel<Scalar, Cap>& m, const FamilyState<Scalar, Cap>* s,
                                  Scalar dt_s, BlockLanes<Scalar, Cap, R>* b,
                                  BlockFamilies<FamilyState<Scalar, Cap>>* f) {
  for (int i = 0; i < batch_block; ++i) {
    if (!b->active[i]) continue;
    const StallStep<Scalar> g{b->x0_rad[i], b->x1_rad[i], dt_s, b->l_over_v_s[i]};
    Scalar value[Cap::max_coefficients];
    for (int c = 0; c < m.set.n_coefficients; ++c) {
      value[c] = b->value[c][i];
      f->stall[i][c] = s[i].stall[c];
    }
    const Scalar test = indicial::detail::advance_families(m, g, f->stall[i], value);
    if (!(test == Scalar(0))) b->finite_test[i] = std::numeric_limits<Scalar>::quiet_NaN();
    for (int c = 0; c < m.set.n_coefficients; ++c) b->value[c][i] = value[c];
  }
  // x - x: 0 for a finite value, NaN otherwise (as advance_lanes' test).
  for (int c = 0; c < m.set.n_coefficients; ++c) b->finite_test = b->finite_test + (b->value[c] - b->value[c]);
}

template <class Scalar, class Cap>
INDICIAL_LANE_INLINE void scatter_lane_families(const RuntimeModel<Scalar, Cap>&, const BlockFamilies<State<Scalar, Cap>>&,
                                                int, State<Scalar, Cap>*) {}

template <class Scalar, class Cap>
INDICIAL_LANE_INLINE void scatter_lane_families(const RuntimeModel<Scalar, Cap>& m,
                                                const BlockFamilies<FamilyState<Scalar, Cap>>& f, int i,
                                                FamilyState<Scalar, Cap>* s) {
  for (int c = 0; c < m.set.n_coefficients; ++c) s->stall[c] = f.stall[i][c];
}

// One full block of batch_block instances; status receives batch_block statuses. Lanes that
// did not step (refused, or a non-finite result) are not written: their States keep their
// bytes and their out rows are untouched.
template <int R, class Scalar, class Cap, class St>
INDICIAL_LANE_INLINE void step_block(const RuntimeModel<Scalar, Cap>& m, St* s,
                                     const double* angle_rad, const double* rate_radps,
                                     const double* airspeed_mps, double dt_s, Scalar* out,
                                     StepStatus* status) {
  BlockLanes<Scalar, Cap, R> b;
  check_lanes(m, s, angle_rad, rate_radps, airspeed_mps, dt_s, out, &b);
  load_lanes(m, s, Scalar(dt_s), &b);
  b.finite_test = lane_constant<Scalar, R>(Scalar(0));
  for (int c = 0; c < m.set.n_coefficients; ++c) advance_lanes(m.set.coefficients[c], c, &b);
  BlockFamilies<St> families;
  advance_lane_families(m, s, Scalar(dt_s), &b, &families);
  const auto not_finite = b.finite_test != b.finite_test;
  const bool all_step = b.all_active && !lane_any(not_finite);
  const std::size_t n_out = static_cast<std::size_t>(m.set.n_coefficients);
  for (int i = 0; i < batch_block; ++i) {
    status[i] = b.status[i];
    if (!all_step) {
      if (!b.active[i]) continue;
      if (!(b.finite_test[i] == Scalar(0))) {
        status[i] = StepStatus::non_finite_result;
        continue;
      }
    }
    scatter_lane(m, b, i, &s[i], out + static_cast<std::size_t>(i) * n_out);
    scatter_lane_families(m, families, i, &s[i]);
  }
}

// The kernels: step_block for the portable target, and compiled for AVX2 (flatten: every call
// in it is inlined, so that the whole step is compiled for that target).
template <class Scalar, class Cap, class St>
INDICIAL_LANE_FLATTEN inline void step_block_portable(const RuntimeModel<Scalar, Cap>& m, St* s,
                                                      const double* angle_rad, const double* rate_radps,
                                                      const double* airspeed_mps, double dt_s, Scalar* out,
                                                      StepStatus* status) {
  step_block<portable_lane_bytes>(m, s, angle_rad, rate_radps, airspeed_mps, dt_s, out, status);
}
#if INDICIAL_AVX2_KERNEL
template <class Scalar, class Cap, class St>
__attribute__((target("avx2"), flatten)) inline void step_block_avx2(
    const RuntimeModel<Scalar, Cap>& m, St* s, const double* angle_rad,
    const double* rate_radps, const double* airspeed_mps, double dt_s, Scalar* out, StepStatus* status) {
  step_block<32>(m, s, angle_rad, rate_radps, airspeed_mps, dt_s, out, status);
}
#endif

template <class Scalar, class Cap, class St>
inline void step_block_with(BatchKernel kernel, const RuntimeModel<Scalar, Cap>& m, St* s,
                            const double* angle_rad, const double* rate_radps,
                            const double* airspeed_mps, double dt_s, Scalar* out, StepStatus* status) {
#if INDICIAL_AVX2_KERNEL
  if (kernel == BatchKernel::avx2) {
    step_block_avx2(m, s, angle_rad, rate_radps, airspeed_mps, dt_s, out, status);
    return;
  }
#endif
  (void)kernel;
  step_block_portable(m, s, angle_rad, rate_radps, airspeed_mps, dt_s, out, status);
}

// The last k < batch_block instances: copied into a full block whose other lanes repeat the
// first instance (their results are dropped), stepped, and the k copied back.
template <class Scalar, class Cap, class St>
inline void step_partial_block(BatchKernel kernel, const RuntimeModel<Scalar, Cap>& m, St* s,
                               int k, const double* angle_rad, const double* rate_radps,
                               const double* airspeed_mps, double dt_s, Scalar* out, StepStatus* status) {
  St states[batch_block];
  double angle[batch_block], rate[batch_block], airspeed[batch_block];
  Scalar rows[batch_block * Cap::max_coefficients];
  StepStatus lane_status[batch_block];
  const int n_out = m.set.n_coefficients;
  for (int i = 0; i < batch_block; ++i) {
    const int from = i < k ? i : 0;
    states[i] = s[from];
    angle[i] = angle_rad[from];
    rate[i] = rate_radps[from];
    airspeed[i] = airspeed_mps[from];
    for (int c = 0; c < n_out; ++c) rows[i * n_out + c] = out[from * n_out + c];
  }
  step_block_with(kernel, m, states, angle, rate, airspeed, dt_s, rows, lane_status);
  for (int i = 0; i < k; ++i) {
    s[i] = states[i];
    status[i] = lane_status[i];
    for (int c = 0; c < n_out; ++c) out[i * n_out + c] = rows[i * n_out + c];
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
}  // namespace batch_detail

namespace batch_detail {
// The blocks of step_batch over an array of St (State or FamilyState).
template <class Scalar, class Cap, class St>
inline StepStatus step_blocks(const RuntimeModel<Scalar, Cap>& m, St* states, std::size_t n,
                              const double* angle_rad, const double* rate_radps,
                              const double* airspeed_mps, double dt_s, Scalar* out,
                              StepStatus* status, BatchKernel kernel) {
  const BatchKernel use = batch_kernel_in_use(kernel);
  StepStatus result = StepStatus::ok;
  const std::size_t n_out = static_cast<std::size_t>(m.set.n_coefficients);
  for (std::size_t b = 0; b < n; b += batch_block) {
    StepStatus lane_status[batch_block];
    const std::size_t left = n - b;
    const int k = left < static_cast<std::size_t>(batch_block) ? static_cast<int>(left) : batch_block;
    if (k == batch_block) {
      batch_detail::step_block_with(use, m, states + b, angle_rad + b, rate_radps + b, airspeed_mps + b,
                              dt_s, out + b * n_out, lane_status);
    } else {
      batch_detail::step_partial_block(use, m, states + b, k, angle_rad + b, rate_radps + b,
                                 airspeed_mps + b, dt_s, out + b * n_out, lane_status);
    }
    for (int i = 0; i < k; ++i) {
      if (status != nullptr) status[b + static_cast<std::size_t>(i)] = lane_status[i];
      result = batch_detail::combine(result, lane_status[i]);
    }
  }
  return result;
}
}  // namespace batch_detail

namespace batch_detail {
// The checks of step_batch before its blocks: no delay, and families only with FamilyStates.
template <class Scalar, class Cap, class St>
inline StepStatus checked_blocks(const RuntimeModel<Scalar, Cap>& m, St* states, std::size_t n,
                                 const double* angle_rad, const double* rate_radps,
                                 const double* airspeed_mps, double dt_s, Scalar* out,
                                 StepStatus* status, BatchKernel kernel) {
  if (n == 0) return StepStatus::ok;
  if (!batch_arguments_given(states, angle_rad, rate_radps, airspeed_mps, out))
    return StepStatus::null_output;
  if (m.delay != DelayUse::none) return StepStatus::delay_needs_history;
  if (m.stall != StallUse::none && std::is_same<St, State<Scalar, Cap>>::value)
    return StepStatus::families_need_state;
  return step_blocks(m, states, n, angle_rad, rate_radps, airspeed_mps, dt_s, out, status, kernel);
}
}  // namespace batch_detail

// Steps n states of one undelayed model with a common dt_s; out receives n rows of
// m.set.n_coefficients values. See the warnings above for statuses, and "Which instructions"
// for `kernel`. A model with dynamic-stall families needs FamilyStates (the overload below).
template <class Scalar, class Cap>
inline StepStatus step_batch(const RuntimeModel<Scalar, Cap>& m, State<Scalar, Cap>* states, std::size_t n,
                             const double* angle_rad, const double* rate_radps,
                             const double* airspeed_mps, double dt_s, Scalar* out,
                             StepStatus* status = nullptr,
                             BatchKernel kernel = BatchKernel::automatic) {
  return batch_detail::checked_blocks(m, states, n, angle_rad, rate_radps, airspeed_mps, dt_s, out, status, kernel);
}

// The same for FamilyStates (any undelayed model): the report's part on lanes, the families
// lane by lane (see BlockFamilies): within 1e-12 of single steps in double, as above.
template <class Scalar, class Cap>
inline StepStatus step_batch(const RuntimeModel<Scalar, Cap>& m, FamilyState<Scalar, Cap>* states,
                             std::size_t n, const double* angle_rad, const double* rate_radps,
                             const double* airspeed_mps, double dt_s, Scalar* out,
                             StepStatus* status = nullptr,
                             BatchKernel kernel = BatchKernel::automatic) {
  return batch_detail::checked_blocks(m, states, n, angle_rad, rate_radps, airspeed_mps, dt_s, out, status, kernel);
}

// The same for DelayedStates (any model): one indicial::step per instance.
template <class Scalar, class Cap>
inline StepStatus step_batch(const RuntimeModel<Scalar, Cap>& m, DelayedState<Scalar, Cap>* states,
                             std::size_t n, const double* angle_rad, const double* rate_radps,
                             const double* airspeed_mps, double dt_s, Scalar* out,
                             StepStatus* status = nullptr) {
  if (n == 0) return StepStatus::ok;
  if (!batch_detail::batch_arguments_given(states, angle_rad, rate_radps, airspeed_mps, out))
    return StepStatus::null_output;
  StepStatus result = StepStatus::ok;
  const std::size_t n_out = static_cast<std::size_t>(m.set.n_coefficients);
  for (std::size_t i = 0; i < n; ++i) {
    const StepStatus s = step(m, states[i], MotionInput{angle_rad[i], rate_radps[i], airspeed_mps[i]},
                              dt_s, out + i * n_out);
    if (status != nullptr) status[i] = s;
    result = batch_detail::combine(result, s);
  }
  return result;
}

}  // inline namespace INDICIAL_LANE_ABI
}  // namespace indicial
