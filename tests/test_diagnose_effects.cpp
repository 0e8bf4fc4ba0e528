// The effect registry's candidate generators (fitter/src/diagnose/diagnose_effects.cpp), called
// directly on a model configuration: which terms each offers. Whole diagnoses that name one
// hidden effect are test_diagnose_effects_a..d.cpp (statistical).
#include <doctest/doctest.h>

#include <algorithm>
#include <string>
#include <vector>

#include "diagnose/diagnose_internal.hpp"

TEST_SUITE_BEGIN("unit");  // the ctest label (tests/CMakeLists.txt)

using namespace indicial;
using namespace indicial::diagnose_detail;

namespace {

// The C_aq(x) powers rotary_alpha's generator offers against `model` (knot candidates left out:
// the knot grid is empty).
std::vector<int> offered_rotary_powers(const ModelConfig& model) {
  const Experiment e;
  const FitResult base;
  const std::vector<double> no_knots;
  const CandidateContext ctx{e, model, base, no_knots, 0.0};
  std::vector<CandidateSpec> out;
  effect_entry(Effect::rotary_alpha).generate(ctx, out);
  std::vector<int> powers;
  for (const CandidateSpec& c : out) {
    REQUIRE(c.effect == Effect::rotary_alpha);
    REQUIRE(!c.is_knot);
    // The candidate is the model plus exactly one power.
    const std::vector<int>& before = model.rotary_correction.powers;
    const std::vector<int>& after = c.config.rotary_correction.powers;
    REQUIRE(after.size() == before.size() + 1);
    for (int p : after)
      if (std::find(before.begin(), before.end(), p) == before.end()) powers.push_back(p);
  }
  return powers;
}

}  // namespace

TEST_CASE("diagnose effects: rotary_alpha offers C_aq's powers in order, x^0 first, one at a time") {
  // Why it matters: offering x^3 alone before x^0 let measured high-angle cycles name C_aq x^3,
  // a term that is zero in attached flow (the generator's comment, docs/validation-real.md).
  ModelConfig m;
  REQUIRE(m.rotary_correction.powers.empty());
  for (int p = 0; p < DefaultCapacity::max_powers; ++p) {
    INFO("the correction holds x^0..x^", p - 1);
    const std::vector<int> offered = offered_rotary_powers(m);
    REQUIRE(offered.size() == 1);
    CHECK(offered.front() == p);
    m.rotary_correction.powers.push_back(p);
  }
  // Full: no power left to offer.
  CHECK(offered_rotary_powers(m).empty());
}

TEST_CASE("diagnose effects: rotary_alpha fills the lowest missing power first") {
  ModelConfig m;
  m.rotary_correction.powers = {1, 2};  // e.g. from a configuration that wrote x^1, x^2 only
  CHECK(offered_rotary_powers(m) == std::vector<int>{0});
  m.rotary_correction.powers = {0, 2};
  CHECK(offered_rotary_powers(m) == std::vector<int>{1});
}
