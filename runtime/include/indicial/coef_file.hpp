// indicial/coef_file.hpp -- the coefficient file (.coef, versions 1 and 2): parse, validate, write.
//
// What it is for
// --------------
// A fitted model travels from the offline fitter to the embedded runtime as a short text
// file: human-readable, diffable, versioned and protected by a CRC-32. This header reads and
// writes that file with no heap, no exceptions and no RTTI, so the same code runs inside a
// flight simulator's real-time loop, in the `indicial` command line and in the tests. The
// format is specified in docs/architecture.md ("The coefficient file"). It is also the
// runtime's text entry point: Predictor::load(text) and load_runtime_model(text) are defined
// here, so that runtime.hpp (the step path, and everything a codegen-only firmware includes)
// has no parser and no <charconv>. The parser is table-driven: the keys and their readers
// are listed in detail::find_header_key and detail::find_block_key.
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
//    DefaultCapacity that is 13376 bytes (1.4 KB of it per coefficient for the dynamic-stall parameters) (GCC 12, x86-64); call it at initialisation, not from an interrupt.
// 2. The parser checks the file (syntax, capacity, finite values, ordering, the checksum), not
//    the dynamics: that b_j(x) > 0 over the envelope is checked by Predictor::load
//    (runtime.hpp, validate_for_runtime). Use the Predictor, not the bare parser, to run.
// 3. The checksum covers every byte before the `checksum` line, comments included: editing a
//    file by hand means recomputing it (`indicial coef check` prints the expected value). A
//    file whose only change is LF -> CRLF line ends still matches (crc32_lf).
// 4. write_coef_file writes exactly *length bytes and no terminating NUL. Numbers are written
//    by std::to_chars in their shortest round-trip form, so write -> parse -> write is
//    byte-identical and every double comes back bit for bit (including -0).
// 5. delay_s (the pure delay of a coefficient's unsteady forcing, s at the reference
//    airspeed) must be finite and >= 0; it is written only when it is not +0, after `con`.
//    (Versions before delay support refused a nonzero delay with unsupported_feature; that
//    value is kept in the enums so their numbering and callers stay valid, but nothing
//    returns it now.)
// 6. Version 2 is version 1 plus the dynamic-stall families' keys (sep_*, vortex_*; model.hpp's
//    StallModel), allowed only in a file that says `indicial-coef 2`. The writer writes
//    version 2 only for a model with a family: every other model is written byte for byte as
//    before. A family is carried by a block that gives any of its keys, and then must give
//    every key it needs (checked at end_coefficient).
#pragma once

#include <charconv>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <system_error>

#include "indicial/model.hpp"
#include "indicial/model_check.hpp"
#include "indicial/runtime.hpp"

// Defined so that a translation unit can prove it does not include the parser
// (tests/test_codegen.cpp compiles one that must not).
#define INDICIAL_COEF_FILE_HPP_INCLUDED 1

namespace indicial {

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

// The format versions this header reads and writes: version 1 is the report's model; version 2
// adds the dynamic-stall families' keys (sep_*, vortex_*), and is written only for a model
// that uses a family, so a model without one is written byte for byte as before (version 1).
inline constexpr int coef_file_version = 1;
inline constexpr int coef_file_version_stall = 2;

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

// The same CRC over the bytes with each '\r' that precedes a '\n' left out: the checksum of
// the file as written (LF) after a Windows checkout or editor turned it into CRLF (git's
// core.autocrlf), which the parser accepts as well as crc32 of the bytes themselves. No
// other byte is skipped, so any other edit still changes it.
inline std::uint32_t crc32_lf(const char* data, std::size_t n) {
  std::uint32_t crc = ~std::uint32_t{0};
  for (std::size_t i = 0; i < n; ++i) {
    if (data[i] == '\r' && i + 1 < n && data[i + 1] == '\n') continue;
    const std::uint32_t byte = static_cast<unsigned char>(data[i]);
    crc = detail::crc32_table.entry[(crc ^ byte) & 0xFFu] ^ (crc >> 8);
  }
  return ~crc;
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
  seen_sep_polar = 1u << 11,       // the dynamic-stall families' keys (version 2)
  seen_sep_time = 1u << 12,
  seen_sep_cp = 1u << 13,
  seen_sep_corr_poly = 1u << 14,
  seen_vortex_shedding = 1u << 15,
  seen_vortex_time = 1u << 20,
  seen_vortex_clock = 1u << 21,
  seen_vortex_output = 1u << 22,
  seen_sep_reattach = 1u << 23,
  seen_sep_forcing = 1u << 28,
  seen_sep_hysteresis = 1u << 29,
  seen_sep_lag_limit = 1u << 30,
  seen_lag_poly0 = 1u << 16,  // + j for lag j (up to 4 lags)
  seen_lag_gain0 = 1u << 24,  // + j
};

// The outcome of reading one key's values: a status, its reason, and which single-occurrence
// bit the key sets (0 for keys that may repeat).
struct KeyRead {
  LoadStatus status = LoadStatus::ok;
  const char* reason = "";
  unsigned once_bit = 0;
};

inline KeyRead key_read(LoadStatus s, const char* reason, unsigned once_bit) {
  KeyRead r;
  r.status = s;
  r.reason = reason;
  r.once_bit = once_bit;
  return r;
}

// --- Header keys (before the first coefficient block) ------------------------------------

template <class Cap>
inline KeyRead read_axis(ModelSet<double, Cap>& m, Tokens& t) {
  const char* vb = nullptr;
  const char* ve = nullptr;
  if (!t.next(&vb, &ve) || !t.at_end())
    return key_read(LoadStatus::syntax_error, "axis needs one value", seen_axis);
  if (token_is(vb, ve, "pitch")) m.axis = Axis::pitch;
  else if (token_is(vb, ve, "roll")) m.axis = Axis::roll;
  else if (token_is(vb, ve, "yaw")) m.axis = Axis::yaw;
  else return key_read(LoadStatus::invalid_value, "axis must be pitch, roll or yaw", seen_axis);
  return key_read(LoadStatus::ok, "", seen_axis);
}

// One positive number (reference_length_m, airspeed_mps).
inline KeyRead read_positive(Tokens& t, double* v, const char* not_positive, unsigned bit) {
  const char* reason = "";
  const LoadStatus st = read_numbers(t, v, 1, &reason);
  if (st != LoadStatus::ok) return key_read(st, reason, bit);
  if (!(*v > 0.0)) return key_read(LoadStatus::invalid_value, not_positive, bit);
  return key_read(LoadStatus::ok, "", bit);
}

template <class Cap>
inline KeyRead read_length(ModelSet<double, Cap>& m, Tokens& t) {
  return read_positive(t, &m.reference_length_m, "reference_length_m must be > 0", seen_length);
}

template <class Cap>
inline KeyRead read_airspeed(ModelSet<double, Cap>& m, Tokens& t) {
  return read_positive(t, &m.airspeed_mps, "airspeed_mps must be > 0", seen_airspeed);
}

template <class Cap>
inline KeyRead read_alpha0(ModelSet<double, Cap>& m, Tokens& t) {
  const char* reason = "";
  const LoadStatus st = read_numbers(t, &m.alpha0_rad, 1, &reason);
  return key_read(st, reason, seen_alpha0);
}

template <class Cap>
inline KeyRead read_envelope(ModelSet<double, Cap>& m, Tokens& t) {
  double v[2] = {0.0, 0.0};
  const char* reason = "";
  const LoadStatus st = read_numbers(t, v, 2, &reason);
  if (st != LoadStatus::ok) return key_read(st, reason, seen_envelope);
  if (!(v[0] < v[1]))
    return key_read(LoadStatus::invalid_value, "envelope_rad: min must be < max", seen_envelope);
  m.x_min_rad = v[0];
  m.x_max_rad = v[1];
  return key_read(LoadStatus::ok, "", seen_envelope);
}

template <class Cap>
struct HeaderKey {
  const char* key;
  KeyRead (*read)(ModelSet<double, Cap>&, Tokens&);
};

template <class Cap>
inline const HeaderKey<Cap>* find_header_key(const char* b, const char* e) {
  static const HeaderKey<Cap> keys[] = {
      {"axis", &read_axis<Cap>},           {"reference_length_m", &read_length<Cap>},
      {"airspeed_mps", &read_airspeed<Cap>}, {"alpha0_rad", &read_alpha0<Cap>},
      {"envelope_rad", &read_envelope<Cap>}};
  for (const HeaderKey<Cap>& k : keys)
    if (token_is(b, e, k.key)) return &k;
  return nullptr;
}

// --- Keys inside a coefficient block -------------------------------------------------------

template <class Cap>
using CoefSpline = typename CoefficientModel<double, Cap>::SplineT;

// `<spline>_poly` and `<spline>_knot` of the correction, rotary and a(x) splines.
template <class Cap, CoefSpline<Cap> CoefficientModel<double, Cap>::*Member, unsigned Bit>
inline KeyRead read_member_poly(CoefficientModel<double, Cap>& cm, Tokens& t, int*) {
  const char* reason = "";
  const LoadStatus st = read_poly(t, &(cm.*Member), &reason);
  return key_read(st, reason, Bit);
}

template <class Cap, CoefSpline<Cap> CoefficientModel<double, Cap>::*Member>
inline KeyRead read_member_knot(CoefficientModel<double, Cap>& cm, Tokens& t, int*) {
  const char* reason = "";
  const LoadStatus st = read_knot(t, &(cm.*Member), &reason);
  return key_read(st, reason, 0);
}

// `static_poly` and `static_knot`: refused once the static curve is a table.
enum class SplineItem : int { poly = 0, knot = 1 };

template <class Cap, SplineItem Item>
inline KeyRead read_static_spline(CoefficientModel<double, Cap>& cm, Tokens& t, int*) {
  if (cm.static_curve.kind == StaticKind::table)
    return key_read(LoadStatus::invalid_value, "static curve given both as table and polynomial", 0);
  const char* reason = "";
  const LoadStatus st = Item == SplineItem::poly ? read_poly(t, &cm.static_curve.polynomial, &reason)
                                                 : read_knot(t, &cm.static_curve.polynomial, &reason);
  return key_read(st, reason, Item == SplineItem::poly ? seen_static_poly : 0u);
}

template <class Cap>
inline KeyRead read_table_point(CoefficientModel<double, Cap>& cm, Tokens& t, int*) {
  auto& sc = cm.static_curve;
  if (sc.polynomial.n_powers != 0 || sc.polynomial.n_knots != 0)
    return key_read(LoadStatus::invalid_value, "static curve given both as polynomial and table", 0);
  double v[2] = {0.0, 0.0};
  const char* reason = "";
  const LoadStatus st = read_numbers(t, v, 2, &reason);
  if (st != LoadStatus::ok) return key_read(st, reason, 0);
  if (sc.n_table >= Cap::max_table_points)
    return key_read(LoadStatus::over_capacity, "more static table rows than the capacity allows", 0);
  if (sc.n_table > 0 && !(v[0] > sc.table_x_rad[sc.n_table - 1]))
    return key_read(LoadStatus::invalid_value, "static table x_rad must be strictly increasing", 0);
  sc.kind = StaticKind::table;
  sc.table_x_rad[sc.n_table] = v[0];
  sc.table_value[sc.n_table] = v[1];
  ++sc.n_table;
  return key_read(LoadStatus::ok, "", 0);
}

// `lag_poly j ...`, `lag_knot j ...`, `lag_gain j c`: the lag index first (0-based to *lag).
enum class LagItem : int { poly = 0, knot = 1, gain = 2 };

template <class Cap, LagItem Item>
inline KeyRead read_lag(CoefficientModel<double, Cap>& cm, Tokens& t, int* lag) {
  const char* reason = "";
  int j = 0;
  LoadStatus st = read_lag_index<Cap>(t, &j, &reason);
  if (st != LoadStatus::ok) return key_read(st, reason, 0);
  *lag = j;
  if (Item == LagItem::poly) {
    st = read_poly(t, &cm.lags[j].b, &reason);
    return key_read(st, reason, seen_lag_poly0 << j);
  }
  if (Item == LagItem::knot) {
    st = read_knot(t, &cm.lags[j].b, &reason);
    return key_read(st, reason, 0);
  }
  double g = 0.0;
  st = read_numbers(t, &g, 1, &reason);
  if (st != LoadStatus::ok) return key_read(st, reason, seen_lag_gain0 << j);
  // Why: c_1 = 1 by definition (a(x) absorbs the first lag's amplitude).
  if (j == 0 && g != 1.0)
    return key_read(LoadStatus::invalid_value, "lag 1's gain is 1 by definition", seen_lag_gain0 << j);
  cm.lags[j].gain = g;
  return key_read(LoadStatus::ok, "", seen_lag_gain0 << j);
}

template <class Cap>
inline KeyRead read_con(CoefficientModel<double, Cap>& cm, Tokens& t, int*) {
  const char* reason = "";
  const LoadStatus st = read_numbers(t, &cm.con, 1, &reason);
  return key_read(st, reason, seen_con);
}

template <class Cap>
inline KeyRead read_delay(CoefficientModel<double, Cap>& cm, Tokens& t, int*) {
  const char* reason = "";
  double d = 0.0;
  const LoadStatus st = read_numbers(t, &d, 1, &reason);
  if (st != LoadStatus::ok) return key_read(st, reason, seen_delay);
  if (d < 0.0)
    return key_read(LoadStatus::invalid_value, "delay_s must be >= 0 (a delay, not a prediction)",
                    seen_delay);
  cm.delay_s = d;
  return key_read(LoadStatus::ok, "", seen_delay);
}

// --- The dynamic-stall families' keys (version 2; model.hpp's StallModel) -----------------
// Each reads a fixed number of values and checks what one line can check (the ranges); which
// family a block carries, and that a family's keys are all there, is decided at
// end_coefficient (close_block).

// What a value must be, with the reason given when it is not.
struct ValueRule {
  enum class Kind : int { any = 0, positive = 1, non_negative = 2, unit_interval = 3 } kind;
  const char* reason;
};

inline bool obeys(const ValueRule& r, double v) {
  switch (r.kind) {
    case ValueRule::Kind::any: return true;
    case ValueRule::Kind::positive: return v > 0.0;
    case ValueRule::Kind::non_negative: return v >= 0.0;
    case ValueRule::Kind::unit_interval: return v >= 0.0 && v <= 1.0;
  }
  return false;
}

// Exactly N values, each obeying its rule, into *dest[i] (written only if all are good).
template <int N>
inline KeyRead read_ruled(Tokens& t, const ValueRule (&rules)[N], double* const (&dest)[N], unsigned bit) {
  double v[N];
  const char* reason = "";
  const LoadStatus st = read_numbers(t, v, N, &reason);
  if (st != LoadStatus::ok) return key_read(st, reason, bit);
  for (int i = 0; i < N; ++i)
    if (!obeys(rules[i], v[i])) return key_read(LoadStatus::invalid_value, rules[i].reason, bit);
  for (int i = 0; i < N; ++i) *dest[i] = v[i];
  return key_read(LoadStatus::ok, "", bit);
}

constexpr ValueRule any_value{ValueRule::Kind::any, ""};

// `sep_polar C_Na zero_lift_angle_rad`: the attached polar the Kirchhoff output uses.
template <class Cap>
inline KeyRead read_sep_polar(CoefficientModel<double, Cap>& cm, Tokens& t, int*) {
  auto& p = cm.stall.separation;
  static constexpr ValueRule rules[2] = {
      {ValueRule::Kind::positive, "sep_polar: the normal-force slope must be > 0"}, any_value};
  return read_ruled(t, rules, {&p.normal_force_slope_per_rad, &p.zero_lift_angle_rad}, seen_sep_polar);
}

// `sep_f0_point x_rad f0`: one row of the static separation table (strictly increasing x).
template <class Cap>
inline KeyRead read_sep_f0_point(CoefficientModel<double, Cap>& cm, Tokens& t, int*) {
  auto& sep = cm.stall.separation;
  double x = 0.0;
  double f0 = 0.0;
  static constexpr ValueRule rules[2] = {
      any_value, {ValueRule::Kind::unit_interval, "sep_f0_point: f0 must be in [0, 1]"}};
  const KeyRead r = read_ruled(t, rules, {&x, &f0}, 0);
  if (r.status != LoadStatus::ok) return r;
  if (sep.n_f0 >= Cap::max_table_points)
    return key_read(LoadStatus::over_capacity, "more sep_f0_point rows than the capacity allows", 0);
  if (sep.n_f0 > 0 && !(x > sep.f0_x_rad[sep.n_f0 - 1]))
    return key_read(LoadStatus::invalid_value, "sep_f0_point x_rad must be strictly increasing", 0);
  sep.f0_x_rad[sep.n_f0] = x;
  sep.f0_value[sep.n_f0] = f0;
  ++sep.n_f0;
  return r;
}

// `sep_f0_corr_poly` / `sep_f0_corr_knot`: the fitted correction of f0.
template <class Cap, SplineItem Item>
inline KeyRead read_sep_f0_corr(CoefficientModel<double, Cap>& cm, Tokens& t, int*) {
  const char* reason = "";
  auto* s = &cm.stall.separation.f0_correction;
  const LoadStatus st = Item == SplineItem::poly ? read_poly(t, s, &reason) : read_knot(t, s, &reason);
  return key_read(st, reason, Item == SplineItem::poly ? seen_sep_corr_poly : 0u);
}

// `sep_time_constants T1 T2` (semichord times l / V).
template <class Cap>
inline KeyRead read_sep_time(CoefficientModel<double, Cap>& cm, Tokens& t, int*) {
  auto& p = cm.stall.separation;
  static constexpr ValueRule rules[2] = {
      {ValueRule::Kind::positive, "sep_time_constants: T1 must be > 0"},
      {ValueRule::Kind::non_negative, "sep_time_constants: T2 must be >= 0"}};
  return read_ruled(t, rules, {&p.tau1_semichords, &p.tau2_semichords}, seen_sep_time);
}

// `sep_reattachment T1r` (optional; semichord times l / V): the separation state's time
// constant while the flow reattaches. Without the key T1r is 0: T1 both ways.
template <class Cap>
inline KeyRead read_sep_reattach(CoefficientModel<double, Cap>& cm, Tokens& t, int*) {
  static constexpr ValueRule rules[1] = {{ValueRule::Kind::positive, "sep_reattachment: T1r must be > 0"}};
  return read_ruled(t, rules, {&cm.stall.separation.tau1_reattach_semichords}, seen_sep_reattach);
}

// `sep_hysteresis dxr_rad` (optional; rad): the static hysteresis of stall (model.hpp): the
// flow reattaches toward the static separation dxr further from alpha_0, held in between.
// Without the key dxr is 0: no hysteresis. At most 20 deg (check_stall_parameters).
template <class Cap>
inline KeyRead read_sep_hysteresis(CoefficientModel<double, Cap>& cm, Tokens& t, int*) {
  static constexpr ValueRule rules[1] = {{ValueRule::Kind::positive, "sep_hysteresis: dxr_rad must be > 0"}};
  return read_ruled(t, rules, {&cm.stall.separation.reattach_shift_rad}, seen_sep_hysteresis);
}

// `sep_lag_limit D_rad` (optional; rad): the limit of the forcing angle's lag (model.hpp): x_e =
// x - D tanh(T2 (l/V) x' / D). Without the key D is 0: no limit. At most 20 deg, and only with
// the delay forcing lag (check_stall_parameters).
template <class Cap>
inline KeyRead read_sep_lag_limit(CoefficientModel<double, Cap>& cm, Tokens& t, int*) {
  static constexpr ValueRule rules[1] = {{ValueRule::Kind::positive, "sep_lag_limit: D_rad must be > 0"}};
  return read_ruled(t, rules, {&cm.stall.separation.lag_limit_rad}, seen_sep_lag_limit);
}

// `sep_forcing_lag first_order` (optional; model.hpp's ForcingLag): how T2 lags the forcing
// angle. Without the key, delay (x - T2 (l/V) x', what files before the key meant).
template <class Cap>
inline KeyRead read_sep_forcing(CoefficientModel<double, Cap>& cm, Tokens& t, int*) {
  const char* vb = nullptr;
  const char* ve = nullptr;
  if (!t.next(&vb, &ve) || !t.at_end())
    return key_read(LoadStatus::syntax_error, "sep_forcing_lag needs one value", seen_sep_forcing);
  for (const ForcingLag l : {ForcingLag::delay, ForcingLag::first_order}) {  // model.hpp's spelling
    if (!token_is(vb, ve, forcing_lag_name(l))) continue;
    cm.stall.separation.forcing_lag = l;
    return key_read(LoadStatus::ok, "", seen_sep_forcing);
  }
  return key_read(LoadStatus::invalid_value, "sep_forcing_lag must be delay or first_order", seen_sep_forcing);
}

// `sep_cp k0 k1 k2`: the centre-of-pressure shape of the output.
template <class Cap>
inline KeyRead read_sep_cp(CoefficientModel<double, Cap>& cm, Tokens& t, int*) {
  auto& p = cm.stall.separation;
  static constexpr ValueRule rules[3] = {any_value, any_value, any_value};
  return read_ruled(t, rules, {&p.cp_k0, &p.cp_k1, &p.cp_k2}, seen_sep_cp);
}

// `vortex_shedding C_N1 width`, `vortex_time_constants T_v T_vl`, `vortex_clock width reset`
// (semichord times), `vortex_output c_v x_v`.
enum class VortexItem : int { shedding = 0, time_constants = 1, clock = 2, output = 3 };

template <class Cap, VortexItem Item>
inline KeyRead read_vortex(CoefficientModel<double, Cap>& cm, Tokens& t, int*) {
  auto& v = cm.stall.vortex;
  static constexpr ValueRule shedding[2] = {
      {ValueRule::Kind::positive, "vortex_shedding: C_N1 must be > 0"},
      {ValueRule::Kind::positive, "vortex_shedding: the width must be > 0"}};
  static constexpr ValueRule times[2] = {
      {ValueRule::Kind::positive, "vortex_time_constants: T_v must be > 0"},
      {ValueRule::Kind::positive, "vortex_time_constants: T_vl must be > 0"}};
  static constexpr ValueRule clock[2] = {
      {ValueRule::Kind::positive, "vortex_clock: the width must be > 0"},
      {ValueRule::Kind::positive, "vortex_clock: the reset time must be > 0"}};
  static constexpr ValueRule output[2] = {any_value, any_value};
  switch (Item) {
    case VortexItem::shedding:
      return read_ruled(t, shedding, {&v.shedding_threshold, &v.shedding_width}, seen_vortex_shedding);
    case VortexItem::time_constants:
      return read_ruled(t, times, {&v.decay_semichords, &v.travel_semichords}, seen_vortex_time);
    case VortexItem::clock:
      return read_ruled(t, clock, {&v.clock_width_semichords, &v.clock_reset_semichords}, seen_vortex_clock);
    case VortexItem::output: break;
  }
  return read_ruled(t, output, {&v.lift_gain, &v.cp_travel}, seen_vortex_output);
}

template <class Cap>
struct BlockKey {
  const char* key;
  KeyRead (*read)(CoefficientModel<double, Cap>&, Tokens&, int* lag_index0);
  int since_version = 1;  // the file version that introduced the key
};

template <class Cap>
inline const BlockKey<Cap>* find_block_key(const char* b, const char* e) {
  using CM = CoefficientModel<double, Cap>;
  static const BlockKey<Cap> keys[] = {
      {"static_poly", &read_static_spline<Cap, SplineItem::poly>},
      {"static_knot", &read_static_spline<Cap, SplineItem::knot>},
      {"static_table_point", &read_table_point<Cap>},
      {"static_corr_poly", &read_member_poly<Cap, &CM::static_correction, seen_corr_poly>},
      {"static_corr_knot", &read_member_knot<Cap, &CM::static_correction>},
      {"rotary_poly", &read_member_poly<Cap, &CM::rotary, seen_rotary_poly>},
      {"rotary_knot", &read_member_knot<Cap, &CM::rotary>},
      {"a_poly", &read_member_poly<Cap, &CM::a, seen_a_poly>},
      {"a_knot", &read_member_knot<Cap, &CM::a>},
      {"lag_poly", &read_lag<Cap, LagItem::poly>},
      {"lag_knot", &read_lag<Cap, LagItem::knot>},
      {"lag_gain", &read_lag<Cap, LagItem::gain>},
      {"con", &read_con<Cap>},
      {"delay_s", &read_delay<Cap>},
      {"sep_polar", &read_sep_polar<Cap>, coef_file_version_stall},
      {"sep_f0_point", &read_sep_f0_point<Cap>, coef_file_version_stall},
      {"sep_f0_corr_poly", &read_sep_f0_corr<Cap, SplineItem::poly>, coef_file_version_stall},
      {"sep_f0_corr_knot", &read_sep_f0_corr<Cap, SplineItem::knot>, coef_file_version_stall},
      {"sep_time_constants", &read_sep_time<Cap>, coef_file_version_stall},
      {"sep_reattachment", &read_sep_reattach<Cap>, coef_file_version_stall},
      {"sep_hysteresis", &read_sep_hysteresis<Cap>, coef_file_version_stall},
      {"sep_lag_limit", &read_sep_lag_limit<Cap>, coef_file_version_stall},
      {"sep_forcing_lag", &read_sep_forcing<Cap>, coef_file_version_stall},
      {"sep_cp", &read_sep_cp<Cap>, coef_file_version_stall},
      {"vortex_shedding", &read_vortex<Cap, VortexItem::shedding>, coef_file_version_stall},
      {"vortex_time_constants", &read_vortex<Cap, VortexItem::time_constants>, coef_file_version_stall},
      {"vortex_clock", &read_vortex<Cap, VortexItem::clock>, coef_file_version_stall},
      {"vortex_output", &read_vortex<Cap, VortexItem::output>, coef_file_version_stall}};
  for (const BlockKey<Cap>& k : keys)
    if (token_is(b, e, k.key)) return &k;
  return nullptr;
}

// --- The body: header, then coefficient blocks ---------------------------------------------

template <class Cap>
struct BodyState {
  ModelSet<double, Cap> m{};
  unsigned header_seen = 0;
  unsigned block_seen = 0;
  int max_lag_index0 = -1;
  CoefficientModel<double, Cap>* cm = nullptr;  // the open block, if any
  std::size_t block_line = 0;
  int version = coef_file_version;  // of the version line
};

template <class Cap>
inline LoadStatus parse_header_line(BodyState<Cap>& b, const HeaderKey<Cap>& key, Tokens& t,
                                    std::size_t line, ParseDiagnostic* diag) {
  if (b.cm != nullptr || b.m.n_coefficients > 0)
    return refuse(diag, line, "header key after a coefficient block", LoadStatus::syntax_error);
  const KeyRead r = key.read(b.m, t);
  if (r.status != LoadStatus::ok) return refuse(diag, line, r.reason, r.status);
  if (b.header_seen & r.once_bit) return refuse(diag, line, "key given twice", LoadStatus::syntax_error);
  b.header_seen |= r.once_bit;
  return LoadStatus::ok;
}

template <class Cap>
inline LoadStatus open_block(BodyState<Cap>& b, Tokens& t, std::size_t line, ParseDiagnostic* diag) {
  if (b.cm != nullptr)
    return refuse(diag, line, "coefficient block opened inside another (missing end_coefficient)",
                  LoadStatus::syntax_error);
  static const struct { unsigned bit; const char* reason; } required[] = {
      {seen_axis, "missing 'axis' before the first coefficient"},
      {seen_length, "missing 'reference_length_m' before the first coefficient"},
      {seen_airspeed, "missing 'airspeed_mps' before the first coefficient"},
      {seen_alpha0, "missing 'alpha0_rad' before the first coefficient"},
      {seen_envelope, "missing 'envelope_rad' before the first coefficient"}};
  for (const auto& r : required)
    if (!(b.header_seen & r.bit)) return refuse(diag, line, r.reason, LoadStatus::syntax_error);
  if (b.m.n_coefficients >= Cap::max_coefficients)
    return refuse(diag, line, "more coefficients than the capacity allows", LoadStatus::over_capacity);
  const char* nb = nullptr;
  const char* ne = nullptr;
  if (!t.next(&nb, &ne) || !t.at_end())
    return refuse(diag, line, "coefficient needs one name", LoadStatus::syntax_error);
  CoefficientModel<double, Cap>* cm = &b.m.coefficients[b.m.n_coefficients];
  b.cm = cm;
  const std::size_t name_len = static_cast<std::size_t>(ne - nb);
  if (name_len >= sizeof cm->name)
    return refuse(diag, line, "coefficient name longer than 7 characters", LoadStatus::syntax_error);
  for (std::size_t i = 0; i < name_len; ++i) cm->name[i] = nb[i];
  cm->name[name_len] = '\0';
  if (!valid_coefficient_name(cm->name, sizeof cm->name))
    return refuse(diag, line, "coefficient name must be letters, digits or _", LoadStatus::syntax_error);
  for (int d = 0; d < b.m.n_coefficients; ++d) {
    if (names_equal(cm->name, b.m.coefficients[d].name))
      return refuse(diag, line, "coefficient name given twice", LoadStatus::invalid_value);
  }
  b.block_seen = 0;
  b.max_lag_index0 = -1;
  b.block_line = line;
  return LoadStatus::ok;
}

// Which dynamic-stall families the block carries, from the keys it gave: a family is used when
// any of its keys is given, and then every key it needs must be (the vortex needs the
// separation family too; sep_f0_corr_* are optional).
template <class Cap>
inline LoadStatus stall_families_of_block(unsigned seen, CoefficientModel<double, Cap>* cm,
                                          std::size_t line, ParseDiagnostic* diag) {
  const unsigned sep_required = seen_sep_polar | seen_sep_time | seen_sep_cp;
  const unsigned vortex_all = seen_vortex_shedding | seen_vortex_time | seen_vortex_clock | seen_vortex_output;
  const bool any_sep = (seen & (sep_required | seen_sep_corr_poly | seen_sep_reattach | seen_sep_forcing |
                                seen_sep_hysteresis | seen_sep_lag_limit)) != 0 ||
                       cm->stall.separation.n_f0 > 0 || cm->stall.separation.f0_correction.n_knots > 0;
  const bool any_vortex = (seen & vortex_all) != 0;
  if (!any_sep && !any_vortex) return LoadStatus::ok;
  if ((seen & sep_required) != sep_required || cm->stall.separation.n_f0 < 2)
    return refuse(diag, line,
                  "the separation family needs sep_polar, sep_time_constants, sep_cp and at least 2 "
                  "sep_f0_point rows (the vortex family needs it too)",
                  LoadStatus::syntax_error);
  if (any_vortex && (seen & vortex_all) != vortex_all)
    return refuse(diag, line,
                  "the vortex family needs vortex_shedding, vortex_time_constants, vortex_clock and "
                  "vortex_output",
                  LoadStatus::syntax_error);
  cm->stall.families = any_vortex ? StallFamilies::separation_and_vortex : StallFamilies::separation;
  return LoadStatus::ok;
}

template <class Cap>
inline LoadStatus close_block(BodyState<Cap>& b, Tokens& t, std::size_t line, ParseDiagnostic* diag) {
  if (!t.at_end()) return refuse(diag, line, "extra text after end_coefficient", LoadStatus::syntax_error);
  const LoadStatus families = stall_families_of_block(b.block_seen, b.cm, line, diag);
  if (families != LoadStatus::ok) return families;
  auto& sc = b.cm->static_curve;
  b.cm->n_lags = b.max_lag_index0 < 0 ? 1 : b.max_lag_index0 + 1;
  if (sc.kind == StaticKind::table) {
    if (sc.n_table < 2)
      return refuse(diag, line, "a static table needs at least 2 rows", LoadStatus::invalid_value);
    prepare_static_table(sc);
  }
  ++b.m.n_coefficients;
  b.cm = nullptr;
  return LoadStatus::ok;
}

template <class Cap>
inline LoadStatus parse_block_line(BodyState<Cap>& b, const BlockKey<Cap>& key, Tokens& t,
                                   std::size_t line, ParseDiagnostic* diag) {
  if (key.since_version > b.version)
    return refuse(diag, line, "a dynamic-stall key (sep_*, vortex_*) needs 'indicial-coef 2'",
                  LoadStatus::syntax_error);
  int lag = -1;
  const KeyRead r = key.read(*b.cm, t, &lag);
  if (lag > b.max_lag_index0) b.max_lag_index0 = lag;
  if (r.status != LoadStatus::ok) return refuse(diag, line, r.reason, r.status);
  if (r.once_bit != 0) {
    if (b.block_seen & r.once_bit) return refuse(diag, line, "key given twice", LoadStatus::syntax_error);
    b.block_seen |= r.once_bit;
  }
  return LoadStatus::ok;
}

// One non-blank body line: dispatched on its first token.
template <class Cap>
inline LoadStatus parse_body_line(BodyState<Cap>& b, Tokens& t, std::size_t line, ParseDiagnostic* diag) {
  const char* kb = nullptr;
  const char* ke = nullptr;
  t.next(&kb, &ke);
  if (const HeaderKey<Cap>* h = find_header_key<Cap>(kb, ke)) return parse_header_line(b, *h, t, line, diag);
  if (token_is(kb, ke, "coefficient")) return open_block(b, t, line, diag);
  if (b.cm == nullptr) {
    if (token_is(kb, ke, "end_coefficient"))
      return refuse(diag, line, "end_coefficient without a block", LoadStatus::syntax_error);
    return refuse(diag, line, "unknown key", LoadStatus::syntax_error);
  }
  if (token_is(kb, ke, "end_coefficient")) return close_block(b, t, line, diag);
  if (const BlockKey<Cap>* k = find_block_key<Cap>(kb, ke)) return parse_block_line(b, *k, t, line, diag);
  return refuse(diag, line, "unknown key", LoadStatus::syntax_error);
}

// Where the body is and what protects it (steps 1 and 2 of parse_coef_file).
struct Frame {
  std::size_t body_first_line = 0;
  std::size_t body_start = 0;
  std::size_t checksum_start = 0;
  std::size_t checksum_line = 0;
};

// Empty input, null pointers, only whitespace.
inline LoadStatus check_input(const char* text, std::size_t length, const void* out,
                              ParseDiagnostic* diag) {
  if (out == nullptr) return refuse(diag, 0, "no output model given", LoadStatus::null_argument);
  if (length == 0) return refuse(diag, 0, "empty input", LoadStatus::empty_input);
  if (text == nullptr) return refuse(diag, 0, "null text with nonzero length", LoadStatus::null_argument);
  std::size_t i = 0;
  while (i < length && (text[i] == ' ' || text[i] == '\t' || text[i] == '\n' || text[i] == '\r')) ++i;
  if (i == length) return refuse(diag, 1, "only whitespace", LoadStatus::empty_input);
  return LoadStatus::ok;
}

// 1. The version line: the first line that is not blank or a comment. Checked before the
//    checksum because another version may protect itself differently.
inline LoadStatus read_version_line(LineCursor& cur, int* version_out, ParseDiagnostic* diag) {
  const char* b = nullptr;
  const char* e = nullptr;
  std::size_t start = 0;
  for (;;) {
    if (!cur.next(&b, &e, &start)) return refuse(diag, 1, "only comments", LoadStatus::empty_input);
    if (!is_ignorable(b, e)) break;
  }
  Tokens t{b, e};
  const char* kb = nullptr;
  const char* ke = nullptr;
  const char* reason = "";
  int version = 0;
  t.next(&kb, &ke);
  if (!token_is(kb, ke, "indicial-coef"))
    return refuse(diag, cur.number, "the first line must be 'indicial-coef 1' (or 2)", LoadStatus::syntax_error);
  if (!t.next(&kb, &ke) || parse_int(kb, ke, &version, &reason) != LoadStatus::ok || !t.at_end())
    return refuse(diag, cur.number, "bad version line", LoadStatus::syntax_error);
  if (version != coef_file_version && version != coef_file_version_stall)
    return refuse(diag, cur.number, "unsupported file version (this runtime reads versions 1 and 2)",
                  LoadStatus::wrong_version);
  *version_out = version;
  return LoadStatus::ok;
}

// The 8 lowercase hex digits of the checksum line.
inline LoadStatus read_checksum_value(Tokens& t, std::size_t line, std::uint32_t* crc,
                                      ParseDiagnostic* diag) {
  const char* hb = nullptr;
  const char* he = nullptr;
  if (!t.next(&hb, &he))
    return refuse(diag, line, "checksum line has no value (file truncated?)", LoadStatus::truncated);
  int digits = 0;
  for (const char* p = hb; p < he; ++p, ++digits) {
    const char ch = *p;
    unsigned v = 0;
    if (ch >= '0' && ch <= '9') v = static_cast<unsigned>(ch - '0');
    else if (ch >= 'a' && ch <= 'f') v = static_cast<unsigned>(ch - 'a' + 10);
    else return refuse(diag, line, "checksum must be 8 lowercase hex digits", LoadStatus::syntax_error);
    if (digits >= 8)
      return refuse(diag, line, "checksum must be 8 lowercase hex digits", LoadStatus::syntax_error);
    *crc = (*crc << 4) | v;
  }
  // Why truncated and not syntax_error: a file cut inside its last line ends here.
  if (digits < 8)
    return refuse(diag, line, "checksum has fewer than 8 digits (file truncated?)", LoadStatus::truncated);
  if (!t.at_end()) return refuse(diag, line, "extra text on the checksum line", LoadStatus::syntax_error);
  return LoadStatus::ok;
}

// 2. The checksum line: the first line whose first token is `checksum`; only blank lines may
//    follow it. Then the CRC of every byte before it.
inline LoadStatus find_checksum(const char* text, LineCursor scan, Frame* f, ParseDiagnostic* diag) {
  const char* b = nullptr;
  const char* e = nullptr;
  std::size_t start = 0;
  std::uint32_t stored_crc = 0;
  bool found = false;
  while (scan.next(&b, &e, &start)) {
    Tokens t{b, e};
    const char* kb = nullptr;
    const char* ke = nullptr;
    if (!found) {
      if (t.next(&kb, &ke) && token_is(kb, ke, "checksum")) {
        found = true;
        f->checksum_start = start;
        f->checksum_line = scan.number;
        const LoadStatus s = read_checksum_value(t, f->checksum_line, &stored_crc, diag);
        if (s != LoadStatus::ok) return s;
      }
    } else if (t.next(&kb, &ke)) {
      return refuse(diag, scan.number, "text after the checksum line", LoadStatus::syntax_error);
    }
  }
  if (!found) return refuse(diag, scan.number, "no checksum line (file truncated?)", LoadStatus::truncated);
  // The bytes as they are, or as written before a change of line ends (LF -> CRLF).
  if (crc32(text, f->checksum_start) != stored_crc && crc32_lf(text, f->checksum_start) != stored_crc)
    return refuse(diag, f->checksum_line, "checksum mismatch: the file is corrupted",
                  LoadStatus::checksum_mismatch);
  return LoadStatus::ok;
}

// 3. The body, between the version line and the checksum line.
template <class Cap>
inline LoadStatus parse_body(const char* text, const Frame& f, BodyState<Cap>& b, ParseDiagnostic* diag) {
  b.m.n_coefficients = 0;
  LineCursor body{text, f.checksum_start};
  body.pos = f.body_start;
  body.number = f.body_first_line - 1;
  const char* lb = nullptr;
  const char* le = nullptr;
  std::size_t start = 0;
  while (body.next(&lb, &le, &start)) {
    if (is_ignorable(lb, le)) continue;
    Tokens t{lb, le};
    const LoadStatus s = parse_body_line(b, t, body.number, diag);
    if (s != LoadStatus::ok) return s;
  }
  if (b.cm != nullptr)
    return refuse(diag, b.block_line, "coefficient block has no end_coefficient (file truncated?)",
                  LoadStatus::truncated);
  if (b.m.n_coefficients == 0) return refuse(diag, f.checksum_line, "no coefficient block", LoadStatus::syntax_error);
  // Belt and braces: the whole-model checks the writer and the runtime use.
  ParseDiagnostic whole;
  const LoadStatus v = validate_model_set(b.m, &whole);
  if (v != LoadStatus::ok) return refuse(diag, f.checksum_line, whole.reason, v);
  return LoadStatus::ok;
}

}  // namespace detail

// Parses and checks a coefficient file (docs/architecture.md); *out is written only on
// success. Table-driven: the keys and their readers are in detail::find_header_key and
// detail::find_block_key.
template <class Cap>
LoadStatus parse_coef_file(const char* text, std::size_t length, ModelSet<double, Cap>* out,
                           ParseDiagnostic* diag) {
  using namespace detail;
  LoadStatus s = check_input(text, length, out, diag);
  if (s != LoadStatus::ok) return s;
  LineCursor cur{text, length};
  int version = coef_file_version;
  if ((s = read_version_line(cur, &version, diag)) != LoadStatus::ok) return s;
  Frame f;
  f.body_first_line = cur.number + 1;
  f.body_start = cur.pos;
  if ((s = find_checksum(text, cur, &f, diag)) != LoadStatus::ok) return s;
  BodyState<Cap> b;
  b.version = version;
  if ((s = parse_body(text, f, b, diag)) != LoadStatus::ok) return s;
  *out = b.m;
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

// `key v0 v1 ...\n`
inline void write_values(Sink& s, const char* key, std::initializer_list<double> values) {
  s.put(key);
  for (double v : values) {
    s.put_char(' ');
    s.put_double(v);
  }
  s.put_char('\n');
}

// The dynamic-stall families of one block (version 2), in the order of the keys' table.
template <class Cap>
inline void write_stall_families(Sink& s, const StallModel<double, Cap>& st) {
  if (st.families == StallFamilies::none) return;
  const auto& sep = st.separation;
  write_values(s, "sep_polar", {sep.normal_force_slope_per_rad, sep.zero_lift_angle_rad});
  for (int i = 0; i < sep.n_f0; ++i) write_values(s, "sep_f0_point", {sep.f0_x_rad[i], sep.f0_value[i]});
  write_spline(s, sep.f0_correction, "sep_f0_corr_poly", "sep_f0_corr_knot", 0);
  write_values(s, "sep_time_constants", {sep.tau1_semichords, sep.tau2_semichords});
  if (sep.tau1_reattach_semichords > 0.0) write_values(s, "sep_reattachment", {sep.tau1_reattach_semichords});
  if (sep.reattach_shift_rad > 0.0) write_values(s, "sep_hysteresis", {sep.reattach_shift_rad});
  if (sep.lag_limit_rad > 0.0) write_values(s, "sep_lag_limit", {sep.lag_limit_rad});
  if (sep.forcing_lag != ForcingLag::delay) {
    s.put("sep_forcing_lag ");
    s.put(forcing_lag_name(sep.forcing_lag));
    s.put_char('\n');
  }
  write_values(s, "sep_cp", {sep.cp_k0, sep.cp_k1, sep.cp_k2});
  if (st.families != StallFamilies::separation_and_vortex) return;
  const auto& v = st.vortex;
  write_values(s, "vortex_shedding", {v.shedding_threshold, v.shedding_width});
  write_values(s, "vortex_time_constants", {v.decay_semichords, v.travel_semichords});
  write_values(s, "vortex_clock", {v.clock_width_semichords, v.clock_reset_semichords});
  write_values(s, "vortex_output", {v.lift_gain, v.cp_travel});
}

// The version a model is written in: 2 only when a coefficient uses a family.
template <class Cap>
inline int file_version_of(const ModelSet<double, Cap>& m) {
  for (int c = 0; c < m.n_coefficients; ++c)
    if (m.coefficients[c].stall.families != StallFamilies::none) return coef_file_version_stall;
  return coef_file_version;
}

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
  s.put_int(file_version_of(m));
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
    write_stall_families(s, cm.stall);
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

// ------------------------------------------------------------------------------------------
// Loading text into the runtime (runtime.hpp has no parser; these are its text entry points).
// ------------------------------------------------------------------------------------------

// Parses (no heap), validates and converts a coefficient file into a RuntimeModel; *out is
// written only on success. About 40 KB of stack with DefaultCapacity (runtime.hpp warning 1).
template <class Scalar, class Cap>
LoadStatus load_runtime_model(const char* text, std::size_t length, RuntimeModel<Scalar, Cap>* out,
                              ParseDiagnostic* diag = nullptr) {
  ModelSet<double, Cap> parsed;
  const LoadStatus s = parse_coef_file(text, length, &parsed, diag);
  if (s != LoadStatus::ok) return s;
  return make_runtime_model(parsed, out, diag);
}

template <class Scalar, class Cap>
LoadStatus Predictor<Scalar, Cap>::load(const char* text, std::size_t length, ParseDiagnostic* diag) {
  ModelSet<double, Cap> parsed;
  const LoadStatus s = parse_coef_file(text, length, &parsed, diag);
  if (s != LoadStatus::ok) return s;
  return load(parsed, diag);
}

}  // namespace indicial
