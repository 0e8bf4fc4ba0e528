// Monte Carlo on a case whose motions are at two airspeeds: each run's airspeed reaches the fit
// (montecarlo.cpp experiment_from_simulation), so the model is scaled as the simulator scaled
// it. Data: the report's Model I (Table I), its three sines simulated by the reference
// integration (Boost.Odeint, its own airspeed scaling) at 0.7 V_ref (0.25 and 1 Hz) and
// 1.4 V_ref (0.5 Hz), frequencies and steps scaled with the airspeed so each run's reduced
// frequency is the report's; white noise SNR 40, 3 seeds.
#include <doctest/doctest.h>

#include <cmath>
#include <string>
#include <vector>

#include "indicial/fitter/fit.hpp"
#include "indicial/fitter/montecarlo.hpp"
#include "indicial/fitter/simulate.hpp"

TEST_SUITE_BEGIN("unit");  // the ctest label (tests/CMakeLists.txt)

using namespace indicial;

namespace {

SimulationCase at_two_airspeeds() {
  SimulationCase c = find_simulation_case("tailless-model-1");
  const double factors[] = {0.7, 1.4, 0.7};
  REQUIRE(c.motions.size() == 3);
  for (std::size_t i = 0; i < c.motions.size(); ++i) {
    MotionSpec& m = c.motions[i];
    m.airspeed_mps = factors[i] * c.truth.airspeed_mps;
    m.freq_hz *= factors[i];
    m.dt_s /= factors[i];
  }
  c.name = "tailless-model-1 at 0.7 and 1.4 V_ref";
  return c;
}

}  // namespace

TEST_CASE("montecarlo: each run's airspeed reaches the fit, s(v) at the noise, estimates at the truth") {
  const SimulationCase c = at_two_airspeeds();
  MonteCarloOptions o;
  o.seeds = 3;
  o.first_seed = 8101;
  o.threads = 2;
  const MonteCarloResult r = run_monte_carlo(c, o);
  REQUIRE(r.fitted == 3);
  CHECK(r.options.case_name == c.name);
  INFO("mean s(v) " << r.mean_fit_error << ", noise " << r.noise_sigma);
  CHECK(std::abs(r.mean_fit_error / r.noise_sigma - 1.0) < 0.1);
  for (const MonteCarloParameter& p : r.parameters) {
    if (!std::isfinite(p.truth) || p.name.rfind("y0_", 0) == 0) continue;
    INFO(p.name << ": mean " << p.mean << ", truth " << p.truth << ", mean CR " << p.mean_cr_bound);
    // The mean of 3 seeds: its standard error is CR / sqrt(3); 4 of those.
    CHECK(std::abs(p.mean - p.truth) < 4.0 * p.mean_cr_bound / std::sqrt(3.0));
  }
}

// What the test above would see without the airspeeds (every run fitted at V_ref, the old
// behaviour): the same data fitted several times worse than the noise.
TEST_CASE("montecarlo's experiment carries each motion's airspeed, without it the fit misses") {
  const SimulationCase c = at_two_airspeeds();
  std::vector<SimulatedRun> runs;
  for (const MotionSpec& m : c.motions) runs.push_back(simulate_reference(c.truth, m));
  const double sigma = add_measurement_noise(runs, 40.0, 8101).at(0);
  Experiment e = experiment_from_simulation(c, runs);
  REQUIRE(e.runs.size() == 3);
  for (std::size_t i = 0; i < e.runs.size(); ++i) CHECK(e.runs[i].airspeed_mps == c.motions[i].airspeed_mps);
  const FitResult with = fit_experiment(e, FitOptions{});
  for (Run& run : e.runs) run.airspeed_mps = 0.0;  // the experiment's airspeed, V_ref
  const FitResult without = fit_experiment(e, FitOptions{});
  MESSAGE("s(v) / noise: with the runs' airspeeds " << with.fit_error / sigma << ", all at V_ref "
                                                    << without.fit_error / sigma);
  CHECK(std::abs(with.fit_error / sigma - 1.0) < 0.1);
  CHECK(without.fit_error > 2.0 * sigma);
}
