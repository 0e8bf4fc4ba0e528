// python/src/module.cpp -- the extension module indicial._indicial (see bindings.hpp).
#include "bindings.hpp"

#include "indicial/fitter/provenance.hpp"

PYBIND11_MODULE(_indicial, m) {
  namespace ip = indicial::python;
  m.doc() = "indicial's C++ fitter and runtime (the library the command line uses); "
            "import the package `indicial`, not this module";
  m.attr("__version__") = indicial::tool_version();
  ip::bind_errors(m);
  ip::bind_experiment(m);
  ip::bind_model(m);
  ip::bind_fit(m);
  ip::bind_diagnose(m);
  ip::bind_predict(m);
  ip::bind_simulate(m);
  ip::bind_stepper(m);
  ip::bind_bench(m);
  ip::bind_polar(m);
}
