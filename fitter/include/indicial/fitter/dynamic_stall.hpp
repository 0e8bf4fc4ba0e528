// indicial/fitter/dynamic_stall.hpp -- a tunnel-realistic test campaign whose truth is
// OUTSIDE the model class: a pitching NACA 0012-like airfoil in dynamic stall.
//
// What it is for
// --------------
// Every other built-in case is simulated from the model indicial fits (truth inside the
// model class, white noise, runs from rest). Real tunnel data are none of these. This
// generator produces what a dynamic-stall campaign delivers: ensemble-averaged pitching cycles
// of 128 samples with a phase column rounded to 0.01 rad (no time column), the reduced
// frequency and airspeed of each cycle in the experiment's runs table, colored measurement
// noise, and a static polar (the static test) as the static table.
//
// The truth is the Goman-Khrabrov separation-point model (Goman & Khrabrov, "State-space
// representation of aerodynamic characteristics of an aircraft at high angles of attack",
// J. Aircraft 31(5), 1994, 1109-1115):
//
//   tau1 df/dt + f = f0(alpha - tau2 alpha_dot)           (f: trailing-edge separation point)
//   C_N = C_Nalpha sin(alpha) ((1 + sqrt f) / 2)^2          (Kirchhoff flow)
//   C_C = eta C_Nalpha sin^2(alpha) sqrt f                  (leading-edge suction)
//   C_L = C_N cos(alpha) + C_C sin(alpha)
//   C_m = C_m0 + C_N (K0 + K1 (1 - f) + K2 sin(pi f^m))     (centre-of-pressure travel)
//
// with the static separation curve f0 and the C_m terms of Leishman & Beddoes ("A
// semi-empirical model for dynamic stall", J. American Helicopter Society 34(3), 1989, 3-17;
// their NACA 0012 constants at M = 0.3, rounded). Time constants are in semichord times
// l / V (l = c / 2 = the reference length), so a cycle at reduced frequency k = omega l / V is
// the same curve at every airspeed, exactly as the indicial model scales its b and con by
// V / V_ref. Integrated by Boost.Odeint's controlled Dormand-Prince 5(4), abs/rel tolerance
// 1e-11 (the project's reference integrator), never by the fitter's discretization.
//
// Usage
// -----
//   const indicial::dynamic_stall::Campaign& c = indicial::dynamic_stall::default_campaign();
//   auto cycles = indicial::dynamic_stall::simulate_campaign(c, 20.0, 1, indicial::NoiseModel{});
//   indicial::Experiment e = indicial::dynamic_stall::campaign_experiment(c, cycles, "CL",
//                                                                         CycleRole::fit);
//   // or on the command line: indicial simulate --case dynamic-stall --snr 20 --out DIR
//
// Warnings
// --------
// 1. ONE case writes both coefficients: every cycle CSV has CL and Cm columns, and there is
//    one experiment per coefficient (experiment-CL.toml, experiment-Cm.toml) listing the FIT
//    cycles only; cycles.csv lists every cycle with its role (fit / holdout), amplitude,
//    reduced frequency, frequency and airspeed.
// 2. SNR: y is the unsteady part C - C_static(alpha) over every raw sample of every cycle;
//    sigma = RMS(y) / SNR is the marginal std of the noise added to the RAW samples (before
//    averaging over Campaign::cycles_averaged cycles), so the averaged cycles carry about
//    sigma / sqrt(cycles_averaged) (the cycles' noise is independent).
// 3. The static polar is the exact static curve (f = f0(alpha)) at 0.5 deg steps, no noise:
//    a well-repeated static test. Its natural cubic spline still misses the kink of f0 at
//    alpha1 slightly -- as a measured table would.
// 4. The cycle is alpha = mean - amplitude cos(phase): phase 0 is the bottom of the cycle.
//    Each cycle is integrated from the static state through Campaign::transient_cycles before
//    the averaged cycles, so the averaged cycle is the periodic steady state.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "indicial/fitter/experiment.hpp"
#include "indicial/fitter/output.hpp"
#include "indicial/fitter/simulate.hpp"

namespace indicial::dynamic_stall {

// Every constant of the truth model, in one place.
struct AirfoilConstants {
  // Leishman & Beddoes (1989), NACA 0012, M = 0.3 (rounded):
  double normal_force_slope_per_rad = 6.47;  // C_Nalpha (0.113 / deg)
  double alpha1_deg = 15.25;                 // static break of f0 (f0(alpha1) = 0.7)
  double s1_deg = 3.0;                       // f0 = 1 - 0.3 exp((|alpha| - alpha1) / S1) below alpha1
  double s2_deg = 2.3;                       // f0 = 0.04 + 0.66 exp((alpha1 - |alpha|) / S2) above
  double k0 = 0.0025;                        // C_m: aerodynamic-centre offset from c/4
  double k1 = -0.135;                        // C_m: centre-of-pressure travel with separation
  double k2 = 0.04;                          // C_m: its shape term
  double m_exponent = 2.0;                   // C_m: sin(pi f^m)
  double cm0 = 0.0;                          // symmetric section
  double suction_recovery = 0.95;            // eta of the chord force
  // Goman-Khrabrov time constants in semichord times l / V: tau1 is the separation point's
  // relaxation (L-B's T_f = 3); tau2 the delay of separation onset (L-B's pressure lag
  // T_p = 1.7 plays that role).
  double tau1_semichords = 3.0;
  double tau2_semichords = 1.7;
};

enum class CycleRole { fit, holdout };

struct PitchCycle {
  double mean_deg = 12.0;
  double amplitude_deg = 8.0;
  double reduced_frequency = 0.05;  // k = omega l / V
  double airspeed_mps = 30.0;
  CycleRole role = CycleRole::holdout;
  std::string file;                 // CSV name in the output directory
};

struct Campaign {
  AirfoilConstants airfoil;
  double chord_m = 0.3;             // reference length l = chord / 2
  double reference_airspeed_mps = 30.0;
  std::vector<PitchCycle> cycles;
  int samples_per_cycle = 128;
  int cycles_averaged = 20;
  int transient_cycles = 3;
  double phase_resolution_rad = 0.01;  // the phase column is rounded to this
  double static_step_deg = 0.5;        // static polar grid, 0 .. static_max_deg
  double static_max_deg = 24.0;
  NoiseModel default_noise{NoiseKind::ar1, 0.8, 0.0, 0.7};  // when the caller gives none
  double reference_length_m() const { return 0.5 * chord_m; }
  double frequency_hz(const PitchCycle& c) const;
};

// 14 cycles about 12 deg: amplitude 8 deg at k = 0.02 .. 0.15 (7 cycles; k = 0.04 at 25 m/s,
// 0.08 at 30 m/s and 0.12 at 35 m/s are the fit cycles) and amplitude 6 deg at the same k;
// hold-out cycles at 25, 30 and 35 m/s.
const Campaign& default_campaign();

// The static separation point f0(alpha) (Leishman-Beddoes' exponential fit).
double static_separation(const AirfoilConstants& a, double alpha_rad);

struct Coefficients {
  double lift = 0.0;    // C_L
  double moment = 0.0;  // C_m about the quarter chord
};
// C_L and C_m at angle alpha with separation point f (the header's equations).
Coefficients airfoil_coefficients(const AirfoilConstants& a, double alpha_rad, double f);

struct PhaseAveragedCycle {
  PitchCycle cycle;
  double frequency_hz = 0.0;
  std::vector<double> phase_rad;         // rounded to Campaign::phase_resolution_rad
  std::vector<double> alpha_rad;         // exact at the unrounded phase 2 pi k / n
  std::vector<double> q_radps;
  std::vector<double> lift, moment;      // ensemble averages of the noisy samples
  std::vector<double> lift_true, moment_true;  // the periodic steady state, no noise
  std::vector<double> lift_static, moment_static;  // the static curve at alpha
};

// Every cycle of the campaign, noise as in warning 2 from std::mt19937_64(seed). snr = inf:
// no noise. Returns the cycles and, in sigma_out (if given), sigma per coefficient (CL, Cm).
std::vector<PhaseAveragedCycle> simulate_campaign(const Campaign& c, double snr, std::uint64_t seed,
                                                  const NoiseModel& noise,
                                                  std::vector<double>* sigma_out = nullptr);

// The static polar: alpha (rad) on the campaign's grid, C_L and C_m.
struct StaticPolar {
  std::vector<double> alpha_rad, lift, moment;
};
StaticPolar static_polar(const Campaign& c);

// The experiment configuration of one coefficient ("CL" or "Cm"): the static polar as the
// static table (in memory), rotary C_aq = 0 a priori, a(x) of degree 2 with knots at 10, 14
// and 17 deg, b1 constant.
Experiment campaign_experiment_config(const Campaign& c, const std::string& coefficient);

// An in-memory Experiment of the cycles with the given role, as the phase-averaged reader
// would build it: time = phase / (2 pi f) on the uniform grid, periodic runs, the measured
// coefficient and each cycle's airspeed (the fit cycles of the default campaign are at 25, 30
// and 35 m/s; V_ref is 30 m/s).
Experiment campaign_experiment(const Campaign& c, const std::vector<PhaseAveragedCycle>& cycles,
                               const std::string& coefficient, CycleRole role);

// Writes DIR/<cycle files>, DIR/static.csv, DIR/experiment-CL.toml, DIR/experiment-Cm.toml and
// DIR/cycles.csv through OutputDir. Returns sigma per coefficient (CL, Cm).
std::vector<double> write_campaign(const Campaign& c, const std::string& out_dir, double snr,
                                   std::uint64_t seed, const NoiseModel& noise, Overwrite overwrite);

}  // namespace indicial::dynamic_stall
