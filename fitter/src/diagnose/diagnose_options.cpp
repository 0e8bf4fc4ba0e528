// diagnose_options.cpp -- DiagnoseOptions::IsValid (diagnose.hpp): every range of the options,
// checked in ONE place, in the shape of Ceres' Solver::Options::IsValid(std::string* error).
// diagnose_experiment refuses invalid options with this message; `indicial diagnose`
// (tools/cmd_diagnose.cpp) and Python's indicial.diagnose check them before reading or writing
// anything and report the same message.
//
// A message names the field and, where there is one, its command-line flag (Python's keyword is
// the flag with '_' for '-'), the range and the value found: one message per problem, the first
// problem found in declaration order. The FitOptions inside (DiagnoseOptions::fit) last, by
// their own FitOptions::IsValid (fit_options.cpp) and its message, naming the field alone
// (OptionNaming::field: diagnose has no --f-to-enter; Python's keyword is the field's name).
#include <cmath>
#include <fmt/format.h>
#include <string>

#include "indicial/fitter/diagnose.hpp"

namespace indicial {

namespace {

// "OPTION: must be RANGE, found VALUE" into *error (when given); false.
template <typename T>
bool refuse(std::string* error, const char* option, const char* range, T found) {
  if (error != nullptr) *error = fmt::format("{}: must be {}, found {}", option, range, found);
  return false;
}

}  // namespace

bool DiagnoseOptions::IsValid(std::string* error) const {
  // Written as !(inside): a NaN is outside every range.
  if (!(alpha > 0.0 && alpha < 1.0))
    return refuse(error, "alpha (--alpha)", "in (0, 1) (the family-wise significance level per round)", alpha);
  if (cv_min_runs < 2) return refuse(error, "cv_min_runs (--cv-min-runs)", ">= 2 (runs: one left out, one fitted)", cv_min_runs);
  if (!(cv_min_gain >= 0.0 && cv_min_gain < 1.0))
    return refuse(error, "cv_min_gain (--min-gain)", "in [0, 1) (a fraction of the held-out mean square error)",
                  cv_min_gain);
  if (!(cv_min_in_sample_gain >= 0.0 && cv_min_in_sample_gain < 1.0))
    return refuse(error, "cv_min_in_sample_gain (--min-in-sample-gain)",
                  "in [0, 1) (a fraction of the mean square error)", cv_min_in_sample_gain);
  if (cv_max_folds < 2) return refuse(error, "cv_max_folds (--max-folds)", ">= 2 (folds)", cv_max_folds);
  if (threads < 1) return refuse(error, "threads (--threads)", ">= 1", threads);
  if (max_steps < 0) return refuse(error, "max_steps (--max-steps)", ">= 0 (effects added)", max_steps);
  if (!(knot_spacing_deg > 0.0 && std::isfinite(knot_spacing_deg)))
    return refuse(error, "knot_spacing_deg (--knot-spacing-deg)", "positive and finite (degrees)", knot_spacing_deg);
  if (!(knot_margin_fraction >= 0.0 && knot_margin_fraction < 0.5))
    return refuse(error, "knot_margin_fraction", "in [0, 0.5) (a fraction of the angle range)",
                  knot_margin_fraction);
  if (max_scan_knots < 1) return refuse(error, "max_scan_knots", ">= 1", max_scan_knots);
  if (max_family_terms < 1)
    return refuse(error, "max_family_terms (--max-family-terms)", ">= 1 (terms)", max_family_terms);
  if (!(indistinguishable_bic >= 0.0))
    return refuse(error, "indistinguishable_bic", ">= 0 (a BIC difference)", indistinguishable_bic);
  // Why the field alone: diagnose has none of `indicial fit`'s flags (--f-to-enter, ...).
  return fit.IsValid(error, OptionNaming::field);
}

}  // namespace indicial
