// python/src/simulate_binding.cpp -- indicial.simulate and indicial.simulation_case: the
// reference simulator (simulate.hpp: Boost.Odeint Dormand-Prince 5(4) at 1e-12, never the
// fitter's discretization) with its measurement noise, as `indicial simulate` runs it.
#include <cmath>

#include "bindings.hpp"

#include "indicial/fitter/error.hpp"
#include "indicial/fitter/experiment_toml.hpp"
#include "indicial/fitter/simulate.hpp"

namespace indicial::python {
namespace {

py::dict run_dict(const TruthModel& model, const SimulatedRun& r) {
  py::dict d;
  d["time_s"] = to_numpy(r.time_s);
  d["motion_angle_rad"] = to_numpy(r.motion_angle_rad);
  d["rate_radps"] = to_numpy(r.rate_radps);
  d["x_rad"] = to_numpy(r.x_rad);
  py::dict measured, truth, y;
  for (int c = 0; c < model.n_coefficients; ++c) {
    const auto i = static_cast<std::size_t>(c);
    measured[py::str(model.coefficients[c].name)] = to_numpy(r.coefficient_measured[i]);
    truth[py::str(model.coefficients[c].name)] = to_numpy(r.coefficient_true[i]);
    y[py::str(model.coefficients[c].name)] = to_numpy(r.y_true[i]);
  }
  d["measured"] = measured;
  d["true"] = truth;
  d["y_true"] = y;
  return d;
}

std::vector<SimulatedRun> simulate_runs(const TruthModel& truth, const std::vector<MotionSpec>& motions, double snr,
                                        std::uint64_t seed, const NoiseModel& noise, std::vector<double>* sigma) {
  std::vector<SimulatedRun> runs;
  for (const MotionSpec& m : motions) runs.push_back(simulate_reference(truth, m));
  *sigma = add_measurement_noise(runs, snr, seed, noise);
  return runs;
}

double snr_of(const py::object& snr) {
  if (py::isinstance<py::str>(snr)) return parse_snr(snr.cast<std::string>());
  const double v = snr.cast<double>();
  if (!(v > 0.0)) throw InputError("snr", 0, "must be > 0 (or inf: no noise)");
  return v;
}

py::dict simulate(const ModelPtr& model, const py::object& motion, const py::object& time_s, const py::object& angle,
                  const py::object& snr, std::uint64_t seed, const std::string& noise, const py::object& airspeed) {
  if (!model) throw ClosedError("simulate: no model");
  MotionSpec spec;
  if (!motion.is_none()) {
    spec = parse_motion_spec(motion.cast<std::string>(), model->set->axis);
  } else {
    spec.kind = MotionKind::samples;
    spec.time_s = to_std(as_vector(time_s, "time_s"));
    spec.angle_rad = to_std(as_vector(angle, "motion angle"));
    spec.source = "arrays";
    if (spec.time_s.size() != spec.angle_rad.size())
      throw InputError("simulate", 0, "the motion angle has " + std::to_string(spec.angle_rad.size()) +
                                          " samples, time_s has " + std::to_string(spec.time_s.size()));
    if (spec.time_s.size() < 4) throw InputError("simulate", 0, "needs at least 4 samples");
    for (std::size_t i = 0; i < spec.time_s.size(); ++i) {
      if (!std::isfinite(spec.time_s[i]) || !std::isfinite(spec.angle_rad[i]))
        throw InputError("simulate", 0, "sample " + std::to_string(i) + " is not finite");
      if (i > 0 && !(spec.time_s[i] > spec.time_s[i - 1]))
        throw InputError("time_s", 0, "is not strictly increasing (time_s[" + std::to_string(i) + "])");
    }
    spec.dt_s = spec.time_s[1] - spec.time_s[0];
    for (std::size_t i = 1; i < spec.time_s.size(); ++i)
      if (std::abs(spec.time_s[i] - spec.time_s[i - 1] - spec.dt_s) > 1e-6 * spec.dt_s)
        throw InputError("time_s", 0, "a sampled motion must be uniform (1e-6 relative); use a sine or ramp motion "
                                      "with output times for a nonuniform log");
  }
  if (!airspeed.is_none()) {
    spec.airspeed_mps = airspeed.cast<double>();
    if (!(spec.airspeed_mps > 0.0) || !std::isfinite(spec.airspeed_mps))
      throw InputError("airspeed_mps", 0, "must be > 0");
  }
  const double s = snr_of(snr);
  const NoiseModel nm = parse_noise_spec(noise);
  std::vector<double> sigma;
  std::vector<SimulatedRun> runs;
  {
    py::gil_scoped_release release;
    runs = simulate_runs(*model->set, {spec}, s, seed, nm, &sigma);
  }
  py::dict d = run_dict(*model->set, runs.front());
  d["sigma"] = to_numpy(sigma);
  return d;
}

py::dict simulation_case(const std::string& name, const py::object& snr, std::uint64_t seed, const std::string& noise) {
  const SimulationCase& c = find_simulation_case(name);
  const double s = snr_of(snr);
  const NoiseModel nm = parse_noise_spec(noise);
  std::vector<double> sigma;
  std::vector<SimulatedRun> runs;
  {
    py::gil_scoped_release release;
    runs = simulate_runs(c.truth, c.motions, s, seed, nm, &sigma);
  }
  py::dict d;
  d["name"] = c.name;
  d["description"] = c.description;
  d["truth"] = model_from_set(c.truth, c.name + " truth", Provenance{});
  py::list l;
  for (std::size_t i = 0; i < runs.size(); ++i) {
    py::dict r = run_dict(c.truth, runs[i]);
    r["name"] = c.run_files[i];
    l.append(r);
  }
  d["runs"] = l;
  d["sigma"] = to_numpy(sigma);
  d["experiment_toml"] = write_experiment_toml(c.experiment, {"the configuration of simulation case " + c.name});
  return d;
}

}  // namespace

void bind_simulate(py::module_& m) {
  m.def("_simulate", &simulate, py::arg("model"), py::arg("motion"), py::arg("time_s"), py::arg("motion_angle_rad"),
        py::arg("snr"), py::arg("seed"), py::arg("noise"), py::arg("airspeed_mps"));
  m.def("_simulation_case", &simulation_case, py::arg("name"), py::arg("snr"), py::arg("seed"), py::arg("noise"));
  m.def("_simulation_case_names", [] {
    std::vector<std::string> names;
    for (const SimulationCase& c : simulation_cases()) names.push_back(c.name);
    return names;
  });
}

}  // namespace indicial::python
