// fit_test_data.hpp -- simulated experiments for the fitter tests (tests/test_fit_*.cpp).
//
// Builds an Experiment in memory from a built-in simulation case (fitter/simulate.hpp: the
// accurate reference integration, never the discrete update), with white measurement noise of
// a given SNR and seed. The noise-free reference runs of a case are simulated once per process.
#pragma once

#include <cmath>
#include <cstdint>
#include <iterator>
#include <limits>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "indicial/fitter/error.hpp"
#include "indicial/fitter/experiment.hpp"
#include "indicial/fitter/experiment_toml.hpp"
#include "indicial/fitter/montecarlo.hpp"
#include "indicial/fitter/simulate.hpp"

namespace indicial::testing {

// True in the ASan/UBSan build (tools/run-sanitizers.sh defines INDICIAL_SANITIZED_BUILD): for
// test_seeds below, and for `TEST_CASE("..." * doctest::skip(kSanitizedBuild))`: a case
// whose code paths another case of the same file already runs there, at the same cost (the
// normal build runs it).
#ifdef INDICIAL_SANITIZED_BUILD
inline constexpr bool kSanitizedBuild = true;
#else
inline constexpr bool kSanitizedBuild = false;
#endif

// The seeds a statistical loop runs. Under ASan/UBSan (tools/run-sanitizers.sh defines
// INDICIAL_SANITIZED_BUILD) every fit is 10-20x slower; that run checks memory safety and
// undefined behaviour, not statistics, so it runs the first `sanitized_count` seeds only. The
// normal build (tools/run-tests.sh, the acceptance run) runs them all.
inline std::vector<std::uint64_t> test_seeds(std::vector<std::uint64_t> seeds,
                                             std::size_t sanitized_count = 1) {
  if (kSanitizedBuild && seeds.size() > sanitized_count) seeds.resize(sanitized_count);
  return seeds;
}

inline const std::vector<SimulatedRun>& reference_runs(const std::string& case_name) {
  static std::map<std::string, std::vector<SimulatedRun>> cache;
  auto it = cache.find(case_name);
  if (it != cache.end()) return it->second;
  const SimulationCase& c = find_simulation_case(case_name);
  std::vector<SimulatedRun> runs;
  for (const auto& m : c.motions) runs.push_back(simulate_reference(c.truth, m));
  return cache.emplace(case_name, std::move(runs)).first->second;
}

// snr = +infinity gives noise-free data. `noise_sigma` (optional) receives the noise std.
inline Experiment simulated_experiment(const std::string& case_name, double snr,
                                       std::uint64_t seed, double* noise_sigma = nullptr) {
  const SimulationCase& c = find_simulation_case(case_name);
  std::vector<SimulatedRun> runs = reference_runs(case_name);
  const std::vector<double> sigma = add_measurement_noise(runs, snr, seed);
  if (noise_sigma) *noise_sigma = sigma.empty() ? 0.0 : sigma[0];
  // The same Run-building as the Monte Carlo command (montecarlo.hpp), only renamed.
  Experiment e = experiment_from_simulation(c, runs);
  e.path = case_name + ".toml";
  return e;
}

// A one-coefficient pitch truth model written out by a test, every curve a polynomial in the
// model angle x (rad; no knots): the static curve C_a(x), a(x) and each lag's b_j(x) by their
// power coefficients, with the gain c_j of every lag after the first (c_1 = 1).
struct PolynomialLag {
  std::vector<double> b_powers;  // b_j(x) = sum_i b_powers[i] x^i, 1/s at the airspeed
  double gain = 1.0;             // c_j; not used for the first lag
};
struct PolynomialTruth {
  std::string coefficient;
  double reference_length_m = 1.0;
  double airspeed_mps = 1.0;
  double x_min_rad = 0.0, x_max_rad = 0.0;  // the envelope
  std::vector<double> static_powers;
  std::vector<double> a_powers;
  std::vector<PolynomialLag> lags;
};

inline TruthModel polynomial_pitch_truth(const PolynomialTruth& s) {
  TruthModel t;
  t.axis = Axis::pitch;
  t.reference_length_m = s.reference_length_m;
  t.airspeed_mps = s.airspeed_mps;
  t.x_min_rad = s.x_min_rad;
  t.x_max_rad = s.x_max_rad;
  t.n_coefficients = 1;
  auto& m = t.coefficients[0];
  if (s.coefficient.size() >= sizeof(m.name) || s.lags.size() > std::size_t{FitCapacity::max_lags})
    throw std::length_error("polynomial_pitch_truth: the name or the lags exceed FitCapacity");
  s.coefficient.copy(m.name, s.coefficient.size());
  auto set_powers = [](auto& spline, const std::vector<double>& c) {
    if (c.size() > std::size(spline.power_coef))
      throw std::length_error("polynomial_pitch_truth: more powers than FitCapacity holds");
    spline.n_powers = static_cast<int>(c.size());
    for (std::size_t i = 0; i < c.size(); ++i) spline.power_coef[i] = c[i];
  };
  set_powers(m.static_curve.polynomial, s.static_powers);
  set_powers(m.a, s.a_powers);
  m.n_lags = static_cast<int>(s.lags.size());
  for (std::size_t j = 0; j < s.lags.size(); ++j) {
    set_powers(m.lags[j].b, s.lags[j].b_powers);
    if (j > 0) m.lags[j].gain = s.lags[j].gain;
  }
  return t;
}

// A pitch experiment of coefficient `coefficient` on a tabulated static curve, one row per
// degree from lo_deg to hi_deg (static_value of the angle in rad), with the report's lag of
// constant a and b1: the set-up of the tests whose truth is integrated by Boost.Odeint
// (test_fit_lag_floor.cpp, stall_truth_data.hpp), which add their runs and families to it.
template <class StaticValue>
inline Experiment pitch_table_experiment(const std::string& path, const std::string& coefficient,
                                         double reference_length_m, double airspeed_mps, double lo_deg,
                                         double hi_deg, StaticValue static_value) {
  constexpr double deg = 3.14159265358979323846 / 180.0;
  Experiment e;
  e.path = path;
  e.axis = Axis::pitch;
  e.coefficient = coefficient;
  e.reference_length_m = reference_length_m;
  e.airspeed_mps = airspeed_mps;
  e.static_curve.kind = StaticKind::table;
  for (double a = lo_deg; a <= hi_deg + 1e-9; a += 1.0) {
    e.static_curve.table_x_rad.push_back(a * deg);
    e.static_curve.table_value.push_back(static_value(a * deg));
  }
  e.model.a.powers = {0};
  e.model.b1.powers = {0};
  return e;
}

// What load_experiment says of the experiment file at `path`: the InputError's message, or
// "(no error)" when it loads.
inline std::string load_experiment_error(const std::string& path) {
  try {
    (void)load_experiment(path);
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no error)";
}

// The estimate named `name` in a fit's parameters, or null.
inline const ParameterEstimate* find_estimate(const FitResult& r, const std::string& name) {
  for (const auto& p : r.parameters)
    if (p.name == name) return &p;
  return nullptr;
}

// The tolerance on |s(v) / sigma - 1| for a fit of the true model structure to data with white
// noise of std sigma: s(v) = sqrt(SSR / N) is sigma with the ML bias -p / 2N and a relative
// standard error 1 / sqrt(2N) (N samples over all runs, p parameters), so 4 standard errors
// plus the bias (0.064 for the tailless cases' 2103 samples).
inline double fit_error_ratio_tolerance(const FitResult& r) {
  std::size_t n = 0;
  for (const auto& run : r.runs) n += run.time_s.size();
  const double nn = static_cast<double>(n), p = static_cast<double>(r.parameters.size());
  return 4.0 / std::sqrt(2.0 * nn) + p / (2.0 * nn);
}

// Samples [first, end) of a simulated run (coefficient 0), times shifted to start at 0: e.g.
// the last, settled cycle of a long oscillation (the reference integration starts from rest).
inline SimulatedRun tail_of(const SimulatedRun& r, std::size_t first) {
  auto cut = [first](const std::vector<double>& v) {
    return std::vector<double>(v.begin() + static_cast<std::ptrdiff_t>(first), v.end());
  };
  SimulatedRun out;
  out.time_s = cut(r.time_s);
  const double t0 = out.time_s.front();
  for (double& t : out.time_s) t -= t0;
  out.motion_angle_rad = cut(r.motion_angle_rad);
  out.rate_radps = cut(r.rate_radps);
  out.x_rad = cut(r.x_rad);
  out.xdot_radps = cut(r.xdot_radps);
  out.lag_states = {{cut(r.lag_states[0][0])}};
  out.y_true = {cut(r.y_true[0])};
  out.coefficient_true = {cut(r.coefficient_true[0])};
  out.coefficient_measured = {cut(r.coefficient_measured[0])};
  return out;
}

}  // namespace indicial::testing
