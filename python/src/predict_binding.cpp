// python/src/predict_binding.cpp -- indicial.predict: predict_motion / predict_periodic
// (predict.hpp: the runtime Predictor over a sampled motion, as `indicial predict`) without
// the GIL, scored against measured coefficients when given.
//
// The motion arrays get the checks `indicial predict` makes on a run CSV (equal lengths,
// finite, strictly increasing time) and the rate, when not given, is the same Savitzky-Golay
// derivative of the angle the CSV reader takes.
#include <algorithm>
#include <cmath>
#include <cstdio>

#include "bindings.hpp"

#include "indicial/fitter/csv_reader.hpp"
#include "indicial/fitter/derivative.hpp"
#include "indicial/fitter/error.hpp"
#include "indicial/fitter/experiment_checks.hpp"
#include "indicial/fitter/predict.hpp"
#include "indicial/fitter/prediction_output.hpp"

namespace indicial::python {
namespace {

// An angle array in radians that reaches beyond 2 pi in magnitude is almost certainly degrees
// (radians_look_like_degrees: the rule a run file's alpha_rad column is warned by).
std::vector<std::string> motion_unit_warnings(const std::vector<double>& angle_rad) {
  double largest = 0.0;
  for (double v : angle_rad) largest = std::max(largest, std::abs(v));
  if (!radians_look_like_degrees(largest)) return {};
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6g", largest);
  return {std::string("the motion angle reaches ") + buf + " rad, beyond 2 pi: it looks like degrees (pass "
          "radians: numpy.radians)"};
}

void check_finite(const std::vector<double>& v, const std::string& name) {
  for (std::size_t i = 0; i < v.size(); ++i)
    if (!std::isfinite(v[i]))
      throw InputError(name, 0, "[" + std::to_string(i) + "] is " + (std::isnan(v[i]) ? "NaN" : "infinite"));
}

py::dict metrics_dict(const ErrorMetrics& m) {
  py::dict d;
  d["n_samples"] = m.n_samples;
  d["rms_error"] = m.rms_error;
  d["max_error"] = m.max_error;
  d["theil_inequality"] = m.theil_inequality;
  d["mean_error"] = m.mean_error;
  d["rms_about_mean"] = m.rms_about_mean;
  d["bias_proportion"] = m.bias_proportion;
  return d;
}

py::dict prediction_dict(const Prediction& p) {
  py::dict d;
  d["axis"] = axis_name(p.axis);
  d["time_s"] = to_numpy(p.time_s);
  d["motion_angle_rad"] = to_numpy(p.motion_angle_rad);
  d["rate_radps"] = to_numpy(p.rate_radps);
  d["x_rad"] = to_numpy(p.x_rad);
  d["clamped_samples"] = p.clamped_samples;
  d["scored_samples"] = p.scored_samples;
  py::dict coefficients;
  for (const CoefficientPrediction& c : p.coefficients) {
    py::dict cd;
    cd["predicted"] = to_numpy(c.predicted);
    cd["quasi_steady"] = to_numpy(c.quasi_steady);
    if (c.scored == CoefficientPrediction::Scored::scored) {
      cd["measured"] = to_numpy(c.measured);
      cd["model_metrics"] = metrics_dict(c.model_metrics);
      cd["quasi_steady_metrics"] = metrics_dict(c.quasi_steady_metrics);
    }
    coefficients[py::str(c.name)] = cd;
  }
  d["coefficients"] = coefficients;
  return d;
}

py::dict predict(const ModelPtr& model, const py::handle& time_s, const py::handle& angle, const py::handle& rate,
                 const py::object& airspeed_mps, bool periodic, const py::object& measured, const std::string& grid,
                 double score_from_s) {
  if (!model) throw ClosedError("predict: no model");
  const std::vector<double> t = to_std(as_vector(time_s, "time_s"));
  const std::vector<double> a = to_std(as_vector(angle, "motion angle"));
  if (a.size() != t.size())
    throw InputError("predict", 0, "the motion angle has " + std::to_string(a.size()) + " samples, time_s has " +
                                       std::to_string(t.size()));
  if (t.size() < static_cast<std::size_t>(min_run_samples))
    throw InputError("predict", 0, "needs at least " + std::to_string(min_run_samples) + " samples, got " +
                                       std::to_string(t.size()));
  check_finite(t, "time_s");
  check_finite(a, "motion angle");
  if (grid != "uniform" && grid != "nonuniform")
    throw InputError("time_grid", 0, "expected 'uniform' or 'nonuniform', found '" + grid + "'");
  // As the command line: a uniform grid (the default) is checked, not assumed (a jittered log
  // read as uniform gave a rate off by 64 % of its amplitude, without a word).
  check_time_grid(t, grid == "nonuniform" ? TimeGrid::nonuniform : TimeGrid::uniform, "time_s");
  std::vector<std::string> warnings = motion_unit_warnings(a);
  if (periodic) {  // as `indicial predict --periodic`: one whole cycle, or refused
    Run probe;
    probe.time_s = t;
    probe.motion_angle_rad = a;
    if (const std::string problem = periodic_closure_problem(probe); !problem.empty())
      throw InputError("periodic", 0, "the motion is " + problem);
  }
  std::vector<double> r;
  if (rate.is_none()) {
    r = grid == "nonuniform" ? smooth_derivative_nonuniform(t, a, default_sg_half_window, default_sg_degree)
                             : smooth_derivative(a, t[1] - t[0], default_sg_half_window, default_sg_degree);
  } else {
    r = to_std(as_vector(rate, "rate"));
    if (r.size() != t.size())
      throw InputError("predict", 0, "the rate has " + std::to_string(r.size()) + " samples, time_s has " +
                                         std::to_string(t.size()));
    check_finite(r, "rate");
  }
  const double v = airspeed_mps.is_none() ? model->set->airspeed_mps : airspeed_mps.cast<double>();
  if (!(v > 0.0) || !std::isfinite(v)) throw InputError("airspeed_mps", 0, "must be > 0");
  std::vector<std::vector<double>> meas(static_cast<std::size_t>(model->set->n_coefficients));
  if (!measured.is_none()) {
    for (const auto& item : measured.cast<py::dict>()) {
      const std::string name = py::str(item.first);
      int c = 0;
      while (c < model->set->n_coefficients && name != model->set->coefficients[c].name) ++c;
      if (c == model->set->n_coefficients) throw InputError("measured", 0, "the model has no coefficient '" + name + "'");
      meas[static_cast<std::size_t>(c)] = to_std(as_vector(item.second, "measured"));
      if (meas[static_cast<std::size_t>(c)].size() != t.size())
        throw InputError("measured", 0, name + " has " + std::to_string(meas[static_cast<std::size_t>(c)].size()) +
                                            " samples, time_s has " + std::to_string(t.size()));
      check_finite(meas[static_cast<std::size_t>(c)], "measured " + name);
    }
  }
  Prediction p;
  {
    py::gil_scoped_release release;
    p = periodic ? predict_periodic(*model->set, t, a, r, v, model->origin)
                 : predict_motion(*model->set, t, a, r, v, model->origin);
    for (std::size_t c = 0; c < p.coefficients.size(); ++c) p.coefficients[c].measured = meas[c];
    score_coefficients(p, score_from_s, "score_from_s");
  }
  py::dict d = prediction_dict(p);
  for (const std::string& w : prediction_warnings(p)) warnings.push_back(w);  // what `predict` prints
  d["warnings"] = warnings;
  return d;
}

}  // namespace

void bind_predict(py::module_& m) {
  m.def("_predict", &predict, py::arg("model"), py::arg("time_s"), py::arg("motion_angle_rad"),
        py::arg("rate_radps"), py::arg("airspeed_mps"), py::arg("periodic"), py::arg("measured"),
        py::arg("time_grid") = "uniform", py::arg("score_from_s") = -std::numeric_limits<double>::infinity());
}

}  // namespace indicial::python
