// noise_level.cpp -- the AR(1) noise level of residual series (see noise_level.hpp).
#include "indicial/fitter/noise_level.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace indicial {

namespace {
// Sums of one residual series' differences (see estimate_noise_level).
struct DifferenceSums {
  double d1_sq = 0.0, d1_lag1 = 0.0, d2_sq = 0.0, d2_count = 0.0;
  void add(const std::vector<double>& v) {
    for (std::size_t k = 1; k < v.size(); ++k) {
      const double d1 = v[k] - v[k - 1];
      d1_sq += d1 * d1;
      if (k >= 2) {
        d1_lag1 += d1 * (v[k - 1] - v[k - 2]);
        const double d2 = d1 - (v[k - 1] - v[k - 2]);
        d2_sq += d2 * d2;
        d2_count += 1.0;
      }
    }
  }
};

// Why the clamp: phi < 0 (a lag-1 correlation below white) is sampling error around white
// noise; near 1 the marginal level is not determined by the differences.
double ar1_phi(const DifferenceSums& s) {
  if (!(s.d1_sq > 0.0)) return 0.0;
  return std::clamp(1.0 + 2.0 * s.d1_lag1 / s.d1_sq, 0.0, 0.98);
}

double ar1_sigma(const DifferenceSums& s, double phi) {
  // Why NaN: a run of fewer than 3 samples has no second difference (no level, not 0).
  if (!(s.d2_count > 0.0)) return std::numeric_limits<double>::quiet_NaN();
  return std::sqrt(s.d2_sq / s.d2_count / (2.0 * (1.0 - phi) * (3.0 - phi)));
}
}  // namespace

NoiseEstimate estimate_noise_level(const std::vector<RunSeries>& runs) {
  std::vector<DifferenceSums> per_run(runs.size());
  DifferenceSums all;
  for (std::size_t r = 0; r < runs.size(); ++r) {
    per_run[r].add(runs[r].residual);
    all.add(runs[r].residual);
  }
  NoiseEstimate ne;
  ne.lag1_correlation = ar1_phi(all);
  ne.sigma = ar1_sigma(all, ne.lag1_correlation);
  ne.white_equivalent = ar1_sigma(all, 0.0);
  for (const DifferenceSums& s : per_run) ne.run_sigma.push_back(ar1_sigma(s, ne.lag1_correlation));
  return ne;
}

}  // namespace indicial
