// Diagnose's leave-one-run-out rule with more than three runs (issue 21, item 2): the minimum
// held-out gain is min_gain 3 / R for R > 3 folds (diagnose_crossval.cpp, min_gain_for_folds).
// Colored noise alone must still name nothing: a complete model (the truth's structure) fitted
// to six runs of data from the reference simulator (Dormand-Prince, never the fitter's update)
// with AR(1) phi 0.8 or band-limited turbulence noise; the minimum gain there is 5 %. The
// in-sample floor (cv_min_in_sample_gain) is off here, so that the held-out rule alone decides.
// The test itself is test_diagnose_crossval.cpp; three runs, test_diagnose_crossval_turbulence.cpp.
// ctest: skipped under sanitizers -- whole diagnoses with six-fold refits, minutes under ASan; test_diagnose_crossval runs the rule's arithmetic there (tools/run-sanitizers.sh; tests/CMakeLists.txt)
#include <doctest/doctest.h>

#include <cmath>
#include <string>

#include "diagnose_test_data.hpp"
#include "diagnose_test_matrix.hpp"
#include "fit_test_data.hpp"

TEST_SUITE_BEGIN("statistical");  // the ctest label (tests/CMakeLists.txt)

using namespace indicial;
using namespace indicial::testing;

namespace {

// Six sine runs from rest over the matrix's 0-70 deg, 0.2 to 1.2 Hz, of the complete model.
Experiment six_runs(MatrixNoise noise, unsigned seed) {
  SimulationCase c = matrix_base_case("Cm", MatrixMotion::sine_from_rest);
  const MotionSpec first = c.motions.front();
  c.motions.clear();
  c.run_files.clear();
  c.experiment.runs.clear();
  for (int r = 0; r < 6; ++r) {
    MotionSpec s = first;
    s.freq_hz = 0.2 + 0.2 * r;
    c.motions.push_back(s);
    c.run_files.push_back(fmt::format("many_{}.csv", r + 1));
    Run run;
    run.path = c.run_files.back();
    c.experiment.runs.push_back(run);
  }
  std::vector<SimulatedRun> runs;
  for (const auto& m : c.motions) runs.push_back(simulate_reference(c.truth, m));
  add_measurement_noise(runs, 40.0, seed, matrix_noise_model(noise));
  Experiment e = experiment_from_simulation(c, runs);
  e.path = fmt::format("many-runs-{}.toml", seed);
  return e;
}

// The diagnosis of six runs with the in-sample materiality floor off (cv_min_in_sample_gain =
// 0), so that the held-out conditions alone decide, and the minimum gain `min_gain`.
DiagnoseResult held_out_alone(MatrixNoise noise, unsigned seed, double min_gain) {
  DiagnoseOptions o;
  o.cv_min_in_sample_gain = 0.0;
  o.cv_min_gain = min_gain;
  const DiagnoseResult d = diagnose_experiment(six_runs(noise, seed), o);
  for (const DiagnoseRound& r : d.rounds)
    for (const HeldOutTest& t : r.held_out)
      MESSAGE(std::string(effect_name(t.effect)), " ", t.stage, " [", t.terms, "]: mean ", t.mean_log_ratio, " se ",
              t.standard_error, " improved ", t.runs_improved, " in sample ", t.in_sample_log_ratio,
              std::string(t.enters ? " ENTERS" : ""));
  MESSAGE("min gain ", min_gain, ": verdict ", d.verdict, ", ", d.elapsed_s, " s, ", d.fits_run, " fits");
  CHECK(d.rule == DecisionRule::leave_one_run_out);
  CHECK(d.cv_folds == 6);
  return d;
}

}  // namespace

// Seed 9009 is the seed of ten (9001-9010, the study in docs/diagnose.md) where a chance term
// gains most held out: with no minimum gain rotary_alpha enters under both noises (held out
// -0.013 +- 0.010 and -0.029 +- 0.026 in ln MSE, 4 of 6 runs better). The minimum gain (10 %
// at three folds, 5 % at six) is what keeps it out.
TEST_CASE("six runs: AR(1) noise alone names nothing at the folds' minimum gain (5 %)") {
  CHECK(held_out_alone(MatrixNoise::ar1, 9009, 0.10).verdict == "none");
  CHECK(held_out_alone(MatrixNoise::ar1, 9009, 0.0).verdict != "none");
}

TEST_CASE("six runs: turbulence noise alone names nothing at the folds' minimum gain (5 %)") {
  CHECK(held_out_alone(MatrixNoise::turbulence, 9009, 0.10).verdict == "none");
  CHECK(held_out_alone(MatrixNoise::turbulence, 9009, 0.0).verdict != "none");
}
