// montecarlo.cpp -- repeat a simulated case over many noise seeds (see montecarlo.hpp).
#include "indicial/fitter/montecarlo.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <fmt/format.h>
#include <limits>
#include <mutex>
#include <thread>

#include "indicial/fitter/error.hpp"
#include "indicial/fitter/experiment_toml.hpp"
#include "indicial/fitter/report.hpp"
#include "indicial/fitter/runtime_limits.hpp"

namespace indicial {

Experiment experiment_from_simulation(const SimulationCase& c, const std::vector<SimulatedRun>& runs) {
  Experiment e = c.experiment;
  e.path = c.name + " (simulated)";
  e.runs.clear();
  for (std::size_t i = 0; i < runs.size(); ++i) {
    Run r;
    r.path = i < c.run_files.size() ? c.run_files[i] : fmt::format("run{}", i + 1);
    r.time_s = runs[i].time_s;
    r.motion_angle_rad = runs[i].motion_angle_rad;
    r.rate_radps = runs[i].rate_radps;
    r.rate_from_file = true;  // the simulator's rate is exact, as a measured rate column would be
    r.coefficient = runs[i].coefficient_measured.at(0);
    r.periodic = i < c.experiment.runs.size() && c.experiment.runs[i].periodic;
    // Run i is the simulation of motion i: the fit scales the model by its airspeed as the
    // simulator did (0: the experiment's).
    r.airspeed_mps = i < c.motions.size() ? c.motions[i].airspeed_mps : 0.0;
    e.runs.push_back(std::move(r));
  }
  set_data_range(e);
  return e;
}

namespace {

// The truth's coefficient of the knot term at knot_rad (0 where the truth has no such knot:
// a fitted knot of a larger pool).
template <class S>
double knot_truth(const S& truth, double knot_rad) {
  for (int k = 0; k < truth.n_knots; ++k)
    if (std::fabs(truth.knot_rad[k] - knot_rad) < 1e-9) return truth.knot_coef[k];
  return 0.0;
}

template <class S>
double power_truth(const S& truth, int i) {
  return i < truth.n_powers ? truth.power_coef[i] : 0.0;
}

}  // namespace

double true_parameter_value(const TruthModel& truth, const ParamId& id) {
  const auto& t = truth.coefficients[0];
  switch (id.kind) {
    case ParamKind::initial_state: return 0.0;  // the simulator starts every run at rest
    case ParamKind::con: return t.con;
    case ParamKind::a_power: return power_truth(t.a, id.power);
    case ParamKind::a_knot: return knot_truth(t.a, id.knot_rad);
    case ParamKind::b_power:
      return id.lag == 0 ? power_truth(t.lags[0].b, id.power) : std::numeric_limits<double>::quiet_NaN();
    case ParamKind::b_knot:
      return id.lag == 0 ? knot_truth(t.lags[0].b, id.knot_rad) : std::numeric_limits<double>::quiet_NaN();
    case ParamKind::rotary_power: return power_truth(t.rotary, id.power);
    case ParamKind::rotary_knot: return knot_truth(t.rotary, id.knot_rad);
    default: return std::numeric_limits<double>::quiet_NaN();
  }
}

double true_parameter_value(const TruthModel& truth, const ModelSet<double, FitCapacity>& fitted,
                            const std::string& name) {
  ParamId id;
  if (!parse_parameter_name(name, &id)) return std::numeric_limits<double>::quiet_NaN();
  // A knot named by its number is the fitted model's knot of that number.
  const auto& f = fitted.coefficients[0];
  const auto* sp = id.kind == ParamKind::a_knot                        ? &f.a
                   : id.kind == ParamKind::b_knot && id.lag == 0       ? &f.lags[0].b
                   : id.kind == ParamKind::rotary_knot                 ? &f.rotary
                                                                       : nullptr;
  if (sp != nullptr) {
    if (id.knot >= sp->n_knots) return std::numeric_limits<double>::quiet_NaN();
    id.knot_rad = sp->knot_rad[id.knot];
  }
  return true_parameter_value(truth, id);
}

namespace {

struct SeedOutcome {
  bool ok = false;
  std::string error;
  Termination termination = Termination::converged;
  double fit_error = 0.0;
  double seconds = 0.0;
  std::vector<ParameterEstimate> parameters;
  std::vector<double> truth;
};

// Seed k's noisy data, fit and runtime check (never throws: a failure is recorded).
SeedOutcome fit_one_seed(const SimulationCase& c, const std::vector<SimulatedRun>& clean, const MonteCarloOptions& o,
                         std::size_t k) {
  SeedOutcome out;
  const auto ts = std::chrono::steady_clock::now();
  try {
    std::vector<SimulatedRun> runs = clean;
    add_measurement_noise(runs, o.snr, o.first_seed + k, o.noise);
    const Experiment e = experiment_from_simulation(c, runs);
    const FitResult fr = fit_experiment(e, o.fit);
    // A model the runtime refuses is a failed fit: counted and named, never averaged in.
    require_runtime_accepts(fr.model, fmt::format("seed {}", o.first_seed + k), ModelFile::to_write);
    out.ok = true;
    out.termination = fr.output_error.termination;
    out.fit_error = fr.fit_error;
    out.parameters = fr.parameters;
    for (const ParameterEstimate& p : fr.parameters) out.truth.push_back(true_parameter_value(c.truth, p.id));
  } catch (const std::exception& ex) {
    out.ok = false;
    out.error = ex.what();
  }
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - ts).count();
  return out;
}

// Every seed's outcome, in seed order, fitted by o.threads threads taking the next seed.
std::vector<SeedOutcome> fit_all_seeds(const SimulationCase& c, const std::vector<SimulatedRun>& clean,
                                       const MonteCarloOptions& o, const MonteCarloProgress& progress) {
  const auto n = static_cast<std::size_t>(o.seeds);
  std::vector<SeedOutcome> outcomes(n);
  std::atomic<std::size_t> next{0};
  std::mutex progress_mutex;
  int done = 0;
  auto worker = [&]() {
    for (;;) {
      const std::size_t k = next.fetch_add(1);
      if (k >= n) return;
      outcomes[k] = fit_one_seed(c, clean, o, k);
      std::lock_guard<std::mutex> lock(progress_mutex);
      ++done;
      if (progress) progress(done, o.seeds);
    }
  };
  const int nt = std::min(o.threads, o.seeds);
  std::vector<std::thread> pool;
  for (int t = 1; t < nt; ++t) pool.emplace_back(worker);
  worker();
  for (std::thread& t : pool) t.join();
  return outcomes;
}

double mean_of(const std::vector<double>& v) {
  double s = 0.0;
  for (double x : v) s += x;
  return v.empty() ? std::numeric_limits<double>::quiet_NaN() : s / static_cast<double>(v.size());
}

// One parameter's statistics over the seeds.
struct ParameterSamples {
  double truth = std::numeric_limits<double>::quiet_NaN();
  std::vector<double> values, cr, crc;
};

MonteCarloParameter parameter_statistics(const std::string& name, const ParameterSamples& a) {
  MonteCarloParameter p;
  p.name = name;
  p.truth = a.truth;
  p.count = static_cast<int>(a.values.size());
  p.mean = mean_of(a.values);
  double ss = 0.0;
  for (double v : a.values) ss += (v - p.mean) * (v - p.mean);
  p.std_dev = p.count > 1 ? std::sqrt(ss / (p.count - 1)) : std::numeric_limits<double>::quiet_NaN();
  p.mean_cr_bound = mean_of(a.cr);
  p.mean_cr_bound_colored = mean_of(a.crc);
  p.ratio = p.std_dev / p.mean_cr_bound;
  p.ratio_colored = p.std_dev / p.mean_cr_bound_colored;
  p.bias_in_std_errors = (p.mean - p.truth) / (p.std_dev / std::sqrt(static_cast<double>(p.count)));
  return p;
}

// Failures, terminations, mean fit error and time, and per parameter (by name, in the order of
// the first successful fit) the statistics of the estimates and their bounds.
void aggregate(const std::vector<SeedOutcome>& outcomes, const MonteCarloOptions& o, MonteCarloResult& res) {
  std::vector<std::string> order;
  std::map<std::string, ParameterSamples> acc;
  double fit_error_sum = 0.0;
  double seconds_sum = 0.0;
  for (std::size_t k = 0; k < outcomes.size(); ++k) {
    const SeedOutcome& out = outcomes[k];
    seconds_sum += out.seconds;
    if (!out.ok) {
      res.failed_seeds.push_back(o.first_seed + k);
      res.failure_messages.push_back(out.error);
      continue;
    }
    ++res.fitted;
    ++res.terminations[termination_name(out.termination)];
    fit_error_sum += out.fit_error;
    for (std::size_t i = 0; i < out.parameters.size(); ++i) {
      const ParameterEstimate& p = out.parameters[i];
      // Why skip: an unidentifiable parameter has no bound; its value is arbitrary.
      if (p.identifiability != Identifiability::identified) continue;
      auto it = acc.find(p.name);
      if (it == acc.end()) {
        order.push_back(p.name);
        it = acc.emplace(p.name, ParameterSamples{}).first;
        it->second.truth = out.truth[i];
      }
      it->second.values.push_back(p.value);
      it->second.cr.push_back(p.cr_bound);
      it->second.crc.push_back(p.cr_bound_colored);
    }
  }
  res.mean_fit_error = res.fitted > 0 ? fit_error_sum / res.fitted : std::numeric_limits<double>::quiet_NaN();
  res.fit_seconds_mean = seconds_sum / static_cast<double>(outcomes.size());
  for (const std::string& name : order) res.parameters.push_back(parameter_statistics(name, acc[name]));
}

}  // namespace

MonteCarloResult run_monte_carlo(const MonteCarloOptions& o, const MonteCarloProgress& progress) {
  return run_monte_carlo(find_simulation_case(o.case_name), o, progress);
}

MonteCarloResult run_monte_carlo(const SimulationCase& c, const MonteCarloOptions& o,
                                 const MonteCarloProgress& progress) {
  if (o.seeds < 2) throw InputError("--seeds", 0, "at least 2 seeds are needed for a standard deviation");
  if (o.threads < 1) throw InputError("--threads", 0, "at least 1 thread");
  if (!(o.snr > 0.0) || !std::isfinite(o.snr))
    throw InputError("--snr", 0, "the Monte Carlo needs noise: a finite SNR > 0");
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<SimulatedRun> clean;
  for (const MotionSpec& m : c.motions) clean.push_back(simulate_reference(c.truth, m));

  MonteCarloResult res;
  res.options = o;
  res.options.case_name = c.name;
  {
    std::vector<SimulatedRun> probe = clean;
    const std::vector<double> sigma = add_measurement_noise(probe, o.snr, o.first_seed, o.noise);
    res.noise_sigma = sigma.empty() ? 0.0 : sigma[0];
  }
  aggregate(fit_all_seeds(c, clean, o, progress), o, res);
  res.elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return res;
}

nlohmann::json monte_carlo_json(const MonteCarloResult& r) {
  nlohmann::json j;
  j["case"] = r.options.case_name;
  j["snr"] = r.options.snr;
  j["seeds"] = r.options.seeds;
  j["first_seed"] = r.options.first_seed;
  j["threads"] = r.options.threads;
  j["noise"] = noise_spec_text(r.options.noise);
  j["noise_sigma"] = finite_or_null(r.noise_sigma);
  j["fitted"] = r.fitted;
  j["failed_seeds"] = r.failed_seeds;
  j["failure_messages"] = r.failure_messages;
  j["terminations"] = r.terminations;
  j["mean_fit_error"] = finite_or_null(r.mean_fit_error);
  j["parameters"] = nlohmann::json::array();
  for (const MonteCarloParameter& p : r.parameters) {
    j["parameters"].push_back({{"name", p.name},
                               {"truth", finite_or_null(p.truth)},
                               {"count", p.count},
                               {"mean", finite_or_null(p.mean)},
                               {"std", finite_or_null(p.std_dev)},
                               {"mean_cr_bound", finite_or_null(p.mean_cr_bound)},
                               {"mean_cr_bound_colored", finite_or_null(p.mean_cr_bound_colored)},
                               {"ratio_std_to_cr", finite_or_null(p.ratio)},
                               {"ratio_std_to_colored", finite_or_null(p.ratio_colored)},
                               {"bias_in_std_errors", finite_or_null(p.bias_in_std_errors)}});
  }
  j["elapsed_s"] = r.elapsed_s;
  j["fit_seconds_mean"] = r.fit_seconds_mean;
  return j;
}

std::string monte_carlo_markdown(const MonteCarloResult& r) {
  auto num = [](double v) { return std::isfinite(v) ? fmt::format("{:.6g}", v) : std::string("-"); };
  std::string m;
  m += fmt::format("# Monte Carlo: {} at SNR {}, {} seeds ({}..{})\n\n", r.options.case_name,
                   num(r.options.snr), r.options.seeds, r.options.first_seed,
                   r.options.first_seed + static_cast<std::uint64_t>(r.options.seeds) - 1);
  m += fmt::format("Gaussian noise `{}`, marginal sigma = {} (RMS of y over all runs / SNR). {} fits "
                   "returned, {} failed; {} threads, {:.1f} s wall, {:.3f} s per fit. Mean s(v) = {}.\n\n",
                   noise_spec_text(r.options.noise), num(r.noise_sigma), r.fitted, r.failed_seeds.size(), r.options.threads, r.elapsed_s,
                   r.fit_seconds_mean, num(r.mean_fit_error));
  m += "Terminations:";
  for (const auto& [name, count] : r.terminations) m += fmt::format(" {} {};", name, count);
  m += "\n\n";
  m += "std: empirical standard deviation of the estimates over the seeds. CR: mean Cramer-Rao "
       "bound. colored: mean colored-residual bound. A correct bound on white-noise data gives "
       "std / CR near 1. bias: (mean - truth) / (std / sqrt(count)).\n\n";
  m += "| parameter | truth | mean | std | mean CR | std / CR | mean colored | std / colored | bias | count |\n"
       "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const MonteCarloParameter& p : r.parameters) {
    m += fmt::format("| {} | {} | {} | {} | {} | {:.3f} | {} | {:.3f} | {:.2f} | {} |\n", p.name,
                     num(p.truth), num(p.mean), num(p.std_dev), num(p.mean_cr_bound), p.ratio,
                     num(p.mean_cr_bound_colored), p.ratio_colored, p.bias_in_std_errors, p.count);
  }
  if (!r.failed_seeds.empty()) {
    m += "\nFailed seeds:\n\n";
    for (std::size_t i = 0; i < r.failed_seeds.size(); ++i)
      m += fmt::format("* seed {}: {}\n", r.failed_seeds[i], r.failure_messages[i]);
  }
  return m;
}

}  // namespace indicial
