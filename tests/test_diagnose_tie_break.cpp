// Diagnose's step among families within indistinguishable_bic of the best (diagnose.cpp
// choose_family): the fewest added parameters, then the lower BIC, then the registry's order
// only on an exact tie. The families here are the round summaries diagnose compares (effect,
// added parameters, delta BIC against the round's base), set so that the registry's order and
// the BIC disagree.
#include <doctest/doctest.h>

#include <algorithm>
#include <vector>

#include "diagnose/diagnose_internal.hpp"

using namespace indicial;
using indicial::diagnose_detail::choose_family;

namespace {

FamilyResult family(Effect e, int added_parameters, double delta_bic) {
  FamilyResult f;
  f.effect = e;
  f.added_parameters = added_parameters;
  f.delta_bic = delta_bic;
  return f;
}

bool named(const std::vector<Effect>& tied, Effect e) { return std::find(tied.begin(), tied.end(), e) != tied.end(); }

}  // namespace

TEST_CASE("diagnose tie-break: equal parameter counts -- the lower BIC, not the registry's order") {
  const DiagnoseOptions o;  // indistinguishable_bic 6
  // a_alpha comes before second_lag in the registry; second_lag has the lower BIC (2 apart,
  // inside the band). Either listing order gives second_lag.
  for (const bool registry_first : {true, false}) {
    std::vector<FamilyResult> fr = {family(Effect::a_alpha, 2, -40.0), family(Effect::second_lag, 2, -42.0)};
    if (!registry_first) std::reverse(fr.begin(), fr.end());
    std::vector<Effect> tied;
    const int w = choose_family(fr, o, tied);
    REQUIRE(w >= 0);
    CHECK(fr[static_cast<std::size_t>(w)].effect == Effect::second_lag);
    CHECK(tied == std::vector<Effect>{Effect::a_alpha});  // named with it
  }
}

TEST_CASE("diagnose tie-break: fewer parameters first, the registry's order only on an exact tie") {
  const DiagnoseOptions o;
  std::vector<Effect> tied;
  // Fewer parameters win inside the band even with a higher BIC.
  const std::vector<FamilyResult> fewer = {family(Effect::b1_alpha, 3, -50.0), family(Effect::time_delay, 1, -45.0),
                                           family(Effect::static_error, 1, -46.0)};
  const int w = choose_family(fewer, o, tied);
  REQUIRE(w >= 0);
  CHECK(fewer[static_cast<std::size_t>(w)].effect == Effect::static_error);  // 1 parameter, lower BIC
  CHECK(tied.size() == 2);
  CHECK(named(tied, Effect::b1_alpha));
  CHECK(named(tied, Effect::time_delay));
  // Outside the band the lowest BIC wins whatever its size, and nothing is tied.
  tied.clear();
  const std::vector<FamilyResult> apart = {family(Effect::bias, 1, -20.0), family(Effect::rotary_alpha, 3, -30.0)};
  const int a = choose_family(apart, o, tied);
  REQUIRE(a >= 0);
  CHECK(apart[static_cast<std::size_t>(a)].effect == Effect::rotary_alpha);
  CHECK(tied.empty());
  // An exact tie in both: the registry's order.
  tied.clear();
  const std::vector<FamilyResult> exact = {family(Effect::second_lag, 2, -42.0), family(Effect::a_alpha, 2, -42.0)};
  const int e = choose_family(exact, o, tied);
  REQUIRE(e >= 0);
  CHECK(exact[static_cast<std::size_t>(e)].effect == Effect::a_alpha);
  CHECK(tied == std::vector<Effect>{Effect::second_lag});
  // No families: no step.
  tied.clear();
  CHECK(choose_family({}, o, tied) == -1);
}
