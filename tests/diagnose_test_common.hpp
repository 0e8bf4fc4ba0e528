// diagnose_test_common.hpp -- the check every single-effect diagnose test makes.
#pragma once

#include <doctest/doctest.h>

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "diagnose_test_data.hpp"
#include "fit_test_data.hpp"
#include "indicial/fitter/diagnose.hpp"

namespace indicial::testing {


// Data with the hidden `effect` of hidden_effect() on `case_name`, SNR 40, `seed`; runs
// diagnose and checks: the configured model's fit error is at least twice the noise (the
// effect is sized as the issue asks), the first step names the effect, the final fit error is
// within 15 % of the true noise level, and so is the white-equivalent noise estimate from the
// initial residuals. Returns the result for further checks.
inline DiagnoseResult check_single_effect(const std::string& case_name, const std::string& effect,
                                          const TruthModifier& modify, std::uint64_t seed) {
  double sigma = 0.0;
  const Experiment e = hidden_effect_experiment(case_name, effect, modify, 40.0, seed, &sigma);
  const DiagnoseResult d = diagnose_experiment(e, DiagnoseOptions{});
  INFO(case_name, " hidden ", effect, " seed ", seed, ": sigma ", sigma, " initial ",
       d.initial_fit_error, " final ", d.final_fit_error, " noise estimate ", d.noise.sigma, " (white-equivalent ", d.noise.white_equivalent, ")",
       " verdict ", d.verdict);
  MESSAGE(effect, " seed ", seed, ": initial/sigma ", d.initial_fit_error / sigma,
          ", final/sigma ", d.final_fit_error / sigma, ", noise est/sigma ", d.noise.sigma / sigma,
          ", steps ", d.steps.size(),
          (d.steps.empty() ? std::string() : ", first LR " + std::to_string(d.steps[0].statistic) +
                                                 " log10 p " + std::to_string(d.steps[0].log10_p) +
                                                 " (" + d.steps[0].detail + ")"),
          ", ", d.elapsed_s, " s");
  CHECK(d.initial_fit_error >= 2.0 * sigma);
  REQUIRE(!d.steps.empty());
  CHECK(std::string(effect_name(d.steps.front().effect)) == effect);
  CHECK(d.verdict == effect);
  CHECK(std::abs(d.final_fit_error / sigma - 1.0) < fit_error_ratio_tolerance(d.fits.back()));
  // White noise: the white-equivalent level is the noise level; the marginal (AR(1)) level
  // may read a large smooth model error as correlation, never much below the noise.
  CHECK(std::abs(d.noise.white_equivalent / sigma - 1.0) < 0.15);
  CHECK(d.noise.sigma / sigma > 0.85);
  // Each step lowers the fit error; the p-values pass their Bonferroni thresholds.
  for (const DiagnoseStep& s : d.steps) {
    CHECK(s.fit_error_after < s.fit_error_before);
    CHECK(s.p_value < s.threshold);
    CHECK(s.delta_bic < 0.0);
  }
  return d;
}

// check_single_effect on Model I (tailless-model-1) for seeds 101-103 (1 under the sanitizers).
inline void check_effect_on_model_1(const std::string& effect) {
  for (std::uint64_t seed : test_seeds({101u, 102u, 103u}))
    check_single_effect("tailless-model-1", effect, hidden_effect(effect), seed);
}

// The final model's estimate of the (non-knot) parameter of `kind`, `lag`, `power` (NaN when
// the model has none): b2_0 is {b_power, 1, 0}, c2 {gain, 1}, delay_s {delay}.
inline double final_estimate(const DiagnoseResult& d, ParamKind kind, int lag = 0, int power = 0) {
  const ParamId id = param_id(kind, lag, power);
  for (const ParameterEstimate& p : d.fits.back().parameters)
    if (p.id == id) return p.value;
  return std::nan("");
}

}  // namespace indicial::testing
