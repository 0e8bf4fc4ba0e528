// One periodic cycle from columns sampled at their own phases. See
// indicial/fitter/phase_resample.hpp.
#include "indicial/fitter/phase_resample.hpp"

#include <algorithm>
#include <boost/math/interpolators/makima.hpp>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "indicial/fitter/derivative.hpp"
#include "indicial/fitter/did_you_mean.hpp"
#include "indicial/fitter/error.hpp"
#include "indicial/fitter/io.hpp"

namespace indicial {
namespace {

constexpr double kTwoPi = 2.0 * 3.14159265358979323846;
// Points wrapped from each end of the cycle to the other: makima's slope at a point uses two
// neighbours on each side, and the end slopes one more, so three make every in-cycle slope
// periodic.
constexpr std::size_t kWrap = 3;

// Which file holds a quantity: the index, or -1.
int holder(const std::vector<PhaseSeries>& files, std::vector<double> PhaseSeries::*member, bool unique,
           const std::string& what, const std::string& label) {
  int found = -1;
  for (std::size_t f = 0; f < files.size(); ++f) {
    if ((files[f].*member).empty()) continue;
    if (found < 0) {
      found = static_cast<int>(f);
    } else if (unique) {
      throw InputError(label, 0, what + " is in both '" + files[static_cast<std::size_t>(found)].path + "' and '" +
                                     files[f].path + "': keep it in one file");
    }
  }
  return found;
}

// A quantity no file of the run has: each file's columns, and the nearest name within two
// edits (letter case ignored), as a one-file run's missing column says.
[[noreturn]] void missing_in_files(const std::vector<PhaseSeries>& files, const std::string& what,
                                   const std::vector<std::string>& wanted, const std::string& label) {
  std::string found, nearest, nearest_file, nearest_wanted;
  std::size_t best = 3;
  for (const PhaseSeries& f : files) {
    std::string names;
    for (const std::string& name : f.columns) {
      names += (names.empty() ? "" : ", ") + name;
      for (const std::string& w : wanted) {
        const std::size_t d = edit_distance(name, w, LetterCase::ignored);
        if (d < best && d < w.size()) best = d, nearest = name, nearest_file = f.path, nearest_wanted = w;
      }
    }
    found += (found.empty() ? "" : "; ") + f.path + ": " + names;
  }
  std::string msg = "no file of the run has " + what + " (columns found: " + found + ")";
  if (!nearest.empty())
    msg += "; did you mean '" + nearest + "' in " + nearest_file + "? (map it in [columns]: " + nearest_wanted +
           " = \"" + nearest + "\")";
  throw InputError(label, 0, msg);
}

}  // namespace

std::vector<double> periodic_interpolate(const std::vector<double>& phase_rad, const std::vector<double>& value,
                                         const std::vector<double>& at_rad) {
  const std::size_t n = phase_rad.size();
  std::vector<double> x, y;
  for (std::size_t i = n - kWrap; i < n; ++i) x.push_back(phase_rad[i] - kTwoPi), y.push_back(value[i]);
  for (std::size_t i = 0; i < n; ++i) x.push_back(phase_rad[i]), y.push_back(value[i]);
  for (std::size_t i = 0; i < kWrap; ++i) x.push_back(phase_rad[i] + kTwoPi), y.push_back(value[i]);
  const boost::math::interpolators::makima<std::vector<double>> spline(std::move(x), std::move(y));
  std::vector<double> out(at_rad.size());
  for (std::size_t k = 0; k < at_rad.size(); ++k) {
    double p = std::fmod(at_rad[k], kTwoPi);
    if (p < 0.0) p += kTwoPi;
    out[k] = spline(p);
  }
  return out;
}

Run resample_phase_series(const std::vector<PhaseSeries>& files, const std::string& coefficient,
                          CoefficientPresence presence, double frequency_hz, int samples, const std::string& label) {
  if (files.empty()) throw InputError(label, 0, "no files");
  if (!(frequency_hz > 0.0))
    throw InputError(label, 0, "a run of files at their own phases needs the cycle's frequency (frequency_hz or "
                               "reduced_frequency)");
  const int angle = holder(files, &PhaseSeries::motion_angle_rad, false, "the motion angle", label);
  if (angle < 0) {
    const std::string& base = files.front().angle_base;
    missing_in_files(files, "the motion angle column", {base + "_deg", base + "_rad"}, label);
  }
  const int coef = holder(files, &PhaseSeries::coefficient, true, "'" + coefficient + "'", label);
  if (coef < 0 && presence == CoefficientPresence::required)
    missing_in_files(files, "the '" + coefficient + "' column", {coefficient}, label);
  const int rate = holder(files, &PhaseSeries::rate_radps, false, "the rate", label);
  // The default grid: the most rows of any file of the run, a file with only another
  // coefficient's column included. Why: the run's coefficients (an experiment's `coefficients
  // = ["CL", "Cm"]`, predict's model) are then on one grid with one envelope; counting only the
  // files each coefficient uses put CL on 309 phases and Cm on 341 of the same cycles.
  std::size_t n = 0;
  for (const PhaseSeries& f : files) n = std::max(n, f.phase_rad.size());
  if (samples > 0) n = static_cast<std::size_t>(samples);
  n = std::max<std::size_t>(n, static_cast<std::size_t>(min_run_samples));
  Run run;
  run.path = label;
  run.periodic = true;
  run.frequency_hz = frequency_hz;
  run.time_source = TimeSource::phase_column;
  run.time_grid = TimeGrid::uniform;
  std::vector<double> grid(n);
  run.time_s.resize(n);
  for (std::size_t k = 0; k < n; ++k) {
    grid[k] = kTwoPi * static_cast<double>(k) / static_cast<double>(n);
    run.time_s[k] = static_cast<double>(k) / (static_cast<double>(n) * frequency_hz);
  }
  const PhaseSeries& a = files[static_cast<std::size_t>(angle)];
  run.motion_angle_rad = periodic_interpolate(a.phase_rad, a.motion_angle_rad, grid);
  run.angle_column = a.motion_column;
  std::string counts = a.motion_column + " at " + std::to_string(a.phase_rad.size());
  if (coef >= 0) {
    const PhaseSeries& c = files[static_cast<std::size_t>(coef)];
    run.coefficient = periodic_interpolate(c.phase_rad, c.coefficient, grid);
    counts += ", " + coefficient + " at " + std::to_string(c.phase_rad.size());
  }
  if (rate >= 0) {
    const PhaseSeries& r = files[static_cast<std::size_t>(rate)];
    run.rate_radps = periodic_interpolate(r.phase_rad, r.rate_radps, grid);
    run.rate_from_file = true;
  } else {
    run.rate_radps = smooth_derivative(run.motion_angle_rad, run.time_s[1] - run.time_s[0], default_sg_half_window,
                                       default_sg_degree);
  }
  for (const PhaseSeries& f : files) {
    run.notes.insert(run.notes.end(), f.notes.begin(), f.notes.end());
    run.warnings.insert(run.warnings.end(), f.warnings.begin(), f.warnings.end());
  }
  run.notes.push_back(label + ": " + counts + " phases, interpolated (periodic modified Akima) onto " +
                      std::to_string(n) + " uniform phases");
  return run;
}

}  // namespace indicial
