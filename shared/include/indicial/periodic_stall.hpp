// periodic_stall.hpp -- the periodic state of the dynamic-stall states (model.hpp "Dynamic
// stall") over one cycle of a periodic motion: the state s* with P(s*) = s*, P the map from a
// state at the cycle's first sample to the state one cycle later. The fitter takes a periodic
// run's stall state at sample 0 from here (fit_output_error.cpp), `predict --periodic` too
// (predict.cpp), each with its own cycle map (advance_stall on the run's samples; the runtime's
// step), so what is fitted is what is predicted.
//
// Why not a warm-up of a few cycles from the steady state (what both did before, three cycles):
// a state with time constant T keeps exp(-cycles x cycle / T) of its start; for T of a few
// semichords that is nothing, but a fit is free to move T, and fits of measured cycles did: 46
// of 184 diagnosed models kept more than 1e-3 of the start after three cycles, 18 with a vortex
// decay T_v of 276 to 2.5e6 semichords (docs/diagnose-speed.md's matrix). Their "periodic" runs
// then carried the slow transient from the steady state, which the output gains could use
// (|c_v| up to 6e4), and a held-out cycle replayed that transient from its own start. The
// exact periodic state alone does not make such a fit sensible (a state with T >> cycle has a
// periodic value of about T / cycle times its feed: an offset), so the output-error fit also
// limits the time constants of periodic runs (fit_output_error.cpp,
// stall_time_constant_limit; measured in docs/periodic-stall.md).
//
// How, exactly and cheaply. Each stall state is AFFINE in its own start value once the states
// it depends on are given over the cycle (model.hpp's update: x_e1 = e x_e0 + ..., f1 = e f0 +
// ..., tau1 = e_c tau0 + ..., v1 = e_v v0 + ..., with e, e_c, e_v and the forcing terms set by
// the angle and the states upstream), and the dependencies run one way:
//   x_e  ->  { f, tau_v }  ->  v
// (f from x_e's table values, tau_v from x_e's shedding switch, v from f's Kirchhoff factors and
// tau_v's gates). So for one group at a time, its upstream at their periodic values, the cycle
// map of each of its states is P(s0) = Phi s0 + c, and two cycles give the fixed point exactly
// (to rounding), whatever T:
//   s* = s_a + (P(s_a) - s_a) / (1 - Phi),   Phi = (P(s_b) - P(s_a)) / (s_b - s_a)
// (the lags' closure, fit_output_error.cpp's periodic_state). With an autodiff Scalar the same
// arithmetic gives the fixed point's derivatives with respect to the parameters (s* =
// c / (1 - Phi) as functions of them), which is what the fitter's sensitivities need.
// Exception: with a reattachment constant T1r > 0 f's decay depends on f itself (T1r while
// f0c(x_e) > f), and so with a static hysteresis dxr > 0 (held inside its band), so its P is
// piecewise affine; its secant step is repeated, at most
// kPeriodicStallMaxSecants times, until |P(f) - f| <= kPeriodicStallTolerance.
// Where Phi is not below 1 - kPeriodicStallMinDecay (a clock tau_v whose shedding switch stays
// saturated over the whole cycle: it grows without bound and has no periodic value; or a decay
// too slow to resolve in double), the state takes its value one cycle later instead (the old
// warm-up's rule), and the result counts it in `unresolved`.
// Cost: 2 cycles per group (x_e with ForcingLag::first_order only; then f and tau_v; then v),
// plus 2 per further secant of a piecewise f, less 1 when the cycle that found a piecewise f
// converged serves as the next group's first: 4 cycles for the default families against 3 for
// the old warm-up.
//
// Header-only, no heap, no exceptions (MaxCoefficients states on the stack), templated on the
// scalar like model.hpp.
#pragma once

#include <cmath>

#include "indicial/model.hpp"

namespace indicial {

inline constexpr int kPeriodicStallMaxSecants = 8;
inline constexpr double kPeriodicStallTolerance = 1e-12;  // |P(f) - f| of a piecewise f
inline constexpr double kPeriodicStallMinDecay = 1e-9;    // 1 - Phi below this: unresolved

// Which states of one coefficient's families move over a cycle (the others are left as they
// are: a delay model's x_e, a separation-only model's tau_v and v).
struct StallPeriodicStates {
  bool forcing_angle = false;        // x_e: ForcingLag::first_order with T2 > 0
  bool separation = false;           // f: any family
  bool piecewise_separation = false; // f with T1r > 0 or dxr > 0 (P piecewise affine)
  bool vortex = false;               // tau_v and v: separation_and_vortex
};

template <class Scalar, class Cap>
inline StallPeriodicStates stall_periodic_states(const StallModel<Scalar, Cap>& m) {
  StallPeriodicStates s;
  if (m.families == StallFamilies::none) return s;
  s.separation = true;
  s.piecewise_separation = m.separation.tau1_reattach_semichords > Scalar(0) ||
                           m.separation.reattach_shift_rad > Scalar(0);
  s.forcing_angle = m.separation.forcing_lag == ForcingLag::first_order && m.separation.tau2_semichords > Scalar(0);
  s.vortex = m.families == StallFamilies::separation_and_vortex;
  return s;
}

struct PeriodicStallResult {
  int cycles = 0;      // cycle maps evaluated (each over every coefficient)
  int unresolved = 0;  // states that took their value one cycle later (no periodic value found)
  int secants = 0;     // secant steps of piecewise states beyond the first
};

namespace detail {

enum class StallComponent : int { forcing_angle, separation, clock, vortex };

template <class Scalar>
inline Scalar& stall_component(StallState<Scalar>& s, StallComponent c) {
  switch (c) {
    case StallComponent::forcing_angle: return s.forcing_angle_rad;
    case StallComponent::separation: return s.separation_point;
    case StallComponent::clock: return s.vortex_clock_semichords;
    case StallComponent::vortex: break;
  }
  return s.vortex_lift;
}

inline bool stall_component_moves(const StallPeriodicStates& live, StallComponent c) {
  switch (c) {
    case StallComponent::forcing_angle: return live.forcing_angle;
    case StallComponent::separation: return live.separation;
    case StallComponent::clock: return live.vortex;
    case StallComponent::vortex: break;
  }
  return live.vortex;
}

template <class Scalar>
inline double stall_value(const Scalar& x) {
  if constexpr (std::is_floating_point<Scalar>::value) {
    return static_cast<double>(x);
  } else {
    return static_cast<double>(x.value());
  }
}

// The secant's second point: a step of 1e-3 of the value's scale (at least 1e-3), toward the
// inside of [0, 1] for f. Any step is exact for an affine map; this one keeps the rounding of
// P(s_b) - P(s_a) under 1e-12 of Phi for values up to 1e3 and crosses few branches of a
// piecewise f.
template <class Scalar>
inline double secant_step(StallComponent c, const Scalar& value) {
  const double v = stall_value(value);
  if (c == StallComponent::separation) return v > 0.5 ? -1e-3 : 1e-3;
  return 1e-3 * (std::abs(v) > 1.0 ? std::abs(v) : 1.0);
}

}  // namespace detail

// Sets s[0..n) (each coefficient's stall state at the cycle's first sample; any start, e.g.
// stall_steady_state) to the periodic state. cycle(const StallState<Scalar>* start,
// StallState<Scalar>* end) propagates all n states over one cycle from start into end.
// live[c]: stall_periodic_states of coefficient c's model. n <= MaxCoefficients.
template <int MaxCoefficients, class Scalar, class Cycle>
PeriodicStallResult periodic_stall_state(const StallPeriodicStates* live, int n, StallState<Scalar>* s,
                                         Cycle&& cycle) {
  using detail::StallComponent;
  PeriodicStallResult result;
  StallState<Scalar> pa[MaxCoefficients], b[MaxCoefficients], pb[MaxCoefficients];
  const StallComponent groups[3][2] = {{StallComponent::forcing_angle, StallComponent::forcing_angle},
                                       {StallComponent::separation, StallComponent::clock},
                                       {StallComponent::vortex, StallComponent::vortex}};
  bool pa_is_cycle_of_s = false;  // pa holds cycle(s) for the current s (reused, same bits)
  for (const auto& group : groups) {
    bool moves = false, piecewise = false;
    for (int c = 0; c < n; ++c)
      for (StallComponent k : group) {
        moves = moves || detail::stall_component_moves(live[c], k);
        piecewise = piecewise || (k == StallComponent::separation && live[c].piecewise_separation);
      }
    if (!moves) continue;
    for (int iter = 0; iter < (piecewise ? kPeriodicStallMaxSecants : 1); ++iter) {
      if (!pa_is_cycle_of_s) {
        cycle(static_cast<const StallState<Scalar>*>(s), pa);
        ++result.cycles;
        pa_is_cycle_of_s = true;
      }
      if (iter > 0) {
        bool converged = true;
        for (int c = 0; c < n; ++c)
          if (live[c].piecewise_separation &&
              !(std::abs(detail::stall_value(pa[c].separation_point) - detail::stall_value(s[c].separation_point)) <=
                kPeriodicStallTolerance))
            converged = false;
        if (converged) break;
        ++result.secants;
      }
      for (int c = 0; c < n; ++c) {
        b[c] = s[c];
        for (StallComponent k : group)
          if (detail::stall_component_moves(live[c], k))
            detail::stall_component(b[c], k) =
                detail::stall_component(s[c], k) + Scalar(detail::secant_step(k, detail::stall_component(s[c], k)));
      }
      cycle(static_cast<const StallState<Scalar>*>(b), pb);
      ++result.cycles;
      pa_is_cycle_of_s = false;  // s moves below
      for (int c = 0; c < n; ++c)
        for (int g = 0; g < 2; ++g) {
          const StallComponent k = group[g];
          if ((g == 1 && group[1] == group[0]) || !detail::stall_component_moves(live[c], k)) continue;
          Scalar& x = detail::stall_component(s[c], k);
          const Scalar& p_a = detail::stall_component(pa[c], k);
          const Scalar phi = (detail::stall_component(pb[c], k) - p_a) /
                             (detail::stall_component(b[c], k) - x);
          const Scalar next = x + (p_a - x) / (Scalar(1) - phi);
          // Why: Phi >= 1 - 1e-9 (or a non-finite value) has no resolvable fixed point.
          if (detail::stall_value(phi) < 1.0 - kPeriodicStallMinDecay && std::isfinite(detail::stall_value(next))) {
            x = next;
          } else {
            x = p_a;
            if (iter == 0) ++result.unresolved;
          }
        }
    }
  }
  return result;
}

}  // namespace indicial
