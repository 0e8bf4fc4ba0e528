// diagnose.cpp -- the missing-effect workflow (see diagnose.hpp): candidate extensions of the
// model, each fitted by fit_experiment from the current estimates, scored by a likelihood-ratio
// test with a Bonferroni guard and BIC; the most significant added, repeated.
#include "indicial/fitter/diagnose.hpp"

#include <boost/math/distributions/chi_squared.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <fmt/format.h>
#include <limits>
#include <map>

#include "diagnose_internal.hpp"
#include "fit_internal.hpp"
#include "indicial/fitter/error.hpp"
#include "indicial/fitter/io.hpp"

namespace indicial {

namespace fs = std::filesystem;

const char* diagnose_stop_name(DiagnoseStop s) {
  switch (s) {
    case DiagnoseStop::nothing_significant: return "nothing_significant";
    case DiagnoseStop::max_steps: return "max_steps";
  }
  return "?";
}

const char* candidate_status_name(CandidateStatus s) {
  switch (s) {
    case CandidateStatus::fitted: return "fitted";
    case CandidateStatus::fit_failed: return "fit_failed";
    case CandidateStatus::not_identifiable: return "not_identifiable";
  }
  return "?";
}

NoiseEstimate estimate_noise_level(const std::vector<RunSeries>& runs) {
  NoiseEstimate ne;
  double sum = 0.0;
  double count = 0.0;
  for (const RunSeries& r : runs) {
    const std::vector<double>& v = r.residual;
    double s = 0.0;
    double c = 0.0;
    for (std::size_t k = 1; k + 1 < v.size(); ++k) {
      const double d2 = v[k + 1] - 2.0 * v[k] + v[k - 1];
      s += d2 * d2;
      c += 1.0;
    }
    // Why: a run of fewer than 3 samples has no second difference; it gives NaN, not 0.
    ne.run_sigma.push_back(c > 0.0 ? std::sqrt(s / (6.0 * c)) : std::numeric_limits<double>::quiet_NaN());
    sum += s;
    count += c;
  }
  ne.sigma = count > 0.0 ? std::sqrt(sum / (6.0 * count)) : std::numeric_limits<double>::quiet_NaN();
  return ne;
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

struct Scored {
  CandidateScore score;
  FitResult fit;
  ModelConfig config;
  bool is_knot = false;
  double knot_rad = 0.0;
  SplineFamily family = SplineFamily::none;  // the spline of a knot (for refinement)
};

void score_against(CandidateScore& c, const FitResult& base, const FitResult& ext, std::size_t n) {
  const double N = static_cast<double>(n);
  const double s0 = base.fit_error;
  const double s1 = ext.fit_error;
  c.fit_error = s1;
  c.added_parameters = ext.output_error.n_parameters - base.output_error.n_parameters;
  // Why the clamp: the extended fit starts from the base estimates with the new terms at 0 (a
  // nested start), so s1 <= s0 up to the iteration's tolerance; a tiny negative LR is that
  // tolerance, not evidence.
  c.statistic = std::max(0.0, 2.0 * N * std::log(s0 / s1));
  const int dp = std::max(1, c.added_parameters);
  c.log10_p = chi2_log10_upper(c.statistic, dp);
  c.p_value = std::pow(10.0, c.log10_p);
  c.delta_bic = 2.0 * N * std::log(s1 / s0) + static_cast<double>(c.added_parameters) * std::log(N);
}

class Diagnoser {
 public:
  Diagnoser(const DiagnoseOptions& o, DiagnoseResult& d) : o_(o), d_(d) {}

  FitResult fit(const Experiment& e, const ModelConfig& m,
                const std::vector<std::pair<std::string, double>>& sv) {
    Experiment x = e;
    x.model = m;
    FitOptions fo = o_.fit;
    fo.start_values = sv;
    ++d_.fits_run;
    return fit_experiment(x, fo);
  }

  Scored evaluate(const Experiment& e, const CandidateSpec& c, const FitResult& base,
                  const std::map<std::string, double>& current) {
    Scored s;
    s.score.effect = c.effect;
    s.score.term = c.term;
    s.score.detail = c.detail;
    s.config = c.config;
    s.is_knot = c.is_knot;
    s.knot_rad = c.knot_rad;
    s.family = c.family;
    s.score.status = CandidateStatus::fit_failed;
    bool have = false;
    std::string last_message;
    const std::vector<std::vector<std::pair<std::string, double>>> starts =
        c.starts.empty() ? std::vector<std::vector<std::pair<std::string, double>>>{{}} : c.starts;
    for (const auto& extra : starts) {
      try {
        FitResult r = fit(e, c.config, start_values_for(c.config, current, e.runs.size(), extra));
        const Termination t = r.output_error.termination;
        if (!std::isfinite(r.fit_error)) {
          last_message = r.output_error.message;
          continue;
        }
        // Why: a rank-deficient extension has a direction the data do not determine; its cost
        // is not evidence for the effect.
        if (t == Termination::rank_deficient) {
          if (!have) {
            s.score.status = CandidateStatus::not_identifiable;
            last_message = r.output_error.message;
          }
          continue;
        }
        if (!have || r.fit_error < s.fit.fit_error) {
          s.fit = std::move(r);
          have = true;
        }
      } catch (const InputError& err) {
        last_message = err.what();
      }
    }
    if (!have) {
      s.score.message = last_message;
      return s;
    }
    s.score.status = CandidateStatus::fitted;
    score_against(s.score, base, s.fit, total_samples(e));
    // The detail of a delay or a second lag carries the estimate.
    for (const ParameterEstimate& p : s.fit.parameters) {
      if (c.effect == Effect::time_delay && p.name == "delay_s")
        s.score.detail = fmt::format("delay {:.4g} s", p.value);
      if (c.effect == Effect::second_lag && p.name == "b2_0")
        s.score.detail = fmt::format("b2 = {:.4g} 1/s", p.value) + s.score.detail;
      if (c.effect == Effect::second_lag && p.name == "c2")
        s.score.detail += fmt::format(", c2 = {:.4g}", p.value);
      if (c.effect == Effect::bias && p.name == "con")
        s.score.detail = fmt::format("con = {:.4g} 1/s", p.value);
    }
    // Why: a negative delay is a prediction, which the runtime refuses; it is no evidence of a
    // delay in the data (the fit is recorded but cannot win).
    if (c.effect == Effect::time_delay) {
      for (const ParameterEstimate& p : s.fit.parameters)
        if (p.name == "delay_s" && !(p.value > 0.0)) {
          s.score.status = CandidateStatus::fit_failed;
          s.score.message = "the delay estimate is not positive";
        }
    }
    return s;
  }

 private:
  const DiagnoseOptions& o_;
  DiagnoseResult& d_;
};

// The working configuration: a stepwise structure is frozen at the selected terms, an
// estimated C_aq at its estimate (diagnose.hpp warning 4).
Experiment working_experiment(const Experiment& e, const FitResult& first) {
  Experiment w = e;
  if (e.model.structure == StructureMode::stepwise) {
    fit_detail::UnsteadyStructure pool = fit_detail::structure_from_config(e.model);
    std::vector<std::string> names;
    for (const ParameterEstimate& p : first.parameters) names.push_back(p.name);
    const fit_detail::UnsteadyStructure s = fit_detail::select_terms(pool, names);
    w.model.a.powers = s.a.powers;
    w.model.a.knots_rad = s.a.knots_rad;
    w.model.b1.powers = s.b1.powers;
    w.model.b1.knots_rad = s.b1.knots_rad;
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

DiagnoseResult diagnose_experiment(const Experiment& e_in, const DiagnoseOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  if (!(o.alpha > 0.0 && o.alpha < 1.0))
    throw InputError("--alpha", 0, "the significance level must be in (0, 1)");
  DiagnoseResult d;
  d.alpha = o.alpha;
  Diagnoser dg(o, d);

  Experiment e = e_in;
  // Why: the knot grid needs the model-angle range; an Experiment built in memory may not
  // carry it (load_experiment fills it).
  if (!(e.data_x_max_rad > e.data_x_min_rad)) {
    const ModelSet<double, FitCapacity> b = base_model_set(e);
    e.data_x_min_rad = b.x_min_rad;
    e.data_x_max_rad = b.x_max_rad;
  }
  FitResult first = dg.fit(e, e.model, {});
  const bool frozen = e.model.structure == StructureMode::stepwise || e.rotary.estimate;
  Experiment w = working_experiment(e, first);
  if (frozen) {
    // Refit the frozen configuration from the first fit's estimates (same model, fixed form).
    std::map<std::string, double> cur = keyed_estimates(w.model, first);
    for (const ParameterEstimate& p : first.parameters) cur[p.name] = p.value;
    first = dg.fit(w, w.model, start_values_for(w.model, cur, w.runs.size(), {}));
  }
  d.experiment = w;
  d.fits.push_back(first);
  d.configs.push_back(w.model);
  d.initial_fit_error = first.fit_error;
  d.noise = estimate_noise_level(first.runs);

  for (int round = 1; round <= o.max_steps; ++round) {
    const FitResult& base = d.fits.back();
    const ModelConfig& m = d.configs.back();
    const std::map<std::string, double> current = keyed_estimates(m, base);
    double spacing = o.knot_spacing_deg * kDegToRad;
    const std::vector<double> grid = knot_grid(w, o, spacing);
    const std::vector<CandidateSpec> specs = all_candidates(CandidateContext{w, m, base, grid, spacing});
    DiagnoseRound rd;
    rd.round = round;
    rd.base_fit_error = base.fit_error;
    std::vector<Scored> scored;
    for (const CandidateSpec& c : specs) scored.push_back(dg.evaluate(w, c, base, current));
    int tested = static_cast<int>(specs.size());
    auto best_index = [&]() {
      int b = -1;
      for (std::size_t i = 0; i < scored.size(); ++i) {
        if (scored[i].score.status != CandidateStatus::fitted) continue;
        if (b < 0 || scored[i].score.log10_p < scored[static_cast<std::size_t>(b)].score.log10_p)
          b = static_cast<int>(i);
      }
      return b;
    };
    int b = best_index();
    // A winning knot is refined between its grid neighbours (+-1/4 and +-1/2 spacing); these
    // positions are counted in the Bonferroni M like the grid's.
    if (b >= 0 && scored[static_cast<std::size_t>(b)].is_knot) {
      const Scored& win = scored[static_cast<std::size_t>(b)];
      const SplineFamily family = win.family;
      const Effect effect = win.score.effect;
      const double k0 = win.knot_rad;
      for (double f : {-0.5, -0.25, 0.25, 0.5}) {
        const double k = k0 + f * spacing;
        if (!(k > w.data_x_min_rad && k < w.data_x_max_rad)) continue;
        const SplineConfig& sp = family_spline(m, family);
        if (has_knot(sp.knots_rad, k, 0.2 * spacing)) continue;
        scored.push_back(dg.evaluate(w, knot_candidate(m, effect, family, k), base, current));
        ++tested;
      }
      b = best_index();
    }
    rd.candidates_tested = tested;
    rd.threshold = o.alpha / static_cast<double>(std::max(1, tested));
    for (const Scored& s : scored) rd.candidates.push_back(s.score);
    rd.best = b;
    bool add = false;
    if (b >= 0) {
      const CandidateScore& c = scored[static_cast<std::size_t>(b)].score;
      // Why both: the Bonferroni-guarded LR test controls false positives; BIC (penalty
      // ln N per parameter) additionally refuses an effect too small to pay for itself.
      add = c.log10_p < std::log10(rd.threshold) && c.delta_bic < 0.0;
    }
    rd.added = add;
    d.rounds.push_back(rd);
    if (!add) break;
    Scored& win = scored[static_cast<std::size_t>(b)];
    DiagnoseStep st;
    st.step = round;
    st.effect = win.score.effect;
    st.detail = win.score.detail;
    st.term = win.score.term;
    st.statistic = win.score.statistic;
    st.p_value = win.score.p_value;
    st.log10_p = win.score.log10_p;
    st.threshold = rd.threshold;
    st.candidates_tested = tested;
    st.added_parameters = win.score.added_parameters;
    st.delta_bic = win.score.delta_bic;
    st.fit_error_before = base.fit_error;
    st.fit_error_after = win.fit.fit_error;
    st.run_rms_before = run_rms(base);
    st.run_rms_after = run_rms(win.fit);
    d.steps.push_back(st);
    d.effects_added.push_back(effect_name(st.effect));
    d.configs.push_back(win.config);
    d.fits.push_back(std::move(win.fit));
    if (round == o.max_steps) d.stopped = DiagnoseStop::max_steps;
  }
  d.final_fit_error = d.fits.back().fit_error;
  d.final_noise = estimate_noise_level(d.fits.back().runs);
  d.verdict = d.steps.empty() ? "none" : effect_name(d.steps.front().effect);
  d.elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return d;
}

}  // namespace indicial
