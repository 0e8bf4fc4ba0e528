// rotary_alpha's pair candidate (diagnose_effects.cpp gen_rotary_alpha): the constant C_aq
// correction with one knot together, c0 + c1 (x - k)_+, offered while the correction has no
// constant. Why it exists: a damping derivative that changes sign through stall (measured C_m
// cycles: -1.39 per rad at a mean of 6 deg, +0.42 at 15) is fitted by neither term alone.
// Here the truth is Model I (tailless-model-1) with such a correction, integrated by the
// reference simulator (Dormand-Prince, tolerance 1e-12; tests/diagnose_test_data.hpp), SNR 40:
// the pair is offered at the true knot and fits to the noise, the constant alone and the knot
// alone do not. Three fits, not a whole diagnosis (seconds).
#include <doctest/doctest.h>

#include <cmath>
#include <string>
#include <vector>

#include "diagnose/diagnose_internal.hpp"
#include "diagnose_test_data.hpp"
#include "indicial/fitter/fit.hpp"

TEST_SUITE_BEGIN("unit");  // the ctest label (tests/CMakeLists.txt)

using namespace indicial;
using namespace indicial::diagnose_detail;
using namespace indicial::testing;

namespace {

// The fit error of `e` with the model `m`, from the fitter's own start.
double fit_error_of(const Experiment& e, const ModelConfig& m) {
  Experiment x = e;
  x.model = m;
  return fit_experiment(x, FitOptions{}).fit_error;
}

}  // namespace

TEST_CASE("diagnose rotary pair: c0 + c1 (x - k)_+ is offered at the knot and fits where neither term alone does") {
  // The knot grid of Model I's runs (35 +- 35 deg, default spacing 5 deg); the truth's knot
  // is the grid's 40 deg, so the pair can be exact.
  Experiment grid_e = find_simulation_case("tailless-model-1").experiment;
  grid_e.data_x_min_rad = 0.0;
  grid_e.data_x_max_rad = 70.0 * kDeg;
  double spacing = 0.0;
  const std::vector<double> grid = knot_grid(grid_e, DiagnoseOptions{}, spacing);
  REQUIRE(!grid.empty());
  double knot = grid.front();
  for (double k : grid)
    if (std::abs(k - 40.0 * kDeg) < std::abs(knot - 40.0 * kDeg)) knot = k;
  REQUIRE(std::abs(knot - 40.0 * kDeg) < 1e-9);
  // Less damping below the knot, more above: the correction changes sign at 55 deg.
  const double c0 = 1.5, c1 = -6.0;
  const TruthModifier modify = [&](TruthCoefficient& m) {
    add_power_term(m.rotary, 0, c0);
    add_knot_term(m.rotary, knot, 1, c1);
  };
  double sigma = 0.0;
  Experiment e = hidden_effect_experiment("tailless-model-1", "rotary-pair", modify, 40.0, 101u, &sigma);
  e.data_x_min_rad = grid_e.data_x_min_rad;
  e.data_x_max_rad = grid_e.data_x_max_rad;
  // The candidates rotary_alpha offers against the configured model: the pair at the knot.
  const FitResult none;
  std::vector<CandidateSpec> specs;
  effect_entry(Effect::rotary_alpha).generate(CandidateContext{e, e.model, none, grid, spacing}, specs);
  const CandidateSpec* pair = nullptr;
  const CandidateSpec* constant = nullptr;
  const CandidateSpec* knot_alone = nullptr;
  for (const CandidateSpec& s : specs) {
    const SplineConfig& r = s.config.rotary_correction;
    const bool at_knot = r.knots_rad.size() == 1 && std::abs(r.knots_rad[0] - knot) < 1e-12;
    if (r.powers == std::vector<int>{0} && at_knot) pair = &s;
    if (r.powers == std::vector<int>{0} && r.knots_rad.empty()) constant = &s;
    if (r.powers.empty() && at_knot) knot_alone = &s;
  }
  REQUIRE(pair != nullptr);
  REQUIRE(constant != nullptr);
  REQUIRE(knot_alone != nullptr);
  CHECK(pair->effect == Effect::rotary_alpha);
  CHECK(pair->term.find("x^0") != std::string::npos);
  const double base = fit_error_of(e, e.model);
  const double with_constant = fit_error_of(e, constant->config);
  const double with_knot = fit_error_of(e, knot_alone->config);
  const double with_pair = fit_error_of(e, pair->config);
  MESSAGE("fit error / sigma: configured ", base / sigma, ", x^0 alone ", with_constant / sigma, ", knot alone ",
          with_knot / sigma, ", pair ", with_pair / sigma);
  CHECK(base >= 2.0 * sigma);           // the effect is sized to be seen
  CHECK(with_constant >= 1.5 * sigma);  // the constant alone is not enough
  CHECK(with_knot >= 1.5 * sigma);      // nor the knot alone
  CHECK(with_pair < 1.1 * sigma);       // both together: the noise
}
