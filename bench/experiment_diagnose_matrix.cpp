// experiment_diagnose_matrix -- the diagnose evaluation matrix of docs/diagnose.md (issue 13):
// every effect x motion x size x noise x coefficient, minutes to half an hour. Not a test
// (tests/test_diagnose_matrix.cpp runs representative cases in ctest); tools/diagnose-matrix.sh
// runs it in shards and writes the measured table into docs/diagnose.md.
//
//   build/bench/experiment_diagnose_matrix matrix   # the matrix (environment below)
//   build/bench/experiment_diagnose_matrix sizes    # each hidden effect's size, no diagnose step
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <fmt/format.h>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include "diagnose_test_matrix.hpp"
#include "fit_test_data.hpp"

using namespace indicial;
using namespace indicial::testing;

namespace {

// Environment: INDICIAL_DIAGNOSE_MATRIX = quick | full (default quick),
// INDICIAL_DIAGNOSE_MATRIX_OUT = the Markdown file to write (default diagnose-matrix.md),
// INDICIAL_DIAGNOSE_MATRIX_SHARD = "i/n" to run cases i, i + n, ... (the script runs shards in
// parallel and merges them).
int run_matrix() {
  const char* mode_env = std::getenv("INDICIAL_DIAGNOSE_MATRIX");
  const char* out_env = std::getenv("INDICIAL_DIAGNOSE_MATRIX_OUT");
  const char* shard_env = std::getenv("INDICIAL_DIAGNOSE_MATRIX_SHARD");  // "i/n": every n-th case from i
  const bool quick = !(mode_env && std::string(mode_env) == "full");
  const std::string out_path = out_env ? out_env : "diagnose-matrix.md";
  int shard = 0, shards = 1;
  if (shard_env && (std::sscanf(shard_env, "%d/%d", &shard, &shards) != 2 || shards < 1 || shard < 0)) {
    std::cerr << "INDICIAL_DIAGNOSE_MATRIX_SHARD: expected i/n, found '" << shard_env << "'\n";
    return 1;
  }
  std::ofstream out(out_path);
  if (!out.good()) {
    std::cerr << out_path << ": cannot open for writing\n";
    return 1;
  }
  out << matrix_header_markdown() << std::flush;
  int effect_cases = 0, first_right = 0, first_tied = 0, within = 0, null_cases = 0, null_clean = 0;
  std::vector<double> times;
  const std::vector<MatrixCase> cases = diagnose_matrix(quick);
  for (std::size_t i = static_cast<std::size_t>(shard); i < cases.size(); i += static_cast<std::size_t>(shards)) {
    const MatrixCase& mc = cases[i];
    const MatrixRow r = run_matrix_case(mc);
    out << matrix_row_markdown(r) << std::flush;
    std::cout << matrix_row_markdown(r) << std::flush;
    times.push_back(r.seconds);
    if (mc.expected == "none") {
      ++null_cases;
      null_clean += r.first == "none" ? 1 : 0;
    } else {
      ++effect_cases;
      first_right += r.first_right ? 1 : 0;
      first_tied += r.first_tied ? 1 : 0;
      within += std::abs(r.final_over_sigma - 1.0) <= 0.15 ? 1 : 0;
    }
  }
  std::sort(times.begin(), times.end());
  out << fmt::format(
      "\nSummary ({}): first named effect right in {} of {} effect cases ({} more named as "
      "indistinguishable from the first); final fit error within 15 % "
      "of the noise level in {} of {}; no effect named in {} of {} null cases (colored noise); "
      "diagnose time median {:.1f} s, max {:.1f} s.\n",
      quick ? "quick" : "full", first_right, effect_cases, first_tied, within, effect_cases, null_clean, null_cases,
      times.empty() ? 0.0 : times[times.size() / 2], times.empty() ? 0.0 : times.back());
  return 0;
}

// The size of each hidden effect: the configured model's fit error / sigma (no diagnose step).
int effect_sizes() {
  DiagnoseOptions o;
  o.max_steps = 0;
  for (const char* coef : {"Cm", "CL"})
    for (const EffectDescription& ef : effect_descriptions())
      // (No injection of the dynamic-stall effects into the matrix's tailless truths: their
      // cases would inject nothing.)
      if (ef.extends == EffectExtends::report_model)
      for (MatrixMotion mo : {MatrixMotion::sine_from_rest, MatrixMotion::sine_from_mean, MatrixMotion::ramps}) {
        const MatrixRow r = run_matrix_case({coef, ef.name, ef.name, 1.0, mo, MatrixNoise::white, 7}, o);
        const std::string line = std::string(coef) + " " + ef.name + " " + matrix_motion_name(mo) +
                                 ": initial / sigma " + std::to_string(r.initial_over_sigma);
        std::cout << line << "\n";
      }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string what = argc > 1 ? argv[1] : "";
  if (what == "matrix") return run_matrix();
  if (what == "sizes") return effect_sizes();
  std::cerr << "usage: " << argv[0] << " matrix | sizes\n";
  return 1;
}
