// tests/fuzz/fuzz_run_csv.cpp -- libFuzzer target: the run CSV reader (indicial::read_run_csv,
// fitter/include/indicial/fitter/io.hpp) and the static-table reader on any byte string.
//
// The input is written to a file (the readers take paths) and read for each axis, with the
// coefficient required and optional. Properties:
//  1. the only exception is indicial::InputError, and its message names the file;
//  2. an accepted run holds what io.hpp promises downstream code may assume: at least
//     min_run_samples rows, all columns the same length, strictly increasing and uniform time
//     (1e-6 relative), finite time, angle, rate and coefficient values;
//  3. an accepted static table has at least 2 rows, strictly increasing finite angles and
//     finite values.
#include <cmath>
#include <cstdint>
#include <string>

#include "fuzz_common.hpp"
#include "indicial/fitter/error.hpp"
#include "indicial/fitter/io.hpp"

namespace {

using indicial_fuzz::fuzz_fail;

void check_finite(const std::vector<double>& v, const char* what) {
  for (double x : v)
    if (!std::isfinite(x)) fuzz_fail("accepted run has a non-finite value in", what);
}

void check_run(const indicial::Run& run, indicial::CoefficientPresence presence) {
  const std::size_t n = run.time_s.size();
  if (n < static_cast<std::size_t>(indicial::min_run_samples)) fuzz_fail("too few samples accepted");
  if (run.motion_angle_rad.size() != n || run.rate_radps.size() != n)
    fuzz_fail("columns of different length");
  if (!(run.coefficient.size() == n ||
        (run.coefficient.empty() && presence == indicial::CoefficientPresence::optional)))
    fuzz_fail("coefficient column of the wrong length");
  check_finite(run.time_s, "time_s");
  check_finite(run.motion_angle_rad, "motion angle");
  check_finite(run.rate_radps, "rate");
  check_finite(run.coefficient, "coefficient");
  const double dt = run.time_s[1] - run.time_s[0];
  for (std::size_t i = 1; i < n; ++i) {
    const double step = run.time_s[i] - run.time_s[i - 1];
    if (!(step > 0.0)) fuzz_fail("time not strictly increasing");
    // 1e-6 relative to the median step (or snapped to an exact grid); against the first step
    // allow twice that. A phase cycle beyond its print resolution is nonuniform by design.
    if (run.time_grid == indicial::TimeGrid::uniform && !(std::abs(step - dt) <= 2.00001e-6 * std::max(step, dt)))
      fuzz_fail("non-uniform step accepted");
  }
}

template <class F>
void expect_input_error_only(const std::string& path, F&& f) {
  try {
    f();
  } catch (const indicial::InputError& e) {
    if (!indicial_fuzz::names_file(e.what(), path)) fuzz_fail("message does not name the file:", e.what());
  }
  // Any other exception escapes: libFuzzer reports the uncaught exception as a crash.
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string path = indicial_fuzz::scratch_dir("csv") + "/run.csv";
  indicial_fuzz::write_file(path, data, size);

  using indicial::Axis;
  using indicial::CoefficientPresence;
  struct Case {
    Axis axis;
    const char* coefficient;
    CoefficientPresence presence;
  };
  const Case cases[] = {{Axis::pitch, "Cm", CoefficientPresence::required},
                        {Axis::roll, "Cl", CoefficientPresence::optional},
                        {Axis::yaw, "Cn", CoefficientPresence::required}};
  for (const Case& c : cases) {
    expect_input_error_only(path, [&] {
      const indicial::Run run = indicial::read_run_csv(path, c.axis, c.coefficient, c.presence);
      check_run(run, c.presence);
    });
  }
  // A phase column (phase_rad | phase_deg) with the cycle's frequency, tolerant dialects.
  expect_input_error_only(path, [&] {
    indicial::RunCsvOptions options;
    options.frequency_hz = 1.0;
    const indicial::Run run = indicial::read_run_csv(path, Axis::pitch, "Cm", CoefficientPresence::required, options);
    check_run(run, CoefficientPresence::required);
  });
  expect_input_error_only(path, [&] {
    indicial::StaticConfig config;
    indicial::read_static_table(path, Axis::pitch, "Cm", config);
    if (config.table_x_rad.size() < 2 || config.table_x_rad.size() != config.table_value.size())
      fuzz_fail("static table: bad size accepted");
    check_finite(config.table_x_rad, "static angle");
    check_finite(config.table_value, "static value");
    for (std::size_t i = 1; i < config.table_x_rad.size(); ++i)
      if (!(config.table_x_rad[i] > config.table_x_rad[i - 1])) fuzz_fail("static table not increasing");
  });
  return 0;
}
