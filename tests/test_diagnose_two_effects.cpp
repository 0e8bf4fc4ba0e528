// Diagnose with two hidden effects at once (b1_alpha and bias): both found, in either order,
// and the final fit error at the noise level. Data from the reference simulator, SNR 40.
// ctest: skipped under sanitizers -- two seeds of a multi-step diagnose, minutes under ASan; test_diagnose_effects_a and test_cmd_diagnose run diagnose there (tools/run-sanitizers.sh; tests/CMakeLists.txt)
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "diagnose_test_common.hpp"

TEST_SUITE_BEGIN("statistical");  // the ctest label (tests/CMakeLists.txt)

using namespace indicial;
using namespace indicial::testing;

namespace {
bool contains(const std::vector<std::string>& v, const std::string& s) {
  return std::find(v.begin(), v.end(), s) != v.end();
}
}  // namespace

TEST_CASE("diagnose finds two hidden effects at once: b1_alpha and bias") {
  const TruthModifier both = [](TruthCoefficient& m) {
    hidden_effect("b1_alpha")(m);
    hidden_effect("bias")(m);
  };
  for (std::uint64_t seed : test_seeds({201u, 202u})) {
    double sigma = 0.0;
    const Experiment e = hidden_effect_experiment("tailless-model-1", "b1+bias", both, 40.0, seed, &sigma);
    const DiagnoseResult d = diagnose_experiment(e, DiagnoseOptions{});
    std::string order;
    for (const auto& s : d.effects_added) order += s + " ";
    MESSAGE("seed ", seed, ": effects ", order, "initial/sigma ", d.initial_fit_error / sigma,
            " final/sigma ", d.final_fit_error / sigma);
    CHECK(contains(d.effects_added, "b1_alpha"));
    CHECK(contains(d.effects_added, "bias"));
    CHECK(std::abs(d.final_fit_error / sigma - 1.0) < fit_error_ratio_tolerance(d.fits.back()));
  }
}

