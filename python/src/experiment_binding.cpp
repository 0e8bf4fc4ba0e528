// python/src/experiment_binding.cpp -- indicial.Experiment: read from a TOML file (the
// command line's load_experiment, every check and message included) or built from numpy
// arrays, and written back as files the command line reads (experiment.toml + run CSVs).
//
// Runs from arrays get the checks read_run_csv makes on a file (csv_reader.hpp): equal
// lengths, at least min_run_samples samples, finite values, strictly increasing time, a
// uniform step within 1e-6 relative unless time_grid = "nonuniform", the rate derived by the
// same Savitzky-Golay derivative when not given. The configuration gets load_experiment's
// checks that do not depend on TOML: knots strictly inside the data's angle range, the
// runtime's capacity, at least one moving run. Messages name the run ("run 2 (name): ...").
// The static table, delay and stall keywords get the file reader's own checks and messages
// (experiment_checks.hpp, called by both), naming the keyword where the file names its line.
#include <algorithm>
#include <cmath>
#include <filesystem>

#include "bindings.hpp"

#include "indicial/fitter/error.hpp"
#include "indicial/fitter/experiment_checks.hpp"
#include "indicial/fitter/io.hpp"
#include "indicial/fitter/output.hpp"

namespace indicial::python {

void check_time_grid(const std::vector<double>& time_s, TimeGrid grid, const std::string& label) {
  for (std::size_t i = 1; i < time_s.size(); ++i) {
    if (!(time_s[i] > time_s[i - 1]))
      throw InputError(label, 0, "time_s is not strictly increasing (time_s[" + std::to_string(i) + "] = " +
                                     format_double(time_s[i]) + " after " + format_double(time_s[i - 1]) + ")");
  }
  if (grid == TimeGrid::nonuniform || time_s.size() < 2) return;
  const double dt = (time_s.back() - time_s.front()) / static_cast<double>(time_s.size() - 1);
  for (std::size_t i = 1; i < time_s.size(); ++i) {
    const double step = time_s[i] - time_s[i - 1];
    if (std::abs(step - dt) > 1e-6 * dt)
      throw InputError(label, 0, "non-uniform time step: " + format_double(step) + " s at time_s[" + std::to_string(i) +
                                     "], mean step " + format_double(dt) +
                                     " s (allowed deviation 1e-6 relative; pass time_grid='nonuniform' if the log is "
                                     "not uniform)");
  }
}

namespace {

const char* angle_base(Axis axis) { return axis == Axis::pitch ? "alpha" : axis == Axis::roll ? "phi" : "psi"; }
const char* rate_base(Axis axis) { return axis == Axis::pitch ? "q" : axis == Axis::roll ? "p" : "r"; }

template <class E>
E choice(const std::string& what, const std::string& value) {
  std::string allowed;
  for (const auto& nv : names_of(E{})) {
    if (value == nv.name) return nv.value;
    allowed += (allowed.empty() ? "'" : ", '") + std::string(nv.name) + "'";
  }
  throw InputError(what, 0, "expected one of " + allowed + ", found '" + value + "'");
}

// The first non-finite entry of a column, as a message; empty when all are finite.
std::string first_non_finite(const std::vector<double>& v, const std::string& column) {
  for (std::size_t i = 0; i < v.size(); ++i)
    if (!std::isfinite(v[i])) return column + "[" + std::to_string(i) + "] is " + (std::isnan(v[i]) ? "NaN" : "infinite");
  return {};
}

void check_time(const Run& run, const std::string& label) { check_time_grid(run.time_s, run.time_grid, label); }

// One run from its arrays (see the file comment). `label` names it in messages.
Run make_run(const py::dict& d, const std::string& label) {
  Run run;
  run.path = d.contains("name") && !d["name"].is_none() ? py::str(d["name"]).cast<std::string>() : label;
  run.time_s = to_std(as_vector(d["time_s"], "time_s"));
  run.motion_angle_rad = to_std(as_vector(d["motion_angle_rad"], "motion angle"));
  run.coefficient = to_std(as_vector(d["coefficient"], "coefficient"));
  run.rate_from_file = d.contains("rate_radps") && !d["rate_radps"].is_none();
  if (run.rate_from_file) run.rate_radps = to_std(as_vector(d["rate_radps"], "rate"));
  run.periodic = d.contains("periodic") && d["periodic"].cast<bool>();
  run.airspeed_mps = d.contains("airspeed_mps") && !d["airspeed_mps"].is_none() ? d["airspeed_mps"].cast<double>() : 0.0;
  if (d.contains("time_grid")) run.time_grid = choice<TimeGrid>(label + ": time_grid", d["time_grid"].cast<std::string>());
  if (d.contains("group") && !d["group"].is_none()) {
    run.group = py::str(d["group"]).cast<std::string>();
    if (run.group.find_first_not_of(" \t") == std::string::npos)
      throw InputError(label, 0, "group is empty: name the tunnel entry, campaign or session the run belongs to");
  }
  const std::size_t n = run.time_s.size();
  auto same = [&](const std::vector<double>& v, const char* what) {
    if (v.size() != n)
      throw InputError(label, 0, std::string(what) + " has " + std::to_string(v.size()) + " samples, time_s has " +
                                     std::to_string(n));
  };
  same(run.motion_angle_rad, "the motion angle");
  same(run.coefficient, "the coefficient");
  if (run.rate_from_file) same(run.rate_radps, "the rate");
  if (n < static_cast<std::size_t>(min_run_samples))
    throw InputError(label, 0, "has " + std::to_string(n) + " samples; a run needs at least " +
                                   std::to_string(min_run_samples));
  for (const auto& [v, col] : {std::pair{&run.time_s, "time_s"}, {&run.motion_angle_rad, "motion angle"},
                               {&run.coefficient, "coefficient"}, {&run.rate_radps, "rate"}}) {
    const std::string bad = first_non_finite(*v, col);
    if (!bad.empty()) throw InputError(label, 0, bad);
  }
  if (!(run.airspeed_mps >= 0.0) || !std::isfinite(run.airspeed_mps))
    throw InputError(label, 0, "airspeed_mps must be > 0");
  check_time(run, label);
  // The file reader's check of a periodic run (experiment_checks.hpp): one whole cycle, else the
  // experiment's write_files would write a run that `indicial fit` refuses.
  if (run.periodic)
    if (const std::string problem = periodic_closure_problem(run); !problem.empty())
      throw InputError(label, 0, "is " + problem);
  if (!run.rate_from_file) {
    run.rate_radps = run.time_grid == TimeGrid::nonuniform
                         ? smooth_derivative_nonuniform(run.time_s, run.motion_angle_rad, default_sg_half_window,
                                                        default_sg_degree)
                         : smooth_derivative(run.motion_angle_rad, run.time_s[1] - run.time_s[0],
                                             default_sg_half_window, default_sg_degree);
  }
  return run;
}

std::vector<double> doubles(const py::dict& c, const char* key) {
  if (!c.contains(key) || c[key].is_none()) return {};
  return to_std(as_vector(c[key], key));
}
std::vector<int> ints(const py::dict& c, const char* key, std::vector<int> fallback) {
  if (!c.contains(key) || c[key].is_none()) return fallback;
  std::vector<int> v = c[key].cast<std::vector<int>>();
  for (std::size_t i = 0; i < v.size(); ++i)
    if (v[i] < 0 || (i > 0 && v[i] <= v[i - 1]))
      throw InputError(key, 0, "powers must be distinct, ascending and >= 0");
  return v;
}

// A knot keyword: the experiment file's knot checks (experiment_checks.hpp), its message as is.
void check_knots(const Experiment& e, const std::vector<double>& knots, const std::string& key) {
  const EntryError as_is = [](std::size_t, const std::string& problem) { return InputError(problem); };
  check_knot_list(knots, key, as_is);
  check_knots_in_data(e, knots, key, as_is);
}

// The runtime's capacity at input time: load_experiment's own rule (experiment_checks.hpp
// check_runtime_capacity), the message as is, a warning without a file and line.
void check_capacity(Experiment& e, const CapacityUse& use) {
  check_runtime_capacity(use, e, [](const std::string& problem) { return InputError(problem); }, "");
}

// A spline's powers and knots (keywords powers_key, knots_key) against the runtime's capacity.
void check_spline_capacity(Experiment& e, const SplineConfig& s, const std::string& powers_key,
                           const std::string& knots_key, CapacityUse::Pool pool) {
  check_capacity(e, {powers_key, "powers (x^0..x^n)", s.powers.empty() ? 0 : s.powers.back() + 1,
                     DefaultCapacity::max_powers, pool});
  check_capacity(e, {knots_key, "knots", static_cast<int>(s.knots_rad.size()), DefaultCapacity::max_knots, pool});
}

bool given(const py::dict& c, const char* key) { return c.contains(key) && !c[key].is_none(); }

// The finite numbers of an array keyword (empty when not given).
std::vector<double> finite_doubles(const py::dict& c, const char* key) {
  std::vector<double> v = doubles(c, key);
  const std::string bad = first_non_finite(v, key);
  if (!bad.empty()) throw InputError(bad);
  return v;
}

// A table from two array keywords (angles `x_key` in rad, values `value_key`), with the checks
// a static table file gets (experiment_checks.hpp); messages name the keyword and the index.
void read_array_table(const py::dict& c, const char* x_key, const char* value_key, std::vector<double>& x_rad,
                      std::vector<double>& value) {
  if (given(c, x_key) != given(c, value_key))
    throw InputError(given(c, x_key) ? value_key : x_key, 0,
                     std::string("required with ") + (given(c, x_key) ? x_key : value_key) + " (the table's " +
                         (given(c, x_key) ? "values" : "angles, rad") + ")");
  x_rad = finite_doubles(c, x_key);
  value = finite_doubles(c, value_key);
  const std::vector<double>& x = x_rad;
  check_static_table(x_rad, value,
                     TableSite{[x_key](std::size_t row, const std::string& problem) {
                                 return InputError(row == static_cast<std::size_t>(-1)
                                                       ? std::string(x_key)
                                                       : std::string(x_key) + "[" + std::to_string(row) + "]",
                                                   0, problem);
                               },
                               [&x](std::size_t row) { return format_double(x[row]); }});
}

// static_table_lift: the lift (CL) at each static_table_x_rad of a pitch experiment of another
// coefficient, as the [static] table file's CL column (Experiment::table_lift_polar, which
// diagnose offers the dynamic-stall families with).
void read_static_table_lift(const py::dict& c, Experiment& e) {
  if (!given(c, "static_table_lift")) return;
  const StaticConfig& st = e.static_curve;
  if (st.kind != StaticKind::table)
    throw InputError("static_table_lift", 0, "needs the static table (static_table_x_rad, static_table_value)");
  if (e.axis != Axis::pitch || e.coefficient == "CL")
    throw InputError("static_table_lift", 0, "the static table's lift column is for a pitch experiment of another "
                                             "coefficient than CL (this one: " + e.coefficient + ", " +
                                             axis_name(e.axis) + ")");
  LiftPolar& lp = e.table_lift_polar;
  lp.lift = finite_doubles(c, "static_table_lift");
  if (lp.lift.size() != st.table_x_rad.size())
    throw InputError("static_table_lift", 0, "has " + std::to_string(lp.lift.size()) + " values for the table's " +
                                                 std::to_string(st.table_x_rad.size()) + " angles");
  lp.x_rad = st.table_x_rad;
  lp.path = st.table_path;
}

// static_table_x_rad + static_table_value: the [static] table (x = alpha in pitch, beta in roll
// and yaw, rad), instead of static_polynomial, and its lift column. Named in messages as its
// keyword.
void read_static_table_keywords(const py::dict& c, Experiment& e) {
  if (!given(c, "static_table_x_rad") && !given(c, "static_table_value")) {
    if (given(c, "static_table_lift"))
      throw InputError("static_table_lift", 0, "needs the static table (static_table_x_rad, static_table_value)");
    return;
  }
  if (!e.static_curve.polynomial.empty())
    throw InputError("static_table_x_rad", 0, "give static_polynomial or static_table_x_rad and static_table_value, "
                                              "not both");
  StaticConfig& st = e.static_curve;
  read_array_table(c, "static_table_x_rad", "static_table_value", st.table_x_rad, st.table_value);
  st.kind = StaticKind::table;
  st.table_path = "static_table_x_rad";
  check_capacity(e, {"static_table_x_rad", "rows", static_cast<int>(st.table_x_rad.size()),
                     DefaultCapacity::max_table_points});
  read_static_table_lift(c, e);
}

// The shared checks' KeySite for keywords: a [model] key's keyword (the same name, but
// stall_polar_alpha_rad for the polar and the f0 correction's knots in rad), a message as is.
KeySite keyword_site() {
  return KeySite{[](const std::string& key) {
                   if (key == "stall_polar") return std::string("stall_polar_alpha_rad");
                   if (key == "stall_f0_correction_knots_deg") return std::string("stall_f0_correction_knots_rad");
                   if (key.rfind("stall_known.", 0) == 0) return "stall_known[\"" + key.substr(12) + "\"]";
                   return key;
                 },
                 [](const std::string&, const std::string& problem) { throw InputError(problem); }};
}

// delay = "estimated" and delay_start_s (s at V_ref).
void read_delay_keywords(const py::dict& c, ModelConfig& m) {
  if (given(c, "delay")) m.delay = choice<DelayEstimation>("delay", c["delay"].cast<std::string>());
  if (given(c, "delay_start_s")) m.delay_start_s = c["delay_start_s"].cast<double>();
  check_delay_keys(m, given(c, "delay_start_s"), keyword_site());
}

// The dynamic-stall keywords (StallConfig; the [model] stall keys of docs/formats.md): read,
// then the experiment file's checks (check_stall_keys), then the polar: the arrays
// stall_polar_alpha_rad + stall_polar_lift, or the static table of the polar's column.
void read_stall_keywords(const py::dict& c, Experiment& e) {
  StallConfig& s = e.model.stall;
  if (given(c, "stall")) s.families = choice<StallFamilies>("stall", c["stall"].cast<std::string>());
  const std::pair<const char*, const char*> keys[] = {
      {"stall_polar_alpha_rad", "stall_polar"}, {"stall_polar_lift", "stall_polar"},
      {"stall_polar_column", "stall_polar_column"}, {"stall_attached_max_deg", "stall_attached_max_deg"},
      {"stall_f0_correction_powers", "stall_f0_correction_powers"},
      {"stall_f0_correction_knots_rad", "stall_f0_correction_knots_deg"}, {"stall_known", "stall_known"},
      {"stall_reattachment", "stall_reattachment"}, {"stall_forcing_lag", "stall_forcing_lag"},
      {"stall_hysteresis", "stall_hysteresis"}, {"stall_lag_limit", "stall_lag_limit"}};
  std::set<std::string> present;
  for (const auto& [keyword, key] : keys)
    if (given(c, keyword)) present.insert(key);
  if (given(c, "stall_polar_column")) s.polar_column = c["stall_polar_column"].cast<std::string>();
  if (given(c, "stall_attached_max_deg")) s.attached_max_deg = c["stall_attached_max_deg"].cast<double>();
  if (given(c, "stall_reattachment"))
    s.reattachment = choice<StallReattachment>("stall_reattachment", c["stall_reattachment"].cast<std::string>());
  if (given(c, "stall_forcing_lag"))
    s.forcing_lag = choice<ForcingLag>("stall_forcing_lag", c["stall_forcing_lag"].cast<std::string>());
  if (given(c, "stall_hysteresis"))
    s.hysteresis = choice<StallHysteresis>("stall_hysteresis", c["stall_hysteresis"].cast<std::string>());
  if (given(c, "stall_lag_limit"))
    s.lag_limit = choice<StallLagLimit>("stall_lag_limit", c["stall_lag_limit"].cast<std::string>());
  for (const StallStart& st : stall_starts()) {  // the start values: the file's keys as keywords
    if (!given(c, st.key)) continue;
    present.insert(st.key);
    s.*st.value = c[st.key].cast<double>();
  }
  if (given(c, "stall_known")) {
    for (const auto& [name, value] : c["stall_known"].cast<py::dict>())
      s.known.emplace_back(py::str(name).cast<std::string>(), value.cast<double>());
    // The order the experiment file's reader gives (toml++ tables are sorted by key).
    std::sort(s.known.begin(), s.known.end());
  }
  check_stall_keys(s, present, e.axis, keyword_site());
  if (s.families == StallFamilies::none) return;
  s.f0_correction.powers = ints(c, "stall_f0_correction_powers", {});
  s.f0_correction.knots_rad = finite_doubles(c, "stall_f0_correction_knots_rad");
  if (given(c, "stall_polar_alpha_rad") || given(c, "stall_polar_lift")) {
    read_array_table(c, "stall_polar_alpha_rad", "stall_polar_lift", s.polar_x_rad, s.polar_lift);
    s.polar_path = "stall_polar_alpha_rad";
  } else if (!stall_polar_from_static_table(e, s)) {
    throw InputError("stall", 0, "the dynamic-stall families need the static lift polar: give stall_polar_alpha_rad "
                                 "and stall_polar_lift, or a static table (static_table_x_rad, static_table_value) of "
                                 "the polar's column stall_polar_column = '" + s.polar_column + "'");
  }
}

void read_model_config(const py::dict& c, Experiment& e) {
  ModelConfig& m = e.model;
  m.a.powers = ints(c, "a_powers", m.a.powers);
  m.a.knots_rad = doubles(c, "a_knots_rad");
  m.b1.powers = ints(c, "b1_powers", m.b1.powers);
  m.b1.knots_rad = doubles(c, "b1_knots_rad");
  m.bias = c.contains("bias") && c["bias"].cast<bool>();
  if (c.contains("structure")) m.structure = choice<StructureMode>("structure", c["structure"].cast<std::string>());
  if (c.contains("lags")) m.lags = c["lags"].cast<int>();
  // As the file's model.lags: 1..FitCapacity::max_lags here, the runtime's capacity with the
  // other capacity uses (check_model_capacity).
  if (m.lags < 1 || m.lags > FitCapacity::max_lags)
    throw InputError("lags", 0, "must be 1.." + std::to_string(FitCapacity::max_lags));
  e.static_curve.polynomial = doubles(c, "static_polynomial");
  e.rotary.polynomial = doubles(c, "rotary_polynomial");
  e.rotary.estimate = c.contains("rotary_estimate") && c["rotary_estimate"].cast<bool>();
  if (e.rotary.estimate) {
    e.rotary.candidates.powers = ints(c, "rotary_powers", {0});
    e.rotary.candidates.knots_rad = doubles(c, "rotary_knots_rad");
  }
  for (const char* key : {"static_polynomial", "rotary_polynomial", "a_knots_rad", "b1_knots_rad", "rotary_knots_rad"}) {
    const std::string bad = first_non_finite(doubles(c, key), key);
    if (!bad.empty()) throw InputError(bad);
  }
  if (m.a.powers.empty() && m.a.knots_rad.empty()) throw InputError("a_powers", 0, "a(x) needs at least one term");
  if (m.b1.powers.empty() && m.b1.knots_rad.empty()) throw InputError("b1_powers", 0, "b1(x) needs at least one term");
  read_static_table_keywords(c, e);
  read_delay_keywords(c, m);
  read_stall_keywords(c, e);
}

// Every capacity use of the keywords, as the file's keys (the static table's at its reading,
// read_static_table_keywords).
void check_model_capacity(Experiment& e) {
  using Pool = CapacityUse::Pool;
  check_spline_capacity(e, e.model.a, "a_powers", "a_knots_rad", Pool::model_stepwise);
  check_spline_capacity(e, e.model.b1, "b1_powers", "b1_knots_rad", Pool::model_stepwise);
  check_spline_capacity(e, e.model.stall.f0_correction, "stall_f0_correction_powers", "stall_f0_correction_knots_rad",
                        Pool::none);
  if (e.rotary.estimate)
    check_spline_capacity(e, e.rotary.candidates, "rotary_powers", "rotary_knots_rad", Pool::rotary_estimate);
  check_capacity(e, {"static_polynomial", "coefficients", static_cast<int>(e.static_curve.polynomial.size()),
                     DefaultCapacity::max_powers});
  check_capacity(e, {"rotary_polynomial", "coefficients", static_cast<int>(e.rotary.polynomial.size()),
                     DefaultCapacity::max_powers});
  check_capacity(e, {"lags", "lags", e.model.lags, DefaultCapacity::max_lags});
}

std::shared_ptr<Experiment> make_experiment(const py::dict& c, const py::list& runs) {
  auto e = std::make_shared<Experiment>();
  e->path = c.contains("name") ? c["name"].cast<std::string>() : std::string("experiment");
  e->axis = choice<Axis>("axis", c.contains("axis") ? c["axis"].cast<std::string>() : "pitch");
  e->coefficient = c["coefficient"].cast<std::string>();
  if (e->coefficient.empty() || e->coefficient.size() > 7) throw InputError("coefficient", 0, "expected a name like 'Cm'");
  e->reference_length_m = c["reference_length_m"].cast<double>();
  e->airspeed_mps = c["airspeed_mps"].cast<double>();
  e->alpha0_rad = c.contains("alpha0_rad") ? c["alpha0_rad"].cast<double>() : 0.0;
  if (!(e->reference_length_m > 0.0) || !std::isfinite(e->reference_length_m))
    throw InputError("reference_length_m", 0, "must be a finite number > 0");
  if (!(e->airspeed_mps > 0.0) || !std::isfinite(e->airspeed_mps))
    throw InputError("airspeed_mps", 0, "must be a finite number > 0");
  if (!std::isfinite(e->alpha0_rad)) throw InputError("alpha0_rad", 0, "must be finite");
  read_model_config(c, *e);
  if (runs.size() == 0) throw InputError(e->path, 0, "no runs given");
  for (std::size_t i = 0; i < runs.size(); ++i) {
    const std::string label = "run " + std::to_string(i + 1);
    Run run = make_run(runs[i].cast<py::dict>(), label);
    if (run.airspeed_mps == 0.0) run.airspeed_mps = e->airspeed_mps;
    e->runs.push_back(std::move(run));
  }
  if (const std::optional<GroupMix> mix = run_group_mix(*e))
    throw InputError("run " + std::to_string(mix->ungrouped + 1), 0,
                     run_group_mix_problem(e->runs[mix->ungrouped].path, e->runs[mix->grouped].path,
                                           e->runs[mix->grouped].group));
  set_data_range(*e);
  check_knots(*e, e->model.a.knots_rad, "a_knots_rad");
  check_knots(*e, e->model.b1.knots_rad, "b1_knots_rad");
  check_knots(*e, e->rotary.candidates.knots_rad, "rotary_knots_rad");
  check_knots(*e, e->model.stall.f0_correction.knots_rad, "stall_f0_correction_knots_rad");
  check_model_capacity(*e);
  const std::string uncovered = static_table_coverage_problem(*e);
  if (!uncovered.empty()) throw InputError(uncovered);
  if (std::none_of(e->runs.begin(), e->runs.end(), [](const Run& r) {
        const auto [lo, hi] = std::minmax_element(r.motion_angle_rad.begin(), r.motion_angle_rad.end());
        return *hi - *lo > 1e-9;
      }))
    throw InputError(e->path, 0, "no run moves: the motion angle is constant in every run, so a(x) and b1(x) "
                                 "cannot be identified");
  return e;
}

// The experiment as files the command line reads: experiment.toml, run<i>.csv, with a static
// table static_table.csv (alpha_rad or beta_rad, the coefficient, and CL when the experiment has
// the table's lift column, Experiment::table_lift_polar), with a stall polar of its own
// stall_polar.csv (alpha_rad and the polar's column). The angles in rad and the rate in rad/s
// as the shortest round-trip numbers, so the command line reads back exactly these doubles.
// Returns (file name, text) pairs, experiment.toml last.
std::vector<std::pair<std::string, std::string>> experiment_files(const Experiment& e) {
  std::vector<std::pair<std::string, std::string>> files;
  Experiment copy = e;
  const std::string x_column = std::string(e.axis == Axis::pitch ? "alpha" : "beta") + "_rad";
  for (std::size_t i = 0; i < copy.runs.size(); ++i) {
    Run& run = copy.runs[i];
    run.path = "run" + std::to_string(i + 1) + ".csv";
    // The CSV written has a time column: a phase cycle or a run of files at their own phases
    // (resampled) is written as that time column of one periodic cycle, `periodic = true`,
    // without the phase-only keys (frequency_hz, files) that the reader refuses beside a time
    // column (a phase-averaged experiment's files did not read back).
    run.source_files.clear();
    run.resampled_points = 0;
    run.time_source = TimeSource::time_column;
    std::vector<CsvColumn> cols{{"time_s", run.time_s}, {std::string(angle_base(e.axis)) + "_rad", run.motion_angle_rad}};
    if (run.rate_from_file) cols.push_back({std::string(rate_base(e.axis)) + "_radps", run.rate_radps});
    cols.push_back({e.coefficient, run.coefficient});
    files.emplace_back(run.path, write_run_csv(cols, {"written by indicial (Python) from " + e.runs[i].path}));
  }
  StallConfig& st = copy.model.stall;
  // The polar is the static table's file only when the reader takes it from there by default.
  const bool polar_in_table = st.polar_path == e.static_curve.table_path && e.coefficient == st.polar_column;
  if (e.static_curve.kind == StaticKind::table) {
    copy.static_curve.table_path = "static_table.csv";
    std::vector<CsvColumn> cols{{x_column, e.static_curve.table_x_rad}, {e.coefficient, e.static_curve.table_value}};
    // The table's lift column (a Cm experiment's CL), which the reader takes as table_lift_polar.
    if (!e.table_lift_polar.empty()) {
      if (e.table_lift_polar.x_rad != e.static_curve.table_x_rad)
        throw InputError(e.table_lift_polar.path + ": the lift polar's angles are not the static table's: it cannot "
                         "be written as the table's CL column");
      cols.push_back({"CL", e.table_lift_polar.lift});
      copy.table_lift_polar.path = copy.static_curve.table_path;
    }
    files.emplace_back(copy.static_curve.table_path, write_run_csv(cols, {"the static table, written by indicial (Python)"}));
  }
  if (st.families != StallFamilies::none) {
    st.polar_path = polar_in_table ? copy.static_curve.table_path : "stall_polar.csv";
    if (!polar_in_table)
      files.emplace_back(st.polar_path, write_run_csv({{"alpha_rad", st.polar_x_rad}, {st.polar_column, st.polar_lift}},
                                                      {"the static lift polar, written by indicial (Python)"}));
  }
  files.emplace_back("experiment.toml", write_experiment_toml(copy, {"written by indicial (Python)"}));
  return files;
}

// experiment_files() into DIR, whole or nothing (OutputDir).
void write_files(const Experiment& e, const std::string& dir, bool force) {
  OutputDir out(dir, force ? Overwrite::replace : Overwrite::refuse);
  for (const auto& [name, text] : experiment_files(e)) out.write(name, text);
  out.commit();
}

py::dict run_dict(const Run& r) {
  py::dict d;
  d["name"] = r.path;
  d["time_s"] = to_numpy(r.time_s);
  d["motion_angle_rad"] = to_numpy(r.motion_angle_rad);
  d["rate_radps"] = to_numpy(r.rate_radps);
  d["coefficient"] = to_numpy(r.coefficient);
  d["periodic"] = r.periodic;
  d["airspeed_mps"] = r.airspeed_mps;
  d["time_grid"] = name_of(r.time_grid);
  d["group"] = r.group.empty() ? py::object(py::none()) : py::object(py::str(r.group));
  return d;
}

}  // namespace

void bind_experiment(py::module_& m) {
  py::class_<Experiment, std::shared_ptr<Experiment>>(m, "_Experiment")
      .def_readonly("path", &Experiment::path)
      .def_property_readonly("axis", [](const Experiment& e) { return std::string(axis_name(e.axis)); })
      .def_readonly("coefficient", &Experiment::coefficient)
      .def_readonly("reference_length_m", &Experiment::reference_length_m)
      .def_readonly("airspeed_mps", &Experiment::airspeed_mps)
      .def_readonly("alpha0_rad", &Experiment::alpha0_rad)
      .def_readonly("data_x_min_rad", &Experiment::data_x_min_rad)
      .def_readonly("data_x_max_rad", &Experiment::data_x_max_rad)
      .def_readonly("warnings", &Experiment::warnings)
      .def_readonly("notes", &Experiment::notes)
      .def_property_readonly("structure", [](const Experiment& e) { return std::string(name_of(e.model.structure)); })
      .def_property_readonly("runs", [](const Experiment& e) {
        py::list l;
        for (const Run& r : e.runs) l.append(run_dict(r));
        return l;
      })
      .def("write_files", &write_files, py::arg("dir"), py::arg("force") = false)
      .def("toml_text", [](const Experiment& e) { return experiment_files(e).back().second; });

  m.def("_load_experiments", [](const std::string& path) {
    std::vector<Experiment> es = load_experiments(path);
    std::vector<std::shared_ptr<Experiment>> out;
    for (Experiment& e : es) out.push_back(std::make_shared<Experiment>(std::move(e)));
    return out;
  }, py::arg("path"));
  m.def("_load_experiment", [](const std::string& path, const std::string& coefficient) {
    return std::make_shared<Experiment>(load_experiment(path, coefficient));
  }, py::arg("path"), py::arg("coefficient") = "");
  m.def("_make_experiment", &make_experiment, py::arg("config"), py::arg("runs"));
  // The runs only (load_experiment_runs: no [static], [rotary] or [model] read), per
  // coefficient: a held-out cycle's files, resampled and derived exactly as fit reads them.
  m.def("_read_runs", [](const std::string& path) {
    py::dict out;
    for (const Experiment& e : load_experiment_runs(path)) {
      py::list runs;
      for (const Run& r : e.runs) {
        py::dict d = run_dict(r);
        d["frequency_hz"] = r.frequency_hz;
        d["axis"] = std::string(axis_name(e.axis));
        d["warnings"] = r.warnings;
        runs.append(d);
      }
      out[py::str(e.coefficient)] = runs;
    }
    return out;
  }, py::arg("path"));
  // The stall start values' keys (experiment_checks.hpp stall_starts(), the one table), which
  // Experiment's keywords must list (python/tests/test_experiment.py).
  m.def("_stall_start_keys", [] {
    std::vector<std::string> keys;
    for (const StallStart& st : stall_starts()) keys.emplace_back(st.key);
    return keys;
  });
}

}  // namespace indicial::python
