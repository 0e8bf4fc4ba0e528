// Diagnose fits every model its rounds compare against to convergence (diagnose.cpp,
// Diagnoser::converged): a fit that ends at the iteration limit is fitted on from its own
// estimates, up to model_iteration_factor times the limit; one still at the limit is listed in
// DiagnoseResult::unconverged_models with a warning. Why: a candidate starts from the current
// model's estimates, so against an unconverged model its own iterations read as the effect's
// gain (docs/diagnose.md, step 6: measured cycles where two effects entered only so).
#include <doctest/doctest.h>

#include <algorithm>
#include <string>
#include <vector>

#include "fit_test_data.hpp"
#include "indicial/fitter/diagnose.hpp"

TEST_SUITE_BEGIN("unit");  // the ctest label (tests/CMakeLists.txt)

using namespace indicial;
using namespace indicial::testing;

namespace {

bool listed(const DiagnoseResult& d, int k) {
  return std::find(d.unconverged_models.begin(), d.unconverged_models.end(), k) != d.unconverged_models.end();
}

bool warns_unconverged(const DiagnoseResult& d) {
  for (const std::string& w : diagnose_warnings(d))
    if (w.find("still at the iteration limit") != std::string::npos) return true;
  return false;
}

// The warning says how far the model was fitted on: the factor, as the code applies it.
bool warning_names_factor(const DiagnoseResult& d) {
  const std::string says = "fitted on to " + std::to_string(model_iteration_factor) + " times the limit";
  for (const std::string& w : diagnose_warnings(d))
    if (w.find(says) != std::string::npos) return true;
  return false;
}

}  // namespace

TEST_CASE("diagnose model convergence: a model stopped at the iteration limit is fitted on, and listed if still there") {
  const Experiment e = simulated_experiment("tailless-model-1", 40.0, 7);
  DiagnoseOptions o;
  o.max_steps = 1;
  o.fit.max_iterations = 1;  // every fit stops after one iteration
  const FitResult one = fit_experiment(e, o.fit);
  REQUIRE(one.output_error.termination == Termination::iteration_limit);
  const DiagnoseResult d = diagnose_experiment(e, o);
  // Fitted on from the one-iteration estimates: lower than one iteration from the start.
  CHECK(d.initial_fit_error < one.fit_error);
  // The configured model's fit and its continuations, model_iteration_factor fits at least.
  CHECK(d.fits_run >= model_iteration_factor);
  // Four one-iteration fits do not converge Model I from its start: the configured model is
  // listed, and so is every step's model exactly when its fit still ended at the limit.
  REQUIRE(d.fits.front().output_error.termination == Termination::iteration_limit);
  CHECK(listed(d, 0));
  for (std::size_t k = 0; k < d.fits.size(); ++k)
    CHECK(listed(d, static_cast<int>(k)) == (d.fits[k].output_error.termination == Termination::iteration_limit));
  CHECK(warns_unconverged(d));
  CHECK(warning_names_factor(d));
}

TEST_CASE("diagnose model convergence: a converged configured model is the fit as fitted" *
          doctest::skip(kSanitizedBuild)) {
  // (Not under the sanitizers: the same loop as above, run zero times, at ~20 s instrumented.)
  const Experiment e = simulated_experiment("tailless-model-1", 40.0, 7);
  DiagnoseOptions o;
  o.max_steps = 1;
  const FitResult fitted = fit_experiment(e, o.fit);
  REQUIRE(fitted.output_error.termination == Termination::converged);
  const DiagnoseResult d = diagnose_experiment(e, o);
  CHECK(d.initial_fit_error == fitted.fit_error);  // no continuation: the same fit, bit for bit
  CHECK(d.unconverged_models.empty());
  CHECK_FALSE(warns_unconverged(d));
}
