// Measurement noise of the simulator: white, AR(1) and band-limited turbulence sequences
// (colored_noise), and their addition to simulated runs at a signal-to-noise ratio
// (add_measurement_noise). See indicial/fitter/simulate.hpp ("Measurement noise").
#include <cmath>
#include <complex>
#include <limits>
#include <random>
#include <vector>

#include "indicial/fitter/error.hpp"
#include "indicial/fitter/io.hpp"
#include "indicial/fitter/simulate.hpp"
#include "simulate/spec_keys.hpp"

namespace indicial {
namespace {

constexpr double kPi = 3.14159265358979323846;

// The AR(2) recursion e_k = a1 e_{k-1} + a2 e_{k-2} + w_k of the turbulence filter at step
// dt_s: the continuous poles s = wn (-zeta +- sqrt(zeta^2 - 1)) mapped by z = exp(s dt).
struct Ar2 {
  double a1 = 0.0;
  double a2 = 0.0;
};

Ar2 turbulence_recursion(const NoiseModel& n, double dt_s) {
  const double wn = 2.0 * kPi * n.cutoff_hz;
  const std::complex<double> root = std::sqrt(std::complex<double>(n.zeta * n.zeta - 1.0, 0.0));
  const std::complex<double> z1 = std::exp(wn * (-n.zeta + root) * dt_s);
  const std::complex<double> z2 = std::exp(wn * (-n.zeta - root) * dt_s);
  return {(z1 + z2).real(), -(z1 * z2).real()};
}

// Lag-1 autocorrelation of the stationary AR(2): rho1 = a1 / (1 - a2).
double ar2_rho1(const Ar2& r) { return r.a1 / (1.0 - r.a2); }

// Stationary variance of the AR(2) per unit innovation variance.
double ar2_variance(const Ar2& r) {
  return (1.0 - r.a2) / ((1.0 + r.a2) * ((1.0 - r.a2) * (1.0 - r.a2) - r.a1 * r.a1));
}

}  // namespace

NoiseModel parse_noise_spec(const std::string& spec) {
  const std::size_t colon = spec.find(':');
  const std::string kind = spec.substr(0, colon);
  detail::SpecKeys kv("--noise", kind + " noise", colon == std::string::npos ? "" : spec.substr(colon + 1));
  using Need = detail::SpecKeys::Need;
  NoiseModel n;
  if (kind == "white") {
    n.kind = NoiseKind::white;
  } else if (kind == "ar1") {
    n.kind = NoiseKind::ar1;
    n.phi = kv.take("phi", Need::required);
    if (!(std::fabs(n.phi) < 1.0)) throw InputError("--noise", 0, "ar1 'phi' must be in (-1, 1)");
  } else if (kind == "turbulence") {
    n.kind = NoiseKind::turbulence;
    n.cutoff_hz = kv.take("cutoff_hz", Need::required);
    n.zeta = kv.take("zeta", Need::optional, 0.7);
    if (!(n.cutoff_hz > 0.0)) throw InputError("--noise", 0, "turbulence 'cutoff_hz' must be > 0");
    if (!(n.zeta > 0.0)) throw InputError("--noise", 0, "turbulence 'zeta' must be > 0");
  } else {
    throw InputError("--noise", 0,
                     "unknown noise '" + kind + "' (white, ar1:phi=P, turbulence:cutoff_hz=F[,zeta=Z])");
  }
  kv.require_all_taken();
  return n;
}

double parse_snr(const std::string& text) {
  if (text == "inf" || text == "Inf" || text == "infinity") return std::numeric_limits<double>::infinity();
  double v = 0.0;
  if (!detail::parse_whole_number(text, v) || !(v > 0))
    throw InputError("--snr", 0, "expected a number > 0 or 'inf', found '" + text + "'");
  return v;
}

std::string noise_spec_text(const NoiseModel& n) {
  switch (n.kind) {
    case NoiseKind::white: return "white";
    case NoiseKind::ar1: return "ar1:phi=" + format_double(n.phi);
    case NoiseKind::turbulence:
      return "turbulence:cutoff_hz=" + format_double(n.cutoff_hz) + ",zeta=" + format_double(n.zeta);
  }
  return "white";
}

double noise_lag1_correlation(const NoiseModel& n, double dt_s) {
  switch (n.kind) {
    case NoiseKind::white: return 0.0;
    case NoiseKind::ar1: return n.phi;
    case NoiseKind::turbulence: return ar2_rho1(turbulence_recursion(n, dt_s));
  }
  return 0.0;
}

std::vector<double> colored_noise(const NoiseModel& n, std::size_t count, double dt_s, double sigma,
                                  std::mt19937_64& rng) {
  std::normal_distribution<double> unit(0.0, 1.0);
  std::vector<double> e(count, 0.0);
  if (count == 0) return e;
  switch (n.kind) {
    case NoiseKind::white:
      for (double& v : e) v = sigma * unit(rng);
      return e;
    case NoiseKind::ar1: {
      // Why sigma for e_0: the stationary marginal, so there is no start-up transient.
      const double innovation = sigma * std::sqrt(1.0 - n.phi * n.phi);
      e[0] = sigma * unit(rng);
      for (std::size_t k = 1; k < count; ++k) e[k] = n.phi * e[k - 1] + innovation * unit(rng);
      return e;
    }
    case NoiseKind::turbulence: {
      if (!(dt_s > 0.0)) throw InputError("--noise", 0, "turbulence noise needs a positive time step");
      const Ar2 r = turbulence_recursion(n, dt_s);
      const double innovation = sigma / std::sqrt(ar2_variance(r));
      const double rho1 = ar2_rho1(r);
      // (e_0, e_1) drawn from the stationary joint distribution (correlation rho1).
      e[0] = sigma * unit(rng);
      if (count > 1) e[1] = rho1 * e[0] + sigma * std::sqrt(1.0 - rho1 * rho1) * unit(rng);
      for (std::size_t k = 2; k < count; ++k) e[k] = r.a1 * e[k - 1] + r.a2 * e[k - 2] + innovation * unit(rng);
      return e;
    }
  }
  return e;
}

std::vector<double> add_measurement_noise(std::vector<SimulatedRun>& runs, double snr,
                                          std::uint64_t seed, const NoiseModel& noise_model) {
  if (runs.empty()) return {};
  const std::size_t nc = runs.front().y_true.size();
  std::vector<double> sigma(nc, 0.0);
  if (!(snr > 0)) throw InputError("--snr", 0, "SNR must be > 0 (or inf for no noise)");
  if (std::isinf(snr)) return sigma;  // no noise: the measured columns stay the truth
  for (std::size_t c = 0; c < nc; ++c) {
    double sum_sq = 0.0;
    std::size_t count = 0;
    for (const auto& r : runs) {
      for (double v : r.y_true[c]) sum_sq += v * v;
      count += r.y_true[c].size();
    }
    sigma[c] = std::sqrt(sum_sq / static_cast<double>(count)) / snr;
  }
  std::mt19937_64 rng(seed);
  for (auto& r : runs) {
    for (std::size_t c = 0; c < nc; ++c) {
      auto& measured = r.coefficient_measured[c];
      if (noise_model.kind == NoiseKind::white) {
        // Why this branch: the very stream the report's tables were reproduced with.
        std::normal_distribution<double> noise(0.0, sigma[c]);
        for (std::size_t k = 0; k < measured.size(); ++k) measured[k] = r.coefficient_true[c][k] + noise(rng);
        continue;
      }
      const std::size_t n = measured.size();
      const double dt_s = n > 1 ? (r.time_s.back() - r.time_s.front()) / static_cast<double>(n - 1) : 0.0;
      const std::vector<double> e = colored_noise(noise_model, n, dt_s, sigma[c], rng);
      for (std::size_t k = 0; k < n; ++k) measured[k] = r.coefficient_true[c][k] + e[k];
    }
  }
  return sigma;
}

}  // namespace indicial
