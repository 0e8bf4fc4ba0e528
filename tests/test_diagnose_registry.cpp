// The diagnose effect registry (fitter/src/diagnose/diagnose_effects.cpp): one entry per Effect
// in the enum's order, each named and described, and its `extends` (EffectDescription) true to
// what the effect's candidates change: a report-model effect leaves the dynamic-stall families'
// configuration alone, a stall-family effect changes it and is offered only where a lift polar
// runs through stall (tests/diagnose_test_matrix.hpp leaves the stall-family effects out by it).
#include <doctest/doctest.h>

#include <set>
#include <string>
#include <vector>

#include "diagnose/diagnose_internal.hpp"
#include "diagnose_polar_model.hpp"

TEST_SUITE_BEGIN("unit");  // the ctest label (tests/CMakeLists.txt)

using namespace indicial;
using namespace indicial::diagnose_detail;

namespace {

// The dynamic-stall configuration a candidate could change: the families and their structure,
// the polar they stand on, the parameters held known.
bool same_families(const StallConfig& a, const StallConfig& b) {
  return a.families == b.families && a.reattachment == b.reattachment && a.forcing_lag == b.forcing_lag &&
         a.hysteresis == b.hysteresis && a.lag_limit == b.lag_limit &&
         a.polar_x_rad == b.polar_x_rad && a.polar_lift == b.polar_lift && a.known == b.known;
}

// The effects of every candidate offered against `model`, each checked against its entry.
std::set<Effect> offered(const ModelConfig& model) {
  const Experiment e;
  const FitResult base;
  const std::vector<double> grid = {0.1, 0.2};
  std::set<Effect> effects;
  for (const CandidateSpec& c : all_candidates(CandidateContext{e, model, base, grid, 0.1})) {
    const EffectDescription& d = effect_descriptions()[static_cast<std::size_t>(c.effect)];
    INFO(d.name, ": ", c.term);
    CHECK(same_families(c.config.stall, model.stall) == (d.extends == EffectExtends::report_model));
    effects.insert(c.effect);
  }
  return effects;
}

std::set<Effect> extending(EffectExtends x) {
  std::set<Effect> out;
  for (const EffectDescription& d : effect_descriptions())
    if (d.extends == x) out.insert(d.effect);
  return out;
}

}  // namespace

TEST_CASE("diagnose registry: one described entry per effect, in the enum's order") {
  REQUIRE(effect_descriptions().size() == static_cast<std::size_t>(effect_count));
  std::set<std::string> names;
  for (std::size_t i = 0; i < effect_descriptions().size(); ++i) {
    const EffectDescription& d = effect_descriptions()[i];
    CHECK(static_cast<std::size_t>(d.effect) == i);
    CHECK(std::string(effect_name(d.effect)) == d.name);
    for (const char* text : {d.description, d.written_as, d.signature, d.separated_by})
      CHECK_FALSE(std::string(text).empty());
    names.insert(d.name);
  }
  CHECK(names.size() == effect_descriptions().size());
  // The stall-family effects come last (the enum's comment).
  bool stall_seen = false;
  for (const EffectDescription& d : effect_descriptions()) {
    if (d.extends == EffectExtends::stall_families) stall_seen = true;
    CHECK((d.extends == EffectExtends::stall_families) == stall_seen);
  }
}

TEST_CASE("diagnose registry: an effect's extends says what its candidates change and where they are offered") {
  const std::set<Effect> report = extending(EffectExtends::report_model);
  const std::set<Effect> stall = extending(EffectExtends::stall_families);
  CHECK(stall == std::set<Effect>{Effect::separation_lag, Effect::vortex_shedding, Effect::slow_reattachment,
                                  Effect::pressure_lag, Effect::static_hysteresis, Effect::lag_limit});
  // No polar: only report-model effects (every one of them has a candidate here).
  CHECK(offered(ModelConfig{}) == report);
  // A polar through stall: the families are offered too.
  ModelConfig model = testing::model_with_polar();
  std::set<Effect> with_polar = offered(model);
  CHECK(with_polar.count(Effect::separation_lag) == 1);
  CHECK(with_polar.count(Effect::vortex_shedding) == 1);
  // With the separation family: its refinements (slower reattachment, the lagged forcing).
  model.stall.families = StallFamilies::separation;
  const std::set<Effect> with_families = offered(model);
  CHECK(with_families.count(Effect::slow_reattachment) == 1);
  CHECK(with_families.count(Effect::pressure_lag) == 1);
  CHECK(with_families.count(Effect::static_hysteresis) == 1);
  CHECK(with_families.count(Effect::lag_limit) == 1);
  // With the hysteresis already estimated it is not offered again.
  model.stall.hysteresis = StallHysteresis::estimated;
  CHECK(offered(model).count(Effect::static_hysteresis) == 0);
  // The lag limit acts on the delay form only, and excludes the first-order form's candidate.
  model.stall.lag_limit = StallLagLimit::estimated;
  CHECK(offered(model).count(Effect::lag_limit) == 0);
  CHECK(offered(model).count(Effect::pressure_lag) == 0);
  model.stall.lag_limit = StallLagLimit::none;
  model.stall.forcing_lag = ForcingLag::first_order;
  CHECK(offered(model).count(Effect::lag_limit) == 0);
}

// The lag limit's candidate starts D twice from the current estimates: at its configured start
// and near the model without it (kLagLimitNestedStartRad, the fit's nested trial), so that its
// best fit does not end far above the model it extends (diagnose_effects.cpp, gen_lag_limit).
TEST_CASE("diagnose registry: the lag limit is started at its configured start and near the model without it") {
  ModelConfig model = testing::model_with_polar();
  model.stall.families = StallFamilies::separation;
  model.stall.lag_limit_start_rad = 0.05;
  const Experiment e;
  const FitResult base;
  const std::vector<double> grid = {0.1, 0.2};
  int seen = 0;
  for (const CandidateSpec& c : all_candidates(CandidateContext{e, model, base, grid, 0.1})) {
    if (c.effect != Effect::lag_limit) continue;
    ++seen;
    const ParamId d = param_id(ParamKind::stall_lag_limit);
    REQUIRE(c.starts.size() == 2);
    std::vector<double> values;
    for (const StartValues& s : c.starts) {
      REQUIRE(s.size() == 1);
      CHECK(s[0].first == d);
      values.push_back(s[0].second);
    }
    CHECK(values == std::vector<double>{0.05, kLagLimitNestedStartRad});
  }
  CHECK(seen == 1);
}
