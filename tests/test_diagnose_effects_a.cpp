// Diagnose, one hidden effect at a time (b1_alpha and a_alpha): data from the reference simulator
// (SNR 40, several seeds), Model I structure with the right static and rotary terms (or the
// lateral case's own configuration); see diagnose_test_common.hpp for the checks.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>

#include "diagnose_test_common.hpp"

TEST_SUITE_BEGIN("statistical");  // the ctest label (tests/CMakeLists.txt)

using namespace indicial;
using namespace indicial::testing;

TEST_CASE("diagnose names a hidden b1(alpha) knot: b1_alpha") {
  for (std::uint64_t seed : test_seeds({101u, 102u, 103u})) {
    const DiagnoseResult d =
        check_single_effect("tailless-model-1", "b1_alpha", hidden_effect("b1_alpha"), seed);
    // The knot is found at the truth's 30 deg (the grid's spacing is 5 deg).
    CHECK(d.steps.front().detail.find("30.00 deg") != std::string::npos);
  }
}

// Skipped under ASan/UBSan: the same diagnose as the b1_alpha case above (every candidate, a(x)
// knots included, is fitted in each), ~120 s there for no code path the other does not run.
TEST_CASE("diagnose names a hidden a(alpha) knot: a_alpha" * doctest::skip(kSanitizedBuild)) {
  check_effect_on_model_1("a_alpha");
}
