// python/src/diagnose_binding.cpp -- indicial.diagnose: diagnose_experiment (diagnose.hpp),
// without the GIL, and its result as Python objects: the steps (effect, detail, statistic,
// p-value, fit error before and after), the verdict, the noise estimates, the final fit and
// model, diagnosis.json and the diagnosed experiment file, with `indicial diagnose`'s warnings.
#include "bindings.hpp"

#include "indicial/fitter/error.hpp"

namespace indicial::python {
namespace {

struct DiagnoseHolder {
  std::shared_ptr<const DiagnoseResult> result;
  ExperimentPtr experiment;  // as given
  DiagnoseOptions options;
  std::vector<std::shared_ptr<FitHolder>> fits;  // fits[0] configured, fits[k] after step k
  std::vector<std::string> warnings;
};

py::dict step_dict(const DiagnoseStep& s) {
  py::dict d;
  d["step"] = s.step;
  d["effect"] = effect_name(s.effect);
  d["detail"] = s.detail;
  d["term"] = s.term;
  std::vector<std::string> same;
  for (Effect e : s.indistinguishable) same.emplace_back(effect_name(e));
  d["indistinguishable"] = same;
  d["statistic"] = s.statistic;
  d["p_value"] = s.p_value;
  d["log10_p"] = s.log10_p;
  d["threshold"] = s.threshold;
  d["candidates_tested"] = s.candidates_tested;
  d["added_parameters"] = s.added_parameters;
  d["delta_bic"] = s.delta_bic;
  d["correlation_factor"] = s.correlation_factor;
  d["fit_error_before"] = s.fit_error_before;
  d["fit_error_after"] = s.fit_error_after;
  d["run_rms_before"] = to_numpy(s.run_rms_before);
  d["run_rms_after"] = to_numpy(s.run_rms_after);
  // The rule that decided the step, and with leave-one-run-out its held-out evidence (what
  // diagnosis.json's steps carry: the statistic and p_value above did not decide then).
  d["rule"] = decision_rule_name(s.rule);
  d["held_out_rms_before"] = to_numpy(s.held_out_rms_before);
  d["held_out_rms_after"] = to_numpy(s.held_out_rms_after);
  d["held_out_mean_log_mse_ratio"] = s.held_out_log_ratio;
  d["held_out_standard_error"] = s.held_out_standard_error;
  return d;
}

py::dict noise_dict(const NoiseEstimate& n) {
  py::dict d;
  d["sigma"] = n.sigma;
  d["lag1_correlation"] = n.lag1_correlation;
  d["white_equivalent"] = n.white_equivalent;
  d["run_sigma"] = to_numpy(n.run_sigma);
  return d;
}

DiagnoseOptions diagnose_options_from(const py::dict& kw) {
  DiagnoseOptions o;
  py::dict fit_kw;
  fit_kw["stall_start_search"] = "configured";  // DiagnoseOptions::fit_defaults(), overridable
  for (const auto& item : kw) {
    const std::string key = py::str(item.first);
    const py::handle v = item.second;
    if (key == "alpha") o.alpha = v.cast<double>();
    else if (key == "max_steps") o.max_steps = v.cast<int>();
    else if (key == "knot_spacing_deg") o.knot_spacing_deg = v.cast<double>();
    else if (key == "knot_margin_fraction") o.knot_margin_fraction = v.cast<double>();
    else if (key == "max_scan_knots") o.max_scan_knots = v.cast<int>();
    else if (key == "max_family_terms") o.max_family_terms = v.cast<int>();
    else if (key == "indistinguishable_bic") o.indistinguishable_bic = v.cast<double>();
    else if (key == "min_in_sample_gain") o.cv_min_in_sample_gain = v.cast<double>();
    else if (key == "min_gain") o.cv_min_gain = v.cast<double>();
    else if (key == "max_folds") o.cv_max_folds = v.cast<int>();
    else if (key == "cv_unit")
      o.cv_unit = pick<CrossValidationUnit>(key, v.cast<std::string>(), {{"run", CrossValidationUnit::run},
                                                                         {"group", CrossValidationUnit::group}});
    else if (key == "cv_min_runs") o.cv_min_runs = v.cast<int>();
    else if (key == "threads") o.threads = v.cast<int>();
    else if (key == "rule")
      o.rule = pick<RuleChoice>(key, v.cast<std::string>(), {{"auto", RuleChoice::automatic},
                                                             {"cv", RuleChoice::leave_one_run_out},
                                                             {"lr", RuleChoice::likelihood_ratio}});
    else fit_kw[item.first] = item.second;
  }
  o.fit = parse_fit_options(fit_kw);
  // DiagnoseOptions' own message, the library's: a fit option named by its field (keyword), as
  // diagnose has no `indicial fit` flags.
  if (std::string bad; !o.IsValid(&bad)) throw InputError(bad);
  return o;
}

std::shared_ptr<DiagnoseHolder> run_diagnose(const ExperimentPtr& e, const py::dict& options, const std::string& call) {
  if (!e) throw ClosedError("diagnose: no experiment");
  auto h = std::make_shared<DiagnoseHolder>();
  h->experiment = e;
  h->options = diagnose_options_from(options);
  {
    py::gil_scoped_release release;
    h->result = std::make_shared<const DiagnoseResult>(diagnose_experiment(*e, h->options));
  }
  const DiagnoseResult& d = *h->result;
  auto working = std::make_shared<Experiment>(d.experiment);
  for (std::size_t k = 0; k < d.fits.size(); ++k)
    h->fits.push_back(wrap_fit(std::make_shared<const FitResult>(d.fits[k]), working, h->options.fit, call,
                               k + 1 == d.fits.size() ? ModelCheck::required : ModelCheck::optional));
  h->warnings = e->warnings;
  const std::vector<std::string> after = diagnose_warnings(d);
  h->warnings.insert(h->warnings.end(), after.begin(), after.end());
  return h;
}

}  // namespace

void bind_diagnose(py::module_& m) {
  py::class_<DiagnoseHolder, std::shared_ptr<DiagnoseHolder>>(m, "_Diagnosis")
      .def_property_readonly("steps", [](const DiagnoseHolder& h) {
        py::list l;
        for (const DiagnoseStep& s : h.result->steps) l.append(step_dict(s));
        return l;
      })
      .def_property_readonly("verdict", [](const DiagnoseHolder& h) { return h.result->verdict; })
      .def_property_readonly("stopped", [](const DiagnoseHolder& h) {
        return std::string(diagnose_stop_name(h.result->stopped));
      })
      .def_property_readonly("still_significant", [](const DiagnoseHolder& h) { return h.result->still_significant; })
      .def_property_readonly("effects_added", [](const DiagnoseHolder& h) { return h.result->effects_added; })
      .def_property_readonly("initial_fit_error", [](const DiagnoseHolder& h) { return h.result->initial_fit_error; })
      .def_property_readonly("final_fit_error", [](const DiagnoseHolder& h) { return h.result->final_fit_error; })
      .def_property_readonly("noise", [](const DiagnoseHolder& h) {
        // "sigma" is the CLI's noise_estimate: the replicates' where the data have replication
        // (it was the residual's AR(1) level always: 0.1245 against the CLI's 0.0147);
        // "residual_sigma" and the rest are the residual's levels.
        py::dict d = noise_dict(h.result->noise);
        const ReplicationNoise& rep = h.result->replication;
        d["residual_sigma"] = h.result->noise.sigma;
        d["source"] = rep.source != NoiseSource::none ? noise_source_name(rep.source) : "residual_differences";
        d["detail"] = rep.detail;
        if (rep.source != NoiseSource::none) {
          d["sigma"] = rep.sigma;
          d["lag1_correlation"] = rep.lag1_correlation;
        }
        return d;
      })
      .def_property_readonly("final_noise", [](const DiagnoseHolder& h) { return noise_dict(h.result->final_noise); })
      .def_property_readonly("ill_conditioned", [](const DiagnoseHolder& h) { return h.result->ill_conditioned; })
      .def_property_readonly("unconverged_models", [](const DiagnoseHolder& h) { return h.result->unconverged_models; })
      .def_property_readonly("fits_run", [](const DiagnoseHolder& h) { return h.result->fits_run; })
      .def_property_readonly("elapsed_s", [](const DiagnoseHolder& h) { return h.result->elapsed_s; })
      .def_readonly("fits", &DiagnoseHolder::fits)
      .def_readonly("warnings", &DiagnoseHolder::warnings)
      .def("diagnosis_json", [](const DiagnoseHolder& h) {
        return diagnosis_json(*h.result, *h.experiment, h.options, nullptr).dump(2);
      })
      .def("experiment_toml", [](const DiagnoseHolder& h) { return diagnosed_experiment_toml(*h.result); });

  m.def("_diagnose", &run_diagnose, py::arg("experiment"), py::arg("options"),
        py::arg("call") = "python: indicial.diagnose");
  m.def("_effect_names", [] {
    std::vector<std::string> names;
    for (const EffectDescription& d : effect_descriptions()) names.emplace_back(d.name);
    return names;
  });
}

}  // namespace indicial::python
