// Where diagnose's candidate fits start (diagnose_internal.hpp: candidate_starts,
// best_usable_fit): every candidate from the current model's estimates; a dynamic-stall
// candidate also from the fitter's own start (StartFrom::current_and_own), the better fit kept.
// Why the own start: on measured C_m cycles the warm start kept the current model's degenerate
// lag (b1 -> 0) and ended at 0.0566, where the fitter's own start ends at 0.0500. No synthetic
// case reproduces that degenerate start, so the mechanism is tested here, with fits made up.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "diagnose/diagnose_internal.hpp"
#include "diagnose_polar_model.hpp"
#include "indicial/fitter/error.hpp"
#include "indicial/fitter/predict.hpp"

TEST_SUITE_BEGIN("unit");  // the ctest label (tests/CMakeLists.txt)

using namespace indicial;
using namespace indicial::diagnose_detail;
using indicial::testing::model_with_polar;

namespace {

bool is_stall(Effect e) { return e == Effect::separation_lag || e == Effect::vortex_shedding; }

// A fit of error `fit_error` whose model the runtime accepts (Model I's example file).
FitResult made_up_fit(double fit_error) {
  static const ModelSet<double, FitCapacity> model =
      read_model_file(std::string(INDICIAL_SOURCE_DIR) + "/examples/tailless-model-1.coef");
  FitResult r;
  r.model = model;
  r.fit_error = fit_error;
  return r;
}

}  // namespace

TEST_CASE("diagnose starts: stall candidates from the current estimates and the own start, others from the current") {
  // A model with a lift polar (stall candidates are offered) and a knot grid (knot candidates).
  ModelConfig model = model_with_polar();
  const Experiment e;
  const FitResult base;
  const std::vector<double> grid = {0.1, 0.2};
  const std::vector<CandidateSpec> specs = all_candidates(CandidateContext{e, model, base, grid, 0.1});
  const ParamId b1_0 = param_id(ParamKind::b_power, 0, 0);
  const Estimates current = {{b1_0, 12.0}};
  int stall = 0;
  for (const CandidateSpec& c : specs) {
    INFO(std::string(effect_name(c.effect)), ": ", c.term);
    const std::vector<StartValues> starts = candidate_starts(c, current, 2);
    const std::size_t from_current = std::max<std::size_t>(1, c.starts.size());
    REQUIRE(starts.size() == from_current + (is_stall(c.effect) ? 1 : 0));
    // The first starts carry the current model's b1_0; the own start carries nothing.
    for (std::size_t i = 0; i < from_current; ++i)
      CHECK(std::find(starts[i].begin(), starts[i].end(), std::make_pair(b1_0, 12.0)) != starts[i].end());
    if (is_stall(c.effect)) {
      CHECK(starts.back().empty());
      ++stall;
    }
  }
  CHECK(stall == 2);  // separation_lag and vortex_shedding
}

TEST_CASE("diagnose starts: the usable fit of lowest error is kept, whichever start gave it") {
  const ParamId b1_0 = param_id(ParamKind::b_power, 0, 0);
  const StartValues warm = {{b1_0, 1e-5}};  // the degenerate current lag
  const StartValues own;                    // the fitter's own start
  // The measured case: the warm start ends at 0.0566, the own start at 0.0500.
  const StartFit fit = [&](const StartValues& sv) { return made_up_fit(sv.empty() ? 0.0500 : 0.0566); };
  for (const std::vector<StartValues>& starts : {std::vector<StartValues>{warm, own}, std::vector<StartValues>{own, warm}}) {
    const CandidateFit best = best_usable_fit(starts, fit);
    REQUIRE(best.status == CandidateStatus::fitted);
    CHECK(best.fit.fit_error == 0.0500);
    CHECK(best.message.empty());
  }
  // A lower error that is not usable is not kept: rank deficient, non-finite, or thrown.
  const StartValues other = {{b1_0, 3.0}};
  for (int bad = 0; bad < 3; ++bad) {
    const StartFit with_bad = [&](const StartValues& sv) {
      if (sv == other) {
        if (bad == 2) throw InputError("made-up failure");
        FitResult r = made_up_fit(bad == 0 ? 0.0100 : std::nan(""));
        if (bad == 0) r.output_error.termination = Termination::rank_deficient;
        return r;
      }
      return fit(sv);
    };
    const CandidateFit best = best_usable_fit({warm, other, own}, with_bad);
    INFO("bad start kind ", bad);
    REQUIRE(best.status == CandidateStatus::fitted);
    CHECK(best.fit.fit_error == 0.0500);
  }
}

TEST_CASE("diagnose starts: slow_reattachment on a model with the families, started at T1r = T1") {
  ModelConfig model = model_with_polar();
  const Experiment e;
  FitResult base;
  ParameterEstimate t1;
  t1.id = param_id(ParamKind::stall_tau1);
  t1.value = 4.25;
  base.parameters.push_back(t1);
  const std::vector<double> grid = {0.1, 0.2};
  // Without the families: not offered (nothing to reattach).
  {
    const std::vector<CandidateSpec> specs = all_candidates(CandidateContext{e, model, base, grid, 0.1});
    CHECK(std::none_of(specs.begin(), specs.end(), [](const CandidateSpec& c) { return c.effect == Effect::slow_reattachment; }));
  }
  model.stall.families = StallFamilies::separation;
  const std::vector<CandidateSpec> specs = all_candidates(CandidateContext{e, model, base, grid, 0.1});
  const auto it = std::find_if(specs.begin(), specs.end(),
                               [](const CandidateSpec& c) { return c.effect == Effect::slow_reattachment; });
  REQUIRE(it != specs.end());
  CHECK(it->config.stall.reattachment == StallReattachment::estimated);
  const std::vector<StartValues> starts = candidate_starts(*it, {{t1.id, 4.25}}, 1);
  REQUIRE(starts.size() == 1);
  const ParamId t1r = param_id(ParamKind::stall_tau1_reattach);
  CHECK(std::find(starts[0].begin(), starts[0].end(), std::make_pair(t1r, 4.25)) != starts[0].end());
  // T1 held by stall_known (a C_m taking the C_L fit's T1): T1r starts at the held value.
  ModelConfig held = model;
  held.stall.known = {{"T1", 5.5}};
  const std::vector<CandidateSpec> held_specs = all_candidates(CandidateContext{e, held, base, grid, 0.1});
  const auto h = std::find_if(held_specs.begin(), held_specs.end(),
                              [](const CandidateSpec& c) { return c.effect == Effect::slow_reattachment; });
  REQUIRE(h != held_specs.end());
  const std::vector<StartValues> held_starts = candidate_starts(*h, {}, 1);
  REQUIRE(held_starts.size() == 1);
  CHECK(std::find(held_starts[0].begin(), held_starts[0].end(), std::make_pair(t1r, 5.5)) != held_starts[0].end());
  // Already estimated: not offered again.
  ModelConfig has = model;
  has.stall.reattachment = StallReattachment::estimated;
  const std::vector<CandidateSpec> has_specs = all_candidates(CandidateContext{e, has, base, grid, 0.1});
  CHECK(std::none_of(has_specs.begin(), has_specs.end(),
                     [](const CandidateSpec& c) { return c.effect == Effect::slow_reattachment; }));
}

// The measured case (docs/validation-real.md `means` C_m): from its configured starts the
// vortex candidate ended at 0.0680, above its base's 0.0568, a local minimum of a model that
// nests the base; it is then fitted again from the start grid.
TEST_CASE("diagnose starts: a stall candidate not below its base is refitted from the start grid") {
  const FitResult base = made_up_fit(0.0568);
  CandidateFit above;
  above.status = CandidateStatus::fitted;
  above.fit = made_up_fit(0.0680);
  CandidateFit below = above;
  below.fit.fit_error = 0.0400;
  CandidateFit failed;  // no usable start
  const StallStartSearch configured = StallStartSearch::configured, grid = StallStartSearch::grid;
  for (Effect effect : {Effect::separation_lag, Effect::vortex_shedding}) {
    INFO(effect_name(effect));
    CHECK(stall_grid_retry_needed(effect, above, base, configured));
    CHECK(stall_grid_retry_needed(effect, failed, base, configured));
    CHECK_FALSE(stall_grid_retry_needed(effect, below, base, configured));
    CHECK_FALSE(stall_grid_retry_needed(effect, above, base, grid));  // the grid already ran
  }
  CandidateFit equal = above;
  equal.fit.fit_error = base.fit_error;  // at the base: no better than it, retried
  CHECK(stall_grid_retry_needed(Effect::vortex_shedding, equal, base, configured));
  for (Effect effect : {Effect::b1_alpha, Effect::time_delay, Effect::slow_reattachment})
    CHECK_FALSE(stall_grid_retry_needed(effect, above, base, configured));
}

// pressure_lag swaps the delay form of the separation forcing for the first-order lag
// (model.hpp ForcingLag): offered only on a model with the families in the delay form, the
// configuration otherwise the model's own, started from the current estimates (T2 included:
// it adds no parameter).
TEST_CASE("diagnose starts: pressure_lag on a model with the families in the delay form, from the current T2") {
  ModelConfig model = model_with_polar();
  const Experiment e;
  const FitResult base;
  const std::vector<double> grid = {0.1, 0.2};
  auto pressure_lag = [&](const ModelConfig& m) {
    const std::vector<CandidateSpec> specs = all_candidates(CandidateContext{e, m, base, grid, 0.1});
    const auto it = std::find_if(specs.begin(), specs.end(),
                                 [](const CandidateSpec& c) { return c.effect == Effect::pressure_lag; });
    return it == specs.end() ? std::optional<CandidateSpec>{} : std::optional<CandidateSpec>{*it};
  };
  CHECK_FALSE(pressure_lag(model).has_value());  // no families: nothing is forced
  for (StallFamilies f : {StallFamilies::separation, StallFamilies::separation_and_vortex}) {
    model.stall.families = f;
    model.stall.reattachment = StallReattachment::estimated;
    const std::optional<CandidateSpec> c = pressure_lag(model);
    REQUIRE(c.has_value());
    CHECK(c->config.stall.forcing_lag == ForcingLag::first_order);
    ModelConfig same = c->config;  // nothing else changed
    same.stall.forcing_lag = ForcingLag::delay;
    CHECK(same.stall.polar_lift == model.stall.polar_lift);
    CHECK(same.stall.families == f);
    CHECK(same.stall.reattachment == StallReattachment::estimated);
    const ParamId t2 = param_id(ParamKind::stall_tau2);
    const std::vector<StartValues> starts = candidate_starts(*c, {{t2, 1.75}}, 1);
    REQUIRE(starts.size() == 1);
    CHECK(std::find(starts[0].begin(), starts[0].end(), std::make_pair(t2, 1.75)) != starts[0].end());
  }
  model.stall.forcing_lag = ForcingLag::first_order;  // already the lag: not offered
  CHECK_FALSE(pressure_lag(model).has_value());
}
