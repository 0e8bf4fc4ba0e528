// bench/bench_fitter.cpp -- how fast the fitter identifies, and how its cost grows.
//
// What it measures
// ----------------
//   fit/example1/...         fit_experiment (fitter/include/indicial/fitter/fit.hpp) on the
//                            built-in Example 1 case (tailless-model-1, SNR 40, seed 7: three
//                            runs of three cycles at 0.25/0.5/1 Hz, dt 0.01 s, 2100 samples),
//                            data simulated by the reference simulator (simulate.hpp) and held
//                            in memory (file I/O excluded):
//       fixed                the configured structure, no two-stage
//       full                 stepwise structure + ML + bounds + two-stage C_mq estimation from
//                            the wrong a priori C_mq = -1.4 (report Table IV set-up)
//   ml_iteration/n:N         time per Gauss-Newton/Levenberg-Marquardt iteration of the
//                            output-error step against the number of samples N (1e3 .. 1e6;
//                            one sine run, Model I structure, 6 + 1 parameters). Measured as
//                            T(1 iteration) - T(0 iterations) from the equation-error start
//                            (minimum of repeated totals): one Jacobian by forward autodiff
//                            through the propagation, the normal equations, and the trial
//                            propagation(s) of the damped step; set-up and the final
//                            covariance cancel in the difference, so fixed costs (set-up, final covariance) cancel; the
//                            benchmark's time IS the per-iteration time (manual timing).
//   ml_iteration/params:P    the same at N = 2e4 against the structural parameter count P
//                            (6, 8, 10, 12) on Model II data
//   montecarlo/threads:T     seeds per second of the fixed-structure Example 1 fit (new noise
//                            per seed, truth simulated once) on T = 1, 2 threads
// run_all.sh fits the slope of log(time per iteration) against log(N) (1 = linear growth).
//
// Warnings
// --------
// 1. ml_iteration uses the fitter's private interface (fitter/src/estimate/fit_internal.hpp:
//    prepare_runs, run_equation_error, fit_output_error) to time one stage in isolation.
// 2. The 1e6-sample case simulates 10^4 s of motion first (a few seconds, not timed).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <thread>
#include <vector>

#include "estimate/fit_internal.hpp"
#include "indicial/fitter/fit.hpp"
#include "indicial/fitter/simulate.hpp"

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// Experiment of a built-in case with its runs filled in memory from simulated data.
indicial::Experiment experiment_from(const indicial::SimulationCase& c,
                                     const std::vector<indicial::SimulatedRun>& sims,
                                     const std::vector<std::string>& paths) {
  indicial::Experiment e = c.experiment;
  e.path = "bench:" + c.name;
  e.runs.clear();
  for (std::size_t i = 0; i < sims.size(); ++i) {
    indicial::Run r;
    r.path = paths[i];
    r.time_s = sims[i].time_s;
    r.motion_angle_rad = sims[i].motion_angle_rad;
    r.rate_radps = sims[i].rate_radps;
    r.rate_from_file = true;
    r.coefficient = sims[i].coefficient_measured[0];
    e.runs.push_back(std::move(r));
  }
  return e;
}

std::vector<indicial::SimulatedRun> simulate_case(const indicial::SimulationCase& c) {
  std::vector<indicial::SimulatedRun> runs;
  for (const auto& m : c.motions) runs.push_back(indicial::simulate_reference(c.truth, m));
  return runs;
}

const indicial::Experiment& example1(bool full) {
  static std::map<bool, indicial::Experiment> cache;
  auto it = cache.find(full);
  if (it != cache.end()) return it->second;
  const auto& c = indicial::find_simulation_case("tailless-model-1");
  auto runs = simulate_case(c);
  indicial::add_measurement_noise(runs, 40.0, 7);
  indicial::Experiment e = experiment_from(c, runs, c.run_files);
  if (full) {
    // Stepwise over a pool larger than the truth, and the Table IV two-stage start.
    e.model.structure = indicial::StructureMode::stepwise;
    e.model.a = indicial::SplineConfig{{0, 1, 2, 3}, {0.4363, 0.9599}, 2};
    e.model.b1 = indicial::SplineConfig{{0, 1}, {}, 1};
    e.rotary.polynomial = {-1.4};
    e.rotary.estimate = true;
    e.rotary.candidates = indicial::SplineConfig{{0, 1, 2}, {}, 1};
  }
  return cache.emplace(full, std::move(e)).first->second;
}

void BM_fit_example1(benchmark::State& state, bool full) {
  const indicial::Experiment& e = example1(full);
  indicial::FitOptions o;
  int iterations = 0, two_stage = 0;
  std::string termination;
  for (auto _ : state) {
    indicial::FitResult r = indicial::fit_experiment(e, o);
    iterations = r.output_error.iterations;
    two_stage = static_cast<int>(r.two_stage.size());
    termination = indicial::termination_name(r.output_error.termination);
    benchmark::DoNotOptimize(r.fit_error);
  }
  state.counters["ml_iterations"] = iterations;
  state.counters["two_stage_iterations"] = two_stage;
  state.SetLabel(termination);
}

// A Model I or II truth on one long 0.5 Hz sine of n samples (dt 0.01 s), SNR 40.
struct LongData {
  indicial::Experiment experiment;
};

LongData simulate_long_data(bool model2, std::size_t n) {
  const auto& c =
      indicial::find_simulation_case(model2 ? "tailless-model-2" : "tailless-model-1");
  indicial::MotionSpec m = c.motions[1];  // 0.5 Hz
  m.cycles = static_cast<double>(n - 1) * m.dt_s * m.freq_hz;
  indicial::ReferenceTolerance tol;
  tol.abs = tol.rel = 1e-9;  // plenty for timing data; keeps the 1e6-sample case short
  std::vector<indicial::SimulatedRun> runs{indicial::simulate_reference(c.truth, m, tol)};
  indicial::add_measurement_noise(runs, 40.0, 11);
  return LongData{experiment_from(c, runs, {"long.csv"})};
}

// Cached: repetitions of a benchmark reuse the simulated data.
const LongData& long_data(bool model2, std::size_t n) {
  static std::map<std::pair<bool, std::size_t>, LongData> cache;
  const auto key = std::make_pair(model2, n);
  auto it = cache.find(key);
  if (it == cache.end()) it = cache.emplace(key, simulate_long_data(model2, n)).first;
  return it->second;
}

// Seconds of fit_output_error with exactly `iterations` iterations (tests disabled).
double time_ml(const indicial::fit_detail::UnsteadyStructure& s,
               const indicial::fit_detail::OutputErrorData& data,
               const Eigen::VectorXd& theta0, int iterations, int* done) {
  indicial::FitOptions o;
  o.max_iterations = iterations;
  o.cost_tolerance = 0.0;
  o.step_tolerance = 0.0;
  const auto t0 = Clock::now();
  indicial::fit_detail::MLResult r =
      indicial::fit_detail::fit_output_error(s, data, theta0, o);
  const double t = seconds_since(t0);
  *done = r.summary.iterations;
  benchmark::DoNotOptimize(r.theta.data());
  return t;
}

void run_ml_iteration(benchmark::State& state, const indicial::Experiment& e) {
  namespace fd = indicial::fit_detail;
  const auto base = indicial::base_model_set(e);
  const auto runs = fd::prepare_runs(e, base);
  const fd::UnsteadyStructure pool = fd::structure_from_config(e.model);
  fd::UnsteadyStructure s;
  indicial::FitOptions o;
  const indicial::EquationErrorResult ee =
      fd::run_equation_error(runs, pool, indicial::StructureMode::fixed, o, e.path, s);
  const fd::ParameterLayout layout(s, runs);
  Eigen::VectorXd theta0 = Eigen::VectorXd::Zero(layout.size());
  for (const indicial::ParameterEstimate& p : ee.parameters) theta0[layout.find(p.id)] = p.value;
  const std::string context = "bench";
  const fd::OutputErrorData data{runs, base.coefficients[0], context,
                                 indicial::AngleRange{base.x_min_rad, base.x_max_rad}};
  std::size_t n = 0;
  for (const auto& r : runs) n += r.t.size();
  // Why the minimum over repeats: the per-iteration time is a difference of two totals, and
  // on a shared machine a single total can be inflated by a preemption; the minimum of each
  // total is the least disturbed. Small problems are repeated more (same total work).
  const int repeats = static_cast<int>(std::clamp<std::size_t>(200000 / n, 1, 20));
  int done0 = 0, done1 = 0;
  for (auto _ : state) {
    double t0 = 1e300, t1 = 1e300;
    for (int k = 0; k < repeats; ++k) {
      t0 = std::min(t0, time_ml(s, data, theta0, 0, &done0));
      t1 = std::min(t1, time_ml(s, data, theta0, 1, &done1));
    }
    state.SetIterationTime(t1 - t0);
  }
  state.counters["samples"] = static_cast<double>(n);
  state.counters["parameters"] = static_cast<double>(theta0.size());
  state.counters["iterations_0_1"] = done0 * 10 + done1;  // 1 when both ran as asked
}

void BM_ml_samples(benchmark::State& state) {
  const auto n = static_cast<std::size_t>(state.range(0));
  const LongData& d = long_data(false, n);
  run_ml_iteration(state, d.experiment);
}

void BM_ml_params(benchmark::State& state) {
  LongData d = long_data(true, 20000);
  auto& m = d.experiment.model;
  m.a = indicial::SplineConfig{{0, 1, 2}, {0.4363, 0.9599}, 2};
  switch (state.range(0)) {
    case 6: m.b1 = indicial::SplineConfig{{0}, {}, 1}; break;
    case 8: m.b1 = indicial::SplineConfig{{0}, {0.349, 1.0472}, 1}; break;
    case 10: m.b1 = indicial::SplineConfig{{0}, {0.349, 0.5236, 0.827, 1.0472}, 1}; break;
    default:
      m.a = indicial::SplineConfig{{0, 1, 2}, {0.4363, 0.7, 0.9599, 1.1}, 2};
      m.b1 = indicial::SplineConfig{{0}, {0.349, 0.5236, 0.827, 1.0472}, 1};
      break;
  }
  run_ml_iteration(state, d.experiment);
}

// Monte Carlo: T threads each fit their share of `seeds_per_iteration` noise seeds.
void BM_montecarlo(benchmark::State& state) {
  const int threads = static_cast<int>(state.range(0));
  const auto& c = indicial::find_simulation_case("tailless-model-1");
  const std::vector<indicial::SimulatedRun> truth = simulate_case(c);
  const int seeds_per_iteration = 8;
  std::atomic<int> next_seed{1000};
  std::atomic<int> failures{0};
  for (auto _ : state) {
    std::atomic<int> remaining{seeds_per_iteration};
    auto worker = [&] {
      while (remaining.fetch_sub(1) > 0) {
        std::vector<indicial::SimulatedRun> runs = truth;
        indicial::add_measurement_noise(runs, 40.0, static_cast<std::uint64_t>(next_seed++));
        const indicial::Experiment e = experiment_from(c, runs, c.run_files);
        const indicial::FitResult r = indicial::fit_experiment(e, indicial::FitOptions{});
        if (r.output_error.termination != indicial::Termination::converged) ++failures;
        benchmark::DoNotOptimize(r.fit_error);
      }
    };
    std::vector<std::thread> pool;
    for (int t = 1; t < threads; ++t) pool.emplace_back(worker);
    worker();
    for (auto& th : pool) th.join();
  }
  state.counters["seeds_per_s"] = benchmark::Counter(
      static_cast<double>(state.iterations()) * seeds_per_iteration, benchmark::Counter::kIsRate);
  state.counters["not_converged"] = failures.load();
}

}  // namespace

BENCHMARK_CAPTURE(BM_fit_example1, fixed, false)->Name("fit/example1/fixed")
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_fit_example1, full, true)->Name("fit/example1/full")
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ml_samples)->Name("ml_iteration/samples")->Arg(1000)->Arg(10000)->Arg(100000)
    ->Arg(1000000)->UseManualTime()->Iterations(3)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ml_params)->Name("ml_iteration/params")->Arg(6)->Arg(8)->Arg(10)->Arg(12)
    ->UseManualTime()->Iterations(5)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_montecarlo)->Name("montecarlo/threads")->Arg(1)->Arg(2)->UseRealTime()
    ->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
