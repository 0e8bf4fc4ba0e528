// python/src/bench_binding.cpp -- the C++ reference of the Python batch-stepper benchmark
// (bench/python_bench.py): the same loop a C++ program runs -- step_batch over T time steps of
// N states sharing one RuntimeModel<double, DefaultCapacity> -- timed in C++ (steady_clock)
// in the same process, on the same arrays, so the benchmark's Python / C++ ratio is measured
// in one run on one machine state. Not part of the package's API (underscore name).
#include <time.h>

#include <chrono>

#include "bindings.hpp"

#include "indicial/batch.hpp"
#include "indicial/coef_file.hpp"
#include "indicial/fitter/error.hpp"

namespace indicial::python {
namespace {

// This thread's CPU time (Python's time.thread_time() reads the same clock), which a loaded
// machine inflates much less than the wall time.
double thread_cpu_s() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

// Resets N states at angle[0], then steps T rows of angle and rate (shape (T, N), C order)
// at one airspeed; returns (wall seconds of the stepping loop, the last row of outputs, this
// thread's CPU seconds of it).
py::tuple bench_step_batch(const ModelPtr& model, const py::handle& angle, const py::handle& rate,
                           double airspeed_mps, double dt_s) {
  const DoubleArray a = as_doubles(angle, "angle_rad"), r = as_doubles(rate, "rate_radps");
  if (a.ndim() != 2 || r.ndim() != 2 || a.shape(0) != r.shape(0) || a.shape(1) != r.shape(1))
    throw InputError("bench", 0, "angle and rate must have one shape (T, N)");
  const auto t_count = static_cast<std::size_t>(a.shape(0)), n = static_cast<std::size_t>(a.shape(1));
  auto rm = std::make_unique<RuntimeModel<double, DefaultCapacity>>();
  ParseDiagnostic diag;
  if (load_runtime_model(model->text.data(), model->text.size(), rm.get(), &diag) != LoadStatus::ok)
    throw InputError(model->origin, 0, std::string("needs a DefaultCapacity model: ") + diag.reason);
  std::vector<State<double, DefaultCapacity>> states(n);
  const std::vector<double> v(n, airspeed_mps);
  std::vector<double> out(n * static_cast<std::size_t>(rm->set.n_coefficients));
  double seconds = 0.0, cpu_seconds = 0.0;
  {
    py::gil_scoped_release release;
    for (std::size_t i = 0; i < n; ++i) reset(*rm, states[i], a.data()[i], airspeed_mps);
    const double cpu_start = thread_cpu_s();
    const auto start = std::chrono::steady_clock::now();
    for (std::size_t k = 0; k < t_count; ++k)
      step_batch(*rm, states.data(), n, a.data() + k * n, r.data() + k * n, v.data(), dt_s, out.data());
    seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    cpu_seconds = thread_cpu_s() - cpu_start;
  }
  return py::make_tuple(seconds, to_numpy(out), cpu_seconds);
}

}  // namespace

void bind_bench(py::module_& m) {
  m.def("_bench_step_batch", &bench_step_batch, py::arg("model"), py::arg("angle_rad"), py::arg("rate_radps"),
        py::arg("airspeed_mps"), py::arg("dt_s"));
}

}  // namespace indicial::python
