// diagnose_test_matrix.hpp -- the evaluation matrix of `indicial diagnose` (issue 13): data made
// differently from the way diagnose assumes, then the question "did it name the right effect,
// and does the final model explain the data to the noise level?".
//
// A case is: a coefficient (C_m: the report's Model I, tailless-model-1; C_L: f16xl-like-CL),
// a truth (the case's model plus a hidden effect at half, full or double size, or a shape
// outside the single-term vocabulary: Model II's four-knot b1(alpha), a static error
// 0.03 sin(3 alpha) with nonzero mean as a 0.5 deg table, two effects at once, or nothing), a
// motion family (three sine runs starting at rest, three sine runs 35 + 35 sin(wt) starting at
// the mean angle with the rate jumping from 0, or three ramps), and noise (the simulator's:
// white, AR(1) with phi = 0.8, or, for null cases, band-limited turbulence; marginal sigma =
// RMS(y) / 40). The truth comes from the simulator's
// reference integration (Dormand-Prince, never the fitter's discrete update); the configured
// model is the case's own, i.e. it lacks exactly the hidden effect.
//
// Used by tests/test_diagnose_matrix.cpp: a handful of representative cases in ctest, the
// whole matrix through tools/diagnose-matrix.sh (writes the table in docs/diagnose.md).
#pragma once

#include <chrono>
#include <cmath>
#include <cstdint>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "diagnose_test_data.hpp"
#include "indicial/fitter/diagnose.hpp"

namespace indicial::testing {

enum class MatrixMotion { sine_from_rest, sine_from_mean, ramps };
enum class MatrixNoise { white, ar1, turbulence };

inline const char* matrix_motion_name(MatrixMotion m) {
  switch (m) {
    case MatrixMotion::sine_from_rest: return "rest";
    case MatrixMotion::sine_from_mean: return "mean";
    case MatrixMotion::ramps: return "ramps";
  }
  return "?";
}
inline const char* matrix_noise_name(MatrixNoise n) {
  return n == MatrixNoise::white ? "white" : n == MatrixNoise::ar1 ? "AR(1) 0.8" : "turbulence 2 Hz";
}
// The simulator's noise models (simulate.hpp): white; AR(1) phi 0.8; band-limited turbulence
// (2nd-order low pass at 2 Hz, zeta 0.7: not AR(1), for the kappa approximation).
inline NoiseModel matrix_noise_model(MatrixNoise n) {
  NoiseModel m;
  if (n == MatrixNoise::ar1) {
    m.kind = NoiseKind::ar1;
    m.phi = 0.8;
  } else if (n == MatrixNoise::turbulence) {
    m.kind = NoiseKind::turbulence;
    m.cutoff_hz = 2.0;
  }
  return m;
}

struct MatrixCase {
  std::string coefficient = "Cm";   // "Cm" or "CL"
  std::string truth = "none";       // an effect name, "model2_b1", "static_sin3", "b1_alpha+bias", "none"
  std::string expected = "none";    // the effect(s) the first step may name ("a|b" for either)
  double magnitude = 1.0;           // of the hidden effect
  MatrixMotion motion = MatrixMotion::sine_from_rest;
  MatrixNoise noise = MatrixNoise::white;
  std::uint64_t seed = 1;
};

struct MatrixRow {
  MatrixCase c;
  double sigma = 0.0;               // the noise's marginal standard deviation
  double initial_over_sigma = 0.0;
  double final_over_sigma = 0.0;
  std::string first;                // the first named effect ("none")
  std::string added;                // every effect added, in order
  std::string stopped;              // diagnose's stop reason
  int steps = 0;
  double seconds = 0.0;
  bool first_right = false;
  // Not first_right, but the expected effect is named with the first as indistinguishable on
  // these data (DiagnoseStep::indistinguishable, with the experiment that separates them).
  bool first_tied = false;
};

// The base simulation case of a coefficient, with the motions of `motion`. C_L: f16xl-like-CL
// (its own configuration: b1 and a with knots, bias estimated).
inline SimulationCase matrix_base_case(const std::string& coefficient, MatrixMotion motion) {
  SimulationCase c = find_simulation_case(coefficient == "CL" ? "f16xl-like-CL" : "tailless-model-1");
  c.motions.clear();
  c.run_files.clear();
  c.experiment.runs.clear();
  const double mean = 35.0 * kDeg, amp = 35.0 * kDeg;
  for (int run = 0; run < 3; ++run) {
    const double f = run == 0 ? 0.25 : run == 1 ? 0.5 : 1.0;
    MotionSpec s;
    if (motion == MatrixMotion::sine_from_rest) {
      s.kind = MotionKind::sine;  // mean - amp cos(wt): starts at rest at the lowest angle
      s.mean_rad = mean;
      s.amplitude_rad = amp;
      s.freq_hz = f;
      s.cycles = 3.0;
    } else if (motion == MatrixMotion::sine_from_mean) {
      // 35 + 35 sin(wt) from t = 0: at the mean angle with the rate jumping from 0 (at rest
      // before), sampled and interpolated by the simulator's C2 spline.
      s.kind = MotionKind::samples;
      const double w = 2.0 * M_PI * f;
      const int n = static_cast<int>(std::lround(3.0 / f / s.dt_s)) + 1;
      for (int k = 0; k < n; ++k) {
        s.time_s.push_back(k * s.dt_s);
        s.angle_rad.push_back(mean + amp * std::sin(w * k * s.dt_s));
      }
      s.source = "matrix sine from the mean";
    } else {
      // Up at 30 and 120 deg/s, down at 60 deg/s, over the whole range.
      s.kind = MotionKind::ramp;
      const bool down = run == 1;
      s.from_rad = down ? 70.0 * kDeg : 0.0;
      s.to_rad = down ? 0.0 : 70.0 * kDeg;
      s.rate_radps = (run == 0 ? 30.0 : run == 1 ? 60.0 : 120.0) * kDeg;
    }
    c.motions.push_back(s);
    c.run_files.push_back(fmt::format("{}_{}.csv", matrix_motion_name(motion), c.motions.size()));
    Run r;
    r.path = c.run_files.back();
    c.experiment.runs.push_back(r);
  }
  return c;
}

// Each hidden effect at magnitude m (m = 1: C_m the sizes of diagnose_test_data.hpp; C_L sized
// for an initial fit error of about 2-5 noise levels). One term each, scaled by m.
inline TruthModifier matrix_effect(const std::string& coefficient, const std::string& effect, double m) {
  const bool lift = coefficient == "CL";
  return [effect, m, lift](TruthCoefficient& t) {
    if (effect == "b1_alpha") add_knot_term(t.lags[0].b, 30 * kDeg, 1, (lift ? 20.0 : 2.0) * m);
    else if (effect == "a_alpha") add_knot_term(t.a, (lift ? 35 : 45) * kDeg, 2, (lift ? 60.0 : 20.0) * m);
    else if (effect == "rotary_alpha") add_knot_term(t.rotary, 40 * kDeg, 1, (lift ? -9.0 : -3.0) * m);
    else if (effect == "bias") t.con = (lift ? -0.25 : 0.025) * m;  // C_L: configured without bias
    else if (effect == "time_delay") t.delay_s = 0.02 * m;
    else if (effect == "static_error") add_knot_term(t.static_correction, 40 * kDeg, 2, (lift ? 0.4 : 0.1) * m);
    else if (effect == "second_lag") {
      t.n_lags = 2;
      t.lags[1].b.n_powers = 1;
      t.lags[1].b.power_coef[0] = lift ? 60.0 : 20.0;
      t.lags[1].gain = (lift ? 0.8 : 0.5) * m;
    }
  };
}

// 0.03 sin(3 alpha) added to the static curve as a 0.5 deg table (outside the spline class).
inline void add_static_sine(TruthCoefficient& t) {
  auto& sc = t.static_curve;
  const auto poly = sc.polynomial;
  sc.kind = StaticKind::table;
  sc.n_table = 0;
  for (double x_deg = -10.0; x_deg <= 90.0 + 1e-9; x_deg += 0.5) {
    const double x = x_deg * kDeg;
    sc.table_x_rad[sc.n_table] = x;
    sc.table_value[sc.n_table] = spline_value(poly, x) + 0.03 * std::sin(3.0 * x);
    ++sc.n_table;
  }
  prepare_static_table(sc);
}

// The experiment of a case; `sigma` receives the noise's marginal standard deviation.
inline Experiment matrix_experiment(const MatrixCase& mc, double* sigma) {
  SimulationCase c = matrix_base_case(mc.coefficient, mc.motion);
  TruthCoefficient& t = c.truth.coefficients[0];
  if (mc.coefficient == "CL") {  // the hidden bias must be missing from the configuration
    t.con = 0.0;
    c.experiment.model.bias = false;
  }
  if (mc.truth == "model2_b1") {
    t = find_simulation_case("tailless-model-2").truth.coefficients[0];
  } else if (mc.truth == "static_sin3") {
    add_static_sine(t);
  } else if (mc.truth != "none") {
    std::string rest = mc.truth;
    while (!rest.empty()) {  // "a+b": both
      const std::size_t plus = rest.find('+');
      matrix_effect(mc.coefficient, rest.substr(0, plus), mc.magnitude)(t);
      rest = plus == std::string::npos ? "" : rest.substr(plus + 1);
    }
  }
  std::vector<SimulatedRun> runs;
  for (const auto& m : c.motions) runs.push_back(simulate_reference(c.truth, m));
  const double s = add_measurement_noise(runs, 40.0, mc.seed, matrix_noise_model(mc.noise)).at(0);
  if (sigma) *sigma = s;
  Experiment e = experiment_from_simulation(c, runs);
  e.path = fmt::format("matrix-{}-{}-{}-{}.toml", mc.coefficient, mc.truth, matrix_motion_name(mc.motion), mc.seed);
  return e;
}

inline bool expected_matches(const std::string& expected, const std::string& named) {
  std::string rest = expected;
  while (true) {
    const std::size_t bar = rest.find('|');
    if (rest.substr(0, bar) == named) return true;
    if (bar == std::string::npos) return false;
    rest = rest.substr(bar + 1);
  }
}

inline MatrixRow run_matrix_case(const MatrixCase& mc, const DiagnoseOptions& o = {}) {
  MatrixRow row;
  row.c = mc;
  const Experiment e = matrix_experiment(mc, &row.sigma);
  const auto t0 = std::chrono::steady_clock::now();
  const DiagnoseResult d = diagnose_experiment(e, o);
  row.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  row.initial_over_sigma = d.initial_fit_error / row.sigma;
  row.final_over_sigma = d.final_fit_error / row.sigma;
  row.first = d.verdict;
  for (const auto& s : d.effects_added) row.added += (row.added.empty() ? "" : " ") + s;
  row.steps = static_cast<int>(d.steps.size());
  row.stopped = diagnose_stop_name(d.stopped);
  row.first_right = expected_matches(mc.expected, row.first);
  if (!row.first_right && !d.steps.empty())
    for (Effect twin : d.steps.front().indistinguishable)
      row.first_tied = row.first_tied || expected_matches(mc.expected, effect_name(twin));
  return row;
}

// The matrix. quick: magnitude 1 and C_m only for the single effects, 10 null seeds.
inline std::vector<MatrixCase> diagnose_matrix(bool quick) {
  std::vector<MatrixCase> cases;
  const std::vector<std::string> coefs = quick ? std::vector<std::string>{"Cm"} : std::vector<std::string>{"Cm", "CL"};
  const std::vector<double> mags = quick ? std::vector<double>{1.0} : std::vector<double>{0.5, 1.0, 2.0};
  const MatrixMotion motions[] = {MatrixMotion::sine_from_rest, MatrixMotion::sine_from_mean, MatrixMotion::ramps};
  const MatrixNoise noises[] = {MatrixNoise::white, MatrixNoise::ar1};
  std::uint64_t seed = 1000;
  for (const auto& coef : coefs)
    for (const EffectDescription& ef : effect_descriptions())
      // The dynamic-stall effects have no injection into this matrix's tailless truths (they
      // need a lift polar through stall; slow_reattachment and pressure_lag also a model with the
      // families): tests/test_fit_stall_recovery.cpp, test_diagnose_stall.cpp, docs/validation-stall.md.
      if (ef.extends == EffectExtends::report_model)
      for (MatrixMotion mo : motions)
        for (double mag : mags)
          for (MatrixNoise no : noises)
            cases.push_back({coef, ef.name, ef.name, mag, mo, no, ++seed});
  for (MatrixMotion mo : {MatrixMotion::sine_from_rest, MatrixMotion::sine_from_mean})
    for (MatrixNoise no : noises) {
      cases.push_back({"Cm", "model2_b1", "b1_alpha", 1.0, mo, no, ++seed});
      cases.push_back({"Cm", "static_sin3", "static_error", 1.0, mo, no, ++seed});
      cases.push_back({"Cm", "b1_alpha+bias", "b1_alpha|bias", 1.0, mo, no, ++seed});
      cases.push_back({"Cm", "time_delay+static_error", "time_delay|static_error", 1.0, mo, no, ++seed});
    }
  const int null_seeds = quick ? 10 : 20;
  for (const auto& coef : coefs)
    for (int s = 0; s < null_seeds; ++s)
      cases.push_back({coef, "none", "none", 1.0, MatrixMotion::sine_from_rest, MatrixNoise::ar1, 5000u + s});
  for (int s = 0; s < null_seeds / 2; ++s)
    cases.push_back({"Cm", "none", "none", 1.0, MatrixMotion::sine_from_rest, MatrixNoise::turbulence, 6000u + s});
  return cases;
}

inline std::string matrix_row_markdown(const MatrixRow& r) {
  return fmt::format("| {} | {} | {} | {} | {} | {} | {} | {} | {:.2f} | {:.3f} | {} | {} | {:.1f} |\n",
                     r.c.coefficient, r.c.truth, r.c.magnitude, matrix_motion_name(r.c.motion),
                     matrix_noise_name(r.c.noise), r.c.seed, r.first,
                     r.first_right ? "yes" : r.first_tied ? "tied" : "**no**",
                     r.initial_over_sigma, r.final_over_sigma, r.steps, r.stopped, r.seconds);
}

inline std::string matrix_header_markdown() {
  return "| coef | truth | size | motion | noise | seed | first named | right | initial / sigma | final / "
         "sigma | steps | stopped | time (s) |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
}

}  // namespace indicial::testing
