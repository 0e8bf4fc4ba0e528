// The warnings about a finished fit (fitter/src/report/fit_warnings.cpp): here the lag that
// does not decay over the runs, which a fit reaches when the data show no lag of the model's
// structure (the Glasgow NACA 0012 C_m cycles: b1 = 8e-5 1/s against runs of 0.43 s), a
// dynamic-stall state too slow for the periodic runs' cycle, an
// estimate on the feasible set's boundary, and ill-conditioned estimates with replicated runs.
#include <doctest/doctest.h>

#include <cmath>
#include <string>
#include <vector>

#include "indicial/fitter/fit.hpp"
#include "indicial/fitter/experiment.hpp"
#include "indicial/fitter/replication.hpp"
#include "indicial/fitter/report.hpp"

TEST_SUITE_BEGIN("unit");  // the ctest label (tests/CMakeLists.txt)

using namespace indicial;

namespace {

// One coefficient, one lag with b1(x) = b0 + b1_slope x over the envelope [-0.1, 0.4] rad, and
// one run of run_s seconds at 1 kHz; no residual (no noise warning) and no parameters.
FitResult lag_fit(double b0_per_s, double b1_slope, double run_s) {
  FitResult r;
  r.fit_error = 0.0;
  r.model.n_coefficients = 1;
  r.model.x_min_rad = -0.1;
  r.model.x_max_rad = 0.4;
  auto& cm = r.model.coefficients[0];
  cm.n_lags = 1;
  cm.lags[0].b.n_powers = 2;
  cm.lags[0].b.power_coef[0] = b0_per_s;
  cm.lags[0].b.power_coef[1] = b1_slope;
  RunSeries run;
  for (int i = 0; i * 1e-3 <= run_s; ++i) run.time_s.push_back(i * 1e-3);
  r.runs.push_back(run);
  return r;
}

int undamped_warnings(const std::vector<std::string>& w) {
  int n = 0;
  for (const std::string& s : w) n += s.find("does not decay over the runs") != std::string::npos;
  return n;
}

}  // namespace

TEST_CASE("fit warnings: a lag that does not decay over the runs is named, with its time constant") {
  Experiment e;
  e.path = "exp.toml";
  // b1 = 8e-5 1/s over 0.43 s: b T = 3.4e-5, the measured case.
  const std::vector<std::string> w = fit_warnings(lag_fit(8e-5, 0.0, 0.43), e);
  REQUIRE(undamped_warnings(w) == 1);
  const std::string& msg = w[0];
  CHECK(msg.rfind("exp.toml: lag 1 does not decay over the runs: b1(x) <= 8e-05 1/s", 0) == 0);
  CHECK(msg.find("a time constant of at least 1.25e+04 s against 0.43 s of the longest run") != std::string::npos);
  CHECK(msg.find("static correction -A(x)") != std::string::npos);
  // The largest b over the envelope decides: 0.2 1/s at its top end (b T = 0.086) is a lag.
  CHECK(undamped_warnings(fit_warnings(lag_fit(0.0, 0.5, 0.43), e)) == 0);
  // Just under the 0.05 floor (b T = 0.043) it is not.
  CHECK(undamped_warnings(fit_warnings(lag_fit(0.1, 0.0, 0.43), e)) == 1);
  // A real lag (b1 = 13 1/s, the C_L fits of the same cycles) is not named.
  CHECK(undamped_warnings(fit_warnings(lag_fit(13.0, 0.0, 0.43), e)) == 0);
  // No runs: nothing to compare with, no warning.
  FitResult no_runs = lag_fit(8e-5, 0.0, 0.43);
  no_runs.runs.clear();
  CHECK(undamped_warnings(fit_warnings(no_runs, e)) == 0);
}

TEST_CASE("fit warnings: a dynamic-stall state too slow for the cycle is named") {
  // One periodic run: a 2 Hz cycle at 30 m/s with l = 0.15 m, 0.5 s = 100 l/V; a vortex lift
  // with T_v of 1e4 l/V keeps exp(-100 / 1e4) = 0.99 of its value over a cycle (the development
  // set's Beddoes-Leishman fits reached 1e4-1e6); T_v = 6, the Beddoes-Leishman constant, 6e-8.
  Experiment e;
  e.path = "exp.toml";
  e.airspeed_mps = 30.0;
  e.reference_length_m = 0.15;
  Run run;
  run.periodic = true;
  run.frequency_hz = 2.0;
  for (int i = 0; i < 100; ++i) run.time_s.push_back(i * 0.005);
  e.runs.push_back(run);
  auto slow_warnings = [](const std::vector<std::string>& w) {
    int n = 0;
    for (const std::string& s : w) n += s.find("is long against the shortest periodic run's cycle") != std::string::npos;
    return n;
  };
  FitResult r = lag_fit(13.0, 0.0, 0.5);
  auto& st = r.model.coefficients[0].stall;
  st.families = StallFamilies::separation_and_vortex;
  st.separation.tau1_semichords = 3.0;
  st.vortex.decay_semichords = 1e4;
  std::vector<std::string> w = fit_warnings(r, e);
  REQUIRE(slow_warnings(w) == 1);
  std::string msg;
  for (const std::string& s : w)
    if (s.find("is long against") != std::string::npos) msg = s;
  CHECK(msg.rfind("exp.toml: the dynamic-stall time constant T_v (the vortex lift's) = 1e+04 l/V", 0) == 0);
  CHECK(msg.find("cycle of 100 l/V") != std::string::npos);
  CHECK(msg.find("keeps 0.99 of its value over a cycle") != std::string::npos);
  st.vortex.decay_semichords = 6.0;
  CHECK(slow_warnings(fit_warnings(r, e)) == 0);
  // The floor, 0.1 kept per cycle: T = 100 / ln(10) = 43.4 l/V. The separation point's T1 on
  // either side of it, and T1r beside it.
  st.separation.tau1_semichords = 44.0;
  CHECK(slow_warnings(fit_warnings(r, e)) == 1);
  st.separation.tau1_semichords = 43.0;
  CHECK(slow_warnings(fit_warnings(r, e)) == 0);
  st.separation.tau1_reattach_semichords = 500.0;
  CHECK(slow_warnings(fit_warnings(r, e)) == 1);
  // A run that is not periodic has no cycle: nothing to say.
  e.runs[0].periodic = false;
  CHECK(slow_warnings(fit_warnings(r, e)) == 0);
  // Without the families, nothing either.
  e.runs[0].periodic = true;
  st.families = StallFamilies::none;
  CHECK(slow_warnings(fit_warnings(r, e)) == 0);
}

TEST_CASE("fit warnings: an estimate on the feasible set's boundary is named with its infeasible trials") {
  Experiment e;
  e.path = "exp.toml";
  FitResult r = lag_fit(13.0, 0.0, 0.43);
  auto boundary_warnings = [](const std::vector<std::string>& w) {
    int n = 0;
    for (const std::string& s : w) n += s.find("sits on the boundary of the admissible models") != std::string::npos;
    return n;
  };
  CHECK(boundary_warnings(fit_warnings(r, e)) == 0);  // interior by default
  r.output_error.boundary = FeasibilityBoundary::active;
  r.output_error.infeasible_trials = 23;
  const std::vector<std::string> w = fit_warnings(r, e);
  REQUIRE(boundary_warnings(w) == 1);
  for (const std::string& s : w)
    if (s.find("admissible models") != std::string::npos)
      CHECK(s.find("exp.toml: the output-error estimate sits on the boundary of the admissible models (23 trial steps") == 0);
}

TEST_CASE("fit warnings: ill-conditioned estimates are named when the runs are replicated too") {
  // Two identical runs at one condition: replicate_runs noise (sigma 0, so no noise-ratio
  // warning). fit returned before the ill-conditioned list whenever the data had replication.
  Experiment e;
  e.path = "exp.toml";
  Run run;
  for (int i = 0; i < 200; ++i) {
    run.time_s.push_back(i * 1e-3);
    run.motion_angle_rad.push_back(0.1 * std::sin(0.05 * i));
    run.coefficient.push_back(0.5 * run.motion_angle_rad.back() + 1e-3 * ((i * 7919) % 13 - 6));
  }
  run.airspeed_mps = 30.0;
  e.runs = {run, run};
  e.runs[1].coefficient[5] += 1e-3;  // replicates that differ: a finite spread
  REQUIRE(replication_noise(e).source == NoiseSource::replicate_runs);
  FitResult r = lag_fit(13.0, 0.0, 0.43);
  ParameterEstimate p;
  p.name = "A3";
  p.value = -2309.0;
  p.cr_bound = 10292.0;
  r.parameters.push_back(p);
  const std::vector<std::string> w = fit_warnings(r, e);
  int named = 0;
  for (const std::string& s : w) named += s.find("ill-conditioned estimates") != std::string::npos &&
                                          s.find("A3 = -2309 +- 1.029e+04") != std::string::npos;
  CHECK(named == 1);
}
