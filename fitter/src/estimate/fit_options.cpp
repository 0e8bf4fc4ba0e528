// fit_options.cpp -- FitOptions::IsValid (fit.hpp): every range of the fit's options, checked in
// ONE place, in the shape of Ceres' Solver::Options::IsValid(std::string* error) (and of
// DiagnoseOptions::IsValid, diagnose_options.cpp). fit_experiment and fit_equation_error refuse
// invalid options with this message before they look at the experiment; `indicial fit`
// (tools/cmd_fit.cpp) and Python's indicial.fit report the same message, before reading or
// writing anything.
//
// A message names the field and, where there is one and the caller has it, `indicial fit`'s
// flag (OptionNaming; Python's keyword is the field's name), the range and the value found: one
// line per problem, the first problem found in declaration order. `indicial diagnose` has none
// of the fit's flags, so DiagnoseOptions::IsValid asks for the field alone. Start-value NAMES
// are checked by the fit, against the model.
#include <cmath>
#include <fmt/format.h>
#include <string>

#include "indicial/fitter/fit.hpp"
#include "numerics/levenberg_marquardt.hpp"

namespace indicial {

namespace {

// How the caller names the option `field`, whose `indicial fit` flag is `flag`.
std::string option_name(const char* field, const char* flag, OptionNaming naming) {
  return naming == OptionNaming::field_and_fit_flag ? fmt::format("{} ({})", field, flag) : std::string(field);
}

// "OPTION: must be RANGE, found VALUE" into *error (when given); false.
template <typename T>
bool refuse(std::string* error, const std::string& option, const std::string& range, T found) {
  if (error != nullptr) *error = fmt::format("{}: must be {}, found {}", option, range, found);
  return false;
}

// The solver's own ranges (numerics::LevenbergMarquardt::Options::IsValid) are stated here for
// the options the fit passes on, so that a bad one is refused with its field's name before any
// work; the solver's check stays as its own guard.
bool solver_ranges_valid(const FitOptions& o, std::string* error, OptionNaming naming) {
  if (!(o.sv_cutoff > 0.0 && o.sv_cutoff < 1.0))
    return refuse(error, "sv_cutoff", "in (0, 1) (a fraction of the largest singular value)", o.sv_cutoff);
  if (o.max_iterations < 0)
    return refuse(error, option_name("max_iterations", "--max-iterations", naming), ">= 0 (0: the start evaluated, no step)",
                  o.max_iterations);
  if (!(o.cost_tolerance >= 0.0)) return refuse(error, "cost_tolerance", ">= 0", o.cost_tolerance);
  if (!(o.step_tolerance >= 0.0))
    return refuse(error, "step_tolerance", ">= 0 (Cramer-Rao bounds)", o.step_tolerance);
  const double initial_damping = numerics::LevenbergMarquardt::Options{}.initial_damping;
  if (!(o.max_damping >= initial_damping))
    return refuse(error, "max_damping", fmt::format(">= the solver's initial damping {}", initial_damping),
                  o.max_damping);
  return true;
}

}  // namespace

bool FitOptions::IsValid(std::string* error, OptionNaming naming) const {
  // Written as !(inside): a NaN is outside every range.
  if (!(f_to_enter > 0.0))
    return refuse(error, option_name("f_to_enter", "--f-to-enter", naming), "> 0 (a partial F)", f_to_enter);
  if (!(f_to_remove > 0.0 && f_to_remove <= f_to_enter))
    return refuse(error, option_name("f_to_remove", "--f-to-remove", naming),
                  fmt::format("in (0, f_to_enter = {}] (F to enter >= F to remove > 0)", f_to_enter), f_to_remove);
  if (!(fallback_r_squared >= 0.0 && fallback_r_squared <= 1.0))
    return refuse(error, option_name("fallback_r_squared", "--fallback-r-squared", naming), "in [0, 1]",
                  fallback_r_squared);
  if (!solver_ranges_valid(*this, error, naming)) return false;
  if (max_two_stage_iterations < 1)
    return refuse(error, "max_two_stage_iterations", ">= 1", max_two_stage_iterations);
  if (!(two_stage_tolerance >= 0.0))
    return refuse(error, "two_stage_tolerance", ">= 0 (a fraction of the ML cost)", two_stage_tolerance);
  if (derivative_half_window < 1)
    return refuse(error, "derivative_half_window", ">= 1 (samples)", derivative_half_window);
  if (derivative_order < 1 || derivative_order > 2 * derivative_half_window)
    return refuse(error, "derivative_order",
                  fmt::format("in [1, 2 derivative_half_window = {}]", 2 * derivative_half_window), derivative_order);
  if (modulating_window < 5) return refuse(error, "modulating_window", ">= 5 (samples)", modulating_window);
  if (modulating_shift < 1) return refuse(error, "modulating_shift", ">= 1 (samples)", modulating_shift);
  if (max_correlation_lag < 0) return refuse(error, "max_correlation_lag", ">= 0 (samples)", max_correlation_lag);
  if (threads < 1) return refuse(error, option_name("threads", "--threads", naming), ">= 1", threads);
  for (const auto& [name, value] : start_values)
    if (!std::isfinite(value))
      return refuse(error, option_name("start_values", "--start-value", naming), "finite numbers",
                    fmt::format("{}={}", name, value));
  return true;
}

}  // namespace indicial
