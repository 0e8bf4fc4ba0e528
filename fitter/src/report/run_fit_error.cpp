// The RMS and the mean of a run's residuals (see report.hpp, run_fit_error).
#include <cmath>
#include <limits>

#include "indicial/fitter/report.hpp"

namespace indicial {

double run_fit_error(const RunSeries& s) {
  if (s.residual.empty()) return std::numeric_limits<double>::quiet_NaN();
  double sum = 0.0;
  for (double v : s.residual) sum += v * v;
  return std::sqrt(sum / static_cast<double>(s.residual.size()));
}

double run_mean_residual(const RunSeries& s) {
  if (s.residual.empty()) return std::numeric_limits<double>::quiet_NaN();
  double sum = 0.0;
  for (double v : s.residual) sum += v;
  return sum / static_cast<double>(s.residual.size());
}

}  // namespace indicial
