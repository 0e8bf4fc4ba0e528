// `indicial init`: a commented template experiment file.
//
//   indicial init FILE.toml [--case NAME] [--force]
//
// Every experiment key appears in FILE.toml with its unit, default and meaning as comments
// (the keys not set are there too, commented out). The values are a built-in case's (default
// tailless-model-1, the report's Example 1): `indicial simulate --case NAME --out DIR` writes
// that case's run files, so `init --case NAME DIR/mine.toml` then `fit DIR/mine.toml` works
// as it stands. The values are written by the experiment writer (write_experiment_toml), so
// the template reads back exactly; this file only adds the documentation around them.
// docs/formats.md is the same documentation in prose.
#include <algorithm>
#include <cstdio>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "command.hpp"
#include "indicial/fitter/dynamic_stall.hpp"
#include "indicial/fitter/error.hpp"
#include "indicial/fitter/experiment_checks.hpp"
#include "indicial/fitter/io.hpp"
#include "indicial/fitter/output.hpp"
#include "indicial/fitter/simulate.hpp"

namespace {

struct KeyDoc {
  std::string section;  // "" (top level), "static", "rotary", "model"
  std::string key;
  std::string doc;      // unit, default and meaning; lines separated by '\n'
  std::string example;  // the commented-out line written when the key is not set
};

// The stall start values' docs, one per key of the one table (experiment_checks.hpp
// stall_starts()), with StallConfig's defaults.
std::vector<KeyDoc> stall_start_docs() {
  using indicial::StartBound;
  const indicial::StallConfig defaults;
  std::vector<KeyDoc> docs;
  for (const indicial::StallStart& st : indicial::stall_starts()) {
    const std::string def = st.default_text ? st.default_text : indicial::format_double(defaults.*st.value);
    docs.push_back({"model", st.key,
                    std::string("with stall: the start value of ") + st.parameter + " (" + st.unit +
                        (st.bound == StartBound::positive       ? ", > 0"
                         : st.bound == StartBound::non_negative ? ", >= 0"
                                                                : ", > 0, at most 0.349 = 20 deg") +
                        "). Default " + def +
                        ".\nNone for a parameter held in stall_known.",
                    std::string(st.key) + " = " + indicial::format_double(st.example)});
  }
  return docs;
}

// The docs with the stall start values' (stall_start_docs) before stall_known's.
std::vector<KeyDoc> with_stall_starts(std::vector<KeyDoc> docs) {
  const auto known = std::find_if(docs.begin(), docs.end(), [](const KeyDoc& d) { return d.key == "stall_known"; });
  const std::vector<KeyDoc> starts = stall_start_docs();
  docs.insert(known, starts.begin(), starts.end());
  return docs;
}

// The documentation of every experiment key, in file order.
const std::vector<KeyDoc>& key_docs() {
  static const std::vector<KeyDoc> docs = with_stall_starts({
      {"", "axis", "pitch | roll | yaw (required). The motion: pitch oscillation (model angle x = alpha),\n"
                   "roll (x = beta = asin(sin phi sin alpha0)) or yaw (x = beta = asin(-sin psi cos alpha0)).",
       "axis = \"pitch\""},
      {"", "coefficient", "the run CSV column to model (required): CL, Cm, CD, CY, Cl or Cn (dimensionless).\n"
                          "Or coefficients = [\"CL\", \"Cm\"] (at most 3, never both keys): every listed column fitted\n"
                          "from the same runs into one model.coef; [static], [rotary], [model] then shared or per\n"
                          "coefficient ([static.CL], [static.Cm], ...; docs/formats.md).",
       "coefficient = \"Cm\""},
      {"", "reference_length_m", "l in m, > 0 (required): the length of the rotary term (l/V) C_aq(x) rate:\n"
                                 "mean chord / 2 in pitch, span / 2 in roll and yaw.",
       "reference_length_m = 0.3765"},
      {"", "airspeed_mps", "V in m/s, > 0 (required): the tunnel airspeed. b1(x) and con are in 1/s at this airspeed.",
       "airspeed_mps = 17.667762"},
      {"", "alpha0_deg", "deg: the fixed angle of attack of a roll or yaw experiment (required there, unused in\n"
                         "pitch). alpha0_rad = ... gives it in rad instead.",
       "alpha0_deg = 30.0"},
      {"", "runs", "the run CSV files (required, at least one), relative to this file. Columns: time_s, the\n"
                   "angle (alpha_deg|alpha_rad, phi_..., psi_...), optional rate (q_degps|q_radps, p_..., r_...),\n"
                   "the coefficient. An entry may be {file = \"run.csv\", periodic = true}: an ensemble-averaged\n"
                   "cycle, fitted in its periodic steady state (no y0 parameter). Other run-table keys:\n"
                   "frequency_hz or reduced_frequency (a phase-column run's cycle), airspeed_mps (default the\n"
                   "experiment's), time_grid = \"uniform\" (default) or \"nonuniform\", cycles_averaged = N\n"
                   "(an average of N >= 2 cycles whose file has the spread column <coefficient>_std, the\n"
                   "single cycles' standard deviation: the noise from replication is spread / sqrt(N)),\n"
                   "group = \"entry 5\" (the tunnel entry, campaign or session; all runs or none: with\n"
                   "diagnose --cv-unit group its cross-validation leaves whole groups out).\n"
                   "A cycle whose quantities are at their own phases (digitized histories: a file per quantity,\n"
                   "each with its own phase_deg|phase_rad|phase_cycles column, any spacing): {files = [\"alpha.csv\", \"cl.csv\"],\n"
                   "frequency_hz = 2.0, samples = 128}, resampled onto `samples` uniform phases (default: the\n"
                   "most rows of any file of the run) by a periodic modified Akima cubic. A file whose columns\n"
                   "are named otherwise (a digitizer's x,y) takes its own map over [columns]:\n"
                   "{file = \"cl.csv\", columns = {phase_deg = \"x\", CL = \"y\"}} in place of its name.",
       "runs = [\"run1.csv\", \"run2.csv\"]"},
      {"static", "polynomial", "the static curve C_a(x) = c0 + c1 x + c2 x^2 + ...: coefficients of x^0, x^1, ...\n"
                               "with x = alpha (pitch) or beta (roll, yaw) in RAD. Give polynomial or table (one is required).",
       "polynomial = [0.0, 0.42, 0.34, -1.0, 0.40]"},
      {"static", "table", "instead of polynomial: a CSV with columns alpha_deg (or beta_deg, or _rad) and the\n"
                          "coefficient, angles strictly increasing and covering the data; natural cubic spline.",
       "table = \"static.csv\""},
      {"static", "columns", "with table: the table file's own column names, over [columns] (the runs' map, which\n"
                            "the table uses without this key): a polar headed otherwise than the runs.",
       "columns = { alpha_deg = \"AoA\", CL = \"CL_static\" }"},
      {"rotary", "polynomial", "the a priori rotary derivative C_aq(x): coefficients of x^0, x^1, ... with x in RAD;\n"
                               "multiplies (l/V) rate, rate in rad/s. Default [] (C_aq = 0; so does a missing [rotary]).",
       "polynomial = [-2.0, 0.0, 0.8]"},
      {"rotary", "prior_knots_deg", "a priori knot terms c_j (x - k_j)_+^p_j of C_aq(x): knots k_j in deg (one entry per\n"
                                    "term; known, not identified). Default [].",
       "prior_knots_deg = [20.0]"},
      {"rotary", "prior_knot_powers", "the powers p_j of those terms (integers 0..8). Default 1 each.",
       "prior_knot_powers = [1]"},
      {"rotary", "prior_knot_coefficients", "the coefficients c_j of those terms (x in rad). Required with prior_knots_deg.",
       "prior_knot_coefficients = [-3.0]"},
      {"rotary", "estimate", "true: re-estimate C_aq(x) by the two-stage loop (report eqs. 25-26), starting from\n"
                             "the a priori C_aq. Default false.",
       "estimate = false"},
      {"rotary", "degree", "with estimate = true: candidate powers x^0..x^degree of C_aq(x). Default: the powers\n"
                           "of the a priori polynomial.",
       "degree = 2"},
      {"rotary", "knots_deg", "with estimate = true: candidate plus-function knots (x - k)_+ of C_aq(x), deg. Default [].",
       "knots_deg = []"},
      {"model", "a_degree", "a(x) = sum_i a_i x^i (i = 0..a_degree) + sum_j A_j (x - k_j)_+^2, x in rad,\n"
                            "dimensionless. Default 2.",
       "a_degree = 2"},
      {"model", "a_powers", "instead of a_degree: exactly these powers, e.g. [1, 2] (a(x) without a0, as in the\n"
                            "report's Tables II-IV).",
       "a_powers = [1, 2]"},
      {"model", "a_knots_deg", "the knots k_j of a(x), deg, strictly increasing, strictly inside the data's angle\n"
                               "range. Default [].",
       "a_knots_deg = [25.0, 55.0]"},
      {"model", "b1_degree", "b1(x) = sum_i b1_i x^i + sum_j B_j (x - k_j)_+, in 1/s at airspeed_mps (x in rad).\n"
                             "Default 0 (a constant).",
       "b1_degree = 0"},
      {"model", "b1_powers", "instead of b1_degree: exactly these powers.", "b1_powers = [0, 1]"},
      {"model", "b1_knots_deg", "the knots k_j of b1(x), deg. Default [].", "b1_knots_deg = []"},
      {"model", "bias", "true: estimate a constant con (1/s) in the state equation (report Table V). Default false.",
       "bias = false"},
      {"model", "structure", "fixed: estimate the terms above; stepwise: they are a candidate pool and stepwise\n"
                             "regression picks the structure. Default \"fixed\".",
       "structure = \"fixed\""},
      {"model", "lags", "number of lag states y_j, 1 or more: 2 adds a second lag with its own decay b2(x)\n"
                        "(parameters b2_i) and gain c2. Default 1.",
       "lags = 1"},
      {"model", "static_correction_degree", "an angle-only correction dC_a(x) of the static curve: powers\n"
                                            "0..degree (static_correction_powers = [...] for exact powers), x in rad.\n"
                                            "Default none. Estimated in the output-error step only.",
       "static_correction_degree = 1"},
      {"model", "static_correction_knots_deg", "knots (x - k)_+^2 of dC_a(x), deg. Default [].",
       "static_correction_knots_deg = []"},
      {"model", "rotary_correction_degree", "C_aq(x) terms ADDED to the a priori C_aq: powers 0..degree\n"
                                            "(rotary_correction_powers = [...] for exact powers). Not with\n"
                                            "rotary.estimate = true. Default none.",
       "rotary_correction_degree = 0"},
      {"model", "rotary_correction_knots_deg", "knots (x - k)_+ of that correction, deg. Default [].",
       "rotary_correction_knots_deg = []"},
      {"model", "delay", "\"none\" or \"estimated\": a pure delay of the unsteady forcing, x_f = x(t - delay_s),\n"
                         "delay_s in s at airspeed_mps. Default \"none\".",
       "delay = \"none\""},
      {"model", "delay_start_s", "with delay = \"estimated\": its start value in s, 0..1. Default 0.",
       "delay_start_s = 0.05"},
      {"columns", "alpha_deg", "[columns] (optional) maps the files' column names to ours, for every run and the\n"
                               "static table: our name (with its unit) = the file's name. Default: none (our names).\n"
                               "A database's cycle (% Time() Angle(deg) Cn Ct Cm): phase_rad = \"Time()\",\n"
                               "alpha_deg = \"Angle(deg)\", Cnormal = \"Cn\", Ctangential = \"Ct\" (normal and chord\n"
                               "force, + toward the leading edge; CL and CD are then derived from them and alpha).\n"
                               "Cn is always the yawing moment: map a normal-force column as Cnormal.",
       "alpha_deg = \"AoA\""},
      {"csv", "delimiter", "[csv] (optional) the run files' dialect: delimiter = \"detect\" (default), \"comma\",\n"
                           "\"semicolon\", \"tab\" or \"whitespace\"; comment = the characters that start a\n"
                           "comment line (default \"#%\"; a header in the comment line above numeric rows is read).",
       "delimiter = \"detect\""},
      {"model", "further_lag_start", "with lags >= 2: \"estimated\" (each run's lags 2.. start from an estimated\n"
                                     "state) or \"at_rest\" (from 0). Default \"estimated\".",
       "further_lag_start = \"estimated\""},
      {"model", "stall", "dynamic-stall families (docs/formats.md, model.hpp): \"none\", \"separation\" (a\n"
                         "separation state f, T1 (l/V) f' + f = f0(x - T2 (l/V) x'), output C_Na (x - alpha_0)\n"
                         "[K(f) h(f) - K(f0) h(f0)]: parameters T1, T2, k0, k1, k2) or \"separation_and_vortex\"\n"
                         "(plus a leading-edge vortex: CN1, Tv, Tvl, cv, xv). Default \"none\".",
       "stall = \"none\""},
      {"model", "stall_polar", "with stall: the static LIFT polar f0(x) comes from (Kirchhoff inversion): a CSV with\n"
                               "alpha_deg and the column stall_polar_column. Default: the [static] table when\n"
                               "coefficient is that column.",
       "stall_polar = \"static-lift.csv\""},
      {"model", "stall_polar_column", "with stall: the polar's lift column. Default \"CL\".",
       "stall_polar_column = \"CL\""},
      {"model", "stall_attached_max_deg", "with stall: polar rows with |x| <= this (deg) are its attached part,\n"
                                          "whose least-squares line gives C_Na and alpha_0; f0 = 1 there. Default 8.",
       "stall_attached_max_deg = 8.0"},
      {"model", "stall_f0_correction_degree", "with stall: a fitted correction of f0(x), powers 0..degree\n"
                                              "(stall_f0_correction_powers, stall_f0_correction_knots_deg as for\n"
                                              "a(x); parameters f0c_i, f0cK j). Default none.",
       "stall_f0_correction_degree = 1"},
      {"model", "stall_reattachment", "with stall: \"estimated\" gives the separation state its own time constant\n"
                                      "T1r (l / V) while the flow reattaches (the downstroke below stall);\n"
                                      "default \"as_separation\" (T1 both ways).",
       "stall_reattachment = \"estimated\""},
      {"model", "stall_forcing_lag", "with stall: how T2 lags the forcing angle: \"delay\" (default, x - T2 (l/V) x')\n"
                                     "or \"first_order\" (a filter: its amplitude falls with the frequency,\n"
                                     "as Beddoes-Leishman's lagged normal force).",
       "stall_forcing_lag = \"first_order\""},
      {"model", "stall_hysteresis", "with stall: \"estimated\" gives the separation state a static hysteresis dxr\n"
                                    "(rad): the flow reattaches only dxr closer to alpha_0 than it separated,\n"
                                    "at any rate (the quasi-static loop of stall); default \"none\".",
       "stall_hysteresis = \"estimated\""},
      {"model", "stall_lag_limit", "with stall and the delay forcing lag: \"estimated\" limits the forcing angle's\n"
                                   "lag to dxl = D (rad): x - D tanh(T2 (l/V) x' / D), so fast motions are\n"
                                   "delayed by at most D; default \"none\" (x - T2 (l/V) x').",
       "stall_lag_limit = \"estimated\""},
      {"model", "stall_known", "with stall: parameters held at known values, not estimated (T1, T2, k0, k1,\n"
                               "k2; with the vortex CN1, Tv, Tvl, cv, xv; with stall_reattachment T1r; with\n"
                               "stall_hysteresis dxr, with stall_lag_limit dxl, both in rad), e.g.\n"
                               "a C_m fit taking T1 and T2 from the C_L fit's model.coef. No start value for\n"
                               "a held parameter.",
       "stall_known = { T1 = 3.0, T2 = 1.5 }"},
  });
  return docs;
}

std::string commented(const std::string& doc) {
  std::string out;
  std::istringstream in(doc);
  for (std::string line; std::getline(in, line);) out += "# " + line + "\n";
  return out;
}

// The key a "key = value" line sets, "" for anything else. The alternative spellings
// (alpha0_rad, *_powers) are documented under their primary key.
std::string key_of(const std::string& line) {
  const std::size_t eq = line.find(" = ");
  if (line.empty() || line[0] == '#' || line[0] == '[' || eq == std::string::npos) return "";
  std::string key = line.substr(0, eq);
  if (key == "alpha0_rad") return "alpha0_deg";
  for (const std::string spline : {"static_correction", "rotary_correction"})
    if (key == spline + "_powers") return spline + "_degree";
  return key;
}

const KeyDoc* find_doc(const std::string& section, const std::string& key) {
  for (const KeyDoc& d : key_docs())
    if (section == d.section && key == d.key) return &d;
  return nullptr;
}

// Commented-out examples of the documented keys of `section` that `present` does not set.
std::string absent_keys(const std::string& section, const std::vector<std::string>& present) {
  std::string out;
  for (const KeyDoc& d : key_docs()) {
    if (section != d.section) continue;
    bool set = false;
    for (const std::string& k : present) set = set || k == d.key;
    if (!set) out += commented(d.doc) + "# " + d.example + "\n";
  }
  return out;
}

// write_experiment_toml's text with every key documented (see the file comment).
std::string annotated_template(const indicial::Experiment& e, const std::vector<std::string>& header) {
  const std::string plain = indicial::write_experiment_toml(e, {});
  std::string out;
  for (const std::string& h : header) out += "# " + h + "\n";
  out += "\n";
  std::string section;
  std::vector<std::string> present;
  std::istringstream in(plain);
  auto close_section = [&] { out += absent_keys(section, present); };
  for (std::string line; std::getline(in, line);) {
    if (!line.empty() && line[0] == '[') {
      close_section();
      section = line.substr(1, line.find(']') - 1);
      present.clear();
      out += "\n" + line + "\n";
      continue;
    }
    if (line.empty()) continue;
    const std::string key = key_of(line);
    if (!key.empty()) {
      present.push_back(key);
      if (const KeyDoc* d = find_doc(section, key)) out += commented(d->doc);
    }
    out += line + "\n";
  }
  close_section();
  // Why: the writer emits [columns] only when the experiment maps columns.
  if (plain.find("\n[columns]\n") == std::string::npos) {
    const KeyDoc* d = find_doc("columns", "alpha_deg");
    out += "\n" + commented(d->doc) + "# [columns]\n# " + d->example + "\n";
  }
  if (plain.find("\n[csv]\n") == std::string::npos) {
    const KeyDoc* d = find_doc("csv", "delimiter");
    out += "\n" + commented(d->doc) + "# [csv]\n# " + d->example + "\n# comment = \"#%\"\n";
  }
  return out;
}

struct InitOptions {
  std::string path;
  std::string case_name = "tailless-model-1";
  bool force = false;
};

// The values of a template: a built-in case's (simulate.hpp), or the dynamic-stall campaign's
// C_L experiment as `indicial simulate --case dynamic-stall` writes it (experiment-CL.toml:
// its fit cycles, phase-averaged, each at its frequency and airspeed; the static table).
struct TemplateCase {
  std::string name;
  std::string description;
  indicial::Experiment experiment;
};

TemplateCase template_case(const std::string& name) {
  using namespace indicial;
  if (name != "dynamic-stall") {
    const SimulationCase& c = find_simulation_case(name);
    return {c.name, c.description, c.experiment};
  }
  const dynamic_stall::Campaign& c = dynamic_stall::default_campaign();
  TemplateCase t{name, "phase-averaged pitching cycles through dynamic stall, CL; experiment-Cm.toml is the same for Cm",
                 dynamic_stall::campaign_experiment_config(c, "CL")};
  t.experiment.static_curve.table_path = "static.csv";
  for (const dynamic_stall::PitchCycle& p : c.cycles) {
    if (p.role != dynamic_stall::CycleRole::fit) continue;
    Run r;
    r.path = p.file;
    r.time_source = TimeSource::phase_column;
    r.periodic = true;
    r.frequency_hz = c.frequency_hz(p);
    r.airspeed_mps = p.airspeed_mps;
    t.experiment.runs.push_back(r);
  }
  return t;
}

void run_init(const InitOptions& o) {
  using namespace indicial;
  const TemplateCase c = template_case(o.case_name);
  const std::vector<std::string> header = {
      "indicial experiment file (TOML), written by `" + tools::invocation() + "`.",
      "Every key is listed with its unit, default and meaning; keys not set are commented out.",
      "The full reference is docs/formats.md. Angles in keys ending _deg are degrees; every",
      "polynomial's x is the model angle in RADIANS.",
      "Values: the built-in case " + c.name + " (" + c.description + ").",
      "Its run files are made by: indicial simulate --case " + c.name + " --out DIR (then put this file in DIR).",
  };
  const std::string text = annotated_template(c.experiment, header);
  write_file_atomically(o.path, text, o.force ? Overwrite::replace : Overwrite::refuse);
  std::printf("init: wrote %s (values of the case %s)\n", o.path.c_str(), c.name.c_str());
}

const indicial::tools::RegisterCommand register_init([](CLI::App& app) {
  auto opt = std::make_shared<InitOptions>();
  CLI::App* sub = app.add_subcommand(
      "init",
      "Write a commented template experiment file: every key with its unit, default and meaning.\n"
      "The values are a built-in case's (--case, default tailless-model-1; list: `indicial simulate\n"
      "--list`), whose run files `indicial simulate --case NAME --out DIR` writes.");
  sub->add_option("FILE", opt->path, "the experiment file to write (.toml)")->required();
  sub->add_option("--case", opt->case_name, "built-in case whose values fill the template (default tailless-model-1)");
  sub->add_flag("--force", opt->force, "replace an existing FILE");
  sub->callback([opt]() { run_init(*opt); });
});

}  // namespace
