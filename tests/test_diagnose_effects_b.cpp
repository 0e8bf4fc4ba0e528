// Diagnose, one hidden effect at a time (rotary_alpha and bias): data from the reference simulator
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

TEST_CASE("diagnose names a hidden C_mq(alpha) term: rotary_alpha") { check_effect_on_model_1("rotary_alpha"); }

TEST_CASE("diagnose names a hidden state-equation constant: bias") {
  for (std::uint64_t seed : test_seeds({101u, 102u, 103u})) {
    const DiagnoseResult d = check_single_effect("tailless-model-1", "bias", hidden_effect("bias"), seed);
    // scale(0): relative to the value (doctest's default scale 1 would pass any con in +-0.1).
    CHECK(final_estimate(d, ParamKind::con) == doctest::Approx(0.025).epsilon(0.1).scale(0.0));
  }
}
