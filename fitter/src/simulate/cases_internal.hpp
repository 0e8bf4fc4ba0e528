// cases_internal.hpp (internal) -- what the files of the case registry share (cases.cpp,
// cases_f16xl.cpp; indicial/fitter/simulate.hpp's simulation_cases()): the cases defined in
// their own files, and the one way a case's experiment lists its runs.
#pragma once

#include <vector>

#include "indicial/fitter/simulate.hpp"

namespace indicial {

// Defined in cases_f16xl.cpp, registered by simulation_cases() (cases.cpp).
std::vector<SimulationCase> f16xl_like_cases();
std::vector<SimulationCase> lateral_cases();

// Sets c.experiment.runs to one Run per c.run_files entry, in order, each with its path only
// (no data): the configuration written to experiment.toml (SimulationCase::experiment).
void list_case_runs(SimulationCase& c);

}  // namespace indicial
