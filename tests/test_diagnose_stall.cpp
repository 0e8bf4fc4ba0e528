// Diagnose end to end on dynamic-stall cycles made by a model that is NOT ours: the built-in
// Goman-Khrabrov campaign (fitter/dynamic_stall.hpp: Kirchhoff lift from a separation point,
// integrated by Boost.Odeint; no vortex, another output map than model.hpp's), its three fit
// cycles of C_L with AR(1) noise (phi 0.8, the case's default), SNR 20. Three runs: the
// leave-one-run-out rule decides. A dynamic-stall family must be named first (the report's
// model cannot bend the lift past the stall), and it must lower the error of every run left
// out of its fit. Measured when this test was written: separation_lag first (bench/diagnose-cv.md).
// ctest: skipped under sanitizers -- a whole diagnosis with stall candidates (about 90 fits), minutes under ASan; test_diagnose_starts covers the stall candidates' starts there
#include <doctest/doctest.h>

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "indicial/fitter/diagnose.hpp"
#include "indicial/fitter/dynamic_stall.hpp"
#include "indicial/fitter/report.hpp"

TEST_SUITE_BEGIN("statistical");  // the ctest label (tests/CMakeLists.txt)

using namespace indicial;

TEST_CASE("diagnose names a dynamic-stall family on Goman-Khrabrov cycles, and it lowers every held-out run's error") {
  const dynamic_stall::Campaign& c = dynamic_stall::default_campaign();
  const std::uint64_t seed = 11u;
  std::vector<double> sigma;
  const auto cycles = dynamic_stall::simulate_campaign(c, 20.0, seed, c.default_noise, &sigma);
  const Experiment e = dynamic_stall::campaign_experiment(c, cycles, "CL", dynamic_stall::CycleRole::fit);
  REQUIRE(e.runs.size() == 3);
  DiagnoseOptions o;
  o.threads = 2;
  const DiagnoseResult d = diagnose_experiment(e, o);
  std::string named;
  for (const auto& s : d.effects_added) named += s + " ";
  MESSAGE("effects: ", named, "fit error ", d.initial_fit_error, " -> ", d.final_fit_error, " (sigma CL ", sigma.at(0),
          "), ", d.fits_run, " fits, ", d.elapsed_s, " s");
  REQUIRE(!d.steps.empty());
  const DiagnoseStep& first = d.steps.front();
  CHECK(first.rule == DecisionRule::leave_one_run_out);
  CHECK((first.effect == Effect::separation_lag || first.effect == Effect::vortex_shedding));
  CHECK(first.fit_error_after < first.fit_error_before);
  REQUIRE(first.held_out_rms_before.size() == 3);
  REQUIRE(first.held_out_rms_after.size() == 3);
  for (std::size_t r = 0; r < 3; ++r) {
    CAPTURE(r);
    MESSAGE("run ", r, " held-out RMS ", first.held_out_rms_before[r], " -> ", first.held_out_rms_after[r]);
    CHECK(first.held_out_rms_after[r] < first.held_out_rms_before[r]);
  }
  CHECK(first.held_out_log_ratio < 0.0);
  // The final model carries the family and the runtime loads and replays it as the fitter.
  const FitResult& final_fit = d.fits.back();
  CHECK(final_fit.model.coefficients[0].stall.families != StallFamilies::none);
  const RuntimeCheck rc = replay_in_runtime(final_fit, d.experiment, model_coef_text(final_fit, "diagnosed.coef"));
  CHECK(rc.load_status == LoadStatus::ok);
  CHECK(rc.steps_not_ok == 0);
  CHECK(rc.max_abs_difference < 1e-9);
}
