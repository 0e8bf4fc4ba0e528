// python/src/model_binding.cpp -- indicial.Model: a coefficient file (.coef) in memory.
//
// A Model is always one the runtime accepts: loading parses the file (coef_file.hpp, the
// runtime's own parser at FitCapacity) and runs the runtime's validation
// (runtime_limits.hpp require_runtime_accepts), with the messages `indicial predict` gives
// for a bad file. Its text is the file's bytes (load) or the bytes `indicial fit` writes
// (a fit's model: the coefficient-file writer plus the provenance header), and save() writes
// exactly that text, refusing to replace a file unless force=True.
#include <filesystem>

#include "bindings.hpp"

#include "indicial/coef_file.hpp"
#include "indicial/fitter/error.hpp"
#include "indicial/fitter/model_merge.hpp"
#include "indicial/fitter/output.hpp"
#include "indicial/fitter/predict.hpp"

namespace indicial::python {

ModelPtr model_from_text(const std::string& text, const std::string& origin) {
  auto set = std::make_shared<FitModelSet>();
  ParseDiagnostic diag;
  const LoadStatus st = parse_coef_file(text.data(), text.size(), set.get(), &diag);
  if (st != LoadStatus::ok)
    throw InputError(origin, static_cast<long>(diag.line), std::string(diag.reason) + " (" + to_string(st) + ")");
  auto h = std::make_shared<ModelHolder>();
  h->acceptance = require_runtime_accepts(*set, origin, ModelFile::read);
  h->set = std::move(set);
  h->text = text;
  h->origin = origin;
  return h;
}

ModelPtr model_from_set(const FitModelSet& set, const std::string& origin, const Provenance& provenance) {
  auto h = std::make_shared<ModelHolder>();
  h->acceptance = require_runtime_accepts(set, origin, ModelFile::read);
  h->set = std::make_shared<FitModelSet>(set);
  h->text = with_provenance_header(coef_file_text(set, origin), provenance);
  h->origin = origin;
  return h;
}

namespace {

const CoefficientModel<double, FitCapacity>& coefficient_of(const ModelHolder& h, const py::object& which) {
  const FitModelSet& s = *h.set;
  if (which.is_none()) return s.coefficients[0];
  if (py::isinstance<py::int_>(which)) {
    const int i = which.cast<int>();
    if (i < 0 || i >= s.n_coefficients)
      throw py::index_error("coefficient index " + std::to_string(i) + " out of range (the model has " +
                            std::to_string(s.n_coefficients) + ")");
    return s.coefficients[i];
  }
  const std::string name = py::str(which);
  std::string names;
  for (int c = 0; c < s.n_coefficients; ++c) {
    if (name == s.coefficients[c].name) return s.coefficients[c];
    names += (c ? ", " : "") + std::string(s.coefficients[c].name);
  }
  throw py::key_error("the model has no coefficient '" + name + "' (it has " + names + ")");
}

// A spline of the model evaluated at every x (rad): a(x), b_j(x), C_aq(x), the static curve.
template <class F>
py::array_t<double> evaluate(const py::handle& x_rad, F f) {
  const DoubleArray x = as_doubles(x_rad, "x_rad");
  py::array_t<double> out(std::vector<py::ssize_t>(x.shape(), x.shape() + x.ndim()));
  double* o = out.mutable_data();
  for (py::ssize_t i = 0; i < x.size(); ++i) o[i] = f(x.data()[i]);
  return out;
}

}  // namespace

void bind_model(py::module_& m) {
  py::class_<ModelHolder, std::shared_ptr<ModelHolder>>(m, "_Model")
      .def_readonly("text", &ModelHolder::text)
      .def_readonly("origin", &ModelHolder::origin)
      .def_property_readonly("axis", [](const ModelHolder& h) { return std::string(axis_name(h.set->axis)); })
      .def_property_readonly("reference_length_m", [](const ModelHolder& h) { return h.set->reference_length_m; })
      .def_property_readonly("airspeed_mps", [](const ModelHolder& h) { return h.set->airspeed_mps; })
      .def_property_readonly("alpha0_rad", [](const ModelHolder& h) { return h.set->alpha0_rad; })
      .def_property_readonly("x_min_rad", [](const ModelHolder& h) { return h.set->x_min_rad; })
      .def_property_readonly("x_max_rad", [](const ModelHolder& h) { return h.set->x_max_rad; })
      .def_property_readonly("coefficients", [](const ModelHolder& h) {
        std::vector<std::string> names;
        for (int c = 0; c < h.set->n_coefficients; ++c) names.emplace_back(h.set->coefficients[c].name);
        return names;
      })
      .def_property_readonly("capacity", [](const ModelHolder& h) {
        return std::string(h.acceptance.capacity == RuntimeCapacity::default_capacity ? "default" : "fit");
      })
      .def("lags", [](const ModelHolder& h, const py::object& c) { return coefficient_of(h, c).n_lags; },
           py::arg("coefficient") = py::none())
      .def("delay_s", [](const ModelHolder& h, const py::object& c) { return coefficient_of(h, c).delay_s; },
           py::arg("coefficient") = py::none())
      .def("con", [](const ModelHolder& h, const py::object& c) { return coefficient_of(h, c).con; },
           py::arg("coefficient") = py::none())
      .def("a", [](const ModelHolder& h, const py::handle& x, const py::object& c) {
             const auto& cm = coefficient_of(h, c);
             return evaluate(x, [&](double xi) { return spline_value(cm.a, xi); });
           }, py::arg("x_rad"), py::arg("coefficient") = py::none())
      .def("b", [](const ModelHolder& h, const py::handle& x, int lag, const py::object& c) {
             const auto& cm = coefficient_of(h, c);
             if (lag < 1 || lag > cm.n_lags)
               throw py::index_error("lag " + std::to_string(lag) + " out of range 1.." + std::to_string(cm.n_lags));
             return evaluate(x, [&](double xi) { return spline_value(cm.lags[lag - 1].b, xi); });
           }, py::arg("x_rad"), py::arg("lag") = 1, py::arg("coefficient") = py::none())
      .def("rotary", [](const ModelHolder& h, const py::handle& x, const py::object& c) {
             const auto& cm = coefficient_of(h, c);
             return evaluate(x, [&](double xi) { return spline_value(cm.rotary, xi); });
           }, py::arg("x_rad"), py::arg("coefficient") = py::none())
      .def("static", [](const ModelHolder& h, const py::handle& x, const py::object& c) {
             const auto& cm = coefficient_of(h, c);
             return evaluate(x, [&](double xi) {
               return static_value(cm.static_curve, xi) + spline_value(cm.static_correction, xi);
             });
           }, py::arg("x_rad"), py::arg("coefficient") = py::none())
      .def("save", [](const ModelHolder& h, const std::string& path, bool force) {
             std::error_code ec;
             if (std::filesystem::is_directory(path, ec))
               throw InputError(path, 0, "is a directory, expected the name of a file to write");
             if (!force && std::filesystem::exists(path, ec))
               throw InputError(path, 0, "output file exists (pass force=True to replace it)");
             write_file_atomically(path, h.text, force ? Overwrite::replace : Overwrite::refuse);
           }, py::arg("path"), py::arg("force") = false);

  m.def("_model_load", [](const std::string& path) { return model_from_text(read_text(path), path); },
        py::arg("path"));
  m.def("_model_from_text", &model_from_text, py::arg("text"), py::arg("origin") = "<text>");
}

}  // namespace indicial::python
