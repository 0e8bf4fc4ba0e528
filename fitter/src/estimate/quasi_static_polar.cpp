// A static table from quasi-static cycles. See indicial/fitter/quasi_static_polar.hpp.
#include "indicial/fitter/quasi_static_polar.hpp"

#include <cmath>
#include <fmt/format.h>
#include <map>
#include <string>
#include <vector>

#include "indicial/fitter/error.hpp"

namespace indicial {

namespace {

constexpr double kPolarDegToRad = 3.14159265358979323846 / 180.0;

// The samples of one run on the stroke asked for: the model angle's change through each sample
// (central difference; a periodic run wraps, a record's ends take the one-sided one), rising
// (> 0), or outward (rising above zero, falling below). A sample at a turning point (no
// change) is on neither.
std::vector<char> stroke_samples(const std::vector<double>& x, bool periodic, PolarStroke stroke) {
  const std::size_t n = x.size();
  std::vector<char> on(n, 1);
  if (stroke == PolarStroke::both) return on;
  for (std::size_t k = 0; k < n; ++k) {
    const bool first = k == 0, last = k + 1 == n;
    const double ahead = last ? (periodic ? x[0] : x[k]) : x[k + 1];
    const double behind = first ? (periodic ? x[n - 1] : x[k]) : x[k - 1];
    const double change = ahead - behind;
    const bool outward_below_zero = stroke == PolarStroke::outward && x[k] < 0.0;
    on[k] = (outward_below_zero ? change < 0.0 : change > 0.0) ? 1 : 0;
  }
  return on;
}

struct Bin {
  int count = 0;
  double sum_x = 0.0;
  std::vector<double> sum_values;
};

}  // namespace

std::string QuasiStaticPolarOptions::invalid_reason() const {
  if (!(bin_deg > 0.0) || !std::isfinite(bin_deg)) return "the bin width must be > 0 deg";
  if (min_samples < 1) return "the minimum samples per bin must be >= 1";
  if (!(hold_deg >= 0.0) || !std::isfinite(hold_deg)) return "the held rows' distance must be >= 0 deg";
  return {};
}

QuasiStaticPolar quasi_static_polar(const std::vector<Experiment>& experiments, const QuasiStaticPolarOptions& o) {
  if (experiments.empty()) throw InputError("polar: no experiment");
  const Experiment& first = experiments.front();
  if (const std::string why = o.invalid_reason(); !why.empty()) throw InputError(first.path, 0, why);
  const std::size_t n_coef = experiments.size();
  for (const Experiment& e : experiments) {
    bool same = e.runs.size() == first.runs.size();
    for (std::size_t r = 0; same && r < e.runs.size(); ++r) same = e.runs[r].size() == first.runs[r].size();
    if (!same) throw InputError(e.path, 0, "the runs of " + e.coefficient + " differ from those of " + first.coefficient);
  }
  // Bins keyed by round(x / w): centred on multiples of the width.
  const double width_rad = o.bin_deg * kPolarDegToRad;
  std::map<long, Bin> bins;
  int considered = 0, total = 0;  // samples binned, samples read
  for (std::size_t r = 0; r < first.runs.size(); ++r) {
    const Run& run = first.runs[r];
    std::vector<double> x(run.size());
    for (std::size_t k = 0; k < x.size(); ++k) x[k] = model_angle(first.axis, first.alpha0_rad, run.motion_angle_rad[k]);
    const std::vector<char> on_stroke = stroke_samples(x, run.periodic, o.stroke);
    for (std::size_t k = 0; k < x.size(); ++k) {
      ++total;
      if (!on_stroke[k]) continue;
      ++considered;
      Bin& b = bins[std::lround(x[k] / width_rad)];
      if (b.sum_values.empty()) b.sum_values.assign(n_coef, 0.0);
      ++b.count;
      b.sum_x += x[k];
      for (std::size_t c = 0; c < n_coef; ++c) b.sum_values[c] += experiments[c].runs[r].coefficient[k];
    }
  }
  QuasiStaticPolar p;
  p.runs = static_cast<int>(first.runs.size());
  p.values.assign(n_coef, {});
  for (const Experiment& e : experiments) p.coefficients.push_back(e.coefficient);
  for (const auto& [key, b] : bins) {
    if (b.count < o.min_samples) {
      ++p.bins_dropped;
      continue;
    }
    p.x_rad.push_back(b.sum_x / b.count);
    p.samples.push_back(b.count);
    p.samples_used += b.count;
    for (std::size_t c = 0; c < n_coef; ++c) p.values[c].push_back(b.sum_values[c] / b.count);
  }
  if (p.x_rad.size() < 2) {
    // Say why: too few samples per bin, or (static runs, a constant angle) none rising.
    const std::string stroke = o.stroke != PolarStroke::both
                                   ? fmt::format(" ({} of {} samples are on the {} stroke: with runs that do not "
                                                 "move, --stroke both)", considered, total, name_of(o.stroke))
                                   : std::string();
    throw InputError(first.path, 0, fmt::format("the polar has {} row(s): {} bin(s) of {:g} deg held fewer than {} "
                                                "samples{} (wider bins, or more or slower cycles)",
                                                p.x_rad.size(), p.bins_dropped, o.bin_deg, o.min_samples, stroke));
  }
  // The table must load where it is meant to go: the runtime holds at most this many rows.
  const std::size_t rows = p.x_rad.size() + (o.hold_deg > 0.0 ? 2 : 0);
  if (rows > static_cast<std::size_t>(DefaultCapacity::max_table_points))
    throw InputError(first.path, 0, fmt::format("the polar has {} rows; a static table holds at most {} (the runtime's "
                                                "indicial::DefaultCapacity): wider bins than {:g} deg",
                                                rows, DefaultCapacity::max_table_points, o.bin_deg));
  if (o.hold_deg > 0.0) {
    const double hold_rad = o.hold_deg * kPolarDegToRad;
    p.x_rad.insert(p.x_rad.begin(), p.x_rad.front() - hold_rad);
    p.x_rad.push_back(p.x_rad.back() + hold_rad);
    p.samples.insert(p.samples.begin(), 0);
    p.samples.push_back(0);
    for (std::vector<double>& v : p.values) {
      v.insert(v.begin(), v.front());
      v.push_back(v.back());
    }
    p.held_rows = 2;
  }
  return p;
}

std::string quasi_static_polar_csv(const QuasiStaticPolar& p, Axis axis, const std::vector<std::string>& comments) {
  std::string out;
  for (const std::string& c : comments) out += "# " + c + "\n";
  out += axis == Axis::pitch ? "alpha_deg" : "beta_deg";
  for (const std::string& name : p.coefficients) out += "," + name;
  out += "\n";
  for (std::size_t i = 0; i < p.x_rad.size(); ++i) {
    // Eight significant digits: a bin mean is not known to more, and the file is read by people.
    out += fmt::format("{:.8g}", p.x_rad[i] / kPolarDegToRad);
    for (const std::vector<double>& v : p.values) out += fmt::format(",{:.8g}", v[i]);
    out += "\n";
  }
  return out;
}

}  // namespace indicial
