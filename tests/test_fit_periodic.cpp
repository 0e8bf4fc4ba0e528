// Periodic runs ({file = ..., periodic = true}): an ensemble-averaged cycle whose state at the
// start is the periodic steady state of the model (fit_output_error.cpp, periodic_state), not
// an estimated y0. The data are the last cycle of long oscillations from the reference
// integration (Model II, Table I), by which time the start-up transient has decayed below
// 1.5e-8 of its size, so the truth IS periodic over that cycle and its state at the cycle's start is
// known from the integration.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "indicial/fitter/fit.hpp"
#include "indicial/fitter/montecarlo.hpp"
#include "indicial/fitter/simulate.hpp"

#include "fit_test_data.hpp"

TEST_SUITE_BEGIN("unit");  // the ctest label (tests/CMakeLists.txt)

using namespace indicial;
using indicial::testing::tail_of;

TEST_CASE("periodic runs: the last settled cycle of each run, no y0, recovers Model II and its state") {
  const SimulationCase& c = find_simulation_case("tailless-model-2");
  std::vector<SimulatedRun> cycles;
  for (MotionSpec m : c.motions) {
    // At least 12 s before the kept cycle: b1(x) >= 1.5 1/s over the envelope, so the start-up
    // transient has decayed to below exp(-18) = 1.5e-8 of its size (4, 7 and 13 cycles).
    m.cycles = std::ceil(12.0 * m.freq_hz) + 1.0;
    const SimulatedRun full = simulate_reference(c.truth, m);
    const double period_s = 1.0 / m.freq_hz;
    const std::size_t per_cycle = static_cast<std::size_t>(std::lround(period_s / m.dt_s));
    REQUIRE(full.time_s.size() > per_cycle);
    // The last cycle, both ends included: the angle returns to its start (a closed cycle).
    cycles.push_back(tail_of(full, full.time_s.size() - 1 - per_cycle));
    const SimulatedRun& cyc = cycles.back();
    REQUIRE(std::abs(cyc.x_rad.back() - cyc.x_rad.front()) < 1e-9);
    // ...and so does the true state: the data really are periodic.
    CHECK(std::abs(cyc.y_true[0].back() - cyc.y_true[0].front()) < 1e-7);
  }
  const std::vector<double> sigma = add_measurement_noise(cycles, 40.0, 4242u);
  Experiment e = experiment_from_simulation(c, cycles);
  e.path = "periodic.toml";
  e.model.a.powers = {1, 2};  // as the report fits Model II (Table III)
  for (Run& r : e.runs) r.periodic = true;

  const FitResult fit = fit_experiment(e, FitOptions{});
  CHECK(fit.output_error.termination == Termination::converged);
  // No initial-state parameter: the state is the periodic steady state.
  for (const auto& p : fit.parameters) CHECK(p.name.rfind("y0", 0) != 0);
  const struct { const char* name; double value; } truth[] = {
      {"b1_0", 2.5}, {"B1", -5.73}, {"B2", 5.73}, {"B3", 5.73}, {"B4", -5.73},
      {"a1", 0.28},  {"a2", -3.2},  {"A1", 8.0},  {"A2", -7.4}};
  for (const auto& t : truth) {
    const ParameterEstimate* p = indicial::testing::find_estimate(fit, t.name);
    REQUIRE(p != nullptr);
    INFO(t.name << " = " << p->value << " (" << p->cr_bound << "), truth " << t.value);
    CHECK(std::abs(p->value - t.value) < 3.0 * p->cr_bound);
  }
  INFO("s(v) " << fit.fit_error << ", noise " << sigma[0]);
  CHECK(std::abs(fit.fit_error / sigma[0] - 1.0) < testing::fit_error_ratio_tolerance(fit));
  // The model's state at each cycle's start is the truth's (from the integration), to well
  // inside the noise; a zero or free start would be off by the size of y (0.05-0.2 here).
  REQUIRE(fit.runs.size() == cycles.size());
  for (std::size_t i = 0; i < cycles.size(); ++i) {
    const double y_true0 = cycles[i].y_true[0].front();
    const double y_model0 = fit.runs[i].y_model.front();
    INFO("run " << i << ": y(0) model " << y_model0 << ", truth " << y_true0);
    CHECK(std::abs(y_true0) > 10.0 * sigma[0]);  // the check below is not trivial
    CHECK(std::abs(y_model0 - y_true0) < 0.5 * sigma[0]);
    // And over the whole cycle the model follows the noise-free truth inside the noise.
    double sum_sq = 0.0;
    for (std::size_t k = 0; k < cycles[i].time_s.size(); ++k) {
      const double d = fit.runs[i].model[k] - cycles[i].coefficient_true[0][k];
      sum_sq += d * d;
    }
    const double rms = std::sqrt(sum_sq / static_cast<double>(cycles[i].time_s.size()));
    MESSAGE("run " << i << ": y(0) truth " << y_true0 << ", model - truth " << (y_model0 - y_true0)
                   << " (" << (y_model0 - y_true0) / sigma[0] << " sigma); rms(model - truth) "
                   << rms / sigma[0] << " sigma");
    CHECK(rms < 0.3 * sigma[0]);
  }
}
