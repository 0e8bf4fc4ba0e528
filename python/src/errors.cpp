// python/src/errors.cpp -- C++ errors as Python exceptions, and the numpy conversions.
//
// indicial::InputError (bad input: file, line, problem) -> indicial.InputError(ValueError),
// with the command line's one-line message. The runtime's refusals (a step refused, a model
// refused) are raised by the binding files as indicial.StepError / indicial.InputError. A
// closed stepper raises indicial.ClosedError. std::invalid_argument (inconsistent lengths in
// the fitter's own checks) becomes ValueError by pybind11's default translation.
#include "bindings.hpp"

#include "indicial/fitter/error.hpp"

namespace indicial::python {

void bind_errors(py::module_& m) {
  py::register_exception<InputError>(m, "InputError", PyExc_ValueError);
  py::register_exception<StepError>(m, "StepError", PyExc_RuntimeError);
  py::register_exception<ClosedError>(m, "ClosedError", PyExc_ValueError);
}

DoubleArray as_doubles(const py::handle& value, const char* name) {
  if (value.is_none()) throw py::type_error(std::string(name) + ": expected an array of numbers, got None");
  py::array raw = py::array::ensure(value);
  if (!raw) throw py::type_error(std::string(name) + ": expected an array of numbers");
  const char kind = raw.dtype().kind();
  if (kind != 'f' && kind != 'i' && kind != 'u' && kind != 'b')
    throw py::type_error(std::string(name) + ": expected an array of real numbers, got dtype " +
                         std::string(py::str(raw.dtype())));
  return DoubleArray::ensure(raw);  // no copy for a C-contiguous float64 array
}

DoubleArray as_vector(const py::handle& value, const char* name) {
  DoubleArray a = as_doubles(value, name);
  if (a.ndim() != 1)
    throw InputError(name, 0, "expected a 1-D array, got " + std::to_string(a.ndim()) + " dimensions");
  return a;
}

std::vector<double> to_std(const DoubleArray& a) { return std::vector<double>(a.data(), a.data() + a.size()); }

py::array_t<double> to_numpy(const std::vector<double>& v) {
  py::array_t<double> a(static_cast<py::ssize_t>(v.size()));
  std::copy(v.begin(), v.end(), a.mutable_data());
  return a;
}

}  // namespace indicial::python
