// DiagnoseOptions::IsValid (fitter/src/diagnose/diagnose_options.cpp): every range of the
// options, one bad option at a time, each refused with its own one-line message -- by IsValid and
// by diagnose_experiment, which throws that same line before it looks at the experiment. The
// command line and Python report the same line (test_cmd_diagnose.cpp, python/tests/test_diagnose.py).
#include <doctest/doctest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "diagnose/diagnose_internal.hpp"
#include "indicial/fitter/diagnose.hpp"
#include "indicial/fitter/error.hpp"
#include "options_test_support.hpp"

TEST_SUITE_BEGIN("unit");  // the ctest label (tests/CMakeLists.txt)

using namespace indicial;

namespace {

using BadOption = testing::BadOption<DiagnoseOptions>;

const double nan = std::numeric_limits<double>::quiet_NaN();

std::vector<BadOption> bad_options() {
  return {
      {"alpha (--alpha): must be in (0, 1)", [](DiagnoseOptions& o) { o.alpha = 0.0; }, "found 0"},
      {"alpha (--alpha): must be in (0, 1)", [](DiagnoseOptions& o) { o.alpha = 1.0; }, "found 1"},
      {"alpha (--alpha): must be in (0, 1)", [](DiagnoseOptions& o) { o.alpha = nan; }, "found nan"},
      {"cv_min_runs (--cv-min-runs): must be >= 2", [](DiagnoseOptions& o) { o.cv_min_runs = 1; }, "found 1"},
      {"cv_min_gain (--min-gain): must be in [0, 1)", [](DiagnoseOptions& o) { o.cv_min_gain = -0.1; }, "found -0.1"},
      {"cv_min_gain (--min-gain): must be in [0, 1)", [](DiagnoseOptions& o) { o.cv_min_gain = 1.0; }, "found 1"},
      {"cv_min_in_sample_gain (--min-in-sample-gain): must be in [0, 1)",
       [](DiagnoseOptions& o) { o.cv_min_in_sample_gain = 1.0; }, "found 1"},
      {"cv_min_in_sample_gain (--min-in-sample-gain): must be in [0, 1)",
       [](DiagnoseOptions& o) { o.cv_min_in_sample_gain = -0.01; }, "found -0.01"},
      {"cv_max_folds (--max-folds): must be >= 2", [](DiagnoseOptions& o) { o.cv_max_folds = 1; }, "found 1"},
      {"threads (--threads): must be >= 1", [](DiagnoseOptions& o) { o.threads = 0; }, "found 0"},
      {"max_steps (--max-steps): must be >= 0", [](DiagnoseOptions& o) { o.max_steps = -1; }, "found -1"},
      {"knot_spacing_deg (--knot-spacing-deg): must be positive and finite",
       [](DiagnoseOptions& o) { o.knot_spacing_deg = 0.0; }, "found 0"},
      {"knot_spacing_deg (--knot-spacing-deg): must be positive and finite",
       [](DiagnoseOptions& o) { o.knot_spacing_deg = std::numeric_limits<double>::infinity(); }, "found inf"},
      {"knot_margin_fraction: must be in [0, 0.5)", [](DiagnoseOptions& o) { o.knot_margin_fraction = 0.5; },
       "found 0.5"},
      {"max_scan_knots: must be >= 1", [](DiagnoseOptions& o) { o.max_scan_knots = 0; }, "found 0"},
      {"max_family_terms (--max-family-terms): must be >= 1", [](DiagnoseOptions& o) { o.max_family_terms = 0; },
       "found 0"},
      {"indistinguishable_bic: must be >= 0", [](DiagnoseOptions& o) { o.indistinguishable_bic = -1.0; },
       "found -1"},
  };
}

}  // namespace

TEST_CASE("diagnose options: the defaults and the edges of every range are valid") {
  std::string error = "untouched";
  CHECK(DiagnoseOptions{}.IsValid(&error));
  CHECK(error == "untouched");
  CHECK(DiagnoseOptions{}.IsValid(nullptr));
  DiagnoseOptions edges;
  edges.cv_min_runs = 2;
  edges.cv_min_gain = 0.0;
  edges.cv_min_in_sample_gain = 0.0;
  edges.cv_max_folds = 2;
  edges.threads = 1;
  edges.max_steps = 0;
  edges.knot_margin_fraction = 0.0;
  edges.max_scan_knots = 1;
  edges.max_family_terms = 1;
  edges.indistinguishable_bic = 0.0;
  CHECK(edges.IsValid(&error));
}

TEST_CASE("diagnose options: a stall candidate's own start is the configured one, not the fit's grid") {
  // The two defaults differ on purpose (DiagnoseOptions::fit_defaults: the grid made the
  // three-run studies of docs/validation-real.md up to 10 times slower and chose no better).
  CHECK(FitOptions{}.stall_start_search == StallStartSearch::grid);
  CHECK(DiagnoseOptions{}.fit.stall_start_search == StallStartSearch::configured);
  DiagnoseOptions grid;
  grid.fit.stall_start_search = StallStartSearch::grid;
  CHECK(grid.IsValid(nullptr));
}

TEST_CASE("diagnose options: the fits diagnose runs take its threads for their stall start grid") {
  // fit.threads (the library's FitOptions default, 1) is replaced in every fit diagnose runs,
  // so that a fit's grid uses the cores diagnose was given (diagnose_internal.hpp); the rest of
  // o.fit is kept, the search and the start values are the call's.
  using diagnose_detail::diagnose_fit_options;
  DiagnoseOptions o;
  o.fit.max_iterations = 77;
  CHECK(o.fit.threads == 1);
  const diagnose_detail::StartValues sv{{param_id(ParamKind::b_power), 2.5}};
  const FitOptions fo = diagnose_fit_options(o, StallStartSearch::grid, sv);
  CHECK(fo.threads == 2);
  CHECK(fo.max_iterations == 77);
  CHECK(fo.stall_start_search == StallStartSearch::grid);
  REQUIRE(fo.start_values.size() == 1);
  CHECK(fo.start_values[0].first == "b1_0");
  CHECK(fo.start_values[0].second == 2.5);
  o.threads = 1;
  o.fit.threads = 3;
  CHECK(diagnose_fit_options(o, StallStartSearch::configured, {}).threads == 1);
  CHECK(diagnose_fit_options(o, StallStartSearch::configured, {}).start_values.empty());
}

TEST_CASE("diagnose options: each bad option is refused by IsValid with its own one-line message") {
  testing::check_each_refused(bad_options());
}

TEST_CASE("diagnose options: diagnose_experiment throws IsValid's message before it reads the experiment") {
  // An empty experiment: with valid options diagnose_experiment refuses it for something else
  // (no runs), so the message below can only come from the options' check.
  const Experiment empty;
  testing::check_entry_throws_first(
      bad_options(), [&](const DiagnoseOptions& o) { diagnose_experiment(empty, o); }, "no runs");
}
