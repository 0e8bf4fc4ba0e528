// python/src/bindings.hpp -- what the binding files of the module indicial._indicial share.
//
// What it is for
// --------------
// The Python package binds the fitter library and the runtime headers the command line uses;
// nothing here computes anything of its own. Each concept has its binding file (one concept
// per file): errors.cpp (exceptions), experiment_binding.cpp, fit_binding.cpp,
// diagnose_binding.cpp, model_binding.cpp, predict_binding.cpp, simulate_binding.cpp,
// stepper_binding.cpp (Predictor and the batch stepper), bench_binding.cpp (the C++ reference
// loop of the Python benchmark). This header holds the types that
// cross files (the model holder, the fit result holder) and the numpy conversions.
//
// Warnings
// --------
// 1. Arrays: every input array goes through as_doubles(), which never copies a C-contiguous
//    float64 array (the batch stepper reads the caller's memory in place) and converts
//    anything else numeric (int, float32, a strided view) with a copy. A non-numeric array
//    is a TypeError, never a crash.
// 2. The GIL is released around fit, diagnose, predict and batch stepping. Everything a
//    released section touches is C++ data owned by the call or by a holder kept alive by the
//    call's arguments; no Python object is touched without the GIL.
// 3. Every indicial::InputError becomes indicial.InputError (a ValueError) carrying the
//    command line's one-line message ("file:line: problem").
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "indicial/fitter/diagnose.hpp"
#include "indicial/fitter/error.hpp"
#include "indicial/fitter/experiment.hpp"
#include "indicial/fitter/fit.hpp"
#include "indicial/fitter/provenance.hpp"
#include "indicial/fitter/runtime_limits.hpp"

namespace indicial::python {

namespace py = pybind11;

using FitModelSet = ModelSet<double, FitCapacity>;

// A step the runtime refused (indicial.StepError) and a use of a closed stepper
// (indicial.ClosedError).
class StepError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};
class ClosedError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};
using DoubleArray = py::array_t<double, py::array::c_style | py::array::forcecast>;

// A loaded, runtime-accepted model and its coefficient-file text (the bytes `indicial fit`
// writes, or those of the file it was loaded from).
struct ModelHolder {
  std::shared_ptr<const FitModelSet> set;
  std::string text;    // coefficient-file text
  std::string origin;  // where it came from (a path, "fit", "text")
  RuntimeAcceptance acceptance;
};
using ModelPtr = std::shared_ptr<ModelHolder>;

// Parses and validates coefficient-file text (the parser, then the runtime's own validation);
// throws InputError(origin, line, problem) as `indicial predict` does for a bad file.
ModelPtr model_from_text(const std::string& text, const std::string& origin);
// A model made by the fitter: validated by the runtime (InputError when refused), text from
// the coefficient-file writer with the provenance header (as `indicial fit` writes it; none
// when the provenance is empty).
ModelPtr model_from_set(const FitModelSet& set, const std::string& origin, const Provenance& provenance);

// An experiment shared by the Python object and the results made from it.
using ExperimentPtr = std::shared_ptr<Experiment>;

// A fit and what it was fitted to (for fit.json, bands, warnings).
struct FitHolder {
  std::shared_ptr<const FitResult> result;
  ExperimentPtr experiment;
  FitOptions options;
  ModelPtr model;
  std::vector<std::string> warnings;
};

// A finished fit as the Python result: the model (runtime-checked) and the warnings
// `indicial fit` prints, in its order. A model the runtime refuses is an InputError with
// ModelCheck::required (a fit's result, as the command line), and no model (None) with
// ModelCheck::optional (diagnose's intermediate fits, which the command line never writes).
enum class ModelCheck { required, optional };
std::shared_ptr<FitHolder> wrap_fit(std::shared_ptr<const FitResult> result, const ExperimentPtr& e,
                                    const FitOptions& fo, const std::string& call,
                                    ModelCheck check = ModelCheck::required);

// The array as contiguous doubles (warning 1); `name` names it in the TypeError.
// time_s strictly increasing, and under TimeGrid::uniform uniform within 1e-6 relative of its
// mean step (the command line's rule); InputError(label, 0, ...) naming the first bad index.
void check_time_grid(const std::vector<double>& time_s, TimeGrid grid, const std::string& label);

DoubleArray as_doubles(const py::handle& value, const char* name);
// A 1-D array of doubles; throws indicial.InputError(name: ...) for another shape.
DoubleArray as_vector(const py::handle& value, const char* name);
std::vector<double> to_std(const DoubleArray& a);
py::array_t<double> to_numpy(const std::vector<double>& v);

// Python-facing option readers: a string choice naming the allowed values on error.
template <class E>
E pick(const std::string& option, const std::string& value, const std::map<std::string, E>& allowed) {
  const auto it = allowed.find(value);
  if (it != allowed.end()) return it->second;
  std::string names;
  for (const auto& [k, v] : allowed) names += (names.empty() ? "'" : ", '") + k + "'";
  throw InputError(option, 0, "expected one of " + names + ", found '" + value + "'");
}
// FitOptions from fit's keywords (a wrong name or choice is an InputError), unchecked:
// diagnose checks them inside DiagnoseOptions::IsValid, naming the field alone.
FitOptions parse_fit_options(const py::dict& kwargs);
// The same, checked by FitOptions::IsValid (its message with `indicial fit`'s flag).
FitOptions fit_options_from(const py::dict& kwargs);

void bind_errors(py::module_& m);
void bind_experiment(py::module_& m);
void bind_model(py::module_& m);
void bind_fit(py::module_& m);
void bind_diagnose(py::module_& m);
void bind_predict(py::module_& m);
void bind_simulate(py::module_& m);
void bind_stepper(py::module_& m);
void bind_bench(py::module_& m);
void bind_polar(py::module_& m);

}  // namespace indicial::python
