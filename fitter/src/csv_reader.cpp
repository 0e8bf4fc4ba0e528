// Run CSV and static-table reading. See indicial/fitter/csv_reader.hpp.
#include "indicial/fitter/csv_reader.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <fstream>
#include <set>
#include <string>
#include <utility>

#include "indicial/fitter/derivative.hpp"
#include "indicial/fitter/error.hpp"
#include "indicial/fitter/io.hpp"

namespace indicial {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegToRad = kPi / 180.0;
// Relative tolerance of the uniform-step check (interface.md).
constexpr double kStepTolerance = 1e-6;

std::string trim(const std::string& s) {
  std::size_t b = 0, e = s.size();
  while (b < e && (s[b] == ' ' || s[b] == '\t' || s[b] == '\r')) ++b;
  while (e > b && (s[e - 1] == ' ' || s[e - 1] == '\t' || s[e - 1] == '\r')) --e;
  return s.substr(b, e - b);
}

std::vector<std::string> split_commas(const std::string& line) {
  std::vector<std::string> out;
  std::size_t start = 0;
  for (;;) {
    const std::size_t comma = line.find(',', start);
    if (comma == std::string::npos) {
      out.push_back(trim(line.substr(start)));
      break;
    }
    out.push_back(trim(line.substr(start, comma - start)));
    start = comma + 1;
  }
  return out;
}

// Parses a whole cell as a finite double; on failure returns the problem text.
bool parse_number(const std::string& cell, double& v, std::string& problem) {
  if (cell.empty()) {
    problem = "empty cell";
    return false;
  }
  const char* first = cell.data();
  const char* last = cell.data() + cell.size();
  if (*first == '+') ++first;  // from_chars does not take a leading '+'
  const auto res = std::from_chars(first, last, v);
  if (res.ec == std::errc::result_out_of_range) {
    problem = "number out of range '" + cell + "'";
    return false;
  }
  if (res.ec != std::errc() || res.ptr != last) {
    problem = "non-numeric value '" + cell + "'";
    return false;
  }
  if (!std::isfinite(v)) {
    problem = "NaN or Inf value '" + cell + "'";
    return false;
  }
  return true;
}

// ---- column names -----------------------------------------------------------------------
enum class Quantity { time, angle, rate };
struct UnitChoice {
  const char* suffix;
  double to_si;  // factor to rad, rad/s or s
};
struct BaseName {
  const char* base;
  Quantity quantity;
};
constexpr std::array<BaseName, 9> kUnitBases = {{{"time", Quantity::time},
                                                 {"alpha", Quantity::angle},
                                                 {"beta", Quantity::angle},
                                                 {"phi", Quantity::angle},
                                                 {"psi", Quantity::angle},
                                                 {"theta", Quantity::angle},
                                                 {"q", Quantity::rate},
                                                 {"p", Quantity::rate},
                                                 {"r", Quantity::rate}}};

std::vector<UnitChoice> units_of(Quantity q) {
  switch (q) {
    case Quantity::time: return {{"s", 1.0}};
    case Quantity::angle: return {{"deg", kDegToRad}, {"rad", 1.0}};
    case Quantity::rate: return {{"degps", kDegToRad}, {"radps", 1.0}};
  }
  return {};
}

std::string unit_hint(const std::string& base, Quantity q) {
  std::string hint;
  for (const auto& u : units_of(q)) {
    if (!hint.empty()) hint += " or ";
    hint += base + "_" + u.suffix;
  }
  return hint;
}

// A column with a unit: its base name and the factor to SI. Columns that are not unit-bearing
// quantities (coefficients, Cm_true, ...) give an empty base.
struct ParsedColumn {
  std::string base;
  double to_si = 1.0;
};

ParsedColumn parse_column_name(const std::string& path, long line, const std::string& name) {
  if (name.empty()) throw InputError(path, line, "empty column name in the header");
  const std::size_t us = name.find('_');
  const std::string base = name.substr(0, us);
  for (const auto& b : kUnitBases) {
    if (base != b.base) continue;
    if (us == std::string::npos) {
      throw InputError(path, line, "column '" + name + "' has no unit suffix (use " +
                                       unit_hint(base, b.quantity) + ")");
    }
    const std::string suffix = name.substr(us + 1);
    for (const auto& u : units_of(b.quantity)) {
      if (suffix == u.suffix) return {base, u.to_si};
    }
    throw InputError(path, line, "column '" + name + "' has unknown unit suffix '_" + suffix +
                                     "' (use " + unit_hint(base, b.quantity) + ")");
  }
  return {};
}

const char* motion_base(Axis axis) {
  return axis == Axis::pitch ? "alpha" : axis == Axis::roll ? "phi" : "psi";
}
const char* rate_base(Axis axis) {
  return axis == Axis::pitch ? "q" : axis == Axis::roll ? "p" : "r";
}


double median_of(std::vector<double> v) {
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

// ---- generic table-shaped CSV: header + numeric columns --------------------------------
struct CsvTable {
  std::vector<std::string> header;
  long header_line = 0;
  std::vector<std::vector<std::string>> rows;
  std::vector<long> row_line;
};

CsvTable read_csv_table(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, 0, "cannot open file (does it exist?)");
  CsvTable t;
  std::string raw;
  long line_no = 0;
  bool any_byte = false;
  while (std::getline(in, raw)) {
    ++line_no;
    any_byte = true;
    const std::string line = trim(raw);
    // Why skip: '#' lines are comments by the contract; blank lines carry no data.
    if (line.empty() || line[0] == '#') continue;
    std::vector<std::string> fields = split_commas(line);
    if (t.header.empty()) {
      t.header = std::move(fields);
      t.header_line = line_no;
      continue;
    }
    if (fields.size() != t.header.size()) {
      throw InputError(path, line_no, "expected " + std::to_string(t.header.size()) +
                                          " comma-separated fields as in the header, found " +
                                          std::to_string(fields.size()));
    }
    t.rows.push_back(std::move(fields));
    t.row_line.push_back(line_no);
  }
  if (in.bad()) throw InputError(path, 0, "read failed");
  if (!any_byte) throw InputError(path, 0, "file is empty");
  if (t.header.empty()) throw InputError(path, line_no, "no header row (only comments or blank lines)");
  std::set<std::string> seen;
  for (const auto& name : t.header) {
    if (!seen.insert(name).second) {
      throw InputError(path, t.header_line, "duplicate column '" + name + "'");
    }
  }
  if (t.rows.empty()) throw InputError(path, t.header_line, "header only: no data rows");
  return t;
}

// Index of the column of `base` with a unit (e.g. alpha_deg or alpha_rad); -1 when absent.
int find_unit_column(const std::string& path, const CsvTable& t, const std::string& base,
                     double& to_si) {
  int found = -1;
  for (std::size_t c = 0; c < t.header.size(); ++c) {
    const ParsedColumn pc = parse_column_name(path, t.header_line, t.header[c]);
    if (pc.base != base) continue;
    if (found >= 0) {
      throw InputError(path, t.header_line, "both '" + t.header[static_cast<std::size_t>(found)] +
                                                "' and '" + t.header[c] +
                                                "' given; keep one");
    }
    found = static_cast<int>(c);
    to_si = pc.to_si;
  }
  return found;
}

int find_plain_column(const CsvTable& t, const std::string& name) {
  for (std::size_t c = 0; c < t.header.size(); ++c) {
    if (t.header[c] == name) return static_cast<int>(c);
  }
  return -1;
}

std::vector<double> numeric_column(const std::string& path, const CsvTable& t, int col,
                                   double factor) {
  std::vector<double> out(t.rows.size());
  const auto c = static_cast<std::size_t>(col);
  for (std::size_t r = 0; r < t.rows.size(); ++r) {
    double v = 0.0;
    std::string problem;
    if (!parse_number(t.rows[r][c], v, problem)) {
      throw InputError(path, t.row_line[r], "column '" + t.header[c] + "': " + problem);
    }
    out[r] = v * factor;
  }
  return out;
}

}  // namespace

// ==========================================================================================
// Run CSV
// ==========================================================================================
Run read_run_csv(const std::string& path, Axis axis, const std::string& coefficient,
                 CoefficientPresence presence, TimeGrid grid) {
  const CsvTable t = read_csv_table(path);
  // Validate every unit-bearing column name first, so a bad name is reported even if it is
  // not one this axis needs.
  for (const auto& name : t.header) (void)parse_column_name(path, t.header_line, name);

  double time_factor = 1.0, angle_factor = 1.0, rate_factor = 1.0;
  const int time_col = find_unit_column(path, t, "time", time_factor);
  if (time_col < 0) throw InputError(path, t.header_line, "missing column 'time_s'");
  const std::string mb = motion_base(axis);
  const int angle_col = find_unit_column(path, t, mb, angle_factor);
  if (angle_col < 0) {
    throw InputError(path, t.header_line, std::string("missing column '") + mb + "_deg' or '" +
                                              mb + "_rad' (the " + axis_name(axis) +
                                              " motion angle)");
  }
  const int rate_col = find_unit_column(path, t, rate_base(axis), rate_factor);
  const int coef_col = find_plain_column(t, coefficient);
  if (coef_col < 0 && presence == CoefficientPresence::required) {
    throw InputError(path, t.header_line, "missing column '" + coefficient + "'");
  }

  Run run;
  run.path = path;
  run.time_s = numeric_column(path, t, time_col, time_factor);
  run.motion_angle_rad = numeric_column(path, t, angle_col, angle_factor);
  if (coef_col >= 0) run.coefficient = numeric_column(path, t, coef_col, 1.0);

  const std::size_t n = run.time_s.size();
  if (n < static_cast<std::size_t>(min_run_samples)) {
    throw InputError(path, t.row_line.back(),
                     "only " + std::to_string(n) + " data rows; a run needs at least " +
                         std::to_string(min_run_samples));
  }
  std::vector<double> steps(n - 1);
  for (std::size_t i = 1; i < n; ++i) {
    if (!(run.time_s[i] > run.time_s[i - 1])) {
      throw InputError(path, t.row_line[i],
                       std::string(run.time_s[i] == run.time_s[i - 1] ? "duplicate time: "
                                                                       : "") +
                           "time_s is not strictly increasing (" + t.rows[i][static_cast<std::size_t>(time_col)] +
                           " after " + t.rows[i - 1][static_cast<std::size_t>(time_col)] + ")");
    }
    steps[i - 1] = run.time_s[i] - run.time_s[i - 1];
  }
  // Why the median: one bad step must be reported at its own line, not shift a mean step so
  // that every line looks wrong.
  const double dt = median_of(steps);
  for (std::size_t i = 1; i < n && grid == TimeGrid::uniform; ++i) {
    if (std::abs(steps[i - 1] - dt) > kStepTolerance * dt) {
      throw InputError(path, t.row_line[i],
                       "non-uniform time step: " + format_double(steps[i - 1]) + " s after " +
                           t.rows[i - 1][static_cast<std::size_t>(time_col)] +
                           ", the run's step is " + format_double(dt) +
                           " s (allowed deviation 1e-6 relative)");
    }
  }
  if (rate_col >= 0) {
    run.rate_radps = numeric_column(path, t, rate_col, rate_factor);
    run.rate_from_file = true;
  } else if (grid == TimeGrid::nonuniform) {
    run.rate_radps = smooth_derivative_nonuniform(run.time_s, run.motion_angle_rad,
                                                  default_sg_half_window, default_sg_degree);
    run.rate_from_file = false;
  } else {
    run.rate_radps = smooth_derivative(run.motion_angle_rad, dt, default_sg_half_window,
                                       default_sg_degree);
    run.rate_from_file = false;
  }
  return run;
}

// ==========================================================================================
// Static table
// ==========================================================================================
void read_static_table(const std::string& path, Axis axis, const std::string& coefficient,
                       StaticConfig& config) {
  const CsvTable t = read_csv_table(path);
  for (const auto& name : t.header) (void)parse_column_name(path, t.header_line, name);
  const std::string base = axis == Axis::pitch ? "alpha" : "beta";
  double factor = 1.0;
  const int x_col = find_unit_column(path, t, base, factor);
  if (x_col < 0) {
    throw InputError(path, t.header_line, "missing column '" + base + "_deg' or '" + base +
                                              "_rad' (the model angle of a " + axis_name(axis) +
                                              " static table)");
  }
  const int c_col = find_plain_column(t, coefficient);
  if (c_col < 0) throw InputError(path, t.header_line, "missing column '" + coefficient + "'");
  config.table_x_rad = numeric_column(path, t, x_col, factor);
  config.table_value = numeric_column(path, t, c_col, 1.0);
  if (config.table_x_rad.size() < 2) {
    throw InputError(path, t.row_line.back(), "a static table needs at least 2 rows");
  }
  if (config.table_x_rad.size() > static_cast<std::size_t>(FitCapacity::max_table_points)) {
    throw InputError(path, 0, "a static table may have at most " +
                                  std::to_string(FitCapacity::max_table_points) + " rows");
  }
  for (std::size_t i = 1; i < config.table_x_rad.size(); ++i) {
    if (!(config.table_x_rad[i] > config.table_x_rad[i - 1])) {
      throw InputError(path, t.row_line[i], "the angle column is not strictly increasing (" +
                                                t.rows[i][static_cast<std::size_t>(x_col)] +
                                                " after " +
                                                t.rows[i - 1][static_cast<std::size_t>(x_col)] + ")");
    }
  }
  config.kind = StaticKind::table;
  config.table_path = path;
}

}  // namespace indicial
