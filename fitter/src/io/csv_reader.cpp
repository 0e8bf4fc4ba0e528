// Run CSV and static-table reading. See indicial/fitter/csv_reader.hpp.
#include "indicial/fitter/csv_reader.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <set>
#include <string>
#include <utility>

#include "indicial/fitter/derivative.hpp"
#include "indicial/fitter/did_you_mean.hpp"
#include "indicial/fitter/error.hpp"
#include "indicial/fitter/experiment_checks.hpp"
#include "indicial/fitter/io.hpp"
#include "indicial/runtime.hpp"  // max_step_dt_s
#include "io/mat_file.hpp"

namespace indicial {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegToRad = kPi / 180.0;
// Relative tolerance of the uniform-step check (interface.md).
constexpr double kStepTolerance = 1e-6;

// Strips spaces and '\r' (and tabs unless they separate the fields) from both ends.
std::string trim(const std::string& s, char delimiter = ',') {
  auto blank = [delimiter](char c) { return c == ' ' || c == '\r' || (c == '\t' && delimiter != '\t'); };
  std::size_t b = 0, e = s.size();
  while (b < e && blank(s[b])) ++b;
  while (e > b && blank(s[e - 1])) --e;
  return s.substr(b, e - b);
}

// Splits a line at `delimiter` outside double quotes; a quoted field loses its quotes ("" in
// it is one quote), every field is trimmed. kWhitespace as the delimiter: fields are separated
// by runs of spaces and tabs (none empty).
constexpr char kWhitespace = ' ';
std::vector<std::string> split_fields(const std::string& line, char delimiter) {
  std::vector<std::string> out;
  std::string field;
  bool quoted = false, pending = false;  // pending: a whitespace field has started
  auto is_delimiter = [delimiter](char c) {
    return delimiter == kWhitespace ? c == ' ' || c == '\t' : c == delimiter;
  };
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (c == '"') {
      pending = true;
      if (quoted && i + 1 < line.size() && line[i + 1] == '"') {
        field += '"';
        ++i;
      } else {
        quoted = !quoted;
      }
    } else if (is_delimiter(c) && !quoted) {
      if (delimiter == kWhitespace && !pending) continue;  // a run of blanks is one delimiter
      out.push_back(trim(field, delimiter));
      field.clear();
      pending = false;
    } else {
      field += c;
      pending = true;
    }
  }
  if (delimiter != kWhitespace || pending) out.push_back(trim(field, delimiter));
  return out;
}

// The delimiter of a header line: the most frequent of tab, ';' and ',' outside quotes; with
// none of them, whitespace when the line has an inner blank, else ',' (a one-column file).
char detect_delimiter(const std::string& header) {
  int tabs = 0, semicolons = 0, commas = 0, blanks = 0;
  bool quoted = false;
  for (char c : header) {
    if (c == '"') quoted = !quoted;
    if (quoted) continue;
    tabs += c == '\t';
    semicolons += c == ';';
    commas += c == ',';
    blanks += c == ' ';
  }
  if (tabs > semicolons && tabs > commas) return '\t';
  if (semicolons > commas) return ';';
  if (commas == 0 && blanks > 0) return kWhitespace;
  return ',';
}

std::string delimiter_name(char d) {
  return d == '\t' ? "tab" : d == ';' ? "semicolon" : d == kWhitespace ? "whitespace" : "comma";
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
constexpr double kPhaseCyclesToRad = 2.0 * 3.14159265358979323846;  // phase_cycles: t / T
enum class Quantity { time, angle, phase, rate };
struct UnitChoice {
  const char* suffix;
  double to_si;  // factor to rad, rad/s or s
};
struct BaseName {
  const char* base;
  Quantity quantity;
};
constexpr std::array<BaseName, 10> kUnitBases = {{{"time", Quantity::time},
                                                  {"phase", Quantity::phase},
                                                  {"alpha", Quantity::angle},
                                                  {"beta", Quantity::angle},
                                                  {"phi", Quantity::angle},
                                                  {"psi", Quantity::angle},
                                                  {"theta", Quantity::angle},
                                                  {"q", Quantity::rate},
                                                  {"p", Quantity::rate},
                                                  {"r", Quantity::rate}}};

// Suffixes that name a unit of time, angle or angular rate. A column of one of our bases with
// such a suffix that is not one we read (alpha_grad, q_dps, time_ms) is refused: its unit
// must never be guessed. Any other suffix (q_pa, r_m, alpha_cmd_deg) is another quantity and
// the column is ignored with a note.
bool names_a_unit(std::string suffix) {
  static const std::set<std::string> units = {
      "s", "ms", "us", "ns", "sec", "secs", "second", "seconds", "min", "h", "hr",
      "deg", "degs", "degree", "degrees", "rad", "rads", "radian", "radians", "grad", "gon",
      "mrad", "urad", "arcmin", "arcsec", "rev", "revs", "turn", "turns", "cycle", "cycles",
      "degps", "radps", "dps", "rps", "rpm", "hz", "deg/s", "rad/s", "degpersec", "radpersec",
      "deg_s", "rad_s", "deg_per_s", "rad_per_s", "degsec", "radsec"};
  for (char& c : suffix) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return units.count(suffix) > 0;
}

std::vector<UnitChoice> units_of(Quantity q) {
  switch (q) {
    case Quantity::time: return {{"s", 1.0}};
    case Quantity::angle: return {{"deg", kDegToRad}, {"rad", 1.0}};
    // A cycle's phase also as the fraction of the cycle (t / T, 0 ... 1: digitized histories
    // are often plotted against it).
    case Quantity::phase: return {{"deg", kDegToRad}, {"rad", 1.0}, {"cycles", kPhaseCyclesToRad}};
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

const std::set<std::string>& coefficient_names() {
  static const std::set<std::string> names = {"CL", "Cm", "CD", "CY", "Cl", "Cn", "Cnormal", "Ctangential"};
  return names;
}

// What a header name is. unit: one of our bases with a unit we read (base and factor set);
// known: a name we write or recognise but the reader may not need (coefficients, Cm_true,
// y_true, Cm_pred); other: anything else (ignored with a note).
enum class ColumnKind { unit, known, other };
struct ParsedColumn {
  ColumnKind kind = ColumnKind::other;
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
      if (suffix == u.suffix) return {ColumnKind::unit, base, u.to_si};
    }
    if (names_a_unit(suffix)) {
      throw InputError(path, line, "column '" + name + "' has unknown unit suffix '_" + suffix +
                                       "' (use " + unit_hint(base, b.quantity) + ")");
    }
    return {};
  }
  if (coefficient_names().count(base) || base == "y") return {ColumnKind::known, "", 1.0};
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
  std::vector<std::string> header;    // after [columns] renaming
  std::vector<std::string> original;  // as in the file
  std::vector<char> negated;          // read with the sign flipped ([columns] ours = "-theirs")
  long header_line = 0;
  char delimiter = ',';
  std::vector<std::vector<std::string>> rows;
  std::vector<long> row_line;
  bool decimal_comma = false;         // a cell was read with ',' as its decimal separator
  bool header_from_comment = false;   // the header is the comment line before the data
  std::vector<std::string> units;     // a units row under the header (skipped), as in the file
  long units_line = 0;
  // A .mat run (mat_file.hpp): its variables are the columns, "lines" are sample numbers.
  std::vector<MatUnusable> unusable;  // variables that cannot be columns, and why
  std::vector<std::string> mat_notes;
};

// Why only with ';', tab or whitespace: in a comma-separated file a decimal comma would split the cell,
// so '0,25' there is never a number; with the other delimiters a cell with one ',' and no
// '.' is a decimal comma (the European spreadsheet default) and is read as such.
std::string decimal_point(const std::string& cell, char delimiter, bool& used_comma) {
  if (delimiter == ',' || cell.find('.') != std::string::npos) return cell;
  const std::size_t comma = cell.find(',');
  if (comma == std::string::npos || cell.find(',', comma + 1) != std::string::npos) return cell;
  used_comma = true;
  std::string out = cell;
  out[comma] = '.';
  return out;
}

char declared_delimiter(Delimiter d) {
  switch (d) {
    case Delimiter::comma: return ',';
    case Delimiter::semicolon: return ';';
    case Delimiter::tab: return '\t';
    case Delimiter::whitespace: return kWhitespace;
    case Delimiter::detect: break;
  }
  return 0;
}

// Whether every field of a line reads as a number: a data row, not a header.
bool all_numeric(const std::vector<std::string>& fields, char delimiter) {
  for (const auto& f : fields) {
    double v = 0.0;
    std::string problem;
    bool comma = false;
    if (!parse_number(decimal_point(f, delimiter, comma), v, problem)) return false;
  }
  return true;
}

// No field is a number (a units row under the header: "s,deg,-"), and one is not blank.
bool no_number(const std::vector<std::string>& fields, char delimiter) {
  bool text = false;
  for (const auto& f : fields) {
    double v = 0.0;
    std::string problem;
    bool comma = false;
    if (parse_number(decimal_point(f, delimiter, comma), v, problem)) return false;
    text = text || !trim(f, kWhitespace).empty();
  }
  return text;
}

// The header line's text and where it came from, until the first data row fixes the delimiter.
struct HeaderText {
  std::string text;
  long line = 0;
  bool from_comment = false;
};

// Fixes the delimiter from the header and the first data row (CsvDialect::delimiter) and
// splits the header.
void settle_header(const std::string& path, const HeaderText& h, const std::string& first_row,
                   const CsvDialect& dialect, CsvTable& t) {
  t.header_line = h.line;
  t.header_from_comment = h.from_comment;
  t.delimiter = declared_delimiter(dialect.delimiter);
  if (t.delimiter == 0) {
    t.delimiter = detect_delimiter(h.text);
    // Why: a header typed with spaces above tab-separated numbers (Octave's and many loggers'
    // text files) splits alike only on runs of blanks.
    if (!first_row.empty() &&
        split_fields(trim(h.text, t.delimiter), t.delimiter).size() !=
            split_fields(trim(first_row, t.delimiter), t.delimiter).size() &&
        split_fields(trim(h.text, kWhitespace), kWhitespace).size() ==
            split_fields(trim(first_row, kWhitespace), kWhitespace).size())
      t.delimiter = kWhitespace;
  }
  t.header = split_fields(trim(h.text, t.delimiter), t.delimiter);
  if (h.from_comment && !first_row.empty() &&
      t.header.size() != split_fields(trim(first_row, t.delimiter), t.delimiter).size()) {
    throw InputError(path, h.line + 0, "no header row: the first data row is numbers, and this comment line has " +
                                           std::to_string(t.header.size()) + " " + delimiter_name(t.delimiter) +
                                           "-separated fields, not the data's " +
                                           std::to_string(split_fields(trim(first_row, t.delimiter), t.delimiter).size()) +
                                           " (add a header row of column names)");
  }
}

// Reads the lines: BOM stripped, comments and blank lines skipped, fields split. See
// CsvDialect for the header found in a comment line.
CsvTable read_csv_lines(const std::string& path, const CsvDialect& dialect) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, 0, "cannot open file (does it exist?)");
  CsvTable t;
  std::string raw;
  long line_no = 0;
  bool any_byte = false;
  HeaderText last_comment, header;
  while (std::getline(in, raw)) {
    ++line_no;
    // Why: Excel's "CSV UTF-8" starts the file with a byte-order mark.
    if (line_no == 1 && raw.compare(0, 3, "\xEF\xBB\xBF") == 0) raw.erase(0, 3);
    any_byte = true;
    const std::string line = trim(raw, kWhitespace);
    // Why skip: '#' (and '%', the MATLAB/Octave comment) lines are comments by the contract;
    // blank lines carry no data.
    if (line.empty()) continue;
    if (dialect.comment_chars.find(line[0]) != std::string::npos) {
      if (header.line == 0) {
        const std::size_t text = line.find_first_not_of(dialect.comment_chars);
        last_comment = {text == std::string::npos ? std::string() : line.substr(text), line_no, true};
      }
      continue;
    }
    if (header.line == 0) {
      const char probe = declared_delimiter(dialect.delimiter) ? declared_delimiter(dialect.delimiter)
                                                                 : detect_delimiter(line);
      const bool numeric = all_numeric(split_fields(trim(raw, probe), probe), probe);
      if (!numeric) {
        header = {raw, line_no, false};
        continue;
      }
      if (last_comment.line == 0 || trim(last_comment.text, kWhitespace).empty())
        throw InputError(path, line_no, "no header row: the first row is numbers (add a header row of column names)");
      header = last_comment;
    }
    if (t.header.empty()) settle_header(path, header, raw, dialect, t);
    std::vector<std::string> fields = split_fields(trim(raw, t.delimiter), t.delimiter);
    // Why: tunnel exports put the units in a row under the names ("s,deg,-"); the units are in
    // our column names already (alpha_deg), so the row is skipped with a note (table_notes).
    if (t.rows.empty() && t.units_line == 0 && !header.from_comment && fields.size() == t.header.size() &&
        no_number(fields, t.delimiter)) {
      t.units = fields;
      t.units_line = line_no;
      continue;
    }
    if (fields.size() != t.header.size()) {
      throw InputError(path, line_no, "expected " + std::to_string(t.header.size()) + " " +
                                          delimiter_name(t.delimiter) +
                                          "-separated fields as in the header, found " +
                                          std::to_string(fields.size()));
    }
    t.rows.push_back(std::move(fields));
    t.row_line.push_back(line_no);
  }
  if (in.bad()) throw InputError(path, 0, "read failed");
  if (!any_byte) throw InputError(path, 0, "file is empty");
  if (header.line == 0) throw InputError(path, line_no, "no header row (only comments or blank lines)");
  if (t.header.empty()) settle_header(path, header, "", dialect, t);
  return t;
}

// A .mat run as a table: a column per usable variable, its values printed exactly
// (format_double reads back bit for bit), so that every CSV rule applies unchanged; the
// "line" of a row is its sample number (1-based), the header has none.
CsvTable read_mat_table(const std::string& path) {
  MatColumns m = read_mat_columns(path);
  CsvTable t;
  for (const MatColumn& c : m.columns) t.header.push_back(c.name);
  const std::size_t n = m.columns.front().values.size();
  t.rows.assign(n, std::vector<std::string>(m.columns.size()));
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t c = 0; c < m.columns.size(); ++c) t.rows[i][c] = format_double(m.columns[c].values[i]);
    t.row_line.push_back(static_cast<long>(i + 1));
  }
  t.unusable = std::move(m.unusable);
  t.mat_notes = std::move(m.notes);
  return t;
}

// A .mat variable that cannot be a column but is named like one this reader uses (any
// unit-bearing or coefficient name, or `wanted`) is refused with its reason; the others are
// ignored, with a note.
void refuse_unusable(const std::string& path, const CsvTable& t, const std::string& wanted) {
  for (const MatUnusable& u : t.unusable) {
    if (u.name == wanted || parse_column_name(path, 0, u.name).kind != ColumnKind::other)
      throw InputError(path, 0, u.reason + " (a column must be a real numeric vector as long as the time column)");
  }
}

// Reads a CSV (or a .mat) and renames the columns `columns` maps (our name -> the file's name).
CsvTable read_csv_table(const std::string& path, const ColumnMap& columns, const CsvDialect& dialect) {
  CsvTable t = is_mat_file(path) ? read_mat_table(path) : read_csv_lines(path, dialect);
  t.original = t.header;
  t.negated.assign(t.header.size(), 0);
  for (const auto& [ours, theirs] : columns) {
    // "-X" maps the file's X with its sign flipped (a chord force positive aft, a moment of the
    // other sign convention), unless the file has a column literally named "-X".
    const bool flip = theirs.size() > 1 && theirs[0] == '-' &&
                      std::find(t.header.begin(), t.header.end(), theirs) == t.header.end();
    const std::string file_name = flip ? theirs.substr(1) : theirs;
    for (std::size_t c = 0; c < t.header.size(); ++c)
      if (t.header[c] == file_name) t.header[c] = ours, t.negated[c] = flip;
  }
  std::set<std::string> seen;
  for (const auto& name : t.header) {
    if (!seen.insert(name).second) {
      throw InputError(path, t.header_line, "duplicate column '" + name + "'");
    }
  }
  if (t.rows.empty()) throw InputError(path, t.header_line, "header only: no data rows");
  return t;
}

// Whether column `col` reads as one cycle's phase in rad: every row a number, non-decreasing,
// from [0, 0.2] to [6.0, 2 pi + 0.05] (the Glasgow database's "Time()" column is such a phase:
// a name nearest "time_s" must not send that file to a time column).
bool looks_like_phase_rad(const CsvTable& t, std::size_t col) {
  double previous = -1.0, first = 0.0;
  bool comma = t.decimal_comma;
  std::string problem;
  for (std::size_t r = 0; r < t.rows.size(); ++r) {
    double v = 0.0;
    if (col >= t.rows[r].size() || !parse_number(decimal_point(t.rows[r][col], t.delimiter, comma), v, problem) ||
        v < previous)
      return false;
    if (r == 0) first = v;
    previous = v;
  }
  return !t.rows.empty() && first >= 0.0 && first <= 0.2 && previous >= 6.0 && previous <= 2.0 * kPi + 0.05;
}

// "missing column 'Cm' (columns found: time_s, alpha_deg, cm; did you mean 'cm'? ...)".
[[noreturn]] void missing_column(const std::string& path, const CsvTable& t, const std::string& what,
                                 const std::vector<std::string>& wanted, const ColumnMap& columns) {
  std::string found, nearest, nearest_wanted;
  std::size_t best = 3, nearest_col = 0;  // suggest only within 2 edits (case does not count)
  for (std::size_t c = 0; c < t.original.size(); ++c) {
    const std::string& name = t.original[c];
    found += (found.empty() ? "" : ", ") + name;
    for (const auto& w : wanted) {
      const std::size_t d = edit_distance(name, w, LetterCase::ignored);
      if (d < best && d < w.size()) {
        best = d;
        nearest = name;
        nearest_wanted = w;
        nearest_col = c;
      }
    }
  }
  // A time-like name whose values are one cycle's phase in rad is mapped as the phase.
  const bool wants_phase = std::find(wanted.begin(), wanted.end(), "phase_rad") != wanted.end();
  const bool phase_values = wants_phase && !nearest.empty() && looks_like_phase_rad(t, nearest_col);
  if (phase_values) nearest_wanted = "phase_rad";
  std::string msg = "missing column " + what + " (columns found: " + found + ")";
  for (const auto& w : wanted) {
    const auto m = columns.find(w);
    if (m != columns.end()) msg += "; [columns] maps " + w + " to '" + m->second + "', not in this file";
  }
  // A header read as one column that another delimiter would split: the [csv] delimiter (one
  // for every run and the static table) does not fit this file.
  if (t.original.size() == 1) {
    const char d = detect_delimiter(t.original.front());
    if (d != t.delimiter && split_fields(t.original.front(), d).size() > 1)
      msg += "; the header is one column when read with the " + delimiter_name(t.delimiter) +
             " delimiter but splits at " + delimiter_name(d) + ": [csv] delimiter applies to every run and the "
             "static table, so write this file with the same delimiter (or [csv] delimiter = \"detect\")";
  }
  if (phase_values) {
    msg += "; '" + nearest + "' runs from 0 to 2 pi: if it is the cycle's phase in rad, map it in the experiment: "
           "[columns] phase_rad = \"" + nearest + "\" (indicial predict reads [columns] with --experiment FILE; "
           "a phase cycle also needs its frequency: the runs entry's frequency_hz, or predict's --frequency-hz)";
  } else if (!nearest.empty()) {
    msg += "; did you mean '" + nearest + "'? (rename it, or map it in the experiment: [columns] " +
           nearest_wanted + " = \"" + nearest + "\")";
  }
  throw InputError(path, t.header_line, msg);
}

// Index of the column of `base` with a unit (e.g. alpha_deg or alpha_rad); -1 when absent.
int find_unit_column(const std::string& path, const CsvTable& t, const std::string& base,
                     double& to_si) {
  int found = -1;
  for (std::size_t c = 0; c < t.header.size(); ++c) {
    const ParsedColumn pc = parse_column_name(path, t.header_line, t.header[c]);
    if (pc.kind != ColumnKind::unit || pc.base != base) continue;
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

std::vector<double> numeric_column(const std::string& path, CsvTable& t, int col, double factor) {
  std::vector<double> out(t.rows.size());
  const auto c = static_cast<std::size_t>(col);
  for (std::size_t r = 0; r < t.rows.size(); ++r) {
    double v = 0.0;
    std::string problem;
    if (!parse_number(decimal_point(t.rows[r][c], t.delimiter, t.decimal_comma), v, problem)) {
      // The file's name first (what the user sees in the file), ours when mapped.
      throw InputError(path, t.row_line[r], "column '" + t.original[c] + "'" +
                                                (t.original[c] != t.header[c] ? " (read as " + t.header[c] + ")" : "") +
                                                ": " + problem);
    }
    out[r] = c < t.negated.size() && t.negated[c] ? -(v * factor) : v * factor;
  }
  return out;
}

// One-line notes on what the reader did beyond the canonical format: ignored columns, the
// delimiter, decimal commas.
std::vector<std::string> table_notes(const std::string& path, const CsvTable& t,
                                     const std::vector<int>& used) {
  std::vector<std::string> notes;
  std::string ignored;
  for (std::size_t c = 0; c < t.header.size(); ++c) {
    if (std::find(used.begin(), used.end(), static_cast<int>(c)) != used.end()) continue;
    if (parse_column_name(path, t.header_line, t.header[c]).kind != ColumnKind::other) continue;
    ignored += (ignored.empty() ? "'" : ", '") + t.original[c] + "'";
  }
  for (const MatUnusable& u : t.unusable) ignored += (ignored.empty() ? "'" : ", '") + u.name + "'";
  if (!ignored.empty()) notes.push_back(path + ": ignored column(s) " + ignored + " (not a column indicial reads)");
  for (std::size_t c = 0; c < t.negated.size(); ++c)
    if (t.negated[c] && std::find(used.begin(), used.end(), static_cast<int>(c)) != used.end())
      notes.push_back(path + ": column '" + t.original[c] + "' read with its sign flipped as " + t.header[c] +
                      " ([columns] " + t.header[c] + " = \"-" + t.original[c] + "\")");
  if (t.header_from_comment) {
    notes.push_back(path + ":" + std::to_string(t.header_line) + ": the column names are read from this comment "
                    "line (the first row below it is numbers)");
  }
  for (const std::string& n : t.mat_notes) notes.push_back(path + ": " + n);
  if (t.units_line > 0) {
    std::string units;
    for (const std::string& u : t.units) units += (units.empty() ? "" : ", ") + u;
    notes.push_back(path + ":" + std::to_string(t.units_line) + ": read as a units row (" + units +
                    ") and skipped: the units are those of the column names (alpha_deg, q_degps, ...)");
  }
  if (t.delimiter != ',' || t.decimal_comma) {
    notes.push_back(path + ": read as " + delimiter_name(t.delimiter) + "-separated" +
                    (t.decimal_comma ? ", with ',' as the decimal separator" : ""));
  }
  return notes;
}

}  // namespace

// ==========================================================================================
// Run CSV
// ==========================================================================================
namespace {

// How a number was printed: decimals after the point (exponent included: "1.5e-3" has 4)
// and significant digits ("0.050" has 2).
struct PrintedDigits {
  int decimals = 0;
  int significant = 0;
};
PrintedDigits printed_digits(const std::string& cell) {
  std::size_t mantissa_end = cell.find_first_of("eE");
  int exponent = 0;
  if (mantissa_end != std::string::npos) exponent = std::atoi(cell.c_str() + mantissa_end + 1);
  else mantissa_end = cell.size();
  PrintedDigits d;
  bool after_point = false, leading = true;
  for (std::size_t i = 0; i < mantissa_end; ++i) {
    const char ch = cell[i];
    if (ch == '.' || ch == ',') after_point = true;
    if (ch < '0' || ch > '9') continue;
    if (after_point) ++d.decimals;
    if (ch != '0') leading = false;
    if (!leading) ++d.significant;
  }
  d.decimals -= exponent;
  return d;
}

// The rounding each printed value of a column may carry: half a unit of its last digit, with
// the column's printing read from its text. Fixed decimals when most cells have the most
// decimals of any cell ("%.2f", or round(x, 2), which drops a trailing zero in a tenth of the
// cells); significant digits when most nonzero cells have the most significant digits of any
// cell ("%.9g"); both: the looser for each value; neither (a shortest-round-trip writer,
// whose 0.09 is "0.09" and 0.06 is "0.060000000000000005"): 0, so only the 1e-6 relative
// check applies. Why per column: one cell alone cannot tell "0.09" printed to two decimals
// from 0.09 printed exactly.
std::vector<double> print_tolerances(const std::vector<std::string>& cells, const std::vector<double>& values) {
  std::vector<PrintedDigits> digits(cells.size());
  int decimals = -400, significant = 0;
  for (std::size_t i = 0; i < cells.size(); ++i) {
    digits[i] = printed_digits(cells[i]);
    decimals = std::max(decimals, digits[i].decimals);
    significant = std::max(significant, digits[i].significant);
  }
  std::size_t at_decimals = 0, at_significant = 0, nonzero = 0;
  for (std::size_t i = 0; i < cells.size(); ++i) {
    at_decimals += digits[i].decimals == decimals;
    nonzero += values[i] != 0.0;
    at_significant += values[i] != 0.0 && digits[i].significant == significant;
  }
  const bool fixed_mode = 2 * at_decimals > cells.size();
  const bool significant_mode = 2 * at_significant > nonzero;
  std::vector<double> tol(cells.size(), 0.0);
  for (std::size_t i = 0; i < cells.size(); ++i) {
    const double v = std::abs(values[i]);
    if (fixed_mode) tol[i] = 0.5 * std::pow(10.0, -decimals);
    if (significant_mode && v > 0.0)
      tol[i] = std::max(tol[i], 0.5 * std::pow(10.0, std::floor(std::log10(v)) - (significant - 1)));
  }
  return tol;
}

// Whether every |values[k] - (a + b k)| <= tol[k].
bool on_grid(const std::vector<double>& values, const std::vector<double>& tol, double a, double b) {
  for (std::size_t k = 0; k < values.size(); ++k)
    if (std::abs(values[k] - (a + b * static_cast<double>(k))) > tol[k] * (1.0 + 1e-9)) return false;
  return true;
}

// A uniform grid a + b k within every sample's tolerance, trying in turn: `preferred` (a phase
// cycle's own grid: one cycle over its samples, offset to fit every value), the least-squares line
// (closest to the truth when the rounding errors average out), and the line that minimises the
// largest deviation relative to the tolerances. Why the last: the least-squares line can leave
// a rounded end sample just outside its half unit although a grid within all of them exists;
// the feasible set of (a, b) is convex, and for a given b the best a is the middle of an
// interval, so a golden-section search over b decides it.
bool fit_uniform_grid(const std::vector<double>& values, const std::vector<double>& tol,
                      const double* preferred_step, double& a, double& b) {
  const std::size_t n = values.size();
  // The offset a that every value admits with slope `slope`: [lo, hi] (feasible when lo <= hi).
  auto spread = [&](double slope, double& mid) {
    double lo = -HUGE_VAL, hi = HUGE_VAL;  // a must lie in [lo, hi]
    for (std::size_t k = 0; k < n; ++k) {
      lo = std::max(lo, values[k] - tol[k] - slope * static_cast<double>(k));
      hi = std::min(hi, values[k] + tol[k] - slope * static_cast<double>(k));
    }
    mid = 0.5 * (lo + hi);
    return lo - hi;  // <= 0: feasible
  };
  if (preferred_step) {
    // From the first value (a phase cycle starting at 0), else offset to fit every value. Why
    // the second: a first value printed half a unit off (1.40625 deg as 1.4062) put every value
    // that rounded the other way a whole unit from the first grid, and the same file read as
    // uniform or not with the frequency (a user's trial).
    b = *preferred_step;
    if (on_grid(values, tol, values.front(), b)) {
      a = values.front();
      return true;
    }
    double mid = 0.0;  // spread's
    if (spread(b, mid) <= 0.0 && on_grid(values, tol, mid, b)) {
      a = mid;
      return true;
    }
  }
  // Weighted by 1 / tol^2: a value printed to more digits says more about the grid.
  double floor_tol = HUGE_VAL;
  for (double t : tol)
    if (t > 0.0) floor_tol = std::min(floor_tol, t);
  if (floor_tol == HUGE_VAL) return false;
  double sw = 0, sk = 0, sv = 0, skk = 0, skv = 0;
  for (std::size_t k = 0; k < n; ++k) {
    const double kd = static_cast<double>(k), w = 1.0 / std::pow(std::max(tol[k], floor_tol) / floor_tol, 2);
    sw += w, sk += w * kd, sv += w * values[k], skk += w * kd * kd, skv += w * kd * values[k];
  }
  b = (sw * skv - sk * sv) / (sw * skk - sk * sk);
  a = (sv - b * sk) / sw;
  if (on_grid(values, tol, a, b)) return true;
  const double step = (values.back() - values.front()) / static_cast<double>(n - 1);
  double x0 = step * 0.99, x1 = step * 1.01, mid = 0.0;
  const double g = 0.5 * (std::sqrt(5.0) - 1.0);
  for (int it = 0; it < 200; ++it) {
    const double c = x1 - g * (x1 - x0), d = x0 + g * (x1 - x0);
    if (spread(c, mid) < spread(d, mid)) x1 = d;
    else x0 = c;
  }
  b = 0.5 * (x0 + x1);
  spread(b, a);
  return on_grid(values, tol, a, b);
}

// ---- lift and drag from normal and chord force ---------------------------------------
// Our names for a file's body-axis force coefficients ([columns] Cnormal = "Cn", Ctangential =
// "Ct"): the normal force, and the chord (tangential) force positive toward the leading edge.
// Why not `Cn`: indicial's Cn is the yawing moment (interface.md), and a pitching-airfoil
// database's `Cn` is the normal force; the map makes the meaning explicit.
constexpr const char* kNormalForce = "Cnormal";
constexpr const char* kChordForce = "Ctangential";

// The file's own `Cn` column (not named in [columns]) beside a chord-force column: every
// airfoil database we know means the normal force by it.
bool cn_beside_chord_force(const CsvTable& t, const ColumnMap& columns) {
  if (columns.count("Cn") || find_plain_column(t, "Cn") < 0) return false;
  for (const char* chord : {"Ct", "CT", "Cc", "CC", "Cchord", kChordForce})
    if (find_plain_column(t, chord) >= 0) return true;
  return false;
}

std::string body_axes_advice() {
  return std::string("map it: [columns] ") + kNormalForce + " = \"Cn\" and " + kChordForce +
         " = \"Ct\" (the chord force, positive toward the leading edge), and CL and CD are derived as "
         "CL = Cn cos(alpha) + Ct sin(alpha), CD = Cn sin(alpha) - Ct cos(alpha)";
}

// Refuses reading `Cn` as the yawing moment from a file whose Cn looks like the normal force,
// unless the experiment declares it ([columns] Cn = "Cn").
void check_cn_meaning(const std::string& path, const CsvTable& t, const std::string& coefficient,
                      const ColumnMap& columns) {
  if (coefficient != "Cn" || !cn_beside_chord_force(t, columns)) return;
  throw InputError(path, t.header_line,
                   "column 'Cn' beside a chord-force column looks like the normal-force coefficient, but "
                   "indicial's Cn is the yawing moment: if it is the normal force, " + body_axes_advice() +
                   "; if it is the yawing moment, say so: [columns] Cn = \"Cn\"");
}

// With `coefficient` CL or CD absent: finds Cnormal and Ctangential to derive it from (true),
// refuses half a pair or a non-pitch run, and explains an unmapped Cn/Ct pair.
bool locate_body_axes(const std::string& path, const CsvTable& t, Axis axis, const std::string& coefficient,
                      const ColumnMap& columns, int& normal, int& chord) {
  if (coefficient != "CL" && coefficient != "CD") return false;
  normal = find_plain_column(t, kNormalForce);
  chord = find_plain_column(t, kChordForce);
  if (normal < 0 && chord < 0) {
    // The usual spellings of a normal / chord-force pair (a trial's `CN` and `CC` drew the
    // advice `[columns] CL = "CN"`, the normal force read as lift).
    int n = -1, ch = -1;
    for (const char* name : {"Cn", "CN", "C_N", "C_n"})
      if (n < 0) n = find_plain_column(t, name);
    for (const char* name : {"Ct", "CT", "Cc", "CC", "C_T", "C_C", "C_t", "C_c"})
      if (ch < 0) ch = find_plain_column(t, name);
    if (n >= 0 && ch >= 0) {
      const std::string nn = t.original[static_cast<std::size_t>(n)], cn = t.original[static_cast<std::size_t>(ch)];
      throw InputError(path, t.header_line,
                       "missing column '" + coefficient + "'; this file's '" + nn + "' and '" + cn + "' look like "
                       "the normal- and chord-force coefficients: map them: [columns] " + kNormalForce + " = \"" + nn +
                       "\" and " + kChordForce + " = \"" + cn + "\" (the chord force positive toward the leading edge; "
                       "a chord force positive aft is mapped with a minus: " + kChordForce + " = \"-" + cn + "\"), and "
                       "CL and CD are derived as CL = Cn cos(alpha) + Ct sin(alpha), CD = Cn sin(alpha) - Ct cos(alpha)");
    }
    return false;
  }
  if (normal < 0 || chord < 0) {
    // The half that is missing was often mapped to a column of another spelling (a trial's
    // [columns] Ctangential = "-Cc" on a file with "CC"): name that mapping and the columns.
    const std::string absent = normal < 0 ? kNormalForce : kChordForce;
    std::string why;
    if (const auto m = columns.find(absent); m != columns.end()) {
      std::string found;
      for (const auto& name : t.original) found += (found.empty() ? "" : ", ") + name;
      why = "; [columns] maps " + absent + " to '" + m->second + "', not in this file (columns found: " + found + ")";
    }
    throw InputError(path, t.header_line, coefficient + " from body-axis forces needs both '" + kNormalForce +
                                              "' and '" + kChordForce + "'; only '" +
                                              (normal < 0 ? kChordForce : kNormalForce) + "' is here" + why);
  }
  if (axis != Axis::pitch)
    throw InputError(path, t.header_line, coefficient + " from '" + kNormalForce + "' and '" + kChordForce +
                                              "' needs the angle of attack of a pitch run; this is a " +
                                              axis_name(axis) + " run");
  return true;
}

// CL = Cn cos(alpha) + Ct sin(alpha) or CD = Cn sin(alpha) - Ct cos(alpha).
std::vector<double> lift_or_drag(const std::string& coefficient, const std::vector<double>& normal,
                                 const std::vector<double>& chord, const std::vector<double>& alpha_rad) {
  std::vector<double> out(alpha_rad.size());
  for (std::size_t i = 0; i < out.size(); ++i) {
    const double c = std::cos(alpha_rad[i]), s = std::sin(alpha_rad[i]);
    out[i] = coefficient == "CL" ? normal[i] * c + chord[i] * s : normal[i] * s - chord[i] * c;
  }
  return out;
}

std::string derived_note(const std::string& path, const CsvTable& t, const std::string& coefficient,
                         int normal, int chord) {
  return path + ": " + coefficient + " derived from '" + t.original[static_cast<std::size_t>(normal)] + "' (" +
         kNormalForce + ") and '" + t.original[static_cast<std::size_t>(chord)] + "' (" + kChordForce + "): " +
         (coefficient == "CL" ? "CL = Cnormal cos(alpha) + Ctangential sin(alpha)"
                              : "CD = Cnormal sin(alpha) - Ctangential cos(alpha)");
}

// The columns a run uses.
struct RunColumns {
  int time = -1, phase = -1, angle = -1, rate = -1, coefficient = -1;
  int normal = -1, chord = -1;  // Cnormal and Ctangential, when the coefficient is derived from them
  double time_factor = 1.0, phase_factor = 1.0, angle_factor = 1.0, rate_factor = 1.0;
};

RunColumns locate_run_columns(const std::string& path, const CsvTable& t, Axis axis,
                              const std::string& coefficient, CoefficientPresence presence,
                              const ColumnMap& columns) {
  RunColumns rc;
  // Validate every unit-bearing column name first, so a bad name is reported even if it is
  // not one this axis needs.
  for (const auto& name : t.header) (void)parse_column_name(path, t.header_line, name);
  refuse_unusable(path, t, coefficient);
  rc.time = find_unit_column(path, t, "time", rc.time_factor);
  rc.phase = find_unit_column(path, t, "phase", rc.phase_factor);
  if (rc.time >= 0 && rc.phase >= 0) {
    throw InputError(path, t.header_line, "both '" + t.header[static_cast<std::size_t>(rc.time)] + "' and '" +
                                              t.header[static_cast<std::size_t>(rc.phase)] +
                                              "' given; keep one (a phase column replaces time)");
  }
  if (rc.time < 0 && rc.phase < 0)
    missing_column(path, t, "'time_s' (or 'phase_rad' / 'phase_deg' / 'phase_cycles')",
                   {"time_s", "phase_rad", "phase_deg", "phase_cycles"}, columns);
  const std::string mb = motion_base(axis);
  rc.angle = find_unit_column(path, t, mb, rc.angle_factor);
  if (rc.angle < 0) {
    missing_column(path, t, "'" + mb + "_deg' or '" + mb + "_rad' (the " + axis_name(axis) + " motion angle)",
                   {mb + "_deg", mb + "_rad"}, columns);
  }
  rc.rate = find_unit_column(path, t, rate_base(axis), rc.rate_factor);
  rc.coefficient = find_plain_column(t, coefficient);
  check_cn_meaning(path, t, coefficient, columns);
  if (rc.coefficient < 0 && locate_body_axes(path, t, axis, coefficient, columns, rc.normal, rc.chord)) return rc;
  if (rc.coefficient < 0 && presence == CoefficientPresence::required)
    missing_column(path, t, "'" + coefficient + "'", {coefficient}, columns);
  return rc;
}

// Run::time_s from the time column, or from the phase column and the cycle's frequency;
// returns the per-sample print tolerance in s (the checks come after every column is parsed).
std::vector<double> read_time(const std::string& path, CsvTable& t, const RunColumns& rc,
                              const RunCsvOptions& options, Run& run) {
  const double frequency_hz = options.frequency_hz;
  const bool phase = rc.phase >= 0;
  const int col = phase ? rc.phase : rc.time;
  const auto c = static_cast<std::size_t>(col);
  const std::string& name = t.header[c];
  run.time_source = phase ? TimeSource::phase_column : TimeSource::time_column;
  double factor = rc.time_factor;
  if (phase) {
    if (options.frequency_source == FrequencySource::none) {
      throw InputError(path, t.header_line, "column '" + name + "' makes the file one periodic cycle, which "
                                            "'simulate --motion csv:' cannot take (it starts at rest and runs the "
                                            "file's times once): give a time_s column, or predict the cycle's "
                                            "periodic steady state with 'indicial predict MODEL FILE "
                                            "--reduced-frequency K'");
    }
    if (!(frequency_hz > 0.0)) {
      throw InputError(path, t.header_line, "column '" + name + "' needs the cycle's frequency: give " +
                                                std::string(options.frequency_source == FrequencySource::command_line
                                                                ? "--frequency-hz or --reduced-frequency"
                                                                : "frequency_hz or reduced_frequency in the "
                                                                  "experiment's runs entry"));
    }
    run.periodic = true;
    run.frequency_hz = frequency_hz;
    factor = rc.phase_factor / (2.0 * kPi * frequency_hz);
  }
  run.time_s = numeric_column(path, t, col, factor);
  std::vector<std::string> cells(run.time_s.size());
  for (std::size_t i = 0; i < cells.size(); ++i) cells[i] = t.rows[i][c];
  const std::vector<double> raw = numeric_column(path, t, col, 1.0);
  std::vector<double> tol = print_tolerances(cells, raw);
  // Plus the rounding of the conversion to seconds (a few ulps of the time): a value printed
  // at an exact half unit (1.40625 deg as 1.4062) sits exactly on its tolerance, and whether the
  // scaled comparison held depended on the frequency (a trial: uniform at 3.72 Hz, not at
  // 1.34 Hz, for one file).
  for (std::size_t i = 0; i < tol.size(); ++i)
    tol[i] = tol[i] * std::abs(factor) + 8.0 * std::numeric_limits<double>::epsilon() * std::abs(run.time_s[i]);
  return tol;
}

// A phase column's unit and its cycle's end, for messages ("rad", "2 pi"; "deg", "360";
// "cycles", "1"), from the column's factor to rad.
const char* phase_unit(double phase_factor) {
  return phase_factor == 1.0 ? "rad" : (phase_factor == kPhaseCyclesToRad ? "cycles" : "deg");
}
const char* phase_cycle_end(double phase_factor) {
  return phase_factor == 1.0 ? "2 pi" : (phase_factor == kPhaseCyclesToRad ? "1" : "360");
}

// What a phase outside [0, 2 pi) most likely is (phase in rad, the column's factor to rad, the
// column's largest phase in rad): the cycle's end point repeating its start (360 deg, 2 pi), a
// cycle in [-pi, pi), or another unit than the name's, judged by the column's largest value
// (every row, not the first out of range: radians under phase_cycles exceed 1 from the second
// row on); "" otherwise.
std::string degrees_hint(double phase_factor, double phase, double largest_phase_rad) {
  if (std::abs(phase - 2.0 * kPi) <= 1e-9 * 2.0 * kPi)
    return " (the cycle's end point repeats its start: drop that row)";
  if (phase < 0.0 && phase >= -kPi) return " (a cycle in [-pi, pi) or [-180, 180): add a full cycle to the negative phases)";
  const double largest_in_unit = largest_phase_rad / phase_factor;  // as written in the column
  if (phase_factor == 1.0 && largest_in_unit < 360.0)
    return " (it looks like degrees in a radian column: name it phase_deg if so)";
  if (phase_factor == kPhaseCyclesToRad && largest_in_unit < 2.0 * kPi)
    return " (its values never reach 2 pi: they look like radians in a column of cycles; name it phase_rad if so)";
  if (phase_factor == kPhaseCyclesToRad && largest_in_unit < 360.0)
    return " (it looks like degrees in a column of cycles: name it phase_deg if so)";
  return "";
}

// v printed with a printf format (the fuzz targets link this file without fmt).
std::string printed(double v, const char* format) {
  char buf[64];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}

// A phase in [0, 2 pi) (or [0, 360)); strictly increasing time.
void check_time_order(const std::string& path, const CsvTable& t, const RunColumns& rc, const Run& run) {
  const bool phase = rc.phase >= 0;
  const auto c = static_cast<std::size_t>(phase ? rc.phase : rc.time);
  const std::string& name = t.header[c];
  double largest_phase_rad = 0.0;
  for (double t_s : run.time_s) largest_phase_rad = std::max(largest_phase_rad, t_s * 2.0 * kPi * run.frequency_hz);
  for (std::size_t i = 0; i < run.time_s.size(); ++i) {
    const double phase_rad = run.time_s[i] * 2.0 * kPi * run.frequency_hz;
    if (phase && !(phase_rad >= 0.0 && phase_rad < 2.0 * kPi * (1.0 - 1e-15))) {
      throw InputError(path, t.row_line[i], "column '" + name + "': phase " + t.rows[i][c] + " is outside [0, " +
                                                phase_cycle_end(rc.phase_factor) + ")" +
                                                degrees_hint(rc.phase_factor, phase_rad, largest_phase_rad));
    }
    if (i > 0 && !(run.time_s[i] > run.time_s[i - 1])) {
      throw InputError(path, t.row_line[i],
                       std::string(run.time_s[i] == run.time_s[i - 1] ? "duplicate time: " : "") + name +
                           " is not strictly increasing (" + t.rows[i][c] + " after " + t.rows[i - 1][c] + ")" +
                           (run.time_s[i] == run.time_s[i - 1] && t.original[c] != name
                                ? " (read from the file's column '" + t.original[c] + "')"
                                : ""));
    }
    // Why refused here: the runtime steps at most max_step_dt_s, so a model fitted to such a
    // run could be neither replayed by fit nor predicted (a user's trial: a `t [ms]` column
    // mapped to time_s fitted, exit 0, and predict refused every step).
    if (!phase && i > 0 && run.time_s[i] - run.time_s[i - 1] > max_step_dt_s)
      throw InputError(path, t.row_line[i],
                       "column '" + t.original[c] + "' (read as " + name + ", seconds): a time step of " +
                           printed(run.time_s[i] - run.time_s[i - 1], "%.6g") + " s (" + t.rows[i][c] + " after " +
                           t.rows[i - 1][c] + ") is longer than the runtime's largest step (" +
                           printed(max_step_dt_s, "%g") + " s): is the column in seconds?");
  }
}

// Decides the run's grid (see csv_reader.hpp) and snaps a printed-uniform grid.
void check_time_grid(const std::string& path, const CsvTable& t, const RunColumns& rc,
                     std::optional<TimeGrid> given, const std::vector<double>& tol, Run& run) {
  const TimeGrid declared = given.value_or(TimeGrid::uniform);
  const std::size_t n = run.time_s.size();
  const auto c = static_cast<std::size_t>(rc.phase >= 0 ? rc.phase : rc.time);
  std::vector<double> steps(n - 1);
  for (std::size_t i = 1; i < n; ++i) steps[i - 1] = run.time_s[i] - run.time_s[i - 1];
  // Why the median: one bad step must be reported at its own line, not shift a mean step so
  // that every line looks wrong.
  const double dt = median_of(steps);
  // The step to report: the first whose deviation neither 1e-6 relative nor the printing of
  // its two samples explains (a moved or dropped sample), else the largest one.
  std::size_t bad = 0, largest = 0;
  for (std::size_t i = 1; i < n; ++i) {
    const double dev = std::abs(steps[i - 1] - dt);
    if (dev <= kStepTolerance * dt) continue;
    if (largest == 0 || dev > std::abs(steps[largest - 1] - dt)) largest = i;
    if (bad == 0 && dev > tol[i] + tol[i - 1]) bad = i;
  }
  if (bad == 0) bad = largest;
  run.time_grid = declared;
  if (bad == 0 || declared == TimeGrid::nonuniform) return;
  // A duration in the column's own unit: a phase column's in rad or deg, with seconds beside.
  // Six significant digits: these are differences of printed values (0.30000000000000016 deg
  // is 0.3 deg to anyone reading the message).
  const auto in_column = [&](double seconds) {
    if (rc.phase < 0) return printed(seconds, "%.6g") + " s";
    const double per_s = 2.0 * kPi * run.frequency_hz / rc.phase_factor;
    return printed(seconds * per_s, "%.6g") + " " + phase_unit(rc.phase_factor) + " (" +
           printed(seconds, "%.6g") + " s)";
  };
  double a = 0.0, b = 0.0;
  // A phase cycle of n samples: one cycle over n steps, 1 / (n f) s each.
  const double cycle_step = rc.phase >= 0 ? 1.0 / (static_cast<double>(n) * run.frequency_hz) : 0.0;
  if (fit_uniform_grid(run.time_s, tol, rc.phase >= 0 ? &cycle_step : nullptr, a, b)) {
    double worst = 0.0;
    for (std::size_t k = 0; k < n; ++k) {
      const double snapped = a + b * static_cast<double>(k);
      worst = std::max(worst, std::abs(run.time_s[k] - snapped));
      run.time_s[k] = snapped;
    }
    run.notes.push_back(path + ": '" + t.header[c] + "' is uniform to its printed digits (max deviation " +
                        in_column(worst) + "): snapped to a step of " + in_column(b));
    return;
  }
  if (rc.phase >= 0 && !given) {
    run.time_grid = TimeGrid::nonuniform;
    run.notes.push_back(path + ": '" + t.header[c] + "' is not uniform even to its printed digits (step " +
                        in_column(steps[bad - 1]) + " after " + t.rows[bad - 1][c] + ", median " +
                        in_column(dt) + "): read as a nonuniform cycle, each sample at its own phase");
    return;
  }
  if (rc.phase >= 0) {
    throw InputError(path, t.row_line[bad],
                     "'" + t.header[c] + "' is not uniform even to its printed digits (step " +
                         in_column(steps[bad - 1]) + " after " + t.rows[bad - 1][c] + ", median " +
                         in_column(dt) + ") but a uniform grid was declared: declare time_grid = "
                         "\"nonuniform\" (predict: --time-grid nonuniform), or leave the grid undeclared, "
                         "to read it as a nonuniform cycle");
  }
  throw InputError(path, t.row_line[bad],
                   "non-uniform time step: " + printed(steps[bad - 1], "%.6g") + " s after " + t.rows[bad - 1][c] +
                       ", the run's step is " + printed(dt, "%.6g") +
                       " s (allowed deviation 1e-6 relative or the printed digits; declare "
                       "time_grid = \"nonuniform\" in the run's entry if the log is not uniform)");
}

// Why these limits: a motion whose largest |angle| is under 2.5 "deg" while it moves is almost
// certainly radians (2.5 rad = 143 deg, 2.5 deg is a tiny motion for a tunnel run); an angle
// beyond 2 pi "rad" is almost certainly degrees.
void warn_angle_unit(const std::string& path, const std::string& column, double factor,
                     const std::vector<double>& angle_rad, std::vector<std::string>* warnings) {
  const auto [lo, hi] = std::minmax_element(angle_rad.begin(), angle_rad.end());
  const double largest = std::max(std::abs(*lo), std::abs(*hi)) / factor;  // in the column's unit
  if (*hi == *lo) return;  // no motion: load_experiment decides
  if (factor != 1.0 && largest < 2.5) {
    warnings->push_back(path + ": '" + column + "' never exceeds " + printed(largest, "%.6g") +
                        " in magnitude: it looks like radians in a degree column (name it " +
                        column.substr(0, column.find('_')) + "_rad if so)");
  } else if (factor == 1.0 && radians_look_like_degrees(largest)) {
    warnings->push_back(path + ": '" + column + "' reaches " + printed(largest, "%.6g") +
                        ", beyond 2 pi: it looks like degrees in a radian column (name it " +
                        column.substr(0, column.find('_')) + "_deg if so)");
  }
}

// One cycle's phases (strictly increasing in [0, 2 pi), checked before): the largest gap
// between neighbours, the wrap from the last phase back to the first included. Refused beyond
// half a cycle: no periodic interpolation or closing step bridges that, and it is how radians
// in a degree column (phases 0 ... 6.28 "deg", 1.7 % of the cycle) show. Warned beyond 60 deg:
// a digitized series with a stretch left out (the interpolation bridges it with a cubic, and a
// stall break inside it is lost). Why 60: 30 digitized points per cycle, twice as dense where
// the curve turns, leave gaps of at most ~25 deg; a whole-cycle grid of 11 samples 33 deg.
void check_phase_gaps(const std::string& path, const CsvTable& t, int phase_col, double factor,
                      const std::vector<double>& phase_rad, std::vector<std::string>* warnings) {
  const auto c = static_cast<std::size_t>(phase_col);
  const std::size_t n = phase_rad.size();
  std::size_t after = 0;  // the row after the largest gap (0: the wrap, last -> first)
  double gap = phase_rad.front() + 2.0 * kPi - phase_rad.back();
  for (std::size_t i = 1; i < n; ++i)
    if (phase_rad[i] - phase_rad[i - 1] > gap) gap = phase_rad[i] - phase_rad[i - 1], after = i;
  const std::size_t before = after == 0 ? n - 1 : after - 1;
  const std::string where = "the phases leave a gap of " + printed(gap * 180.0 / kPi, "%.1f") + " deg between " +
                            t.rows[before][c] + " and " + t.rows[after][c] + (after == 0 ? " (the wrap)" : "");
  if (gap > kPi) {
    // Values that never exceed 1 are a fraction of the cycle (t / T) whatever the name says;
    // values up to 2 pi under phase_deg are radians.
    const double largest_in_unit = phase_rad.back() / factor;  // as written in the column
    const bool fraction = factor != kPhaseCyclesToRad && largest_in_unit <= 1.0;
    const bool radians = !fraction && factor == kDegToRad && largest_in_unit <= 2.0 * kPi;
    throw InputError(path, t.row_line[after], "column '" + t.header[c] + "': " + where +
                                                  ", more than half the cycle: a cycle's phases must cover it" +
                                                  (fraction ? " (its values never exceed 1: they look like a fraction "
                                                              "of the cycle, t / T; name it phase_cycles if so)"
                                                   : radians ? " (its values never exceed 2 pi: they look like radians "
                                                               "in a degree column; name it phase_rad if so)"
                                                             : ""));
  }
  if (gap > kPi / 3.0)
    warnings->push_back(path + ":" + std::to_string(t.row_line[after]) + ": column '" + t.header[c] + "': " + where +
                        ": the cycle is interpolated across it (a feature inside the gap is lost)");
}

// A unit as written ("deg", "Degrees", "[rad/s]", "msec") as our column names' suffix ("deg",
// "radps", "ms"): blanks and brackets dropped, case ignored. Empty for anything else ("-",
// "[1]", "N"), which says nothing. The spellings warn_units_row and warn_mapped_units compare
// (names_a_unit's wider set only tells a unit from another quantity, to refuse it).
std::string unit_suffix_of(const std::string& written) {
  std::string k;
  for (char ch : written)
    if (!std::isspace(static_cast<unsigned char>(ch)) && ch != '[' && ch != ']' && ch != '(' && ch != ')')
      k += static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  static const std::vector<std::pair<const char*, const char*>> names = {
      {"ms", "ms"},           {"msec", "ms"},       {"s", "s"},         {"sec", "s"},       {"deg", "deg"},
      {"degree", "deg"},      {"degrees", "deg"},   {"rad", "rad"},     {"radian", "rad"},  {"radians", "rad"},
      {"deg/s", "degps"},     {"degps", "degps"},   {"rad/s", "radps"}, {"radps", "radps"}};
  for (const auto& [name, suffix] : names)
    if (k == name) return suffix;
  return "";
}

// A units row (read_csv_lines) whose unit for one of our columns is not the column name's
// ("alpha_deg" over "rad"): one of the two is wrong, and the name is what is read. Only units
// unit_suffix_of recognises are compared.
void warn_units_row(const std::string& path, const CsvTable& t, std::vector<std::string>* warnings) {
  if (t.units_line == 0) return;
  for (std::size_t c = 0; c < t.header.size() && c < t.units.size(); ++c) {
    const std::size_t us = t.header[c].find('_');
    const std::string unit = unit_suffix_of(t.units[c]);
    if (us == std::string::npos || unit.empty() || t.header[c].substr(us + 1) == unit) continue;
    warnings->push_back(path + ":" + std::to_string(t.units_line) + ": the units row gives '" + t.units[c] +
                        "' for column '" + t.original[c] + "', whose name reads it in " + t.header[c].substr(us + 1) +
                        ": the name is what is read (rename the column if the row is right)");
  }
}

// A file column whose own name gives a unit (`t [ms]`, `AoA (rad)`, `alpha_deg`) read, through
// the experiment's [columns] map, as one of our columns in another unit (time_s, alpha_deg):
// the name is what is read, so the values are taken in our column's unit. Only units
// unit_suffix_of recognises are compared; a trial's `t [ms]` mapped to time_s fitted without a
// word and every step was 1000 times too long.
void warn_mapped_units(const std::string& path, const CsvTable& t, std::vector<std::string>* warnings) {
  // The unit in a name: in brackets or parentheses, else after the last '_'.
  auto unit_of = [](const std::string& original) {
    const std::size_t open = original.find_first_of("[(");
    const std::size_t close = original.find_first_of("])", open == std::string::npos ? 0 : open);
    if (open != std::string::npos && close != std::string::npos)
      return unit_suffix_of(original.substr(open + 1, close - open - 1));
    const std::size_t us = original.rfind('_');
    return us == std::string::npos ? std::string() : unit_suffix_of(original.substr(us + 1));
  };
  for (std::size_t c = 0; c < t.header.size() && c < t.original.size(); ++c) {
    if (t.original[c] == t.header[c]) continue;  // not mapped
    const std::size_t us = t.header[c].rfind('_');
    const std::string unit = unit_of(t.original[c]);
    if (us == std::string::npos || unit.empty() || t.header[c].substr(us + 1) == unit) continue;
    warnings->push_back(path + ":" + std::to_string(t.header_line) + ": column '" + t.original[c] + "' is read as " +
                        t.header[c] + " (in " + t.header[c].substr(us + 1) + "), but its name says " + unit +
                        ": the values are taken in " + t.header[c].substr(us + 1) + " (map it to the column "
                        "of its own unit, or convert the file)");
  }
}

// The coefficient's spread column (`Cm_std`: the standard deviation of the single cycles of an
// ensemble average at each sample; docs/formats.md "Phase-averaged cycles with a spread column"),
// when the file has one; -1 otherwise. Every value finite (numeric_column) and >= 0.
int read_spread_column(const std::string& path, CsvTable& t, const std::string& coefficient, Run& run) {
  const int col = find_plain_column(t, coefficient + "_std");
  if (col < 0) return -1;
  run.coefficient_spread = numeric_column(path, t, col, 1.0);
  const auto c = static_cast<std::size_t>(col);
  for (std::size_t i = 0; i < run.coefficient_spread.size(); ++i) {
    if (!(run.coefficient_spread[i] >= 0.0))
      throw InputError(path, t.row_line[i], "column '" + t.original[c] + "': spread " + t.rows[i][c] +
                                                " is negative (a standard deviation across the averaged cycles is >= 0)");
  }
  return col;
}

}  // namespace

Run read_run_csv(const std::string& path, Axis axis, const std::string& coefficient,
                 CoefficientPresence presence, const RunCsvOptions& options) {
  CsvTable t = read_csv_table(path, options.columns, options.dialect);
  const RunColumns rc = locate_run_columns(path, t, axis, coefficient, presence, options.columns);
  Run run;
  run.path = path;
  const std::vector<double> tol = read_time(path, t, rc, options, run);
  run.motion_angle_rad = numeric_column(path, t, rc.angle, rc.angle_factor);
  run.angle_column = t.header[static_cast<std::size_t>(rc.angle)];
  if (rc.coefficient >= 0) run.coefficient = numeric_column(path, t, rc.coefficient, 1.0);
  if (rc.normal >= 0) {
    run.coefficient = lift_or_drag(coefficient, numeric_column(path, t, rc.normal, 1.0),
                                   numeric_column(path, t, rc.chord, 1.0), run.motion_angle_rad);
    run.notes.push_back(derived_note(path, t, coefficient, rc.normal, rc.chord));
  }
  const std::size_t n = run.time_s.size();
  if (n < static_cast<std::size_t>(min_run_samples)) {
    throw InputError(path, t.row_line.back(),
                     "only " + std::to_string(n) + " data rows; a run needs at least " +
                         std::to_string(min_run_samples));
  }
  check_time_order(path, t, rc, run);
  if (rc.phase >= 0) {
    std::vector<double> phase_rad(n);
    for (std::size_t i = 0; i < n; ++i) phase_rad[i] = run.time_s[i] * 2.0 * kPi * run.frequency_hz;
    check_phase_gaps(path, t, rc.phase, rc.phase_factor, phase_rad, &run.warnings);
  }
  check_time_grid(path, t, rc, options.grid, tol, run);
  if (rc.rate >= 0) {
    run.rate_radps = numeric_column(path, t, rc.rate, rc.rate_factor);
    run.rate_from_file = true;
  } else if (run.time_grid == TimeGrid::nonuniform) {
    run.rate_radps = smooth_derivative_nonuniform(run.time_s, run.motion_angle_rad,
                                                  default_sg_half_window, default_sg_degree);
  } else {
    run.rate_radps = smooth_derivative(run.motion_angle_rad, run.time_s[1] - run.time_s[0],
                                       default_sg_half_window, default_sg_degree);
  }
  warn_angle_unit(path, t.header[static_cast<std::size_t>(rc.angle)], rc.angle_factor, run.motion_angle_rad,
                  &run.warnings);
  warn_units_row(path, t, &run.warnings);
  warn_mapped_units(path, t, &run.warnings);
  const int spread = read_spread_column(path, t, coefficient, run);
  std::vector<std::string> notes =
      table_notes(path, t, {rc.time, rc.phase, rc.angle, rc.rate, rc.coefficient, rc.normal, rc.chord, spread});
  run.notes.insert(run.notes.begin(), notes.begin(), notes.end());
  return run;
}

Run read_run_csv(const std::string& path, Axis axis, const std::string& coefficient,
                 CoefficientPresence presence, std::optional<TimeGrid> grid) {
  RunCsvOptions options;
  options.grid = grid;
  return read_run_csv(path, axis, coefficient, presence, options);
}

PhaseSeries read_phase_series(const std::string& path, Axis axis, const std::string& coefficient,
                              const RunCsvOptions& options) {
  CsvTable t = read_csv_table(path, options.columns, options.dialect);
  for (const auto& name : t.header) (void)parse_column_name(path, t.header_line, name);
  RunColumns rc;
  rc.phase = find_unit_column(path, t, "phase", rc.phase_factor);
  if (rc.phase < 0) {
    missing_column(path, t, "'phase_rad', 'phase_deg' or 'phase_cycles' (each file of a run sampled at its own "
                            "phases has its own phase column)", {"phase_rad", "phase_deg", "phase_cycles"}, options.columns);
  }
  rc.angle = find_unit_column(path, t, motion_base(axis), rc.angle_factor);
  rc.rate = find_unit_column(path, t, rate_base(axis), rc.rate_factor);
  rc.coefficient = find_plain_column(t, coefficient);
  check_cn_meaning(path, t, coefficient, options.columns);
  if (rc.coefficient < 0 && locate_body_axes(path, t, axis, coefficient, options.columns, rc.normal, rc.chord) && rc.angle < 0)
    throw InputError(path, t.header_line, coefficient + " from '" + kNormalForce + "' and '" + kChordForce +
                                              "' needs the angle of attack in the same file");
  PhaseSeries s;
  s.path = path;
  s.columns = t.original;
  s.angle_base = motion_base(axis);
  s.phase_rad = numeric_column(path, t, rc.phase, rc.phase_factor);
  if (s.phase_rad.size() < 4)
    throw InputError(path, t.row_line.back(), "only " + std::to_string(s.phase_rad.size()) +
                                                  " data rows; a series at its own phases needs at least 4");
  const auto pc = static_cast<std::size_t>(rc.phase);
  const double largest_phase_rad = *std::max_element(s.phase_rad.begin(), s.phase_rad.end());
  for (std::size_t i = 0; i < s.phase_rad.size(); ++i) {
    if (!(s.phase_rad[i] >= 0.0 && s.phase_rad[i] < 2.0 * kPi * (1.0 - 1e-15)))
      throw InputError(path, t.row_line[i], "column '" + t.header[pc] + "': phase " + t.rows[i][pc] +
                                                " is outside [0, " + phase_cycle_end(rc.phase_factor) + ")" +
                                                degrees_hint(rc.phase_factor, s.phase_rad[i], largest_phase_rad));
    if (i > 0 && !(s.phase_rad[i] > s.phase_rad[i - 1]))
      throw InputError(path, t.row_line[i], t.header[pc] + " is not strictly increasing (" + t.rows[i][pc] +
                                                " after " + t.rows[i - 1][pc] + ")");
  }
  check_phase_gaps(path, t, rc.phase, rc.phase_factor, s.phase_rad, &s.warnings);
  warn_units_row(path, t, &s.warnings);
  if (rc.angle >= 0) {
    s.motion_angle_rad = numeric_column(path, t, rc.angle, rc.angle_factor);
    s.motion_column = t.header[static_cast<std::size_t>(rc.angle)];
    warn_angle_unit(path, s.motion_column, rc.angle_factor, s.motion_angle_rad, &s.warnings);
  }
  if (rc.rate >= 0) s.rate_radps = numeric_column(path, t, rc.rate, rc.rate_factor);
  if (rc.coefficient >= 0) s.coefficient = numeric_column(path, t, rc.coefficient, 1.0);
  if (rc.normal >= 0) {
    s.coefficient = lift_or_drag(coefficient, numeric_column(path, t, rc.normal, 1.0),
                                 numeric_column(path, t, rc.chord, 1.0), s.motion_angle_rad);
    s.notes.push_back(derived_note(path, t, coefficient, rc.normal, rc.chord));
  }
  std::vector<std::string> notes =
      table_notes(path, t, {rc.phase, rc.angle, rc.rate, rc.coefficient, rc.normal, rc.chord});
  s.notes.insert(s.notes.begin(), notes.begin(), notes.end());
  return s;
}

// ==========================================================================================
// Static table
// ==========================================================================================
void read_static_table(const std::string& path, Axis axis, const std::string& coefficient,
                       StaticConfig& config, const ColumnMap& columns, const CsvDialect& dialect) {
  CsvTable t = read_csv_table(path, columns, dialect);
  for (const auto& name : t.header) (void)parse_column_name(path, t.header_line, name);
  refuse_unusable(path, t, coefficient);
  const std::string base = axis == Axis::pitch ? "alpha" : "beta";
  double factor = 1.0;
  const int x_col = find_unit_column(path, t, base, factor);
  if (x_col < 0) {
    missing_column(path, t, "'" + base + "_deg' or '" + base + "_rad' (the model angle of a " +
                                axis_name(axis) + " static table)", {base + "_deg", base + "_rad"}, columns);
  }
  const int c_col = find_plain_column(t, coefficient);
  check_cn_meaning(path, t, coefficient, columns);
  int normal = -1, chord = -1;
  const bool derived = c_col < 0 && locate_body_axes(path, t, axis, coefficient, columns, normal, chord);
  if (c_col < 0 && !derived) missing_column(path, t, "'" + coefficient + "'", {coefficient}, columns);
  config.table_x_rad = numeric_column(path, t, x_col, factor);
  config.table_value = derived ? lift_or_drag(coefficient, numeric_column(path, t, normal, 1.0),
                                              numeric_column(path, t, chord, 1.0), config.table_x_rad)
                               : numeric_column(path, t, c_col, 1.0);
  const auto x_field = static_cast<std::size_t>(x_col);
  check_static_table(config.table_x_rad, config.table_value,
                     TableSite{[&](std::size_t row, const std::string& problem) {
                                 return InputError(path, row < t.row_line.size() ? t.row_line[row] : 0, problem);
                               },
                               [&](std::size_t row) { return t.rows[row][x_field]; }});
  config.kind = StaticKind::table;
  config.table_path = path;
}

}  // namespace indicial
