// Diagnose with NO hidden effect: Model I data (reference simulator, SNR 40) fitted with the
// true structure. Over 20 seeds at least 19 must end with no step and verdict "none" (the
// Bonferroni-guarded family-wise level per round is alpha = 0.01, so ~0.2 false positives are
// expected in 20).
// ctest: skipped under sanitizers -- a loop of whole diagnoses over seeds, a statistic, not a memory question (tools/run-sanitizers.sh; tests/CMakeLists.txt)
#include <doctest/doctest.h>

#include <cmath>
#include <string>

#include "diagnose_test_common.hpp"
#include "diagnose_test_data.hpp"
#include "indicial/fitter/diagnose.hpp"

TEST_SUITE_BEGIN("statistical");  // the ctest label (tests/CMakeLists.txt)

using namespace indicial;
using namespace indicial::testing;

TEST_CASE("diagnose leaves a complete model alone on at least 19 of 20 seeds") {
  int clean = 0;
  double worst_log10_p = 0.0;  // the smallest best-candidate p of any seed's first round
  const std::vector<std::uint64_t> seeds =
      test_seeds({1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18, 19, 20}, 3);
  const int n_seeds = static_cast<int>(seeds.size());
  for (std::uint64_t seed : seeds) {
    double sigma = 0.0;
    const Experiment e = hidden_effect_experiment("tailless-model-1", "none", {}, 40.0, seed, &sigma);
    const DiagnoseResult d = diagnose_experiment(e, DiagnoseOptions{});
    REQUIRE(!d.rounds.empty());
    REQUIRE(!d.fits.empty());
    const DiagnoseRound& r = d.rounds.front();
    const double best = r.best >= 0 ? r.candidates[static_cast<std::size_t>(r.best)].log10_p : 0.0;
    worst_log10_p = std::min(worst_log10_p, best);
    MESSAGE("seed ", seed, ": verdict ", d.verdict, ", best candidate ",
            (r.best >= 0 ? r.candidates[static_cast<std::size_t>(r.best)].term : std::string("-")),
            " log10 p ", best, " (threshold log10 ", std::log10(r.threshold), "), fit error / sigma ",
            d.initial_fit_error / sigma);
    if (d.steps.empty() && d.verdict == "none") {
      ++clean;
      // The model is left alone: the final fit IS the configured one.
      CHECK(d.final_fit_error == d.initial_fit_error);
      CHECK(d.fits.size() == 1);
    }
    CHECK(std::abs(d.initial_fit_error / sigma - 1.0) < fit_error_ratio_tolerance(d.fits.front()));
  }
  MESSAGE("clean seeds: ", clean, " of ", n_seeds, "; smallest best-candidate log10 p ", worst_log10_p);
  CHECK(clean >= n_seeds - 1);  // 19 of 20 in the normal build
}
