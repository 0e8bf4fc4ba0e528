// Monte Carlo: do the Cramer-Rao bounds predict the scatter of the estimates? (issue 3)
#include <doctest/doctest.h>
#include <unistd.h>
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "cli_test_support.hpp"
#include "indicial/fitter/error.hpp"
#include "indicial/fitter/montecarlo.hpp"
#include "test_support.hpp"

namespace fs = std::filesystem;

namespace {

// Under ASan + UBSan (tools/run-sanitizers.sh defines INDICIAL_SANITIZED_BUILD) every fit is
// 10-20x slower, and that run checks memory safety and undefined behaviour, not statistics:
// the Monte Carlo loops run 20 seeds there and skip the ratio and bias checks, which 20 seeds
// cannot decide. The normal build (tools/run-tests.sh) runs all 200 and checks them.
enum class Statistics { checked, skipped };
#ifdef INDICIAL_SANITIZED_BUILD
constexpr int kSeeds = 20;
constexpr Statistics kStatistics = Statistics::skipped;
#else
constexpr int kSeeds = 200;
constexpr Statistics kStatistics = Statistics::checked;
#endif

TEST_SUITE_BEGIN("cli");  // the ctest label (tests/CMakeLists.txt)

using indicial::testing::slurp;

// kSeeds seeds of `case_name` at SNR 40 from first_seed; checks that every seed was fitted
// and, when the statistics are checked, that every parameter's empirical std / mean CR bound
// lies in [0.8, 1.25]. Returns the result for further checks.
indicial::MonteCarloResult check_cr_bounds(const char* case_name, std::uint64_t first_seed,
                                           std::size_t min_parameters) {
  indicial::MonteCarloOptions o;
  o.case_name = case_name;
  o.seeds = kSeeds;
  o.first_seed = first_seed;
  o.snr = 40.0;
  o.threads = 2;
  const indicial::MonteCarloResult r = indicial::run_monte_carlo(o);
  MESSAGE(indicial::monte_carlo_markdown(r));
  CHECK(r.fitted == kSeeds);
  CHECK(r.failed_seeds.empty());
  REQUIRE(r.parameters.size() >= min_parameters);
  for (const auto& p : r.parameters) {
    CAPTURE(p.name);
    CAPTURE(p.std_dev);
    CAPTURE(p.mean_cr_bound);
    CHECK(p.count == kSeeds);
    if (kStatistics == Statistics::skipped) continue;
    CHECK(p.ratio >= 0.8);
    CHECK(p.ratio <= 1.25);
  }
  return r;
}

}  // namespace

// Issue-3 acceptance check: over at least 200 seeds of white-noise data (Model I, SNR 40), the
// empirical standard deviation of every estimate lies within [0.8, 1.25] of its mean Cramer-Rao
// bound. Seeds 1001..1200 were not used to tune anything.
TEST_CASE("Monte Carlo, Model I, SNR 40, 200 seeds: empirical std / mean CR bound in [0.8, 1.25]") {
  const indicial::MonteCarloResult r = check_cr_bounds("tailless-model-1", 1001, 9);  // a0 a1 a2 A1 A2 b1_0 y0_1..3
  if (kStatistics == Statistics::skipped) return;
  for (const auto& p : r.parameters) {
    // The estimator is (nearly) unbiased: the mean lies within a few of its standard errors of
    // the truth, or within a small fraction of one CR bound (the second-order discrete update's
    // bias, fit.hpp warning 4).
    CAPTURE(p.name);
    REQUIRE(std::isfinite(p.truth));
    CHECK(std::fabs(p.mean - p.truth) < std::max(4.0 * p.std_dev / std::sqrt(double(kSeeds)), 0.5 * p.mean_cr_bound));
  }
  // s(v) = sqrt(SSR / N) estimates the noise standard deviation with the ML bias -p / 2N = -0.21 %
  // (p = 9 parameters, N = 1201 + 601 + 301 samples) and, as a mean over the seeds, a relative
  // standard error 1 / sqrt(2 N seeds) = 0.11 %: 4 standard errors about the biased mean
  // (measured -0.19 %). The former Approx(sigma).epsilon(0.05), at doctest's default scale 1,
  // was an absolute 0.05: 14 noise sigmas.
  const double n_samples = 1201 + 601 + 301;
  const double expected_ratio = 1.0 - 9.0 / (2.0 * n_samples);
  INFO("mean s(v) / sigma " << r.mean_fit_error / r.noise_sigma << ", expected " << expected_ratio);
  CHECK(std::fabs(r.mean_fit_error / r.noise_sigma - expected_ratio) < 4.0 / std::sqrt(2.0 * n_samples * kSeeds));
}

// The same check on Model II (b1(alpha) a spline with four knots: 13 parameters).
TEST_CASE("Monte Carlo, Model II, SNR 40, 200 seeds: empirical std / mean CR bound in [0.8, 1.25]") {
  check_cr_bounds("tailless-model-2", 2001, 13);
}

// Issue 12, Done-when: on AR(1) colored noise (phi 0.8) the colored-residual bound predicts the
// scatter of the estimates, and the white Cramer-Rao bound does not. The full tables (both
// models, turbulence too) are in docs/validation-realistic.md (tools/validate-realistic.sh).
TEST_CASE("Monte Carlo, AR(1) noise phi 0.8: std / colored bound in [0.8, 1.25], white bounds 2-4x too small") {
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
  REQUIRE(r.parameters.size() >= 9);  // a0 a1 a2 A1 A2 b1_0 y0_1..3: the loop checks each
  for (const auto& p : r.parameters) {
    CAPTURE(p.name);
    CHECK(p.ratio_colored >= 0.8);
    CHECK(p.ratio_colored <= 1.25);
    // sqrt((1 + phi) / (1 - phi)) = 3 is the inflation of a mean's std under AR(1) noise.
    CHECK(p.ratio > 2.0);
    CHECK(p.ratio < 4.0);
  }
}

TEST_CASE("results do not depend on the thread count") {
  indicial::MonteCarloOptions o;
  o.seeds = 6;
  o.first_seed = 77;
  o.threads = 1;
  const auto one = indicial::run_monte_carlo(o);
  o.threads = 2;
  const auto two = indicial::run_monte_carlo(o);
  CHECK(one.fitted == 6);
  REQUIRE(one.parameters.size() >= 9);  // the loop below compares something
  REQUIRE(one.parameters.size() == two.parameters.size());
  for (std::size_t i = 0; i < one.parameters.size(); ++i) {
    CHECK(one.parameters[i].name == two.parameters[i].name);
    CHECK(one.parameters[i].mean == two.parameters[i].mean);
    CHECK(one.parameters[i].std_dev == two.parameters[i].std_dev);
  }
}

TEST_CASE("bad options are refused") {
  // The refusal itself (an InputError naming the option), not any exception: a crash-like
  // std::exception from inside the fits would have passed a bare CHECK_THROWS.
  auto refusal = [](const indicial::MonteCarloOptions& opt) -> std::string {
    try {
      indicial::run_monte_carlo(opt);
    } catch (const indicial::InputError& e) {
      return e.what();
    }
    return "no InputError";
  };
  indicial::MonteCarloOptions o;
  o.seeds = 1;
  CHECK(refusal(o).find("--seeds") != std::string::npos);
  o.seeds = 4;
  o.case_name = "no-such-case";
  CHECK(refusal(o).find("unknown case 'no-such-case'") != std::string::npos);
  o.case_name = "tailless-model-1";
  o.snr = std::numeric_limits<double>::infinity();
  CHECK(refusal(o).find("--snr") != std::string::npos);
}

TEST_CASE("the montecarlo command writes montecarlo.json and .md, with progress lines on a non-tty") {
  const indicial::testing::TempDir scratch("montecarlo");
  const fs::path& dir = scratch.path;
  const indicial::testing::CliRun r = indicial::testing::run_indicial(
      "montecarlo --case tailless-model-1 --seeds 10 --snr 40 --first-seed 5 --threads 2 --out '" +
          (dir / "mc").string() + "'",
      dir);
  CHECK(r.exit_code == 0);
  const std::string& err = r.err;
  CHECK(err.find("montecarlo: 100% (10/10 seeds") != std::string::npos);
  CHECK(err.find('\r') == std::string::npos);  // no live counter when stderr is a file
  const nlohmann::json j = nlohmann::json::parse(slurp(dir / "mc" / "montecarlo.json"));
  CHECK(j["seeds"] == 10);
  CHECK(j["fitted"] == 10);
  REQUIRE(j["parameters"].is_array());
  for (const auto& p : j["parameters"]) {
    CHECK(p["std"].is_number());
    CHECK(p["mean_cr_bound"].is_number());
    CHECK(p["mean_cr_bound_colored"].is_number());
    CHECK(p["ratio_std_to_cr"].is_number());
  }
  CHECK(slurp(dir / "mc" / "montecarlo.md").find("| b1_0 |") != std::string::npos);
  // A second run into the same directory is refused without --force.
  CHECK(indicial::testing::run_indicial("montecarlo --case tailless-model-1 --seeds 2 --out '" + (dir / "mc").string() + "'",
                                        dir).exit_code == 1);
}
