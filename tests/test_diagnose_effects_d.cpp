// Diagnose, one hidden effect at a time (static_error; and the lateral axes: a delay in roll, a constant in yaw): data from the reference simulator
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

TEST_CASE("diagnose names a hidden static-curve error: static_error") {
  for (std::uint64_t seed : test_seeds({101u, 102u, 103u}))
    check_single_effect("tailless-model-1", "static_error", hidden_effect("static_error"), seed);
}

TEST_CASE("diagnose on roll data: a hidden delay of the forcing") {
  const TruthModifier delay = [](TruthCoefficient& m) { m.delay_s = 0.03; };
  for (std::uint64_t seed : test_seeds({301u, 302u}))
    check_single_effect("lateral-roll-Cl", "time_delay", delay, seed);
}

TEST_CASE("diagnose on yaw data: a hidden state-equation constant") {
  const TruthModifier bias = [](TruthCoefficient& m) { m.con = 0.02; };
  for (std::uint64_t seed : test_seeds({301u, 302u})) check_single_effect("lateral-yaw-Cn", "bias", bias, seed);
}
