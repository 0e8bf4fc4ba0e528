// The case registry of `indicial simulate --case` (see indicial/fitter/simulate.hpp,
// simulation_cases): the report's Table I tailless cases here, the F-16XL-like and lateral
// cases in cases_f16xl.cpp, the dynamic-stall campaign in cases_dynamic_stall.cpp.
#include <string>
#include <vector>

#include "indicial/fitter/error.hpp"
#include "indicial/fitter/simulate.hpp"
#include "indicial/fitter/tailless_model.hpp"
#include "simulate/cases_internal.hpp"

namespace indicial {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegToRad = kPi / 180.0;

}  // namespace

// ==========================================================================================
// Built-in cases
// ==========================================================================================
namespace {

// Report Table I (Example 1), the tailless aircraft; Model II when b1 depends on alpha.
enum class TaillessB1 { constant_model_1, spline_model_2 };

SimulationCase tailless_case(TaillessB1 kind) {
  SimulationCase c;
  const bool model2 = kind == TaillessB1::spline_model_2;
  c.name = model2 ? "tailless-model-2" : "tailless-model-1";
  c.description = model2 ? "report Table I, Model II: b1(alpha) spline with 4 knots"
                         : "report Table I, Model I: b1 = 2.5 1/s";
  TruthModel& t = c.truth;
  // Table I (tailless_model.hpp); V from the report's l / V = 0.02131 s exactly.
  t = tailless_model_set<FitCapacity>(model2 ? TaillessModel::model_2 : TaillessModel::model_1,
                                      tailless_reference_length_m / tailless_l_over_v_s);
  for (double f : {0.25, 0.5, 1.0}) {
    MotionSpec s;
    s.kind = MotionKind::sine;
    s.mean_rad = 35.0 * kDegToRad;
    s.amplitude_rad = 35.0 * kDegToRad;
    s.freq_hz = f;
    s.cycles = 3.0;
    s.dt_s = 0.01;
    c.motions.push_back(s);
  }
  c.run_files = {"run_f0.25.csv", "run_f0.50.csv", "run_f1.00.csv"};

  Experiment& e = c.experiment;
  e.axis = Axis::pitch;
  e.coefficient = "Cm";
  e.reference_length_m = t.reference_length_m;
  e.airspeed_mps = t.airspeed_mps;
  e.static_curve.kind = StaticKind::polynomial;
  e.static_curve.polynomial = {0.0, 0.42, 0.34, -1.0, 0.40};
  e.rotary.polynomial = {-2.0, 0.0, 0.8};
  e.rotary.estimate = false;
  e.model.a = SplineConfig{{0, 1, 2}, {0.4363, 0.9599}, 2};
  e.model.b1 = model2 ? SplineConfig{{0}, {0.349, 0.5236, 0.827, 1.0472}, 1}
                      : SplineConfig{{0}, {}, 1};
  e.model.bias = false;
  e.model.structure = StructureMode::fixed;
  list_case_runs(c);
  return c;
}

}  // namespace

void list_case_runs(SimulationCase& c) {
  c.experiment.runs.clear();
  for (const std::string& file : c.run_files) {
    Run r;
    r.path = file;
    c.experiment.runs.push_back(std::move(r));
  }
}

const std::vector<SimulationCase>& simulation_cases() {
  static const std::vector<SimulationCase> cases = [] {
    std::vector<SimulationCase> all = {
        tailless_case(TaillessB1::constant_model_1),
        tailless_case(TaillessB1::spline_model_2),
    };
    for (auto& c : f16xl_like_cases()) all.push_back(std::move(c));
    for (auto& c : lateral_cases()) all.push_back(std::move(c));
    return all;
  }();
  return cases;
}

const SimulationCase& find_simulation_case(const std::string& name) {
  std::string names;
  for (const auto& c : simulation_cases()) {
    if (c.name == name) return c;
    names += (names.empty() ? "" : ", ") + c.name;
  }
  throw InputError("--case", 0, "unknown case '" + name + "' (known: " + names + ")");
}

}  // namespace indicial
