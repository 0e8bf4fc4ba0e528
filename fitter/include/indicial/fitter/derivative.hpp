// indicial/fitter/derivative.hpp -- smoothing differentiators for sampled signals.
//
// What it is for
// --------------
// The fitter needs derivatives of measured signals: the body rate when a run has no rate
// column (the derivative of the motion angle) and y_E' of the equation error (eq. 22). Both
// come from a local least-squares polynomial (Savitzky-Golay), on a uniform grid or on each
// sample's own time.
//
// Usage
// -----
//   std::vector<double> rate = indicial::smooth_derivative(angle_rad, dt_s,
//       indicial::default_sg_half_window, indicial::default_sg_degree);
//   std::vector<double> rate2 = indicial::smooth_derivative_nonuniform(time_s, angle_rad, 5, 3);
//
// Warnings
// --------
// 1. The filter smooths the signal as well as the noise: with fewer than ~20 samples per cycle
//    of the motion the derivative is biased (amplitude loss); give the rate when you have it.
// 2. Both functions throw std::invalid_argument (not InputError) on a bad call: the callers
//    validate the data first, so a throw here is a programming error.
#pragma once

#include <vector>

namespace indicial {

// The smoothing differentiator used for absent rate columns and for y_E' (eq. 22).
inline constexpr int default_sg_half_window = 5;
inline constexpr int default_sg_degree = 3;

// Savitzky-Golay first derivative of uniformly sampled values: at every sample, a polynomial of
// degree poly_degree is fitted by least squares to the 2 * half_window + 1 samples of a window
// and differentiated at that sample. Interior samples use the centred window; the first and
// last half_window samples use the first / last full window (the same local polynomial, fitted
// asymmetrically and evaluated at the end sample), so the ends keep the order of accuracy
// instead of dropping to a one-sided difference. Requires values.size() >= 2 * half_window + 1,
// 1 <= poly_degree <= 2 * half_window, dt_s > 0 (std::invalid_argument otherwise).
std::vector<double> smooth_derivative(const std::vector<double>& values, double dt_s,
                                      int half_window, int poly_degree);

// The same local least-squares polynomial on a non-uniform grid: at every sample the window of
// 2 * half_window + 1 samples (clamped at the ends, as above) is fitted in time and the
// polynomial differentiated at that sample's time. On a uniform grid it equals
// smooth_derivative to rounding. Requires strictly increasing time_s of the same length as
// values, and the size and degree limits above (std::invalid_argument otherwise).
std::vector<double> smooth_derivative_nonuniform(const std::vector<double>& time_s,
                                                 const std::vector<double>& values,
                                                 int half_window, int poly_degree);

}  // namespace indicial
