// python/src/polar_binding.cpp -- indicial.quasi_static_polar: `indicial polar` in memory (the
// experiment file's runs, read by load_experiment_runs; quasi_static_polar.hpp's recipe).
#include "bindings.hpp"

#include "indicial/fitter/error.hpp"
#include "indicial/fitter/experiment_toml.hpp"
#include "indicial/fitter/output.hpp"
#include "indicial/fitter/provenance.hpp"
#include "indicial/fitter/quasi_static_polar.hpp"

namespace indicial::python {

namespace {

py::dict polar_of_file(const std::string& path, double bin_deg, int min_samples, const std::string& stroke,
                       double hold_deg) {
  QuasiStaticPolarOptions o;
  o.bin_deg = bin_deg;
  o.min_samples = min_samples;
  o.hold_deg = hold_deg;
  std::string allowed;
  bool known = false;
  for (const auto& nv : polar_stroke_names) {
    if (stroke == nv.name) o.stroke = nv.value, known = true;
    allowed += (allowed.empty() ? "'" : ", '") + std::string(nv.name) + "'";
  }
  if (!known) throw InputError("stroke", 0, "expected one of " + allowed + ", found '" + stroke + "'");
  if (const std::string why = o.invalid_reason(); !why.empty()) throw InputError("quasi_static_polar", 0, why);
  const std::vector<Experiment> es = load_experiment_runs(path);
  const QuasiStaticPolar p = quasi_static_polar(es, o);
  py::dict values;
  for (std::size_t c = 0; c < p.coefficients.size(); ++c) values[py::str(p.coefficients[c])] = to_numpy(p.values[c]);
  std::vector<double> samples(p.samples.begin(), p.samples.end());
  py::dict d;
  d["x_rad"] = to_numpy(p.x_rad);
  d["values"] = values;
  d["samples"] = to_numpy(samples);
  d["bins_dropped"] = p.bins_dropped;
  d["samples_used"] = p.samples_used;
  d["runs"] = p.runs;
  d["held_rows"] = p.held_rows;
  d["axis"] = std::string(axis_name(es.front().axis));
  d["csv"] = quasi_static_polar_csv(p, es.front().axis, {"indicial.quasi_static_polar " + path});
  d["inputs"] = experiment_input_paths(es.front());  // what write() must never replace
  std::vector<std::string> warnings;
  for (const Experiment& e : es) warnings.insert(warnings.end(), e.warnings.begin(), e.warnings.end());
  d["warnings"] = warnings;
  return d;
}

}  // namespace

void bind_polar(py::module_& m) {
  m.def("_quasi_static_polar", &polar_of_file, py::arg("path"), py::arg("bin_deg"), py::arg("min_samples"),
        py::arg("stroke"), py::arg("hold_deg"));
  // The polar's CSV written as the command writes it: atomically, an existing file refused
  // unless force.
  m.def("_write_polar", [](const std::string& path, const std::string& text, bool force,
                           const std::vector<std::string>& inputs) {
    refuse_output_onto_input(path, inputs);  // force replaces an output, never an input
    write_file_atomically(path, text, force ? Overwrite::replace : Overwrite::refuse);
  }, py::arg("path"), py::arg("text"), py::arg("force"), py::arg("inputs"));
}

}  // namespace indicial::python
