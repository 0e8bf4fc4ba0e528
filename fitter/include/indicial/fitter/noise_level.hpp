// indicial/fitter/noise_level.hpp -- the measurement noise level of fit residuals.
//
// What it is for
// --------------
// The residual of a good fit is the measurement noise; the residual of a model that lacks an
// effect is noise plus a smooth model error. estimate_noise_level() separates the two by their
// short-lag structure, so that a report can say whether a fit error is at the noise level
// (report.cpp, "at the noise level") and diagnose can set its noise floor (diagnose.hpp, step 1).
// It is an estimation result on residual series and lives in the estimate layer, below both
// (docs/architecture.md, "The fitter's layers").
#pragma once

#include <vector>

#include "indicial/fitter/fit.hpp"

namespace indicial {

// The measurement noise as an AR(1) process n[k] = phi n[k-1] + e[k] (white: phi = 0).
struct NoiseEstimate {
  double sigma = 0.0;                  // marginal standard deviation, pooled over runs
  double lag1_correlation = 0.0;       // phi, in [0, 0.98], pooled over runs
  double white_equivalent = 0.0;       // sqrt(mean d2^2 / 6): the white noise of the same
                                       // second-difference power (= sigma for white noise)
  std::vector<double> run_sigma;       // per run (marginal, with the pooled phi)
};

// The noise level of residual series (one per run), pooled over runs, from their first and
// second differences d1[k] = v[k+1] - v[k], d2[k] = v[k+1] - 2 v[k] + v[k-1], as AR(1) noise
// of marginal variance s^2 and lag-1 correlation phi:
//   phi = 1 + 2 r1(d1)                  (r1 = sum d1[k] d1[k-1] / sum d1^2; E r1 = -(1 - phi) / 2)
//   s^2 = mean d2^2 / (2 (1 - phi) (3 - phi))   (E d2^2 = 2 (1 - phi) (3 - phi) s^2)
//   white_equivalent^2 = mean d2^2 / 6          (the estimate before issue 13's item 3)
// Why differences: a model error that is smooth on the scale of the sample step (motion
// frequency f, step dt) is attenuated by (2 pi f dt)^2 in d1 and (2 pi f dt)^4 in d2 (4e-3
// and 2.4e-5 at 1 Hz, 100 samples/s), the noise is not; the gains on AR(1) noise are known
// exactly. Why AR(1): diagnose's LR test's kappa assumes it too (diagnose.hpp, warning 2); for
// white noise phi is ~0 and s is the white level. The white-equivalent level reads AR(1)
// phi = 0.8 noise at 0.38 of its marginal level (docs/diagnose.md, "Noise estimate", for the
// measured errors).
NoiseEstimate estimate_noise_level(const std::vector<RunSeries>& runs);

}  // namespace indicial
