// indicial/coef_file.hpp -- the coefficient file (.coef, version 1): parse, validate, write.
//
// What it is for
// --------------
// A fitted model travels from the offline fitter to the embedded runtime as a short text
// file: human-readable, diffable, versioned and protected by a CRC-32. This header reads and
// writes that file with no heap, no exceptions and no RTTI, so the same code runs inside a
// flight simulator's real-time loop, in the `indicial` command line and in the tests. The
// format is specified in docs/architecture.md ("The coefficient file").
//
// Usage
// -----
//   indicial::ModelSet<double, indicial::DefaultCapacity> model;
//   indicial::ParseDiagnostic diag;
//   indicial::LoadStatus s = indicial::parse_coef_file(text, text_length, &model, &diag);
//   if (s != indicial::LoadStatus::ok)
//     printf("line %zu: %s (%s)\n", diag.line, diag.reason, indicial::to_string(s));
//
//   char buffer[4096];
//   std::size_t n = 0;
//   if (indicial::write_coef_file(model, buffer, sizeof buffer, &n) == indicial::WriteStatus::ok)
//     fwrite(buffer, 1, n, f);
//
// Warnings
// --------
// 1. parse_coef_file keeps a whole ModelSet<double, Cap> on the stack (it parses into a local
//    and copies it out only on success, so *out is untouched on refusal). With
//    DefaultCapacity that is 9176 bytes (GCC 12, x86-64); call it at initialisation, not from an interrupt.
// 2. The parser checks the file (syntax, capacity, finite values, ordering, the checksum), not
//    the dynamics: that b_j(x) > 0 over the envelope is checked by Predictor::load
//    (runtime.hpp, validate_for_runtime). Use the Predictor, not the bare parser, to run.
// 3. The checksum covers every byte before the `checksum` line, comments included: editing a
//    file by hand means recomputing it (`indicial coef check` prints the expected value).
// 4. write_coef_file writes exactly *length bytes and no terminating NUL. Numbers are written
//    by std::to_chars in their shortest round-trip form, so write -> parse -> write is
//    byte-identical and every double comes back bit for bit (including -0).
// 5. delay_s (the pure delay of a coefficient's unsteady forcing, s at the reference
//    airspeed) must be finite and >= 0; it is written only when it is not +0, after `con`.
//    (Versions before delay support refused a nonzero delay with unsupported_feature; that
//    value is kept in the enums so their numbering and callers stay valid, but nothing
//    returns it now.)
#pragma once

#include <charconv>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <system_error>

#include "indicial/model.hpp"

namespace indicial {

// Why a load failed (or ok). Each value says exactly what was wrong with the input.
enum class LoadStatus : int {
  ok = 0,
  empty_input,          // no bytes, or only whitespace
  null_argument,        // text == nullptr with length > 0, or out == nullptr
  truncated,            // no (complete) checksum line, or a coefficient block never ended
  checksum_mismatch,    // the CRC-32 of the bytes before `checksum` differs: corrupted
  wrong_version,        // `indicial-coef N` with N != 1
  over_capacity,        // more powers/knots/lags/table rows/coefficients than Cap allows
  syntax_error,         // unknown or duplicate key, bad number, wrong token count, bad order
  invalid_value,        // NaN/Inf, non-increasing table, lag 1 gain != 1, bad power,
                        // non-positive length or airspeed, envelope min >= max, ...
  unsupported_feature,  // no longer returned (was: nonzero delay_s before delay support)
  unstable_lag,         // (runtime validation) b_j(x) <= 0 somewhere inside the envelope
};

inline constexpr const char* to_string(LoadStatus s) {
  switch (s) {
    case LoadStatus::ok: return "ok";
    case LoadStatus::empty_input: return "empty_input";
    case LoadStatus::null_argument: return "null_argument";
    case LoadStatus::truncated: return "truncated";
    case LoadStatus::checksum_mismatch: return "checksum_mismatch";
    case LoadStatus::wrong_version: return "wrong_version";
    case LoadStatus::over_capacity: return "over_capacity";
    case LoadStatus::syntax_error: return "syntax_error";
    case LoadStatus::invalid_value: return "invalid_value";
    case LoadStatus::unsupported_feature: return "unsupported_feature";
    case LoadStatus::unstable_lag: return "unstable_lag";
  }
  return "unknown_load_status";
}

enum class WriteStatus : int {
  ok = 0,
  null_argument,        // buffer == nullptr (with capacity > 0) or length == nullptr
  buffer_too_small,     // the text does not fit in capacity bytes; nothing usable written
  invalid_model,        // the model would not read back (non-finite value, bad count, name...)
  unsupported_feature,  // no longer returned (was: nonzero delay_s before delay support)
};

inline constexpr const char* to_string(WriteStatus s) {
  switch (s) {
    case WriteStatus::ok: return "ok";
    case WriteStatus::null_argument: return "null_argument";
    case WriteStatus::buffer_too_small: return "buffer_too_small";
    case WriteStatus::invalid_model: return "invalid_model";
    case WriteStatus::unsupported_feature: return "unsupported_feature";
  }
  return "unknown_write_status";
}

// Where and why a load was refused. `reason` always points to a string literal (no heap);
// `line` is 1-based, 0 when the problem is not on one line (e.g. a ModelSet built in code).
struct ParseDiagnostic {
  std::size_t line = 0;
  const char* reason = "";
};

// The format version this header reads and writes.
inline constexpr int coef_file_version = 1;
// Highest power allowed for a plus-function knot term (x - k)_+^p: the report uses 1 and 2;
// beyond 8 the term is numerically meaningless over an angle range of a few radians.
inline constexpr int max_knot_power = 8;

// ------------------------------------------------------------------------------------------
// CRC-32 (IEEE 802.3, reflected polynomial 0xEDB88320, as zlib's crc32()).
// Written by hand, not taken from zlib or Boost.CRC: this header must stay header-only,
// dependency-free and heap-free for the embedded runtime; the table is built at compile time.
// ------------------------------------------------------------------------------------------
namespace detail {
struct Crc32Table {
  std::uint32_t entry[256];
};
constexpr Crc32Table make_crc32_table() {
  Crc32Table t{};
  for (std::uint32_t i = 0; i < 256; ++i) {
    std::uint32_t c = i;
    for (int k = 0; k < 8; ++k) c = (c & 1u) ? (0xEDB88320u ^ (c >> 1)) : (c >> 1);
    t.entry[i] = c;
  }
  return t;
}
inline constexpr Crc32Table crc32_table = make_crc32_table();
}  // namespace detail

// crc32(data, n) equals zlib's crc32(0, data, n); pass a previous result as `crc` to continue.
inline std::uint32_t crc32(const char* data, std::size_t n, std::uint32_t crc = 0) {
  crc = ~crc;
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint32_t byte = static_cast<unsigned char>(data[i]);
    crc = detail::crc32_table.entry[(crc ^ byte) & 0xFFu] ^ (crc >> 8);
  }
  return ~crc;
}

// ------------------------------------------------------------------------------------------
// Structural validation shared by the parser, the writer and the runtime: counts within Cap,
// finite values, positive length and airspeed, ordered envelope and table, valid powers and
// names, lag 1's gain 1, delay finite and >= 0. (The runtime adds the b_j(x) > 0 check.)
// ------------------------------------------------------------------------------------------
namespace detail {

inline bool valid_coefficient_name(const char* name, std::size_t capacity) {
  std::size_t n = 0;
  while (n < capacity && name[n] != '\0') {
    const char ch = name[n];
    const bool ok = (ch >= 'A' && ch <= 'Z') || (ch >= 'a' && ch <= 'z') ||
                    (ch >= '0' && ch <= '9') || ch == '_';
    if (!ok) return false;
    ++n;
  }
  return n > 0 && n < capacity;  // non-empty and NUL-terminated inside the array
}

inline bool names_equal(const char* a, const char* b) {
  std::size_t i = 0;
  while (a[i] != '\0' && a[i] == b[i]) ++i;
  return a[i] == b[i];
}

inline LoadStatus refuse(ParseDiagnostic* diag, std::size_t line, const char* reason,
                         LoadStatus status) {
  if (diag != nullptr) {
    diag->line = line;
    diag->reason = reason;
  }
  return status;
}

template <int P, int K>
inline LoadStatus check_spline(const Spline<double, P, K>& s, const char** reason) {
  if (s.n_powers < 0 || s.n_powers > P) {
    *reason = "more polynomial powers than the capacity allows";
    return LoadStatus::over_capacity;
  }
  if (s.n_knots < 0 || s.n_knots > K) {
    *reason = "more knots than the capacity allows";
    return LoadStatus::over_capacity;
  }
  for (int i = 0; i < s.n_powers; ++i) {
    if (!std::isfinite(s.power_coef[i])) {
      *reason = "polynomial coefficient is NaN or Inf";
      return LoadStatus::invalid_value;
    }
  }
  for (int j = 0; j < s.n_knots; ++j) {
    if (!std::isfinite(s.knot_rad[j]) || !std::isfinite(s.knot_coef[j])) {
      *reason = "knot position or coefficient is NaN or Inf";
      return LoadStatus::invalid_value;
    }
    if (s.knot_power[j] < 0 || s.knot_power[j] > max_knot_power) {
      *reason = "knot power must be an integer 0..8";
      return LoadStatus::invalid_value;
    }
  }
  return LoadStatus::ok;
}

}  // namespace detail

template <class Cap>
inline LoadStatus validate_model_set(const ModelSet<double, Cap>& m, ParseDiagnostic* diag) {
  using detail::refuse;
  const char* reason = "";
  if (m.axis != Axis::pitch && m.axis != Axis::roll && m.axis != Axis::yaw)
    return refuse(diag, 0, "axis must be pitch, roll or yaw", LoadStatus::invalid_value);
  if (!std::isfinite(m.reference_length_m) || !(m.reference_length_m > 0.0))
    return refuse(diag, 0, "reference_length_m must be finite and > 0", LoadStatus::invalid_value);
  if (!std::isfinite(m.airspeed_mps) || !(m.airspeed_mps > 0.0))
    return refuse(diag, 0, "airspeed_mps must be finite and > 0", LoadStatus::invalid_value);
  if (!std::isfinite(m.alpha0_rad))
    return refuse(diag, 0, "alpha0_rad is NaN or Inf", LoadStatus::invalid_value);
  if (!std::isfinite(m.x_min_rad) || !std::isfinite(m.x_max_rad))
    return refuse(diag, 0, "envelope_rad is NaN or Inf", LoadStatus::invalid_value);
  if (!(m.x_min_rad < m.x_max_rad))
    return refuse(diag, 0, "envelope_rad: min must be < max", LoadStatus::invalid_value);
  if (m.n_coefficients > Cap::max_coefficients)
    return refuse(diag, 0, "more coefficients than the capacity allows", LoadStatus::over_capacity);
  if (m.n_coefficients < 1)
    return refuse(diag, 0, "no coefficient block", LoadStatus::syntax_error);
  for (int c = 0; c < m.n_coefficients; ++c) {
    const CoefficientModel<double, Cap>& cm = m.coefficients[c];
    if (!detail::valid_coefficient_name(cm.name, sizeof cm.name))
      return refuse(diag, 0, "coefficient name must be 1..7 letters, digits or _",
                    LoadStatus::syntax_error);
    for (int d = 0; d < c; ++d) {
      if (detail::names_equal(cm.name, m.coefficients[d].name))
        return refuse(diag, 0, "coefficient name given twice", LoadStatus::invalid_value);
    }
    const auto& sc = cm.static_curve;
    LoadStatus s = detail::check_spline(sc.polynomial, &reason);
    if (s != LoadStatus::ok) return refuse(diag, 0, reason, s);
    if (sc.kind == StaticKind::table) {
      if (sc.n_table > Cap::max_table_points)
        return refuse(diag, 0, "more static table rows than the capacity allows",
                      LoadStatus::over_capacity);
      if (sc.n_table < 2)
        return refuse(diag, 0, "a static table needs at least 2 rows", LoadStatus::invalid_value);
      if (sc.polynomial.n_powers != 0 || sc.polynomial.n_knots != 0)
        return refuse(diag, 0, "static curve given both as polynomial and as table",
                      LoadStatus::invalid_value);
      for (int i = 0; i < sc.n_table; ++i) {
        if (!std::isfinite(sc.table_x_rad[i]) || !std::isfinite(sc.table_value[i]))
          return refuse(diag, 0, "static table value is NaN or Inf", LoadStatus::invalid_value);
        if (i > 0 && !(sc.table_x_rad[i] > sc.table_x_rad[i - 1]))
          return refuse(diag, 0, "static table x_rad must be strictly increasing",
                        LoadStatus::invalid_value);
      }
    } else if (sc.kind != StaticKind::polynomial) {
      return refuse(diag, 0, "unknown static curve kind", LoadStatus::invalid_value);
    }
    if ((s = detail::check_spline(cm.static_correction, &reason)) != LoadStatus::ok ||
        (s = detail::check_spline(cm.rotary, &reason)) != LoadStatus::ok ||
        (s = detail::check_spline(cm.a, &reason)) != LoadStatus::ok)
      return refuse(diag, 0, reason, s);
    if (cm.n_lags > Cap::max_lags)
      return refuse(diag, 0, "more lag states than the capacity allows", LoadStatus::over_capacity);
    if (cm.n_lags < 1)
      return refuse(diag, 0, "at least one lag state is required", LoadStatus::invalid_value);
    for (int j = 0; j < cm.n_lags; ++j) {
      if ((s = detail::check_spline(cm.lags[j].b, &reason)) != LoadStatus::ok)
        return refuse(diag, 0, reason, s);
      if (!std::isfinite(cm.lags[j].gain))
        return refuse(diag, 0, "lag gain is NaN or Inf", LoadStatus::invalid_value);
    }
    // Why: c_1 = 1 by definition (a(x) absorbs it); a different value would be silently
    // ignored by advance_lags, so it is refused rather than dropped.
    if (cm.lags[0].gain != 1.0)
      return refuse(diag, 0, "lag 1's gain is 1 by definition", LoadStatus::invalid_value);
    if (!std::isfinite(cm.con))
      return refuse(diag, 0, "con is NaN or Inf", LoadStatus::invalid_value);
    if (!std::isfinite(cm.delay_s))
      return refuse(diag, 0, "delay_s is NaN or Inf", LoadStatus::invalid_value);
    if (cm.delay_s < 0.0)
      return refuse(diag, 0, "delay_s must be >= 0 (a delay, not a prediction)",
                    LoadStatus::invalid_value);
  }
  return LoadStatus::ok;
}

// ------------------------------------------------------------------------------------------
// Parser.
// ------------------------------------------------------------------------------------------
namespace detail {

// One line split into whitespace-separated tokens on demand.
struct Tokens {
  const char* p;
  const char* end;
  bool next(const char** b, const char** e) {
    while (p < end && (*p == ' ' || *p == '\t')) ++p;
    if (p >= end) return false;
    *b = p;
    while (p < end && *p != ' ' && *p != '\t') ++p;
    *e = p;
    return true;
  }
  bool at_end() {
    while (p < end && (*p == ' ' || *p == '\t')) ++p;
    return p >= end;
  }
};

inline bool token_is(const char* b, const char* e, const char* word) {
  std::size_t i = 0;
  for (; b + i < e; ++i) {
    if (word[i] == '\0' || word[i] != b[i]) return false;
  }
  return word[i] == '\0';
}

struct LineCursor {
  const char* text;
  std::size_t length;
  std::size_t pos = 0;
  std::size_t number = 0;  // 1-based number of the line last returned
  // Returns the next line [b, e) without its '\n' (and without a trailing '\r'), and the
  // offset of its first byte.
  bool next(const char** b, const char** e, std::size_t* start) {
    if (pos >= length) return false;
    *start = pos;
    std::size_t q = pos;
    while (q < length && text[q] != '\n') ++q;
    *b = text + pos;
    *e = text + q;
    if (*e > *b && *(*e - 1) == '\r') --*e;
    pos = (q < length) ? q + 1 : q;
    ++number;
    return true;
  }
};

// Blank or comment line?
inline bool is_ignorable(const char* b, const char* e) {
  while (b < e && (*b == ' ' || *b == '\t')) ++b;
  return b >= e || *b == '#';
}

inline LoadStatus parse_number(const char* b, const char* e, double* v, const char** reason) {
  double value = 0.0;
  const std::from_chars_result r = std::from_chars(b, e, value);
  if (r.ec == std::errc::result_out_of_range) {
    *reason = "number out of the range of double";
    return LoadStatus::invalid_value;
  }
  if (r.ec != std::errc() || r.ptr != e) {
    *reason = "bad number";
    return LoadStatus::syntax_error;
  }
  if (!std::isfinite(value)) {
    *reason = "NaN or Inf is not allowed";
    return LoadStatus::invalid_value;
  }
  *v = value;
  return LoadStatus::ok;
}

inline LoadStatus parse_int(const char* b, const char* e, int* v, const char** reason) {
  int value = 0;
  const std::from_chars_result r = std::from_chars(b, e, value);
  if (r.ec != std::errc() || r.ptr != e) {
    *reason = "bad integer";
    return LoadStatus::syntax_error;
  }
  *v = value;
  return LoadStatus::ok;
}

// Reads exactly n numbers and then the end of the line.
inline LoadStatus read_numbers(Tokens& t, double* v, int n, const char** reason) {
  for (int i = 0; i < n; ++i) {
    const char* b = nullptr;
    const char* e = nullptr;
    if (!t.next(&b, &e)) {
      *reason = "missing value";
      return LoadStatus::syntax_error;
    }
    const LoadStatus s = parse_number(b, e, &v[i], reason);
    if (s != LoadStatus::ok) return s;
  }
  if (!t.at_end()) {
    *reason = "too many values on the line";
    return LoadStatus::syntax_error;
  }
  return LoadStatus::ok;
}

// `<key> c0 c1 ...`: at least one value, at most P.
template <int P, int K>
inline LoadStatus read_poly(Tokens& t, Spline<double, P, K>* s, const char** reason) {
  int n = 0;
  const char* b = nullptr;
  const char* e = nullptr;
  while (t.next(&b, &e)) {
    if (n >= P) {
      *reason = "more polynomial powers than the capacity allows";
      return LoadStatus::over_capacity;
    }
    const LoadStatus st = parse_number(b, e, &s->power_coef[n], reason);
    if (st != LoadStatus::ok) return st;
    ++n;
  }
  if (n == 0) {
    *reason = "a polynomial needs at least one coefficient";
    return LoadStatus::syntax_error;
  }
  s->n_powers = n;
  return LoadStatus::ok;
}

// `<key> knot_rad power coef`
template <int P, int K>
inline LoadStatus read_knot(Tokens& t, Spline<double, P, K>* s, const char** reason) {
  const char* b = nullptr;
  const char* e = nullptr;
  double knot = 0.0;
  double coef = 0.0;
  int power = 0;
  if (!t.next(&b, &e)) {
    *reason = "missing value";
    return LoadStatus::syntax_error;
  }
  LoadStatus st = parse_number(b, e, &knot, reason);
  if (st != LoadStatus::ok) return st;
  if (!t.next(&b, &e)) {
    *reason = "missing value";
    return LoadStatus::syntax_error;
  }
  if ((st = parse_int(b, e, &power, reason)) != LoadStatus::ok) return st;
  if ((st = read_numbers(t, &coef, 1, reason)) != LoadStatus::ok) return st;
  if (power < 0 || power > max_knot_power) {
    *reason = "knot power must be an integer 0..8";
    return LoadStatus::invalid_value;
  }
  if (s->n_knots >= K) {
    *reason = "more knots than the capacity allows";
    return LoadStatus::over_capacity;
  }
  s->knot_rad[s->n_knots] = knot;
  s->knot_power[s->n_knots] = power;
  s->knot_coef[s->n_knots] = coef;
  ++s->n_knots;
  return LoadStatus::ok;
}

// Lag index j (1-based in the file) -> 0-based index.
template <class Cap>
inline LoadStatus read_lag_index(Tokens& t, int* index0, const char** reason) {
  const char* b = nullptr;
  const char* e = nullptr;
  int j = 0;
  if (!t.next(&b, &e)) {
    *reason = "missing lag index";
    return LoadStatus::syntax_error;
  }
  const LoadStatus st = parse_int(b, e, &j, reason);
  if (st != LoadStatus::ok) return st;
  if (j < 1) {
    *reason = "lag index must be >= 1";
    return LoadStatus::invalid_value;
  }
  if (j > Cap::max_lags) {
    *reason = "more lag states than the capacity allows";
    return LoadStatus::over_capacity;
  }
  *index0 = j - 1;
  return LoadStatus::ok;
}

// Bits of which single-occurrence keys were seen.
enum SeenBit : unsigned {
  seen_axis = 1u << 0,
  seen_length = 1u << 1,
  seen_airspeed = 1u << 2,
  seen_alpha0 = 1u << 3,
  seen_envelope = 1u << 4,
  seen_static_poly = 1u << 5,
  seen_corr_poly = 1u << 6,
  seen_rotary_poly = 1u << 7,
  seen_a_poly = 1u << 8,
  seen_con = 1u << 9,
  seen_delay = 1u << 10,
  seen_lag_poly0 = 1u << 16,  // + j for lag j (up to 4 lags)
  seen_lag_gain0 = 1u << 24,  // + j
};

}  // namespace detail

template <class Cap>
LoadStatus parse_coef_file(const char* text, std::size_t length, ModelSet<double, Cap>* out,
                           ParseDiagnostic* diag) {
  using namespace detail;
  if (out == nullptr) return refuse(diag, 0, "no output model given", LoadStatus::null_argument);
  if (length == 0) return refuse(diag, 0, "empty input", LoadStatus::empty_input);
  if (text == nullptr)
    return refuse(diag, 0, "null text with nonzero length", LoadStatus::null_argument);
  {
    std::size_t i = 0;
    while (i < length && (text[i] == ' ' || text[i] == '\t' || text[i] == '\n' ||
                          text[i] == '\r'))
      ++i;
    if (i == length) return refuse(diag, 1, "only whitespace", LoadStatus::empty_input);
  }

  const char* b = nullptr;
  const char* e = nullptr;
  std::size_t start = 0;
  const char* reason = "";

  // 1. The version line: the first line that is not blank or a comment. Checked before the
  //    checksum because another version may protect itself differently.
  LineCursor cur{text, length};
  for (;;) {
    if (!cur.next(&b, &e, &start)) return refuse(diag, 1, "only comments", LoadStatus::empty_input);
    if (!is_ignorable(b, e)) break;
  }
  {
    Tokens t{b, e};
    const char* kb = nullptr;
    const char* ke = nullptr;
    int version = 0;
    t.next(&kb, &ke);
    if (!token_is(kb, ke, "indicial-coef"))
      return refuse(diag, cur.number, "the first line must be 'indicial-coef 1'",
                    LoadStatus::syntax_error);
    if (!t.next(&kb, &ke) || parse_int(kb, ke, &version, &reason) != LoadStatus::ok || !t.at_end())
      return refuse(diag, cur.number, "bad version line", LoadStatus::syntax_error);
    if (version != coef_file_version)
      return refuse(diag, cur.number, "unsupported file version (this runtime reads version 1)",
                    LoadStatus::wrong_version);
  }
  const std::size_t body_first_line = cur.number + 1;
  const std::size_t body_start = cur.pos;

  // 2. The checksum line: the first line whose first token is `checksum`; only blank lines
  //    may follow it.
  std::size_t checksum_start = 0;
  std::size_t checksum_line = 0;
  std::uint32_t stored_crc = 0;
  {
    LineCursor scan = cur;
    bool found = false;
    while (scan.next(&b, &e, &start)) {
      Tokens t{b, e};
      const char* kb = nullptr;
      const char* ke = nullptr;
      if (!found) {
        if (t.next(&kb, &ke) && token_is(kb, ke, "checksum")) {
          found = true;
          checksum_start = start;
          checksum_line = scan.number;
          const char* hb = nullptr;
          const char* he = nullptr;
          if (!t.next(&hb, &he))
            return refuse(diag, checksum_line, "checksum line has no value (file truncated?)",
                          LoadStatus::truncated);
          int digits = 0;
          for (const char* p = hb; p < he; ++p, ++digits) {
            const char ch = *p;
            unsigned v = 0;
            if (ch >= '0' && ch <= '9') v = static_cast<unsigned>(ch - '0');
            else if (ch >= 'a' && ch <= 'f') v = static_cast<unsigned>(ch - 'a' + 10);
            else
              return refuse(diag, checksum_line, "checksum must be 8 lowercase hex digits",
                            LoadStatus::syntax_error);
            if (digits >= 8)
              return refuse(diag, checksum_line, "checksum must be 8 lowercase hex digits",
                            LoadStatus::syntax_error);
            stored_crc = (stored_crc << 4) | v;
          }
          // Why truncated and not syntax_error: a file cut inside its last line ends here.
          if (digits < 8)
            return refuse(diag, checksum_line, "checksum has fewer than 8 digits (file truncated?)",
                          LoadStatus::truncated);
          if (!t.at_end())
            return refuse(diag, checksum_line, "extra text on the checksum line",
                          LoadStatus::syntax_error);
        }
      } else if (t.next(&kb, &ke)) {
        return refuse(diag, scan.number, "text after the checksum line", LoadStatus::syntax_error);
      }
    }
    if (!found)
      return refuse(diag, scan.number, "no checksum line (file truncated?)", LoadStatus::truncated);
  }
  if (crc32(text, checksum_start) != stored_crc)
    return refuse(diag, checksum_line, "checksum mismatch: the file is corrupted",
                  LoadStatus::checksum_mismatch);

  // 3. The body, between the version line and the checksum line.
  ModelSet<double, Cap> m{};
  m.n_coefficients = 0;
  LineCursor body{text, checksum_start};
  body.pos = body_start;
  body.number = body_first_line - 1;
  unsigned header_seen = 0;
  unsigned block_seen = 0;
  int max_lag_index0 = -1;
  CoefficientModel<double, Cap>* cm = nullptr;  // the open block, if any
  std::size_t block_line = 0;

  while (body.next(&b, &e, &start)) {
    const std::size_t line = body.number;
    if (is_ignorable(b, e)) continue;
    Tokens t{b, e};
    const char* kb = nullptr;
    const char* ke = nullptr;
    t.next(&kb, &ke);
    LoadStatus st = LoadStatus::ok;
    reason = "";

    // Header keys, before the first coefficient block.
    const bool is_header_key = token_is(kb, ke, "axis") || token_is(kb, ke, "reference_length_m") ||
                               token_is(kb, ke, "airspeed_mps") || token_is(kb, ke, "alpha0_rad") ||
                               token_is(kb, ke, "envelope_rad");
    if (is_header_key) {
      if (cm != nullptr || m.n_coefficients > 0)
        return refuse(diag, line, "header key after a coefficient block", LoadStatus::syntax_error);
      unsigned bit = 0;
      if (token_is(kb, ke, "axis")) {
        bit = seen_axis;
        const char* vb = nullptr;
        const char* ve = nullptr;
        if (!t.next(&vb, &ve) || !t.at_end())
          return refuse(diag, line, "axis needs one value", LoadStatus::syntax_error);
        if (token_is(vb, ve, "pitch")) m.axis = Axis::pitch;
        else if (token_is(vb, ve, "roll")) m.axis = Axis::roll;
        else if (token_is(vb, ve, "yaw")) m.axis = Axis::yaw;
        else return refuse(diag, line, "axis must be pitch, roll or yaw", LoadStatus::invalid_value);
      } else if (token_is(kb, ke, "reference_length_m")) {
        bit = seen_length;
        if ((st = read_numbers(t, &m.reference_length_m, 1, &reason)) != LoadStatus::ok)
          return refuse(diag, line, reason, st);
        if (!(m.reference_length_m > 0.0))
          return refuse(diag, line, "reference_length_m must be > 0", LoadStatus::invalid_value);
      } else if (token_is(kb, ke, "airspeed_mps")) {
        bit = seen_airspeed;
        if ((st = read_numbers(t, &m.airspeed_mps, 1, &reason)) != LoadStatus::ok)
          return refuse(diag, line, reason, st);
        if (!(m.airspeed_mps > 0.0))
          return refuse(diag, line, "airspeed_mps must be > 0", LoadStatus::invalid_value);
      } else if (token_is(kb, ke, "alpha0_rad")) {
        bit = seen_alpha0;
        if ((st = read_numbers(t, &m.alpha0_rad, 1, &reason)) != LoadStatus::ok)
          return refuse(diag, line, reason, st);
      } else {
        bit = seen_envelope;
        double v[2] = {0.0, 0.0};
        if ((st = read_numbers(t, v, 2, &reason)) != LoadStatus::ok)
          return refuse(diag, line, reason, st);
        if (!(v[0] < v[1]))
          return refuse(diag, line, "envelope_rad: min must be < max", LoadStatus::invalid_value);
        m.x_min_rad = v[0];
        m.x_max_rad = v[1];
      }
      if (header_seen & bit) return refuse(diag, line, "key given twice", LoadStatus::syntax_error);
      header_seen |= bit;
      continue;
    }

    if (token_is(kb, ke, "coefficient")) {
      if (cm != nullptr)
        return refuse(diag, line, "coefficient block opened inside another (missing end_coefficient)",
                      LoadStatus::syntax_error);
      if (!(header_seen & seen_axis))
        return refuse(diag, line, "missing 'axis' before the first coefficient", LoadStatus::syntax_error);
      if (!(header_seen & seen_length))
        return refuse(diag, line, "missing 'reference_length_m' before the first coefficient",
                      LoadStatus::syntax_error);
      if (!(header_seen & seen_airspeed))
        return refuse(diag, line, "missing 'airspeed_mps' before the first coefficient",
                      LoadStatus::syntax_error);
      if (!(header_seen & seen_alpha0))
        return refuse(diag, line, "missing 'alpha0_rad' before the first coefficient",
                      LoadStatus::syntax_error);
      if (!(header_seen & seen_envelope))
        return refuse(diag, line, "missing 'envelope_rad' before the first coefficient",
                      LoadStatus::syntax_error);
      if (m.n_coefficients >= Cap::max_coefficients)
        return refuse(diag, line, "more coefficients than the capacity allows",
                      LoadStatus::over_capacity);
      const char* nb = nullptr;
      const char* ne = nullptr;
      if (!t.next(&nb, &ne) || !t.at_end())
        return refuse(diag, line, "coefficient needs one name", LoadStatus::syntax_error);
      cm = &m.coefficients[m.n_coefficients];
      const std::size_t name_len = static_cast<std::size_t>(ne - nb);
      if (name_len >= sizeof cm->name)
        return refuse(diag, line, "coefficient name longer than 7 characters", LoadStatus::syntax_error);
      for (std::size_t i = 0; i < name_len; ++i) cm->name[i] = nb[i];
      cm->name[name_len] = '\0';
      if (!valid_coefficient_name(cm->name, sizeof cm->name))
        return refuse(diag, line, "coefficient name must be letters, digits or _",
                      LoadStatus::syntax_error);
      for (int d = 0; d < m.n_coefficients; ++d) {
        if (names_equal(cm->name, m.coefficients[d].name))
          return refuse(diag, line, "coefficient name given twice", LoadStatus::invalid_value);
      }
      block_seen = 0;
      max_lag_index0 = -1;
      block_line = line;
      continue;
    }

    if (cm == nullptr) {
      if (token_is(kb, ke, "end_coefficient"))
        return refuse(diag, line, "end_coefficient without a block", LoadStatus::syntax_error);
      return refuse(diag, line, "unknown key", LoadStatus::syntax_error);
    }

    // Keys inside a coefficient block.
    auto& sc = cm->static_curve;
    unsigned once_bit = 0;
    if (token_is(kb, ke, "end_coefficient")) {
      if (!t.at_end()) return refuse(diag, line, "extra text after end_coefficient", LoadStatus::syntax_error);
      cm->n_lags = max_lag_index0 < 0 ? 1 : max_lag_index0 + 1;
      if (sc.kind == StaticKind::table) {
        if (sc.n_table < 2)
          return refuse(diag, line, "a static table needs at least 2 rows", LoadStatus::invalid_value);
        prepare_static_table(sc);
      }
      ++m.n_coefficients;
      cm = nullptr;
      continue;
    } else if (token_is(kb, ke, "static_poly")) {
      once_bit = seen_static_poly;
      if (sc.kind == StaticKind::table)
        return refuse(diag, line, "static curve given both as table and polynomial", LoadStatus::invalid_value);
      st = read_poly(t, &sc.polynomial, &reason);
    } else if (token_is(kb, ke, "static_knot")) {
      if (sc.kind == StaticKind::table)
        return refuse(diag, line, "static curve given both as table and polynomial", LoadStatus::invalid_value);
      st = read_knot(t, &sc.polynomial, &reason);
    } else if (token_is(kb, ke, "static_table_point")) {
      if (sc.polynomial.n_powers != 0 || sc.polynomial.n_knots != 0)
        return refuse(diag, line, "static curve given both as polynomial and table", LoadStatus::invalid_value);
      double v[2] = {0.0, 0.0};
      if ((st = read_numbers(t, v, 2, &reason)) != LoadStatus::ok) return refuse(diag, line, reason, st);
      if (sc.n_table >= Cap::max_table_points)
        return refuse(diag, line, "more static table rows than the capacity allows",
                      LoadStatus::over_capacity);
      if (sc.n_table > 0 && !(v[0] > sc.table_x_rad[sc.n_table - 1]))
        return refuse(diag, line, "static table x_rad must be strictly increasing",
                      LoadStatus::invalid_value);
      sc.kind = StaticKind::table;
      sc.table_x_rad[sc.n_table] = v[0];
      sc.table_value[sc.n_table] = v[1];
      ++sc.n_table;
    } else if (token_is(kb, ke, "static_corr_poly")) {
      once_bit = seen_corr_poly;
      st = read_poly(t, &cm->static_correction, &reason);
    } else if (token_is(kb, ke, "static_corr_knot")) {
      st = read_knot(t, &cm->static_correction, &reason);
    } else if (token_is(kb, ke, "rotary_poly")) {
      once_bit = seen_rotary_poly;
      st = read_poly(t, &cm->rotary, &reason);
    } else if (token_is(kb, ke, "rotary_knot")) {
      st = read_knot(t, &cm->rotary, &reason);
    } else if (token_is(kb, ke, "a_poly")) {
      once_bit = seen_a_poly;
      st = read_poly(t, &cm->a, &reason);
    } else if (token_is(kb, ke, "a_knot")) {
      st = read_knot(t, &cm->a, &reason);
    } else if (token_is(kb, ke, "lag_poly") || token_is(kb, ke, "lag_knot") ||
               token_is(kb, ke, "lag_gain")) {
      const bool is_poly = token_is(kb, ke, "lag_poly");
      const bool is_gain = token_is(kb, ke, "lag_gain");
      int j = 0;
      if ((st = read_lag_index<Cap>(t, &j, &reason)) != LoadStatus::ok) return refuse(diag, line, reason, st);
      if (j > max_lag_index0) max_lag_index0 = j;
      if (is_poly) {
        once_bit = seen_lag_poly0 << j;
        st = read_poly(t, &cm->lags[j].b, &reason);
      } else if (is_gain) {
        once_bit = seen_lag_gain0 << j;
        double g = 0.0;
        if ((st = read_numbers(t, &g, 1, &reason)) != LoadStatus::ok) return refuse(diag, line, reason, st);
        // Why: c_1 = 1 by definition (a(x) absorbs the first lag's amplitude).
        if (j == 0 && g != 1.0)
          return refuse(diag, line, "lag 1's gain is 1 by definition", LoadStatus::invalid_value);
        cm->lags[j].gain = g;
      } else {
        st = read_knot(t, &cm->lags[j].b, &reason);
      }
    } else if (token_is(kb, ke, "con")) {
      once_bit = seen_con;
      st = read_numbers(t, &cm->con, 1, &reason);
    } else if (token_is(kb, ke, "delay_s")) {
      once_bit = seen_delay;
      double d = 0.0;
      if ((st = read_numbers(t, &d, 1, &reason)) != LoadStatus::ok) return refuse(diag, line, reason, st);
      if (d < 0.0)
        return refuse(diag, line, "delay_s must be >= 0 (a delay, not a prediction)",
                      LoadStatus::invalid_value);
      cm->delay_s = d;
    } else {
      return refuse(diag, line, "unknown key", LoadStatus::syntax_error);
    }
    if (st != LoadStatus::ok) return refuse(diag, line, reason, st);
    if (once_bit != 0) {
      if (block_seen & once_bit) return refuse(diag, line, "key given twice", LoadStatus::syntax_error);
      block_seen |= once_bit;
    }
  }
  if (cm != nullptr)
    return refuse(diag, block_line, "coefficient block has no end_coefficient (file truncated?)",
                  LoadStatus::truncated);
  if (m.n_coefficients == 0)
    return refuse(diag, checksum_line, "no coefficient block", LoadStatus::syntax_error);

  // Belt and braces: the whole-model checks the writer and the runtime use.
  ParseDiagnostic whole;
  const LoadStatus v = validate_model_set(m, &whole);
  if (v != LoadStatus::ok) return refuse(diag, checksum_line, whole.reason, v);
  *out = m;
  if (diag != nullptr) {
    diag->line = 0;
    diag->reason = "";
  }
  return LoadStatus::ok;
}

// ------------------------------------------------------------------------------------------
// Writer.
// ------------------------------------------------------------------------------------------
namespace detail {

struct Sink {
  char* p;
  char* end;
  bool overflow = false;
  void put(const char* s) {
    for (; *s != '\0'; ++s) put_char(*s);
  }
  void put_char(char ch) {
    if (p < end) *p++ = ch;
    else overflow = true;
  }
  void put_range(const char* b, const char* e) {
    for (; b < e; ++b) put_char(*b);
  }
  // Shortest representation that parses back to the same double (std::to_chars without a
  // format or precision: no heap, locale-independent).
  void put_double(double v) {
    char tmp[40];
    const std::to_chars_result r = std::to_chars(tmp, tmp + sizeof tmp, v);
    put_range(tmp, r.ptr);
  }
  void put_int(int v) {
    char tmp[16];
    const std::to_chars_result r = std::to_chars(tmp, tmp + sizeof tmp, v);
    put_range(tmp, r.ptr);
  }
};

template <int P, int K>
inline void write_spline(Sink& s, const Spline<double, P, K>& sp, const char* poly_key,
                         const char* knot_key, int lag_index1) {
  if (sp.n_powers > 0) {
    s.put(poly_key);
    if (lag_index1 > 0) {
      s.put_char(' ');
      s.put_int(lag_index1);
    }
    for (int i = 0; i < sp.n_powers; ++i) {
      s.put_char(' ');
      s.put_double(sp.power_coef[i]);
    }
    s.put_char('\n');
  }
  for (int j = 0; j < sp.n_knots; ++j) {
    s.put(knot_key);
    if (lag_index1 > 0) {
      s.put_char(' ');
      s.put_int(lag_index1);
    }
    s.put_char(' ');
    s.put_double(sp.knot_rad[j]);
    s.put_char(' ');
    s.put_int(sp.knot_power[j]);
    s.put_char(' ');
    s.put_double(sp.knot_coef[j]);
    s.put_char('\n');
  }
}

// True for any value other than +0.0 (so -0.0 survives the round trip).
inline bool differs_from_positive_zero(double v) { return v != 0.0 || std::signbit(v); }

}  // namespace detail

template <class Cap>
WriteStatus write_coef_file(const ModelSet<double, Cap>& m, char* buffer, std::size_t capacity,
                            std::size_t* length) {
  using namespace detail;
  if (length == nullptr || (buffer == nullptr && capacity > 0)) return WriteStatus::null_argument;
  *length = 0;
  const LoadStatus v = validate_model_set(m, nullptr);
  if (v == LoadStatus::unsupported_feature) return WriteStatus::unsupported_feature;
  if (v != LoadStatus::ok) return WriteStatus::invalid_model;

  Sink s{buffer, buffer + capacity};
  s.put("indicial-coef ");
  s.put_int(coef_file_version);
  s.put("\naxis ");
  s.put(axis_name(m.axis));
  s.put("\nreference_length_m ");
  s.put_double(m.reference_length_m);
  s.put("\nairspeed_mps ");
  s.put_double(m.airspeed_mps);
  s.put("\nalpha0_rad ");
  s.put_double(m.alpha0_rad);
  s.put("\nenvelope_rad ");
  s.put_double(m.x_min_rad);
  s.put_char(' ');
  s.put_double(m.x_max_rad);
  s.put_char('\n');
  for (int c = 0; c < m.n_coefficients; ++c) {
    const CoefficientModel<double, Cap>& cm = m.coefficients[c];
    s.put("coefficient ");
    s.put(cm.name);
    s.put_char('\n');
    if (cm.static_curve.kind == StaticKind::table) {
      for (int i = 0; i < cm.static_curve.n_table; ++i) {
        s.put("static_table_point ");
        s.put_double(cm.static_curve.table_x_rad[i]);
        s.put_char(' ');
        s.put_double(cm.static_curve.table_value[i]);
        s.put_char('\n');
      }
    } else {
      write_spline(s, cm.static_curve.polynomial, "static_poly", "static_knot", 0);
    }
    write_spline(s, cm.static_correction, "static_corr_poly", "static_corr_knot", 0);
    write_spline(s, cm.rotary, "rotary_poly", "rotary_knot", 0);
    write_spline(s, cm.a, "a_poly", "a_knot", 0);
    for (int j = 0; j < cm.n_lags; ++j) {
      write_spline(s, cm.lags[j].b, "lag_poly", "lag_knot", j + 1);
      if (j > 0) {  // lag 1's gain is 1 by definition and never written
        s.put("lag_gain ");
        s.put_int(j + 1);
        s.put_char(' ');
        s.put_double(cm.lags[j].gain);
        s.put_char('\n');
      }
    }
    if (differs_from_positive_zero(cm.con)) {
      s.put("con ");
      s.put_double(cm.con);
      s.put_char('\n');
    }
    // Why not when +0: files of undelayed models stay byte-identical to those written before
    // delays were supported (-0 is written so that it reads back bit for bit).
    if (differs_from_positive_zero(cm.delay_s)) {
      s.put("delay_s ");
      s.put_double(cm.delay_s);
      s.put_char('\n');
    }
    s.put("end_coefficient\n");
  }
  if (s.overflow) return WriteStatus::buffer_too_small;
  const std::size_t body_length = static_cast<std::size_t>(s.p - buffer);
  const std::uint32_t crc = crc32(buffer, body_length);
  s.put("checksum ");
  const char* hex = "0123456789abcdef";
  for (int shift = 28; shift >= 0; shift -= 4) s.put_char(hex[(crc >> shift) & 0xFu]);
  s.put_char('\n');
  if (s.overflow) return WriteStatus::buffer_too_small;
  *length = static_cast<std::size_t>(s.p - buffer);
  return WriteStatus::ok;
}

}  // namespace indicial
