// indicial/model_check.hpp -- what a model must satisfy before the runtime steps it.
//
// What it is for
// --------------
// The load statuses (LoadStatus, ParseDiagnostic) and the structural checks of a ModelSet
// (counts within the capacity, finite values, ordered envelope and table, valid powers and
// names, lag 1's gain 1, delay finite and >= 0), shared by the coefficient-file parser and
// writer (coef_file.hpp), the runtime (runtime.hpp: make_runtime_model, check_runtime_model)
// and `indicial codegen`. It includes no parser: a translation unit that steps a generated
// model includes this header and runtime.hpp, never coef_file.hpp.
//
// Usage
// -----
//   indicial::ParseDiagnostic diag;
//   if (indicial::validate_model_set(model, &diag) != indicial::LoadStatus::ok)
//     printf("%s\n", diag.reason);
//
// Warnings
// --------
// 1. validate_model_set checks structure, not dynamics: b_j(x) > 0 over the envelope is
//    checked by runtime.hpp's validate_for_runtime (which calls this first).
// 2. `reason` strings are literals (no heap); `line` is 0 for a model built in code.
#pragma once

#include <cmath>
#include <cstddef>

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

// Where and why a load was refused. `reason` always points to a string literal (no heap);
// `line` is 1-based, 0 when the problem is not on one line (e.g. a ModelSet built in code).
struct ParseDiagnostic {
  std::size_t line = 0;
  const char* reason = "";
};

// Highest power allowed for a plus-function knot term (x - k)_+^p: the report uses 1 and 2;
// beyond 8 the term is numerically meaningless over an angle range of a few radians.
inline constexpr int max_knot_power = 8;

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

template <class Scalar, int P, int K>
inline LoadStatus check_spline(const Spline<Scalar, P, K>& s, const char** reason) {
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

// The dynamic-stall families' parameters: model.hpp's feasible set (check_stall_parameters,
// the one the fitter keeps its trial models in), a known family choice, the capacity of the
// separation table and a valid f0 correction spline.
inline const char* stall_check_reason(StallCheck c) {
  switch (c) {
    case StallCheck::valid: return "";
    case StallCheck::nonpositive_time_constant:
      return "dynamic stall: every time constant, width and reset time must be > 0 (T2 >= 0; T1r >= 0, 0: T1 both ways)";
    case StallCheck::nonpositive_threshold: return "vortex_shedding: C_N1 must be > 0";
    case StallCheck::bad_separation_table:
      return "sep_f0_point: at least 2 rows, x_rad strictly increasing, f0 in [0, 1]";
    case StallCheck::bad_hysteresis: return "sep_hysteresis: dxr_rad must be in [0, 0.349] (0 to 20 deg)";
    case StallCheck::bad_lag_limit:
      return "sep_lag_limit: D_rad must be in [0, 0.349] (0 to 20 deg), and only with the delay forcing lag";
    case StallCheck::not_finite: return "a dynamic-stall parameter is NaN or Inf";
  }
  return "unknown dynamic-stall check";
}

template <class Scalar, class Cap>
inline LoadStatus check_stall(const StallModel<Scalar, Cap>& st, const char** reason) {
  if (st.families != StallFamilies::none && st.families != StallFamilies::separation &&
      st.families != StallFamilies::separation_and_vortex) {
    *reason = "unknown dynamic-stall family choice";
    return LoadStatus::invalid_value;
  }
  if (st.families == StallFamilies::none) return LoadStatus::ok;
  if (st.separation.n_f0 > Cap::max_table_points) {
    *reason = "more sep_f0_point rows than the capacity allows";
    return LoadStatus::over_capacity;
  }
  const StallCheck c = check_stall_parameters(st);
  if (c != StallCheck::valid) {
    *reason = stall_check_reason(c);
    return LoadStatus::invalid_value;
  }
  if (!(st.separation.normal_force_slope_per_rad > Scalar(0))) {
    *reason = "sep_polar: the normal-force slope must be > 0";
    return LoadStatus::invalid_value;
  }
  return check_spline(st.separation.f0_correction, reason);
}

}  // namespace detail

template <class Scalar, class Cap>
inline LoadStatus validate_model_set(const ModelSet<Scalar, Cap>& m, ParseDiagnostic* diag) {
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
    const CoefficientModel<Scalar, Cap>& cm = m.coefficients[c];
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
    if ((s = detail::check_stall(cm.stall, &reason)) != LoadStatus::ok) return refuse(diag, 0, reason, s);
  }
  return LoadStatus::ok;
}

}  // namespace indicial
