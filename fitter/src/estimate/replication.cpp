// replication.cpp -- the noise from replicates (replication.hpp): runs at one condition, cycles
// of one periodic run, or an ensemble file's spread column. Written by hand: the pooled
// within-group variance and lag-1 correlation are a few sums, no library does this grouping.
#include "indicial/fitter/replication.hpp"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>

namespace indicial {

const char* noise_source_name(NoiseSource s) {
  switch (s) {
    case NoiseSource::replicate_runs: return "replicate_runs";
    case NoiseSource::replicate_cycles: return "replicate_cycles";
    case NoiseSource::spread_column: return "spread_column";
    case NoiseSource::none: return "none";
  }
  return "?";
}

namespace {

constexpr double kAngleTolerance = 0.005;   // RMS motion difference / angle range (warning 1)
constexpr double kAlignTolerance = 0.1;     // samples of phase drift over a run (warning 2)

// Sums over groups of replicates: the deviations from each group's sample-by-sample mean.
struct SpreadSums {
  double ss = 0.0, lag1 = 0.0, dof = 0.0;
  std::size_t samples = 0;
  int replicates = 0, groups = 0;
  // `rep` are R equally long series of one condition.
  void add_group(const std::vector<const double*>& rep, std::size_t n) {
    const std::size_t r = rep.size();
    if (r < 2 || n < 2) return;
    for (std::size_t i = 0; i < r; ++i) {
      double prev = 0.0;
      for (std::size_t k = 0; k < n; ++k) {
        double mean = 0.0;
        for (const double* s : rep) mean += s[k];
        mean /= static_cast<double>(r);
        const double d = rep[i][k] - mean;
        ss += d * d;
        if (k > 0) lag1 += d * prev;
        prev = d;
      }
    }
    dof += static_cast<double>(n) * static_cast<double>(r - 1);
    samples += n * r;
    replicates += static_cast<int>(r);
    ++groups;
  }
  void finish(ReplicationNoise& out, NoiseSource src) const {
    if (!(dof > 0.0) || !(ss > 0.0)) return;
    out.source = src;
    out.sigma = std::sqrt(ss / dof);
    out.lag1_correlation = std::clamp(lag1 / ss, 0.0, 0.98);
    out.samples = samples;
    out.replicates = replicates;
    out.groups = groups;
  }
};

double rms_difference(const std::vector<double>& a, const std::vector<double>& b) {
  double s = 0.0;
  for (std::size_t k = 0; k < a.size(); ++k) s += (a[k] - b[k]) * (a[k] - b[k]);
  return std::sqrt(s / static_cast<double>(a.size()));
}

bool same_condition(const Run& a, const Run& b, double angle_range) {
  if (a.size() != b.size() || a.size() < 3 || a.periodic != b.periodic) return false;
  if (a.coefficient.size() != a.size() || b.coefficient.size() != b.size()) return false;
  if (std::abs(a.dt_s() - b.dt_s()) > 1e-6 * std::abs(a.dt_s())) return false;
  if (std::abs(a.airspeed_mps - b.airspeed_mps) > 0.01 * std::max(a.airspeed_mps, b.airspeed_mps)) return false;
  return rms_difference(a.motion_angle_rad, b.motion_angle_rad) <= kAngleTolerance * angle_range;
}

std::string run_list(const std::vector<std::size_t>& idx) {
  std::string s;
  for (std::size_t i : idx) s += (s.empty() ? "" : ", ") + std::to_string(i + 1);
  return s;
}

ReplicationNoise from_replicate_runs(const Experiment& e) {
  ReplicationNoise out;
  double lo = 0.0, hi = 0.0;
  bool first = true;
  for (const Run& r : e.runs)
    for (double a : r.motion_angle_rad) {
      lo = first ? a : std::min(lo, a);
      hi = first ? a : std::max(hi, a);
      first = false;
    }
  const double range = hi - lo;
  std::vector<bool> used(e.runs.size(), false);
  SpreadSums sums;
  std::string groups;
  for (std::size_t i = 0; i < e.runs.size(); ++i) {
    if (used[i]) continue;
    std::vector<std::size_t> g{i};
    for (std::size_t j = i + 1; j < e.runs.size(); ++j)
      if (!used[j] && same_condition(e.runs[i], e.runs[j], range)) g.push_back(j);
    if (g.size() < 2) continue;
    std::vector<const double*> rep;
    for (std::size_t j : g) {
      used[j] = true;
      rep.push_back(e.runs[j].coefficient.data());
    }
    sums.add_group(rep, e.runs[i].size());
    groups += (groups.empty() ? "runs " : "; runs ") + run_list(g);
  }
  sums.finish(out, NoiseSource::replicate_runs);
  if (out.source != NoiseSource::none)
    out.detail = fmt::format("{} runs at {} condition(s) ({})", out.replicates, out.groups, groups);
  return out;
}

ReplicationNoise from_replicate_cycles(const Experiment& e, std::string& why_not) {
  ReplicationNoise out;
  SpreadSums sums;
  for (std::size_t i = 0; i < e.runs.size(); ++i) {
    const Run& r = e.runs[i];
    if (r.periodic || !(r.frequency_hz > 0.0) || r.time_grid != TimeGrid::uniform || !(r.dt_s() > 0.0)) continue;
    const double period = 1.0 / (r.frequency_hz * r.dt_s());
    const auto p = static_cast<std::size_t>(std::lround(period));
    const std::size_t cycles = p > 0 ? r.size() / p : 0;
    if (cycles < 2) continue;
    if (std::abs(period - static_cast<double>(p)) * static_cast<double>(cycles) > kAlignTolerance) {
      why_not = fmt::format("run {}: its period is {:.3f} samples, not a whole number (cycles not aligned)", i + 1, period);
      continue;
    }
    // Why skip the first: a run from rest carries its start-up transient in cycle 1.
    const std::size_t skip = cycles >= 3 ? 1 : 0;
    std::vector<const double*> rep;
    for (std::size_t c = skip; c < cycles; ++c) rep.push_back(r.coefficient.data() + c * p);
    sums.add_group(rep, p);
  }
  sums.finish(out, NoiseSource::replicate_cycles);
  if (out.source != NoiseSource::none)
    out.detail = fmt::format("{} cycles of {} periodic run(s) at equal phase", out.replicates, out.groups);
  return out;
}

ReplicationNoise from_spread_column(const Experiment& e) {
  ReplicationNoise out;
  double ss = 0.0;
  std::size_t n = 0;
  int runs = 0;
  for (const Run& r : e.runs) {
    if (r.coefficient_spread.size() != r.size() || !(r.ensemble_count >= 2.0)) continue;
    for (double s : r.coefficient_spread) ss += s * s / r.ensemble_count;
    n += r.size();
    ++runs;
  }
  if (n == 0 || !(ss > 0.0)) return out;
  out.source = NoiseSource::spread_column;
  out.sigma = std::sqrt(ss / static_cast<double>(n));
  out.samples = n;
  out.groups = runs;
  out.replicates = runs;
  // Why 0: a spread column gives the level, not the correlation between samples.
  out.lag1_correlation = 0.0;
  out.detail = fmt::format("spread column of {} ensemble-averaged run(s), divided by sqrt(count)", runs);
  return out;
}

}  // namespace

ReplicationNoise replication_noise(const Experiment& e) {
  ReplicationNoise n = from_replicate_runs(e);
  if (n.source != NoiseSource::none) return n;
  std::string why_cycles;
  n = from_replicate_cycles(e, why_cycles);
  if (n.source != NoiseSource::none) return n;
  n = from_spread_column(e);
  if (n.source != NoiseSource::none) return n;
  n.detail = "no replication (no two runs at one condition, no run of several aligned cycles with a "
             "frequency, no spread column): the noise level is unknown";
  if (!why_cycles.empty()) n.detail += "; " + why_cycles;
  return n;
}

}  // namespace indicial
