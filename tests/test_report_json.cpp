// fit.json's extension fields that only an unusual fit sets: the solver's feasibility boundary
// and its count of rejected inadmissible trial steps (docs/formats.md, "fit.json"). The usual
// values ("interior", 0) are pinned by tests/test_golden_fit.cpp on real fits.
#include <doctest/doctest.h>

#include <nlohmann/json.hpp>

#include "indicial/fitter/fit.hpp"
#include "indicial/fitter/report.hpp"

TEST_SUITE_BEGIN("unit");  // the ctest label (tests/CMakeLists.txt)

TEST_CASE("fit.json carries the output-error solver's feasibility boundary and infeasible trials") {
  indicial::Experiment e;
  e.coefficient = "Cm";
  indicial::FitResult r;
  const nlohmann::json interior = indicial::fit_json(r, e, indicial::FitOptions{}, nullptr);
  CHECK(interior.at("feasibility_boundary") == "interior");
  CHECK(interior.at("infeasible_trials") == 0);

  r.output_error.boundary = indicial::FeasibilityBoundary::active;
  r.output_error.infeasible_trials = 4;
  const nlohmann::json active = indicial::fit_json(r, e, indicial::FitOptions{}, nullptr);
  CHECK(active.at("feasibility_boundary") == "active");
  CHECK(active.at("infeasible_trials") == 4);
}
