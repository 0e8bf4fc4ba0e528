// Run CSV and experiment TOML ingest and writers. See indicial/fitter/io.hpp.
#include "indicial/fitter/io.hpp"

#include <Eigen/Core>
#include <Eigen/QR>
#include <algorithm>
#include <array>
#include <charconv>
#include <cstdio>
#include <cmath>
#include <filesystem>
#include <initializer_list>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>
#include <utility>
#include <toml++/toml.h>

#include "indicial/coef_file.hpp"
#include "indicial/fitter/error.hpp"
#include "indicial/fitter/output.hpp"

namespace fs = std::filesystem;

namespace indicial {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegToRad = kPi / 180.0;
constexpr double kRadToDeg = 180.0 / kPi;
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

const std::set<std::string>& coefficient_names() {
  static const std::set<std::string> names = {"CL", "Cm", "CD", "CY", "Cl", "Cn"};
  return names;
}

// Degrees for messages: 6 significant digits (59.99999999999999 reads as 60).
std::string deg_text(double rad) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", rad * kRadToDeg);
  return buf;
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
// Savitzky-Golay differentiation. Written by hand: neither Eigen nor Boost 1.74 has a
// Savitzky-Golay filter; Eigen does the least squares that gives the weights.
// ==========================================================================================
std::vector<double> smooth_derivative(const std::vector<double>& values, double dt_s,
                                      int half_window, int poly_degree) {
  if (half_window < 1) throw std::invalid_argument("smooth_derivative: half_window must be >= 1");
  const int width = 2 * half_window + 1;
  if (poly_degree < 1 || poly_degree >= width) {
    throw std::invalid_argument("smooth_derivative: need 1 <= poly_degree <= 2 * half_window");
  }
  if (!(dt_s > 0.0)) throw std::invalid_argument("smooth_derivative: dt_s must be > 0");
  const std::size_t n = values.size();
  if (n < static_cast<std::size_t>(width)) {
    throw std::invalid_argument("smooth_derivative: fewer values than one window");
  }
  // weights(e, k): the derivative at window position e (0..width-1) as a combination of the
  // window's values k. The local abscissa u = (k - e) / half_window keeps the Vandermonde
  // matrix well conditioned; d/dt = (1 / (half_window dt)) d/du.
  Eigen::MatrixXd weights(width, width);
  for (int e = 0; e < width; ++e) {
    Eigen::MatrixXd V(width, poly_degree + 1);
    for (int k = 0; k < width; ++k) {
      const double u = static_cast<double>(k - e) / half_window;
      double pw = 1.0;
      for (int p = 0; p <= poly_degree; ++p) {
        V(k, p) = pw;
        pw *= u;
      }
    }
    // Least-squares coefficients c = pinv(V) v; the derivative at u = 0 is c_1.
    const Eigen::MatrixXd pinv =
        V.colPivHouseholderQr().solve(Eigen::MatrixXd::Identity(width, width));
    weights.row(e) = pinv.row(1) / (half_window * dt_s);
  }
  std::vector<double> d(n);
  const std::size_t hw = static_cast<std::size_t>(half_window);
  for (std::size_t i = 0; i < n; ++i) {
    // Why the clamp: near the ends the centred window does not fit, so the first / last full
    // window is used with the evaluation point moved off-centre (the same local polynomial).
    std::size_t lo = i >= hw ? i - hw : 0;
    if (lo + static_cast<std::size_t>(width) > n) lo = n - static_cast<std::size_t>(width);
    const auto e = static_cast<Eigen::Index>(i - lo);
    double s = 0.0;
    for (int k = 0; k < width; ++k) s += weights(e, k) * values[lo + static_cast<std::size_t>(k)];
    d[i] = s;
  }
  return d;
}

std::vector<double> smooth_derivative_nonuniform(const std::vector<double>& time_s,
                                                 const std::vector<double>& values,
                                                 int half_window, int poly_degree) {
  if (half_window < 1) throw std::invalid_argument("smooth_derivative_nonuniform: half_window must be >= 1");
  const int width = 2 * half_window + 1;
  if (poly_degree < 1 || poly_degree >= width)
    throw std::invalid_argument("smooth_derivative_nonuniform: need 1 <= poly_degree <= 2 * half_window");
  const std::size_t n = values.size();
  if (time_s.size() != n) throw std::invalid_argument("smooth_derivative_nonuniform: lengths differ");
  if (n < static_cast<std::size_t>(width))
    throw std::invalid_argument("smooth_derivative_nonuniform: fewer values than one window");
  for (std::size_t i = 1; i < n; ++i)
    if (!(time_s[i] > time_s[i - 1]))
      throw std::invalid_argument("smooth_derivative_nonuniform: time is not strictly increasing");
  const std::size_t hw = static_cast<std::size_t>(half_window);
  std::vector<double> d(n);
  Eigen::MatrixXd V(width, poly_degree + 1);
  Eigen::VectorXd v(width);
  for (std::size_t i = 0; i < n; ++i) {
    std::size_t lo = i >= hw ? i - hw : 0;
    if (lo + static_cast<std::size_t>(width) > n) lo = n - static_cast<std::size_t>(width);
    // Why the scaling: the local abscissa u = (t - t_i) / h with h the window's half span keeps
    // the Vandermonde matrix as well conditioned as the uniform case's; d/dt = (1 / h) d/du.
    const double h = 0.5 * (time_s[lo + static_cast<std::size_t>(width) - 1] - time_s[lo]);
    for (int k = 0; k < width; ++k) {
      const std::size_t s = lo + static_cast<std::size_t>(k);
      const double u = (time_s[s] - time_s[i]) / h;
      double pw = 1.0;
      for (int p = 0; p <= poly_degree; ++p) {
        V(k, p) = pw;
        pw *= u;
      }
      v(k) = values[s];
    }
    const Eigen::VectorXd c = V.colPivHouseholderQr().solve(v);
    d[i] = c(1) / h;
  }
  return d;
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

// ==========================================================================================
// Experiment TOML
// ==========================================================================================
namespace {

class TomlReader {
 public:
  explicit TomlReader(std::string file) : file_(std::move(file)) {}

  [[noreturn]] void fail(const toml::source_region& where, const std::string& problem) const {
    throw InputError(file_, static_cast<long>(where.begin.line), problem);
  }
  [[noreturn]] void fail(const toml::node& node, const std::string& problem) const {
    fail(node.source(), problem);
  }

  // Every key of `table` must be in `allowed`; `where` prefixes the key in messages.
  void check_keys(const toml::table& table, const std::set<std::string>& allowed,
                  const std::string& where) const {
    for (auto&& [key, node] : table) {
      (void)node;
      if (allowed.count(std::string(key.str())) == 0) {
        std::string list;
        for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
        fail(key.source(), "unknown key '" + where + std::string(key.str()) +
                               "' (allowed here: " + list + ")");
      }
    }
  }

  static std::string type_name(const toml::node& n) {
    switch (n.type()) {
      case toml::node_type::string: return "a string";
      case toml::node_type::integer: return "an integer";
      case toml::node_type::floating_point: return "a number";
      case toml::node_type::boolean: return "a boolean";
      case toml::node_type::array: return "an array";
      case toml::node_type::table: return "a table";
      default: return "a date/time";
    }
  }

  double number(const toml::node& n, const std::string& key) const {
    if (n.is_integer()) return static_cast<double>(*n.value<int64_t>());
    if (n.is_floating_point()) {
      const double v = *n.value<double>();
      if (!std::isfinite(v)) fail(n, "'" + key + "' must be finite");
      return v;
    }
    fail(n, "wrong type: '" + key + "' must be a number, found " + type_name(n));
  }
  long integer(const toml::node& n, const std::string& key) const {
    if (!n.is_integer()) fail(n, "wrong type: '" + key + "' must be an integer, found " + type_name(n));
    return static_cast<long>(*n.value<int64_t>());
  }
  bool boolean(const toml::node& n, const std::string& key) const {
    if (!n.is_boolean()) fail(n, "wrong type: '" + key + "' must be true or false, found " + type_name(n));
    return *n.value<bool>();
  }
  // A string naming one of `choices`; returns its enum value, refuses anything else with the
  // list: 'model.delay' must be "none" or "estimated", found "yes".
  template <class E>
  E choice(const toml::node& n, const std::string& key,
           std::initializer_list<std::pair<const char*, E>> choices) const {
    const std::string s = string(n, key);
    std::string list;
    for (const auto& [name, value] : choices) {
      if (s == name) return value;
      list += (list.empty() ? "\"" : " or \"") + std::string(name) + "\"";
    }
    fail(n, "'" + key + "' must be " + list + ", found \"" + s + "\"");
  }
  std::string string(const toml::node& n, const std::string& key) const {
    if (!n.is_string()) fail(n, "wrong type: '" + key + "' must be a string, found " + type_name(n));
    return *n.value<std::string>();
  }
  const toml::array& array(const toml::node& n, const std::string& key) const {
    if (!n.is_array()) fail(n, "wrong type: '" + key + "' must be an array, found " + type_name(n));
    return *n.as_array();
  }
  const toml::table& table(const toml::node& n, const std::string& key) const {
    if (!n.is_table()) fail(n, "wrong type: '" + key + "' must be a table, found " + type_name(n));
    return *n.as_table();
  }
  std::vector<double> numbers(const toml::node& n, const std::string& key) const {
    std::vector<double> out;
    for (const auto& e : array(n, key)) out.push_back(number(e, key + " entry"));
    return out;
  }
  std::vector<int> powers(const toml::node& n, const std::string& key) const {
    std::vector<int> out;
    for (const auto& e : array(n, key)) {
      const long p = integer(e, key + " entry");
      if (p < 0 || p >= FitCapacity::max_powers) {
        fail(e, "'" + key + "': power " + std::to_string(p) + " is outside 0.." +
                    std::to_string(FitCapacity::max_powers - 1));
      }
      if (!out.empty() && p <= out.back()) fail(e, "'" + key + "' must be strictly increasing");
      out.push_back(static_cast<int>(p));
    }
    return out;
  }
  std::vector<int> degree_powers(const toml::node& n, const std::string& key) const {
    const long d = integer(n, key);
    if (d < 0 || d >= FitCapacity::max_powers) {
      fail(n, "'" + key + "' must be 0.." + std::to_string(FitCapacity::max_powers - 1));
    }
    std::vector<int> out;
    for (int p = 0; p <= static_cast<int>(d); ++p) out.push_back(p);
    return out;
  }
  std::vector<double> knots_deg(const toml::node& n, const std::string& key) const {
    std::vector<double> out;
    for (const auto& e : array(n, key)) {
      const double k = number(e, key + " entry") * kDegToRad;
      if (!out.empty() && !(k > out.back())) fail(e, "'" + key + "' must be strictly increasing");
      out.push_back(k);
    }
    if (out.size() > static_cast<std::size_t>(FitCapacity::max_knots)) {
      fail(n, "'" + key + "' has more than " + std::to_string(FitCapacity::max_knots) + " knots");
    }
    return out;
  }

  const std::string& file() const { return file_; }

 private:
  std::string file_;
};

// A knot list's source, for range checks after the runs are read.
struct KnotSource {
  std::string key;
  const std::vector<double>* knots_rad;
  toml::source_region where;
};

// Refuses bytes that the system toml++ (3.3.0, Debian 12) mishandles before it sees them:
// a NUL byte anywhere, and a non-ASCII byte outside a string or comment, reach an assertion
// and __builtin_unreachable in its whitespace classifier (upstream marzer/tomlplusplus #190,
// #295, fixed by PR #305; found by tests/fuzz/fuzz_experiment.cpp). Non-ASCII text inside
// quoted strings (a run file name) and comments stays allowed. Why a hand scan: no TOML
// library on the machine is free of the bug, and the scan only needs to know where strings
// and comments are, not the grammar.
void refuse_bytes_toml_cannot_take(const std::string& text, const std::string& path) {
  long line = 1;
  enum class Where { code, comment, basic_string, literal_string } where = Where::code;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    if (c == 0) throw InputError(path, line, "NUL byte in the file (is it a TOML text file?)");
    if (c == '\n') {
      ++line;
      if (where == Where::comment) where = Where::code;
      continue;
    }
    switch (where) {
      case Where::code:
        if (c == '#') where = Where::comment;
        else if (c == '"') where = Where::basic_string;
        else if (c == '\'') where = Where::literal_string;
        else if (c >= 0x80) {
          char hex[8];
          std::snprintf(hex, sizeof hex, "0x%02X", static_cast<unsigned>(c));
          throw InputError(path, line, std::string("non-ASCII byte ") + hex +
                                           " outside a string or comment (keys and values must be ASCII)");
        }
        break;
      case Where::comment: break;
      case Where::basic_string:
        if (c == '\\') ++i;  // an escaped character, e.g. \" does not end the string
        else if (c == '"') where = Where::code;
        break;
      case Where::literal_string:
        if (c == '\'') where = Where::code;
        break;
    }
  }
}

}  // namespace

Experiment load_experiment(const std::string& toml_path) {
  const std::string text = read_text(toml_path);
  refuse_bytes_toml_cannot_take(text, toml_path);
  toml::table root;
  try {
    root = toml::parse(text, toml_path);
  } catch (const toml::parse_error& e) {
    throw InputError(toml_path, static_cast<long>(e.source().begin.line),
                     "TOML syntax error: " + std::string(e.description()));
  }
  const TomlReader r(toml_path);
  r.check_keys(root, {"axis", "coefficient", "reference_length_m", "airspeed_mps", "alpha0_deg",
                      "alpha0_rad", "runs", "static", "rotary", "model"},
               "");
  auto require = [&](const toml::table& t, const std::string& key,
                     const std::string& where) -> const toml::node& {
    const toml::node* n = t.get(key);
    if (!n) {
      throw InputError(toml_path, static_cast<long>(t.source().begin.line),
                       "missing required key '" + where + key + "'");
    }
    return *n;
  };

  Experiment e;
  e.path = toml_path;

  const toml::node& axis_node = require(root, "axis", "");
  const std::string axis = r.string(axis_node, "axis");
  if (axis == "pitch") e.axis = Axis::pitch;
  else if (axis == "roll") e.axis = Axis::roll;
  else if (axis == "yaw") e.axis = Axis::yaw;
  else r.fail(axis_node, "'axis' must be \"pitch\", \"roll\" or \"yaw\", found \"" + axis + "\"");

  const toml::node& coef_node = require(root, "coefficient", "");
  e.coefficient = r.string(coef_node, "coefficient");
  if (coefficient_names().count(e.coefficient) == 0) {
    r.fail(coef_node, "'coefficient' must be one of CL, Cm, CD, CY, Cl, Cn, found \"" +
                          e.coefficient + "\"");
  }

  const toml::node& l_node = require(root, "reference_length_m", "");
  e.reference_length_m = r.number(l_node, "reference_length_m");
  if (!(e.reference_length_m > 0)) r.fail(l_node, "'reference_length_m' must be > 0");
  const toml::node& v_node = require(root, "airspeed_mps", "");
  e.airspeed_mps = r.number(v_node, "airspeed_mps");
  if (!(e.airspeed_mps > 0)) r.fail(v_node, "'airspeed_mps' must be > 0");

  const toml::node* a0deg = root.get("alpha0_deg");
  const toml::node* a0rad = root.get("alpha0_rad");
  if (a0deg && a0rad) r.fail(*a0rad, "give 'alpha0_deg' or 'alpha0_rad', not both");
  if (a0deg) e.alpha0_rad = r.number(*a0deg, "alpha0_deg") * kDegToRad;
  if (a0rad) e.alpha0_rad = r.number(*a0rad, "alpha0_rad");
  if (e.axis != Axis::pitch && !a0deg && !a0rad) {
    throw InputError(toml_path, 0, std::string("missing required key 'alpha0_deg' (the fixed "
                                               "angle of attack of a ") +
                                       axis_name(e.axis) + " experiment)");
  }

  // ---- runs ----
  const fs::path base_dir = fs::path(toml_path).parent_path();
  auto resolve = [&](const std::string& file) {
    const fs::path p(file);
    return (p.is_absolute() || base_dir.empty() ? p : base_dir / p).lexically_normal().string();
  };
  const toml::node& runs_node = require(root, "runs", "");
  const toml::array& runs = r.array(runs_node, "runs");
  if (runs.empty()) r.fail(runs_node, "'runs' is empty: name at least one run CSV");
  struct RunEntry {
    std::string file;
    bool periodic;
  };
  std::vector<RunEntry> entries;
  for (const auto& entry : runs) {
    if (entry.is_string()) {
      entries.push_back({*entry.value<std::string>(), false});
    } else if (entry.is_table()) {
      const toml::table& t = *entry.as_table();
      r.check_keys(t, {"file", "periodic"}, "runs.");
      const toml::node* f = t.get("file");
      if (!f) r.fail(entry, "a run table needs 'file'");
      const toml::node* per = t.get("periodic");
      entries.push_back({r.string(*f, "runs.file"), per ? r.boolean(*per, "runs.periodic") : false});
    } else {
      r.fail(entry, "wrong type: 'runs' entries must be strings or {file = ..., periodic = ...} "
                    "tables, found " + TomlReader::type_name(entry));
    }
  }

  // ---- [static] ----
  const toml::node& static_node = require(root, "static", "");
  const toml::table& st = r.table(static_node, "static");
  r.check_keys(st, {"polynomial", "table"}, "static.");
  const toml::node* poly = st.get("polynomial");
  const toml::node* table = st.get("table");
  if (poly && table) r.fail(*table, "give 'static.polynomial' or 'static.table', not both");
  if (!poly && !table) r.fail(static_node, "missing required key 'static.polynomial' or 'static.table'");
  toml::source_region static_where = static_node.source();
  if (poly) {
    e.static_curve.kind = StaticKind::polynomial;
    e.static_curve.polynomial = r.numbers(*poly, "static.polynomial");
    if (e.static_curve.polynomial.size() > static_cast<std::size_t>(FitCapacity::max_powers)) {
      r.fail(*poly, "'static.polynomial' has more than " +
                        std::to_string(FitCapacity::max_powers) + " coefficients");
    }
  } else {
    static_where = table->source();
    const std::string tp = resolve(r.string(*table, "static.table"));
    read_static_table(tp, e.axis, e.coefficient, e.static_curve);
  }

  // ---- [rotary] ----
  std::vector<KnotSource> knot_sources;
  if (const toml::node* rot_node = root.get("rotary")) {
    const toml::table& rt = r.table(*rot_node, "rotary");
    r.check_keys(rt, {"polynomial", "estimate", "degree", "knots_deg", "prior_knots_deg",
                      "prior_knot_powers", "prior_knot_coefficients"},
                 "rotary.");
    {
      const toml::node* k = rt.get("prior_knots_deg");
      const toml::node* c = rt.get("prior_knot_coefficients");
      if ((k == nullptr) != (c == nullptr))
        r.fail(k ? *k : *c, "give both 'rotary.prior_knots_deg' and 'rotary.prior_knot_coefficients'");
      const toml::node* pw = rt.get("prior_knot_powers");
      if (pw && !k) r.fail(*pw, "'rotary.prior_knot_powers' needs 'rotary.prior_knots_deg'");
      if (k && c) {
        // Not knots_deg(): a priori terms may repeat a knot with another power, and need not
        // lie inside the data's range (they are known, not identified).
        e.rotary.prior_knots_rad = r.numbers(*k, "rotary.prior_knots_deg");
        for (double& v : e.rotary.prior_knots_rad) v *= kDegToRad;
        e.rotary.prior_knot_coefficients = r.numbers(*c, "rotary.prior_knot_coefficients");
        const std::size_t n = e.rotary.prior_knots_rad.size();
        if (n > static_cast<std::size_t>(FitCapacity::max_knots))
          r.fail(*k, "'rotary.prior_knots_deg' has more than " + std::to_string(FitCapacity::max_knots) + " terms");
        e.rotary.prior_knot_powers.assign(n, 1);
        if (pw) {
          e.rotary.prior_knot_powers.clear();
          for (const auto& entry : r.array(*pw, "rotary.prior_knot_powers")) {
            const long p = r.integer(entry, "rotary.prior_knot_powers entry");
            if (p < 0 || p > max_knot_power)
              r.fail(entry, "'rotary.prior_knot_powers': power " + std::to_string(p) + " is outside 0.." +
                                std::to_string(max_knot_power));
            e.rotary.prior_knot_powers.push_back(static_cast<int>(p));
          }
          if (e.rotary.prior_knot_powers.size() != n)
            r.fail(*pw, "'rotary.prior_knot_powers' has " + std::to_string(e.rotary.prior_knot_powers.size()) +
                            " entries for " + std::to_string(n) + " terms in 'rotary.prior_knots_deg'");
        }
        if (e.rotary.prior_knot_coefficients.size() != n)
          r.fail(*c, "'rotary.prior_knot_coefficients' has " +
                         std::to_string(e.rotary.prior_knot_coefficients.size()) + " entries for " +
                         std::to_string(n) + " terms in 'rotary.prior_knots_deg'");
      }
    }
    if (const toml::node* n = rt.get("polynomial")) {
      e.rotary.polynomial = r.numbers(*n, "rotary.polynomial");
      if (e.rotary.polynomial.size() > static_cast<std::size_t>(FitCapacity::max_powers)) {
        r.fail(*n, "'rotary.polynomial' has more than " + std::to_string(FitCapacity::max_powers) +
                       " coefficients");
      }
    }
    if (const toml::node* n = rt.get("estimate")) e.rotary.estimate = r.boolean(*n, "rotary.estimate");
    e.rotary.candidates.knot_power = 1;
    if (const toml::node* n = rt.get("degree")) {
      e.rotary.candidates.powers = r.degree_powers(*n, "rotary.degree");
    } else {
      // Why this default: without a degree the pool is the a-priori polynomial's own powers
      // (at least a constant), so estimate = true re-estimates the same shape.
      const int d = std::max<int>(0, static_cast<int>(e.rotary.polynomial.size()) - 1);
      for (int p = 0; p <= d; ++p) e.rotary.candidates.powers.push_back(p);
    }
    if (const toml::node* n = rt.get("knots_deg")) {
      e.rotary.candidates.knots_rad = r.knots_deg(*n, "rotary.knots_deg");
      knot_sources.push_back({"rotary.knots_deg", &e.rotary.candidates.knots_rad, n->source()});
    }
    if (!e.rotary.estimate && (rt.get("degree") || rt.get("knots_deg"))) {
      r.fail(*rot_node, "'rotary.degree' and 'rotary.knots_deg' are used only with "
                        "rotary.estimate = true");
    }
  } else {
    e.rotary.candidates.powers = {0};
    e.rotary.candidates.knot_power = 1;
  }

  // ---- [model] ----
  if (const toml::node* model_node = root.get("model")) {
    const toml::table& mt = r.table(*model_node, "model");
    r.check_keys(mt, {"a_degree", "a_powers", "a_knots_deg", "b1_degree", "b1_powers",
                      "b1_knots_deg", "bias", "structure", "lags",
                      // extensions (docs/formats.md): what `indicial diagnose` adds to a model
                      "static_correction_degree", "static_correction_powers",
                      "static_correction_knots_deg", "rotary_correction_degree",
                      "rotary_correction_powers", "rotary_correction_knots_deg", "delay",
                      "delay_start_s", "further_lag_start"},
                 "model.");
    auto spline_terms = [&](const std::string& name, SplineConfig& cfg) {
      const toml::node* deg = mt.get(name + "_degree");
      const toml::node* pw = mt.get(name + "_powers");
      if (deg && pw) r.fail(*pw, "give 'model." + name + "_degree' or 'model." + name + "_powers', not both");
      if (deg) cfg.powers = r.degree_powers(*deg, "model." + name + "_degree");
      if (pw) cfg.powers = r.powers(*pw, "model." + name + "_powers");
      if (const toml::node* k = mt.get(name + "_knots_deg")) {
        cfg.knots_rad = r.knots_deg(*k, "model." + name + "_knots_deg");
        knot_sources.push_back({"model." + name + "_knots_deg", &cfg.knots_rad, k->source()});
      }
    };
    spline_terms("a", e.model.a);
    spline_terms("b1", e.model.b1);
    spline_terms("static_correction", e.model.static_correction);
    spline_terms("rotary_correction", e.model.rotary_correction);
    const bool rotary_correction = !e.model.rotary_correction.powers.empty() ||
                                   !e.model.rotary_correction.knots_rad.empty();
    if (rotary_correction && e.rotary.estimate) {
      // Why refused: with rotary.estimate the two-stage loop re-estimates the whole C_aq(x);
      // a correction of the a priori C_aq on top of it would be the same terms twice.
      r.fail(*model_node, "'model.rotary_correction_*' corrects the a priori C_aq(x); it cannot "
                          "be combined with rotary.estimate = true");
    }
    if (const toml::node* n = mt.get("delay")) {
      e.model.delay = r.choice<DelayEstimation>(
          *n, "model.delay", {{"none", DelayEstimation::none}, {"estimated", DelayEstimation::estimated}});
    }
    if (const toml::node* n = mt.get("delay_start_s")) {
      const double d = r.number(*n, "model.delay_start_s");
      if (!(d >= 0.0 && d <= 1.0)) r.fail(*n, "'model.delay_start_s' must be in [0, 1] s");
      if (e.model.delay != DelayEstimation::estimated)
        r.fail(*n, "'model.delay_start_s' is used only with model.delay = \"estimated\"");
      e.model.delay_start_s = d;
    }
    if (const toml::node* n = mt.get("further_lag_start")) {
      e.model.further_lag_start = r.choice<LagStart>(
          *n, "model.further_lag_start", {{"estimated", LagStart::estimated}, {"at_rest", LagStart::at_rest}});
    }
    if (const toml::node* n = mt.get("bias")) e.model.bias = r.boolean(*n, "model.bias");
    if (const toml::node* n = mt.get("structure")) {
      e.model.structure = r.choice<StructureMode>(
          *n, "model.structure", {{"fixed", StructureMode::fixed}, {"stepwise", StructureMode::stepwise}});
    }
    if (const toml::node* n = mt.get("lags")) {
      const long lags = r.integer(*n, "model.lags");
      if (lags < 1 || lags > FitCapacity::max_lags) {
        r.fail(*n, "'model.lags' must be 1.." + std::to_string(FitCapacity::max_lags));
      }
      e.model.lags = static_cast<int>(lags);
    }
  }

  // ---- read the runs, then the checks that need the data ----
  for (const auto& entry : entries) {
    Run run = read_run_csv(resolve(entry.file), e.axis, e.coefficient, CoefficientPresence::required);
    run.periodic = entry.periodic;
    e.runs.push_back(std::move(run));
  }
  double x_min = 0, x_max = 0;
  bool first = true;
  for (const auto& run : e.runs) {
    for (double angle : run.motion_angle_rad) {
      const double x = model_angle(e.axis, e.alpha0_rad, angle);
      if (first || x < x_min) x_min = x;
      if (first || x > x_max) x_max = x;
      first = false;
    }
  }
  e.data_x_min_rad = x_min;
  e.data_x_max_rad = x_max;
  const std::string xname = e.axis == Axis::pitch ? "alpha" : "beta";
  for (const auto& ks : knot_sources) {
    for (double k : *ks.knots_rad) {
      // Why strictly inside: a knot at or beyond the range makes its term identically zero or
      // a polynomial on the data, which cannot be identified separately.
      if (!(k > x_min && k < x_max)) {
        r.fail(ks.where, "'" + ks.key + "': knot " + deg_text(k) +
                             " deg is outside the data's " + xname + " range [" +
                             deg_text(x_min) + ", " +
                             deg_text(x_max) + "] deg");
      }
    }
  }
  if (e.static_curve.kind == StaticKind::table) {
    const double tmin = e.static_curve.table_x_rad.front();
    const double tmax = e.static_curve.table_x_rad.back();
    const double tol = 1e-9;  // rad: rounding of degree columns
    if (tmin > x_min + tol || tmax < x_max - tol) {
      r.fail(static_where, "the static table '" + e.static_curve.table_path + "' covers " + xname +
                               " [" + deg_text(tmin) + ", " +
                               deg_text(tmax) + "] deg but the runs reach [" +
                               deg_text(x_min) + ", " +
                               deg_text(x_max) + "] deg");
    }
  }
  return e;
}

// ==========================================================================================
// Writers
// ==========================================================================================
std::string format_double(double v) {
  char buf[64];
  const auto res = std::to_chars(buf, buf + sizeof(buf), v);
  return std::string(buf, res.ptr);
}

std::string write_run_csv(const std::vector<CsvColumn>& columns,
                          const std::vector<std::string>& comment_lines) {
  std::string out;
  for (const auto& c : comment_lines) out += "# " + c + "\n";
  const std::size_t n = columns.empty() ? 0 : columns.front().values.size();
  for (std::size_t c = 0; c < columns.size(); ++c) {
    if (columns[c].values.size() != n) {
      throw std::invalid_argument("write_run_csv: column '" + columns[c].name +
                                  "' has a different length");
    }
    out += (c ? "," : "") + columns[c].name;
  }
  out += "\n";
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t c = 0; c < columns.size(); ++c) {
      if (c) out += ',';
      out += format_double(columns[c].values[i]);
    }
    out += '\n';
  }
  return out;
}

namespace {
std::string toml_string(const std::string& s) {
  std::string out = "\"";
  for (char ch : s) {
    if (ch == '"' || ch == '\\') out += '\\';
    out += ch;
  }
  return out + "\"";
}
std::string number_list(const std::vector<double>& v, double factor) {
  std::string out = "[";
  for (std::size_t i = 0; i < v.size(); ++i) out += (i ? ", " : "") + format_double(v[i] * factor);
  return out + "]";
}
std::string power_terms(const std::string& name, const std::vector<int>& powers) {
  bool contiguous = !powers.empty();
  for (std::size_t i = 0; i < powers.size(); ++i) contiguous = contiguous && powers[i] == static_cast<int>(i);
  if (contiguous) return name + "_degree = " + std::to_string(powers.size() - 1) + "\n";
  std::string out = name + "_powers = [";
  for (std::size_t i = 0; i < powers.size(); ++i) out += (i ? ", " : "") + std::to_string(powers[i]);
  return out + "]\n";
}
}  // namespace

std::string write_experiment_toml(const Experiment& e, const std::vector<std::string>& comment_lines) {
  std::string out;
  for (const auto& c : comment_lines) out += "# " + c + "\n";
  out += std::string("axis = \"") + axis_name(e.axis) + "\"\n";
  out += "coefficient = " + toml_string(e.coefficient) + "\n";
  out += "reference_length_m = " + format_double(e.reference_length_m) + "\n";
  out += "airspeed_mps = " + format_double(e.airspeed_mps) + "\n";
  if (e.axis != Axis::pitch) out += "alpha0_deg = " + format_double(e.alpha0_rad * kRadToDeg) + "\n";
  out += "runs = [";
  for (std::size_t i = 0; i < e.runs.size(); ++i) {
    out += i ? ", " : "";
    if (e.runs[i].periodic) out += "{file = " + toml_string(e.runs[i].path) + ", periodic = true}";
    else out += toml_string(e.runs[i].path);
  }
  out += "]\n\n[static]\n";
  if (e.static_curve.kind == StaticKind::polynomial) {
    out += "polynomial = " + number_list(e.static_curve.polynomial, 1.0) + "  # x^0, x^1, ... with x in rad\n";
  } else {
    out += "table = " + toml_string(e.static_curve.table_path) + "\n";
  }
  out += "\n[rotary]\npolynomial = " + number_list(e.rotary.polynomial, 1.0) + "  # x^0, x^1, ... with x in rad\n";
  if (!e.rotary.prior_knots_rad.empty()) {
    out += "prior_knots_deg = " + number_list(e.rotary.prior_knots_rad, kRadToDeg) + "\n";
    bool all_linear = true;
    for (int p : e.rotary.prior_knot_powers) all_linear = all_linear && p == 1;
    if (!all_linear) {
      out += "prior_knot_powers = [";
      for (std::size_t i = 0; i < e.rotary.prior_knot_powers.size(); ++i)
        out += (i ? ", " : "") + std::to_string(e.rotary.prior_knot_powers[i]);
      out += "]\n";
    }
    out += "prior_knot_coefficients = " + number_list(e.rotary.prior_knot_coefficients, 1.0) + "\n";
  }
  out += std::string("estimate = ") + (e.rotary.estimate ? "true" : "false") + "\n";
  if (e.rotary.estimate) {
    const auto& p = e.rotary.candidates.powers;
    out += "degree = " + std::to_string(p.empty() ? 0 : p.back()) + "\n";
    out += "knots_deg = " + number_list(e.rotary.candidates.knots_rad, kRadToDeg) + "\n";
  }
  out += "\n[model]\n";
  out += power_terms("a", e.model.a.powers);
  out += "a_knots_deg = " + number_list(e.model.a.knots_rad, kRadToDeg) + "\n";
  out += power_terms("b1", e.model.b1.powers);
  out += "b1_knots_deg = " + number_list(e.model.b1.knots_rad, kRadToDeg) + "\n";
  out += std::string("bias = ") + (e.model.bias ? "true" : "false") + "\n";
  out += std::string("structure = \"") +
         (e.model.structure == StructureMode::fixed ? "fixed" : "stepwise") + "\"\n";
  if (e.model.lags != 1) out += "lags = " + std::to_string(e.model.lags) + "\n";
  // The extensions, only when used (a file without them reads back the same defaults).
  for (const auto& [name, cfg] : {std::pair<const char*, const SplineConfig*>{"static_correction", &e.model.static_correction},
                                  std::pair<const char*, const SplineConfig*>{"rotary_correction", &e.model.rotary_correction}}) {
    if (!cfg->powers.empty()) out += power_terms(name, cfg->powers);
    if (!cfg->knots_rad.empty())
      out += std::string(name) + "_knots_deg = " + number_list(cfg->knots_rad, kRadToDeg) + "\n";
  }
  if (e.model.delay == DelayEstimation::estimated) {
    out += "delay = \"estimated\"\n";
    if (e.model.delay_start_s != 0.0) out += "delay_start_s = " + format_double(e.model.delay_start_s) + "\n";
  }
  if (e.model.further_lag_start == LagStart::at_rest) out += "further_lag_start = \"at_rest\"\n";
  return out;
}

}  // namespace indicial
