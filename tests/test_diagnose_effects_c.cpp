// Diagnose, one hidden effect at a time (time_delay and second_lag): data from the reference simulator
// (SNR 40, several seeds), Model I structure with the right static and rotary terms (or the
// lateral case's own configuration); see diagnose_test_common.hpp for the checks.
// ctest: skipped under sanitizers -- single-effect diagnoses like test_diagnose_effects_a, which runs under the sanitizers (tools/run-sanitizers.sh; tests/CMakeLists.txt)
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>

#include "diagnose_test_common.hpp"

TEST_SUITE_BEGIN("statistical");  // the ctest label (tests/CMakeLists.txt)

using namespace indicial;
using namespace indicial::testing;

TEST_CASE("diagnose names a hidden pure delay: time_delay, and estimates it") {
  for (std::uint64_t seed : test_seeds({101u, 102u, 103u})) {
    const DiagnoseResult d =
        check_single_effect("tailless-model-1", "time_delay", hidden_effect("time_delay"), seed);
    // scale(0): relative to the value (doctest's default scale 1 would pass any delay in +-0.1 s).
    CHECK(final_estimate(d, ParamKind::delay) == doctest::Approx(0.02).epsilon(0.1).scale(0.0));
  }
}

TEST_CASE("diagnose names a hidden second lag: second_lag") {
  for (std::uint64_t seed : test_seeds({101u, 102u, 103u})) {
    const DiagnoseResult d =
        check_single_effect("tailless-model-1", "second_lag", hidden_effect("second_lag"), seed);
    // With constant b1 the two lags may come out in either order: (b1, b2, c2) and
    // (b2, b1, 1/c2) with a(x) scaled by c2 are the same model. The time constants agree as a
    // set, and the second lag's share of the forcing (c2 / (1 + c2) of the fast one) too.
    const double b1 = final_estimate(d, ParamKind::b_power, 0, 0);
    const double b2 = final_estimate(d, ParamKind::b_power, 1, 0);
    const double c2 = final_estimate(d, ParamKind::gain, 1);
    CHECK(std::min(b1, b2) == doctest::Approx(2.5).epsilon(0.1).scale(0.0));
    CHECK(std::max(b1, b2) == doctest::Approx(20.0).epsilon(0.3).scale(0.0));
    const double fast_share = b2 > b1 ? c2 / (1.0 + c2) : 1.0 / (1.0 + c2);
    CHECK(fast_share == doctest::Approx(0.5 / 1.5).epsilon(0.3).scale(0.0));
  }
}
