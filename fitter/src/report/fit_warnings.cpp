// The warnings about a finished fit (see report.hpp, fit_warnings): the fit error against the
// noise (replicates' spread, or the residual's short-lag level) and ill-conditioned estimates.
#include <cmath>
#include <fmt/format.h>
#include <string>
#include <vector>

#include "indicial/fitter/noise_level.hpp"
#include "indicial/fitter/replication.hpp"
#include "indicial/fitter/report.hpp"

namespace indicial {

std::vector<std::string> fit_warnings(const FitResult& r, const Experiment& e) {
  std::vector<std::string> w;
  // Why first: replicates' spread is the noise; a residual's short-lag level is noise only
  // where the model is right (replication.hpp).
  const ReplicationNoise rep = replication_noise(e);
  if (rep.source != NoiseSource::none) {
    if (std::isfinite(r.fit_error) && rep.sigma > 0.0 && r.fit_error > kFitErrorNoiseRatio * rep.sigma)
      w.push_back(fmt::format(
          "{}: the fit error s(v) = {:.4g} is {:.1f} times the noise level from replication ({:.4g}: {}); "
          "more than {:g} times means the model misses an effect or the input is wrong: check the angle "
          "units and columns, or run `indicial diagnose`",
          e.path, r.fit_error, r.fit_error / rep.sigma, rep.sigma, rep.detail, kFitErrorNoiseRatio));
    return w;
  }
  const NoiseEstimate noise = estimate_noise_level(r.runs);
  // Why the white-equivalent level: a model error leaks into the marginal (AR(1)) level and
  // would hide itself; the second difference does not pass it (noise_level.hpp).
  const double level = noise.white_equivalent;
  if (std::isfinite(r.fit_error) && level > 0.0 && r.fit_error > kFitErrorNoiseRatio * level) {
    w.push_back(fmt::format(
        "{}: the fit error s(v) = {:.4g} is {:.1f} times the short-lag level of the fit's own residual "
        "({:.4g}, white-equivalent, from the residuals' second differences; their AR(1) phi is {:.2f}): "
        "more than {:g} times, the residual is smooth and structured -- wrong input (check the angle units "
        "and columns) or a missing effect. That level comes from this model's residual, not from "
        "replicated data, so it is not a measurement of the noise: `indicial diagnose` decides whether an "
        "effect is missing",
        e.path, r.fit_error, r.fit_error / level, level, noise.lag1_correlation, kFitErrorNoiseRatio));
  }
  std::string weak;
  for (const ParameterEstimate& p : r.parameters)
    if (bound_exceeds_value(p)) weak += fmt::format("{}{} = {:.4g} +- {:.4g}", weak.empty() ? "" : ", ", p.name, p.value, p.cr_bound);
  if (!weak.empty())
    w.push_back(fmt::format("{}: ill-conditioned estimates (Cramer-Rao bound larger than the value): {}; the data "
                            "do not determine them (remove the terms, or add runs that excite them)",
                            e.path, weak));
  return w;
}

}  // namespace indicial
