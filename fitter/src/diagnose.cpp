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

#include "fit_internal.hpp"
#include "indicial/fitter/error.hpp"
#include "indicial/fitter/io.hpp"

namespace indicial {

namespace fs = std::filesystem;

const char* effect_name(Effect e) {
  switch (e) {
    case Effect::b1_alpha: return "b1_alpha";
    case Effect::a_alpha: return "a_alpha";
    case Effect::rotary_alpha: return "rotary_alpha";
    case Effect::bias: return "bias";
    case Effect::time_delay: return "time_delay";
    case Effect::second_lag: return "second_lag";
    case Effect::static_error: return "static_error";
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

using Term = ParamId;  // issue 11: fit_detail's terms are ParamIds now
constexpr double kRadToDeg = 180.0 / M_PI;
constexpr double kDegToRad = M_PI / 180.0;

// ------------------------------------------------------------------------------------------
// Parameters by identity: knots are renumbered when one is inserted (A{j}, B{j} ascending), so
// start values are carried from fit to fit by what a parameter IS (kind, lag, power, knot),
// not by its name.
// ------------------------------------------------------------------------------------------
std::string term_key(const Term& t) {
  return fmt::format("{}:{}:{}:{:.12g}", static_cast<int>(t.kind), t.lag, t.power, t.knot_rad);
}

// (name, key) of every structural and output parameter of a configuration.
std::vector<std::pair<std::string, std::string>> parameter_keys(const ModelConfig& m) {
  const fit_detail::UnsteadyStructure s = fit_detail::structure_from_config(m);
  std::vector<std::pair<std::string, std::string>> out;
  for (const Term& t : fit_detail::structural_terms(s)) out.emplace_back(parameter_name(t), term_key(t));
  for (const Term& t : fit_detail::rotary_terms(s.rotary)) out.emplace_back(parameter_name(t), term_key(t));
  for (const Term& t : fit_detail::static_corr_terms(s.static_corr))
    out.emplace_back(parameter_name(t), term_key(t));
  return out;
}

// Estimates of a fit keyed by identity (y0 names are their own keys).
std::map<std::string, double> keyed_estimates(const ModelConfig& m, const FitResult& r) {
  std::map<std::string, double> by_name;
  for (const ParameterEstimate& p : r.parameters) by_name[p.name] = p.value;
  std::map<std::string, double> out;
  for (const auto& [name, key] : parameter_keys(m)) {
    const auto it = by_name.find(name);
    if (it != by_name.end()) out[key] = it->second;
  }
  for (const ParameterEstimate& p : r.parameters)
    if (p.name.rfind("y0_", 0) == 0) out[p.name] = p.value;
  return out;
}

std::vector<std::pair<std::string, double>> start_values_for(
    const ModelConfig& m, const std::map<std::string, double>& current, std::size_t n_runs,
    const std::vector<std::pair<std::string, double>>& extra) {
  std::vector<std::pair<std::string, double>> sv;
  for (const auto& [name, key] : parameter_keys(m)) {
    const auto it = current.find(key);
    if (it != current.end()) sv.emplace_back(name, it->second);
  }
  for (std::size_t r = 1; r <= n_runs; ++r) {
    for (int j = 1; j <= m.lags; ++j) {
      const std::string n = j == 1 ? fmt::format("y0_{}", r) : fmt::format("y0_{}_{}", r, j);
      const auto it = current.find(n);
      if (it != current.end()) sv.emplace_back(n, it->second);
    }
  }
  for (const auto& e : extra) {
    bool replaced = false;
    for (auto& s : sv)
      if (s.first == e.first) {
        s.second = e.second;
        replaced = true;
      }
    if (!replaced) sv.push_back(e);
  }
  return sv;
}

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
  int family_kind = 0;  // which knot family (for refinement)
};

std::size_t total_samples(const Experiment& e) {
  std::size_t n = 0;
  for (const Run& r : e.runs) n += r.size();
  return n;
}

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

// One candidate: configuration and its start values (several starts: the best fit is kept;
// the starts are one model, one test).
struct CandidateSpec {
  Effect effect = Effect::bias;
  std::string term;
  std::string detail;
  ModelConfig config;
  std::vector<std::vector<std::pair<std::string, double>>> starts;  // extra start values
  bool is_knot = false;
  double knot_rad = 0.0;
  int family_kind = 0;
};

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
    s.family_kind = c.family_kind;
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

bool has_knot(const std::vector<double>& knots, double k, double min_gap) {
  for (double q : knots)
    if (std::abs(q - k) < min_gap) return true;
  return false;
}

int max_power(const std::vector<int>& p) {
  int m = -1;
  for (int i : p) m = std::max(m, i);
  return m;
}

bool has_power(const std::vector<int>& p, int i) {
  return std::find(p.begin(), p.end(), i) != p.end();
}

enum KnotFamily { kB1 = 1, kA = 2, kRotary = 3, kStatic = 4 };

SplineConfig& family_spline(ModelConfig& m, int family) {
  switch (family) {
    case kB1: return m.b1;
    case kA: return m.a;
    case kRotary: return m.rotary_correction;
    default: return m.static_correction;
  }
}

const SplineConfig& family_spline(const ModelConfig& m, int family) {
  return family_spline(const_cast<ModelConfig&>(m), family);  // read-only view of the same
}

const char* family_knot_label(int family) {
  switch (family) {
    case kB1: return "b1(x) knot (x - k)_+";
    case kA: return "a(x) knot (x - k)_+^2";
    case kRotary: return "C_aq(x) knot (x - k)_+";
    default: return "dC_a(x) knot (x - k)_+^2";
  }
}

CandidateSpec knot_candidate(const ModelConfig& m, Effect effect, int family, double k) {
  CandidateSpec c;
  c.effect = effect;
  c.config = m;
  SplineConfig& sp = family_spline(c.config, family);
  sp.knots_rad.push_back(k);
  std::sort(sp.knots_rad.begin(), sp.knots_rad.end());
  c.term = fmt::format("{} at {:.2f} deg", family_knot_label(family), k * kRadToDeg);
  c.detail = fmt::format("knot {:.2f} deg", k * kRadToDeg);
  c.is_knot = true;
  c.knot_rad = k;
  c.family_kind = family;
  return c;
}

CandidateSpec power_candidate(const ModelConfig& m, Effect effect, int family, int power,
                              const char* what) {
  CandidateSpec c;
  c.effect = effect;
  c.config = m;
  SplineConfig& sp = family_spline(c.config, family);
  sp.powers.push_back(power);
  std::sort(sp.powers.begin(), sp.powers.end());
  c.term = fmt::format("{} x^{}", what, power);
  c.detail = fmt::format("{} x^{} term", what, power);
  return c;
}

std::vector<double> knot_grid(const Experiment& e, const DiagnoseOptions& o, double& spacing) {
  const double lo = e.data_x_min_rad, hi = e.data_x_max_rad;
  const double range = hi - lo;
  std::vector<double> g;
  if (!(range > 0.0)) return g;
  const double a = lo + o.knot_margin_fraction * range;
  const double b = hi - o.knot_margin_fraction * range;
  spacing = std::max(1e-6, o.knot_spacing_deg * kDegToRad);
  // Why the widening: a wide range at a fine spacing would multiply the fits and the
  // Bonferroni count; past max_scan_knots the spacing grows instead.
  if ((b - a) / spacing + 1.0 > o.max_scan_knots && o.max_scan_knots > 1)
    spacing = (b - a) / (o.max_scan_knots - 1);
  // Knots at multiples of the spacing (round degree values for the default grid).
  for (double k = std::ceil(a / spacing - 1e-9) * spacing; k <= b + 1e-12; k += spacing)
    g.push_back(k);
  return g;
}

std::vector<CandidateSpec> candidates(const Experiment& e, const ModelConfig& m,
                                      const FitResult& base, const DiagnoseOptions& o,
                                      double& spacing) {
  using Cap = FitCapacity;
  std::vector<CandidateSpec> out;
  const std::vector<double> grid = knot_grid(e, o, spacing);
  const double gap = 0.5 * spacing;
  auto add_knots = [&](Effect effect, int family) {
    const SplineConfig& sp = family_spline(m, family);
    if (static_cast<int>(sp.knots_rad.size()) >= DefaultCapacity::max_knots) return;
    for (double k : grid)
      if (!has_knot(sp.knots_rad, k, gap)) out.push_back(knot_candidate(m, effect, family, k));
  };
  // b1_alpha: next power of b1(x), knots.
  {
    const int p = max_power(m.b1.powers) + 1;
    if (p < DefaultCapacity::max_powers) out.push_back(power_candidate(m, Effect::b1_alpha, kB1, p, "b1(x)"));
    add_knots(Effect::b1_alpha, kB1);
  }
  // a_alpha: next power of a(x), knots.
  {
    const int p = max_power(m.a.powers) + 1;
    if (p < DefaultCapacity::max_powers) out.push_back(power_candidate(m, Effect::a_alpha, kA, p, "a(x)"));
    add_knots(Effect::a_alpha, kA);
  }
  // rotary_alpha: C_aq correction powers 0..max(a priori degree, 2) + 1, knots.
  {
    const int top = std::max(2, static_cast<int>(e.rotary.polynomial.size()) - 1) + 1;
    for (int p = 0; p <= top && p < DefaultCapacity::max_powers; ++p)
      if (!has_power(m.rotary_correction.powers, p))
        out.push_back(power_candidate(m, Effect::rotary_alpha, kRotary, p, "C_aq(x)"));
    add_knots(Effect::rotary_alpha, kRotary);
  }
  // bias.
  if (!m.bias) {
    CandidateSpec c;
    c.effect = Effect::bias;
    c.config = m;
    c.config.bias = true;
    c.term = "con";
    c.detail = "con";
    out.push_back(c);
  }
  // time_delay: two starts, at 0 (nested: the right-hand sensitivity moves it) and 4 steps.
  if (m.delay == DelayEstimation::none) {
    CandidateSpec c;
    c.effect = Effect::time_delay;
    c.config = m;
    c.config.delay = DelayEstimation::estimated;
    c.config.delay_start_s = 0.0;
    c.term = "delay_s";
    c.detail = "delay";
    const double dt = e.runs.empty() ? 0.01 : e.runs.front().dt_s();
    c.starts = {{{"delay_s", 0.0}}, {{"delay_s", 4.0 * dt}}};
    out.push_back(c);
  }
  // second_lag: b2 started slower, faster and much faster than b1.
  if (m.lags == 1 && DefaultCapacity::max_lags >= 2 && Cap::max_lags >= 2) {
    double b1_0 = 1.0;
    for (const ParameterEstimate& p : base.parameters)
      if (p.name == "b1_0") b1_0 = std::abs(p.value);
    if (!(b1_0 > 0.0)) b1_0 = 1.0;
    CandidateSpec c;
    c.effect = Effect::second_lag;
    c.config = m;
    c.config.lags = 2;
    c.config.further_lag_start = LagStart::at_rest;
    c.term = "b2_0, c2";
    c.detail = "";
    for (double f : {0.3, 4.0, 15.0}) c.starts.push_back({{"b2_0", f * b1_0}, {"c2", 0.1}});
    out.push_back(c);
  }
  // static_error: x^1..x^3 and knots (no x^0: see the header).
  {
    for (int p = 1; p <= 3; ++p)
      if (!has_power(m.static_correction.powers, p))
        out.push_back(power_candidate(m, Effect::static_error, kStatic, p, "dC_a(x)"));
    add_knots(Effect::static_error, kStatic);
  }
  return out;
}

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
    const std::vector<CandidateSpec> specs = candidates(w, m, base, o, spacing);
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
      const int family = win.family_kind;
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
  }
  d.final_fit_error = d.fits.back().fit_error;
  d.final_noise = estimate_noise_level(d.fits.back().runs);
  d.verdict = d.steps.empty() ? "none" : effect_name(d.steps.front().effect);
  d.elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return d;
}

// ==========================================================================================
// Outputs
// ==========================================================================================
namespace {

nlohmann::json candidate_json(const CandidateScore& c) {
  nlohmann::json j;
  j["effect"] = effect_name(c.effect);
  j["term"] = c.term;
  j["detail"] = c.detail;
  j["status"] = candidate_status_name(c.status);
  if (c.status == CandidateStatus::fitted) {
    j["added_parameters"] = c.added_parameters;
    j["fit_error"] = finite_or_null(c.fit_error);
    j["statistic"] = finite_or_null(c.statistic);
    j["p_value"] = c.p_value;
    j["log10_p_value"] = finite_or_null(c.log10_p);
    j["delta_bic"] = finite_or_null(c.delta_bic);
  } else {
    j["message"] = c.message;
  }
  return j;
}

std::string num(double v) { return std::isfinite(v) ? fmt::format("{:.4g}", v) : std::string("-"); }

std::string pval(double p, double log10p) {
  if (p > 0.0 && p >= 1e-300) return fmt::format("{:.3g}", p);
  return fmt::format("1e{:.0f}", std::floor(log10p));
}

// Residuals against time (one panel per run) and against the model angle, before and after
// each step (or of the configured model when there is no step). Same conventions as the fit
// report (run_gnuplot_script): plots/plots.gp and its data files stay beside the images.
PlotSet make_plots(const DiagnoseResult& d, const OutputDir& out, const ReportOptions& ro) {
  if (ro.plots == PlotRequest::none) {
    PlotSet ps;
    ps.message = "plots not requested";
    return ps;
  }
  for (std::size_t f = 0; f < d.fits.size(); ++f) {
    for (std::size_t r = 0; r < d.fits[f].runs.size(); ++r) {
      const RunSeries& s = d.fits[f].runs[r];
      std::string t = "# time_s x_deg residual\n";
      for (std::size_t i = 0; i < s.residual.size(); ++i)
        t += fmt::format("{:.6g} {:.6g} {:.6g}\n", s.time_s[i], s.x_rad[i] * kRadToDeg, s.residual[i]);
      out.write(fmt::format("plots/fit{}_run{}.dat", f, r + 1), t);
    }
  }
  const std::size_t n_runs = d.fits.front().runs.size();
  std::string gp = "# gnuplot script written by indicial diagnose; run `gnuplot plots.gp` here.\n";
  std::vector<std::string> expected;
  auto pair_plots = [&](std::size_t before, std::size_t after, const std::string& stem,
                        const std::string& title) {
    const bool two = before != after;
    const std::string png_t = stem + "_time.png";
    gp += fmt::format("set terminal pngcairo size 1000,{} noenhanced\nset output '{}'\n",
                      std::max<std::size_t>(300, 230 * n_runs), png_t);
    gp += fmt::format("set multiplot layout {},1 title '{}: residual (measured - model) against time'\n",
                      n_runs, title);
    for (std::size_t r = 1; r <= n_runs; ++r) {
      gp += fmt::format("set xlabel 'time (s)'\nset ylabel 'run {}'\nset grid\n", r);
      if (two)
        gp += fmt::format("plot 'fit{}_run{}.dat' u 1:3 w l lc rgb '#bbbbbb' title 'before', "
                          "'fit{}_run{}.dat' u 1:3 w l lc rgb '#08519c' title 'after'\n",
                          before, r, after, r);
      else
        gp += fmt::format("plot 'fit{}_run{}.dat' u 1:3 w l lc rgb '#08519c' title 'configured model'\n",
                          after, r);
    }
    gp += "unset multiplot\nset output\n";
    expected.push_back(png_t);
    const std::string png_a = stem + "_angle.png";
    gp += fmt::format("set terminal pngcairo size 1000,450 noenhanced\nset output '{}'\n", png_a);
    gp += fmt::format("set title '{}: residual against the model angle'\nset xlabel 'x (deg)'\n"
                      "set ylabel 'residual'\nset grid\nplot ", title);
    std::string items;
    for (std::size_t r = 1; r <= n_runs; ++r) {
      if (two)
        items += fmt::format("{}'fit{}_run{}.dat' u 2:3 w p pt 7 ps 0.3 lc rgb '#bbbbbb' title '{}'",
                             items.empty() ? "" : ", ", before, r, r == 1 ? "before" : "");
    }
    for (std::size_t r = 1; r <= n_runs; ++r)
      items += fmt::format("{}'fit{}_run{}.dat' u 2:3 w p pt 7 ps 0.3 lc rgb '#08519c' title '{}'",
                           items.empty() ? "" : ", ", after, r,
                           r == 1 ? (two ? "after" : "configured model") : "");
    gp += items + "\nunset title\nset output\n";
    expected.push_back(png_a);
  };
  if (d.steps.empty()) {
    pair_plots(0, 0, "initial", "configured model");
  } else {
    for (std::size_t k = 1; k <= d.steps.size(); ++k)
      pair_plots(k - 1, k, fmt::format("step{}", k),
                 fmt::format("step {}: {} ({})", k, effect_name(d.steps[k - 1].effect),
                             d.steps[k - 1].detail));
  }
  return run_gnuplot_script(out, gp, expected, ro);
}

std::string rms_list(const std::vector<double>& v) {
  std::string s;
  for (double x : v) s += (s.empty() ? "" : ", ") + num(x);
  return s;
}

std::string report_markdown(const DiagnoseResult& d, const Experiment& e, const DiagnoseOptions& o,
                            const RuntimeCheck& rc, const PlotSet& ps, const ReportOptions& ro) {
  std::string md;
  md += "# indicial diagnose\n\n";
  if (!ro.command_line.empty()) md += "`" + ro.command_line + "`\n\n";
  md += fmt::format("Experiment `{}`: {} of {} axis, {} runs, {} samples.\n\n",
                    ro.experiment_display.empty() ? e.path : ro.experiment_display, e.coefficient,
                    axis_name(e.axis), e.runs.size(), total_samples(e));
  md += fmt::format("**Verdict: `{}`**", d.verdict);
  if (d.effects_added.size() > 1) {
    std::string l;
    for (const auto& s : d.effects_added) l += (l.empty() ? "" : ", ") + s;
    md += fmt::format(" (effects added in order: {})", l);
  }
  md += "\n\n";
  md += fmt::format("| | value |\n|---|---|\n| initial fit error s(v) | {} |\n| noise estimate (initial "
                    "residuals) | {} |\n| final fit error | {} |\n| noise estimate (final residuals) | {} |\n"
                    "| fits run | {} |\n| elapsed | {:.2f} s |\n\n",
                    num(d.initial_fit_error), num(d.noise.sigma), num(d.final_fit_error),
                    num(d.final_noise.sigma), d.fits_run, d.elapsed_s);
  md += "The noise estimate is sqrt(mean (second difference of the residual)^2 / 6): white noise "
        "passes the second difference with variance 6 sigma^2, a smooth model error is filtered "
        "out. When the fit error is well above it, the model is missing something.\n\n";
  md += "## Steps\n\n";
  if (d.steps.empty()) {
    md += "No candidate effect is significant: the model is left as configured (verdict `none`).\n\n";
  } else {
    md += "| step | effect | detail | LR statistic | dp | p-value | threshold alpha/M (M) | delta BIC | "
          "fit error before | after | run RMS before | run RMS after |\n"
          "|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (const DiagnoseStep& s : d.steps)
      md += fmt::format("| {} | `{}` | {} | {:.1f} | {} | {} | {:.3g} ({}) | {:.1f} | {} | {} | {} | {} |\n",
                        s.step, effect_name(s.effect), s.detail, s.statistic, s.added_parameters,
                        pval(s.p_value, s.log10_p), s.threshold, s.candidates_tested, s.delta_bic,
                        num(s.fit_error_before), num(s.fit_error_after), rms_list(s.run_rms_before),
                        rms_list(s.run_rms_after));
    md += "\n";
  }
  md += fmt::format("Test: LR = N ln(s0^2/s1^2) against chi^2(dp) (Boost.Math), N = {} samples. An effect "
                    "enters when p < alpha / M (Bonferroni, alpha = {}, M = every candidate model of the "
                    "round, each scanned knot position counted) and delta BIC = N ln(s1^2/s0^2) + dp ln N "
                    "< 0. Knot grid: every {:.2f} deg inside the data's angle range.\n\n",
                    total_samples(e), o.alpha, o.knot_spacing_deg);
  md += "## Plots\n\n";
  if (ps.images.empty()) md += ps.message + "\n\n";
  for (const std::string& img : ps.images) md += fmt::format("![{}]({})\n\n", img, img);
  md += "## Candidates per round (best of each effect)\n\n";
  for (const DiagnoseRound& r : d.rounds) {
    md += fmt::format("### Round {} (base fit error {}, M = {}, threshold {:.3g}){}\n\n", r.round,
                      num(r.base_fit_error), r.candidates_tested, r.threshold,
                      r.added ? "" : ": nothing significant");
    md += "| effect | best term | LR | dp | p-value | delta BIC | fit error | candidates |\n|---|---|---|---|---|---|---|---|\n";
    for (int k = 0; k < effect_count; ++k) {
      const Effect ef = static_cast<Effect>(k);
      int best = -1, count = 0;
      for (std::size_t i = 0; i < r.candidates.size(); ++i) {
        const CandidateScore& c = r.candidates[i];
        if (c.effect != ef) continue;
        ++count;
        if (c.status != CandidateStatus::fitted) continue;
        if (best < 0 || c.log10_p < r.candidates[static_cast<std::size_t>(best)].log10_p)
          best = static_cast<int>(i);
      }
      if (count == 0) continue;
      if (best < 0) {
        md += fmt::format("| `{}` | (no fit) | | | | | | {} |\n", effect_name(ef), count);
        continue;
      }
      const CandidateScore& c = r.candidates[static_cast<std::size_t>(best)];
      md += fmt::format("| `{}` | {} | {:.1f} | {} | {} | {:.1f} | {} | {} |\n", effect_name(ef),
                        c.detail.empty() ? c.term : c.detail, c.statistic, c.added_parameters,
                        pval(c.p_value, c.log10_p), c.delta_bic, num(c.fit_error), count);
    }
    md += "\n";
  }
  md += "## Final model\n\n```\n" + estimates_text_table(d.fits.back().parameters) + "```\n\n";
  md += fmt::format("model.coef: runtime {}{}; replay max |runtime - fitter| = {:.3g} over {} samples.\n",
                    runtime_fit_name(rc.fit), rc.detail.empty() ? "" : " (" + rc.detail + ")",
                    rc.max_abs_difference, rc.samples_compared);
  return md;
}

}  // namespace

nlohmann::json diagnosis_json(const DiagnoseResult& d, const Experiment& e, const DiagnoseOptions& o,
                              const RuntimeCheck* runtime) {
  nlohmann::json j;
  j["initial_fit_error"] = finite_or_null(d.initial_fit_error);
  j["noise_estimate"] = finite_or_null(d.noise.sigma);
  nlohmann::json steps = nlohmann::json::array();
  for (const DiagnoseStep& s : d.steps) {
    nlohmann::json k;
    k["effect"] = effect_name(s.effect);
    k["detail"] = s.detail;
    k["statistic"] = finite_or_null(s.statistic);
    k["p_value"] = s.p_value;
    k["log10_p_value"] = finite_or_null(s.log10_p);
    k["threshold"] = s.threshold;
    k["candidates_tested"] = s.candidates_tested;
    k["added_parameters"] = s.added_parameters;
    k["delta_bic"] = finite_or_null(s.delta_bic);
    k["term"] = s.term;
    k["fit_error_before"] = finite_or_null(s.fit_error_before);
    k["fit_error_after"] = finite_or_null(s.fit_error_after);
    nlohmann::json rb = nlohmann::json::array(), ra = nlohmann::json::array();
    for (double v : s.run_rms_before) rb.push_back(finite_or_null(v));
    for (double v : s.run_rms_after) ra.push_back(finite_or_null(v));
    k["run_rms_before"] = rb;
    k["run_rms_after"] = ra;
    steps.push_back(k);
  }
  j["steps"] = steps;
  j["final_fit_error"] = finite_or_null(d.final_fit_error);
  j["verdict"] = d.verdict;
  j["effects_added"] = d.effects_added;
  j["alpha"] = o.alpha;
  j["test"] = "likelihood ratio N ln(s0^2/s1^2) ~ chi2(dp); Bonferroni alpha/M per round; delta BIC < 0";
  j["noise_estimate_method"] = "second difference of the residual: sqrt(sum d2^2 / (6 n))";
  nlohmann::json rn = nlohmann::json::array();
  for (double v : d.noise.run_sigma) rn.push_back(finite_or_null(v));
  j["noise_estimate_per_run"] = rn;
  j["final_noise_estimate"] = finite_or_null(d.final_noise.sigma);
  j["samples"] = total_samples(e);
  nlohmann::json rounds = nlohmann::json::array();
  for (const DiagnoseRound& r : d.rounds) {
    nlohmann::json k;
    k["round"] = r.round;
    k["base_fit_error"] = finite_or_null(r.base_fit_error);
    k["candidates_tested"] = r.candidates_tested;
    k["threshold"] = r.threshold;
    k["added"] = r.added;
    nlohmann::json cs = nlohmann::json::array();
    for (const CandidateScore& c : r.candidates) cs.push_back(candidate_json(c));
    k["candidates"] = cs;
    rounds.push_back(k);
  }
  j["rounds"] = rounds;
  nlohmann::json params = nlohmann::json::array();
  for (const ParameterEstimate& p : d.fits.back().parameters) {
    nlohmann::json q;
    q["name"] = p.name;
    q["value"] = p.value;
    q["cr_bound"] = finite_or_null(p.cr_bound);
    params.push_back(q);
  }
  j["final_parameters"] = params;
  j["fits_run"] = d.fits_run;
  j["elapsed_s"] = d.elapsed_s;
  if (runtime) {
    nlohmann::json r;
    r["fit"] = runtime_fit_name(runtime->fit);
    r["detail"] = runtime->detail;
    r["max_abs_difference"] = finite_or_null(runtime->max_abs_difference);
    r["samples_compared"] = runtime->samples_compared;
    j["runtime_check"] = r;
  }
  return j;
}

std::string diagnosed_experiment_toml(const DiagnoseResult& d) {
  Experiment next = d.experiment;
  next.model = d.configs.back();
  // Absolute paths: the file is read from DIR, not from where the original experiment was.
  std::error_code ec;
  for (Run& r : next.runs) r.path = fs::absolute(r.path, ec).string();
  if (next.static_curve.kind == StaticKind::table)
    next.static_curve.table_path = fs::absolute(next.static_curve.table_path, ec).string();
  // Why the start value: a delay is a non-convex parameter (diagnose fits it from two starts);
  // the refit starts from the diagnosed estimate instead of 0.
  if (next.model.delay == DelayEstimation::estimated) {
    for (const ParameterEstimate& p : d.fits.back().parameters)
      if (p.name == "delay_s" && std::isfinite(p.value)) next.model.delay_start_s = std::clamp(p.value, 0.0, 1.0);
  }
  std::string added;
  for (const std::string& x : d.effects_added) added += (added.empty() ? "" : ", ") + x;
  const std::vector<std::string> comments = {
      "written by indicial diagnose: the experiment with the diagnosed model structure",
      "(effects added: " + (added.empty() ? std::string("none") : added) +
          "); refit it with: indicial fit experiment.toml --out DIR"};
  return write_experiment_toml(next, comments);
}

DiagnoseOutputs write_diagnose_outputs(const DiagnoseResult& d, const Experiment& e,
                                       const DiagnoseOptions& o, const fs::path& dir,
                                       Overwrite overwrite, const ReportOptions& ro) {
  OutputDir out(dir, overwrite);
  DiagnoseOutputs w;
  w.dir = dir;
  const FitResult& final_fit = d.fits.back();
  w.model_coef = model_coef_text(final_fit, "model.coef");
  w.runtime = replay_in_runtime(final_fit, d.experiment, w.model_coef);
  w.diagnosis_json = diagnosis_json(d, e, o, &w.runtime).dump(2) + "\n";
  const PlotSet ps = make_plots(d, out, ro);
  w.plots = ps.status;
  w.plot_message = ps.message;
  w.images = ps.images;
  w.report_md = report_markdown(d, e, o, w.runtime, ps, ro);
  w.experiment_toml = diagnosed_experiment_toml(d);
  out.write("diagnosis.json", w.diagnosis_json);
  out.write("experiment.toml", w.experiment_toml);
  out.write("model.coef", w.model_coef);
  out.write("report.md", w.report_md);
  out.commit();
  return w;
}

}  // namespace indicial
