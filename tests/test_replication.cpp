// The noise from replication (replication.hpp, issue 21 item 1): runs at one condition, cycles
// of one periodic run, a spread column; and no replication where the runs differ. The response
// is a smooth function of time (any response: what repeats is removed), the noise the
// simulator's AR(1) and white sequences with a known level.
#include <doctest/doctest.h>

#include <cmath>
#include <random>

#include "indicial/fitter/replication.hpp"
#include "indicial/fitter/simulate.hpp"

using namespace indicial;

namespace {

constexpr double kPi = 3.14159265358979323846;

// A run of n samples at dt 0.01 s: alpha = 0.3 + 0.2 sin(2 pi f t), the coefficient a smooth
// response of the angle plus noise of std sigma.
Run sine_run(double f_hz, std::size_t n, const NoiseModel& noise, double sigma, std::mt19937_64& rng) {
  Run r;
  const double dt = 0.01;
  const std::vector<double> e = colored_noise(noise, n, dt, sigma, rng);
  for (std::size_t k = 0; k < n; ++k) {
    const double t = dt * static_cast<double>(k);
    const double a = 0.3 + 0.2 * std::sin(2.0 * kPi * f_hz * t);
    r.time_s.push_back(t);
    r.motion_angle_rad.push_back(a);
    r.rate_radps.push_back(0.4 * kPi * f_hz * std::cos(2.0 * kPi * f_hz * t));
    r.coefficient.push_back(std::sin(3.0 * a) + 0.1 * std::cos(2.0 * kPi * f_hz * t) + e[k]);
  }
  r.airspeed_mps = 30.0;
  return r;
}

NoiseModel ar1(double phi) {
  NoiseModel m;
  m.kind = NoiseKind::ar1;
  m.phi = phi;
  return m;
}

}  // namespace

TEST_CASE("replication: three runs at one condition give the noise level and its correlation") {
  std::mt19937_64 rng(7);
  Experiment e;
  for (int i = 0; i < 3; ++i) e.runs.push_back(sine_run(1.0, 3000, ar1(0.8), 0.01, rng));
  const ReplicationNoise n = replication_noise(e);
  MESSAGE("replicate runs: sigma ", n.sigma, " phi ", n.lag1_correlation, " (", n.detail, ")");
  CHECK(n.source == NoiseSource::replicate_runs);
  CHECK(n.replicates == 3);
  CHECK(std::abs(n.sigma / 0.01 - 1.0) < 0.15);
  CHECK(std::abs(n.lag1_correlation - 0.8) < 0.05);
}

TEST_CASE("replication: runs at different frequencies are not replicates") {
  std::mt19937_64 rng(8);
  Experiment e;
  for (double f : {0.25, 0.5, 1.0}) e.runs.push_back(sine_run(f, 2000, ar1(0.0), 0.01, rng));
  const ReplicationNoise n = replication_noise(e);
  CHECK(n.source == NoiseSource::none);
  CHECK(n.sigma == 0.0);
  CHECK(n.detail.find("no replication") != std::string::npos);
}

TEST_CASE("replication: cycles of one periodic run, compared at equal phase") {
  std::mt19937_64 rng(9);
  Experiment e;
  e.runs.push_back(sine_run(1.0, 1000, ar1(0.0), 0.02, rng));  // 10 cycles of 100 samples
  e.runs[0].frequency_hz = 1.0;
  const ReplicationNoise n = replication_noise(e);
  MESSAGE("replicate cycles: sigma ", n.sigma, " phi ", n.lag1_correlation, " (", n.detail, ")");
  CHECK(n.source == NoiseSource::replicate_cycles);
  CHECK(n.replicates == 9);  // the first cycle (start-up transient) left out
  CHECK(std::abs(n.sigma / 0.02 - 1.0) < 0.1);
  CHECK(n.lag1_correlation < 0.1);
  // A period of 100.5 samples does not align: not replication, and the reason is given.
  e.runs[0].frequency_hz = 1.0 / 1.005;
  const ReplicationNoise m = replication_noise(e);
  CHECK(m.source == NoiseSource::none);
  CHECK(m.detail.find("not aligned") != std::string::npos);
}

TEST_CASE("replication: an ensemble-averaged run's spread column over sqrt(count)") {
  std::mt19937_64 rng(10);
  Experiment e;
  e.runs.push_back(sine_run(1.0, 100, ar1(0.0), 0.0, rng));
  e.runs[0].periodic = true;
  CHECK(replication_noise(e).source == NoiseSource::none);  // one averaged cycle, no spread
  e.runs[0].coefficient_spread.assign(100, 0.04);
  e.runs[0].ensemble_count = 16.0;
  const ReplicationNoise n = replication_noise(e);
  CHECK(n.source == NoiseSource::spread_column);
  CHECK(n.sigma == doctest::Approx(0.01));
}
