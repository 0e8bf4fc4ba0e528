// indicial/fitter/replication.hpp -- the measurement noise from REPLICATION, never from the
// residual of the model under test (issue 21, item 1).
//
// Why
// ---
// A residual's short-lag structure cannot tell measurement noise from a model error that is
// smooth on the sample scale, nor from noise smoother than the sample step: on measured
// pitching cycles the residual of a model that misses dynamic stall is structured and
// repeatable (lag-1 correlation 0.98), and an AR(1) noise model fitted to it reads it as noise
// (estimate_noise_level in diagnose.hpp). What repeats from one realisation of a condition to
// the next is the response; what does not is the noise. So the noise is the spread between
// replicates at equal phase:
//
//   replicate_runs    several runs at one condition: the same number of samples, the same time
//                     step and airspeed, motion angles equal to within 0.5 % of their range
//                     (RMS); the spread about the group's sample-by-sample mean.
//   replicate_cycles  several cycles in one run of a periodic motion (the run's frequency_hz
//                     known, a uniform grid, and a period that is a whole number of samples to
//                     within 0.1 sample over the run); the first cycle is left out when there
//                     are three or more (the start-up transient); the spread about the cycles'
//                     mean at equal phase index.
//   spread_column     an ensemble-averaged file with a spread column (Run::coefficient_spread,
//                     the standard deviation of the single cycles at each sample) and a count
//                     (Run::ensemble_count): the averaged value's noise is spread / sqrt(count).
//   none              no replication: the noise is not known, and the residual is NOT treated
//                     as noise (diagnose then says so and decides by prediction where it can).
//
// With R replicates the deviations d_rk = c_rk - mean_r c_rk have variance sigma^2 (R - 1) / R:
// sigma^2 = sum d^2 / (K (R - 1)) is unbiased. Their lag-1 correlation is the noise's own (the
// factor (R - 1) / R cancels), clamped to [0, 0.98] as in diagnose.
//
// Usage
// -----
//   indicial::ReplicationNoise n = indicial::replication_noise(experiment);
//   if (n.source != indicial::NoiseSource::none) use(n.sigma, n.lag1_correlation);
//   std::puts(n.detail.c_str());   // "3 runs at one condition (runs 1, 2, 3)" or why none
//
// Warnings
// --------
// 1. Replicates that differ in motion carry the response's difference into the spread: the
//    0.5 % tolerance on the angle bounds that leak by 0.005 x range x the coefficient's slope.
//    A measured sweep whose runs differ in frequency or mean angle is not replication.
// 2. Cycles of one run are compared at equal sample index: a period that is not a whole number
//    of samples is reported as not aligned (interpolation would smooth the noise it measures).
// 3. An ensemble-averaged file (one cycle per run, Run::periodic) without a spread column has
//    no replication, however many cycles went into the average.
#pragma once

#include <string>
#include <vector>

#include "indicial/fitter/experiment.hpp"

namespace indicial {

enum class NoiseSource { replicate_runs, replicate_cycles, spread_column, none };
const char* noise_source_name(NoiseSource s);  // "replicate_runs", ..., "none"

struct ReplicationNoise {
  NoiseSource source = NoiseSource::none;
  double sigma = 0.0;             // noise standard deviation of one sample (0 with source none)
  double lag1_correlation = 0.0;  // of the deviations between replicates, in [0, 0.98]
  int replicates = 0;             // runs or cycles compared (summed over groups)
  int groups = 0;                 // conditions with two or more replicates
  std::size_t samples = 0;        // deviations used
  std::string detail;             // one line: what was compared, or why there is no replication
};

// The noise from the experiment's replication, in the order of the list above (the first
// source with data wins). Never reads the residual of any model.
ReplicationNoise replication_noise(const Experiment& e);

}  // namespace indicial
