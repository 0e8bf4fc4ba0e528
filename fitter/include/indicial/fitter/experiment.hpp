// indicial/fitter/experiment.hpp -- tunnel runs and the experiment file, in memory.
//
// load_experiment() reads the TOML experiment file (keys in ../shared/reference/interface.md,
// documented with our extensions in docs/formats.md) and every run CSV it names, validates
// them, and returns an Experiment whose angles are all in radians. Everything downstream
// (equation error, output error, diagnose, predict) works on these structures only.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "indicial/model.hpp"

namespace indicial {

// One run: uniform time grid, the motion angle (alpha, phi or psi), its body rate, and the
// measured coefficient. All angles in rad, rates in rad/s.
struct Run {
  std::string path;                  // as named in the experiment (for messages and reports)
  std::vector<double> time_s;
  std::vector<double> motion_angle_rad;   // alpha (pitch), phi (roll), psi (yaw)
  std::vector<double> rate_radps;         // q, p or r: from the file, or smoothed derivative
  bool rate_from_file = false;
  std::vector<double> coefficient;        // measured C_a
  bool periodic = false;                  // an ensemble-averaged cycle: periodic steady state
  double dt_s() const { return time_s.size() > 1 ? time_s[1] - time_s[0] : 0.0; }
  std::size_t size() const { return time_s.size(); }
};

// Term pool of one spline, as configured.
struct SplineConfig {
  std::vector<int> powers;           // x^i terms (from *_degree: 0..degree, or *_powers)
  std::vector<double> knots_rad;     // plus-function knots
  int knot_power = 1;                // 2 for a(x), 1 for b1(x) and C_aq(x)
};

enum class StructureMode { fixed, stepwise };

struct StaticConfig {
  StaticKind kind = StaticKind::polynomial;
  std::vector<double> polynomial;    // coefficients of x^0, x^1, ... (x in rad)
  std::string table_path;            // when kind == table
  std::vector<double> table_x_rad;   // alpha or beta, rad, strictly increasing
  std::vector<double> table_value;
};

struct RotaryConfig {
  std::vector<double> polynomial;    // a priori C_aq(x) coefficients of x^0, x^1, ...
  bool estimate = false;             // two-stage re-estimation (eqs. 25-26)
  SplineConfig candidates;           // with estimate: powers 0..degree and knots (power 1)
};

struct ModelConfig {
  SplineConfig a{{0, 1, 2}, {}, 2};
  SplineConfig b1{{0}, {}, 1};
  bool bias = false;
  StructureMode structure = StructureMode::fixed;
  int lags = 1;                      // extension: number of lag states (>= 1)
};

struct Experiment {
  std::string path;                  // the experiment file
  Axis axis = Axis::pitch;
  std::string coefficient;           // "Cm", "CL", ...
  double reference_length_m = 0.0;
  double airspeed_mps = 0.0;
  double alpha0_rad = 0.0;           // roll and yaw
  StaticConfig static_curve;
  RotaryConfig rotary;
  ModelConfig model;
  std::vector<Run> runs;
  // The range of the model angle x over all samples of all runs (filled by load_experiment).
  double data_x_min_rad = 0.0;
  double data_x_max_rad = 0.0;
  double l_over_v_s() const { return reference_length_m / airspeed_mps; }
};

}  // namespace indicial
