// indicial/fitter/runtime_limits.hpp -- never write a model the runtime refuses.
//
// What it is for
// --------------
// A fitted model is only useful if the embedded runtime loads it. These checks run the
// runtime's OWN validation (runtime.hpp validate_for_runtime: structure, finite values,
// capacities, b_j(x) > 0 over the envelope; Predictor::load's delay limit) on a model before
// any command writes it. (The runtime's capacities are checked at input time, before a fit,
// by load_experiment and Python's Experiment: experiment_checks.hpp check_runtime_capacity.)
// min_lag_decay is the feasibility predicate of the constrained output-error fit.
//
// Usage
// -----
//   const FitResult r = fit_experiment(experiment, options);
//   indicial::require_runtime_accepts(r.model, out_dir + "/model.coef", indicial::ModelFile::to_write);
//
// Warnings
// --------
// 1. "Accepted" means accepted by Predictor<double, FitCapacity> (the fitter's capacity);
//    RuntimeAcceptance::capacity says whether the default Predictor<> (DefaultCapacity) also
//    loads it. A model only the larger capacity holds is written (with a warning line).
// 2. require_runtime_accepts throws InputError("<file>", 0, "not written: the runtime refuses
//    the model: <reason> (<status>)") for a file about to be written, and "<file>: the runtime
//    refuses the model: ..." for one read (predict): the file is named, never "model".
#pragma once

#include <string>
#include <vector>

#include "indicial/coef_file.hpp"
#include "indicial/model.hpp"

namespace indicial {

enum class RuntimeCapacity { default_capacity, fit_capacity_only, refused };

struct RuntimeAcceptance {
  RuntimeCapacity capacity = RuntimeCapacity::refused;
  LoadStatus status = LoadStatus::ok;  // of the FitCapacity load when refused, else ok
  std::string reason;                  // the runtime's reason when not default_capacity
};

// The runtime's verdict on a model set (validate_for_runtime and Predictor::load's limits at
// both capacities).
RuntimeAcceptance runtime_acceptance(const ModelSet<double, FitCapacity>& model);

// Whether the model's file is about to be written (fit, diagnose) or was read (predict).
enum class ModelFile { to_write, read };

// Throws InputError(file_label, 0, ...) when the runtime refuses the model (warning 2).
// Returns the acceptance otherwise (check capacity for the warning of warning 1).
RuntimeAcceptance require_runtime_accepts(const ModelSet<double, FitCapacity>& model,
                                          const std::string& file_label, ModelFile role);

// The smallest b_j(x) of lag j over [x_min_rad, x_max_rad] on the runtime's own validation
// grid (runtime.hpp: validation_samples + 1 evenly spaced angles, the envelope ends, and just
// either side of each knot inside the envelope). A model whose every lag has a positive
// minimum here passes validate_for_runtime's b_j(x) > 0 check: it is the same set of points.
// For the default b(x) (knot power 1, degree <= 1, piecewise linear) the minimum over the
// continuum is at an end or a knot, so it is exact there too.
double min_lag_decay(const CoefficientModel<double, FitCapacity>& m, int lag, double x_min_rad,
                     double x_max_rad);

// Whether every lag of m decays everywhere on that grid (min_lag_decay > 0 for every lag):
// the feasibility predicate of the constrained output-error fit.
bool lag_decay_positive(const CoefficientModel<double, FitCapacity>& m, double x_min_rad, double x_max_rad);

}  // namespace indicial
