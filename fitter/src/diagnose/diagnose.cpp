// diagnose.cpp -- the missing-effect workflow (see diagnose.hpp): candidate extensions of the
// model, each fitted by fit_experiment from the current estimates, scored by a likelihood-ratio
// test with a Bonferroni guard and BIC; the most significant added, repeated.
#include "indicial/fitter/diagnose.hpp"

#include <boost/math/distributions/chi_squared.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <fmt/format.h>
#include <limits>
#include <map>

#include "diagnose/diagnose_internal.hpp"
#include "estimate/fit_internal.hpp"
#include "indicial/fitter/error.hpp"
#include "indicial/fitter/io.hpp"
#include "indicial/runtime.hpp"
#include "numerics/parallel_for.hpp"

namespace indicial {

namespace fs = std::filesystem;

const char* diagnose_stop_name(DiagnoseStop s) {
  switch (s) {
    case DiagnoseStop::nothing_significant: return "nothing_significant";
    case DiagnoseStop::max_steps: return "max_steps";
  }
  return "?";
}

const char* decision_rule_name(DecisionRule r) {
  switch (r) {
    case DecisionRule::leave_one_run_out: return "leave_one_run_out";
    case DecisionRule::lr_replication_noise: return "lr_replication_noise";
    case DecisionRule::lr_residual: return "lr_residual";
  }
  return "?";
}

const char* candidate_status_name(CandidateStatus s) {
  switch (s) {
    case CandidateStatus::fitted: return "fitted";
    case CandidateStatus::fit_failed: return "fit_failed";
    case CandidateStatus::not_identifiable: return "not_identifiable";
    case CandidateStatus::refused_by_runtime: return "refused_by_runtime";
  }
  return "?";
}

namespace {

using namespace diagnose_detail;

// ------------------------------------------------------------------------------------------
// Statistics.
// ------------------------------------------------------------------------------------------
// log10 of the chi^2(k) upper tail at x, finite when the tail underflows a double.
double chi2_log10_upper(double x, int k) {
  if (!(x > 0.0)) return 0.0;
  const boost::math::chi_squared dist(static_cast<double>(k));
  const double p = boost::math::cdf(boost::math::complement(dist, x));
  // Why the branch: below ~1e-300 the double underflows; the leading term of the asymptotic
  // expansion of the upper incomplete gamma function Q(k/2, x/2) ~ (x/2)^(k/2-1) e^(-x/2) /
  // Gamma(k/2) ranks such candidates correctly (its relative error is O(k / x) there).
  if (p > 1e-300) return std::log10(p);
  const double a = 0.5 * k;
  const double h = 0.5 * x;
  return ((a - 1.0) * std::log(h) - h - std::lgamma(a)) / std::log(10.0);
}

// The residual-correlation factor kappa = (1 + r1) / (1 - r1), r1 the lag-1 autocorrelation
// of the residuals pooled over runs (clamped to [0, 0.98]). For AR(1) noise it is the ratio of
// the noise spectrum at low frequency to its variance, which is how much the white-noise LR
// statistic of a slowly varying sensitivity is inflated: LR / kappa restores its chi^2 scale
// (diagnose.hpp, warning 2).
double correlation_factor(const FitResult& r) {
  double c0 = 0.0, c1 = 0.0;
  for (const RunSeries& s : r.runs) {
    const std::vector<double>& v = s.residual;
    for (std::size_t k = 0; k < v.size(); ++k) {
      c0 += v[k] * v[k];
      if (k > 0) c1 += v[k] * v[k - 1];
    }
  }
  if (!(c0 > 0.0)) return 1.0;
  const double r1 = std::clamp(c1 / c0, 0.0, 0.98);
  return (1.0 + r1) / (1.0 - r1);
}

// The kappa of a likelihood-ratio rule: the candidate's own residual's (lr_residual, and the
// informative statistics of leave_one_run_out), or the replicates' (lr_replication_noise:
// fixed, the noise's own correlation).
struct KappaRule {
  double fixed = 0.0;  // > 0: this kappa for every fit
  double of(const FitResult& r) const { return fixed > 0.0 ? fixed : correlation_factor(r); }
};

// log10 p of a candidate's LR as if its residuals were white (kappa = 1): the ranking and the
// first screen of the leave-one-run-out rule, which decides by prediction instead.
double white_log10_p(const CandidateScore& c) {
  return chi2_log10_upper(c.raw_statistic, std::max(1, c.added_parameters));
}

struct Scored {
  CandidateScore score;
  FitResult fit;
  ModelConfig config;
  SplineFamily family = SplineFamily::none;  // the spline of a knot (for refinement)
  bool is_knot = false;
  double knot_rad = 0.0;
};

// LR / kappa against chi^2(dp), BIC with N_eff = N / kappa (kappa of the extended fit).
void score_against(CandidateScore& c, const FitResult& base, const FitResult& ext, std::size_t n,
                   const KappaRule& kr) {
  const double N = static_cast<double>(n);
  const double s0 = base.fit_error;
  const double s1 = ext.fit_error;
  c.fit_error = s1;
  c.added_parameters = ext.output_error.n_parameters - base.output_error.n_parameters;
  c.correlation_factor = kr.of(ext);
  const double n_eff = N / c.correlation_factor;
  // Why the clamp: the extended fit starts from the base estimates with the new terms at 0 (a
  // nested start), so s1 <= s0 up to the iteration's tolerance; a tiny negative LR is that
  // tolerance, not evidence.
  c.raw_statistic = std::max(0.0, 2.0 * N * std::log(s0 / s1));
  c.statistic = c.raw_statistic / c.correlation_factor;
  const int dp = std::max(1, c.added_parameters);
  c.log10_p = chi2_log10_upper(c.statistic, dp);
  c.p_value = std::pow(10.0, c.log10_p);
  c.delta_bic = -c.statistic + static_cast<double>(c.added_parameters) * std::log(n_eff);
}

// Why: a model the runtime refuses (b(x) <= 0 inside the envelope, a non-finite value) cannot
// be the diagnosis, whatever its fit.
bool runtime_accepts(const FitResult& r, std::string& why) {
  ParseDiagnostic diag;
  if (validate_for_runtime(r.model, &diag) == LoadStatus::ok) return true;
  why = std::string("the runtime refuses the fitted model: ") + diag.reason;
  return false;
}

}  // namespace

namespace diagnose_detail {

FitOptions diagnose_fit_options(const DiagnoseOptions& o, StallStartSearch search, const StartValues& sv) {
  FitOptions fo = o.fit;
  fo.stall_start_search = search;
  fo.threads = o.threads;
  // Why names here: FitOptions takes start values by contract name; each is made from the
  // id of this configuration's term (its knot number in this model), never parsed back.
  fo.start_values.clear();
  for (const auto& [id, value] : sv) fo.start_values.emplace_back(parameter_name(id), value);
  return fo;
}

bool stall_grid_retry_needed(Effect effect, const CandidateFit& best, const FitResult& base, StallStartSearch search) {
  const bool stall_family = effect == Effect::separation_lag || effect == Effect::vortex_shedding;
  if (!stall_family || search == StallStartSearch::grid) return false;
  return best.status != CandidateStatus::fitted || !(best.fit.fit_error < base.fit_error);
}

CandidateFit best_usable_fit(const std::vector<StartValues>& starts, const StartFit& fit) {
  CandidateFit best;
  bool have = false;
  for (const StartValues& start : starts) {
    try {
      FitResult r = fit(start);
      if (!std::isfinite(r.fit_error)) {
        best.message = r.output_error.message;
        continue;
      }
      // Why: a rank-deficient extension has a direction the data do not determine; its cost
      // is not evidence for the effect.
      if (r.output_error.termination == Termination::rank_deficient) {
        if (!have) best.status = CandidateStatus::not_identifiable;
        best.message = r.output_error.message;
        continue;
      }
      std::string why;
      if (!runtime_accepts(r, why)) {
        if (!have) best.status = CandidateStatus::refused_by_runtime;
        best.message = why;
        continue;
      }
      if (!have || r.fit_error < best.fit.fit_error) {
        best.fit = std::move(r);
        have = true;
      }
    } catch (const InputError& err) {
      best.message = err.what();
    }
  }
  if (have) {
    best.status = CandidateStatus::fitted;
    best.message.clear();
  }
  return best;
}

}  // namespace diagnose_detail

namespace {

void describe_estimates(Scored& s, Effect effect) {
  const FitResult& f = s.fit;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  switch (effect) {
    case Effect::time_delay: {
      const double delay_s = estimate_of(f, param_id(ParamKind::delay), nan);
      s.score.detail = fmt::format("delay {:.4g} s", delay_s);
      // Why: a negative delay is a prediction, which the runtime refuses; it is no evidence of
      // a delay in the data (the fit is recorded but cannot win).
      if (!(delay_s > 0.0)) {
        s.score.status = CandidateStatus::fit_failed;
        s.score.message = "the delay estimate is not positive";
      }
      break;
    }
    case Effect::second_lag:
      s.score.detail = fmt::format("b2 = {:.4g} 1/s", estimate_of(f, param_id(ParamKind::b_power, 1, 0), nan)) +
                       s.score.detail +
                       fmt::format(", c2 = {:.4g}", estimate_of(f, param_id(ParamKind::gain, 1), nan));
      break;
    case Effect::bias:
      s.score.detail = fmt::format("con = {:.4g} 1/s", estimate_of(f, param_id(ParamKind::con), nan));
      break;
    case Effect::separation_lag:
      s.score.detail = fmt::format("T1 = {:.4g}, T2 = {:.4g} (l/V)", estimate_of(f, param_id(ParamKind::stall_tau1), nan),
                                   estimate_of(f, param_id(ParamKind::stall_tau2), nan));
      break;
    case Effect::slow_reattachment:
      s.score.detail = fmt::format("T1r = {:.4g}, T1 = {:.4g} (l/V)",
                                   estimate_of(f, param_id(ParamKind::stall_tau1_reattach), nan),
                                   estimate_of(f, param_id(ParamKind::stall_tau1), nan));
      break;
    case Effect::static_hysteresis:
      s.score.detail = fmt::format("dxr = {:.4g} deg",
                                   estimate_of(f, param_id(ParamKind::stall_reattach_shift), nan) * 180.0 / 3.141592653589793);
      break;
    case Effect::lag_limit:
      s.score.detail = fmt::format("D = {:.4g} deg (T2 = {:.4g} (l/V))",
                                   estimate_of(f, param_id(ParamKind::stall_lag_limit), nan) * 180.0 / 3.141592653589793,
                                   estimate_of(f, param_id(ParamKind::stall_tau2), nan));
      break;
    case Effect::pressure_lag:
      s.score.detail = fmt::format("T2 = {:.4g} (l/V) as a first-order lag",
                                   estimate_of(f, param_id(ParamKind::stall_tau2), nan));
      break;
    case Effect::vortex_shedding:
      s.score.detail = fmt::format("CN1 = {:.4g}, Tv = {:.4g}, Tvl = {:.4g} (l/V)",
                                   estimate_of(f, param_id(ParamKind::shedding_threshold), nan),
                                   estimate_of(f, param_id(ParamKind::vortex_decay), nan),
                                   estimate_of(f, param_id(ParamKind::vortex_travel), nan));
      break;
    default: break;
  }
}

// Why every model the rounds compare against is fitted to convergence: a candidate is fitted
// from the current model's estimates, so when that model's fit stopped at the iteration limit
// the candidate's own iterations continue the model's descent, and that gain reads as the
// effect's. Measured on validate-real's `means` C_L from the Beddoes-Leishman structure (three
// measured cycles): the configured model stopped at 50 iterations at s(v) 0.0833, and a_alpha
// then rotary_alpha entered against it; continued from its estimates it converged at 0.0812,
// and against that model neither lowered the held-out runs' error (b1_alpha's and a_alpha's
// mean held-out log MSE ratio +0.23 and +0.12: worse) and nothing entered. So the configured
// model and each step's model are fitted on from their own estimates until converged, up to
// model_iteration_factor (diagnose.hpp) times the iteration limit in all; one still at the
// limit then is reported (DiagnoseResult::unconverged_models, a warning). Not always the better
// predictor: on the same cycles' C_m an effect that had entered against the unconverged model
// and helped other cycles no longer enters (docs/diagnose.md, step 6, with 64 more cases:
// docs/diagnose-ab.md).

class Diagnoser {
 public:
  Diagnoser(const DiagnoseOptions& o, KappaRule kr) : o_(o), kappa_(kr) {}
  const KappaRule& kappa() const { return kappa_; }
  int fits_run() const { return fits_.load(); }
  int threads() const { return o_.threads; }

  FitResult fit(const Experiment& e, const ModelConfig& m, const StartValues& sv) {
    return fit_with(e, m, sv, o_.fit.stall_start_search);
  }

  FitResult fit_with(const Experiment& e, const ModelConfig& m, const StartValues& sv, StallStartSearch search) {
    Experiment x = e;
    x.model = m;
    ++fits_;
    return fit_experiment(x, diagnose_fit_options(o_, search, sv));
  }

  // f (a fit of model m to e) fitted on from its own estimates while it ends at the iteration
  // limit, up to model_iteration_factor times the limit in all (see there).
  // A continuation is kept only as a candidate's fit is (best_usable_fit: finite, identifiable,
  // accepted by the runtime, not thrown) and not above f.
  FitResult converged(const Experiment& e, const ModelConfig& m, FitResult f) {
    for (int k = 1; k < model_iteration_factor && f.output_error.termination == Termination::iteration_limit; ++k) {
      CandidateFit next = diagnose_detail::best_usable_fit(
          {start_values_for(m, estimates_by_id(f), e.runs.size(), {})},
          [&](const StartValues& sv) { return fit(e, m, sv); });
      if (next.status != CandidateStatus::fitted || !(next.fit.fit_error <= f.fit_error)) break;
      f = std::move(next.fit);
    }
    return f;
  }

  // Every spec evaluated against `base`, in parallel (o.threads).
  std::vector<Scored> evaluate_all(const Experiment& e, const std::vector<CandidateSpec>& specs,
                                   const FitResult& base) {
    const Estimates current = estimates_by_id(base);
    std::vector<Scored> out(specs.size());
    detail::parallel_for(specs.size(), o_.threads,
                         [&](std::size_t i) { out[i] = evaluate(e, specs[i], base, current); });
    return out;
  }

  // Per-run held-out errors of model m, folds warm-started from its full fit.
  HeldOut held_out(const Experiment& w, const ModelConfig& m, const FitResult& full) {
    HeldOut h = held_out_errors(w, m, estimates_by_id(full), o_.threads, o_.cv_max_folds,
                                [this](const Experiment& x, const ModelConfig& c, const StartValues& sv) { return fit(x, c, sv); },
                                o_.cv_unit);
    h.fit_error = full.fit_error;
    return h;
  }

  // Fits a candidate from each of its starts (candidate_starts), keeps the best usable fit
  // (best_usable_fit), scores it against `base`.
  // A stall family's candidate whose fits from its configured starts did not end below its
  // base (a nested model: a local minimum, not the family's) is fitted once more from the same
  // starts, each with the fit's start grid (FitOptions::stall_start_search), the better fit
  // kept. Why: validate-real's `means` C_m (three runs): from the configured starts the vortex
  // candidate ended at 0.0680 above its base's 0.0568 and was never tested on held-out runs;
  // with the grid it reached 0.0386. The grid runs only then (the default stays the configured
  // start, for speed: DiagnoseOptions::fit_defaults).
  // Returns what was done, for the candidate's message (diagnosis.json), or "" (no retry).
  std::string retry_stall_from_grid(const Experiment& e, const CandidateSpec& c, const FitResult& base,
                                    const Estimates& current, CandidateFit& best) {
    if (!stall_grid_retry_needed(c.effect, best, base, o_.fit.stall_start_search)) return "";
    const std::string before = best.status == CandidateStatus::fitted ? fmt::format("ended at {:.4g}", best.fit.fit_error)
                                                                      : "gave no usable fit";
    CandidateFit grid = best_usable_fit(candidate_starts(c, current, e.runs.size()), [&](const StartValues& sv) {
      return fit_with(e, c.config, sv, StallStartSearch::grid);
    });
    const bool better = grid.status == CandidateStatus::fitted &&
                        (best.status != CandidateStatus::fitted || grid.fit.fit_error < best.fit.fit_error);
    const std::string note = fmt::format("from the configured stall starts the fit {}, not below the base's {:.4g}: "
                                         "refitted from the start grid, {}",
                                         before, base.fit_error,
                                         better ? fmt::format("which ended at {:.4g} (kept)", grid.fit.fit_error)
                                                : std::string("which did no better"));
    if (better) best = std::move(grid);
    return best.status == CandidateStatus::fitted ? note : best.message + " (" + note + ")";
  }

  Scored evaluate(const Experiment& e, const CandidateSpec& c, const FitResult& base,
                  const Estimates& current) {
    Scored s;
    s.score.effect = c.effect;
    s.score.term = c.term;
    s.score.detail = c.detail;
    s.config = c.config;
    s.is_knot = c.is_knot;
    s.knot_rad = c.knot_rad;
    s.family = c.family;
    CandidateFit best = best_usable_fit(candidate_starts(c, current, e.runs.size()),
                                        [&](const StartValues& sv) { return fit(e, c.config, sv); });
    const std::string retried = retry_stall_from_grid(e, c, base, current, best);
    s.score.status = best.status;
    s.score.message = retried.empty() ? std::move(best.message) : retried;
    if (best.status != CandidateStatus::fitted) return s;
    s.fit = std::move(best.fit);
    score_against(s.score, base, s.fit, total_samples(e), kappa_);
    describe_estimates(s, c.effect);
    return s;
  }

 private:
  const DiagnoseOptions& o_;
  KappaRule kappa_;
  std::atomic<int> fits_{0};
};

// The most significant fitted candidate (of effect `only` unless any_effect): by its LR / kappa,
// or, under leave_one_run_out (`white`), by its LR alone (kappa is not the decision there).
int best_of(const std::vector<Scored>& scored, Effect only, bool any_effect, bool white = false) {
  int b = -1;
  double best = 0.0;
  for (std::size_t i = 0; i < scored.size(); ++i) {
    const CandidateScore& c = scored[i].score;
    if (c.status != CandidateStatus::fitted || (!any_effect && c.effect != only)) continue;
    const double lp = white ? white_log10_p(c) : c.log10_p;
    if (b < 0 || lp < best) {
      b = static_cast<int>(i);
      best = lp;
    }
  }
  return b;
}

bool significant(const CandidateScore& c, double threshold) {
  // Why both: the Bonferroni-guarded LR test controls false positives; BIC (penalty ln N_eff
  // per parameter) additionally refuses an effect too small to pay for itself.
  return c.status == CandidateStatus::fitted && c.log10_p < std::log10(threshold) && c.delta_bic < 0.0;
}

// The first screen of leave_one_run_out: the white LR passes the Bonferroni threshold (a
// necessary condition; under colored noise it passes often, and the held-out test decides).
bool passes_screen(const CandidateScore& c, double threshold, DecisionRule rule) {
  if (rule != DecisionRule::leave_one_run_out) return significant(c, threshold);
  return c.status == CandidateStatus::fitted && white_log10_p(c) < std::log10(threshold);
}

// One effect's sub-model grown from its first term: the family's candidates against the
// current sub-model, the most significant added while it passes alpha / (candidates of that
// scan) and lowers BIC, up to max_family_terms terms.
struct Family {
  Effect effect = Effect::bias;
  std::vector<Scored> path;  // path[0] the first term (scored against the base), then each added
  HeldOut held_out;          // leave_one_run_out: the held-out errors of path.back()
};

struct RoundContext {
  const Experiment& w;
  const ModelConfig& model;
  const FitResult& base;
  const std::vector<double>& grid;
  double spacing = 0.0;
  DecisionRule rule = DecisionRule::lr_residual;
  const HeldOut* base_held_out = nullptr;  // leave_one_run_out: the base's held-out errors
};

// The working configuration: a stepwise structure is frozen at the selected terms, an
// estimated C_aq at its estimate (diagnose.hpp warning 4).
Experiment working_experiment(const Experiment& e, const FitResult& first) {
  Experiment w = e;
  if (e.model.structure == StructureMode::stepwise) {
    fit_detail::UnsteadyStructure pool = fit_detail::structure_from_config(e.model);
    std::vector<ParamId> ids;
    for (const ParameterEstimate& p : first.parameters) ids.push_back(p.id);
    const fit_detail::UnsteadyStructure s = fit_detail::select_terms(pool, ids);
    w.model.a.powers = s.a.powers;
    w.model.a.knots_rad = s.a.knots_rad;
    w.model.b1.powers = s.b[0].powers;
    w.model.b1.knots_rad = s.b[0].knots_rad;
    w.model.bias = s.con == fit_detail::Bias::present;
    w.model.structure = StructureMode::fixed;
  }
  if (e.rotary.estimate) {
    const auto& rot = first.model.coefficients[0].rotary;
    w.rotary.estimate = false;
    w.rotary.polynomial.assign(rot.power_coef, rot.power_coef + rot.n_powers);
    w.model.rotary_correction = SplineConfig{{}, {}, 1};
    for (int j = 0; j < rot.n_knots; ++j)
      if (rot.knot_coef[j] != 0.0) w.model.rotary_correction.knots_rad.push_back(rot.knot_rad[j]);
  }
  return w;
}

std::vector<double> run_rms(const FitResult& r) {
  std::vector<double> v;
  for (const RunSeries& s : r.runs) v.push_back(run_fit_error(s));
  return v;
}

}  // namespace

ResidualSignature residual_signature(const std::vector<RunSeries>& runs) {
  ResidualSignature sig;
  constexpr double bin_rad = 2.0 * kDegToRad;
  std::map<long, std::pair<double, double>> by_angle;          // bin -> (sum, count)
  std::map<std::pair<long, int>, std::pair<double, double>> by_direction;  // (bin, sign rate)
  double total = 0.0, ss_rate = 0.0, ss_const = 0.0;
  for (const RunSeries& s : runs) {
    std::map<std::pair<long, int>, std::pair<double, double>> run_dir;
    double sum = 0.0, vq = 0.0, qq = 0.0;
    for (std::size_t k = 0; k < s.residual.size(); ++k) {
      const double v = s.residual[k], q = s.rate_radps[k];
      const long bin = std::lround(s.x_rad[k] / bin_rad);
      const int dir = q > 0.0 ? 1 : q < 0.0 ? -1 : 0;
      for (auto* m : {&by_direction, &run_dir}) {
        (*m)[{bin, dir}].first += v;
        (*m)[{bin, dir}].second += 1.0;
      }
      by_angle[bin].first += v;
      by_angle[bin].second += 1.0;
      total += v * v;
      sum += v;
      vq += v * q;
      qq += q * q;
    }
    const double n = static_cast<double>(s.residual.size());
    sig.run_mean.push_back(n > 0.0 ? sum / n : 0.0);
    sig.run_rate_gain.push_back(qq > 0.0 ? vq / qq : 0.0);
    sig.run_rms_rate.push_back(n > 0.0 ? std::sqrt(qq / n) : 0.0);
    ss_const += n > 0.0 ? sum * sum / n : 0.0;
    ss_rate += qq > 0.0 ? vq * vq / qq : 0.0;
    // Half the up - down difference of the bin means, RMS over the bins with both strokes.
    double hs = 0.0, hc = 0.0;
    for (const auto& [key, up] : run_dir) {
      if (key.second != 1) continue;
      const auto down = run_dir.find({key.first, -1});
      if (down == run_dir.end()) continue;
      const double h = 0.5 * (up.first / up.second - down->second.first / down->second.second);
      hs += h * h;
      hc += 1.0;
    }
    sig.run_hysteresis.push_back(hc > 0.0 ? std::sqrt(hs / hc) : 0.0);
  }
  if (!(total > 0.0)) return sig;
  double ss_angle = 0.0, ss_dir = 0.0;
  for (const auto& [bin, a] : by_angle) ss_angle += a.first * a.first / a.second;
  for (const auto& [key, a] : by_direction) ss_dir += a.first * a.first / a.second;
  sig.angle_only = ss_angle / total;
  sig.hysteresis = std::max(0.0, ss_dir - ss_angle) / total;
  sig.rate_in_phase = ss_rate / total;
  sig.constant = ss_const / total;
  return sig;
}

namespace {

// Bonferroni count of a round: every candidate model, plus the refinement positions (+-1/4,
// +-1/2 spacing) budgeted for every knot effect whether or not its best knot is refined.
constexpr int kRefinements = 4;

std::vector<Scored> score_candidates(Diagnoser& dg, const RoundContext& rc, int& tested) {
  const std::vector<CandidateSpec> specs =
      all_candidates(CandidateContext{rc.w, rc.model, rc.base, rc.grid, rc.spacing});
  std::vector<Scored> scored = dg.evaluate_all(rc.w, specs, rc.base);
  tested = static_cast<int>(specs.size());
  for (const EffectEntry& e : effect_registry())
    if (e.family != SplineFamily::none) tested += kRefinements;
  return scored;
}

// A winning knot refined between its grid neighbours; the better position replaces it.
void refine_knot(Diagnoser& dg, const RoundContext& rc, std::vector<Scored>& scored, std::size_t b) {
  if (!scored[b].is_knot) return;
  const SplineFamily family = scored[b].family;
  const Effect effect = scored[b].score.effect;
  const double k0 = scored[b].knot_rad;
  std::vector<CandidateSpec> specs;
  for (double f : {-0.5, -0.25, 0.25, 0.5}) {
    const double k = k0 + f * rc.spacing;
    if (!(k > rc.w.data_x_min_rad && k < rc.w.data_x_max_rad)) continue;
    if (has_knot(family_spline(rc.model, family).knots_rad, k, 0.2 * rc.spacing)) continue;
    specs.push_back(knot_candidate(rc.model, effect, family, k));
  }
  for (Scored& s : dg.evaluate_all(rc.w, specs, rc.base)) scored.push_back(std::move(s));
}

// Grows an effect's sub-model from its first term (see Family).
std::string joined_terms(const std::vector<Scored>& path, const Scored* next = nullptr) {
  std::string t;
  for (const Scored& s : path) t += (t.empty() ? "" : "; ") + s.score.term;
  if (next) t += (t.empty() ? "" : "; ") + next->score.term;
  return t;
}

// Under leave_one_run_out: whether `cand` (the family `f` plus one term, or its first term)
// lowers the held-out error of f's current model (the round's base for a first term). The
// test is recorded in the round; `ho` receives the candidate's held-out errors.
bool enters_held_out(Diagnoser& dg, const RoundContext& rc, const DiagnoseOptions& o, const Family& f,
                     const Scored& cand, DiagnoseRound& rd, HeldOut& ho) {
  const bool first = f.path.empty();
  ho = dg.held_out(rc.w, cand.config, cand.fit);
  const HeldOut& without = first ? *rc.base_held_out : f.held_out;
  rd.held_out.push_back(held_out_test(f.effect, joined_terms(f.path, &cand), first ? "first term" : "next term",
                                      without, ho, o.cv_min_gain, o.cv_min_in_sample_gain));
  return rd.held_out.back().enters;
}

// Grows an effect's sub-model from its first term (see Family). Under leave_one_run_out the
// first term and every next term enter only by the held-out test (an empty path: the first
// term did not enter); otherwise by the Bonferroni-guarded LR test and BIC.
Family grow_family(Diagnoser& dg, const RoundContext& rc, Scored first, const DiagnoseOptions& o, DiagnoseRound& rd) {
  const bool cv = rc.rule == DecisionRule::leave_one_run_out;
  Family f;
  f.effect = first.score.effect;
  if (cv) {
    HeldOut ho;
    if (!enters_held_out(dg, rc, o, f, first, rd, ho)) return f;
    f.held_out = std::move(ho);
  }
  f.path.push_back(std::move(first));
  const EffectEntry& entry = effect_entry(f.effect);
  if (entry.family == SplineFamily::none && !entry.grows) return f;
  while (static_cast<int>(f.path.size()) < o.max_family_terms) {
    const Scored& cur = f.path.back();
    std::vector<CandidateSpec> specs;
    entry.generate(CandidateContext{rc.w, cur.config, cur.fit, rc.grid, rc.spacing}, specs);
    if (specs.empty()) break;
    std::vector<Scored> sc = dg.evaluate_all(rc.w, specs, cur.fit);
    const int b = best_of(sc, f.effect, false, cv);
    const double threshold = o.alpha / static_cast<double>(sc.size());
    if (b < 0 || !passes_screen(sc[static_cast<std::size_t>(b)].score, threshold, rc.rule)) break;
    Scored& next = sc[static_cast<std::size_t>(b)];
    if (cv) {
      HeldOut ho;
      if (!enters_held_out(dg, rc, o, f, next, rd, ho)) break;
      f.held_out = std::move(ho);
    }
    f.path.push_back(std::move(next));
  }
  return f;
}

// A family's sub-model against the round's base: its own kappa for the p-value, a common
// kappa (the whitest residual of the round's families) for the BIC that compares families.
FamilyResult summarize(const Family& f, const FitResult& base, std::size_t n, double kappa_common,
                       const KappaRule& kr) {
  const Scored& last = f.path.back();
  FamilyResult r;
  r.effect = f.effect;
  for (const Scored& s : f.path) {
    r.terms.push_back(s.score.term);
    r.detail += (r.detail.empty() ? "" : "; ") + s.score.detail;
  }
  const double N = static_cast<double>(n);
  r.added_parameters = last.fit.output_error.n_parameters - base.output_error.n_parameters;
  r.fit_error = last.fit.fit_error;
  const double lr = std::max(0.0, 2.0 * N * std::log(base.fit_error / last.fit.fit_error));
  r.log10_p = chi2_log10_upper(lr / kr.of(last.fit), std::max(1, r.added_parameters));
  r.delta_bic = -lr / kappa_common + r.added_parameters * std::log(N / kappa_common);
  return r;
}

}  // namespace

namespace diagnose_detail {

// The family that explains the disagreement: the lowest BIC; families within
// indistinguishable_bic of it are named with it, and among them the step is the one with the
// fewest parameters, then the lower BIC, then the registry's order (an exact tie only).
int choose_family(const std::vector<FamilyResult>& fr, const DiagnoseOptions& o, std::vector<Effect>& tied) {
  if (fr.empty()) return -1;
  double best = fr.front().delta_bic;
  for (const FamilyResult& f : fr) best = std::min(best, f.delta_bic);
  auto simpler = [](const FamilyResult& x, const FamilyResult& y) {
    if (x.added_parameters != y.added_parameters) return x.added_parameters < y.added_parameters;
    if (x.delta_bic != y.delta_bic) return x.delta_bic < y.delta_bic;
    return x.effect < y.effect;
  };
  int w = -1;
  for (std::size_t i = 0; i < fr.size(); ++i) {
    if (fr[i].delta_bic > best + o.indistinguishable_bic) continue;
    if (w < 0 || simpler(fr[i], fr[static_cast<std::size_t>(w)])) w = static_cast<int>(i);
  }
  for (std::size_t i = 0; i < fr.size(); ++i)
    if (static_cast<int>(i) != w && fr[i].delta_bic <= best + o.indistinguishable_bic) tied.push_back(fr[i].effect);
  return w;
}

}  // namespace diagnose_detail

namespace {

void record_step(DiagnoseResult& d, const DiagnoseRound& rd, const FamilyResult& fr, Scored& last,
                 const std::vector<Effect>& tied, const KappaRule& kr) {
  const FitResult& base = d.fits.back();
  DiagnoseStep st;
  st.step = static_cast<int>(d.steps.size()) + 1;
  st.effect = fr.effect;
  st.detail = fr.detail;
  for (const std::string& t : fr.terms) st.term += (st.term.empty() ? "" : "; ") + t;
  st.indistinguishable = tied;
  st.correlation_factor = kr.of(last.fit);
  const double N = static_cast<double>(total_samples(d.experiment));
  st.statistic = std::max(0.0, 2.0 * N * std::log(base.fit_error / last.fit.fit_error)) / st.correlation_factor;
  st.log10_p = fr.log10_p;
  st.p_value = std::pow(10.0, fr.log10_p);
  st.threshold = rd.threshold;
  st.candidates_tested = rd.candidates_tested;
  st.added_parameters = fr.added_parameters;
  st.delta_bic = -st.statistic + fr.added_parameters * std::log(N / st.correlation_factor);
  st.fit_error_before = base.fit_error;
  st.fit_error_after = last.fit.fit_error;
  st.run_rms_before = run_rms(base);
  st.run_rms_after = run_rms(last.fit);
  st.rule = rd.rule;
  if (fr.has_held_out) {
    st.held_out_rms_before = fr.held_out.rms_without;
    st.held_out_rms_after = fr.held_out.rms_with;
    st.held_out_log_ratio = fr.held_out.mean_log_ratio;
    st.held_out_standard_error = fr.held_out.standard_error;
  }
  d.steps.push_back(st);
  d.effects_added.push_back(effect_name(st.effect));
  d.configs.push_back(last.config);
  d.fits.push_back(std::move(last.fit));
}

// leave_one_run_out's choice among the families that entered (the one-standard-error rule):
// the best is the lowest mean held-out log ratio against the round's model; every family
// within one standard error of it is as good on these runs, and among those the step is the
// one with the fewest added parameters, then the lower ratio; the others within are named
// with it (`indistinguishable`).
int choose_family_held_out(const std::vector<FamilyResult>& fr, std::vector<Effect>& tied) {
  int best = -1;
  for (std::size_t i = 0; i < fr.size(); ++i)
    if (best < 0 || fr[i].held_out.mean_log_ratio < fr[static_cast<std::size_t>(best)].held_out.mean_log_ratio)
      best = static_cast<int>(i);
  if (best < 0) return -1;
  const HeldOutTest& b = fr[static_cast<std::size_t>(best)].held_out;
  const double bound = b.mean_log_ratio + b.standard_error;
  int w = best;
  for (std::size_t i = 0; i < fr.size(); ++i) {
    const FamilyResult& x = fr[i];
    const FamilyResult& y = fr[static_cast<std::size_t>(w)];
    if (x.held_out.mean_log_ratio > bound) continue;
    if (x.added_parameters < y.added_parameters ||
        (x.added_parameters == y.added_parameters && x.held_out.mean_log_ratio < y.held_out.mean_log_ratio))
      w = static_cast<int>(i);
  }
  for (std::size_t i = 0; i < fr.size(); ++i)
    if (static_cast<int>(i) != w && fr[i].held_out.mean_log_ratio <= bound) tied.push_back(fr[i].effect);
  return w;
}

// The round's rule: leave_one_run_out needs the base's held-out errors; when a fold of the
// base cannot be scored the round falls back to the likelihood ratio (rule_note says why).
DecisionRule round_rule(Diagnoser& dg, const DiagnoseResult& d, DiagnoseRound& rd, HeldOut& base_ho) {
  if (d.rule != DecisionRule::leave_one_run_out) return d.rule;
  base_ho = dg.held_out(d.experiment, d.configs.back(), d.fits.back());
  for (double v : base_ho.mse) rd.held_out_base_rms.push_back(std::sqrt(v));
  rd.held_out_scored_fraction = base_ho.scored_fraction;
  if (base_ho.ok) return DecisionRule::leave_one_run_out;
  rd.rule_note = "leave-one-run-out could not score the model of this round (" + base_ho.message +
                 "); the likelihood ratio with the residual's kappa decided";
  return dg.kappa().fixed > 0.0 ? DecisionRule::lr_replication_noise : DecisionRule::lr_residual;
}

// One round: every candidate against the current model; the effects that pass the round's
// rule grown into sub-models and compared; the winner added (unless check_only). Returns
// whether an effect passed.
bool run_round(Diagnoser& dg, const DiagnoseOptions& o, DiagnoseResult& d, bool check_only) {
  const Experiment& w = d.experiment;
  double spacing = o.knot_spacing_deg * kDegToRad;
  const std::vector<double> grid = knot_grid(w, o, spacing);
  DiagnoseRound rd;
  HeldOut base_ho;
  rd.rule = round_rule(dg, d, rd, base_ho);
  const bool cv = rd.rule == DecisionRule::leave_one_run_out;
  const RoundContext rc{w, d.configs.back(), d.fits.back(), grid, spacing, rd.rule, &base_ho};
  rd.round = static_cast<int>(d.rounds.size()) + 1;
  rd.check_only = check_only;
  rd.base_fit_error = rc.base.fit_error;
  rd.signature = residual_signature(rc.base.runs);
  int tested = 0;
  std::vector<Scored> scored = score_candidates(dg, rc, tested);
  rd.candidates_tested = tested;
  rd.threshold = o.alpha / static_cast<double>(std::max(1, tested));
  std::vector<Family> families;
  for (const EffectEntry& e : effect_registry()) {
    int b = best_of(scored, e.description.effect, false, cv);
    if (b < 0 || !passes_screen(scored[static_cast<std::size_t>(b)].score, rd.threshold, rd.rule)) continue;
    if (!check_only) refine_knot(dg, rc, scored, static_cast<std::size_t>(b));
    b = best_of(scored, e.description.effect, false, cv);
    // At check_only the first term is tested (by the round's rule) and not grown.
    DiagnoseOptions once = o;
    if (check_only) once.max_family_terms = 1;
    Family f = (check_only && !cv) ? Family{e.description.effect, {scored[static_cast<std::size_t>(b)]}, {}}
                                   : grow_family(dg, rc, scored[static_cast<std::size_t>(b)], once, rd);
    if (!f.path.empty()) families.push_back(std::move(f));
  }
  for (const Scored& s : scored) rd.candidates.push_back(s.score);
  rd.best = best_of(scored, Effect::bias, true, cv);
  const bool any = !families.empty();
  if (check_only || !any) {
    if (check_only && any) d.still_significant = effect_name(families.front().effect);
    d.rounds.push_back(std::move(rd));
    return any;
  }
  double kappa_common = std::numeric_limits<double>::infinity();
  for (const Family& f : families) kappa_common = std::min(kappa_common, dg.kappa().of(f.path.back().fit));
  for (const Family& f : families) {
    rd.families.push_back(summarize(f, rc.base, total_samples(w), kappa_common, dg.kappa()));
    if (!cv) continue;
    rd.families.back().has_held_out = true;
    rd.families.back().held_out = held_out_test(f.effect, joined_terms(f.path), "sub-model", base_ho, f.held_out,
                                                o.cv_min_gain, o.cv_min_in_sample_gain);
  }
  std::vector<Effect> tied;
  rd.winner = cv ? choose_family_held_out(rd.families, tied) : choose_family(rd.families, o, tied);
  for (Effect twin : structural_look_alikes(rd.families[static_cast<std::size_t>(rd.winner)].effect, rc.model))
    if (std::find(tied.begin(), tied.end(), twin) == tied.end()) tied.push_back(twin);
  rd.added = true;
  const std::size_t win = static_cast<std::size_t>(rd.winner);
  Scored& chosen = families[win].path.back();
  chosen.fit = dg.converged(w, chosen.config, std::move(chosen.fit));
  if (chosen.fit.output_error.termination == Termination::iteration_limit)
    d.unconverged_models.push_back(static_cast<int>(d.steps.size()) + 1);
  record_step(d, rd, rd.families[win], chosen, tied, dg.kappa());
  d.rounds.push_back(std::move(rd));
  return true;
}

// The rule of the rounds (DecisionRule) and, for lr_replication_noise, the replicates' kappa.
// The options are valid (diagnose_experiment checked them): cv_min_runs >= 2, cv_max_folds >= 2.
KappaRule choose_rule(const Experiment& e, const DiagnoseOptions& o, DiagnoseResult& d) {
  const int runs = static_cast<int>(e.runs.size());
  const bool enough = runs >= o.cv_min_runs;
  if (o.rule == RuleChoice::leave_one_run_out && !enough)
    throw InputError("--rule", 0, fmt::format("leave_one_run_out needs at least {} runs (--cv-min-runs); the "
                                              "experiment has {}", o.cv_min_runs, runs));
  KappaRule kr;
  if (o.rule != RuleChoice::likelihood_ratio && enough) {
    d.rule = DecisionRule::leave_one_run_out;
    d.rule_reason = fmt::format("{} runs: an effect enters only when it lowers the error of runs left out of its fit", runs);
    const diagnose_detail::FoldPlan plan = diagnose_detail::fold_plan(e, o.cv_max_folds, o.cv_unit);
    d.cv_folds = plan.folds;
    d.cv_unit = plan.unit;
    d.cv_groups = plan.groups;
    if (plan.unit == CrossValidationUnit::group) {
      d.rule_reason += fmt::format(" (whole groups left out: {} groups", plan.groups.size());
      d.rule_reason += plan.folds < static_cast<int>(plan.groups.size())
                           ? fmt::format(" in {} folds, group g with fold g mod {})", plan.folds, plan.folds)
                           : std::string(", one per fold)");
    } else if (d.cv_folds < runs) {
      d.rule_reason += fmt::format(" ({} folds of runs: run r left out with fold r mod {})", d.cv_folds, d.cv_folds);
    }
  } else if (d.replication.source != NoiseSource::none) {
    d.rule = DecisionRule::lr_replication_noise;
    const double r1 = d.replication.lag1_correlation;
    kr.fixed = (1.0 + r1) / (1.0 - r1);
    d.rule_reason = fmt::format("{} run(s): likelihood ratio, kappa {:.3g} from the replicates' correlation ({})",
                                runs, kr.fixed, d.replication.detail);
  } else {
    d.rule = DecisionRule::lr_residual;
    d.rule_reason = fmt::format(
        "{} run(s) and no replication: likelihood ratio with kappa from each candidate's residual -- a "
        "structured model error can read as colored noise and hide itself; give {} or more runs, or replicates",
        runs, o.cv_min_runs);
  }
  return kr;
}

void flag_ill_conditioned(DiagnoseResult& d) {
  // Why y0 is left out: a run's initial state is a nuisance parameter that may well be ~0.
  for (const ParameterEstimate& p : d.fits.back().parameters)
    if (bound_exceeds_value(p)) d.ill_conditioned.push_back(p.name);
}

}  // namespace

DiagnoseResult diagnose_experiment(const Experiment& e_in, const DiagnoseOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  if (std::string bad; !o.IsValid(&bad)) throw InputError(bad);
  DiagnoseResult d;
  d.alpha = o.alpha;
  Experiment e = e_in;
  d.replication = replication_noise(e);
  Diagnoser dg(o, choose_rule(e, o, d));
  // Why: the knot grid needs the model-angle range; an Experiment built in memory may not
  // carry it (load_experiment fills it).
  if (!(e.data_x_max_rad > e.data_x_min_rad)) {
    const ModelSet<double, FitCapacity> b = base_model_set(e);
    e.data_x_min_rad = b.x_min_rad;
    e.data_x_max_rad = b.x_max_rad;
  }
  // The configured model is fitted as `indicial fit` fits it: with stall families, from the
  // fit's start grid whatever o.fit.stall_start_search says for the candidates (that choice is
  // for speed over many candidate fits; this is one fit). Why: from the configured start alone a
  // digitized C_m with the separation family ended at s(v) 0.0536 where `indicial fit` reached
  // 0.0391, and diagnose wrote the worse model with verdict none (a user's trial, 2026-11-27).
  const StallStartSearch base_search =
      e.model.stall.families != StallFamilies::none ? StallStartSearch::grid : o.fit.stall_start_search;
  FitResult first = dg.fit_with(e, e.model, {}, base_search);
  const bool frozen = e.model.structure == StructureMode::stepwise || e.rotary.estimate;
  d.experiment = working_experiment(e, first);
  if (frozen) {
    // Refit the frozen configuration from the first fit's estimates (same model, fixed form).
    const Experiment& w = d.experiment;
    first = dg.fit(w, w.model, start_values_for(w.model, estimates_by_id(first), w.runs.size(), {}));
  }
  first = dg.converged(d.experiment, d.experiment.model, std::move(first));
  if (first.output_error.termination == Termination::iteration_limit) d.unconverged_models.push_back(0);
  d.fits.push_back(first);
  d.configs.push_back(d.experiment.model);
  d.initial_fit_error = first.fit_error;
  d.noise = estimate_noise_level(first.runs);
  bool last_added = false;
  for (int round = 1; round <= o.max_steps; ++round)
    if (!(last_added = run_round(dg, o, d, false))) break;
  // At max_steps: one more round, tested only, says whether an effect is still significant.
  if (last_added && run_round(dg, o, d, true)) d.stopped = DiagnoseStop::max_steps;
  d.final_fit_error = d.fits.back().fit_error;
  d.final_noise = estimate_noise_level(d.fits.back().runs);
  d.verdict = d.steps.empty() ? "none" : effect_name(d.steps.front().effect);
  flag_ill_conditioned(d);
  d.fits_run = dg.fits_run();
  d.elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return d;
}

}  // namespace indicial
