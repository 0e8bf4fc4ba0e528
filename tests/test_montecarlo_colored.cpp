// Monte Carlo on AR(1) colored noise (issue 12, Done-when): the colored-residual bound predicts
// the scatter of the estimates; the white Cramer-Rao bound does not. docs/validation-realistic.md
// has the full tables (tools/validate-realistic.sh).
#include <doctest/doctest.h>

#include <cmath>

#include "indicial/fitter/montecarlo.hpp"

namespace {

// Same policy as tests/test_montecarlo.cpp: the sanitizer build runs a few seeds and checks
// memory safety, not statistics.
enum class Statistics { checked, skipped };
#ifdef INDICIAL_SANITIZED_BUILD
constexpr int kSeeds = 20;
constexpr Statistics kStatistics = Statistics::skipped;
#else
constexpr int kSeeds = 200;
constexpr Statistics kStatistics = Statistics::checked;
#endif

}  // namespace

TEST_CASE("Monte Carlo, AR(1) noise phi 0.8: std / colored bound in [0.8, 1.25]; white bounds 2-4x too small") {
  indicial::MonteCarloOptions o;
  o.case_name = "tailless-model-1";
  o.seeds = kSeeds;
  o.first_seed = 5001;
  o.snr = 40.0;
  o.noise = indicial::parse_noise_spec("ar1:phi=0.8");
  o.threads = 2;
  const indicial::MonteCarloResult r = indicial::run_monte_carlo(o);
  MESSAGE(indicial::monte_carlo_markdown(r));
  CHECK(r.fitted == kSeeds);
  if (kStatistics == Statistics::skipped) return;
  for (const auto& p : r.parameters) {
    CAPTURE(p.name);
    CHECK(p.ratio_colored >= 0.8);
    CHECK(p.ratio_colored <= 1.25);
    // sqrt((1 + phi) / (1 - phi)) = 3 is the inflation of a mean's variance under AR(1) noise.
    CHECK(p.ratio > 2.0);
    CHECK(p.ratio < 4.0);
  }
}
