// indicial/fitter/simulate.hpp -- the reference simulator: truth data for tests and examples.
//
// What it is for
// --------------
// Simulated wind-tunnel runs whose truth is known to ~1e-10: the continuous model
//
//   y_j' = -b_j(x) y_j - c_j a(x_f) x_f' (+ con),   C_a = C_a(x) + dC_a(x) + (l/V) C_aq(x) rate + sum_j y_j
//
// (shared/include/indicial/model.hpp, lag_derivatives and coefficient_output), plus, for a
// coefficient with dynamic-stall families, the separation point f, the vortex lift v and the
// vortex clock tau_v (model.hpp's stall_derivatives, x' the motion's exact rate) and their
// output delta stall_output, is integrated by
// Boost.Odeint's Dormand-Prince 5(4) with error control (abs and rel tolerance 1e-12), with the
// motion known analytically (sine, ramp) or as a C2 cubic B-spline through a sampled history.
// The discrete update advance_lags() is NEVER used here: the simulator is the yardstick the
// discrete update is measured against (tests/test_advance_lags.cpp).
//
// Usage
// -----
//   const indicial::SimulationCase& c = indicial::find_simulation_case("tailless-model-2");
//   std::vector<indicial::SimulatedRun> runs;
//   for (const auto& m : c.motions) runs.push_back(indicial::simulate_reference(c.truth, m));
//   std::vector<double> sigma = indicial::add_measurement_noise(runs, 40.0, 7);   // SNR, seed
//   indicial::write_simulation_case(c, "out/", 40.0, 7, indicial::Overwrite::refuse);
//
// Adding a built-in case: add an entry to simulation_cases() in fitter/src/simulate/cases.cpp (a
// family of cases in its own cases_*.cpp, declared in cases_internal.hpp): the truth ModelSet,
// its motions, the run file names and the experiment configuration to write.
//
// Warnings
// --------
// 1. Every run starts at rest at its first angle x0: each lag at its steady state there,
//    y_1(t0) = con / b_1(x0), y_j(t0) = 0 for j >= 2 (model.hpp's steady_state; y = 0 when
//    con = 0), and, for a delay, the forcing angle held at its first value before t0. This is
//    the one initial state of every command: the runtime's reset(), predict (non-periodic),
//    simulate --model and --case. Why this one: a model held at x0 for a long time is there
//    (y' = 0); y = 0 with con != 0 is a transient the tunnel never shows. A sine motion is
//    x(t) = mean - amplitude cos(2 pi f t), which starts at rest; a CSV motion that starts
//    moving starts from the same state all the same.
// 2. The integration runs between consecutive output samples, and is also split at the kinks
//    of a ramp and at the times a delayed forcing sees them; the plus-function knots of a(x),
//    b(x) are left to the error control (they are C0..C1 in time, not discontinuous).
//    Dynamic stall: the shedding criterion and the vortex's passage of the trailing edge are
//    logistic switches of widths w and w_t (model.hpp: smooth, steep), which the error control
//    resolves like any fast term; the f0 table's rows, the clipping of f0c, |C_N'| at 0 and the
//    clamp of xi are kinks of the right-hand side (continuous, a jump of its derivative),
//    left to the error control like the knots. A jump of the rate (a ramp's kinks, a sampled
//    motion's start) makes the lagged angle x - T2 (l/V) x' and so f0c and the switch JUMP:
//    those are exactly the motion's kinks, where the integration is already split. The kinks
//    cost the error control its regular convergence in the tolerance, not its accuracy.
//    Measured on a deep-stall cycle (tests/test_simulate_stall.cpp, 4..24 deg at k = 0.1, the
//    vortex shed): the default tolerance 1e-12 is within 5.8e-10 of a 1e-13 integration in
//    C_L and C_m (1e-10: 2.4e-8; 1e-11: 2.3e-8), and the runtime's discrete step converges to
//    it at order 2 (max error 8.6e-6 at 2000 steps per cycle).
// 3. SNR follows the corrected definition at the top of the reference report: sigma =
//    RMS(y) over all samples of all runs of the set, divided by the SNR, with y the unsteady
//    part (eq. 12) = sum_j y_j. Noise is Gaussian (white by default; AR(1) or band-limited
//    turbulence by NoiseModel) from std::mt19937_64(seed) and std::normal_distribution;
//    streams are reproducible with one standard library.
// 4. The model is simulated at its reference airspeed (time_scale = 1) unless
//    MotionSpec::airspeed_mps says otherwise (then time_scale = V / V_ref, as the runtime).
#pragma once

#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "indicial/fitter/experiment.hpp"
#include "indicial/fitter/output.hpp"
#include "indicial/model.hpp"

namespace indicial {

using TruthModel = ModelSet<double, FitCapacity>;

// Copies a model set of a smaller capacity (e.g. the runtime's DefaultCapacity) into the
// simulator's. Every field is copied; counts are checked against the larger capacity by
// construction (static_asserts).
template <class Cap>
TruthModel to_truth_model(const ModelSet<double, Cap>& in) {
  static_assert(Cap::max_powers <= FitCapacity::max_powers && Cap::max_knots <= FitCapacity::max_knots &&
                    Cap::max_lags <= FitCapacity::max_lags &&
                    Cap::max_table_points <= FitCapacity::max_table_points &&
                    Cap::max_coefficients <= FitCapacity::max_coefficients,
                "to_truth_model: the source capacity must fit in FitCapacity");
  TruthModel out;
  out.axis = in.axis;
  out.reference_length_m = in.reference_length_m;
  out.airspeed_mps = in.airspeed_mps;
  out.alpha0_rad = in.alpha0_rad;
  out.x_min_rad = in.x_min_rad;
  out.x_max_rad = in.x_max_rad;
  out.n_coefficients = in.n_coefficients;
  auto copy_spline = [](const auto& s, auto& d) {
    d.n_powers = s.n_powers;
    for (int i = 0; i < s.n_powers; ++i) d.power_coef[i] = s.power_coef[i];
    d.n_knots = s.n_knots;
    for (int j = 0; j < s.n_knots; ++j) {
      d.knot_rad[j] = s.knot_rad[j];
      d.knot_power[j] = s.knot_power[j];
      d.knot_coef[j] = s.knot_coef[j];
    }
  };
  for (int c = 0; c < in.n_coefficients; ++c) {
    const auto& s = in.coefficients[c];
    auto& d = out.coefficients[c];
    for (int i = 0; i < 8; ++i) d.name[i] = s.name[i];
    d.static_curve.kind = s.static_curve.kind;
    copy_spline(s.static_curve.polynomial, d.static_curve.polynomial);
    d.static_curve.n_table = s.static_curve.n_table;
    for (int i = 0; i < s.static_curve.n_table; ++i) {
      d.static_curve.table_x_rad[i] = s.static_curve.table_x_rad[i];
      d.static_curve.table_value[i] = s.static_curve.table_value[i];
      d.static_curve.table_second_derivative[i] = s.static_curve.table_second_derivative[i];
    }
    copy_spline(s.static_correction, d.static_correction);
    copy_spline(s.rotary, d.rotary);
    copy_spline(s.a, d.a);
    d.n_lags = s.n_lags;
    for (int j = 0; j < s.n_lags; ++j) {
      copy_spline(s.lags[j].b, d.lags[j].b);
      d.lags[j].gain = s.lags[j].gain;
    }
    d.con = s.con;
    d.delay_s = s.delay_s;
    d.stall.families = s.stall.families;
    const auto& sp = s.stall.separation;
    auto& dp = d.stall.separation;
    dp.normal_force_slope_per_rad = sp.normal_force_slope_per_rad;
    dp.zero_lift_angle_rad = sp.zero_lift_angle_rad;
    dp.n_f0 = sp.n_f0;
    for (int i = 0; i < sp.n_f0; ++i) {
      dp.f0_x_rad[i] = sp.f0_x_rad[i];
      dp.f0_value[i] = sp.f0_value[i];
    }
    copy_spline(sp.f0_correction, dp.f0_correction);
    dp.tau1_semichords = sp.tau1_semichords;
    dp.tau2_semichords = sp.tau2_semichords;
    dp.forcing_lag = sp.forcing_lag;
    dp.tau1_reattach_semichords = sp.tau1_reattach_semichords;
    dp.reattach_shift_rad = sp.reattach_shift_rad;
    dp.lag_limit_rad = sp.lag_limit_rad;
    dp.cp_k0 = sp.cp_k0;
    dp.cp_k1 = sp.cp_k1;
    dp.cp_k2 = sp.cp_k2;
    d.stall.vortex = s.stall.vortex;
  }
  return out;
}

// ------------------------------------------------------------------------------------------
// Motions
// ------------------------------------------------------------------------------------------
enum class MotionKind { sine, ramp, samples };

struct MotionSpec {
  MotionKind kind = MotionKind::sine;
  double dt_s = 0.01;
  // sine: angle(t) = mean_rad - amplitude_rad cos(2 pi freq_hz t), t = 0 .. cycles / freq_hz
  double mean_rad = 0.0;
  double amplitude_rad = 0.0;
  double freq_hz = 1.0;
  double cycles = 3.0;
  // ramp: held at from_rad for hold_before_s, then at rate_radps (> 0, the sign follows
  // to - from) to to_rad, then held for hold_after_s.
  double from_rad = 0.0;
  double to_rad = 0.0;
  double rate_radps = 0.0;
  double hold_before_s = 0.5;
  double hold_after_s = 2.0;
  // samples: a uniformly sampled motion-angle history (e.g. from a CSV), interpolated by a C2
  // cubic B-spline (Boost.Math cardinal_cubic_b_spline); output at the same times.
  std::vector<double> time_s;
  std::vector<double> angle_rad;
  std::string source;  // where the samples came from (messages)
  // The run's tunnel airspeed; 0: the model's reference airspeed. At V the model's b_j and con
  // scale by V / V_ref, its delay by V_ref / V and the rotary term's l / V is at V (as the
  // runtime does).
  double airspeed_mps = 0.0;
  // sine and ramp: when not empty, the output sample times (strictly increasing, from >= 0)
  // instead of the uniform grid of dt_s -- e.g. a jittered, nonuniform log.
  std::vector<double> output_times_s;
};

// Parses --motion: "sine:alpha0_deg=35,amp_deg=35,freq_hz=0.5,cycles=3,dt_s=0.01",
// "ramp:from_deg=0,to_deg=70,rate_dps=30,dt_s=0.01[,hold_before_s=0.5,hold_after_s=2]" or
// "csv:PATH" (a run CSV with time_s and the axis' angle column). In roll and yaw the sine's
// mean is mean_deg (alpha0 is the model's fixed angle of attack); mean_deg is accepted in
// pitch too. Throws InputError("--motion", 0, problem).
MotionSpec parse_motion_spec(const std::string& spec, Axis axis);

// The output sample times of a motion.
std::vector<double> motion_sample_times(const MotionSpec& motion);

// ------------------------------------------------------------------------------------------
// Reference integration
// ------------------------------------------------------------------------------------------
struct ReferenceTolerance {
  double abs = 1e-12;
  double rel = 1e-12;
};

struct SimulatedRun {
  std::vector<double> time_s;
  std::vector<double> motion_angle_rad;  // alpha, phi or psi
  std::vector<double> rate_radps;        // q, p or r (the motion angle's derivative)
  std::vector<double> x_rad;             // model angle alpha or beta
  std::vector<double> xdot_radps;
  // Indexed [coefficient][...] over model.n_coefficients:
  std::vector<std::vector<std::vector<double>>> lag_states;  // [c][j][k]
  // [c][k]: the dynamic-stall states (f, v, tau_v) of a coefficient with families (empty
  // for one without).
  std::vector<std::vector<StallState<double>>> stall_states;
  std::vector<std::vector<double>> y_true;                   // [c][k] = sum_j lag_states
                                                             //   + stall_output (the families' delta)
  std::vector<std::vector<double>> coefficient_true;         // [c][k]
  std::vector<std::vector<double>> coefficient_measured;     // [c][k]: true + noise
};

// Integrates every coefficient's lag states and dynamic-stall states of `model` along
// `motion` from rest.
SimulatedRun simulate_reference(const TruthModel& model, const MotionSpec& motion,
                                const ReferenceTolerance& tolerance = {});

// ------------------------------------------------------------------------------------------
// Measurement noise (white or colored)
// ------------------------------------------------------------------------------------------
// Tunnel residuals are colored (balance dynamics, turbulence, vortex shedding). Every kind is
// a zero-mean stationary Gaussian sequence per run and coefficient, started in its stationary
// distribution (no transient), with MARGINAL standard deviation sigma_c = RMS(y_true[c] over
// all runs) / snr (the report's corrected SNR convention, applied to the noise's marginal std).
//   white       e_k = sigma w_k                                 (the report's noise)
//   ar1         e_k = phi e_{k-1} + sigma sqrt(1 - phi^2) w_k,  |phi| < 1 (lag-1 corr. phi)
//   turbulence  white noise through the 2nd-order low pass wn^2 / (s^2 + 2 zeta wn s + wn^2),
//               wn = 2 pi cutoff_hz, discretized exactly at the run's step by its poles
//               (z = exp(s dt)): the AR(2) e_k = a1 e_{k-1} + a2 e_{k-2} + s_w w_k, scaled to
//               the marginal sigma; a band-limited (Dryden-like) turbulence spectrum.
// Command-line spelling (parse_noise_spec): "white", "ar1:phi=0.8",
// "turbulence:cutoff_hz=2[,zeta=0.7]".
enum class NoiseKind { white, ar1, turbulence };

struct NoiseModel {
  NoiseKind kind = NoiseKind::white;
  double phi = 0.0;        // ar1: lag-1 autocorrelation, |phi| < 1
  double cutoff_hz = 0.0;  // turbulence: natural frequency of the low pass, > 0
  double zeta = 0.7;       // turbulence: damping ratio, > 0
};

// Parses the spelling above; throws InputError("--noise", 0, problem).
NoiseModel parse_noise_spec(const std::string& spec);
// Parses --snr: a number > 0, or "inf" / "Inf" / "infinity" (no noise); throws
// InputError("--snr", 0, problem).
double parse_snr(const std::string& text);
// The spelling back ("ar1:phi=0.8"), for comments and reports.
std::string noise_spec_text(const NoiseModel& noise);
// The theoretical lag-1 autocorrelation of the noise sampled at step dt_s.
double noise_lag1_correlation(const NoiseModel& noise, double dt_s);

// One stationary noise sequence of n samples at step dt_s with marginal std sigma, drawn
// from rng (std::mt19937_64 with std::normal_distribution).
std::vector<double> colored_noise(const NoiseModel& noise, std::size_t n, double dt_s, double sigma,
                                  std::mt19937_64& rng);

// Adds noise to coefficient_measured of every run, sigma_c = RMS(y_true[c] over all runs) /
// snr. Returns sigma per coefficient. snr = +inf adds nothing (sigma 0, RNG unused). White
// noise draws exactly the stream it always drew (Tables II-IV are reproduced with it); each
// run and coefficient gets its own stationary sequence, in run-major order, from one
// std::mt19937_64(seed).
std::vector<double> add_measurement_noise(std::vector<SimulatedRun>& runs, double snr,
                                          std::uint64_t seed, const NoiseModel& noise = {});

// ------------------------------------------------------------------------------------------
// Built-in cases
// ------------------------------------------------------------------------------------------
struct SimulationCase {
  std::string name;
  std::string description;
  TruthModel truth;
  std::vector<MotionSpec> motions;
  std::vector<std::string> run_files;  // one per motion, relative to the output directory
  Experiment experiment;               // the configuration written to experiment.toml
                                       // (runs[i].path = run_files[i], no data)
};

// The registry. tailless-model-1 and tailless-model-2: the report's Table I, Example 1.
const std::vector<SimulationCase>& simulation_cases();
// Throws InputError("--case", 0, ...) listing the known names.
const SimulationCase& find_simulation_case(const std::string& name);

// The CSV text of one simulated run: time_s, <angle>_deg, <rate>_degps, then per coefficient
// its measured column (e.g. Cm) and <name>_true, then y_true (one coefficient) or
// y_true_<name> (several).
std::string simulated_run_csv(const TruthModel& model, const SimulatedRun& run,
                              const std::vector<std::string>& comment_lines);

// The truth model as coefficient-file text (runtime/include/indicial/coef_file.hpp's writer).
std::string truth_coef_text(const TruthModel& model);

// Simulates a case and writes DIR/<run files>, DIR/experiment.toml and DIR/truth.coef (the
// true model, loadable by the runtime and by `simulate --model`) through OutputDir. Returns
// sigma per coefficient.
std::vector<double> write_simulation_case(const SimulationCase& c, const std::string& out_dir,
                                          double snr, std::uint64_t seed, Overwrite overwrite,
                                          const NoiseModel& noise = {});

}  // namespace indicial
