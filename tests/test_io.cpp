// Ingest: run CSVs, experiment TOML, Savitzky-Golay differentiation (fitter/io.hpp).
#include <doctest/doctest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "indicial/fitter/error.hpp"
#include "indicial/fitter/fit.hpp"
#include "indicial/fitter/io.hpp"
#include "indicial/fitter/simulate.hpp"
#include "test_support.hpp"

TEST_SUITE_BEGIN("unit");  // the ctest label (tests/CMakeLists.txt)

namespace fs = std::filesystem;

namespace {

using indicial::testing::kPi;

const fs::path& dir() {
  static const indicial::testing::TempDir d("test-io");
  return d.path;
}

std::string write(const std::string& name, const std::string& text) {
  return indicial::testing::write_text(dir() / name, text);
}

// A good run CSV: comment, header, n rows of a 1 Hz sine at dt = 0.01.
std::string good_csv(int n, bool with_rate = true) {
  std::ostringstream s;
  s.precision(17);
  s << "# a comment before the header\n";
  s << (with_rate ? "time_s,alpha_deg,q_degps,Cm\n" : "time_s,alpha_deg,Cm\n");
  for (int k = 0; k < n; ++k) {
    const double t = 0.01 * k;
    const double a = 35.0 - 35.0 * std::cos(2 * kPi * t);
    const double q = 35.0 * 2 * kPi * std::sin(2 * kPi * t);
    s << indicial::format_double(t) << "," << indicial::format_double(a) << ",";
    if (with_rate) s << indicial::format_double(q) << ",";
    s << indicial::format_double(0.01 * a) << "\n";
  }
  return s.str();
}

// Runs f and returns the InputError's message (fails the test if none is thrown).
std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const indicial::InputError& e) {
    return e.what();
  }
  FAIL("no InputError thrown");
  return "";
}

std::string csv_error(const std::string& name, const std::string& text) {
  const std::string p = write(name, text);
  return error_of([&] {
    indicial::read_run_csv(p, indicial::Axis::pitch, "Cm", indicial::CoefficientPresence::required);
  });
}

// Replaces line `line` (1-based) of text.
std::string replace_line(const std::string& text, int line, const std::string& with) {
  std::istringstream in(text);
  std::string out, l;
  int n = 0;
  while (std::getline(in, l)) out += (++n == line ? with : l) + "\n";
  return out;
}

}  // namespace

TEST_CASE("a good run CSV is read, converted to rad and rad/s") {
  const std::string p = write("good.csv", good_csv(101));
  const indicial::Run r = indicial::read_run_csv(p, indicial::Axis::pitch, "Cm",
                                                 indicial::CoefficientPresence::required);
  REQUIRE(r.size() == 101);
  CHECK(r.rate_from_file);
  // Read values are the printed ones to rounding: 1e-12 relative (scale 0), not doctest's default
  // (an absolute ~1.2e-5, which is 0.1 % of dt and 3e-5 of the 0.35 below).
  CHECK(r.dt_s() == doctest::Approx(0.01).epsilon(1e-12).scale(0));
  CHECK(r.motion_angle_rad[25] == doctest::Approx(35.0 * kPi / 180).epsilon(1e-12));
  CHECK(r.rate_radps[25] == doctest::Approx(35.0 * kPi / 180 * 2 * kPi).epsilon(1e-12));
  CHECK(r.coefficient[25] == doctest::Approx(0.35).epsilon(1e-12).scale(0));
  // Without the rate column the rate is the Savitzky-Golay derivative of alpha.
  const std::string p2 = write("norate.csv", good_csv(101, false));
  const indicial::Run r2 = indicial::read_run_csv(p2, indicial::Axis::pitch, "Cm",
                                                  indicial::CoefficientPresence::required);
  CHECK_FALSE(r2.rate_from_file);
  double err = 0;
  for (std::size_t k = 0; k < r.size(); ++k) err = std::max(err, std::abs(r2.rate_radps[k] - r.rate_radps[k]));
  // 1 Hz at 100 samples per cycle, 35 deg amplitude (rate amplitude 3.84 rad/s): the
  // end-point error of the Savitzky-Golay derivative of a cosine is ~2.5e-3 relative (see the
  // Savitzky-Golay test), i.e. ~0.0095 rad/s here; inside the run it is ~1e-4 rad/s.
  INFO("max rate error " << err);
  CHECK(err < 1.5e-2);
  double err_inside = 0;
  for (std::size_t k = 5; k + 5 < r.size(); ++k) {
    err_inside = std::max(err_inside, std::abs(r2.rate_radps[k] - r.rate_radps[k]));
  }
  CHECK(err_inside < 3e-4);
  // The coefficient may be optional (predict); extra columns are ignored.
  const std::string p3 = write("extra.csv", "time_s,alpha_rad,Cm_true,y_true,label\n" + [] {
    std::string s;
    for (int k = 0; k < 20; ++k) s += std::to_string(0.5 * k) + ",0.1,1,2,x\n";
    return s;
  }());
  const indicial::Run r3 = indicial::read_run_csv(p3, indicial::Axis::pitch, "Cm",
                                                  indicial::CoefficientPresence::optional);
  CHECK(r3.coefficient.empty());
  CHECK(r3.motion_angle_rad[3] == 0.1);
}

TEST_CASE("roll and yaw runs use phi / psi and p / r") {
  std::string s = "time_s,phi_rad,p_radps,alpha_deg,Cl\n";
  for (int k = 0; k < 15; ++k) s += std::to_string(0.1 * k) + ",0.2,0.3,30,0.01\n";
  const indicial::Run r = indicial::read_run_csv(write("roll.csv", s), indicial::Axis::roll, "Cl",
                                                 indicial::CoefficientPresence::required);
  CHECK(r.motion_angle_rad[0] == 0.2);
  CHECK(r.rate_radps[0] == 0.3);
  const std::string msg = error_of([&] {
    indicial::read_run_csv(write("roll2.csv", s), indicial::Axis::yaw, "Cl",
                           indicial::CoefficientPresence::required);
  });
  CHECK(msg.find("psi_deg") != std::string::npos);
}

TEST_CASE("each bad run CSV names the file, the line and the problem") {
  const std::string good = good_csv(30);  // line 1 comment, line 2 header, rows from line 3
  SUBCASE("missing file") {
    const std::string m = error_of([] {
      indicial::read_run_csv((dir() / "nope.csv").string(), indicial::Axis::pitch, "Cm",
                             indicial::CoefficientPresence::required);
    });
    CHECK_HAS(m, "nope.csv");
    CHECK_HAS(m, "cannot open");
  }
  SUBCASE("empty file") {
    const std::string m = csv_error("empty.csv", "");
    CHECK_HAS(m, "empty.csv: file is empty");
  }
  SUBCASE("header only") {
    const std::string m = csv_error("header.csv", "# c\ntime_s,alpha_deg,Cm\n");
    CHECK_HAS(m, "header.csv:2: header only");
  }
  SUBCASE("missing column") {
    const std::string m = csv_error("nocm.csv", replace_line(good, 2, "time_s,alpha_deg,q_degps,CL"));
    CHECK_HAS(m, "nocm.csv:2: missing column 'Cm'");
    const std::string m2 = csv_error("noalpha.csv", replace_line(good, 2, "time_s,theta_deg,q_degps,Cm"));
    CHECK_HAS(m2, "noalpha.csv:2: missing column 'alpha_deg' or 'alpha_rad'");
    const std::string m3 = csv_error("notime.csv", replace_line(good, 2, "t,alpha_deg,q_degps,Cm"));
    CHECK_HAS(m3, "notime.csv:2: missing column 'time_s'");
  }
  SUBCASE("duplicate column") {
    const std::string m = csv_error("dup.csv", replace_line(good, 2, "time_s,alpha_deg,Cm,Cm"));
    CHECK_HAS(m, "dup.csv:2: duplicate column 'Cm'");
    const std::string m2 = csv_error("dup2.csv", replace_line(good, 2, "time_s,alpha_deg,alpha_rad,Cm"));
    CHECK_HAS(m2, "dup2.csv:2: both 'alpha_deg' and 'alpha_rad'");
  }
  SUBCASE("no unit suffix, unknown suffix") {
    const std::string m = csv_error("nounit.csv", replace_line(good, 2, "time_s,alpha,q_degps,Cm"));
    CHECK_HAS(m, "nounit.csv:2: column 'alpha' has no unit suffix (use alpha_deg or alpha_rad)");
    const std::string m2 = csv_error("grad.csv", replace_line(good, 2, "time_s,alpha_grad,q_degps,Cm"));
    CHECK_HAS(m2, "grad.csv:2: column 'alpha_grad' has unknown unit suffix '_grad'");
    const std::string m3 = csv_error("ms.csv", replace_line(good, 2, "time_ms,alpha_deg,q_degps,Cm"));
    CHECK_HAS(m3, "ms.csv:2: column 'time_ms' has unknown unit suffix '_ms' (use time_s)");
  }
  SUBCASE("non-numeric, NaN, Inf, empty cells") {
    const std::string m = csv_error("text.csv", replace_line(good, 7, "0.04,abc,1,2"));
    CHECK_HAS(m, "text.csv:7: column 'alpha_deg': non-numeric value 'abc'");
    const std::string m2 = csv_error("nan.csv", replace_line(good, 8, "0.05,1,1,nan"));
    CHECK_HAS(m2, "nan.csv:8: column 'Cm': NaN or Inf value 'nan'");
    const std::string m3 = csv_error("inf.csv", replace_line(good, 9, "0.06,1,-inf,1"));
    CHECK_HAS(m3, "inf.csv:9: column 'q_degps': NaN or Inf value '-inf'");
    const std::string m4 = csv_error("cell.csv", replace_line(good, 9, "0.06,1,,1"));
    CHECK_HAS(m4, "cell.csv:9: column 'q_degps': empty cell");
  }
  SUBCASE("wrong field count") {
    const std::string m = csv_error("fields.csv", replace_line(good, 10, "0.07,1,1"));
    CHECK_HAS(m, "fields.csv:10: expected 4 comma-separated fields as in the header, found 3");
  }
  SUBCASE("non-monotonic and duplicate time") {
    const std::string m = csv_error("back.csv", replace_line(good, 12, "0.05,1,1,1"));
    CHECK_HAS(m, "back.csv:12: time_s is not strictly increasing (0.05 after 0.08)");
    const std::string m2 = csv_error("same.csv", replace_line(good, 12, "0.08,1,1,1"));
    CHECK_HAS(m2, "same.csv:12: duplicate time: time_s is not strictly increasing (0.08 after 0.08)");
  }
  SUBCASE("non-uniform step") {
    const std::string m = csv_error("step.csv", replace_line(good, 12, "0.0900001,1,1,1"));
    CHECK_HAS(m, "step.csv:12: non-uniform time step");
    // 1e-6 relative is allowed: 0.09 + 1e-9 is a relative step deviation of 1e-7.
    const std::string p = write("stepok.csv", replace_line(good, 12, "0.090000001,1,1,1"));
    CHECK_NOTHROW(indicial::read_run_csv(p, indicial::Axis::pitch, "Cm",
                                         indicial::CoefficientPresence::required));
  }
  SUBCASE("too few rows") {
    const std::string m = csv_error("short.csv", good_csv(10));
    CHECK_HAS(m, "short.csv:12: only 10 data rows; a run needs at least 11");
  }
}

TEST_CASE("Savitzky-Golay derivative: exact on cubics, accurate on a sine at the ends too") {
  // A cubic is reproduced exactly by a cubic local fit: the derivative is exact at every
  // sample, including the first and last half_window samples (the asymmetric end windows).
  const double dt = 0.02;
  std::vector<double> v(40), dv(40);
  for (int k = 0; k < 40; ++k) {
    const double t = dt * k;
    v[static_cast<std::size_t>(k)] = 1 - 2 * t + 3 * t * t - 0.7 * t * t * t;
    dv[static_cast<std::size_t>(k)] = -2 + 6 * t - 2.1 * t * t;
  }
  const std::vector<double> d = indicial::smooth_derivative(v, dt, 5, 3);
  for (std::size_t k = 0; k < 40; ++k) CHECK(d[k] == doctest::Approx(dv[k]).epsilon(1e-10));

  // sin(2 pi f t + phase), f = 1 Hz, dt = 0.01 s (100 samples per cycle), window 11, cubic;
  // phases 0 (largest 3rd derivative at the ends) and pi/2 (largest 4th derivative).
  const double w = 2 * kPi;
  double err_inner = 0, err_end = 0;
  for (double phase : {0.0, kPi / 2}) {
    std::vector<double> s(301);
    for (std::size_t k = 0; k < s.size(); ++k) s[k] = std::sin(w * 0.01 * static_cast<double>(k) + phase);
    const std::vector<double> ds = indicial::smooth_derivative(s, 0.01, 5, 3);
    for (std::size_t k = 0; k < s.size(); ++k) {
      const double e = std::abs(ds[k] - w * std::cos(w * 0.01 * static_cast<double>(k) + phase));
      if (k < 5 || k + 5 >= s.size()) err_end = std::max(err_end, e);
      else err_inner = std::max(err_inner, e);
    }
  }
  std::printf("Savitzky-Golay (11 samples, cubic) on sin(2 pi t + phase), dt = 0.01: max |error| / "
              "omega interior %.2e, end points %.2e\n", err_inner / w, err_end / w);
  // Truncation of a cubic SG derivative ~ (m dt w)^4 * const: measured 2.5e-5 relative inside
  // and 2.5e-3 at the very ends (the off-centre fit), vs. 3.1e-2 (= dt w / 2) for a one-sided
  // first difference at the ends.
  CHECK(err_inner / w < 1e-4);
  CHECK(err_end / w < 5e-3);
  CHECK_THROWS_AS(indicial::smooth_derivative(std::vector<double>(5, 1.0), 0.01, 5, 3), std::invalid_argument);
}

// ---------------------------------------------------------------------------------------
// Experiment files
// ---------------------------------------------------------------------------------------
namespace {

// interface.md's example, verbatim.
const char* kInterfaceExample = R"(axis = "pitch"                 # pitch | roll | yaw
coefficient = "Cm"             # column to model
reference_length_m = 0.3765    # l: mean chord / 2 in pitch, span / 2 in roll and yaw
airspeed_mps = 17.667762       # V
# alpha0_deg = 30.0            # roll and yaw: the fixed angle of attack
runs = ["run_f0.25.csv", "run_f0.50.csv", "run_f1.00.csv"]

[static]                       # C_a(x), known from static tests
polynomial = [0.0, 0.42, 0.34, -1.0, 0.40]   # coefficients of x^0, x^1, ... with x in rad
# table = "static.csv"         # or a table: columns alpha_deg (or beta_deg) and the coefficient

[rotary]                       # C_aq(x), a priori
polynomial = [-2.0, 0.0, 0.8]
estimate = false               # true: two-stage re-estimation (report eq. 25-26)
# degree = 2                   # with estimate = true: candidate powers x^0..x^degree for C_aq(x)
# knots_deg = []               #   and candidate plus-function terms (x - k)_+ ; stepwise picks

[model]
a_degree = 2                   # a(x)  = sum_i a_i x^i (i = 0..a_degree) + sum_j A_j (x - k_j)_+^2
# a_powers = [1, 2]            # instead of a_degree: exactly these powers (the report's Tables
#                              #   II-IV fit a(x) without a0); b1_powers likewise for b1(x)
a_knots_deg = [24.998149, 54.998219]
b1_degree = 0                  # b1(x) = sum_i b1_i x^i + sum_j B_j (x - k_j)_+
b1_knots_deg = []
bias = false                   # the constant 'con' in the state equation (report Table V)
structure = "fixed"            # fixed | stepwise (stepwise: the terms above are the candidate pool)
)";

// The simulated runs (tailless Model I, no noise) in dir()/exp.
const fs::path& runs_dir() {
  static const fs::path d = [] {
    const fs::path p = dir() / "exp";
    indicial::write_simulation_case(indicial::find_simulation_case("tailless-model-1"), p.string(),
                                    std::numeric_limits<double>::infinity(), 1,
                                    indicial::Overwrite::refuse);
    return p;
  }();
  return d;
}

std::string write_exp(const std::string& name, const std::string& text) {
  const fs::path p = runs_dir() / name;
  std::ofstream(p, std::ios::binary) << text;
  return p.string();
}

std::string exp_error(const std::string& name, const std::string& text) {
  const std::string p = write_exp(name, text);
  return error_of([&] { indicial::load_experiment(p); });
}

std::string replace(std::string s, const std::string& from, const std::string& to) {
  const std::size_t i = s.find(from);
  REQUIRE(i != std::string::npos);
  return s.replace(i, from.size(), to);
}

}  // namespace

TEST_CASE("interface.md's experiment file is accepted verbatim") {
  const std::string p = write_exp("interface.toml", kInterfaceExample);
  const indicial::Experiment e = indicial::load_experiment(p);
  CHECK(e.axis == indicial::Axis::pitch);
  CHECK(e.coefficient == "Cm");
  CHECK(e.reference_length_m == 0.3765);
  CHECK(e.airspeed_mps == 17.667762);
  REQUIRE(e.runs.size() == 3);
  CHECK(e.runs[0].size() == 1201);
  CHECK(e.runs[2].size() == 301);
  CHECK(e.static_curve.polynomial == std::vector<double>{0.0, 0.42, 0.34, -1.0, 0.40});
  CHECK(e.rotary.polynomial == std::vector<double>{-2.0, 0.0, 0.8});
  CHECK_FALSE(e.rotary.estimate);
  CHECK(e.model.a.powers == std::vector<int>{0, 1, 2});
  REQUIRE(e.model.a.knots_rad.size() == 2);
  CHECK(e.model.a.knots_rad[0] == doctest::Approx(0.4363).epsilon(1e-7));
  CHECK(e.model.a.knots_rad[1] == doctest::Approx(0.9599).epsilon(1e-7));
  CHECK(e.model.b1.powers == std::vector<int>{0});
  CHECK(e.model.b1.knots_rad.empty());
  CHECK(e.model.structure == indicial::StructureMode::fixed);
  // The data's extremes, 0 and 70 deg printed exactly: to rounding (absolute 1e-12 rad).
  CHECK(e.data_x_min_rad == doctest::Approx(0.0).epsilon(1e-12));
  CHECK(e.data_x_max_rad == doctest::Approx(70 * kPi / 180).epsilon(1e-12));
  // And the copy in the reference, if the checkout has shared/ beside it, says the same.
  const fs::path ref = fs::path(INDICIAL_SOURCE_DIR) / ".." / "shared" / "reference" / "interface.md";
  if (fs::exists(ref)) {
    std::ifstream in(ref);
    std::stringstream ss;
    ss << in.rdbuf();
    const std::string md = ss.str();
    const std::size_t a = md.find("```toml\n");
    const std::size_t b = md.find("```", a + 8);
    REQUIRE(a != std::string::npos);
    CHECK(md.substr(a + 8, b - a - 8) == kInterfaceExample);
  }
}

TEST_CASE("the simulator's experiment file round-trips through the reader") {
  const indicial::Experiment e = indicial::load_experiment((runs_dir() / "experiment.toml").string());
  const indicial::Experiment& c = indicial::find_simulation_case("tailless-model-1").experiment;
  CHECK(e.airspeed_mps == c.airspeed_mps);
  CHECK(e.model.a.knots_rad[0] == doctest::Approx(c.model.a.knots_rad[0]).epsilon(1e-15));
  CHECK(e.static_curve.polynomial == c.static_curve.polynomial);
  const std::string text = indicial::write_experiment_toml(e, {});
  // Paths were resolved on read; writing and reading again gives the same configuration.
  const std::string p = write_exp("again.toml", text);
  const indicial::Experiment e2 = indicial::load_experiment(p);
  CHECK(e2.runs.size() == 3);
  CHECK(e2.model.a.knots_rad == e.model.a.knots_rad);
}

TEST_CASE("knots written in degrees read back bit for bit, in their shortest digits (12, not 12.000000000000002)") {
  indicial::Experiment e = indicial::load_experiment((runs_dir() / "experiment.toml").string());
  // 12 deg as the reader makes it, a knot computed in rad (diagnose's candidates), and 1/3 deg.
  e.model.a.knots_rad = {12.0 * (kPi / 180.0), 0.35, (1.0 / 3.0) * (kPi / 180.0) + 0.5};
  e.model.b1.knots_rad = {0.6};
  const std::string text = indicial::write_experiment_toml(e, {});
  INFO(text);
  CHECK(text.find("a_knots_deg = [12, ") != std::string::npos);
  CHECK(text.find("12.000000000000002") == std::string::npos);
  const indicial::Experiment back = indicial::load_experiment(write_exp("knots_back.toml", text));
  CHECK(back.model.a.knots_rad == e.model.a.knots_rad);
  CHECK(back.model.b1.knots_rad == e.model.b1.knots_rad);
}

TEST_CASE("model extension keys (what diagnose adds): read, written back, and refused when wrong") {
  const std::string t = kInterfaceExample;
  const std::string ext = replace(t, "bias = false",
                                  "bias = false\n"
                                  "static_correction_powers = [1, 2]\n"
                                  "static_correction_knots_deg = [30.0]\n"
                                  "rotary_correction_degree = 1\n"
                                  "rotary_correction_knots_deg = [20.0]\n"
                                  "delay = \"estimated\"\n"
                                  "delay_start_s = 0.015\n"
                                  "lags = 2\n"
                                  "further_lag_start = \"at_rest\"");
  const indicial::Experiment e = indicial::load_experiment(write_exp("mext.toml", ext));
  const double deg = 3.14159265358979323846 / 180.0;
  CHECK(e.model.static_correction.powers == std::vector<int>{1, 2});
  REQUIRE(e.model.static_correction.knots_rad.size() == 1);
  CHECK(e.model.static_correction.knots_rad[0] == doctest::Approx(30.0 * deg).epsilon(1e-14).scale(0));
  CHECK(e.model.static_correction.knot_power == 2);
  CHECK(e.model.rotary_correction.powers == std::vector<int>{0, 1});
  REQUIRE(e.model.rotary_correction.knots_rad.size() == 1);
  CHECK(e.model.rotary_correction.knot_power == 1);
  CHECK(e.model.delay == indicial::DelayEstimation::estimated);
  CHECK(e.model.delay_start_s == 0.015);
  CHECK(e.model.lags == 2);
  CHECK(e.model.further_lag_start == indicial::LagStart::at_rest);
  // Written and read again: the same configuration.
  const indicial::Experiment e2 =
      indicial::load_experiment(write_exp("mext2.toml", indicial::write_experiment_toml(e, {})));
  CHECK(e2.model.static_correction.powers == e.model.static_correction.powers);
  CHECK(e2.model.static_correction.knots_rad[0] == doctest::Approx(e.model.static_correction.knots_rad[0]).epsilon(1e-14));
  CHECK(e2.model.rotary_correction.powers == e.model.rotary_correction.powers);
  CHECK(e2.model.rotary_correction.knots_rad.size() == 1);
  CHECK(e2.model.delay == e.model.delay);
  CHECK(e2.model.delay_start_s == e.model.delay_start_s);
  CHECK(e2.model.further_lag_start == e.model.further_lag_start);
  // A file without them writes none of them (the interface's example stays as it was).
  const std::string plain = indicial::write_experiment_toml(
      indicial::load_experiment(write_exp("plain.toml", t)), {});
  for (const char* key : {"static_correction", "rotary_correction", "delay", "further_lag_start"})
    CHECK(plain.find(key) == std::string::npos);

  std::string m = exp_error("x1.toml", replace(t, "bias = false", "bias = false\ndelay = \"yes\""));
  CHECK_HAS(m, "x1.toml:26: 'model.delay' must be \"none\" or \"estimated\", found \"yes\"");
  m = exp_error("x2.toml", replace(t, "bias = false", "bias = false\ndelay_start_s = 0.01"));
  CHECK_HAS(m, "x2.toml:26: 'model.delay_start_s' is used only with model.delay = \"estimated\"");
  m = exp_error("x3.toml", replace(t, "bias = false", "bias = false\ndelay = \"estimated\"\ndelay_start_s = -1"));
  CHECK_HAS(m, "x3.toml:27: 'model.delay_start_s' must be in [0, 1] s");
  m = exp_error("x4.toml", replace(t, "bias = false", "bias = false\nfurther_lag_start = \"rest\""));
  CHECK_HAS(m, "x4.toml:26: 'model.further_lag_start' must be \"estimated\" or \"at_rest\", found \"rest\"");
  m = exp_error("x5.toml", replace(replace(t, "estimate = false", "estimate = true"), "bias = false",
                                   "bias = false\nrotary_correction_degree = 1"));
  CHECK_HAS(m, "'model.rotary_correction_*' corrects the a priori C_aq(x); it cannot be combined with rotary.estimate = true");
  m = exp_error("x6.toml", replace(t, "bias = false", "bias = false\nstatic_correction_knots_deg = [80.0]"));
  CHECK_HAS(m, "x6.toml:26: 'model.static_correction_knots_deg': knot 80 deg is outside the data's alpha range");
  m = exp_error("x7.toml", replace(t, "bias = false", "bias = false\nstatic_correction_degre = 2"));
  CHECK_HAS(m, "x7.toml:26: unknown key 'model.static_correction_degre'");
}

TEST_CASE("smooth_derivative_nonuniform: the uniform filter on a uniform grid, exact for cubics on any grid") {
  std::vector<double> t, v;
  for (int i = 0; i < 60; ++i) {
    t.push_back(0.01 * i);
    v.push_back(std::sin(3.0 * t.back()) + 0.1 * std::cos(17.0 * t.back()));
  }
  const std::vector<double> u = indicial::smooth_derivative(v, 0.01, 5, 3);
  const std::vector<double> n = indicial::smooth_derivative_nonuniform(t, v, 5, 3);
  for (std::size_t i = 0; i < t.size(); ++i) CHECK(n[i] == doctest::Approx(u[i]).epsilon(1e-9));
  // An irregular grid (steps 0.005..0.03 s) and a cubic: the local cubic fit is exact.
  std::vector<double> ti, ci;
  double time = 0.0;
  for (int i = 0; i < 40; ++i) {
    ti.push_back(time);
    ci.push_back(1.0 - 2.0 * time + 3.0 * time * time - 4.0 * time * time * time);
    time += 0.005 + 0.025 * std::abs(std::sin(1.7 * i));
  }
  const std::vector<double> d = indicial::smooth_derivative_nonuniform(ti, ci, 5, 3);
  for (std::size_t i = 0; i < ti.size(); ++i)
    CHECK(d[i] == doctest::Approx(-2.0 + 6.0 * ti[i] - 12.0 * ti[i] * ti[i]).epsilon(1e-9));
  CHECK_THROWS_AS(indicial::smooth_derivative_nonuniform({0.0, 1.0}, {0.0, 1.0}, 5, 3), std::invalid_argument);
  std::vector<double> back = ti;
  back[7] = back[6];
  CHECK_THROWS_AS(indicial::smooth_derivative_nonuniform(back, ci, 5, 3), std::invalid_argument);
}

TEST_CASE("[rotary] a priori knot terms: read, used by the model, written back, refused when wrong") {
  const std::string t = kInterfaceExample;
  const std::string with = replace(t, "polynomial = [-2.0, 0.0, 0.8]",
                                   "polynomial = [-2.0, 0.0, 0.8]\n"
                                   "prior_knots_deg = [20.0, 20.0]\n"
                                   "prior_knot_powers = [1, 2]\n"
                                   "prior_knot_coefficients = [3.3, -3.4]");
  const indicial::Experiment e = indicial::load_experiment(write_exp("prior.toml", with));
  const double deg = 3.14159265358979323846 / 180.0;
  REQUIRE(e.rotary.prior_knots_rad.size() == 2);
  CHECK(e.rotary.prior_knots_rad[1] == doctest::Approx(20.0 * deg).epsilon(1e-14).scale(0));
  CHECK(e.rotary.prior_knot_powers == std::vector<int>{1, 2});
  CHECK(e.rotary.prior_knot_coefficients == std::vector<double>{3.3, -3.4});
  // The fitter's a priori C_aq(x) carries them: at 30 deg, -2 + 0.8 x^2 + 3.3 u - 3.4 u^2.
  const auto base = indicial::base_model_set(e);
  const double x = 30.0 * deg, u = 10.0 * deg;
  CHECK(indicial::spline_value(base.coefficients[0].rotary, x) ==
        doctest::Approx(-2.0 + 0.8 * x * x + 3.3 * u - 3.4 * u * u).epsilon(1e-14));
  // Written back, read again: the same terms (powers written because one is not 1).
  const std::string text = indicial::write_experiment_toml(e, {});
  CHECK(text.find("prior_knot_powers = [1, 2]") != std::string::npos);
  const indicial::Experiment e2 = indicial::load_experiment(write_exp("prior2.toml", text));
  CHECK(e2.rotary.prior_knot_powers == e.rotary.prior_knot_powers);
  CHECK(e2.rotary.prior_knot_coefficients == e.rotary.prior_knot_coefficients);
  CHECK(e2.rotary.prior_knots_rad[0] == doctest::Approx(e.rotary.prior_knots_rad[0]).epsilon(1e-14));
  // Powers default to 1.
  const indicial::Experiment e3 = indicial::load_experiment(write_exp("prior3.toml", replace(
      t, "polynomial = [-2.0, 0.0, 0.8]", "polynomial = [-2.0]\nprior_knots_deg = [20.0]\nprior_knot_coefficients = [1.0]")));
  CHECK(e3.rotary.prior_knot_powers == std::vector<int>{1});

  const std::string poly = "polynomial = [-2.0, 0.0, 0.8]";
  std::string m = exp_error("p1.toml", replace(t, poly, poly + "\nprior_knots_deg = [20.0]"));
  CHECK_HAS(m, "p1.toml:14: give both 'rotary.prior_knots_deg' and 'rotary.prior_knot_coefficients'");
  m = exp_error("p2.toml", replace(t, poly, poly + "\nprior_knots_deg = [20.0]\nprior_knot_coefficients = [1.0, 2.0]"));
  CHECK_HAS(m, "p2.toml:15: 'rotary.prior_knot_coefficients' has 2 entries for 1 terms in 'rotary.prior_knots_deg'");
  m = exp_error("p3.toml", replace(t, poly, poly + "\nprior_knots_deg = [20.0]\nprior_knot_powers = [9]\nprior_knot_coefficients = [1.0]"));
  CHECK_HAS(m, "p3.toml:15: 'rotary.prior_knot_powers': power 9 is outside 0..8");
  m = exp_error("p4.toml", replace(t, poly, poly + "\nprior_knot_powers = [1]"));
  CHECK_HAS(m, "p4.toml:14: 'rotary.prior_knot_powers' needs 'rotary.prior_knots_deg'");
}

TEST_CASE("experiment extensions: run tables, powers, rotary pool, static table") {
  std::string t = kInterfaceExample;
  t = replace(t, R"(runs = ["run_f0.25.csv", "run_f0.50.csv", "run_f1.00.csv"])",
              R"(runs = ["run_f0.25.csv", {file = "run_f1.00.csv", periodic = true}])");
  t = replace(t, "a_degree = 2 ", "a_powers = [1, 2]");
  t = replace(t, "estimate = false", "estimate = true\ndegree = 2\nknots_deg = [20.0]");
  t = replace(t, "polynomial = [0.0, 0.42, 0.34, -1.0, 0.40]", "table = \"tables/static.csv\"");
  std::string table = "# static Cm\nalpha_deg,Cm\n";
  for (int d = 0; d <= 70; d += 2) table += std::to_string(d) + "," + std::to_string(0.001 * d) + "\n";
  fs::create_directories(runs_dir() / "tables");
  std::ofstream(runs_dir() / "tables" / "static.csv") << table;
  const indicial::Experiment e = indicial::load_experiment(write_exp("ext.toml", t));
  REQUIRE(e.runs.size() == 2);
  CHECK_FALSE(e.runs[0].periodic);
  CHECK(e.runs[1].periodic);
  CHECK(e.model.a.powers == std::vector<int>{1, 2});
  CHECK(e.rotary.estimate);
  CHECK(e.rotary.candidates.powers == std::vector<int>{0, 1, 2});
  CHECK(e.rotary.candidates.knots_rad.size() == 1);
  CHECK(e.static_curve.kind == indicial::StaticKind::table);
  CHECK(e.static_curve.table_x_rad.size() == 36);
  CHECK(e.static_curve.table_value[35] == doctest::Approx(0.07).epsilon(1e-12).scale(0));

  // A table that stops at 60 deg does not cover the runs' 70 deg.
  std::string short_table = "alpha_deg,Cm\n";
  for (int d = 0; d <= 60; d += 2) short_table += std::to_string(d) + ",0\n";
  std::ofstream(runs_dir() / "tables" / "short.csv") << short_table;
  const std::string m = exp_error("short.toml", replace(t, "tables/static.csv", "tables/short.csv"));
  CHECK_HAS(m, "short.toml:9: the static table");
  CHECK_HAS(m, "covers alpha [0, 60] deg but the runs reach [0, 70");
  // A table that is not increasing.
  std::ofstream(runs_dir() / "tables" / "bad.csv") << "alpha_deg,Cm\n0,0\n10,0\n10,1\n70,0\n";
  const std::string m2 = exp_error("badtable.toml", replace(t, "tables/static.csv", "tables/bad.csv"));
  CHECK_HAS(m2, "bad.csv:4: the angle column is not strictly increasing (10 after 10)");
}

TEST_CASE("each bad experiment file names the file, the line and the key") {
  const std::string t = kInterfaceExample;
  SUBCASE("unknown keys at every level") {
    std::string m = exp_error("u1.toml", replace(t, "coefficient = \"Cm\"", "coefficient = \"Cm\"\ncoeficient = 1"));
    CHECK_HAS(m, "u1.toml:3: unknown key 'coeficient'");
    m = exp_error("u2.toml", replace(t, "b1_degree = 0", "b1_degree = 0\nb_degree = 1"));
    CHECK_HAS(m, "u2.toml:24: unknown key 'model.b_degree'");
    m = exp_error("u3.toml", replace(t, "estimate = false", "estimate = false\nestimated = true"));
    CHECK_HAS(m, "u3.toml:15: unknown key 'rotary.estimated'");
    m = exp_error("u4.toml", replace(t, "\"run_f0.25.csv\",", "{file = \"run_f0.25.csv\", periodc = true},"));
    CHECK_HAS(m, "u4.toml:6: unknown key 'runs.periodc'");
    m = exp_error("u5.toml", t + "[fit]\nx = 1\n");
    CHECK_HAS(m, "u5.toml:27: unknown key 'fit'");
  }
  SUBCASE("bytes the TOML library cannot take are refused before it sees them") {
    // A non-ASCII byte where whitespace is expected reaches __builtin_unreachable in the
    // system toml++ (found by the fuzzer); experiment_toml.cpp refuses it with the line.
    std::string m = exp_error("n1.toml", replace(t, "axis = \"pitch\"", "axis =\xef\xbb\xb7\"pitch\""));
    CHECK_HAS(m, "n1.toml:1: non-ASCII byte 0xEF outside a string or comment");
    m = exp_error("n2.toml", replace(t, "[static]", std::string("[stat\0ic]", 9)));
    CHECK_HAS(m, "n2.toml:8: NUL byte in the file");
    // Inside a comment or a string non-ASCII text is fine: this file fails later, on the run
    // file it names, not on its bytes.
    m = exp_error("n3.toml", replace(replace(t, "\"run_f0.25.csv\"", "\"l\xc3\xa4uft.csv\""),
                                     "# pitch | roll | yaw", "# Messl\xc3\xa4ufe"));
    CHECK(m.find("non-ASCII") == std::string::npos);
    CHECK_HAS(m, "l\xc3\xa4uft.csv");
  }
  SUBCASE("wrong types") {
    std::string m = exp_error("w1.toml", replace(t, "reference_length_m = 0.3765", "reference_length_m = \"0.3765\""));
    CHECK_HAS(m, "w1.toml:3: wrong type: 'reference_length_m' must be a number, found a string");
    m = exp_error("w2.toml", replace(t, "bias = false", "bias = 0"));
    CHECK_HAS(m, "w2.toml:25: wrong type: 'model.bias' must be true or false, found an integer");
    m = exp_error("w3.toml", replace(t, "a_degree = 2", "a_degree = 2.5"));
    CHECK_HAS(m, "w3.toml:19: wrong type: 'model.a_degree' must be an integer");
    m = exp_error("w4.toml", replace(t, "runs = [", "runs = [3, "));
    CHECK_HAS(m, "w4.toml:6: wrong type: 'runs' entries must be strings");
    m = exp_error("w5.toml", replace(t, "axis = \"pitch\"", "axis = \"pich\""));
    CHECK_HAS(m, "w5.toml:1: 'axis' must be \"pitch\", \"roll\" or \"yaw\"");
    m = exp_error("w6.toml", replace(t, "a_knots_deg = [24.998149, 54.998219]", "a_knots_deg = [\"25\"]"));
    CHECK_HAS(m, "w6.toml:22: wrong type: 'model.a_knots_deg entry' must be a number");
  }
  SUBCASE("missing required keys") {
    std::string m = exp_error("m1.toml", replace(t, "coefficient = \"Cm\"", ""));
    CHECK_HAS(m, "m1.toml");
    CHECK_HAS(m, "missing required key 'coefficient'");
    m = exp_error("m2.toml", replace(t, "polynomial = [0.0, 0.42, 0.34, -1.0, 0.40]", ""));
    CHECK_HAS(m, "m2.toml:8: missing required key 'static.polynomial' or 'static.table'");
    m = exp_error("m3.toml", replace(t, "axis = \"pitch\"", "axis = \"roll\""));
    CHECK_HAS(m, "missing required key 'alpha0_deg'");
  }
  SUBCASE("non-positive length and airspeed") {
    std::string m = exp_error("l.toml", replace(t, "reference_length_m = 0.3765", "reference_length_m = 0"));
    CHECK_HAS(m, "l.toml:3: 'reference_length_m' must be > 0");
    m = exp_error("v.toml", replace(t, "airspeed_mps = 17.667762", "airspeed_mps = -17.6"));
    CHECK_HAS(m, "v.toml:4: 'airspeed_mps' must be > 0");
  }
  SUBCASE("knots outside the data's angle range, unordered knots") {
    std::string m = exp_error("k.toml", replace(t, "b1_knots_deg = []", "b1_knots_deg = [30.0, 75.0]"));
    CHECK_HAS(m, "k.toml:24: 'model.b1_knots_deg': knot 75 deg is outside the data's alpha range [0, 70");
    m = exp_error("k2.toml", replace(t, "b1_knots_deg = []", "b1_knots_deg = [40.0, 30.0]"));
    CHECK_HAS(m, "k2.toml:24: 'model.b1_knots_deg' must be strictly increasing");
  }
  SUBCASE("TOML syntax and a bad run file named from the experiment") {
    std::string m = exp_error("syn.toml", replace(t, "bias = false", "bias = "));
    CHECK_HAS(m, "syn.toml:25: TOML syntax error");
    m = exp_error("run.toml", replace(t, "run_f0.50.csv", "missing_run.csv"));
    CHECK_HAS(m, "run.toml:6: run file 'missing_run.csv' not found (looked for ");
  }
}

// ==========================================================================================
// Tolerant CSV dialects, [columns], unknown columns (issue 14 item 2)
// ==========================================================================================
namespace {

// good_csv(n) in another dialect: delimiter, decimal separator, BOM, quoted header names.
std::string dialect_csv(int n, char delimiter, bool decimal_comma, bool bom, bool quoted) {
  std::string out = bom ? "\xEF\xBB\xBF" : "";
  std::istringstream in(good_csv(n));
  std::string line;
  bool header = true;
  while (std::getline(in, line)) {
    if (line[0] == '#') continue;
    std::string row;
    std::istringstream cells(line);
    std::string cell;
    while (std::getline(cells, cell, ',')) {
      if (!row.empty()) row += delimiter;
      if (header && quoted) cell = "\"" + cell + "\"";
      if (!header && decimal_comma) std::replace(cell.begin(), cell.end(), '.', ',');
      row += cell;
    }
    out += row + "\r\n";
    header = false;
  }
  return out;
}

indicial::Run read_pitch(const std::string& path) {
  return indicial::read_run_csv(path, indicial::Axis::pitch, "Cm", indicial::CoefficientPresence::required);
}

bool any_note_has(const std::vector<std::string>& notes, const std::string& s) {
  for (const auto& n : notes)
    if (n.find(s) != std::string::npos) return true;
  return false;
}

}  // namespace

TEST_CASE("CSV dialects: semicolons with decimal commas, tabs, a BOM and quoted names read the same values") {
  const indicial::Run ref = read_pitch(write("dialect_ref.csv", good_csv(40)));
  CHECK(ref.notes.empty());
  struct Case {
    const char* name;
    char delimiter;
    bool decimal_comma, bom, quoted;
    const char* note;
  };
  for (const Case& c : {Case{"semi_comma.csv", ';', true, true, true, "semicolon-separated, with ',' as the decimal"},
                        Case{"semi_point.csv", ';', false, false, false, "read as semicolon-separated"},
                        Case{"tab.csv", '\t', true, false, true, "tab-separated, with ','"},
                        Case{"bom_quoted.csv", ',', false, true, true, ""}}) {
    INFO(c.name);
    const indicial::Run r = read_pitch(write(c.name, dialect_csv(40, c.delimiter, c.decimal_comma, c.bom, c.quoted)));
    REQUIRE(r.size() == ref.size());
    CHECK(r.time_s == ref.time_s);
    CHECK(r.motion_angle_rad == ref.motion_angle_rad);
    CHECK(r.coefficient == ref.coefficient);
    if (*c.note) CHECK(any_note_has(r.notes, c.note));
    else CHECK(r.notes.empty());
  }
  // In a comma-separated file a decimal comma cannot be read: the quoted cell is refused.
  std::string bad = good_csv(30);
  bad = replace_line(bad, 7, "0.04,\"1,5\",1,2");
  CHECK_HAS(csv_error("quoted_comma.csv", bad), "quoted_comma.csv:7: column 'alpha_deg': non-numeric value '1,5'");
  // A ';' file's wrong field count names its delimiter.
  CHECK_HAS(csv_error("semi_fields.csv", replace_line(dialect_csv(30, ';', true, false, false), 5, "0,03;1")),
            "semi_fields.csv:5: expected 4 semicolon-separated fields as in the header, found 2");
}

TEST_CASE("a missing column lists the columns found and suggests the nearest") {
  const std::string good = good_csv(30);
  std::string m = csv_error("lower.csv", replace_line(good, 2, "time_s,alpha_deg,q_degps,cm"));
  CHECK_HAS(m, "lower.csv:2: missing column 'Cm' (columns found: time_s, alpha_deg, q_degps, cm); did you mean 'cm'?");
  CHECK_HAS(m, "[columns] Cm = \"cm\"");
  m = csv_error("typo.csv", replace_line(good, 2, "time_s,alpah_deg,q_degps,Cm"));
  CHECK_HAS(m, "missing column 'alpha_deg' or 'alpha_rad' (the pitch motion angle) (columns found: time_s, alpah_deg, "
               "q_degps, Cm); did you mean 'alpah_deg'?");
  // The suggestion names the wanted column the file's name is nearest to (its unit included).
  m = csv_error("unit.csv", replace_line(good, 2, "time_s,alpha_rd,q_degps,Cm"));
  CHECK_HAS(m, "did you mean 'alpha_rd'? (rename it, or map it in the experiment: [columns] alpha_rad = \"alpha_rd\")");
  // Nothing near: no suggestion.
  m = csv_error("far.csv", replace_line(good, 2, "time_s,alpha_deg,q_degps,balance"));
  CHECK_HAS(m, "missing column 'Cm' (columns found: time_s, alpha_deg, q_degps, balance)");
  CHECK(m.find("did you mean") == std::string::npos);
}

TEST_CASE("unknown columns are ignored with a note, one of ours with an unknown unit is refused") {
  std::string s = "time_s,alpha_deg,q_pa,alpha_cmd_deg,r_m,Cm,Cm_true,beta_deg\n";
  for (int k = 0; k < 20; ++k) s += indicial::format_double(0.01 * k) + "," + std::to_string(k) + ",101325,5,0.2,0.1,0.1,0\n";
  const indicial::Run r = read_pitch(write("tunnel_log.csv", s));
  CHECK(r.motion_angle_rad[3] == doctest::Approx(3 * kPi / 180).epsilon(1e-14).scale(0));
  REQUIRE(r.notes.size() == 1);
  CHECK_HAS(r.notes[0], "tunnel_log.csv: ignored column(s) 'q_pa', 'alpha_cmd_deg', 'r_m' (not a column indicial reads)");
  // The rule: one of our bases (time, phase, alpha, beta, phi, psi, theta, q, p, r) with a
  // suffix that names a unit we do not read is refused.
  for (const char* name : {"alpha_grad", "q_dps", "time_ms", "phase_turns", "alpha_degrees"}) {
    std::string h = "time_s,alpha_deg,Cm," + std::string(name) + "\n";
    for (int k = 0; k < 20; ++k) h += std::to_string(k) + ",1,1,1\n";
    if (std::string(name) == "time_ms") h = replace_line(h, 1, "time_s,alpha_deg,Cm,time_ms");
    CHECK_HAS(csv_error(std::string(name) + ".csv", h), "has unknown unit suffix");
  }
}

TEST_CASE("[columns] maps the file's names to ours, in runs and the static table") {
  // The simulated runs renamed: time_s -> Time, alpha_deg -> AoA, Cm -> CM_balance.
  std::vector<std::string> files;
  for (const char* f : {"run_f0.25.csv", "run_f0.50.csv", "run_f1.00.csv"}) {
    std::ifstream in(runs_dir() / f);
    std::ostringstream ss;
    ss << in.rdbuf();
    std::string text = ss.str();
    for (auto [from, to] : {std::pair<const char*, const char*>{"time_s,", "Time,"}, {"alpha_deg,", "AoA,"},
                            {",Cm,", ",CM_balance,"}}) {
      const std::size_t i = text.find(from);
      if (i != std::string::npos) text.replace(i, std::string(from).size(), to);
    }
    std::ofstream(runs_dir() / (std::string("mapped_") + f)) << text;
  }
  std::string t = replace(kInterfaceExample, "run_f0.25.csv\", \"run_f0.50.csv\", \"run_f1.00.csv",
                          "mapped_run_f0.25.csv\", \"mapped_run_f0.50.csv\", \"mapped_run_f1.00.csv");
  const std::string columns = "\n[columns]\ntime_s = \"Time\"\nalpha_deg = \"AoA\"\nCm = \"CM_balance\"\n";
  const indicial::Experiment mapped = indicial::load_experiment(write_exp("mapped.toml", t + columns));
  const indicial::Experiment plain = indicial::load_experiment(write_exp("plain.toml", kInterfaceExample));
  REQUIRE(mapped.runs.size() == 3);
  CHECK(mapped.runs[1].time_s == plain.runs[1].time_s);
  CHECK(mapped.runs[1].motion_angle_rad == plain.runs[1].motion_angle_rad);
  CHECK(mapped.runs[1].coefficient == plain.runs[1].coefficient);
  // Without the table: the message suggests the mapping.
  const std::string m = exp_error("unmapped.toml", t);
  CHECK_HAS(m, "missing column 'time_s' (or 'phase_rad' / 'phase_deg' / 'phase_cycles') (columns found: Time, AoA");
  CHECK_HAS(m, "did you mean 'Time'?");
  // A mapping to a column the file does not have is named.
  const std::string m2 = exp_error("badmap.toml", t + replace(columns, "\"AoA\"", "\"AOA2\""));
  CHECK_HAS(m2, "[columns] maps alpha_deg to 'AOA2', not in this file");
  CHECK_HAS(exp_error("typemap.toml", t + "\n[columns]\nalpha_deg = 3\n"),
            "typemap.toml:29: wrong type: 'columns.alpha_deg' must be a string, found an integer");
}

TEST_CASE("[static] columns: the static table's own column names, over [columns]") {
  // The runs mapped by [columns] (Time, AoA, CM_balance), the polar headed otherwise (Alpha,
  // Cm_static): one map cannot serve both; [static] columns names the table's.
  std::string t = replace(kInterfaceExample, "run_f0.25.csv\", \"run_f0.50.csv\", \"run_f1.00.csv",
                          "mapped_run_f0.25.csv\", \"mapped_run_f0.50.csv\", \"mapped_run_f1.00.csv");
  t = replace(t, "polynomial = [0.0, 0.42, 0.34, -1.0, 0.40]",
              "table = \"tables/polar.csv\"\ncolumns = { alpha_deg = \"Alpha\", Cm = \"Cm_static\" }");
  std::string table = "Alpha,Cm_static\n";
  for (int d = 0; d <= 70; d += 2) table += std::to_string(d) + "," + std::to_string(0.001 * d) + "\n";
  fs::create_directories(runs_dir() / "tables");
  std::ofstream(runs_dir() / "tables" / "polar.csv") << table;
  for (const char* f : {"run_f0.25.csv", "run_f0.50.csv", "run_f1.00.csv"}) {  // as the [columns] test writes them
    std::string text = indicial::read_text(runs_dir() / f);
    for (auto [from, to] : {std::pair<const char*, const char*>{"time_s,", "Time,"}, {"alpha_deg,", "AoA,"},
                            {",Cm,", ",CM_balance,"}})
      if (const std::size_t i = text.find(from); i != std::string::npos) text.replace(i, std::string(from).size(), to);
    std::ofstream(runs_dir() / (std::string("mapped_") + f)) << text;
  }
  const std::string columns = "\n[columns]\ntime_s = \"Time\"\nalpha_deg = \"AoA\"\nCm = \"CM_balance\"\n";
  const indicial::Experiment e = indicial::load_experiment(write_exp("static_columns.toml", t + columns));
  REQUIRE(e.static_curve.kind == indicial::StaticKind::table);
  CHECK(e.static_curve.table_x_rad.size() == 36);
  CHECK(e.static_curve.table_value[35] == doctest::Approx(0.07).epsilon(1e-12).scale(0));
  CHECK(e.runs.size() == 3);
  // Written back and read again: the same table (write_experiment_toml keeps the key).
  const std::string written = indicial::write_experiment_toml(e, {"round trip"});
  CHECK_HAS(written, "columns = { Cm = \"Cm_static\", alpha_deg = \"Alpha\" }");
  // Without it the table's columns are missing (the runs' map does not name them).
  CHECK_HAS(exp_error("static_nocolumns.toml", replace(t, "\ncolumns = { alpha_deg = \"Alpha\", Cm = \"Cm_static\" }", "") + columns),
            "polar.csv:1: missing column");
  // Only with a table.
  CHECK_HAS(exp_error("static_polycolumns.toml", replace(kInterfaceExample, "polynomial = [0.0, 0.42, 0.34, -1.0, 0.40]",
                                                         "polynomial = [0.0]\ncolumns = { Cm = \"x\" }")),
            "'static.columns' names a static table's columns: give 'static.table'");
}

// ==========================================================================================
// Phase-averaged cycles and per-run conditions (issue 12 item 3, input side)
// ==========================================================================================
namespace {

// One ensemble-averaged cycle of n samples: alpha = 35 - 35 cos(phase) deg, phase printed by
// `fmt` (e.g. "%.2f": rounded to 0.01 rad), or time_s printed by fmt when f_hz > 0.
std::string cycle_csv(int n, const char* fmt, double f_hz = 0.0, double jitter_rad = 0.0) {
  std::string s = f_hz > 0.0 ? "time_s,alpha_deg,Cm\n" : "phase_rad,alpha_deg,Cm\n";
  for (int k = 0; k < n; ++k) {
    const double phase = 2 * kPi * k / n + (k == n / 2 ? jitter_rad : 0.0);
    char cell[64];
    std::snprintf(cell, sizeof cell, fmt, f_hz > 0.0 ? phase / (2 * kPi * f_hz) : phase);
    const double a = 35.0 - 35.0 * std::cos(phase);
    s += std::string(cell) + "," + indicial::format_double(a) + "," + indicial::format_double(0.01 * a) + "\n";
  }
  return s;
}

std::string cycle_experiment(const std::string& runs) {
  return replace(kInterfaceExample, R"(runs = ["run_f0.25.csv", "run_f0.50.csv", "run_f1.00.csv"])",
                 "runs = [" + runs + "]");
}

}  // namespace

TEST_CASE("a 128-sample cycle with phase rounded to 0.01 rad is uniform, snapped, periodic") {
  std::ofstream(runs_dir() / "cycle128.csv") << cycle_csv(128, "%.2f");
  const indicial::Experiment e = indicial::load_experiment(
      write_exp("cycle.toml", cycle_experiment(R"({file = "cycle128.csv", frequency_hz = 2.0}, "run_f0.50.csv")")));
  const indicial::Run& r = e.runs[0];
  CHECK(r.time_source == indicial::TimeSource::phase_column);
  CHECK(r.time_grid == indicial::TimeGrid::uniform);
  CHECK(r.periodic);
  CHECK(r.frequency_hz == 2.0);
  CHECK(r.airspeed_mps == e.airspeed_mps);
  CHECK(r.experiment_line == 6);
  REQUIRE(r.size() == 128);
  // t = phase / (2 pi f): the exact grid k / (128 f), recovered from the rounded phases.
  for (std::size_t k = 0; k < r.size(); ++k) CHECK(r.time_s[k] == doctest::Approx(static_cast<double>(k) / 256.0).epsilon(1e-9));
  CHECK(r.dt_s() == doctest::Approx(1 / 256.0).epsilon(1e-9));
  CHECK(any_note_has(e.notes, "cycle128.csv: 'phase_rad' is uniform to its printed digits"));
  // In the column's own unit (2 pi / 128 rad), seconds beside; the rounding is below 0.005 rad.
  CHECK(any_note_has(e.notes, "snapped to a step of 0.0490874 rad (0.00390625 s)"));
  CHECK(any_note_has(e.notes, " rad (0.00390625"));
  CHECK(any_note_has(e.notes, "is uniform to its printed digits (max deviation 0.00"));
  for (const std::string& n : e.notes) {
    const std::size_t at = n.find("(max deviation ");
    if (at == std::string::npos) continue;
    const std::string deviation = n.substr(at, n.find("): snapped") - at);
    CHECK_MESSAGE(deviation.find(" rad (") != std::string::npos, deviation);  // rad first, seconds beside
  }
  // The writer writes the run keys back; the file reads back the same run.
  const std::string text = indicial::write_experiment_toml(e, {});
  CHECK(text.find("frequency_hz = 2}") != std::string::npos);
  const indicial::Experiment back = indicial::load_experiment(write_exp("cycle_back.toml", text));
  CHECK(back.runs[0].frequency_hz == 2.0);
  CHECK(back.runs[0].time_s == r.time_s);
  CHECK(back.runs[0].periodic);
  CHECK_FALSE(e.runs[1].periodic);
  CHECK(e.runs[1].time_source == indicial::TimeSource::time_column);
  CHECK(e.runs[1].frequency_hz == 0.0);
  // reduced_frequency k = 2 pi f l / V gives the same frequency.
  const double k_red = 2 * kPi * 2.0 * 0.3765 / 17.667762;
  const indicial::Experiment e2 = indicial::load_experiment(write_exp(
      "cycle_k.toml", cycle_experiment("{file = \"cycle128.csv\", reduced_frequency = " + indicial::format_double(k_red) + "}")));
  CHECK(e2.runs[0].frequency_hz == doctest::Approx(2.0).epsilon(1e-12));
  // phase_deg rounded to 0.1 deg, the same grid.
  std::string deg = "phase_deg,alpha_deg,Cm\n";
  for (int k = 0; k < 128; ++k) {
    char cell[32];
    std::snprintf(cell, sizeof cell, "%.1f", 360.0 * k / 128);
    deg += std::string(cell) + ",10,0.1\n";
  }
  const indicial::Run rd = indicial::read_run_csv(write("cycle_deg.csv", deg), indicial::Axis::pitch, "Cm",
                                                  indicial::CoefficientPresence::required,
                                                  indicial::RunCsvOptions{indicial::TimeGrid::uniform, {}, 1.0, indicial::CsvDialect{}});
  CHECK(rd.time_s[127] == doctest::Approx(127 / 128.0).epsilon(1e-9));
}

// 300 samples at 3 kHz from t = 10 s, time printed with "%.9g" (a resolution of 1e-7 s, i.e.
// 3e-4 of the step: far beyond the 1e-6 relative check); sample 150 moved by jitter_s.
std::string time9_csv(double jitter_s) {
  std::string s = "time_s,alpha_deg,Cm\n";
  for (int k = 0; k < 300; ++k) {
    char cell[64];
    std::snprintf(cell, sizeof cell, "%.9g", 10.0 + k / 3000.0 + (k == 150 ? jitter_s : 0.0));
    const double a = 10.0 * std::sin(2 * kPi * 10.0 * k / 3000.0);
    s += std::string(cell) + "," + indicial::format_double(a) + "," + indicial::format_double(0.01 * a) + "\n";
  }
  return s;
}

TEST_CASE("a time column written to 9 significant digits is uniform, beyond its digits it is refused") {
  const indicial::Run r = read_pitch(write("nine.csv", time9_csv(0.0)));
  CHECK(r.time_grid == indicial::TimeGrid::uniform);
  CHECK(any_note_has(r.notes, "nine.csv: 'time_s' is uniform to its printed digits"));
  // Snapped to the weighted least-squares grid: within 2e-8 s of the exact one (the printing's
  // half unit is 5e-8 s; the rounding errors average out over 300 samples).
  double worst = 0.0;
  for (std::size_t k = 0; k < r.size(); ++k)
    worst = std::max(worst, std::abs(r.time_s[k] - (10.0 + static_cast<double>(k) / 3000.0)));
  CHECK(worst < 2e-8);
  // dt relative to 1/3000 (scale 0; the former epsilon(1e-6) was an absolute 1e-6 s, 0.3 % of dt):
  // 4 standard errors of a least-squares slope through N = 300 times rounded to 1e-7 s,
  // 4 (1e-7 / sqrt 12) sqrt(12 / N^3) / dt = 2.3e-7 (measured 4.5e-9).
  CHECK(r.dt_s() == doctest::Approx(1 / 3000.0).epsilon(2.5e-7).scale(0));
  // One sample moved by 1e-6 s (20 times the half unit) is not uniform: refused, with the hint.
  const std::string moved = time9_csv(1e-6);
  const std::string m = csv_error("nine_moved.csv", moved);
  CHECK_HAS(m, "nine_moved.csv:152: non-uniform time step");
  CHECK_HAS(m, "declare time_grid = \"nonuniform\" in the run's entry");
  // Declared nonuniform, it is read with each sample's own time.
  indicial::RunCsvOptions o;
  o.grid = indicial::TimeGrid::nonuniform;
  const indicial::Run rn = indicial::read_run_csv(write("nine_moved3.csv", moved), indicial::Axis::pitch, "Cm",
                                                  indicial::CoefficientPresence::required, o);
  CHECK(rn.time_grid == indicial::TimeGrid::nonuniform);
  CHECK(rn.time_s[150] == doctest::Approx(10.05 + 1e-6).epsilon(1e-12));
}

TEST_CASE("phase cycles and run conditions: every wrong combination names the line") {
  std::ofstream(runs_dir() / "cycle64.csv") << cycle_csv(64, "%.2f");
  std::ofstream(runs_dir() / "cycle_jitter.csv") << cycle_csv(64, "%.2f", 0.0, 0.03);
  CHECK_HAS(exp_error("c1.toml", cycle_experiment(R"("cycle64.csv")")),
            "cycle64.csv:1: column 'phase_rad' needs the cycle's frequency: give frequency_hz or reduced_frequency");
  CHECK_HAS(exp_error("c2.toml", cycle_experiment(R"({file = "cycle64.csv", frequency_hz = 1.0, periodic = false})")),
            "c2.toml:6: run 'cycle64.csv' has a phase column, so it is one periodic cycle: remove 'periodic = false'");
  // A time column's frequency is the motion's (kept for the noise from its cycles), not refused.
  CHECK(indicial::load_experiment(write_exp("c3.toml", cycle_experiment(R"({file = "run_f0.50.csv", frequency_hz = 0.5})")))
            .runs.at(0).frequency_hz == 0.5);
  CHECK_HAS(exp_error("c4.toml", cycle_experiment(R"({file = "cycle64.csv", frequency_hz = 1.0, reduced_frequency = 0.1})")),
            "c4.toml:6: give 'runs.frequency_hz' or 'runs.reduced_frequency', not both");
  CHECK_HAS(exp_error("c5.toml", cycle_experiment(R"({file = "cycle64.csv", frequency_hz = -1.0})")),
            "c5.toml:6: 'runs.frequency_hz' must be > 0");
  CHECK_HAS(exp_error("c6.toml", cycle_experiment(R"({file = "cycle64.csv", frequency_hz = 1.0, time_grid = "jittery"})")),
            "c6.toml:6: 'runs.time_grid' must be \"uniform\" or \"nonuniform\", found \"jittery\"");
  // A jittered phase column and a declared nonuniform run are read as nonuniform (fit and
  // diagnose step each sample's own dt, issue 12).
  const indicial::Experiment e7 = indicial::load_experiment(
      write_exp("c7.toml", cycle_experiment(R"({file = "cycle_jitter.csv", frequency_hz = 1.0})")));
  CHECK(e7.runs.at(0).time_grid == indicial::TimeGrid::nonuniform);
  const indicial::Experiment e8 = indicial::load_experiment(
      write_exp("c8.toml", cycle_experiment(R"({file = "run_f0.50.csv", time_grid = "nonuniform"})")));
  CHECK(e8.runs.at(0).time_grid == indicial::TimeGrid::nonuniform);
  // A run at another airspeed is read with it (fit and diagnose scale by V / V_ref, issue 12).
  const indicial::Experiment e9 = indicial::load_experiment(
      write_exp("c9.toml", cycle_experiment(R"({file = "cycle64.csv", frequency_hz = 1.0, airspeed_mps = 30.0})")));
  CHECK(e9.runs.at(0).airspeed_mps == 30.0);
  CHECK(e9.airspeed_mps == 17.667762);
  // The jittered cycle itself is read, as nonuniform, with a note when no grid is declared;
  // declared uniform (predict --time-grid uniform) it is refused, never silently nonuniform.
  const indicial::Run rj = indicial::read_run_csv((runs_dir() / "cycle_jitter.csv").string(), indicial::Axis::pitch,
                                                  "Cm", indicial::CoefficientPresence::required,
                                                  indicial::RunCsvOptions{std::nullopt, {}, 1.0, indicial::CsvDialect{}});
  CHECK(rj.time_grid == indicial::TimeGrid::nonuniform);
  CHECK(any_note_has(rj.notes, "'phase_rad' is not uniform even to its printed digits"));
  CHECK_HAS(error_of([&] {
              indicial::read_run_csv((runs_dir() / "cycle_jitter.csv").string(), indicial::Axis::pitch, "Cm",
                                     indicial::CoefficientPresence::required,
                                     indicial::RunCsvOptions{indicial::TimeGrid::uniform, {}, 1.0, indicial::CsvDialect{}});
            }),
            "but a uniform grid was declared");
  // Phase outside [0, 2 pi) and time and phase together.
  std::string over = cycle_csv(20, "%.2f");
  over = replace_line(over, 21, "6.30,1,1");
  CHECK_HAS(error_of([&] {
              indicial::read_run_csv(write("over.csv", over), indicial::Axis::pitch, "Cm",
                                     indicial::CoefficientPresence::required,
                                     indicial::RunCsvOptions{indicial::TimeGrid::uniform, {}, 1.0, indicial::CsvDialect{}});
            }),
            "over.csv:21: column 'phase_rad': phase 6.30 is outside [0, 2 pi)");
  CHECK_HAS(csv_error("both.csv", "time_s,phase_rad,alpha_deg,Cm\n0,0,1,1\n"),
            "both.csv:1: both 'time_s' and 'phase_rad' given; keep one");
}

// ==========================================================================================
// Several coefficients per experiment (issue 14 item 4)
// ==========================================================================================
namespace {

// The interface example's runs with a CL column besides Cm.
std::string two_coefficient_experiment(const std::string& sections) {
  std::string s = "time_s,alpha_deg,Cm,CL\n";
  for (int k = 0; k < 200; ++k) {
    const double t = 0.01 * k, a = 35.0 - 35.0 * std::cos(2 * kPi * 0.5 * t);
    s += indicial::format_double(t) + "," + indicial::format_double(a) + "," + indicial::format_double(-0.002 * a) +
         "," + indicial::format_double(0.03 * a) + "\n";
  }
  std::ofstream(runs_dir() / "two.csv") << s;
  return "axis = \"pitch\"\ncoefficients = [\"CL\", \"Cm\"]\nreference_length_m = 0.3765\n"
         "airspeed_mps = 17.667762\nruns = [\"two.csv\"]\n" + sections;
}

}  // namespace

TEST_CASE("coefficients = [\"CL\", \"Cm\"]: per-coefficient or shared sections, one Experiment each") {
  const std::string per = two_coefficient_experiment(
      "\n[static.CL]\npolynomial = [0.0, 2.0]\n[static.Cm]\npolynomial = [0.0, -0.1]\n"
      "\n[rotary]\npolynomial = [-1.0]\n"
      "\n[model.CL]\na_degree = 1\n[model.Cm]\na_degree = 2\nb1_knots_deg = [30.0]\n");
  const std::string path = write_exp("two.toml", per);
  const std::vector<indicial::Experiment> es = indicial::load_experiments(path);
  REQUIRE(es.size() == 2);
  CHECK(es[0].coefficient == "CL");
  CHECK(es[1].coefficient == "Cm");
  CHECK(es[0].static_curve.polynomial == std::vector<double>{0.0, 2.0});
  CHECK(es[1].static_curve.polynomial == std::vector<double>{0.0, -0.1});
  CHECK(es[0].rotary.polynomial == es[1].rotary.polynomial);  // shared
  CHECK(es[0].model.a.powers == std::vector<int>{0, 1});
  CHECK(es[1].model.a.powers == std::vector<int>{0, 1, 2});
  CHECK(es[1].model.b1.knots_rad.size() == 1);
  // Relative (scale 0): Cm here is -0.0034, and the default absolute ~1.2e-5 is 0.35 % of it.
  CHECK(es[0].runs[0].coefficient[10] == doctest::Approx(0.03 * es[0].runs[0].motion_angle_rad[10] * 180 / kPi).epsilon(1e-12).scale(0));
  CHECK(es[1].runs[0].coefficient[10] == doctest::Approx(-0.002 * es[1].runs[0].motion_angle_rad[10] * 180 / kPi).epsilon(1e-12).scale(0));
  // One of them, by name (diagnose --coefficient); none named: refused with the hint.
  CHECK(indicial::load_experiment(path, "Cm").model.a.powers.size() == 3);
  CHECK_HAS(error_of([&] { indicial::load_experiment(path); }),
            "two.toml:2: 'coefficients' lists several coefficients; this command works on one: name it (e.g. "
            "--coefficient CL)");
  CHECK_HAS(error_of([&] { indicial::load_experiment(path, "CD"); }), "coefficient 'CD' is not modelled by this experiment");
  // A single-coefficient file gives one.
  CHECK(indicial::load_experiments(write_exp("one.toml", kInterfaceExample)).size() == 1);
}

// load_experiments' error for an experiment file.
std::string exps_error(const std::string& name, const std::string& text) {
  const std::string p = write_exp(name, text);
  return error_of([&] { indicial::load_experiments(p); });
}

TEST_CASE("several coefficients: ambiguous or wrong sections are refused with the line") {
  const std::string statics = "\n[static.CL]\npolynomial = [0.0, 2.0]\n[static.Cm]\npolynomial = [0.0, -0.1]\n";
  CHECK_HAS(exps_error("mix.toml", two_coefficient_experiment(statics + "\n[model]\nbias = true\n[model.CL]\na_degree = 1\n")),
            "mix.toml:12: '[model]' mixes per-coefficient tables (CL) with shared keys (bias): give one form");
  CHECK_HAS(exps_error("shared_static.toml", two_coefficient_experiment("\n[static]\npolynomial = [0.0, 2.0]\n")),
            "shared_static.toml:7: a shared '[static] polynomial' would be one static curve for every coefficient: "
            "give [static.CL], [static.Cm], ...");
  CHECK_HAS(exps_error("cd.toml", two_coefficient_experiment(statics + "\n[rotary.CD]\npolynomial = [1.0]\n")),
            "cd.toml:12: '[rotary.CD]': CD is not in 'coefficients'");
  CHECK_HAS(exps_error("nostatic.toml", two_coefficient_experiment("\n[static.CL]\npolynomial = [0.0, 2.0]\n")),
            "missing required key 'static.Cm'");
  CHECK_HAS(exps_error("bothkeys.toml", replace(two_coefficient_experiment(statics), "coefficients = [",
                                               "coefficient = \"CL\"\ncoefficients = [")),
            "bothkeys.toml:3: give 'coefficient' or 'coefficients', not both");
  CHECK_HAS(exps_error("twice.toml", replace(two_coefficient_experiment(statics), "[\"CL\", \"Cm\"]", "[\"CL\", \"CL\"]")),
            "twice.toml:2: 'coefficients' names CL twice");
  CHECK_HAS(exps_error("four.toml", replace(two_coefficient_experiment(statics), "[\"CL\", \"Cm\"]",
                                           "[\"CL\", \"Cm\", \"CD\", \"CY\"]")),
            "four.toml:2: 'coefficients' lists 4; the runtime (indicial::DefaultCapacity) holds at most 3 per model");
}
