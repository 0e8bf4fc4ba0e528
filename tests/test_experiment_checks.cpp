// The configuration checks both front ends call (fitter/src/io/experiment_checks.cpp), through
// the experiment file's reader: the message names the file, the line and the key. Python's
// Experiment(...) gets the same checks and words for its keywords (python/tests/test_experiment.py
// runs the same bad inputs through both paths and compares the messages).
#include <doctest/doctest.h>

#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "indicial/fitter/error.hpp"
#include "indicial/fitter/experiment_checks.hpp"
#include "indicial/fitter/experiment_toml.hpp"
#include "test_support.hpp"

TEST_SUITE_BEGIN("unit");  // the ctest label (tests/CMakeLists.txt)

using namespace indicial;
using indicial::testing::kPi;

namespace {

// A run of 64 samples of `angle` (deg) moving 4..20 deg, and the coefficient `coefficient`.
std::string run_csv(const std::string& angle, const std::string& coefficient) {
  std::string text = "time_s," + angle + "_deg," + coefficient + "\n";
  for (int i = 0; i < 64; ++i) {
    const double a = 12.0 + 8.0 * std::sin(2 * kPi * i / 64.0);
    text += std::to_string(i * 0.01) + "," + std::to_string(a) + "," + std::to_string(0.1 * a / 57.3) + "\n";
  }
  return text;
}

// A lift polar of x = -10..30 deg named `angle_deg`, and CL.
std::string polar_csv(const std::string& angle) {
  std::string text = angle + "_deg,CL\n";
  for (int a = -10; a <= 30; ++a) text += std::to_string(a) + "," + std::to_string(6.0 * a * kPi / 180 / (1 + 0.002 * a * a)) + "\n";
  return text;
}

// The line of `needle`'s first occurrence in text (1-based).
int line_of(const std::string& text, const std::string& needle) {
  const std::size_t at = text.find(needle);
  REQUIRE(at != std::string::npos);
  int line = 1;
  for (std::size_t i = 0; i < at; ++i) line += text[i] == '\n';
  return line;
}

std::string load_error(const std::string& path) {
  try {
    load_experiment(path);
  } catch (const InputError& e) {
    return e.what();
  }
  return "(accepted)";
}

}  // namespace

TEST_CASE("stall is refused outside pitch, naming the key, the axis, the file and the line") {
  indicial::testing::TempDir dir("experiment-checks");
  for (const char* axis : {"roll", "yaw"}) {
    CAPTURE(axis);
    const std::string angle = std::string(axis) == "roll" ? "phi" : "psi";
    indicial::testing::write_text(dir.path / "run.csv", run_csv(angle, "Cl"));
    // The polar with the model angle's column of the axis (beta), so that only the axis is wrong.
    indicial::testing::write_text(dir.path / "polar.csv", polar_csv("beta"));
    const std::string toml = std::string("axis = \"") + axis + "\"\ncoefficient = \"Cl\"\nreference_length_m = 0.5\n"
                             "airspeed_mps = 30.0\nalpha0_deg = 10\nruns = [\"run.csv\"]\n[static]\n"
                             "polynomial = [0.0, 0.1]\n[rotary]\npolynomial = [0.0]\n[model]\n"
                             "stall = \"separation\"\nstall_polar = \"polar.csv\"\n";
    const std::string path = indicial::testing::write_text(dir.path / "e.toml", toml);
    CHECK_HAS(load_error(path), path + ":" + std::to_string(line_of(toml, "stall =")) +
                                    ": 'model.stall' = \"separation\": the dynamic-stall families are for a pitch "
                                    "experiment (they act on the angle of attack and its lift polar); this "
                                    "experiment's axis is " + axis);
  }
  // The same file in pitch is accepted (the refusal is the axis, nothing else).
  indicial::testing::write_text(dir.path / "run.csv", run_csv("alpha", "Cl"));
  indicial::testing::write_text(dir.path / "polar.csv", polar_csv("alpha"));
  const std::string pitch = indicial::testing::write_text(dir.path / "e.toml",
                                       "axis = \"pitch\"\ncoefficient = \"Cl\"\nreference_length_m = 0.5\n"
                                       "airspeed_mps = 30.0\nruns = [\"run.csv\"]\n[static]\npolynomial = [0.0, 0.1]\n"
                                       "[rotary]\npolynomial = [0.0]\n[model]\nstall = \"separation\"\n"
                                       "stall_polar = \"polar.csv\"\n");
  CHECK(load_experiment(pitch).model.stall.families == StallFamilies::separation);
}

TEST_CASE("the knot checks name the entry's line, in the words Python's keywords get") {
  indicial::testing::TempDir dir("experiment-checks");
  indicial::testing::write_text(dir.path / "run.csv", run_csv("alpha", "Cm"));
  auto toml = [](const std::string& knots) {
    return "axis = \"pitch\"\ncoefficient = \"Cm\"\nreference_length_m = 0.5\nairspeed_mps = 30.0\nruns = [\"run.csv\"]\n"
           "[static]\npolynomial = [0.0, 0.1]\n[rotary]\npolynomial = [0.0]\n[model]\na_knots_deg = [\n  " + knots +
           "\n]\n";
  };
  const std::string unordered = toml("10,\n  8");
  const std::string path = indicial::testing::write_text(dir.path / "e.toml", unordered);
  CHECK(load_error(path) == path + ":" + std::to_string(line_of(unordered, "  8")) +
                                ": 'model.a_knots_deg' must be strictly increasing");
  const std::string outside = indicial::testing::write_text(dir.path / "e.toml", toml("10,\n  30"));
  CHECK(load_error(outside) == outside + ":" + std::to_string(line_of(toml(""), "a_knots_deg")) + ": 'model.a_knots_deg': knot 30 deg is outside the data's alpha range "
                                         "[4, 20] deg");
  // The functions Python calls, with its keyword: the same words.
  const EntryError as_is = [](std::size_t, const std::string& problem) { return InputError(problem); };
  CHECK_THROWS_WITH_AS(check_knot_list({0.2, 0.1}, "a_knots_rad", as_is), "'a_knots_rad' must be strictly increasing",
                       InputError);
  Experiment e;
  e.data_x_min_rad = 4 * kPi / 180;
  e.data_x_max_rad = 20 * kPi / 180;
  CHECK_THROWS_WITH_AS(check_knots_in_data(e, {30 * kPi / 180}, "a_knots_rad", as_is),
                       "'a_knots_rad': knot 30 deg is outside the data's alpha range [4, 20] deg", InputError);
}

namespace {

// A C_L run and its lift polar (the static table) in dir; returns the experiment file's text up
// to the [model] section's stall = "separation_and_vortex", for the test to add stall keys to.
std::string write_stall_case(const indicial::testing::TempDir& dir) {
  indicial::testing::write_text(dir.path / "run.csv", run_csv("alpha", "CL"));
  indicial::testing::write_text(dir.path / "polar.csv", polar_csv("alpha"));
  return "axis = \"pitch\"\ncoefficient = \"CL\"\nreference_length_m = 0.5\nairspeed_mps = 30.0\nruns = [\"run.csv\"]\n"
         "[static]\ntable = \"polar.csv\"\n[rotary]\npolynomial = [0.0]\n[model]\nstall = \"separation_and_vortex\"\n";
}

}  // namespace

// stall_start_key is the one map of a held parameter to the start value it excludes: the
// reader refuses both together (check_stall_known), the writer leaves the held one's out.
TEST_CASE("a held stall parameter's start key: refused beside it, not written, read back") {
  CHECK(std::string(stall_start_key("T1")) == "stall_T1_start");
  CHECK(std::string(stall_start_key("CN1")) == "stall_CN1_start");
  CHECK(stall_start_key("k0") == nullptr);
  CHECK(stall_start_key("tau1") == nullptr);
  indicial::testing::TempDir dir("experiment-checks");
  const std::string head = write_stall_case(dir);
  const std::vector<std::string> starts = {"stall_T1_start", "stall_T2_start", "stall_CN1_start", "stall_Tv_start",
                                           "stall_Tvl_start"};
  for (const std::string name : {"T1", "T2", "k0", "k1", "k2", "CN1", "Tv", "Tvl", "cv", "xv"}) {
    CAPTURE(name);
    const char* start = stall_start_key(name);
    const std::string path = indicial::testing::write_text(dir.path / "e.toml", head + "stall_known = { " + name + " = 1.5 }\n");
    Experiment e = load_experiment(path);
    e.model.stall.shedding_threshold_start = 1.2;  // written unless CN1 is held
    const std::string back = write_experiment_toml(e, {});
    for (const std::string& key : starts)
      CHECK_MESSAGE((back.find(key + " =") == std::string::npos) == (start && key == start), key);
    const std::string again = indicial::testing::write_text(dir.path / "back.toml", back);
    CHECK(load_experiment(again).model.stall.known == e.model.stall.known);
    if (!start) continue;
    const std::string both = indicial::testing::write_text(dir.path / "e.toml", head + start + " = 2.0\nstall_known = { " + name + " = 1.5 }\n");
    CHECK_HAS(load_error(both), "'model.stall_known." + name + "' holds " + name +
                                    " at a known value, and 'model." + start + "' gives it a start value");
  }
}

// stall_starts() is the one table of the start-value keys: each key is read by the file's reader
// into its StallConfig member, checked against its bound, written back and read again, and
// documented under its own name in docs/formats.md and `indicial init`'s keys (cmd_init.cpp).
TEST_CASE("the stall start-value table: each key read, bound-checked, written, read back and documented") {
  const std::vector<std::string> documented = {"stall_T1_start", "stall_T2_start", "stall_CN1_start",
                                               "stall_Tv_start", "stall_Tvl_start", "stall_T1r_start",
                                               "stall_dxr_start", "stall_dxl_start"};
  REQUIRE(stall_starts().size() == documented.size());
  std::ifstream formats_file(std::string(INDICIAL_SOURCE_DIR) + "/docs/formats.md");
  std::stringstream formats_text;
  formats_text << formats_file.rdbuf();
  const std::string formats = formats_text.str();
  REQUIRE(!formats.empty());
  indicial::testing::TempDir dir("experiment-checks-starts");
  const std::string head = write_stall_case(dir);
  for (std::size_t i = 0; i < documented.size(); ++i) {
    const StallStart& st = stall_starts()[i];
    CAPTURE(st.key);
    CHECK(std::string(st.key) == documented[i]);
    CHECK(std::string(stall_start_key(st.parameter)) == st.key);
    CHECK(formats.find(std::string("`") + st.key + "`") != std::string::npos);
    // T1r's, dxr's and dxl's starts need their parameter: model.stall_reattachment,
    // model.stall_hysteresis or model.stall_lag_limit = "estimated" (refused without).
    const bool reattach = std::string(st.key) == "stall_T1r_start";
    const bool hysteresis = std::string(st.key) == "stall_dxr_start";
    const bool lag_limit = std::string(st.key) == "stall_dxl_start";
    const bool angle = hysteresis || lag_limit;
    const std::string value = angle ? "0.0625" : "2.25";  // dxr and dxl in rad, at most 20 deg
    if (reattach)
      CHECK_HAS(load_error(indicial::testing::write_text(dir.path / "e.toml", head + st.key + " = 2.25\n")),
                "'model.stall_T1r_start' is used only with model.stall_reattachment = \"estimated\"");
    if (hysteresis)
      CHECK_HAS(load_error(indicial::testing::write_text(dir.path / "e.toml", head + st.key + " = 0.0625\n")),
                "'model.stall_dxr_start' is used only with model.stall_hysteresis = \"estimated\"");
    if (lag_limit)
      CHECK_HAS(load_error(indicial::testing::write_text(dir.path / "e.toml", head + st.key + " = 0.0625\n")),
                "'model.stall_dxl_start' is used only with model.stall_lag_limit = \"estimated\"");
    const std::string head_here = reattach     ? head + "stall_reattachment = \"estimated\"\n"
                                  : hysteresis ? head + "stall_hysteresis = \"estimated\"\n"
                                  : lag_limit  ? head + "stall_lag_limit = \"estimated\"\n"
                                               : head;
    const std::string path = indicial::testing::write_text(dir.path / "e.toml", head_here + st.key + " = " + value + "\n");
    const Experiment e = load_experiment(path);
    CHECK(e.model.stall.*st.value == std::stod(value));
    const std::string back = write_experiment_toml(e, {});
    CHECK(back.find(std::string(st.key) + " = " + value + "\n") != std::string::npos);
    const std::string again = indicial::testing::write_text(dir.path / "back.toml", back);
    CHECK(load_experiment(again).model.stall.*st.value == std::stod(value));
    const std::string bad = indicial::testing::write_text(dir.path / "e.toml", head_here + st.key + " = -1.0\n");
    CHECK_HAS(load_error(bad), std::string("'model.") + st.key +
                                   (st.bound == StartBound::non_negative ? "' must be >= 0"
                                    : st.bound == StartBound::angle_to_20_deg ? "' must be in (0, 0.349] rad (20 deg)"
                                                                         : "' must be > 0"));
    if (angle)  // and above 20 deg
      CHECK_HAS(load_error(indicial::testing::write_text(dir.path / "e.toml", head_here + st.key + " = 0.4\n")),
                std::string("'model.") + st.key + "' must be in (0, 0.349] rad (20 deg)");
  }
  // The lag limit acts on the delay form's lag only: with the first-order form it is refused.
  CHECK_HAS(load_error(indicial::testing::write_text(
                dir.path / "e.toml", head + "stall_lag_limit = \"estimated\"\nstall_forcing_lag = \"first_order\"\n")),
            "'model.stall_lag_limit' = \"estimated\" limits the delay form's lag");
  // The default CN1 start (0: from the polar) is outside its bound, so not set and not written.
  const StallConfig defaults;
  for (const StallStart& st : stall_starts())
    CHECK(start_in_bound(st, defaults.*st.value) == (st.default_text == nullptr));
}

// check_runtime_capacity is the one capacity rule of the file's reader and Python's Experiment:
// over the limit is refused, a candidate pool (stepwise a/b1, an estimated rotary) only warned
// about, with the site the caller gives.
TEST_CASE("the runtime capacity rule: refused over the limit, a candidate pool warned about") {
  const auto error = [](const std::string& problem) { return InputError("f.toml", 7, problem); };
  Experiment e;
  CapacityUse fits{"model.a_knots_deg", "knots", DefaultCapacity::max_knots, DefaultCapacity::max_knots,
                   CapacityUse::Pool::model_stepwise};
  check_runtime_capacity(fits, e, error, "f.toml:7: ");
  CHECK(e.warnings.empty());
  CapacityUse over = fits;
  over.needed = DefaultCapacity::max_knots + 1;
  CHECK_THROWS_WITH_AS(check_runtime_capacity(over, e, error, "f.toml:7: "),
                       "f.toml:7: 'model.a_knots_deg' needs 9 knots; the runtime (indicial::DefaultCapacity) holds at "
                       "most 8",
                       InputError);
  e.model.structure = StructureMode::stepwise;
  check_runtime_capacity(over, e, error, "f.toml:7: ");
  REQUIRE(e.warnings.size() == 1);
  CHECK(e.warnings[0] == "f.toml:7: 'model.a_knots_deg' needs 9 knots; the runtime (indicial::DefaultCapacity) holds "
                         "at most 8: a candidate pool may exceed it, the selected model must not");
  // A rotary pool is one only with rotary.estimate; a use that is no pool is refused even so.
  CapacityUse rotary{"rotary.knots_deg", "knots", 9, 8, CapacityUse::Pool::rotary_estimate};
  CHECK_THROWS_AS(check_runtime_capacity(rotary, e, error, ""), InputError);
  e.rotary.estimate = true;
  check_runtime_capacity(rotary, e, error, "");
  CHECK(e.warnings.size() == 2);
  CapacityUse lags{"model.lags", "lags", 3, DefaultCapacity::max_lags};
  CHECK_THROWS_AS(check_runtime_capacity(lags, e, error, ""), InputError);
}
