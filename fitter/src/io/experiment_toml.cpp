// Experiment file (TOML) reading, section by section, and writing. See
// indicial/fitter/experiment_toml.hpp.
#include "indicial/fitter/experiment_toml.hpp"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "indicial/coef_file.hpp"
#include "indicial/fitter/csv_reader.hpp"
#include "indicial/fitter/error.hpp"
#include "indicial/fitter/experiment_checks.hpp"
#include "indicial/fitter/io.hpp"
#include "indicial/fitter/output.hpp"
#include "indicial/fitter/phase_resample.hpp"
#include "io/toml_reader.hpp"

namespace fs = std::filesystem;

namespace indicial {
namespace {

using detail::kDegToRad;
using detail::kRadToDeg;
using detail::TomlReader;

// The coefficient names a run CSV and an experiment may use.
const std::set<std::string>& coefficient_names() {
  static const std::set<std::string> names = {"CL", "Cm", "CD", "CY", "Cl", "Cn"};
  return names;
}

// A knot list's source, for range checks after the runs are read.
struct KnotSource {
  std::string key;
  const std::vector<double>* knots_rad;
  toml::source_region where;
};

// One entry of `runs`, before its file is read.
struct RunEntry {
  std::string file;
  std::vector<std::string> files;    // `files = [...]`: columns at their own phases (phase_resample.hpp)
  std::vector<ColumnMap> file_columns;  // each file's own map ({file = ..., columns = {...}}; empty: none)
  int samples = 0;                   // with files: the uniform grid's size (0: the most rows of any file)
  long line = 0;
  std::optional<bool> periodic;      // as stated
  RunCsvOptions csv;                 // grid and frequency (from frequency_hz or reduced_frequency)
  bool frequency_given = false;
  double airspeed_mps = 0.0;         // the run's V (default: the experiment's)
  int cycles_averaged = 0;           // cycles behind an ensemble average's spread column (0: not given)
  std::string group;                 // the run's group (Run::group; empty: not given)
};

// A use of a runtime capacity found while reading, checked once the structure is known
// (check_runtime_capacity, experiment_checks.hpp), and where the file gives it.
struct SitedCapacityUse {
  CapacityUse use;
  toml::source_region where;
};

// What the section readers share: the reader, the file's directory, and the places to check
// against the data once the runs are read.
struct LoadContext {
  const TomlReader& r;
  fs::path base_dir;
  std::vector<KnotSource> knot_sources;
  toml::source_region static_where;
  ColumnMap columns;
  CsvDialect dialect;
  std::vector<SitedCapacityUse> capacity;

  std::string resolve(const std::string& file) const {
    const fs::path p(file);
    return (p.is_absolute() || base_dir.empty() ? p : base_dir / p).lexically_normal().string();
  }
  const toml::node& require(const toml::table& t, const std::string& key,
                            const std::string& where) const {
    const toml::node* n = t.get(key);
    if (!n) {
      throw InputError(r.file(), static_cast<long>(t.source().begin.line),
                       "missing required key '" + where + key + "'");
    }
    return *n;
  }
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


toml::table parse_toml(const std::string& toml_path) {
  const std::string text = read_text(toml_path);
  refuse_bytes_toml_cannot_take(text, toml_path);
  try {
    return toml::parse(text, toml_path);
  } catch (const toml::parse_error& e) {
    throw InputError(toml_path, static_cast<long>(e.source().begin.line),
                     "TOML syntax error: " + std::string(e.description()));
  }
}

// axis, coefficient, reference_length_m, airspeed_mps, alpha0_*.
void read_top_level(LoadContext& c, const toml::table& root, const std::string& coefficient, Experiment& e) {
  const TomlReader& r = c.r;
  e.axis = r.choice<Axis>(c.require(root, "axis", ""), "axis");

  e.coefficient = coefficient;
  const toml::node& l_node = c.require(root, "reference_length_m", "");
  e.reference_length_m = r.number(l_node, "reference_length_m");
  if (!(e.reference_length_m > 0)) r.fail(l_node, "'reference_length_m' must be > 0");
  const toml::node& v_node = c.require(root, "airspeed_mps", "");
  e.airspeed_mps = r.number(v_node, "airspeed_mps");
  if (!(e.airspeed_mps > 0)) r.fail(v_node, "'airspeed_mps' must be > 0");

  const toml::node* a0deg = root.get("alpha0_deg");
  const toml::node* a0rad = root.get("alpha0_rad");
  if (a0deg && a0rad) r.fail(*a0rad, "give 'alpha0_deg' or 'alpha0_rad', not both");
  if (a0deg) e.alpha0_rad = r.number(*a0deg, "alpha0_deg") * kDegToRad;
  if (a0rad) e.alpha0_rad = r.number(*a0rad, "alpha0_rad");
  if (e.axis != Axis::pitch && !a0deg && !a0rad) {
    throw InputError(r.file(), 0, std::string("missing required key 'alpha0_deg' (the fixed "
                                              "angle of attack of a ") +
                                      axis_name(e.axis) + " experiment)");
  }
}

// The coefficients the file models: `coefficient = "Cm"` or `coefficients = ["CL", "Cm"]`,
// exactly one of the two; names valid and distinct, at most DefaultCapacity::max_coefficients.
std::vector<std::string> read_coefficient_names(const LoadContext& c, const toml::table& root) {
  const TomlReader& r = c.r;
  const toml::node* one = root.get("coefficient");
  const toml::node* many = root.get("coefficients");
  if (one && many) r.fail(*many, "give 'coefficient' or 'coefficients', not both");
  if (!one && !many) c.require(root, "coefficient", "");
  auto valid = [&](const toml::node& n, const std::string& key) {
    const std::string name = r.string(n, key);
    if (coefficient_names().count(name) == 0)
      r.fail(n, "'" + key + "' must be one of CL, Cm, CD, CY, Cl, Cn, found \"" + name + "\"");
    return name;
  };
  if (one) return {valid(*one, "coefficient")};
  std::vector<std::string> names;
  for (const auto& n : r.array(*many, "coefficients")) {
    names.push_back(valid(n, "coefficients"));
    if (std::count(names.begin(), names.end(), names.back()) > 1)
      r.fail(n, "'coefficients' names " + names.back() + " twice");
  }
  if (names.empty()) r.fail(*many, "'coefficients' is empty");
  if (names.size() > static_cast<std::size_t>(DefaultCapacity::max_coefficients))
    r.fail(*many, "'coefficients' lists " + std::to_string(names.size()) +
                      "; the runtime (indicial::DefaultCapacity) holds at most " +
                      std::to_string(DefaultCapacity::max_coefficients) + " per model");
  return names;
}

// The section `name` ("static", "rotary", "model") that applies to `coefficient`. With several
// coefficients a section is either shared ([model] with its keys, for all) or per coefficient
// ([model.CL], [model.Cm], each with the same keys): never both, and a per-coefficient table
// must name one of `coefficients`. A shared [static] polynomial is refused (one static curve
// for CL and Cm is a mistake); a shared static table (one file with both columns) is fine.
const toml::node* section_for(const LoadContext& c, const toml::table& root, const std::string& name,
                              const std::vector<std::string>& coefficients, const std::string& coefficient) {
  const toml::node* node = root.get(name);
  if (coefficients.size() < 2 || !node || !node->is_table()) return node;
  const TomlReader& r = c.r;
  std::string per, shared;
  for (auto&& [key, value] : *node->as_table()) {
    const std::string k(key.str());
    const bool is_coefficient = coefficient_names().count(k) > 0;
    if (is_coefficient && std::find(coefficients.begin(), coefficients.end(), k) == coefficients.end())
      r.fail(key.source(), "'[" + name + "." + k + "]': " + k + " is not in 'coefficients'");
    (is_coefficient ? per : shared) += (is_coefficient ? per : shared).empty() ? k : ", " + k;
  }
  if (!per.empty() && !shared.empty()) {
    r.fail(*node, "'[" + name + "]' mixes per-coefficient tables (" + per + ") with shared keys (" + shared +
                      "): give one form");
  }
  if (per.empty()) {
    if (name == "static" && node->as_table()->get("polynomial"))
      r.fail(*node, "a shared '[static] polynomial' would be one static curve for every coefficient: give "
                    "[static." + coefficients.front() + "], [static." + coefficients.back() + "], ...");
    return node;
  }
  return node->as_table()->get(coefficient);
}

// A column map (`[columns]`, `[static] columns`): our column name = the file's name, into *out.
// The file column a map value names: "-X" (X with its sign flipped) names X.
std::string mapped_column_name(const std::string& theirs) {
  return theirs.size() > 1 && theirs[0] == '-' ? theirs.substr(1) : theirs;
}

// A file column mapped to two of ours is refused (one of them was silently lost): a
// digitizer's files headed x,y each hold a different quantity under the same name, which
// only a map per file can say.
void read_column_map(const TomlReader& r, const toml::node& node, const std::string& key_name,
                     std::map<std::string, std::string>* out) {
  std::map<std::string, std::string> mapped_from;  // the file's name (sign dropped) -> ours
  const bool per_file = key_name == "runs.files.columns";
  for (auto&& [key, value] : r.table(node, key_name)) {
    const std::string ours(key.str());
    const std::string theirs = r.string(value, key_name + "." + ours);
    if (theirs.empty()) r.fail(value, "'" + key_name + "." + ours + "' is empty: name the file's column");
    const auto [it, fresh] = mapped_from.emplace(mapped_column_name(theirs), ours);
    if (!fresh)
      r.fail(value, "'" + key_name + "' maps the file column '" + mapped_column_name(theirs) + "' to both '" +
                        it->second + "' and '" + ours + "': a column is one quantity" +
                        (per_file ? std::string()
                                  : " (files whose columns share names, such as a digitizer's x,y, each need a map "
                                    "of their own: runs = [{files = [{file = \"alpha.csv\", columns = {phase_deg = "
                                    "\"x\", alpha_deg = \"y\"}}, {file = \"cl.csv\", columns = {phase_deg = "
                                    "\"x\", CL = \"y\"}}], frequency_hz = ...}])"));
    (*out)[ours] = theirs;
  }
}

// A file's own map over the experiment's [columns]: every [columns] entry for one of the file
// columns its own map names is dropped (else both would rename that column, and the first in
// our names' order would win: a trial's [columns] phase_cycles = "x" beat a file's
// phase_deg = "x"), then the file's entries are laid over the rest.
ColumnMap file_column_map(const ColumnMap& experiment, const ColumnMap& own) {
  std::set<std::string> taken;
  for (const auto& [ours, theirs] : own) taken.insert(mapped_column_name(theirs));
  ColumnMap merged;
  for (const auto& [ours, theirs] : experiment)
    if (!taken.count(mapped_column_name(theirs))) merged[ours] = theirs;
  for (const auto& [ours, theirs] : own) merged[ours] = theirs;
  return merged;
}

// runs.files (at least one file name) and runs.samples; each file has its own phase column, so
// the run is one periodic cycle with its frequency given (checked by read_runs).
void read_run_files(const TomlReader& r, const toml::node& files, const toml::table& t, RunEntry& re) {
  for (const auto& n : r.array(files, "runs.files")) {
    ColumnMap own;
    if (const toml::table* ft = n.as_table()) {
      // {file = "cl.csv", columns = {phase_deg = "x", CL = "y"}}: this file's own column map.
      r.check_keys(*ft, {"file", "columns"}, "runs.files.");
      const toml::node* f = ft->get("file");
      if (!f) r.fail(n, "a 'runs.files' table needs 'file' (and optionally 'columns', the file's own column map)");
      re.files.push_back(r.string(*f, "runs.files.file"));
      if (const toml::node* m = ft->get("columns")) read_column_map(r, *m, "runs.files.columns", &own);
    } else {
      re.files.push_back(r.string(n, "runs.files entry"));
    }
    re.file_columns.push_back(own);
  }
  if (re.files.empty()) r.fail(files, "'runs.files' is empty");
  re.file = re.files.front();
  for (std::size_t i = 1; i < re.files.size(); ++i) re.file += " + " + re.files[i];
  if (const toml::node* n = t.get("samples")) {
    const long v = r.integer(*n, "runs.samples");
    if (v < min_run_samples || v > 100000)
      r.fail(*n, "'runs.samples' must be " + std::to_string(min_run_samples) + "..100000");
    re.samples = static_cast<int>(v);
  }
  if (t.get("time_grid")) r.fail(*t.get("time_grid"), "'runs.time_grid' is not used with 'runs.files' (the grid is "
                                                      "uniform: 'runs.samples' points)");
}

// One table entry of `runs`: {file = ..., periodic, frequency_hz | reduced_frequency,
// airspeed_mps, time_grid}.
RunEntry read_run_table(const LoadContext& c, const toml::node& entry, const Experiment& e) {
  const TomlReader& r = c.r;
  const toml::table& t = *entry.as_table();
  r.check_keys(t, {"file", "files", "samples", "periodic", "frequency_hz", "reduced_frequency", "airspeed_mps",
                   "time_grid", "cycles_averaged", "group"}, "runs.");
  RunEntry re;
  re.line = static_cast<long>(entry.source().begin.line);
  const toml::node* f = t.get("file");
  const toml::node* fs = t.get("files");
  if (f && fs) r.fail(*fs, "give 'runs.file' or 'runs.files', not both");
  if (!f && !fs) r.fail(entry, "a run table needs 'file' (or 'files': columns at their own phases)");
  if (f) re.file = r.string(*f, "runs.file");
  if (fs) read_run_files(r, *fs, t, re);
  if (const toml::node* n = t.get("periodic")) re.periodic = r.boolean(*n, "runs.periodic");
  if (const toml::node* n = t.get("group")) {
    re.group = r.string(*n, "runs.group");
    if (re.group.find_first_not_of(" \t") == std::string::npos)
      r.fail(*n, "'runs.group' is empty: name the tunnel entry, campaign or session the run belongs to");
  }
  re.airspeed_mps = e.airspeed_mps;
  if (const toml::node* n = t.get("airspeed_mps")) {
    re.airspeed_mps = r.number(*n, "runs.airspeed_mps");
    if (!(re.airspeed_mps > 0.0)) r.fail(*n, "'runs.airspeed_mps' must be > 0");
  }
  const toml::node* fh = t.get("frequency_hz");
  const toml::node* k = t.get("reduced_frequency");
  if (fh && k) r.fail(*k, "give 'runs.frequency_hz' or 'runs.reduced_frequency', not both");
  if (fh) {
    re.csv.frequency_hz = r.number(*fh, "runs.frequency_hz");
    if (!(re.csv.frequency_hz > 0.0)) r.fail(*fh, "'runs.frequency_hz' must be > 0");
  }
  if (k) {
    // k = 2 pi f l / V, with V the run's airspeed.
    const double kv = r.number(*k, "runs.reduced_frequency");
    if (!(kv > 0.0)) r.fail(*k, "'runs.reduced_frequency' must be > 0");
    re.csv.frequency_hz = frequency_hz_from_reduced(kv, re.airspeed_mps, e.reference_length_m);
  }
  re.frequency_given = fh || k;
  if (const toml::node* n = t.get("time_grid")) re.csv.grid = r.choice<TimeGrid>(*n, "runs.time_grid");
  if (t.get("samples") && !fs) r.fail(*t.get("samples"), "'runs.samples' is used only with 'runs.files'");
  if (const toml::node* n = t.get("cycles_averaged")) {
    if (fs) r.fail(*n, "'runs.cycles_averaged' is not used with 'runs.files' (a spread column is read from a "
                       "run of one file)");
    const long v = r.integer(*n, "runs.cycles_averaged");
    if (v < 2 || v > 1000000)
      r.fail(*n, "'runs.cycles_averaged' must be an integer 2..1000000 (the number of cycles the file's average "
                 "and spread column were taken over; one cycle has no spread)");
    re.cycles_averaged = static_cast<int>(v);
  }
  return re;
}

// The `runs` array: strings or tables.
std::vector<RunEntry> read_run_entries(LoadContext& c, const toml::table& root, const Experiment& e) {
  const TomlReader& r = c.r;
  const toml::node& runs_node = c.require(root, "runs", "");
  const toml::array& runs = r.array(runs_node, "runs");
  if (runs.empty()) r.fail(runs_node, "'runs' is empty: name at least one run CSV");
  std::vector<RunEntry> entries;
  for (const auto& entry : runs) {
    if (entry.is_string()) {
      RunEntry re;
      re.file = *entry.value<std::string>();
      re.line = static_cast<long>(entry.source().begin.line);
      re.airspeed_mps = e.airspeed_mps;
      entries.push_back(re);
    } else if (entry.is_table()) {
      entries.push_back(read_run_table(c, entry, e));
    } else {
      r.fail(entry, "wrong type: 'runs' entries must be strings or {file = ..., periodic = ...} "
                    "tables, found " + TomlReader::type_name(entry));
    }
    entries.back().csv.columns = c.columns;
    entries.back().csv.dialect = c.dialect;
  }
  return entries;
}


// [columns]: the runs' (and, without [static] columns, the static table's) column map.
void read_columns_section(LoadContext& c, const toml::node* node) {
  if (node) read_column_map(c.r, *node, "columns", &c.columns);
}

// The static table's column map: [columns] with [static] columns over it.
ColumnMap static_table_column_map(const ColumnMap& runs, const StaticConfig& table) {
  ColumnMap columns = runs;
  for (const auto& [ours, theirs] : table.table_columns) columns[ours] = theirs;
  return columns;
}

// [csv]: the run files' delimiter and comment characters (CsvDialect; detected by default).
void read_csv_section(LoadContext& c, const toml::node* node) {
  if (!node) return;
  const TomlReader& r = c.r;
  const toml::table& t = r.table(*node, "csv");
  r.check_keys(t, {"delimiter", "comment"}, "csv.");
  if (const toml::node* n = t.get("delimiter")) c.dialect.delimiter = r.choice<Delimiter>(*n, "csv.delimiter");
  if (const toml::node* n = t.get("comment")) {
    c.dialect.comment_chars = r.string(*n, "csv.comment");
    for (char ch : c.dialect.comment_chars)
      if (ch == ' ' || ch == '\t' || ch == '"' || ch == '-' || ch == '+' || ch == '.' || (ch >= '0' && ch <= '9'))
        r.fail(*n, std::string("'csv.comment': '") + ch + "' cannot start a comment (it starts a number or a field)");
  }
}

// [static]: polynomial or table.
// The [static] table's lift column (CL, or CL derived from Cnormal and Ctangential through
// [columns]) when the experiment models another coefficient in pitch: Experiment::table_lift_polar,
// which diagnose offers the dynamic-stall families with (a Cm experiment whose table also has
// the lift). Optional: a table without it is not an error.
void read_table_lift_polar(const std::string& path, const LoadContext& c, const ColumnMap& columns, Experiment& e) {
  if (e.axis != Axis::pitch || e.coefficient == "CL") return;
  StaticConfig lift;
  try {
    read_static_table(path, e.axis, "CL", lift, columns, c.dialect);
  } catch (const InputError&) {
    return;  // no lift column: the stall families need model.stall_polar then
  }
  e.table_lift_polar.x_rad = lift.table_x_rad;
  e.table_lift_polar.lift = lift.table_value;
  e.table_lift_polar.path = path;
}

void read_static_section(LoadContext& c, const toml::table& root, const toml::node* section, Experiment& e) {
  const TomlReader& r = c.r;
  if (!section) {
    throw InputError(r.file(), static_cast<long>(root.source().begin.line),
                     "missing required key 'static" + (root.get("static") ? "." + e.coefficient : std::string()) + "'");
  }
  const toml::node& static_node = *section;
  const toml::table& st = r.table(static_node, "static");
  r.check_keys(st, {"polynomial", "table", "columns"}, "static.");
  const toml::node* poly = st.get("polynomial");
  const toml::node* table = st.get("table");
  if (poly && table) r.fail(*table, "give 'static.polynomial' or 'static.table', not both");
  if (poly && st.get("columns")) r.fail(*st.get("columns"), "'static.columns' names a static table's columns: give 'static.table'");
  if (!poly && !table) r.fail(static_node, "missing required key 'static.polynomial' or 'static.table'");
  c.static_where = static_node.source();
  if (poly) {
    e.static_curve.kind = StaticKind::polynomial;
    e.static_curve.polynomial = r.numbers(*poly, "static.polynomial");
    c.capacity.push_back({{"static.polynomial", "coefficients", static_cast<int>(e.static_curve.polynomial.size()),
                           DefaultCapacity::max_powers},
                          poly->source()});
    if (e.static_curve.polynomial.size() > static_cast<std::size_t>(FitCapacity::max_powers)) {
      r.fail(*poly, "'static.polynomial' has more than " +
                        std::to_string(FitCapacity::max_powers) + " coefficients");
    }
  } else {
    c.static_where = table->source();
    const std::string tp = c.resolve(r.string(*table, "static.table"));
    if (const toml::node* n = st.get("columns")) read_column_map(r, *n, "static.columns", &e.static_curve.table_columns);
    const ColumnMap columns = static_table_column_map(c.columns, e.static_curve);
    read_static_table(tp, e.axis, e.coefficient, e.static_curve, columns, c.dialect);
    read_table_lift_polar(tp, c, columns, e);
    c.capacity.push_back({{"static.table", "rows ('" + tp + "')", static_cast<int>(e.static_curve.table_x_rad.size()),
                           DefaultCapacity::max_table_points},
                          table->source()});
  }
}

// [rotary] prior_knots_deg, prior_knot_powers, prior_knot_coefficients.
void read_prior_knots(const TomlReader& r, const toml::table& rt, RotaryConfig& rotary,
                      std::vector<SitedCapacityUse>& c_capacity) {
  const toml::node* k = rt.get("prior_knots_deg");
  const toml::node* c = rt.get("prior_knot_coefficients");
  if ((k == nullptr) != (c == nullptr))
    r.fail(k ? *k : *c, "give both 'rotary.prior_knots_deg' and 'rotary.prior_knot_coefficients'");
  const toml::node* pw = rt.get("prior_knot_powers");
  if (pw && !k) r.fail(*pw, "'rotary.prior_knot_powers' needs 'rotary.prior_knots_deg'");
  if (!k || !c) return;
  // Not knots_deg(): a priori terms may repeat a knot with another power, and need not lie
  // inside the data's range (they are known, not identified).
  rotary.prior_knots_rad = r.numbers(*k, "rotary.prior_knots_deg");
  c_capacity.push_back({{"rotary.prior_knots_deg", "knot terms", static_cast<int>(rotary.prior_knots_rad.size()),
                         DefaultCapacity::max_knots},
                        k->source()});
  for (double& v : rotary.prior_knots_rad) v *= kDegToRad;
  rotary.prior_knot_coefficients = r.numbers(*c, "rotary.prior_knot_coefficients");
  const std::size_t n = rotary.prior_knots_rad.size();
  if (n > static_cast<std::size_t>(FitCapacity::max_knots))
    r.fail(*k, "'rotary.prior_knots_deg' has more than " + std::to_string(FitCapacity::max_knots) + " terms");
  rotary.prior_knot_powers.assign(n, 1);
  if (pw) {
    rotary.prior_knot_powers.clear();
    for (const auto& entry : r.array(*pw, "rotary.prior_knot_powers")) {
      const long p = r.integer(entry, "rotary.prior_knot_powers entry");
      if (p < 0 || p > max_knot_power)
        r.fail(entry, "'rotary.prior_knot_powers': power " + std::to_string(p) + " is outside 0.." +
                          std::to_string(max_knot_power));
      rotary.prior_knot_powers.push_back(static_cast<int>(p));
    }
    if (rotary.prior_knot_powers.size() != n)
      r.fail(*pw, "'rotary.prior_knot_powers' has " + std::to_string(rotary.prior_knot_powers.size()) +
                      " entries for " + std::to_string(n) + " terms in 'rotary.prior_knots_deg'");
  }
  if (rotary.prior_knot_coefficients.size() != n)
    r.fail(*c, "'rotary.prior_knot_coefficients' has " +
                   std::to_string(rotary.prior_knot_coefficients.size()) + " entries for " +
                   std::to_string(n) + " terms in 'rotary.prior_knots_deg'");
}

// [rotary]: the a priori C_aq(x) and, with estimate = true, the candidate pool.
void read_rotary_section(LoadContext& c, const toml::node* rot_node, RotaryConfig& rotary) {
  const TomlReader& r = c.r;
  if (!rot_node) {
    rotary.candidates.powers = {0};
    rotary.candidates.knot_power = 1;
    return;
  }
  const toml::table& rt = r.table(*rot_node, "rotary");
  r.check_keys(rt, {"polynomial", "estimate", "degree", "knots_deg", "prior_knots_deg",
                    "prior_knot_powers", "prior_knot_coefficients"},
               "rotary.");
  read_prior_knots(r, rt, rotary, c.capacity);
  if (const toml::node* n = rt.get("polynomial")) {
    rotary.polynomial = r.numbers(*n, "rotary.polynomial");
    c.capacity.push_back({{"rotary.polynomial", "coefficients", static_cast<int>(rotary.polynomial.size()),
                           DefaultCapacity::max_powers},
                          n->source()});
    if (rotary.polynomial.size() > static_cast<std::size_t>(FitCapacity::max_powers)) {
      r.fail(*n, "'rotary.polynomial' has more than " + std::to_string(FitCapacity::max_powers) +
                     " coefficients");
    }
  }
  if (const toml::node* n = rt.get("estimate")) rotary.estimate = r.boolean(*n, "rotary.estimate");
  rotary.candidates.knot_power = 1;
  if (const toml::node* n = rt.get("degree")) {
    rotary.candidates.powers = r.degree_powers(*n, "rotary.degree");
    c.capacity.push_back({{"rotary.degree", "powers (x^0..x^degree)", rotary.candidates.powers.back() + 1,
                           DefaultCapacity::max_powers, CapacityUse::Pool::rotary_estimate},
                          n->source()});
  } else {
    // Why this default: without a degree the pool is the a-priori polynomial's own powers
    // (at least a constant), so estimate = true re-estimates the same shape.
    const int d = std::max<int>(0, static_cast<int>(rotary.polynomial.size()) - 1);
    for (int p = 0; p <= d; ++p) rotary.candidates.powers.push_back(p);
  }
  if (const toml::node* n = rt.get("knots_deg")) {
    rotary.candidates.knots_rad = r.knots_deg(*n, "rotary.knots_deg");
    c.knot_sources.push_back({"rotary.knots_deg", &rotary.candidates.knots_rad, n->source()});
    c.capacity.push_back({{"rotary.knots_deg", "knots", static_cast<int>(rotary.candidates.knots_rad.size()),
                           DefaultCapacity::max_knots, CapacityUse::Pool::rotary_estimate},
                          n->source()});
  }
  if (!rotary.estimate && (rt.get("degree") || rt.get("knots_deg"))) {
    r.fail(*rot_node, "'rotary.degree' and 'rotary.knots_deg' are used only with "
                      "rotary.estimate = true");
  }
}

// [model] NAME_degree | NAME_powers and NAME_knots_deg of one spline.
void read_spline_terms(LoadContext& c, const toml::table& mt, const std::string& name,
                       SplineConfig& cfg) {
  const TomlReader& r = c.r;
  const toml::node* deg = mt.get(name + "_degree");
  const toml::node* pw = mt.get(name + "_powers");
  if (deg && pw) r.fail(*pw, "give 'model." + name + "_degree' or 'model." + name + "_powers', not both");
  if (deg) cfg.powers = r.degree_powers(*deg, "model." + name + "_degree");
  if (pw) cfg.powers = r.powers(*pw, "model." + name + "_powers");
  // Why a and b1 only are pools: with structure = "stepwise" their terms are candidates; the
  // corrections diagnose adds are always in the model.
  const auto pool = name == "a" || name == "b1" ? CapacityUse::Pool::model_stepwise : CapacityUse::Pool::none;
  if (deg || pw) {
    c.capacity.push_back({{"model." + name + (deg ? "_degree" : "_powers"), "powers (x^0..x^n)",
                           cfg.powers.empty() ? 0 : cfg.powers.back() + 1, DefaultCapacity::max_powers, pool},
                          (deg ? deg : pw)->source()});
  }
  if (const toml::node* k = mt.get(name + "_knots_deg")) {
    cfg.knots_rad = r.knots_deg(*k, "model." + name + "_knots_deg");
    c.knot_sources.push_back({"model." + name + "_knots_deg", &cfg.knots_rad, k->source()});
    c.capacity.push_back({{"model." + name + "_knots_deg", "knots", static_cast<int>(cfg.knots_rad.size()),
                           DefaultCapacity::max_knots, pool},
                          k->source()});
  }
}

// The [model] keys of lag k's b_k(x) (k = 1..FitCapacity::max_lags): bK_degree, bK_powers,
// bK_knots_deg, the same names for every lag.
std::vector<std::string> lag_b_keys(int k) {
  const std::string b = "b" + std::to_string(k);
  return {b + "_degree", b + "_powers", b + "_knots_deg"};
}

// The keys [model] accepts.
std::set<std::string> model_keys() {
  std::set<std::string> keys = {"a_degree", "a_powers", "a_knots_deg", "bias", "structure", "lags",
                                // extensions (docs/formats.md): what `indicial diagnose` adds to a model
                                "static_correction_degree", "static_correction_powers",
                                "static_correction_knots_deg", "rotary_correction_degree",
                                "rotary_correction_powers", "rotary_correction_knots_deg", "delay",
                                "delay_start_s", "further_lag_start",
                                // the dynamic-stall families (issue 22)
                                "stall", "stall_polar", "stall_polar_column", "stall_attached_max_deg",
                                "stall_f0_correction_degree", "stall_f0_correction_powers",
                                "stall_f0_correction_knots_deg", "stall_known", "stall_reattachment",
                                "stall_forcing_lag", "stall_hysteresis", "stall_lag_limit"};
  for (const StallStart& st : stall_starts()) keys.insert(st.key);
  for (int k = 1; k <= FitCapacity::max_lags; ++k)
    for (const std::string& key : lag_b_keys(k)) keys.insert(key);
  return keys;
}

// model.lags: 1..FitCapacity::max_lags here; beyond the runtime's capacity refused with the
// other capacity uses once the structure is known.
void read_lag_count(LoadContext& c, const toml::table& mt, ModelConfig& model) {
  const TomlReader& r = c.r;
  const toml::node* n = mt.get("lags");
  if (!n) return;
  const long lags = r.integer(*n, "model.lags");
  if (lags < 1 || lags > FitCapacity::max_lags) {
    r.fail(*n, "'model.lags' must be 1.." + std::to_string(FitCapacity::max_lags));
  }
  model.lags = static_cast<int>(lags);
  c.capacity.push_back({{"model.lags", "lags", model.lags, DefaultCapacity::max_lags}, n->source()});
}

// b_k(x) of lags k = 2..model.lags (ModelConfig::further_lag_b); a lag without keys keeps the
// constant b_k. Keys of a lag beyond model.lags are refused (they would be silently unused).
void read_further_lag_b(LoadContext& c, const toml::table& mt, ModelConfig& model) {
  model.further_lag_b.clear();
  for (int k = 2; k <= FitCapacity::max_lags; ++k) {
    const std::vector<std::string> keys = lag_b_keys(k);
    const auto given = std::find_if(keys.begin(), keys.end(), [&](const std::string& key) { return mt.get(key); });
    if (given == keys.end()) continue;
    if (k > model.lags) {
      c.r.fail(*mt.get(*given), "'model." + *given + "' is for lag " + std::to_string(k) + " but model.lags = " +
                                    std::to_string(model.lags) + ": set 'lags = " + std::to_string(k) + "' or remove it");
    }
    model.further_lag_b.resize(static_cast<std::size_t>(k - 1), SplineConfig{{0}, {}, 1});
    read_spline_terms(c, mt, "b" + std::to_string(k), model.further_lag_b.back());
  }
}

// The [model] keys as the shared checks (experiment_checks.hpp) name them: "model.KEY", a
// problem reported at the key's line ("stall_known.T1": the entry's line).
KeySite model_key_site(const TomlReader& r, const toml::table& mt) {
  return KeySite{[](const std::string& key) { return "model." + key; },
                 [&r, &mt](const std::string& key, const std::string& problem) {
                   const toml::node* n = mt.get(key);
                   if (const auto dot = key.find('.'); dot != std::string::npos) {
                     const toml::node* t = mt.get(key.substr(0, dot));
                     n = t && t->is_table() ? t->as_table()->get(key.substr(dot + 1)) : t;
                   }
                   if (n) r.fail(*n, problem);
                   r.fail(mt.source(), problem);
                 }};
}

// [model]: the splines, the structure and what diagnose adds.
void read_model_section(LoadContext& c, const toml::node* model_node, bool rotary_estimate,
                        ModelConfig& model) {
  const TomlReader& r = c.r;
  if (!model_node) return;
  const toml::table& mt = r.table(*model_node, "model");
  r.check_keys(mt, model_keys(), "model.");
  read_lag_count(c, mt, model);
  read_spline_terms(c, mt, "a", model.a);
  read_spline_terms(c, mt, "b1", model.b1);
  read_further_lag_b(c, mt, model);
  read_spline_terms(c, mt, "static_correction", model.static_correction);
  read_spline_terms(c, mt, "rotary_correction", model.rotary_correction);
  const bool rotary_correction =
      !model.rotary_correction.powers.empty() || !model.rotary_correction.knots_rad.empty();
  if (rotary_correction && rotary_estimate) {
    // Why refused: with rotary.estimate the two-stage loop re-estimates the whole C_aq(x);
    // a correction of the a priori C_aq on top of it would be the same terms twice.
    r.fail(*model_node, "'model.rotary_correction_*' corrects the a priori C_aq(x); it cannot "
                        "be combined with rotary.estimate = true");
  }
  if (const toml::node* n = mt.get("delay")) model.delay = r.choice<DelayEstimation>(*n, "model.delay");
  if (const toml::node* n = mt.get("delay_start_s")) model.delay_start_s = r.number(*n, "model.delay_start_s");
  check_delay_keys(model, mt.get("delay_start_s") != nullptr, model_key_site(r, mt));
  if (const toml::node* n = mt.get("further_lag_start"))
    model.further_lag_start = r.choice<LagStart>(*n, "model.further_lag_start");
  if (const toml::node* n = mt.get("bias")) model.bias = r.boolean(*n, "model.bias");
  if (const toml::node* n = mt.get("structure")) model.structure = r.choice<StructureMode>(*n, "model.structure");
}

// A runs entry `files = [...]`: each file's series at its own phases, resampled onto one grid.
Run read_run_of_files(const LoadContext& c, const RunEntry& entry, const Experiment& e, CoefficientPresence presence) {
  if (!entry.frequency_given)
    throw InputError(c.r.file(), entry.line, "run '" + entry.file + "' (files at their own phases) needs the cycle's "
                                             "frequency: give frequency_hz or reduced_frequency in its entry");
  // The files as resolved from the experiment's folder (as a one-file run's path is): the run is
  // then found from any working directory (provenance digests, a diagnosed experiment.toml).
  std::vector<std::string> resolved;
  std::string label;
  for (const std::string& name : entry.files) {
    resolved.push_back(c.resolve(name));
    label += (label.empty() ? "" : " + ") + resolved.back();
  }
  std::vector<PhaseSeries> series;
  for (std::size_t i = 0; i < resolved.size(); ++i) {
    RunCsvOptions options = entry.csv;  // [columns], with the file's own map over it
    options.columns = file_column_map(entry.csv.columns, entry.file_columns[i]);
    series.push_back(read_phase_series(resolved[i], e.axis, e.coefficient, options));
    // A file's own map names its columns: one the file lacks is a mistake in that map (the
    // run-level "no file has ..." would not say which map).
    for (const auto& [ours, theirs] : entry.file_columns[i]) {
      const std::vector<std::string>& have = series.back().columns;
      if (std::find(have.begin(), have.end(), theirs) != have.end() ||
          std::find(have.begin(), have.end(), mapped_column_name(theirs)) != have.end())
        continue;
      std::string found;
      for (const std::string& h : have) found += (found.empty() ? "" : ", ") + h;
      throw InputError(c.r.file(), entry.line, "runs entry: the map of '" + entry.files[i] + "' names its column '" +
                                                   theirs + "' (for " + ours + "), which the file does not have "
                                                   "(columns found: " + found + ")");
    }
  }
  Run run;
  try {
    run = resample_phase_series(series, e.coefficient, presence, entry.csv.frequency_hz,
                                entry.samples, label);
  } catch (const InputError& err) {
    // The run's own errors (no angle, a coefficient in two files) name its label, not a file:
    // say where its entry is.
    const std::string m = err.what();
    if (m.rfind(label + ": ", 0) != 0) throw;
    throw InputError(c.r.file(), entry.line, "runs entry " + m);
  }
  run.source_files = resolved;
  if (std::any_of(entry.file_columns.begin(), entry.file_columns.end(), [](const ColumnMap& m) { return !m.empty(); }))
    run.source_file_columns = entry.file_columns;
  run.resampled_points = entry.samples;
  return run;
}

// [model] stall keys (the dynamic-stall families, ModelConfig::stall): which families, the
// static lift polar they are derived from (default: the [static] table when the experiment
// models its lift column), its attached part, the f0 correction's terms, the start values and
// stall_known (the parameters held at known values). Read here, checked by check_stall_keys.
void read_stall_keys(LoadContext& c, const toml::node* model_node, Experiment& e) {
  const TomlReader& r = c.r;
  if (!model_node) return;
  const toml::table& mt = r.table(*model_node, "model");
  StallConfig& s = e.model.stall;
  const toml::node* fam = mt.get("stall");
  if (fam) s.families = r.choice<StallFamilies>(*fam, "model.stall");
  if (const toml::node* n = mt.get("stall_reattachment"))
    s.reattachment = r.choice<StallReattachment>(*n, "model.stall_reattachment");
  if (const toml::node* n = mt.get("stall_forcing_lag"))
    s.forcing_lag = r.choice<ForcingLag>(*n, "model.stall_forcing_lag");
  if (const toml::node* n = mt.get("stall_hysteresis"))
    s.hysteresis = r.choice<StallHysteresis>(*n, "model.stall_hysteresis");
  if (const toml::node* n = mt.get("stall_lag_limit"))
    s.lag_limit = r.choice<StallLagLimit>(*n, "model.stall_lag_limit");
  std::set<std::string> given;
  for (auto&& [key, value] : mt)
    if (key.str().rfind("stall_", 0) == 0) given.insert(std::string(key.str()));
  if (const toml::node* n = mt.get("stall_polar_column")) s.polar_column = r.string(*n, "model.stall_polar_column");
  if (const toml::node* n = mt.get("stall_attached_max_deg"))
    s.attached_max_deg = r.number(*n, "model.stall_attached_max_deg");
  for (const StallStart& st : stall_starts())
    if (const toml::node* n = mt.get(st.key)) s.*st.value = r.number(*n, std::string("model.") + st.key);
  if (const toml::node* n = mt.get("stall_known"))
    for (auto&& [key, value] : r.table(*n, "model.stall_known"))
      s.known.emplace_back(std::string(key.str()), r.number(value, "model.stall_known." + std::string(key.str())));
  check_stall_keys(s, given, e.axis, model_key_site(r, mt));
  if (s.families == StallFamilies::none) return;
  read_spline_terms(c, mt, "stall_f0_correction", s.f0_correction);
  if (const toml::node* n = mt.get("stall_polar")) {
    s.polar_path = c.resolve(r.string(*n, "model.stall_polar"));
    StaticConfig polar;
    // The static table named again as the polar is read with its own column names.
    const ColumnMap polar_columns =
        s.polar_path == e.static_curve.table_path ? static_table_column_map(c.columns, e.static_curve) : c.columns;
    read_static_table(s.polar_path, e.axis, s.polar_column, polar, polar_columns, c.dialect);
    s.polar_x_rad = polar.table_x_rad;
    s.polar_lift = polar.table_value;
  } else if (!stall_polar_from_static_table(e, s)) {
    r.fail(*fam, "'model.stall' needs the static lift polar: 'model.stall_polar' (a CSV with alpha_deg and the "
                 "column model.stall_polar_column, default CL), or a [static] table of that coefficient");
  }
}

// A run's ensemble spread (Run::coefficient_spread, read from the file's `<coefficient>_std`
// column) and the entry's cycles_averaged: the noise of the average is spread / sqrt(cycles), so
// a spread without the count is refused; a count without a spread column is a warning (the
// column may be misnamed; another coefficient of the file may have one).
void attach_spread(const LoadContext& c, const RunEntry& entry, const std::string& coefficient, Run& run) {
  const std::string column = coefficient + "_std";
  if (!run.coefficient_spread.empty() && entry.cycles_averaged == 0)
    throw InputError(c.r.file(), entry.line, "run '" + entry.file + "' has a spread column '" + column +
                                             "' but its entry gives no 'cycles_averaged': give the number of cycles "
                                             "averaged (the noise of the average is " + column +
                                             " / sqrt(cycles_averaged))");
  run.ensemble_count = entry.cycles_averaged;
  if (entry.cycles_averaged > 0 && run.coefficient_spread.empty()) {
    run.warnings.push_back(c.r.file() + ":" + std::to_string(entry.line) + ": run '" + entry.file +
                           "' gives 'cycles_averaged' but has no '" + column + "' column: no replication for " +
                           coefficient + " from this run (name the spread column " + column +
                           ", or map it in [columns])");
    return;
  }
  if (!run.coefficient_spread.empty() &&
      std::all_of(run.coefficient_spread.begin(), run.coefficient_spread.end(), [](double v) { return v == 0.0; }))
    run.warnings.push_back(run.path + ": column '" + column + "' is zero at every sample: an average of " +
                           std::to_string(entry.cycles_averaged) + " cycles without any spread is not a measured "
                           "noise (no replication from this run)");
}

// Reads every run file and records the model angle's range over all of them (set_data_range).
// presence: CoefficientPresence::optional reads a coefficient the file does not model where a
// run has it (load_experiment_runs' `also`); an absent column leaves that run's empty.
void read_runs(const LoadContext& c, const std::vector<RunEntry>& entries, Experiment& e,
               CoefficientPresence presence = CoefficientPresence::required) {
  for (const auto& entry : entries) {
    const std::vector<std::string> names = entry.files.empty() ? std::vector<std::string>{entry.file} : entry.files;
    for (const std::string& name : names) {
      const std::string path = c.resolve(name);
      std::error_code ec;
      if (!fs::exists(path, ec))
        throw InputError(c.r.file(), entry.line, "run file '" + name + "' not found (looked for " + path + ")");
    }
    Run run = entry.files.empty()
                  ? read_run_csv(c.resolve(entry.file), e.axis, e.coefficient, presence, entry.csv)
                  : read_run_of_files(c, entry, e, presence);
    run.experiment_line = entry.line;
    run.airspeed_mps = entry.airspeed_mps;
    run.group = entry.group;
    if (run.time_source == TimeSource::phase_column) {
      if (entry.periodic == false)
        throw InputError(c.r.file(), entry.line, "run '" + entry.file + "' has a phase column, so it is one periodic "
                                                 "cycle: remove 'periodic = false'");
    } else {
      // A time column's frequency is the motion's: a record of several cycles then gives the
      // noise from their spread (replication.hpp, replicate_cycles), which was unreachable while
      // the key was refused here.
      if (entry.frequency_given) run.frequency_hz = entry.csv.frequency_hz;
      run.periodic = entry.periodic.value_or(false);
      if (run.periodic) {
        const std::string problem = periodic_closure_problem(run);
        if (!problem.empty()) throw InputError(c.r.file(), entry.line, "run '" + entry.file + "' is " + problem);
      }
    }
    attach_spread(c, entry, e.coefficient, run);
    e.notes.insert(e.notes.end(), run.notes.begin(), run.notes.end());
    e.warnings.insert(e.warnings.end(), run.warnings.begin(), run.warnings.end());
    e.runs.push_back(std::move(run));
  }
  if (const std::optional<GroupMix> mix = run_group_mix(e))
    throw InputError(c.r.file(), entries[mix->ungrouped].line,
                     run_group_mix_problem(entries[mix->ungrouped].file, entries[mix->grouped].file,
                                           e.runs[mix->grouped].group));
  set_data_range(e);
}

// Knots strictly inside the data's angle range; the static table covering it.
void check_against_data(const LoadContext& c, const Experiment& e) {
  for (const auto& ks : c.knot_sources)
    check_knots_in_data(e, *ks.knots_rad, ks.key, [&](std::size_t, const std::string& problem) {
      return InputError(c.r.file(), static_cast<long>(ks.where.begin.line), problem);
    });
  const std::string uncovered = static_table_coverage_problem(e);
  if (!uncovered.empty()) c.r.fail(c.static_where, uncovered);
}

// Every runtime limit at input time, before fitting: the one capacity rule
// (experiment_checks.hpp check_runtime_capacity) on each use the file gives, at its line.
void check_file_capacity(const LoadContext& c, Experiment& e) {
  for (const SitedCapacityUse& u : c.capacity) {
    const long line = static_cast<long>(u.where.begin.line);
    check_runtime_capacity(
        u.use, e, [&](const std::string& problem) { return InputError(c.r.file(), line, problem); },
        c.r.file() + ":" + std::to_string(line) + ": ");
  }
}

// Sections that were left out and so take their defaults.
void warn_defaulted_sections(const TomlReader& r, const toml::node* rotary, const toml::node* model, Experiment& e) {
  if (!rotary) {
    e.warnings.push_back(r.file() + ": no [rotary] section: C_aq(x) = 0 assumed (the rate term is left out)");
  }
  if (e.axis == Axis::pitch && e.coefficient == "Cn") {
    e.warnings.push_back(r.file() + ": coefficient Cn in a pitch experiment: indicial's Cn is the yawing moment (a "
                                    "normal-force column is mapped as Cnormal, see docs/formats.md)");
  }
  if (!model) {
    e.warnings.push_back(r.file() + ": no [model] section: the default a(x) = a0 + a1 x + a2 x^2, b1(x) = b1_0, "
                                    "fixed structure");
  }
}

// A run whose angle never moves has no unsteady response to fit. Why refuse only when no run
// moves: a static run among moving ones still informs the fit (its y0, the bias), but with no
// motion at all a(x) and b1(x) cannot be identified.
void check_motion(const TomlReader& r, Experiment& e) {
  std::size_t moving = 0;
  for (const Run& run : e.runs) {
    const auto [lo, hi] = std::minmax_element(run.motion_angle_rad.begin(), run.motion_angle_rad.end());
    if (*hi - *lo > 1e-9) {
      ++moving;
      continue;
    }
    e.warnings.push_back(run.path + ": the motion angle never moves (constant " + deg_text(*lo) +
                         " deg): the run has no unsteady response to fit");
  }
  if (moving == 0) {
    throw InputError(r.file(), e.runs.front().experiment_line,
                     "no run moves: the motion angle is constant in every run, so a(x) and b1(x) cannot be "
                     "identified");
  }
}

}  // namespace

void set_data_range(Experiment& e) {
  const AngleRange r = model_angle_range(e);
  e.data_x_min_rad = r.empty() ? 0.0 : r.min_rad;
  e.data_x_max_rad = r.empty() ? 0.0 : r.max_rad;
}

namespace {

// What every reader of the runs reads first: the top level, [columns], [csv] and the runs
// entries (load_one goes on to the model sections, load_experiment_runs to the runs).
Experiment read_run_format(LoadContext& c, const toml::table& root, const std::string& coefficient,
                           std::vector<RunEntry>* entries) {
  Experiment e;
  e.path = c.r.file();
  read_top_level(c, root, coefficient, e);
  read_columns_section(c, root.get("columns"));
  read_csv_section(c, root.get("csv"));
  *entries = read_run_entries(c, root, e);
  return e;
}

// One coefficient's experiment from the parsed file (see load_experiments).
Experiment load_one(const std::string& toml_path, const toml::table& root, const std::string& coefficient,
                    const std::vector<std::string>& coefficients) {
  const TomlReader r(toml_path);
  LoadContext c{r, fs::path(toml_path).parent_path(), {}, root.source(), {}, {}, {}};
  std::vector<RunEntry> entries;
  Experiment e = read_run_format(c, root, coefficient, &entries);
  read_static_section(c, root, section_for(c, root, "static", coefficients, coefficient), e);
  const toml::node* rotary = section_for(c, root, "rotary", coefficients, coefficient);
  const toml::node* model = section_for(c, root, "model", coefficients, coefficient);
  read_rotary_section(c, rotary, e.rotary);
  read_model_section(c, model, e.rotary.estimate, e.model);
  read_stall_keys(c, model, e);
  read_runs(c, entries, e);
  check_against_data(c, e);
  check_file_capacity(c, e);
  check_motion(r, e);
  warn_defaulted_sections(r, rotary, model, e);
  return e;
}

toml::table parse_checked(const std::string& toml_path, std::vector<std::string>& coefficients) {
  toml::table root = parse_toml(toml_path);
  const TomlReader r(toml_path);
  r.check_keys(root, {"axis", "coefficient", "coefficients", "reference_length_m", "airspeed_mps", "alpha0_deg",
                      "alpha0_rad", "runs", "static", "rotary", "model", "columns", "csv"},
               "");
  const LoadContext c{r, {}, {}, root.source(), {}, {}, {}};
  coefficients = read_coefficient_names(c, root);
  return root;
}

}  // namespace

RunCsvOptions run_file_format(const std::string& toml_path) {
  const toml::table root = parse_toml(toml_path);
  const TomlReader r(toml_path);
  LoadContext c{r, {}, {}, root.source(), {}, {}, {}};
  read_columns_section(c, root.get("columns"));
  read_csv_section(c, root.get("csv"));
  RunCsvOptions options;
  options.columns = c.columns;
  options.dialect = c.dialect;
  return options;
}

std::vector<Experiment> load_experiment_runs(const std::string& toml_path, const std::vector<std::string>& also) {
  std::vector<std::string> coefficients;
  const toml::table root = parse_checked(toml_path, coefficients);
  auto read = [&](const std::string& name, CoefficientPresence presence) {
    const TomlReader r(toml_path);
    LoadContext c{r, fs::path(toml_path).parent_path(), {}, root.source(), {}, {}, {}};
    std::vector<RunEntry> entries;
    Experiment e = read_run_format(c, root, name, &entries);
    read_runs(c, entries, e, presence);
    return e;
  };
  std::vector<Experiment> out;
  for (const std::string& name : coefficients) out.push_back(read(name, CoefficientPresence::required));
  for (const std::string& name : also)
    if (std::find(coefficients.begin(), coefficients.end(), name) == coefficients.end())
      out.push_back(read(name, CoefficientPresence::optional));
  return out;
}

std::vector<Experiment> load_experiments(const std::string& toml_path) {
  std::vector<std::string> coefficients;
  const toml::table root = parse_checked(toml_path, coefficients);
  std::vector<Experiment> out;
  for (const std::string& name : coefficients) out.push_back(load_one(toml_path, root, name, coefficients));
  return out;
}

Experiment load_experiment(const std::string& toml_path, const std::string& coefficient) {
  std::vector<std::string> coefficients;
  const toml::table root = parse_checked(toml_path, coefficients);
  if (coefficient.empty() && coefficients.size() > 1) {
    const toml::node* n = root.get("coefficients");
    throw InputError(toml_path, static_cast<long>(n->source().begin.line),
                     "'coefficients' lists several coefficients; this command works on one: name it (e.g. "
                     "--coefficient " + coefficients.front() + ")");
  }
  const std::string name = coefficient.empty() ? coefficients.front() : coefficient;
  if (std::find(coefficients.begin(), coefficients.end(), name) == coefficients.end()) {
    throw InputError(toml_path, 0, "coefficient '" + name + "' is not modelled by this experiment");
  }
  return load_one(toml_path, root, name, coefficients);
}

// ==========================================================================================
// Writer
// ==========================================================================================
namespace {
std::string toml_string(const std::string& s) {
  std::string out = "\"";
  for (char ch : s) {
    if (ch == '"' || ch == '\\') out += '\\';
    out += ch;
  }
  return out + "\"";
}
// The shortest decimal of degrees that the reader (value * kDegToRad) turns back into `rad` bit
// for bit. Why: a knot read as 12 deg and written as rad * kRadToDeg reads 12.000000000000002
// (180/pi and pi/180 are not exact inverses in double); the shortest round-tripping digits
// write 12, and any angle still reads back to the same radians.
std::string degrees_text(double rad) {
  for (int digits = 1; digits <= 17; ++digits) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.*g", digits, rad * kRadToDeg);
    const double deg = std::strtod(buf, nullptr);  // "%.1g" of 20 is "2e+01": written as 20
    if (deg * kDegToRad == rad) return format_double(deg);
  }
  return format_double(rad * kRadToDeg);
}
std::string number_list(const std::vector<double>& v, double factor) {
  std::string out = "[";
  for (std::size_t i = 0; i < v.size(); ++i)
    out += (i ? ", " : "") + (factor == kRadToDeg ? degrees_text(v[i]) : format_double(v[i] * factor));
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
// A TOML key: bare when it can be (letters, digits, '_', '-'), quoted otherwise.
std::string toml_key(const std::string& k) {
  const bool bare = !k.empty() && std::all_of(k.begin(), k.end(), [](char ch) {
    return (ch >= 'a' && ch <= 'z') || (ch >= 'A' && ch <= 'Z') || (ch >= '0' && ch <= '9') || ch == '_' || ch == '-';
  });
  return bare ? k : toml_string(k);
}

// A `runs` entry: the bare file name, or a table with the keys that differ from the defaults.
// A phase-column run is periodic by its file (periodic is then implied, not written).
std::string run_entry(const Run& run, double experiment_airspeed_mps) {
  std::string keys;
  if (!run.source_files.empty()) {
    std::string files = "[";
    for (std::size_t i = 0; i < run.source_files.size(); ++i) {
      const ColumnMap* own = i < run.source_file_columns.size() && !run.source_file_columns[i].empty()
                                 ? &run.source_file_columns[i]
                                 : nullptr;
      files += (i ? ", " : "");
      if (!own) {
        files += toml_string(run.source_files[i]);
        continue;
      }
      files += "{file = " + toml_string(run.source_files[i]) + ", columns = {";
      bool first = true;
      for (const auto& [ours, theirs] : *own) {
        files += std::string(first ? "" : ", ") + toml_key(ours) + " = " + toml_string(theirs);
        first = false;
      }
      files += "}}";
    }
    std::string out = "{files = " + files + "], frequency_hz = " + format_double(run.frequency_hz);
    if (run.resampled_points > 0) out += ", samples = " + std::to_string(run.resampled_points);
    if (run.airspeed_mps > 0.0 && run.airspeed_mps != experiment_airspeed_mps)
      out += ", airspeed_mps = " + format_double(run.airspeed_mps);
    if (!run.group.empty()) out += ", group = " + toml_string(run.group);
    return out + "}";
  }
  // (A time column's frequency is the motion's, kept for the noise from its cycles.)
  if (run.frequency_hz > 0.0) keys += ", frequency_hz = " + format_double(run.frequency_hz);
  if (run.time_source != TimeSource::phase_column && run.periodic) keys += ", periodic = true";
  if (run.airspeed_mps > 0.0 && run.airspeed_mps != experiment_airspeed_mps)
    keys += ", airspeed_mps = " + format_double(run.airspeed_mps);
  if (run.time_grid == TimeGrid::nonuniform) keys += std::string(", time_grid = \"") + name_of(run.time_grid) + "\"";
  if (run.ensemble_count >= 2.0) keys += ", cycles_averaged = " + format_double(run.ensemble_count);
  if (!run.group.empty()) keys += ", group = " + toml_string(run.group);
  return keys.empty() ? toml_string(run.path) : "{file = " + toml_string(run.path) + keys + "}";
}


// The [columns] and [csv] sections of a run-file format, each only where it is not the
// default (read_columns_section, read_csv_section read them back).
std::string file_format_sections(const RunCsvOptions& f) {
  std::string out;
  if (!f.columns.empty()) {
    out += "\n[columns]\n";
    for (const auto& [ours, theirs] : f.columns) out += toml_key(ours) + " = " + toml_string(theirs) + "\n";
  }
  const CsvDialect defaults;
  if (f.dialect.delimiter != defaults.delimiter || f.dialect.comment_chars != defaults.comment_chars) {
    out += "\n[csv]\n";
    out += std::string("delimiter = \"") + name_of(f.dialect.delimiter) + "\"\n";
    out += "comment = " + toml_string(f.dialect.comment_chars) + "\n";
  }
  return out;
}

}  // namespace

std::string write_experiment_toml(const Experiment& e, const std::vector<std::string>& comment_lines) {
  return write_experiment_toml(e, comment_lines, RunCsvOptions{});
}

std::string write_experiment_toml(const Experiment& e, const std::vector<std::string>& comment_lines,
                                  const RunCsvOptions& file_format) {
  std::string out;
  for (const auto& c : comment_lines) out += "# " + c + "\n";
  out += std::string("axis = \"") + name_of(e.axis) + "\"\n";
  out += "coefficient = " + toml_string(e.coefficient) + "\n";
  out += "reference_length_m = " + format_double(e.reference_length_m) + "\n";
  out += "airspeed_mps = " + format_double(e.airspeed_mps) + "\n";
  if (e.axis != Axis::pitch) out += "alpha0_deg = " + degrees_text(e.alpha0_rad) + "\n";
  out += "runs = [";
  for (std::size_t i = 0; i < e.runs.size(); ++i) {
    out += i ? ", " : "";
    out += run_entry(e.runs[i], e.airspeed_mps);
  }
  out += "]\n" + file_format_sections(file_format) + "\n[static]\n";
  if (e.static_curve.kind == StaticKind::polynomial) {
    out += "polynomial = " + number_list(e.static_curve.polynomial, 1.0) + "  # x^0, x^1, ... with x in rad\n";
  } else {
    out += "table = " + toml_string(e.static_curve.table_path) + "\n";
    if (!e.static_curve.table_columns.empty()) {
      out += "columns = {";
      bool first = true;
      for (const auto& [ours, theirs] : e.static_curve.table_columns) {
        out += std::string(first ? " " : ", ") + toml_key(ours) + " = " + toml_string(theirs);
        first = false;
      }
      out += " }  # the table's own column names, over [columns]\n";
    }
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
  // Only the lags the model has: the reader refuses b_k keys beyond model.lags.
  for (std::size_t j = 0; j < e.model.further_lag_b.size() && static_cast<int>(j) + 2 <= e.model.lags; ++j) {
    const std::string b = "b" + std::to_string(j + 2);
    out += power_terms(b, e.model.further_lag_b[j].powers);
    if (!e.model.further_lag_b[j].knots_rad.empty())
      out += b + "_knots_deg = " + number_list(e.model.further_lag_b[j].knots_rad, kRadToDeg) + "\n";
  }
  out += std::string("bias = ") + (e.model.bias ? "true" : "false") + "\n";
  out += std::string("structure = \"") + name_of(e.model.structure) + "\"\n";
  if (e.model.lags != 1) out += "lags = " + std::to_string(e.model.lags) + "\n";
  // The extensions, only when used (a file without them reads back the same defaults).
  for (const auto& [name, cfg] : {std::pair<const char*, const SplineConfig*>{"static_correction", &e.model.static_correction},
                                  std::pair<const char*, const SplineConfig*>{"rotary_correction", &e.model.rotary_correction}}) {
    if (!cfg->powers.empty()) out += power_terms(name, cfg->powers);
    if (!cfg->knots_rad.empty())
      out += std::string(name) + "_knots_deg = " + number_list(cfg->knots_rad, kRadToDeg) + "\n";
  }
  if (e.model.delay == DelayEstimation::estimated) {
    out += std::string("delay = \"") + name_of(e.model.delay) + "\"\n";
    if (e.model.delay_start_s != 0.0) out += "delay_start_s = " + format_double(e.model.delay_start_s) + "\n";
  }
  if (e.model.further_lag_start == LagStart::at_rest) out += std::string("further_lag_start = \"") + name_of(e.model.further_lag_start) + "\"\n";
  const StallConfig& st = e.model.stall;
  if (st.families != StallFamilies::none) {
    out += std::string("stall = \"") + name_of(st.families) + "\"\n";
    // Implied only by a [static] table of the polar's own coefficient (read_stall_keys).
    if (st.polar_path != e.static_curve.table_path || e.coefficient != st.polar_column)
      out += "stall_polar = " + toml_string(st.polar_path) + "\n";
    out += "stall_polar_column = " + toml_string(st.polar_column) + "\n";
    out += "stall_attached_max_deg = " + format_double(st.attached_max_deg) + "\n";
    if (st.reattachment != StallReattachment::as_separation)
      out += std::string("stall_reattachment = \"") + name_of(st.reattachment) + "\"\n";
    if (st.forcing_lag != ForcingLag::delay)
      out += std::string("stall_forcing_lag = \"") + name_of(st.forcing_lag) + "\"\n";
    if (st.hysteresis != StallHysteresis::none)
      out += std::string("stall_hysteresis = \"") + name_of(st.hysteresis) + "\"\n";
    if (st.lag_limit != StallLagLimit::none)
      out += std::string("stall_lag_limit = \"") + name_of(st.lag_limit) + "\"\n";
    if (!st.f0_correction.powers.empty()) out += power_terms("stall_f0_correction", st.f0_correction.powers);
    if (!st.f0_correction.knots_rad.empty())
      out += "stall_f0_correction_knots_deg = " + number_list(st.f0_correction.knots_rad, kRadToDeg) + "\n";
    // A held parameter (stall_known) has no start value: the reader refuses both together. A
    // value outside the start's feasible set is "not set" (CN1's 0: from the polar).
    for (const StallStart& start : stall_starts()) {
      if (stall_start_used(start, st) && start_in_bound(start, st.*start.value) && !stall_start_held(st, start.key))
        out += std::string(start.key) + " = " + format_double(st.*start.value) + "\n";
    }
    if (!st.known.empty()) {
      std::string list;
      for (const auto& [name, value] : st.known) list += (list.empty() ? "" : ", ") + name + " = " + format_double(value);
      out += "stall_known = { " + list + " }\n";
    }
  }
  return out;
}
}  // namespace indicial

