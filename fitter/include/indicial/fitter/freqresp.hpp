// indicial/fitter/freqresp.hpp -- the linearised frequency response of a model.
//
// What it is for
// --------------
// Small-amplitude forced-oscillation tests give "dynamic derivatives": the in-phase and
// out-of-phase parts of a coefficient's response to a harmonic oscillation about a mean
// angle, as functions of the reduced frequency k = omega l / V. A nonlinear indicial model
// has such derivatives too: its linearisation about the steady state at the mean angle. This
// header computes them exactly (no simulation), so a fitted large-amplitude model can be
// compared with small-amplitude data, and with Theodorsen's function for a thin airfoil.
//
// The linearisation (derived here, tested against a small-amplitude simulation of the runtime
// in tests/test_freqresp.cpp). Let m be the motion angle (alpha, phi or psi), x = x(m) the
// model angle, m = m0 + dm e^{i w t}, dx = x_m dm with x_m = dx/dm at m0 (1 in pitch; roll and
// yaw: the derivative of eqs. 17 / 20). About the steady state y_1* = con / b_1(x0) (other
// lags 0), the state equations y_j' = -b_j(x) y_j - c_j a(x) x' (+ con for j = 1) give
//
//   dy_j' = -b_j(x0) dy_j - b_j'(x0) y_j* dx - c_j a(x0) dx'
//   dy_j  = -[ c_j a(x0) i w + b_j'(x0) y_j* ] / (i w + b_j(x0)) dx
//
// and with the rate = m' = i w dm (q, p or r) and C_aq's own slope multiplying rate = 0,
//
//   H(w) = dC / dm = x_m [ C_a'(x0) + dC_a'(x0) - sum_j (c_j a(x0) i w + b_j'(x0) y_j*) / (i w + b_j(x0)) ]
//                    + (l / V) C_aq(x0) i w.
//
// The b_1'(x0) y_1* term is the steady state moving with the angle: at w -> 0 it tends to
// x_m d/dx [con / b_1(x)] = -x_m con b_1'(x0) / b_1(x0)^2, so H(0) is the slope of the model's
// steady-state curve C_a(x) + dC_a(x) + con / b_1(x), not of C_a(x) alone. b_j and con are
// scaled by V / V_ref like the runtime does. A pure delay tau of the forcing (delay_s, scaled by
// V_ref / V) multiplies the c_j a(x0) i w term by e^{-i w tau}.
//
// Outputs per k: H, its magnitude and phase, the in-phase component Re H (the forced-
// oscillation derivative C_a_alpha-bar, per rad) and the out-of-phase component Im H / k
// (C_a_q-bar-equivalent, per rad: the coefficient of (l/V) rate, since (l/V) m' = i k dm).
//
// Usage
// -----
//   auto model = indicial::read_model_file("model.coef");
//   auto r = indicial::linearised_response(model, 35.0 * M_PI / 180, {0.05, 0.1, 0.2},
//                                          model.airspeed_mps);
//   for (const auto& pt : r[0].points) printf("%g %g %g\n", pt.k, pt.in_phase, pt.out_of_phase);
//
// Warnings
// --------
// 1. Linear in dm: valid for small amplitudes. Near a knot of a(x), b_j(x) or C_a(x) the
//    one-sided slopes differ; exactly at a knot the LEFT slope is used (the plus functions'
//    branch u > 0 excludes the knot itself). Move off the knot for a meaningful answer.
// 2. The mean angle must be inside the model's envelope (InputError otherwise): outside it
//    the runtime clamps and the response is zero.
// 3. A static table's slope is the natural cubic spline's derivative; outside the table the
//    runtime clamps the angle, so the slope there is 0.
#pragma once

#include <complex>
#include <string>
#include <vector>

#include "indicial/model.hpp"

namespace indicial {

struct FrequencyPoint {
  double k = 0.0;             // reduced frequency omega l / V
  double omega_radps = 0.0;
  double freq_hz = 0.0;
  std::complex<double> h;     // dC / dm, per rad of motion angle
  double in_phase = 0.0;      // Re H
  double out_of_phase = 0.0;  // Im H / k (0 at k = 0)
  double magnitude = 0.0;
  double phase_deg = 0.0;
};

struct FrequencyResponse {
  std::string coefficient;
  double motion_angle0_rad = 0.0;
  double x0_rad = 0.0;
  double dx_dmotion = 1.0;             // x_m
  double static_slope = 0.0;           // C_a'(x0) + dC_a'(x0), per rad of x
  double steady_state_slope = 0.0;     // x_m (C_a' + dC_a' + d/dx con / b_1), per rad of m = H(0)
  double rotary = 0.0;                 // C_aq(x0)
  std::vector<FrequencyPoint> points;
};

// One response per coefficient of the model, at the given reduced frequencies (>= 0) and
// airspeed. Throws InputError("--alpha0-deg"/..., 0, ...) for a mean angle outside the
// envelope or a negative k.
std::vector<FrequencyResponse> linearised_response(const ModelSet<double, FitCapacity>& model,
                                                   double motion_angle0_rad,
                                                   const std::vector<double>& k_list,
                                                   double airspeed_mps);

// d(static curve)/dx at x (polynomial: exact; table: natural cubic spline derivative, 0
// outside the table where the curve is clamped).
double static_curve_slope(const CoefficientModel<double, FitCapacity>& cm, double x_rad);

}  // namespace indicial
