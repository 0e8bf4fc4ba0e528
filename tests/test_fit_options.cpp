// FitOptions::IsValid (fitter/src/estimate/fit_options.cpp): every range of the fit's options,
// one bad option at a time, each refused with its own one-line message -- by IsValid, by
// fit_experiment and fit_equation_error (which throw that same line before they look at the
// experiment) and by diagnose_experiment (DiagnoseOptions::IsValid checks its `fit` last). The
// command line and Python report the same line (test_fit_cli.cpp, python/tests/test_fit.py).
#include <doctest/doctest.h>

#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "indicial/fitter/diagnose.hpp"
#include "indicial/fitter/error.hpp"
#include "indicial/fitter/fit.hpp"
#include "options_test_support.hpp"

TEST_SUITE_BEGIN("unit");  // the ctest label (tests/CMakeLists.txt)

using namespace indicial;

namespace {

using BadOption = testing::BadOption<FitOptions>;

const double nan = std::numeric_limits<double>::quiet_NaN();
const double inf = std::numeric_limits<double>::infinity();

std::vector<BadOption> bad_options() {
  return {
      {"f_to_enter (--f-to-enter): must be > 0", [](FitOptions& o) { o.f_to_enter = 0.0; }, "found 0"},
      {"f_to_enter (--f-to-enter): must be > 0", [](FitOptions& o) { o.f_to_enter = nan; }, "found nan"},
      {"f_to_remove (--f-to-remove): must be in (0, f_to_enter = 4]", [](FitOptions& o) { o.f_to_remove = 5.0; },
       "found 5"},
      {"f_to_remove (--f-to-remove): must be in (0, f_to_enter = 2]",
       [](FitOptions& o) { o.f_to_enter = 2.0, o.f_to_remove = 3.0; }, "found 3"},
      {"f_to_remove (--f-to-remove): must be in (0, f_to_enter = 4]", [](FitOptions& o) { o.f_to_remove = 0.0; },
       "found 0"},
      {"fallback_r_squared (--fallback-r-squared): must be in [0, 1]",
       [](FitOptions& o) { o.fallback_r_squared = 1.5; }, "found 1.5"},
      {"fallback_r_squared (--fallback-r-squared): must be in [0, 1]",
       [](FitOptions& o) { o.fallback_r_squared = -0.1; }, "found -0.1"},
      {"sv_cutoff: must be in (0, 1)", [](FitOptions& o) { o.sv_cutoff = 0.0; }, "found 0"},
      {"sv_cutoff: must be in (0, 1)", [](FitOptions& o) { o.sv_cutoff = 1.0; }, "found 1"},
      {"max_iterations (--max-iterations): must be >= 0", [](FitOptions& o) { o.max_iterations = -1; }, "found -1"},
      {"cost_tolerance: must be >= 0", [](FitOptions& o) { o.cost_tolerance = -1e-9; }, "found -1e-09"},
      {"step_tolerance: must be >= 0", [](FitOptions& o) { o.step_tolerance = nan; }, "found nan"},
      {"max_damping: must be >= the solver's initial damping", [](FitOptions& o) { o.max_damping = 1e-4; },
       "found 0.0001"},
      {"max_two_stage_iterations: must be >= 1", [](FitOptions& o) { o.max_two_stage_iterations = 0; }, "found 0"},
      {"two_stage_tolerance: must be >= 0", [](FitOptions& o) { o.two_stage_tolerance = -0.1; }, "found -0.1"},
      {"derivative_half_window: must be >= 1", [](FitOptions& o) { o.derivative_half_window = 0; }, "found 0"},
      {"derivative_order: must be in [1, 2 derivative_half_window = 10]",
       [](FitOptions& o) { o.derivative_order = 11; }, "found 11"},
      {"derivative_order: must be in [1, 2 derivative_half_window = 10]",
       [](FitOptions& o) { o.derivative_order = 0; }, "found 0"},
      {"modulating_window: must be >= 5", [](FitOptions& o) { o.modulating_window = 4; }, "found 4"},
      {"modulating_shift: must be >= 1", [](FitOptions& o) { o.modulating_shift = 0; }, "found 0"},
      {"max_correlation_lag: must be >= 0", [](FitOptions& o) { o.max_correlation_lag = -1; }, "found -1"},
      {"start_values (--start-value): must be finite numbers",
       [](FitOptions& o) { o.start_values = {{"a0", 1.0}, {"b1_0", inf}}; }, "found b1_0=inf"},
  };
}

}  // namespace

TEST_CASE("fit options: the defaults and the edges of every range are valid") {
  std::string error = "untouched";
  CHECK(FitOptions{}.IsValid(&error));
  CHECK(error == "untouched");
  CHECK(FitOptions{}.IsValid(nullptr));
  FitOptions edges;
  edges.f_to_enter = edges.f_to_remove = 1e-9;  // F to enter == F to remove
  edges.fallback_r_squared = 1.0;
  edges.max_iterations = 0;  // the start evaluated (tests/test_fit_bad_inputs.cpp uses it)
  edges.cost_tolerance = edges.step_tolerance = edges.two_stage_tolerance = 0.0;
  edges.max_damping = 1e-3;  // the solver's initial damping
  edges.max_two_stage_iterations = 1;
  edges.derivative_half_window = 1;
  edges.derivative_order = 2;
  edges.modulating_window = 5;
  edges.modulating_shift = 1;
  edges.max_correlation_lag = 0;
  edges.start_values = {{"b1_0", -1e300}};
  CHECK(edges.IsValid(&error));
  edges.fallback_r_squared = 0.0;
  edges.derivative_order = 1;
  CHECK(edges.IsValid(&error));
}

TEST_CASE("fit options: each bad option is refused by IsValid with its own one-line message") {
  testing::check_each_refused(bad_options());
}

TEST_CASE("fit options: fit_experiment, fit_equation_error and diagnose_experiment throw IsValid's message first") {
  // An empty experiment: with valid options fit_experiment refuses it for something else (no
  // runs), so the message below can only come from the options' check.
  const Experiment empty;
  testing::check_entry_throws_first(bad_options(), [&](const FitOptions& o) { fit_experiment(empty, o); }, "no runs");
  for (const BadOption& b : bad_options()) {
    FitOptions o;
    b.set(o);
    const std::string error = testing::is_valid_line(b);
    INFO(b.option, " ", b.found);
    CHECK_THROWS_WITH_AS(fit_equation_error(empty, o), error.c_str(), InputError);
    // DiagnoseOptions::IsValid checks its `fit` last, with FitOptions' line naming the field
    // alone (OptionNaming::field): `indicial diagnose` has none of the fit's flags.
    std::string field_line = error;
    if (const std::size_t flag = field_line.find(" (--"); flag != std::string::npos)
      field_line.erase(flag, field_line.find(')', flag) + 1 - flag);
    CHECK(field_line.find("--") == std::string::npos);
    std::string field_error;
    CHECK(!o.IsValid(&field_error, OptionNaming::field));
    CHECK(field_error == field_line);
    DiagnoseOptions d;
    d.fit = o;
    std::string diagnose_error;
    CHECK(!d.IsValid(&diagnose_error));
    CHECK(diagnose_error == field_line);
    CHECK_THROWS_WITH_AS(diagnose_experiment(empty, d), field_line.c_str(), InputError);
  }
}
