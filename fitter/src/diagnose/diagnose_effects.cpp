// diagnose_effects.cpp -- the effect registry of `indicial diagnose`: one table entry per
// effect (name, what it explains, how it is written to the model, its residual signature, the
// experiment that separates it from its look-alikes, and its candidate generator). The effect
// count, the --help list and the report's descriptions all come from this table: a new effect
// is one new entry (plus its Effect enumerator).
#include <algorithm>
#include <fmt/format.h>
#include <stdexcept>

#include "diagnose/diagnose_internal.hpp"
#include "estimate/fit_internal.hpp"

namespace indicial {
namespace diagnose_detail {

namespace {

int max_power(const std::vector<int>& p) {
  int m = -1;
  for (int i : p) m = std::max(m, i);
  return m;
}

bool has_power(const std::vector<int>& p, int i) {
  return std::find(p.begin(), p.end(), i) != p.end();
}

const char* family_knot_label(SplineFamily f) {
  switch (f) {
    case SplineFamily::b1: return "b1(x) knot (x - k)_+";
    case SplineFamily::a: return "a(x) knot (x - k)_+^2";
    case SplineFamily::rotary: return "C_aq(x) knot (x - k)_+";
    default: return "dC_a(x) knot (x - k)_+^2";
  }
}

CandidateSpec power_candidate(const ModelConfig& m, Effect effect, SplineFamily f, int power,
                              const char* what) {
  CandidateSpec c;
  c.effect = effect;
  c.config = m;
  c.family = f;
  SplineConfig& sp = family_spline(c.config, f);
  sp.powers.push_back(power);
  std::sort(sp.powers.begin(), sp.powers.end());
  c.term = fmt::format("{} x^{}", what, power);
  c.detail = fmt::format("{} x^{} term", what, power);
  return c;
}

// A knot term at every grid knot not already in the spline (none once the spline is full).
void add_grid_knots(const CandidateContext& ctx, Effect effect, SplineFamily f,
                    std::vector<CandidateSpec>& out) {
  const SplineConfig& sp = family_spline(ctx.model, f);
  if (static_cast<int>(sp.knots_rad.size()) >= DefaultCapacity::max_knots) return;
  for (double k : ctx.knot_grid)
    if (!has_knot(sp.knots_rad, k, 0.5 * ctx.knot_spacing_rad))
      out.push_back(knot_candidate(ctx.model, effect, f, k));
}

// ---- generators, one per effect ----------------------------------------------------------
void gen_b1_alpha(const CandidateContext& ctx, std::vector<CandidateSpec>& out) {
  const int p = max_power(ctx.model.b1.powers) + 1;
  if (p < DefaultCapacity::max_powers)
    out.push_back(power_candidate(ctx.model, Effect::b1_alpha, SplineFamily::b1, p, "b1(x)"));
  add_grid_knots(ctx, Effect::b1_alpha, SplineFamily::b1, out);
}

void gen_a_alpha(const CandidateContext& ctx, std::vector<CandidateSpec>& out) {
  const int p = max_power(ctx.model.a.powers) + 1;
  if (p < DefaultCapacity::max_powers)
    out.push_back(power_candidate(ctx.model, Effect::a_alpha, SplineFamily::a, p, "a(x)"));
  add_grid_knots(ctx, Effect::a_alpha, SplineFamily::a, out);
}

// The C_aq correction's lowest missing power, and knots. Powers enter in order (x^0 before
// x^1 before x^2 ...), as b1(x)'s and a(x)'s do above: the marginality principle of polynomial
// regression (a term enters only with the lower terms of its polynomial), and the physics: the
// constant damping derivative (C_mq, C_lp) is the leading term of a rotary derivative. Offering
// x^3 alone before x^0 let a training set at high angles pick a term that is zero in attached
// flow: on measured pitching cycles (docs/validation-real.md, training `sweep`, C_m) diagnose
// named C_aq x^3, while the attached cycles' moment follows a constant C_mq (per-cycle least
// squares of the attached cycles of the development set: -1.0 to -1.5 per rad, every campaign).
//
// And, while the correction has no constant, the constant with one knot together, c0 + c1 (x -
// k)_+ at each grid knot. Why: the damping derivative changes sign through stall (the same
// C_m cycles, per-run least squares of the residual on q l / V: -1.39 at mean 6 deg, -0.59 at
// 8, +0.42 at 15, the negative damping of dynamic stall), so over runs that span the regimes
// neither term alone lowers the error (x^0 alone fitted to 0: gain 0) while the two together
// are the physics. One step adds the pair; the held-out runs decide as for any candidate.
void gen_rotary_alpha(const CandidateContext& ctx, std::vector<CandidateSpec>& out) {
  int p = 0;
  const SplineConfig& rc = ctx.model.rotary_correction;
  while (has_power(rc.powers, p)) ++p;
  if (p < DefaultCapacity::max_powers)
    out.push_back(power_candidate(ctx.model, Effect::rotary_alpha, SplineFamily::rotary, p, "C_aq(x)"));
  add_grid_knots(ctx, Effect::rotary_alpha, SplineFamily::rotary, out);
  if (p != 0 || static_cast<int>(rc.knots_rad.size()) >= DefaultCapacity::max_knots) return;
  for (double k : ctx.knot_grid) {
    if (has_knot(rc.knots_rad, k, 0.5 * ctx.knot_spacing_rad)) continue;
    CandidateSpec c = knot_candidate(ctx.model, Effect::rotary_alpha, SplineFamily::rotary, k);
    family_spline(c.config, SplineFamily::rotary).powers.insert(
        family_spline(c.config, SplineFamily::rotary).powers.begin(), 0);
    c.term = fmt::format("C_aq(x) x^0 + {} at {:.2f} deg", family_knot_label(SplineFamily::rotary), k * kRadToDeg);
    c.detail = fmt::format("x^0 + knot {:.2f} deg", k * kRadToDeg);
    c.is_knot = false;  // (the grid's knot only: a refined knot would move the pair's second term)
    out.push_back(c);
  }
}

void gen_bias(const CandidateContext& ctx, std::vector<CandidateSpec>& out) {
  if (ctx.model.bias) return;
  CandidateSpec c;
  c.effect = Effect::bias;
  c.config = ctx.model;
  c.config.bias = true;
  c.term = "con";
  c.detail = "con";
  out.push_back(c);
}

// Two starts, at 0 (nested: the right-hand sensitivity moves it) and 4 steps.
void gen_time_delay(const CandidateContext& ctx, std::vector<CandidateSpec>& out) {
  if (ctx.model.delay != DelayEstimation::none) return;
  CandidateSpec c;
  c.effect = Effect::time_delay;
  c.config = ctx.model;
  c.config.delay = DelayEstimation::estimated;
  c.config.delay_start_s = 0.0;
  c.term = "delay_s";
  c.detail = "delay";
  const double dt = ctx.experiment.runs.empty() ? 0.01 : ctx.experiment.runs.front().dt_s();
  const ParamId delay = param_id(ParamKind::delay);
  c.starts = {{{delay, 0.0}}, {{delay, 4.0 * dt}}};
  out.push_back(c);
}

// b2 started slower, faster and much faster than b1; the second lag starts at rest
// (docs/diagnose.md, design notes).
void gen_second_lag(const CandidateContext& ctx, std::vector<CandidateSpec>& out) {
  if (ctx.model.lags != 1 || DefaultCapacity::max_lags < 2 || FitCapacity::max_lags < 2) return;
  double b1_0 = std::abs(estimate_of(ctx.base, param_id(ParamKind::b_power, 0, 0), 1.0));
  if (!(b1_0 > 0.0)) b1_0 = 1.0;
  CandidateSpec c;
  c.effect = Effect::second_lag;
  c.config = ctx.model;
  c.config.lags = 2;
  c.config.further_lag_start = LagStart::at_rest;
  c.term = "b2_0, c2";
  for (double f : {0.3, 4.0, 15.0})
    c.starts.push_back({{param_id(ParamKind::b_power, 1, 0), f * b1_0}, {param_id(ParamKind::gain, 1), 0.1}});
  out.push_back(c);
}

// x^1..x^3 and knots. No x^0: with constant b1 a constant offset IS con / b1 (structural_look_
// alikes names both); with b1(x) a free x^0 plus further static terms mimics con / b1(x) and took
// two-effect cases (b1_alpha + bias) from bias.
void gen_static_error(const CandidateContext& ctx, std::vector<CandidateSpec>& out) {
  for (int p = 1; p <= 3; ++p)
    if (!has_power(ctx.model.static_correction.powers, p))
      out.push_back(power_candidate(ctx.model, Effect::static_error, SplineFamily::static_correction, p,
                                    "dC_a(x)"));
  add_grid_knots(ctx, Effect::static_error, SplineFamily::static_correction, out);
}

// The dynamic-stall families (model.hpp "Dynamic stall"; issue 22) need the static lift polar:
// the model's own, or the experiment's static table when the experiment models the lift (CL)
// or when that table also has the lift (Experiment::table_lift_polar: a Cm experiment whose
// table has CL, or Cnormal and Ctangential). Without one there is no candidate (a Cm
// experiment then names the polar with model.stall_polar).
bool stall_candidate(const CandidateContext& ctx, StallFamilies families, Effect effect,
                     std::vector<CandidateSpec>& out) {
  const StallConfig& have = ctx.model.stall;
  CandidateSpec c;
  c.effect = effect;
  c.config = ctx.model;
  StallConfig& s = c.config.stall;
  if (have.polar_x_rad.empty()) {
    const StaticConfig& st = ctx.experiment.static_curve;
    const LiftPolar& lp = ctx.experiment.table_lift_polar;
    if (st.kind == StaticKind::table && ctx.experiment.coefficient == s.polar_column) {
      s.polar_path = st.table_path;
      s.polar_x_rad = st.table_x_rad;
      s.polar_lift = st.table_value;
    } else if (!lp.empty()) {  // e.g. Cm, with the lift in the same static table
      s.polar_path = lp.path;
      s.polar_column = "CL";
      s.polar_x_rad = lp.x_rad;
      s.polar_lift = lp.lift;
    } else {
      return false;
    }
  }
  s.families = families;
  c.start_from = CandidateSpec::StartFrom::current_and_own;
  c.term = families == StallFamilies::separation ? "T1, T2, k0, k1, k2" : "CN1, Tv, Tvl, cv, xv";
  c.detail = stall_families_name(families);
  out.push_back(c);
  return true;
}

void gen_separation_lag(const CandidateContext& ctx, std::vector<CandidateSpec>& out) {
  if (ctx.model.stall.families != StallFamilies::none) return;
  stall_candidate(ctx, StallFamilies::separation, Effect::separation_lag, out);
}

// The vortex is fed by the separation state: the candidate adds both when neither is there.
void gen_vortex_shedding(const CandidateContext& ctx, std::vector<CandidateSpec>& out) {
  if (ctx.model.stall.families == StallFamilies::separation_and_vortex) return;
  stall_candidate(ctx, StallFamilies::separation_and_vortex, Effect::vortex_shedding, out);
}

// The separation state's own reattachment time constant T1r (model.hpp), on a model that has
// the families with one time constant both ways: started where it IS that model (T1r = T1's
// current estimate), so its first fit begins at the base's cost.
void gen_slow_reattachment(const CandidateContext& ctx, std::vector<CandidateSpec>& out) {
  const StallConfig& have = ctx.model.stall;
  if (have.families == StallFamilies::none || have.reattachment == StallReattachment::estimated) return;
  CandidateSpec c;
  c.effect = Effect::slow_reattachment;
  c.config = ctx.model;
  c.config.stall.reattachment = StallReattachment::estimated;
  // T1 held by stall_known (e.g. a C_m taking the C_L fit's) is no estimate: its held value.
  double t1 = estimate_of(ctx.base, param_id(ParamKind::stall_tau1), have.tau1_start);
  for (const auto& k : have.known)
    if (k.first == "T1") t1 = k.second;
  c.starts = {{{param_id(ParamKind::stall_tau1_reattach), t1}}};
  c.term = "T1r";
  c.detail = "reattachment time constant";
  out.push_back(c);
}

// The separation state's static hysteresis dxr (model.hpp), on a model that has the families
// without it: started at kHysteresisNestedStartRad (fit.hpp), as the fit's nested trial, a band
// too narrow to move the base's cost, so its first fit begins there.
void gen_static_hysteresis(const CandidateContext& ctx, std::vector<CandidateSpec>& out) {
  const StallConfig& have = ctx.model.stall;
  if (have.families == StallFamilies::none || have.hysteresis == StallHysteresis::estimated) return;
  CandidateSpec c;
  c.effect = Effect::static_hysteresis;
  c.config = ctx.model;
  c.config.stall.hysteresis = StallHysteresis::estimated;
  c.starts = {{{param_id(ParamKind::stall_reattach_shift), kHysteresisNestedStartRad}}};
  c.term = "dxr";
  c.detail = "static hysteresis of stall";
  out.push_back(c);
}

// The separation state forced through a first-order lag of the angle (model.hpp ForcingLag::
// first_order, Beddoes-Leishman's leading-edge pressure lag) instead of the angle extrapolated
// back by T2 (the delay form), on a model that has the families in the delay form. It adds no
// parameter (T2 is the filter's time constant): started from the current estimates, T2 as it
// is (the two forms have the same phase lag k T2 at low reduced frequency k).
void gen_pressure_lag(const CandidateContext& ctx, std::vector<CandidateSpec>& out) {
  const StallConfig& have = ctx.model.stall;
  if (have.families == StallFamilies::none || have.forcing_lag != ForcingLag::delay ||
      have.lag_limit != StallLagLimit::none)
    return;
  CandidateSpec c;
  c.effect = Effect::pressure_lag;
  c.config = ctx.model;
  c.config.stall.forcing_lag = ForcingLag::first_order;
  c.term = "T2 as a first-order lag";
  c.detail = "forcing through a first-order lag";
  out.push_back(c);
}

// The forcing angle's lag limited to D (model.hpp's lag limit: x_e = x - D tanh(T2 (l/V) x' /
// D)), on a model that has the families in the delay form without it: from the current
// estimates, two starts, the better fit kept: D at its configured start (stall_dxl_start,
// 0.1 rad), and D at kLagLimitNestedStartRad (fit.hpp), near the model without it, as the
// fit's nested trial (from 0.1 rad alone the fit of tools/validate_stall.py's C_m cycles ended
// at the 20 deg bound, far above the model without D).
void gen_lag_limit(const CandidateContext& ctx, std::vector<CandidateSpec>& out) {
  const StallConfig& have = ctx.model.stall;
  if (have.families == StallFamilies::none || have.forcing_lag != ForcingLag::delay ||
      have.lag_limit == StallLagLimit::estimated)
    return;
  CandidateSpec c;
  c.effect = Effect::lag_limit;
  c.config = ctx.model;
  c.config.stall.lag_limit = StallLagLimit::estimated;
  c.starts = {{{param_id(ParamKind::stall_lag_limit), have.lag_limit_start_rad}},
              {{param_id(ParamKind::stall_lag_limit), kLagLimitNestedStartRad}}};
  c.term = "dxl";
  c.detail = "limit of the forcing angle's lag";
  out.push_back(c);
}

// ---- parameter identity -------------------------------------------------------------------
// Every structural and output parameter of a configuration, with the knot numbers of THAT
// configuration (what its fit names them).
std::vector<ParamId> model_terms(const ModelConfig& m) {
  const fit_detail::UnsteadyStructure s = fit_detail::structure_from_config(m);
  std::vector<ParamId> out = fit_detail::structural_terms(s);
  for (const ParamId& t : fit_detail::rotary_terms(s.rotary)) out.push_back(t);
  for (const ParamId& t : fit_detail::static_corr_terms(s.static_corr)) out.push_back(t);
  return out;
}

}  // namespace

// The table. Order = the Effect enum's.
const std::vector<EffectEntry>& effect_registry() {
  static const std::vector<EffectEntry> table = {
      {{Effect::b1_alpha, EffectExtends::report_model, "b1_alpha",
        "the lag's decay rate b1 varies with the angle",
        "b1(x) power or plus-function knot term (x - k)_+ (lag_poly / lag_knot 1)",
        "hysteresis whose width and phase change along the angle range, at every frequency",
        "oscillations about several mean angles at small amplitude (b1 then shows as a "
        "different time constant at each mean)"},
       SplineFamily::b1, gen_b1_alpha},
      {{Effect::a_alpha, EffectExtends::report_model, "a_alpha",
        "the unsteady forcing a(x) lacks a term",
        "a(x) power or knot term (x - k)_+^2 (a_poly / a_knot)",
        "hysteresis growing with the rate, concentrated in part of the angle range",
        "ramps at several rates through the suspected angle range"},
       SplineFamily::a, gen_a_alpha},
      {{Effect::rotary_alpha, EffectExtends::report_model, "rotary_alpha",
        "the rotary derivative C_aq(x) is wrong",
        "a C_aq(x) correction, power or knot (x - k)_+, added to the a priori C_aq (rotary_poly / "
        "rotary_knot)",
        "a residual in phase with the rate, proportional to it, at every frequency",
        "oscillations at several frequencies: the rotary term grows with frequency, the lag's "
        "contribution saturates"},
       SplineFamily::rotary, gen_rotary_alpha},
      {{Effect::bias, EffectExtends::report_model, "bias",
        "a constant in the state equation (con)",
        "con (state-equation constant)",
        "a constant offset in every run",
        "with constant b1, con / b1 equals a constant static offset: runs over an angle range where "
        "b1 varies, or transients from a long hold (y known to be 0), separate them"},
       SplineFamily::none, gen_bias},
      {{Effect::time_delay, EffectExtends::report_model, "time_delay",
        "a pure delay of the unsteady forcing, x_f = x(t - delay)",
        "delay_s",
        "a phase lag growing with the frequency",
        "oscillations at several frequencies or fast ramps: a delay's phase lag grows linearly "
        "with frequency, a lower b1's saturates"},
       SplineFamily::none, gen_time_delay},
      {{Effect::second_lag, EffectExtends::report_model, "second_lag",
        "a second lag state with its own time constant",
        "lag 2: lag_poly 2 b2_0, lag_gain 2 c2 (starting at rest)",
        "a residual transient after every change of rate, with a time constant unlike b1's",
        "ramp-and-hold runs sampled well within 1 / b2: the second lag's response continues after "
        "the ramp stops, decaying with its own time constant (a rotary term's stops with the rate); "
        "or oscillations up to b2 / (2 pi) Hz, above which its contribution saturates"},
       SplineFamily::none, gen_second_lag},
      {{Effect::static_error, EffectExtends::report_model, "static_error",
        "the static curve C_a(x) is wrong",
        "a static correction dC_a(x), powers x^1..x^3 or knots (x - k)_+^2 (static_corr_poly / "
        "static_corr_knot)",
        "a residual that depends on the angle alone: the same on upstroke and downstroke, at "
        "every frequency",
        "slow (quasi-static) sweeps or held angles: a static error remains, an unsteady one "
        "vanishes"},
       SplineFamily::static_correction, gen_static_error},
      {{Effect::separation_lag, EffectExtends::stall_families, "separation_lag",
        "the trailing-edge separation point lags the angle (dynamic stall without a vortex)",
        "the separation family: state f, T1 (l/V) f' + f = f0(x - T2 (l/V) x'), Kirchhoff output "
        "(model.stall = \"separation\"; coefficient-file sep_* keys)",
        "hysteresis only at and above the static stall angle, lift higher on the upstroke (delayed "
        "stall) and lower on the downstroke (slow reattachment), the loop widening with the reduced "
        "frequency; none in attached flow",
        "oscillations at several mean angles through the static stall angle and at several reduced "
        "frequencies: below stall it is silent, a lag's hysteresis is not"},
       SplineFamily::none, gen_separation_lag},
      {{Effect::vortex_shedding, EffectExtends::stall_families, "vortex_shedding",
        "a leading-edge vortex is shed past a criterion and convected over the chord",
        "the vortex family on the separation family: vortex lift fed by N(x) (1 - K(f)), shed past "
        "|C_N'| > CN1, decaying with Tv, convected in Tvl (model.stall = \"separation_and_vortex\"; "
        "vortex_* keys)",
        "a lift overshoot above the static maximum on the upstroke past stall, then a sharp nose-down "
        "pitching-moment break that comes later in the cycle as the reduced frequency grows",
        "deep-stall oscillations at several reduced frequencies: the overshoot and the moment break "
        "move with the convection time Tvl, a separation lag's hysteresis has neither"},
       SplineFamily::none, gen_vortex_shedding},
      {{Effect::slow_reattachment, EffectExtends::stall_families, "slow_reattachment",
        "the flow reattaches more slowly than it separates",
        "the separation state's own time constant T1r while f rises toward f0 (model.stall_reattachment "
        "= \"estimated\"; coefficient-file sep_reattachment)",
        "on the downstroke below the static stall angle the lift stays low (and the moment off its "
        "static value) for longer than the upstroke's separation lag explains, the loop's lower branch "
        "widening with the reduced frequency",
        "oscillations through stall at several reduced frequencies and mean angles: the separation "
        "(upstroke) and the reattachment (downstroke) lags are then told apart"},
       SplineFamily::none, gen_slow_reattachment},
      {{Effect::pressure_lag, EffectExtends::stall_families, "pressure_lag",
        "the separation point follows the angle through a lag, not the angle extrapolated back",
        "the separation state forced by x_e with T2 (l/V) x_e' + x_e = x (Beddoes-Leishman's "
        "leading-edge pressure lag) instead of x - T2 (l/V) x'; no parameter added "
        "(model.stall_forcing_lag = \"first_order\"; coefficient-file sep_forcing_lag first_order)",
        "on fast cycles the model separates and reattaches at angles the flow does not: the delay "
        "form's lagged angle swings sqrt(1 + (k T2)^2) times the motion's amplitude, a filter's "
        "1 / sqrt(1 + (k T2)^2) times, so the residual sits at the stall break and grows with the "
        "reduced frequency k",
        "oscillations through stall at several reduced frequencies up to k T2 ~ 1: the two forms "
        "agree at low frequency and part as k T2 grows"},
       SplineFamily::none, gen_pressure_lag},
      {{Effect::static_hysteresis, EffectExtends::stall_families, "static_hysteresis",
        "the flow reattaches only at an angle below where it separated, however slow the motion",
        "the separation state's static hysteresis dxr: while reattaching f relaxes toward f0(x + dxr) "
        "(further from alpha_0) and holds between that and f0(x) (model.stall_hysteresis = "
        "\"estimated\"; coefficient-file sep_hysteresis)",
        "a loop through stall that stays open as the reduced frequency falls: on the downstroke the "
        "lift stays low (the moment off its static value) down to dxr below the static stall angle "
        "even on quasi-static cycles, where a time lag's loop closes",
        "oscillations through stall at low and moderate reduced frequencies (k <= 0.05 with faster "
        "ones): a time lag's loop shrinks with k, the hysteresis's does not"},
       SplineFamily::none, gen_static_hysteresis},
      {{Effect::lag_limit, EffectExtends::stall_families, "lag_limit",
        "the onset of separation is delayed by the motion, less and less as the motion gets faster",
        "the forcing angle's lag limited to D: x_e = x - D tanh(T2 (l/V) x' / D) (model.stall_lag_limit = "
        "\"estimated\"; coefficient-file sep_lag_limit)",
        "on fast cycles the model separates late and stays separated where the measurement barely "
        "separates (light stall at high reduced frequency), while slow cycles fit: a delay that "
        "grows with the rate without bound over-shoots the fast ones",
        "oscillations through stall over a range of reduced frequencies, fast ones (k T2 ~ 0.5 and "
        "above) with slow ones"},
       SplineFamily::none, gen_lag_limit},
  };
  // Why: Effect values index this table (effect_entry); a missing or misplaced entry is a bug.
  static const bool checked = [] {
    if (table.size() != static_cast<std::size_t>(effect_count))
      throw std::logic_error("diagnose effect registry: wrong number of entries");
    for (std::size_t i = 0; i < table.size(); ++i)
      if (static_cast<std::size_t>(table[i].description.effect) != i)
        throw std::logic_error("diagnose effect registry: entries out of enum order");
    return true;
  }();
  (void)checked;
  return table;
}

const EffectEntry& effect_entry(Effect e) {
  return effect_registry().at(static_cast<std::size_t>(e));
}

SplineConfig& family_spline(ModelConfig& m, SplineFamily f) {
  switch (f) {
    case SplineFamily::b1: return m.b1;
    case SplineFamily::a: return m.a;
    case SplineFamily::rotary: return m.rotary_correction;
    default: return m.static_correction;
  }
}

const SplineConfig& family_spline(const ModelConfig& m, SplineFamily f) {
  return family_spline(const_cast<ModelConfig&>(m), f);  // read-only view of the same
}

bool has_knot(const std::vector<double>& knots, double k, double min_gap) {
  for (double q : knots)
    if (std::abs(q - k) < min_gap) return true;
  return false;
}

CandidateSpec knot_candidate(const ModelConfig& m, Effect effect, SplineFamily f, double k) {
  CandidateSpec c;
  c.effect = effect;
  c.config = m;
  SplineConfig& sp = family_spline(c.config, f);
  sp.knots_rad.push_back(k);
  std::sort(sp.knots_rad.begin(), sp.knots_rad.end());
  c.term = fmt::format("{} at {:.2f} deg", family_knot_label(f), k * kRadToDeg);
  c.detail = fmt::format("knot {:.2f} deg", k * kRadToDeg);
  c.family = f;
  c.is_knot = true;
  c.knot_rad = k;
  return c;
}

std::vector<double> knot_grid(const Experiment& e, const DiagnoseOptions& o, double& spacing) {
  const double lo = e.data_x_min_rad, hi = e.data_x_max_rad;
  const double range = hi - lo;
  std::vector<double> g;
  spacing = std::max(1e-6, o.knot_spacing_deg * kDegToRad);
  if (!(range > 0.0)) return g;
  const double a = lo + o.knot_margin_fraction * range;
  const double b = hi - o.knot_margin_fraction * range;
  // Why the widening: a wide range at a fine spacing would multiply the fits and the
  // Bonferroni count; past max_scan_knots the spacing grows instead.
  if ((b - a) / spacing + 1.0 > o.max_scan_knots && o.max_scan_knots > 1)
    spacing = (b - a) / (o.max_scan_knots - 1);
  // Knots at multiples of the spacing (round degree values for the default grid).
  for (double k = std::ceil(a / spacing - 1e-9) * spacing; k <= b + 1e-12; k += spacing) g.push_back(k);
  return g;
}

std::vector<CandidateSpec> all_candidates(const CandidateContext& ctx) {
  std::vector<CandidateSpec> out;
  for (const EffectEntry& entry : effect_registry()) entry.generate(ctx, out);
  return out;
}

Estimates estimates_by_id(const FitResult& r) {
  Estimates out;
  for (const ParameterEstimate& p : r.parameters) out[p.id] = p.value;
  return out;
}

double estimate_of(const FitResult& r, const ParamId& id, double fallback) {
  for (const ParameterEstimate& p : r.parameters)
    if (p.id == id) return p.value;
  return fallback;
}

StartValues start_values_for(const ModelConfig& m, const Estimates& current, std::size_t n_runs,
                             const StartValues& extra) {
  std::vector<ParamId> ids = model_terms(m);
  for (std::size_t r = 0; r < n_runs; ++r)
    for (int j = 0; j < m.lags; ++j) {
      ParamId y0 = param_id(ParamKind::initial_state, j);
      y0.run = static_cast<int>(r);
      ids.push_back(y0);
    }
  StartValues sv;
  for (const ParamId& id : ids) {
    const auto it = current.find(id);
    if (it != current.end()) sv.emplace_back(id, it->second);
  }
  for (const auto& e : extra) {
    const auto it = std::find_if(sv.begin(), sv.end(), [&](const auto& s) { return s.first == e.first; });
    if (it != sv.end())
      it->second = e.second;
    else
      sv.push_back(e);
  }
  return sv;
}

std::vector<StartValues> candidate_starts(const CandidateSpec& c, const Estimates& current, std::size_t n_runs) {
  std::vector<StartValues> starts;
  for (const StartValues& extra : c.starts.empty() ? std::vector<StartValues>{{}} : c.starts)
    starts.push_back(start_values_for(c.config, current, n_runs, extra));
  if (c.start_from == CandidateSpec::StartFrom::current_and_own) starts.emplace_back();
  return starts;
}

std::vector<Effect> structural_look_alikes(Effect e, const ModelConfig& m) {
  const bool b1_constant = m.b1.knots_rad.empty() && (m.b1.powers.empty() || max_power(m.b1.powers) == 0);
  // Why: y' = -b1 y + con with constant b1 and a free initial state per run is y_hom + con / b1,
  // exactly a constant static offset.
  if (e == Effect::bias && b1_constant) return {Effect::static_error};
  return {};
}

std::size_t total_samples(const Experiment& e) {
  std::size_t n = 0;
  for (const Run& r : e.runs) n += r.size();
  return n;
}

}  // namespace diagnose_detail

// ---- public views of the registry ---------------------------------------------------------
const std::vector<EffectDescription>& effect_descriptions() {
  static const std::vector<EffectDescription> d = [] {
    std::vector<EffectDescription> v;
    for (const auto& e : diagnose_detail::effect_registry()) v.push_back(e.description);
    return v;
  }();
  return d;
}

const char* effect_name(Effect e) { return diagnose_detail::effect_entry(e).description.name; }

std::string effect_names_list() {
  std::string s;
  for (const auto& e : diagnose_detail::effect_registry()) s += (s.empty() ? "" : ", ") + std::string(e.description.name);
  return s;
}

}  // namespace indicial
