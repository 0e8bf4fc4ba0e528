// python/src/fit_binding.cpp -- indicial.fit: fit_experiment (fit.hpp) with the checks
// `indicial fit` makes around it, and the result as Python objects.
//
// Around the fit, as the command line: the options are checked by FitOptions::IsValid (its
// message, the command line's; keywords are the fields' names); the fitted model must be
// one the runtime accepts (else indicial.InputError, nothing returned: the command line
// writes nothing then); the warnings are the experiment's, fit_warnings' and the capacity
// note, in the command line's order. The fit itself runs without the GIL.
#include <cmath>
#include <filesystem>
#include <map>

#include "bindings.hpp"

#include "indicial/fitter/error.hpp"
#include "indicial/fitter/provenance.hpp"
#include "indicial/fitter/report.hpp"

namespace indicial::python {
namespace {

// The provenance of a fit from Python: the version, the call, and the digests of the files
// an experiment read from disk came from (none for arrays).
// The inputs are hashed when they are files: an Experiment read from a file names its files; one
// built from arrays names its runs ("run 1", ...) and itself ("experiment"), which are not
// files even when a file of the experiment's name happens to be in the working directory (that
// raised "run 1: cannot be read" before).
Provenance provenance_for(const Experiment& e, const std::string& call) {
  std::error_code ec;
  bool files = std::filesystem::is_regular_file(e.path, ec);
  for (const Run& r : e.runs) files = files && std::filesystem::is_regular_file(r.path, ec);
  if (files) return experiment_provenance(e, call, "unknown");
  return make_provenance(call, "unknown");
}

py::dict parameter_dict(const ParameterEstimate& p) {
  py::dict d;
  d["name"] = p.name;
  d["value"] = p.value;
  d["cr_bound"] = p.cr_bound;
  d["cr_bound_colored"] = p.cr_bound_colored;
  d["identifiable"] = p.identifiability == Identifiability::identified;
  return d;
}

py::array_t<double> matrix(const Eigen::MatrixXd& m) {
  py::array_t<double> a({static_cast<py::ssize_t>(m.rows()), static_cast<py::ssize_t>(m.cols())});
  for (Eigen::Index i = 0; i < m.rows(); ++i)
    for (Eigen::Index j = 0; j < m.cols(); ++j) a.mutable_at(i, j) = m(i, j);
  return a;
}

py::dict run_series_dict(const RunSeries& s) {
  py::dict d;
  d["name"] = s.path;
  d["time_s"] = to_numpy(s.time_s);
  d["x_rad"] = to_numpy(s.x_rad);
  d["rate_radps"] = to_numpy(s.rate_radps);
  d["measured"] = to_numpy(s.measured);
  d["model"] = to_numpy(s.model);
  d["quasi_steady"] = to_numpy(s.quasi_steady);
  d["y_measured"] = to_numpy(s.y_measured);
  d["y_model"] = to_numpy(s.y_model);
  d["residual"] = to_numpy(s.residual);
  return d;
}

ModelFunction function_named(const std::string& f) {
  return pick<ModelFunction>("function", f, {{"a", ModelFunction::a}, {"b1", ModelFunction::b1},
                                             {"rotary", ModelFunction::rotary}});
}

}  // namespace

FitOptions parse_fit_options(const py::dict& kw) {
  FitOptions fo;
  for (const auto& item : kw) {
    const std::string key = py::str(item.first);
    const py::handle v = item.second;
    if (key == "f_to_enter") fo.f_to_enter = v.cast<double>();
    else if (key == "f_to_remove") fo.f_to_remove = v.cast<double>();
    else if (key == "max_iterations") fo.max_iterations = v.cast<int>();
    else if (key == "fallback_r_squared") fo.fallback_r_squared = v.cast<double>();
    else if (key == "state_derivative")
      fo.state_derivative = pick<StateDerivative>(key, v.cast<std::string>(),
          {{"smoothed", StateDerivative::smoothed_difference}, {"modulating", StateDerivative::modulating_function}});
    else if (key == "stepwise_refinement")
      fo.stepwise_refinement = pick<StepwiseRefinement>(key, v.cast<std::string>(),
          {{"none", StepwiseRefinement::none}, {"output_error", StepwiseRefinement::output_error}});
    else if (key == "stepwise_significance")
      fo.stepwise_significance = pick<StepwiseSignificance>(key, v.cast<std::string>(),
          {{"colored", StepwiseSignificance::colored_residuals}, {"white", StepwiseSignificance::white_residuals}});
    else if (key == "stepwise_fallback")
      fo.stepwise_fallback = pick<StepwiseFallback>(key, v.cast<std::string>(),
          {{"automatic", StepwiseFallback::automatic}, {"off", StepwiseFallback::off}});
    else if (key == "stall_start_search")
      fo.stall_start_search = pick<StallStartSearch>(key, v.cast<std::string>(),
          {{"grid", StallStartSearch::grid}, {"configured", StallStartSearch::configured}});
    else if (key == "stall_prior")
      fo.stall_prior = pick<StallPrior>(key, v.cast<std::string>(),
          {{"beddoes_leishman", StallPrior::beddoes_leishman}, {"none", StallPrior::none}});
    else if (key == "threads") fo.threads = v.cast<int>();
    else if (key == "start_values")
      for (const auto& sv : v.cast<std::map<std::string, double>>()) fo.start_values.emplace_back(sv.first, sv.second);
    else throw InputError(key, 0, "not a fit option");
  }
  return fo;
}

FitOptions fit_options_from(const py::dict& kw) {
  FitOptions fo = parse_fit_options(kw);
  // fit's default threads are `indicial fit --threads`'s, 2 (the library's are 1; diagnose's
  // fits take diagnose's own `threads`).
  if (!kw.contains("threads")) fo.threads = 2;
  if (std::string bad; !fo.IsValid(&bad)) throw InputError(bad);  // FitOptions' own message, as the CLI's
  return fo;
}

std::shared_ptr<FitHolder> wrap_fit(std::shared_ptr<const FitResult> result, const ExperimentPtr& e,
                                    const FitOptions& fo, const std::string& call, ModelCheck check) {
  auto h = std::make_shared<FitHolder>();
  h->experiment = e;
  h->options = fo;
  h->result = std::move(result);
  const FitResult& r = *h->result;
  h->warnings = e->warnings;
  if (!r.stepwise_fallback.empty()) h->warnings.push_back(e->path + ": " + r.stepwise_fallback);
  if (check == ModelCheck::required || runtime_acceptance(r.model).capacity != RuntimeCapacity::refused)
    h->model = model_from_set(r.model, e->path, provenance_for(*e, call));
  const std::vector<std::string> after = fit_warnings(r, *e);
  h->warnings.insert(h->warnings.end(), after.begin(), after.end());
  if (h->model && h->model->acceptance.capacity == RuntimeCapacity::fit_capacity_only)
    h->warnings.push_back(e->path + ": " + h->model->acceptance.reason);
  return h;
}

void bind_fit(py::module_& m) {
  py::class_<FitHolder, std::shared_ptr<FitHolder>>(m, "_FitResult")
      .def_property_readonly("parameters", [](const FitHolder& h) {
        py::list l;
        for (const ParameterEstimate& p : h.result->parameters) l.append(parameter_dict(p));
        return l;
      })
      .def_property_readonly("fit_error", [](const FitHolder& h) { return h.result->fit_error; })
      .def_property_readonly("termination", [](const FitHolder& h) {
        return std::string(termination_name(h.result->output_error.termination));
      })
      .def_property_readonly("message", [](const FitHolder& h) { return h.result->output_error.message; })
      .def_property_readonly("iterations", [](const FitHolder& h) { return h.result->output_error.iterations; })
      .def_property_readonly("unidentifiable", [](const FitHolder& h) { return h.result->output_error.unidentifiable; })
      .def_property_readonly("elapsed_s", [](const FitHolder& h) { return h.result->elapsed_s; })
      .def_property_readonly("stepwise_fallback", [](const FitHolder& h) { return h.result->stepwise_fallback; })
      .def_property_readonly("equation_error_r_squared", [](const FitHolder& h) {
        return h.result->equation_error.r_squared;
      })
      .def_property_readonly("equation_error_parameters", [](const FitHolder& h) {
        py::list l;
        for (const ParameterEstimate& p : h.result->equation_error.parameters) l.append(parameter_dict(p));
        return l;
      })
      .def_readonly("warnings", &FitHolder::warnings)
      .def_readonly("model", &FitHolder::model)
      .def_readonly("experiment", &FitHolder::experiment)
      .def_property_readonly("covariance", [](const FitHolder& h) { return matrix(h.result->covariance); })
      .def_property_readonly("covariance_colored", [](const FitHolder& h) {
        return matrix(h.result->covariance_colored);
      })
      .def_property_readonly("runs", [](const FitHolder& h) {
        py::list l;
        for (const RunSeries& s : h.result->runs) l.append(run_series_dict(s));
        return l;
      })
      .def("band", [](const FitHolder& h, const std::string& f, const py::handle& x_rad, const std::string& kind) {
             const ModelFunction mf = function_named(f);
             const BoundKind bk = pick<BoundKind>("kind", kind, {{"white", BoundKind::white}, {"colored", BoundKind::colored}});
             const DoubleArray x = as_vector(x_rad, "x_rad");
             py::array_t<double> value(x.size()), sigma(x.size());
             for (py::ssize_t i = 0; i < x.size(); ++i) {
               const FunctionBand b = function_band(*h.result, mf, x.data()[i], bk);
               value.mutable_data()[i] = b.value;
               sigma.mutable_data()[i] = b.sigma;
             }
             return py::make_tuple(value, sigma);
           }, py::arg("function"), py::arg("x_rad"), py::arg("kind") = "white")
      .def("fit_json", [](const FitHolder& h) {
        return fit_json(*h.result, *h.experiment, h.options, nullptr).dump(2);
      });

  m.def("_fit", [](const ExperimentPtr& e, const py::dict& options, const std::string& call) {
    if (!e) throw ClosedError("fit: no experiment");
    const FitOptions fo = fit_options_from(options);
    std::shared_ptr<const FitResult> r;
    {
      py::gil_scoped_release release;  // e is kept alive by the caller's reference
      r = std::make_shared<const FitResult>(fit_experiment(*e, fo));
    }
    return wrap_fit(std::move(r), e, fo, call);
  }, py::arg("experiment"), py::arg("options"), py::arg("call") = "python: indicial.fit");
}

}  // namespace indicial::python
