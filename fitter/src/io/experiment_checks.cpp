// The configuration checks both front ends call. See indicial/fitter/experiment_checks.hpp.
#include <algorithm>
#include "indicial/fitter/experiment_checks.hpp"

#include <cmath>
#include <cstdio>
#include <iterator>
#include <string>
#include <vector>

#include "indicial/fitter/experiment_toml.hpp"
#include "indicial/model.hpp"

namespace indicial {
namespace {

// The keys of the stall families besides the start values (stall_starts()), as [model] names
// (docs/formats.md's stall table).
const char* const kStallKeys[] = {"stall_polar", "stall_polar_column", "stall_attached_max_deg",
                                  "stall_f0_correction_degree", "stall_f0_correction_powers",
                                  "stall_f0_correction_knots_deg", "stall_known", "stall_reattachment",
                                  "stall_forcing_lag", "stall_hysteresis", "stall_lag_limit"};

// The stall parameters stall_known may name, with the feasible set model.hpp's
// check_stall_parameters enforces (a parameter with a start value: the start's bound, the same
// set). Their start keys are stall_starts()'s (stall_start_key).
enum class Bound { any, positive, non_negative, angle_to_20_deg };  // the last: [0, 20 deg] in rad
enum class Family { separation, reattachment, hysteresis, lag_limit, vortex };
static_assert(kMaxReattachShiftRad == kMaxLagLimitRad, "Bound::angle_to_20_deg is both bounds");
struct StallParameter { const char* name; Bound bound; Family family; };
const StallParameter kStallParameters[] = {
    {"T1", Bound::positive, Family::separation},     {"T2", Bound::non_negative, Family::separation},
    {"k0", Bound::any, Family::separation},          {"k1", Bound::any, Family::separation},
    {"k2", Bound::any, Family::separation},          {"CN1", Bound::positive, Family::vortex},
    {"Tv", Bound::positive, Family::vortex},         {"Tvl", Bound::positive, Family::vortex},
    {"cv", Bound::any, Family::vortex},              {"xv", Bound::any, Family::vortex},
    {"T1r", Bound::positive, Family::reattachment},   {"dxr", Bound::angle_to_20_deg, Family::hysteresis},
    {"dxl", Bound::angle_to_20_deg, Family::lag_limit}};

const StallParameter* stall_parameter(const std::string& name) {
  for (const StallParameter& p : kStallParameters)
    if (name == p.name) return &p;
  return nullptr;
}

// stall_known's entries: each a parameter of the separation or the vortex family, in its
// feasible set, without a start value beside it.
void check_stall_known(const StallConfig& s, const std::set<std::string>& given, const KeySite& site) {
  for (const auto& [name, v] : s.known) {
    const std::string key = "stall_known." + name, where = site.name(key);
    const StallParameter* k = stall_parameter(name);
    if (!k)
      site.raise(key, "'" + site.name("stall_known") + "' names '" + name + "', not a dynamic-stall parameter (T1, "
                      "T2, k0, k1, k2; with the vortex also CN1, Tv, Tvl, cv, xv; with stall_reattachment = "
                      "\"estimated\" also T1r; with stall_hysteresis = \"estimated\" also dxr; with "
                      "stall_lag_limit = \"estimated\" also dxl)");
    if (k->family == Family::reattachment && s.reattachment != StallReattachment::estimated)
      site.raise(key, "'" + where + "' is the reattachment time constant: it needs " +
                      site.name("stall_reattachment") + " = \"estimated\"");
    if (k->family == Family::hysteresis && s.hysteresis != StallHysteresis::estimated)
      site.raise(key, "'" + where + "' is the static hysteresis: it needs " + site.name("stall_hysteresis") +
                      " = \"estimated\"");
    if (k->family == Family::lag_limit && s.lag_limit != StallLagLimit::estimated)
      site.raise(key, "'" + where + "' is the forcing lag's limit: it needs " + site.name("stall_lag_limit") +
                      " = \"estimated\"");
    if (k->family == Family::vortex && s.families != StallFamilies::separation_and_vortex)
      site.raise(key, "'" + where + "' is a vortex parameter: it needs " + site.name("stall") +
                      " = \"separation_and_vortex\"");
    if (!std::isfinite(v)) site.raise(key, "'" + where + "' must be finite");
    if (k->bound == Bound::positive && !(v > 0.0)) site.raise(key, "'" + where + "' must be > 0");
    if (k->bound == Bound::non_negative && !(v >= 0.0)) site.raise(key, "'" + where + "' must be >= 0");
    if (k->bound == Bound::angle_to_20_deg && !(v >= 0.0 && v <= kMaxReattachShiftRad))
      site.raise(key, "'" + where + "' must be in [0, 0.349] rad (0 to 20 deg)");
    const char* start_key = stall_start_key(name);
    if (start_key && given.count(start_key))
      site.raise(key, "'" + where + "' holds " + name + " at a known value, and '" + site.name(start_key) +
                      "' gives it a start value: drop one of the two");
  }
}
}  // namespace

std::string deg_text(double rad) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", rad * (180.0 / 3.14159265358979323846));
  return buf;
}

std::optional<GroupMix> run_group_mix(const Experiment& e) {
  const auto grouped = std::find_if(e.runs.begin(), e.runs.end(), [](const Run& r) { return !r.group.empty(); });
  const auto ungrouped = std::find_if(e.runs.begin(), e.runs.end(), [](const Run& r) { return r.group.empty(); });
  if (grouped == e.runs.end() || ungrouped == e.runs.end()) return std::nullopt;
  return GroupMix{static_cast<std::size_t>(ungrouped - e.runs.begin()), static_cast<std::size_t>(grouped - e.runs.begin())};
}

std::string run_group_mix_problem(const std::string& ungrouped_name, const std::string& grouped_name,
                                  const std::string& group) {
  return "run '" + ungrouped_name + "' has no 'group' while run '" + grouped_name + "' has group '" + group +
         "': give every run a group (diagnose --cv-unit group leaves whole groups out) or none";
}

std::string periodic_closure_problem(const Run& run) {
  const std::vector<double>& a = run.motion_angle_rad;
  const std::size_t n = a.size();
  if (n < 3 || run.time_s.size() != n) return "";
  double largest = 0.0;
  for (std::size_t i = 1; i < n; ++i) largest = std::max(largest, std::abs(a[i] - a[i - 1]));
  const double wrap = std::abs(a.front() - a.back());
  if (!(wrap > 2.0 * largest + 1e-12)) return "";
  std::string cycles;
  if (run.frequency_hz > 0.0) {
    const double span_s = run.time_s.back() - run.time_s.front() + (run.time_s[1] - run.time_s[0]);
    char buf[64];
    std::snprintf(buf, sizeof buf, "; at %.6g Hz it holds %.3g cycles", run.frequency_hz, span_s * run.frequency_hz);
    cycles = buf;
  }
  char ratio[32];
  std::snprintf(ratio, sizeof ratio, "%.3g", largest > 0.0 ? wrap / largest : 0.0);
  return "declared periodic (one cycle, wrapping from its last sample back to its first), but the angle jumps "
         "from " + deg_text(a.back()) + " to " + deg_text(a.front()) + " deg at the wrap, " + ratio +
         " times the largest step inside the run" + cycles +
         ": not one whole cycle (cut it to one period, or drop 'periodic' for a record of several cycles)";
}

void KeySite::raise(const std::string& key, const std::string& problem) const {
  fail(key, problem);
  throw InputError(problem);  // a `fail` that returned: still an error
}

void check_static_table(const std::vector<double>& x_rad, const std::vector<double>& value, const TableSite& site) {
  constexpr std::size_t whole = static_cast<std::size_t>(-1);
  if (x_rad.size() != value.size())
    throw site.error(whole, "the table has " + std::to_string(x_rad.size()) + " angles and " +
                                std::to_string(value.size()) + " values");
  if (x_rad.size() < 2) throw site.error(x_rad.empty() ? whole : x_rad.size() - 1, "a static table needs at least 2 rows");
  if (x_rad.size() > static_cast<std::size_t>(FitCapacity::max_table_points))
    throw site.error(whole, "a static table may have at most " + std::to_string(FitCapacity::max_table_points) +
                                " rows");
  for (std::size_t i = 1; i < x_rad.size(); ++i)
    if (!(x_rad[i] > x_rad[i - 1]))
      throw site.error(i, "the angle column is not strictly increasing (" + site.angle_text(i) + " after " +
                              site.angle_text(i - 1) + ")");
}

std::string static_table_coverage_problem(const Experiment& e) {
  if (e.static_curve.kind != StaticKind::table) return {};
  const double x_min = e.data_x_min_rad, x_max = e.data_x_max_rad;
  const double tmin = e.static_curve.table_x_rad.front(), tmax = e.static_curve.table_x_rad.back();
  const double tol = 1e-9;  // rad: rounding of degree columns
  if (!(tmin > x_min + tol || tmax < x_max - tol)) return {};
  const std::string xname = e.axis == Axis::pitch ? "alpha" : "beta";
  return "the static table '" + e.static_curve.table_path + "' covers " + xname + " [" + deg_text(tmin) + ", " +
         deg_text(tmax) + "] deg but the runs reach [" + deg_text(x_min) + ", " + deg_text(x_max) + "] deg";
}

void check_knot_list(const std::vector<double>& knots_rad, const std::string& key, const EntryError& error) {
  for (std::size_t i = 1; i < knots_rad.size(); ++i)
    if (!(knots_rad[i] > knots_rad[i - 1])) throw error(i, "'" + key + "' must be strictly increasing");
  if (knots_rad.size() > static_cast<std::size_t>(FitCapacity::max_knots))
    throw error(static_cast<std::size_t>(-1),
                "'" + key + "' has more than " + std::to_string(FitCapacity::max_knots) + " knots");
}

void check_knots_in_data(const Experiment& e, const std::vector<double>& knots_rad, const std::string& key,
                         const EntryError& error) {
  const double x_min = e.data_x_min_rad, x_max = e.data_x_max_rad;
  const std::string xname = e.axis == Axis::pitch ? "alpha" : "beta";
  for (std::size_t i = 0; i < knots_rad.size(); ++i)
    if (!(knots_rad[i] > x_min && knots_rad[i] < x_max))
      throw error(i, "'" + key + "': knot " + deg_text(knots_rad[i]) + " deg is outside the data's " + xname +
                         " range [" + deg_text(x_min) + ", " + deg_text(x_max) + "] deg");
}

void check_delay_keys(const ModelConfig& m, bool start_given, const KeySite& site) {
  if (!start_given) return;
  const std::string key = site.name("delay_start_s");
  if (!(m.delay_start_s >= 0.0 && m.delay_start_s <= 1.0)) site.raise("delay_start_s", "'" + key + "' must be in [0, 1] s");
  if (m.delay != DelayEstimation::estimated)
    site.raise("delay_start_s", "'" + key + "' is used only with " + site.name("delay") + " = \"estimated\"");
}

void check_stall_keys(const StallConfig& s, const std::set<std::string>& given, Axis axis, const KeySite& site) {
  // Why pitch only: the separation point and the vortex are driven by the angle of attack and
  // its static lift polar (model.hpp, "Dynamic stall"); roll and yaw move another angle.
  if (s.families != StallFamilies::none && axis != Axis::pitch)
    site.raise("stall", "'" + site.name("stall") + "' = \"" + name_of(s.families) +
                            "\": the dynamic-stall families are for a pitch experiment (they act on the angle of "
                            "attack and its lift polar); this experiment's axis is " + axis_name(axis));
  if (s.families == StallFamilies::none) {
    std::vector<std::string> keys(std::begin(kStallKeys), std::end(kStallKeys));
    for (const StallStart& st : stall_starts()) keys.emplace_back(st.key);
    for (const std::string& key : keys)
      if (given.count(key))
        site.raise(key, "'" + site.name(key) + "' is used only with " + site.name("stall") +
                            " = \"separation\" or \"separation_and_vortex\"");
    return;
  }
  auto check_bound = [&](const char* key, bool ok, StartBound bound) {
    if (given.count(key) && !ok)
      site.raise(key, "'" + site.name(key) + (bound == StartBound::non_negative ? "' must be >= 0"
                                              : bound == StartBound::angle_to_20_deg ? "' must be in (0, 0.349] rad (20 deg)"
                                                                                : "' must be > 0"));
  };
  check_bound("stall_attached_max_deg", s.attached_max_deg > 0.0 && std::isfinite(s.attached_max_deg),
              StartBound::positive);
  for (const StallStart& st : stall_starts()) {
    check_bound(st.key, start_in_bound(st, s.*st.value), st.bound);
    if (given.count(st.key) && !stall_start_used(st, s))
      site.raise(st.key, "'" + site.name(st.key) + "' is used only with " +
                             site.name(stall_start_condition(st).key) + " = \"" + stall_start_condition(st).value + "\"");
  }
  if (s.lag_limit == StallLagLimit::estimated && s.forcing_lag != ForcingLag::delay)
    site.raise("stall_lag_limit", "'" + site.name("stall_lag_limit") + "' = \"estimated\" limits the delay form's lag (x - "
                                  "T2 (l/V) x'); with " + site.name("stall_forcing_lag") + " = \"" +
                                  name_of(s.forcing_lag) + "\" there is no such lag to limit");
  check_stall_known(s, given, site);
}

const std::vector<StallStart>& stall_starts() {
  static const std::vector<StallStart> starts = {
      {"stall_T1_start", "T1", &StallConfig::tau1_start, StartBound::positive, "l / V", nullptr, 3.0},
      {"stall_T2_start", "T2", &StallConfig::tau2_start, StartBound::non_negative, "l / V", nullptr, 1.5},
      {"stall_CN1_start", "CN1", &StallConfig::shedding_threshold_start, StartBound::positive, "C_N",
       "from the polar, where f0 falls below 0.7", 1.2},
      {"stall_Tv_start", "Tv", &StallConfig::decay_start, StartBound::positive, "l / V", nullptr, 6.0},
      {"stall_Tvl_start", "Tvl", &StallConfig::travel_start, StartBound::positive, "l / V", nullptr, 7.0},
      {"stall_T1r_start", "T1r", &StallConfig::tau1_reattach_start, StartBound::positive, "l / V",
       "T1's start (stall_T1_start); only with stall_reattachment = \"estimated\"", 8.0,
       StartUse::with_reattachment_estimated},
      {"stall_dxr_start", "dxr", &StallConfig::reattach_shift_start_rad, StartBound::angle_to_20_deg, "rad", nullptr,
       0.05, StartUse::with_hysteresis_estimated},
      {"stall_dxl_start", "dxl", &StallConfig::lag_limit_start_rad, StartBound::angle_to_20_deg, "rad", nullptr, 0.1,
       StartUse::with_lag_limit_estimated}};
  return starts;
}

bool stall_start_used(const StallStart& start, const StallConfig& s) {
  switch (start.use) {
    case StartUse::with_families: return true;
    case StartUse::with_reattachment_estimated: return s.reattachment == StallReattachment::estimated;
    case StartUse::with_hysteresis_estimated: return s.hysteresis == StallHysteresis::estimated;
    case StartUse::with_lag_limit_estimated: return s.lag_limit == StallLagLimit::estimated;
  }
  return true;
}

StartCondition stall_start_condition(const StallStart& start) {
  switch (start.use) {
    case StartUse::with_families: return {nullptr, nullptr};
    case StartUse::with_reattachment_estimated: return {"stall_reattachment", "estimated"};
    case StartUse::with_hysteresis_estimated: return {"stall_hysteresis", "estimated"};
    case StartUse::with_lag_limit_estimated: return {"stall_lag_limit", "estimated"};
  }
  return {nullptr, nullptr};
}

bool start_in_bound(const StallStart& start, double v) {
  if (!std::isfinite(v)) return false;
  switch (start.bound) {
    case StartBound::positive: return v > 0.0;
    case StartBound::non_negative: return v >= 0.0;
    case StartBound::angle_to_20_deg: return v > 0.0 && v <= kMaxReattachShiftRad;
  }
  return false;
}

const char* stall_start_key(const std::string& parameter) {
  for (const StallStart& st : stall_starts())
    if (parameter == st.parameter) return st.key;
  return nullptr;
}

bool stall_start_held(const StallConfig& s, const std::string& start_key) {
  for (const auto& held : s.known)
    if (const char* key = stall_start_key(held.first); key && start_key == key) return true;
  return false;
}

void check_runtime_capacity(const CapacityUse& use, Experiment& e,
                            const std::function<InputError(const std::string& problem)>& error,
                            const std::string& warning_site) {
  if (use.needed <= use.limit) return;
  const bool pool = (use.pool == CapacityUse::Pool::model_stepwise && e.model.structure == StructureMode::stepwise) ||
                    (use.pool == CapacityUse::Pool::rotary_estimate && e.rotary.estimate);
  std::string text = "'" + use.key + "' needs " + std::to_string(use.needed) + " " + use.what +
                     "; the runtime (indicial::DefaultCapacity) holds at most " + std::to_string(use.limit);
  // A digitized or finely tabulated polar: the runtime interpolates linearly between rows, so
  // the table is the user's to thin (where it is straight), not ours to change silently.
  if (use.key == "static.table")
    text += " (thin the table to at most " + std::to_string(use.limit) +
            " rows: keep those where the curve bends, drop rows where it is straight)";
  if (!pool) throw error(text);
  e.warnings.push_back(warning_site + text + ": a candidate pool may exceed it, the selected model must not");
}

bool stall_polar_from_static_table(const Experiment& e, StallConfig& s) {
  if (e.static_curve.kind != StaticKind::table) return false;
  if (e.coefficient == s.polar_column) {
    s.polar_path = e.static_curve.table_path;
    s.polar_x_rad = e.static_curve.table_x_rad;
    s.polar_lift = e.static_curve.table_value;
    return true;
  }
  // A Cm experiment whose table also has the lift: the polar diagnose offers the families with.
  if (s.polar_column != "CL" || e.table_lift_polar.empty()) return false;
  s.polar_path = e.table_lift_polar.path;
  s.polar_x_rad = e.table_lift_polar.x_rad;
  s.polar_lift = e.table_lift_polar.lift;
  return true;
}

}  // namespace indicial
