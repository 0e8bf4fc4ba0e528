// diagnose_test_data.hpp -- simulated experiments with ONE (or two) hidden effects for the
// diagnose tests (tests/test_diagnose_*.cpp).
//
// The truth is a built-in case's model (Model I of the report's Table I, or a lateral case)
// changed by a modifier -- a b1 knot, an a(x) knot, a C_aq term, con, a delay, a second lag,
// a static correction -- integrated by the reference simulator (fitter/simulate.hpp: Dormand-
// Prince with tolerance 1e-12, never the discrete update), with white noise of SNR 40 (sigma =
// RMS(y) / 40) from a seed. The experiment configuration is the case's own (Model I structure,
// the right static and rotary terms), i.e. it lacks exactly the hidden effect.
#pragma once

#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "indicial/fitter/experiment.hpp"
#include "indicial/fitter/montecarlo.hpp"
#include "indicial/fitter/simulate.hpp"

namespace indicial::testing {

using TruthCoefficient = CoefficientModel<double, FitCapacity>;
using TruthModifier = std::function<void(TruthCoefficient&)>;

// Noise-free reference runs of `case_name` with `modify` applied to the truth, cached per key.
inline const std::vector<SimulatedRun>& hidden_reference_runs(const std::string& case_name,
                                                               const std::string& key,
                                                               const TruthModifier& modify) {
  static std::map<std::string, std::vector<SimulatedRun>> cache;
  const std::string k = case_name + "|" + key;
  auto it = cache.find(k);
  if (it != cache.end()) return it->second;
  const SimulationCase& c = find_simulation_case(case_name);
  TruthModel truth = c.truth;
  if (modify) modify(truth.coefficients[0]);
  std::vector<SimulatedRun> runs;
  for (const auto& m : c.motions) runs.push_back(simulate_reference(truth, m));
  return cache.emplace(k, std::move(runs)).first->second;
}

// The case's experiment (its configuration: the model WITHOUT the hidden effect) on data of
// the modified truth with SNR `snr` noise from `seed`. `noise_sigma` receives the noise std.
inline Experiment hidden_effect_experiment(const std::string& case_name, const std::string& key,
                                           const TruthModifier& modify, double snr,
                                           std::uint64_t seed, double* noise_sigma) {
  const SimulationCase& c = find_simulation_case(case_name);
  std::vector<SimulatedRun> runs = hidden_reference_runs(case_name, key, modify);
  const std::vector<double> sigma = add_measurement_noise(runs, snr, seed);
  if (noise_sigma) *noise_sigma = sigma.empty() ? 0.0 : sigma[0];
  // The same Run-building as the Monte Carlo command (montecarlo.hpp), only renamed.
  Experiment e = experiment_from_simulation(c, runs);
  e.path = case_name + "-" + key + ".toml";
  return e;
}

// Spline helpers for modifiers.
inline void add_knot_term(Spline<double, FitCapacity::max_powers, FitCapacity::max_knots>& s,
                          double knot_rad, int power, double coef) {
  s.knot_rad[s.n_knots] = knot_rad;
  s.knot_power[s.n_knots] = power;
  s.knot_coef[s.n_knots] = coef;
  ++s.n_knots;
}
inline void add_power_term(Spline<double, FitCapacity::max_powers, FitCapacity::max_knots>& s,
                           int power, double coef) {
  for (int i = s.n_powers; i <= power; ++i) s.power_coef[i] = 0.0;
  if (s.n_powers < power + 1) s.n_powers = power + 1;
  s.power_coef[power] += coef;
}

constexpr double kDeg = 3.14159265358979323846 / 180.0;

// The seven hidden effects on Model I (tailless-model-1), sized so that the configured model's
// fit error is at least twice the noise (the tests check that too).
inline TruthModifier hidden_effect(const std::string& effect) {
  if (effect == "b1_alpha") return [](TruthCoefficient& m) { add_knot_term(m.lags[0].b, 30 * kDeg, 1, 2.0); };
  if (effect == "a_alpha") return [](TruthCoefficient& m) { add_knot_term(m.a, 45 * kDeg, 2, 20.0); };
  if (effect == "rotary_alpha") return [](TruthCoefficient& m) { add_knot_term(m.rotary, 40 * kDeg, 1, -3.0); };
  if (effect == "bias") return [](TruthCoefficient& m) { m.con = 0.025; };
  if (effect == "time_delay") return [](TruthCoefficient& m) { m.delay_s = 0.02; };
  if (effect == "second_lag") return [](TruthCoefficient& m) {
    m.n_lags = 2;
    m.lags[1].b.n_powers = 1;
    m.lags[1].b.power_coef[0] = 20.0;
    m.lags[1].gain = 0.5;
  };
  if (effect == "static_error") return [](TruthCoefficient& m) { add_knot_term(m.static_correction, 40 * kDeg, 2, 0.1); };
  return {};
}

}  // namespace indicial::testing
