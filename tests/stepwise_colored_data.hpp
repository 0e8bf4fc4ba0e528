// stepwise_colored_data.hpp -- the stepwise-under-colored-residuals setup shared by
// tests/test_fit_stepwise_colored.cpp (a few seeds, in ctest) and
// bench/experiment_stepwise_colored.cpp (the measured tables of docs/validation.md, by hand).
// Model I (reference simulator) with a pool of three terms the truth does not have.
#pragma once

#include <cstdint>
#include <functional>
#include <set>
#include <string>
#include <vector>

#include "fit_test_data.hpp"
#include "indicial/fitter/fit.hpp"

namespace indicial::testing {

inline const std::set<std::string> kTruth = {"a1", "a2", "A1", "A3", "b1_0"};

inline Experiment noisy_experiment(std::uint64_t seed, const NoiseModel& noise) {
  const std::string name = "tailless-model-1";
  std::vector<SimulatedRun> runs = testing::reference_runs(name);
  add_measurement_noise(runs, 40.0, seed, noise);
  Experiment e = experiment_from_simulation(find_simulation_case(name), runs);
  e.path = name + ".toml";
  e.model.structure = StructureMode::stepwise;
  e.model.a = SplineConfig{{0, 1, 2}, {0.4363, 0.6981, 0.9599}, 2};  // A2 (40 deg) extra
  e.model.b1 = SplineConfig{{0, 1}, {}, 1};                          // b1_1 extra
  return e;
}

struct Selection {
  std::set<std::string> regression;  // the equation-error stepwise's
  std::set<std::string> refined;     // after the output-error stepwise (empty if not run)
  bool fallback = false;             // the fit fell back to the output-error stepwise
};

inline Selection select(std::uint64_t seed, const NoiseModel& noise, StepwiseSignificance sig,
                 StepwiseRefinement refinement) {
  FitOptions o;
  o.stepwise_significance = sig;
  o.stepwise_refinement = refinement;
  const FitResult r = fit_experiment(noisy_experiment(seed, noise), o);
  const auto& s = r.equation_error.stepwise.selected;
  const auto& f = r.output_error_stepwise.selected;
  return {{s.begin(), s.end()}, {f.begin(), f.end()}, !r.stepwise_fallback.empty()};
}

// A spurious ENTRY: more terms outside the truth than true terms missing. A swap of a true term
// for a collinear one (a0 for a1: their a(x) columns are nearly proportional over the
// oscillation, docs/validation.md) is not an entry; it counts as a miss.
inline bool spurious(const std::set<std::string>& got) {
  int extra = 0, missing = 0;
  for (const auto& t : got) extra += kTruth.count(t) == 0 ? 1 : 0;
  for (const auto& t : kTruth) missing += got.count(t) == 0 ? 1 : 0;
  return extra > missing;
}
inline bool complete(const std::set<std::string>& got) {
  for (const auto& t : kTruth)
    if (got.count(t) == 0) return false;
  return true;
}

struct Rates {
  int seeds = 0, spurious_white = 0, spurious_colored = 0, missed_white = 0, missed_colored = 0;
};

// log(line) gets one line per seed; fallbacks counts the fits that fell back (none expected:
// the regression explains these data well).
inline Rates measure(const std::vector<std::uint64_t>& seeds, const NoiseModel& noise, StepwiseRefinement refinement,
                     const std::function<void(const std::string&)>& log, int* fallbacks = nullptr) {
  Rates r;
  for (std::uint64_t seed : seeds) {
    const Selection w = select(seed, noise, StepwiseSignificance::white_residuals, refinement);
    const Selection c = select(seed, noise, StepwiseSignificance::colored_residuals, refinement);
    const auto& wg = refinement == StepwiseRefinement::output_error ? w.refined : w.regression;
    const auto& cg = refinement == StepwiseRefinement::output_error ? c.refined : c.regression;
    std::string lw, lc;
    for (const auto& t : wg) lw += t + " ";
    for (const auto& t : cg) lc += t + " ";
    log("seed " + std::to_string(seed) + ": white F " + lw + "| colored F " + lc);
    if (fallbacks) *fallbacks += (w.fallback ? 1 : 0) + (c.fallback ? 1 : 0);
    ++r.seeds;
    r.spurious_white += spurious(wg) ? 1 : 0;
    r.spurious_colored += spurious(cg) ? 1 : 0;
    r.missed_white += complete(wg) ? 0 : 1;
    r.missed_colored += complete(cg) ? 0 : 1;
  }
  return r;
}

inline NoiseModel ar1() { return parse_noise_spec("ar1:phi=0.8"); }


}  // namespace indicial::testing
