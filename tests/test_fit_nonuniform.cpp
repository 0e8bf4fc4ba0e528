// Runs on a nonuniform time grid (issue 12 item 3: time_grid = "nonuniform", or a phase
// column with jitter): the equation error differentiates y_E on the actual times
// (smooth_derivative_nonuniform) and the output error steps with each sample's own dt, as the
// runtime does (fit_internal.hpp PreparedRun::step_s). The data: the report's Model II
// integrated by the reference simulator (Boost.Odeint) to exactly the jittered sample times
// (MotionSpec::output_times_s), white noise; the same noise draws on the uniform grid give the
// comparison.
#include <doctest/doctest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "indicial/fitter/fit.hpp"
#include "indicial/fitter/montecarlo.hpp"
#include "indicial/fitter/report.hpp"
#include "indicial/fitter/simulate.hpp"

#include "fit_test_data.hpp"

TEST_SUITE_BEGIN("unit");  // the ctest label (tests/CMakeLists.txt)

using namespace indicial;
using indicial::testing::find_estimate;

namespace {

// Model II's runs, sampled at k dt + u_k with u_k uniform in [-jitter dt, jitter dt] (k > 0;
// 0: the uniform grid), SNR 40 white noise from `seed`.
Experiment simulated_jittered(double jitter, std::uint64_t seed, double* sigma) {
  const SimulationCase& c = find_simulation_case("tailless-model-2");
  std::vector<SimulatedRun> runs;
  std::mt19937_64 rng(seed + 17u);
  for (MotionSpec m : c.motions) {
    if (jitter > 0.0) {
      std::uniform_real_distribution<double> u(-jitter * m.dt_s, jitter * m.dt_s);
      const std::vector<double> uniform = motion_sample_times(m);
      for (std::size_t k = 0; k < uniform.size(); ++k) m.output_times_s.push_back(k == 0 ? 0.0 : uniform[k] + u(rng));
    }
    runs.push_back(simulate_reference(c.truth, m));
  }
  *sigma = add_measurement_noise(runs, 40.0, seed).at(0);
  Experiment e = experiment_from_simulation(c, runs);
  e.path = "nonuniform.toml";
  for (Run& r : e.runs) r.time_grid = jitter > 0.0 ? TimeGrid::nonuniform : TimeGrid::uniform;
  return e;
}

const char* const kModel2Names[] = {"b1_0", "B1", "B2", "B3", "B4", "a0", "a1", "a2", "A1", "A2"};
const double kModel2Truth[] = {2.5, -5.73, 5.73, 5.73, -5.73, 0.0, 0.28, -3.2, 8.0, -7.4};

}  // namespace

TEST_CASE("jittered times (+-30% of the step): Model II within 3 bounds, and within a bound of the uniform fit") {
  double sigma_j = 0.0, sigma_u = 0.0;
  const Experiment ej = simulated_jittered(0.3, 8001u, &sigma_j);
  const Experiment eu = simulated_jittered(0.0, 8001u, &sigma_u);
  for (const StateDerivative sd : {StateDerivative::smoothed_difference, StateDerivative::modulating_function}) {
    FitOptions o;
    o.state_derivative = sd;
    const FitResult fj = fit_experiment(ej, o);
    const FitResult fu = fit_experiment(eu, o);
    CHECK(fj.output_error.termination == Termination::converged);
    for (std::size_t i = 0; i < std::size(kModel2Names); ++i) {
      const ParameterEstimate* pj = find_estimate(fj, kModel2Names[i]);
      const ParameterEstimate* pu = find_estimate(fu, kModel2Names[i]);
      REQUIRE(pj != nullptr);
      REQUIRE(pu != nullptr);
      INFO(kModel2Names[i] << ": jittered " << pj->value << " (" << pj->cr_bound << "), uniform " << pu->value
                           << ", truth " << kModel2Truth[i]);
      CHECK(std::abs(pj->value - kModel2Truth[i]) < 3.0 * pj->cr_bound);
      // The same noise draws on slightly different times: the estimates differ by far less
      // than their spread over noise realisations.
      CHECK(std::abs(pj->value - pu->value) < pj->cr_bound);
      // The equation error (start values) on the actual times as well.
      int ee_found = 0;
      for (const ParameterEstimate& ee : fj.equation_error.parameters) {
        if (ee.name != kModel2Names[i]) continue;
        ++ee_found;
        CHECK(std::abs(ee.value - kModel2Truth[i]) < 0.2 * std::abs(kModel2Truth[i]) + 0.1);
      }
      CHECK(ee_found == 1);
    }
    INFO("s(v) " << fj.fit_error << ", noise " << sigma_j);
    CHECK(std::abs(fj.fit_error / sigma_j - 1.0) < testing::fit_error_ratio_tolerance(fj));
    // The runtime, stepping each sample's own dt, replays the fitted model to rounding.
    const RuntimeCheck rc = replay_in_runtime(fj, ej, model_coef_text(fj, "nonuniform fit"));
    CHECK(rc.steps_not_ok == 0);
    CHECK(rc.max_abs_difference < 1e-9);
  }
}

TEST_CASE("jittered times taken as uniform: the fit is worse than with the actual times") {
  double sigma = 0.0;
  const Experiment ej = simulated_jittered(0.3, 8002u, &sigma);
  Experiment as_uniform = ej;
  for (Run& r : as_uniform.runs) r.time_grid = TimeGrid::uniform;
  const FitResult right = fit_experiment(ej, FitOptions{});
  const FitResult wrong = fit_experiment(as_uniform, FitOptions{});
  MESSAGE("s(v) actual times " << right.fit_error << ", taken as uniform " << wrong.fit_error << ", noise " << sigma);
  CHECK(right.fit_error < wrong.fit_error);
}

TEST_CASE("a periodic cycle on jittered times: the periodic state steps with each sample's dt") {
  // The last settled cycle of a long 0.5 Hz oscillation, sampled at jittered times (both
  // ends at the cycle's ends, so the cycle closes on its last sample).
  const SimulationCase& c = find_simulation_case("tailless-model-2");
  std::vector<SimulatedRun> cycles;
  std::mt19937_64 rng(99u);
  for (MotionSpec m : c.motions) {
    const double period_s = 1.0 / m.freq_hz;
    m.cycles = std::ceil(12.0 * m.freq_hz) + 1.0;
    const double t0 = (m.cycles - 1.0) * period_s;
    const int per_cycle = static_cast<int>(std::lround(period_s / m.dt_s));
    const int before = static_cast<int>(std::lround(t0 / m.dt_s));
    std::uniform_real_distribution<double> u(-0.3 * m.dt_s, 0.3 * m.dt_s);
    // The integration starts from rest at the first output time: the settling cycles on the
    // uniform grid, then the kept cycle on jittered times.
    m.output_times_s.clear();
    for (int k = 0; k < before; ++k) m.output_times_s.push_back(k * m.dt_s);
    for (int k = 0; k <= per_cycle; ++k)
      m.output_times_s.push_back(t0 + k * m.dt_s + (k == 0 || k == per_cycle ? 0.0 : u(rng)));
    cycles.push_back(indicial::testing::tail_of(simulate_reference(c.truth, m), static_cast<std::size_t>(before)));
    REQUIRE(std::abs(cycles.back().y_true[0].back() - cycles.back().y_true[0].front()) < 1e-7);
  }
  const double sigma = add_measurement_noise(cycles, 40.0, 8003u).at(0);
  Experiment e = experiment_from_simulation(c, cycles);
  e.path = "periodic-nonuniform.toml";
  e.model.a.powers = {1, 2};  // as the report fits Model II (Table III)
  for (Run& r : e.runs) {
    r.periodic = true;
    r.time_grid = TimeGrid::nonuniform;
  }
  const FitResult fit = fit_experiment(e, FitOptions{});
  CHECK(fit.output_error.termination == Termination::converged);
  for (std::size_t i = 0; i < std::size(kModel2Names); ++i) {
    if (std::string(kModel2Names[i]) == "a0") continue;
    const ParameterEstimate* p = find_estimate(fit, kModel2Names[i]);
    REQUIRE(p != nullptr);
    INFO(kModel2Names[i] << " = " << p->value << " (" << p->cr_bound << "), truth " << kModel2Truth[i]);
    CHECK(std::abs(p->value - kModel2Truth[i]) < 3.0 * p->cr_bound);
  }
  // The model's state at the cycle's start is the truth's periodic state, inside the noise.
  for (std::size_t i = 0; i < cycles.size(); ++i) {
    INFO("run " << i);
    CHECK(std::abs(fit.runs[i].y_model.front() - cycles[i].y_true[0].front()) < 0.5 * sigma);
  }
}
