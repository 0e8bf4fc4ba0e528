// indicial/fitter/experiment.hpp -- tunnel runs and the experiment file, in memory.
//
// load_experiment() reads the TOML experiment file (keys in docs/formats.md,
// documented with our extensions in docs/formats.md) and every run CSV it names, validates
// them, and returns an Experiment whose angles are all in radians. Everything downstream
// (equation error, output error, diagnose, predict) works on these structures only.
#pragma once

#include <algorithm>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "indicial/model.hpp"

namespace indicial {

// The time grid a run is declared to have (interface.md: "uniform step within 1e-6 relative
// unless a run is declared otherwise"; the tolerance in docs/formats.md). fit, diagnose and
// predict take either: on a nonuniform grid each step is the sample's own dt, as the runtime
// steps (a HIL or flight log with timestamp jitter, a jittered phase column, dropped samples),
// and the fitter's derivatives are taken on the actual times.
enum class TimeGrid { uniform, nonuniform };

// Where a run's time came from: its time_s column, or a phase column (phase_rad | phase_deg of
// one ensemble-averaged cycle) and the cycle's frequency: t = phase / (2 pi f).
enum class TimeSource { time_column, phase_column };

// One run: the time grid, the motion angle (alpha, phi or psi), its body rate, and the
// measured coefficient. All angles in rad, rates in rad/s.
struct Run {
  std::string path;                  // as named in the experiment (for messages and reports)
  long experiment_line = 0;          // the line of its `runs` entry (0: not from an experiment)
  std::vector<double> time_s;
  std::vector<double> motion_angle_rad;   // alpha (pitch), phi (roll), psi (yaw)
  std::string angle_column;               // the column it was read from ("alpha_deg", ...)
  std::vector<double> rate_radps;         // q, p or r: from the file, or smoothed derivative
  bool rate_from_file = false;
  std::vector<double> coefficient;        // measured C_a
  bool periodic = false;                  // an ensemble-averaged cycle: periodic steady state
  double airspeed_mps = 0.0;              // V of this run; load_experiment fills it (the run's or the
                                          // experiment's); 0 in a Run built in code: use Experiment's.
                                          // The fit scales b_j, con and the delay by it (V / V_ref)
  double frequency_hz = 0.0;              // the cycle's frequency; 0 when not given
  // The runs entry's `group` (a tunnel entry, campaign or session; empty: none given). Runs of
  // one group share what changes between entries (a balance's zero, a model's installation, the
  // tunnel's turbulence); with DiagnoseOptions::cv_unit group (`diagnose --cv-unit group`;
  // diagnose.hpp, CrossValidationUnit) diagnose's cross-validation leaves whole groups out, so an
  // effect enters only if it carries to an entry its fit never saw. Either every run of an
  // experiment has a group or none does.
  std::string group;
  // An ensemble-averaged file's replication (replication.hpp): the standard deviation of the
  // single cycles at each sample (empty: not given) and how many cycles were averaged (0: not
  // given). Noise of the averaged value: spread / sqrt(count).
  std::vector<double> coefficient_spread;
  double ensemble_count = 0.0;
  TimeGrid time_grid = TimeGrid::uniform;
  TimeSource time_source = TimeSource::time_column;
  // A run of several files whose columns are at their own phases (runs entry `files = [...]`,
  // phase_resample.hpp): the files as resolved from the experiment's folder, and the grid's
  // size; path is then those paths joined by " + " (a label, not a file). Empty for a run of
  // one file.
  std::vector<std::string> source_files;
  // Each source file's own column map (`files = [{file = ..., columns = {...}}]`, over the
  // experiment's [columns]); empty maps for files named by a bare string. Empty, or one per file.
  std::vector<std::map<std::string, std::string>> source_file_columns;
  int resampled_points = 0;
  std::vector<std::string> notes;         // one-line notes of the reader (ignored columns, ...)
  std::vector<std::string> warnings;      // plausible mistakes (radians in a degree column, ...)
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
  // [static] columns = { ours = "theirs", ... }: the table file's own column names, over the
  // experiment's [columns] (which the runs use): a polar headed otherwise than the runs.
  std::map<std::string, std::string> table_columns;
  std::vector<double> table_x_rad;   // alpha or beta, rad, strictly increasing
  std::vector<double> table_value;
};

struct RotaryConfig {
  std::vector<double> polynomial;    // a priori C_aq(x) coefficients of x^0, x^1, ...
  // A priori plus-function terms c_j (x - k_j)_+^p_j of C_aq(x) (extension: [rotary]
  // prior_knots_deg, prior_knot_powers (default 1 each), prior_knot_coefficients), e.g. a
  // break in C_Lq(alpha). One entry per term; a knot may repeat with another power.
  std::vector<double> prior_knots_rad;
  std::vector<int> prior_knot_powers;
  std::vector<double> prior_knot_coefficients;
  bool estimate = false;             // two-stage re-estimation (eqs. 25-26)
  SplineConfig candidates;           // with estimate: powers 0..degree and knots (power 1)
};

// Whether the fit estimates a pure delay of the unsteady forcing (x_f = x(t - delay)).
enum class DelayEstimation { none, estimated };
// The initial state of lags 2.. in each run: estimated (y0_{r}_{k}, like lag 1's y0_{r}) or
// at rest (0). Why at rest exists: with a free initial state, a slow further lag is a per-run
// constant offset, which would mimic the state-equation constant (diagnose tests the second
// lag at rest: tunnel runs start from rest, and lag 1's estimated y0 keeps the fit's freedom
// for a run that does not).
enum class LagStart { estimated, at_rest };

// Whether the separation state has a time constant of its own while the flow reattaches (T1r,
// model.hpp): as_separation (T1 both ways, the default) or estimated ([model]
// stall_reattachment = "estimated"; diagnose's slow_reattachment).
enum class StallReattachment { as_separation, estimated };

// Whether the separation state has a static hysteresis (dxr, model.hpp: the flow reattaches
// only dxr closer to alpha_0 than it separated, at any rate): none (the default) or estimated
// ([model] stall_hysteresis = "estimated"; diagnose's static_hysteresis).
enum class StallHysteresis { none, estimated };

// Whether the forcing angle's lag is limited (D, model.hpp: x_e = x - D tanh(T2 (l/V) x' / D),
// with the delay forcing lag only): none (the default: x - T2 (l/V) x') or estimated ([model]
// stall_lag_limit = "estimated"; diagnose's lag_limit).
enum class StallLagLimit { none, estimated };

// The dynamic-stall families of one coefficient (issue 22; model.hpp's "Dynamic stall"). [model]
// keys stall, stall_polar, stall_polar_column, stall_attached_max_deg,
// stall_f0_correction_{degree,powers,knots_deg}, stall_{T1,T2,CN1,Tv,Tvl}_start (docs/formats.md).
// The static lift polar gives the Kirchhoff separation f0(x) and the attached line N(x) =
// C_Na (x - alpha_0); the fitter estimates T1, T2, the f0 correction, k0..k2 and, with the
// vortex, CN1, Tv, Tvl, cv, xv by output error.
struct StallConfig {
  StallFamilies families = StallFamilies::none;
  std::string polar_path;               // the polar's CSV as named in the file ("" = [static] table)
  std::string polar_column = "CL";      // its lift column
  std::vector<double> polar_x_rad;      // the polar, read (strictly increasing)
  std::vector<double> polar_lift;
  double attached_max_deg = 8.0;        // rows with |x| <= this are the attached part
  SplineConfig f0_correction{{}, {}, 1};
  // Start values, in semichord times l / V (T1, T2, Tv, Tvl) and C_N units (CN1): the
  // Beddoes-Leishman NACA 0012 constants. A start is scaled by l / V because the parameters are.
  double tau1_start = 3.0;
  double tau2_start = 1.5;
  double tau1_reattach_start = 0.0;       // T1r (with reattachment = estimated); 0: T1's start
  StallReattachment reattachment = StallReattachment::as_separation;
  double reattach_shift_start_rad = 0.035;  // dxr (with hysteresis = estimated): 2 deg
  StallHysteresis hysteresis = StallHysteresis::none;
  double lag_limit_start_rad = 0.1;  // D (with lag_limit = estimated): 5.7 deg
  StallLagLimit lag_limit = StallLagLimit::none;
  // [model] stall_forcing_lag: how T2 lags the forcing angle (model.hpp's ForcingLag; structure,
  // not fitted). "delay" (default) or "first_order".
  ForcingLag forcing_lag = ForcingLag::delay;
  double shedding_threshold_start = 0.0;  // 0: from the polar (stall_polar.cpp)
  double decay_start = 6.0;
  double travel_start = 7.0;
  // [model] stall_known = { T1 = 8.5, T2 = 5.0 }: stall parameters held at known values, not
  // estimated (by name: T1 T2 k0 k1 k2, and CN1 Tv Tvl cv xv with the vortex), e.g. a C_m fit
  // that takes its separation dynamics from the C_L fit, as Beddoes-Leishman's moment does.
  std::vector<std::pair<std::string, double>> known;
};

struct ModelConfig {
  SplineConfig a{{0, 1, 2}, {}, 2};
  SplineConfig b1{{0}, {}, 1};
  bool bias = false;
  StructureMode structure = StructureMode::fixed;
  int lags = 1;                      // extension: number of lag states (>= 1)
  // b_k(x) of lags k = 2..lags: further_lag_b[k - 2] (extension; TOML keys b{k}_degree or
  // b{k}_powers, and b{k}_knots_deg, as b1's). A lag without an entry has a constant b_k
  // (powers {0}), the default. Knot power 1 unless given.
  std::vector<SplineConfig> further_lag_b;
  // Extensions used by `indicial diagnose` ([model] keys: docs/formats.md). All are estimated
  // in the maximum-likelihood output-error step only (the equation error does not see them);
  // they start at 0 (delay: delay_start_s) unless FitOptions::start_values names them.
  //  * static_correction: dC_a(x) terms (ML names dCa_{i}, dCaK{j}), an angle-only
  //    correction of the static curve, CoefficientModel::static_correction.
  //  * rotary_correction: C_aq(x) terms ADDED to the a priori C_aq (names Caq_{i}, CaqK{j});
  //    requires rotary.estimate = false (the two-stage loop owns C_aq otherwise).
  //  * delay: DelayEstimation::estimated adds the parameter delay_s (s at V_ref), with its
  //    sensitivity through indicial::delayed_angle.
  SplineConfig static_correction{{}, {}, 2};
  SplineConfig rotary_correction{{}, {}, 1};
  DelayEstimation delay = DelayEstimation::none;
  double delay_start_s = 0.0;
  LagStart further_lag_start = LagStart::estimated;
  StallConfig stall;                 // extension: dynamic-stall families (none by default)
};

// A static lift polar found beside the modelled coefficient (see Experiment::table_lift_polar).
struct LiftPolar {
  std::string path;                  // the file it was read from
  std::vector<double> x_rad;         // strictly increasing
  std::vector<double> lift;          // CL
  bool empty() const { return x_rad.empty(); }
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
  // Pitch, a coefficient other than CL, a [static] table that also has the lift (a CL column,
  // or Cnormal and Ctangential): that lift polar (load_experiment fills it; empty otherwise).
  // `indicial diagnose` offers the dynamic-stall families with it (model.stall_polar = the
  // table, stall_polar_column = "CL" in the experiment it writes).
  LiftPolar table_lift_polar;
  std::vector<Run> runs;
  // The range of the model angle x over all samples of all runs (filled by load_experiment).
  double data_x_min_rad = 0.0;
  double data_x_max_rad = 0.0;
  // One-line notes (what the readers did: ignored columns, snapped times) and warnings
  // (plausible mistakes: radians in a degree column, a defaulted section, a run without
  // motion), in the order found. The command line prints both on stderr (fit.json is to keep
  // the warnings: issue 14's CLI side).
  std::vector<std::string> notes;
  std::vector<std::string> warnings;
  double l_over_v_s() const {
    return airspeed_scaling(airspeed_mps, reference_length_m, airspeed_mps).l_over_v_s;
  }
};

// A range of the model angle x, in rad. Empty (min_rad > max_rad) when nothing was measured.
struct AngleRange {
  double min_rad = std::numeric_limits<double>::infinity();
  double max_rad = -std::numeric_limits<double>::infinity();
  bool empty() const { return !(min_rad <= max_rad); }
};

// The range of the model angle x = model_angle(axis, alpha0, motion angle) over every sample
// of every run: the one computation behind Experiment::data_x_min_rad / data_x_max_rad
// (set_data_range) and the fitted model's envelope (base_model_set). Empty without samples.
inline AngleRange model_angle_range(const Experiment& e) {
  AngleRange r;
  for (const Run& run : e.runs)
    for (double angle : run.motion_angle_rad) {
      const double x = model_angle(e.axis, e.alpha0_rad, angle);
      r.min_rad = std::min(r.min_rad, x);
      r.max_rad = std::max(r.max_rad, x);
    }
  return r;
}

// The frequency of a motion given its reduced frequency k = 2 pi f l / V (l the reference
// length, V the airspeed): f = k V / (2 pi l).
inline double frequency_hz_from_reduced(double reduced_frequency, double airspeed_mps,
                                        double reference_length_m) {
  return reduced_frequency * airspeed_mps / (2.0 * 3.14159265358979323846 * reference_length_m);
}

}  // namespace indicial
