// The report's prediction study (figures 11-16) on the F-16XL-like cases: identify C_L and C_m
// from the four 35 deg-amplitude oscillations (fitter library, the report's structure), then
// predict motions the fit never saw -- 20 deg-amplitude oscillations and ramps at two rates --
// with the runtime, and score them against the reference integration plus noise. The
// identified model must beat the quasi-steady model (static + rotary) on every held-out motion,
// in RMS error and in Theil's inequality coefficient.
//
// The static curves of these cases are ASSUMED (the report gives none): see
// fitter/src/simulate/cases_f16xl.cpp and docs/validation-prediction.md.
#include <doctest/doctest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "indicial/fitter/fit.hpp"
#include "indicial/fitter/montecarlo.hpp"
#include "indicial/fitter/predict.hpp"
#include "indicial/fitter/simulate.hpp"
#include "fit_test_data.hpp"
#include "test_support.hpp"

namespace {

using indicial::testing::kPi;
constexpr double kDeg = kPi / 180.0;
constexpr double kSnr = 20.0;  // fitting data; the held-out data get the same noise sigma

struct HeldOut {
  std::string name;
  indicial::MotionSpec motion;
};

std::vector<HeldOut> held_out_motions() {
  std::vector<HeldOut> h;
  for (double f : {0.42, 1.0}) {
    indicial::MotionSpec s;
    s.kind = indicial::MotionKind::sine;
    s.mean_rad = 35.0 * kDeg;
    s.amplitude_rad = 20.0 * kDeg;
    s.freq_hz = f;
    s.cycles = 3;
    s.dt_s = 0.01;
    h.push_back({"sine 35+-20 deg, " + std::to_string(f).substr(0, 4) + " Hz", s});
  }
  for (double rate : {15.0, 60.0}) {
    indicial::MotionSpec s;
    s.kind = indicial::MotionKind::ramp;
    s.from_rad = 0.0;
    s.to_rad = 60.0 * kDeg;
    s.rate_radps = rate * kDeg;
    s.hold_before_s = 0.5;
    s.hold_after_s = 2.0;
    s.dt_s = 0.01;
    h.push_back({"ramp 0-60 deg at " + std::to_string(static_cast<int>(rate)) + " deg/s", s});
  }
  return h;
}

void study(const char* case_name, std::uint64_t seed) {
  const indicial::SimulationCase& c = indicial::find_simulation_case(case_name);
  const indicial::TruthModel& truth = c.truth;
  std::vector<indicial::SimulatedRun> sims;
  for (const auto& m : c.motions) sims.push_back(indicial::simulate_reference(truth, m));
  const std::vector<double> sigma = indicial::add_measurement_noise(sims, kSnr, seed);

  const indicial::Experiment e = indicial::experiment_from_simulation(c, sims);
  const indicial::FitResult fit = indicial::fit_experiment(e, indicial::FitOptions{});
  MESSAGE(std::string(case_name) << ": ML " << std::string(indicial::termination_name(fit.output_error.termination))
                    << ", s(v) = " << fit.fit_error << " (noise sigma " << sigma[0] << ")");
  for (const auto& p : fit.parameters)
    if (p.name.rfind("y0_", 0) != 0) MESSAGE("  " << p.name << " = " << p.value << " (" << p.cr_bound << ")");
  // The fit reproduces its own data to the noise level: s(v) / sigma within 4 standard errors
  // plus the ML bias (measured 1.006 and 0.993; the former one-sided < 1.3 was ~5x wider and
  // passed any s(v) below sigma).
  CHECK(std::abs(fit.fit_error / sigma[0] - 1.0) < indicial::testing::fit_error_ratio_tolerance(fit));

  // The predicting model: the fitted one (its C_aq is the experiment's, C_Lq's a priori knot
  // terms included), over the truth's envelope.
  indicial::ModelSet<double, indicial::FitCapacity> model = fit.model;
  model.x_min_rad = truth.x_min_rad;
  model.x_max_rad = truth.x_max_rad;
  REQUIRE(model.coefficients[0].rotary.n_knots == truth.coefficients[0].rotary.n_knots);

  std::mt19937_64 rng(seed + 1000);
  std::normal_distribution<double> noise(0.0, sigma[0]);
  for (const HeldOut& h : held_out_motions()) {
    const indicial::SimulatedRun s = indicial::simulate_reference(truth, h.motion);
    std::vector<double> measured = s.coefficient_true[0];
    for (double& v : measured) v += noise(rng);
    indicial::Prediction p =
        indicial::predict_motion(model, s.time_s, s.motion_angle_rad, s.rate_radps, truth.airspeed_mps);
    p.coefficients[0].measured = measured;
    indicial::score_coefficients(p);
    const auto& m = p.coefficients[0].model_metrics;
    const auto& q = p.coefficients[0].quasi_steady_metrics;
    // Against the noise-free truth too: how much of the error is the model's own.
    const auto t = indicial::score_prediction(s.coefficient_true[0], p.coefficients[0].predicted);
    MESSAGE(std::string(case_name) << " | " << h.name << " | model RMS " << m.rms_error << " max " << m.max_error
                      << " TIC " << m.theil_inequality << " | quasi-steady RMS " << q.rms_error
                      << " max " << q.max_error << " TIC " << q.theil_inequality
                      << " | model vs noise-free truth RMS " << t.rms_error);
    CHECK(p.clamped_samples == 0);
    CHECK(m.rms_error < q.rms_error);
    CHECK(m.theil_inequality < q.theil_inequality);
    // And by a clear margin: the model's error is close to the noise (<= 1.5 sigma), the
    // quasi-steady model's is not.
    CHECK(m.rms_error < 1.5 * sigma[0]);
  }
}

}  // namespace

TEST_CASE("f16xl-like-CL: fit on 35 deg oscillations then predict 20 deg oscillations and ramps") {
  study("f16xl-like-CL", 101);
}

TEST_CASE("f16xl-like-Cm: fit on 35 deg oscillations then predict 20 deg oscillations and ramps") {
  study("f16xl-like-Cm", 202);
}
