// Columns sampled at their own phases (phase_resample.hpp): periodic interpolation, its
// measured error, and the experiment's `files = [...]` runs entry.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "indicial/fitter/error.hpp"
#include "indicial/fitter/experiment_toml.hpp"
#include "indicial/fitter/io.hpp"
#include "indicial/fitter/phase_resample.hpp"
#include "indicial/fitter/provenance.hpp"
#include "test_support.hpp"

namespace fs = std::filesystem;

namespace {

using indicial::testing::kPi;

const fs::path& dir() {
  static const indicial::testing::TempDir d("test-phase-resample");
  return d.path;
}

std::string write(const std::string& name, const std::string& text) {
  const fs::path p = dir() / name;
  std::ofstream(p, std::ios::binary) << text;
  return p.string();
}

// A C_L-like periodic history: harmonics 1-3 (a hysteresis loop's shape), peak-to-peak ~2.
double history(double phase) {
  return 0.8 + 0.9 * std::sin(phase) + 0.25 * std::sin(2 * phase + 0.7) + 0.08 * std::cos(3 * phase - 0.3);
}

// n phases in [0, 2 pi): evenly spaced, each moved by up to 40 % of the spacing (a digitizer's
// clicks), seeded.
std::vector<double> digitized_phases(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-0.4, 0.4);
  std::vector<double> p;
  for (int k = 0; k < n; ++k) p.push_back(2 * kPi * (k + 0.5 + u(rng)) / n);
  std::sort(p.begin(), p.end());
  return p;
}

// Periodic linear interpolation, the baseline the makima error is compared with.
double linear_at(const std::vector<double>& x, const std::vector<double>& y, double at) {
  const std::size_t n = x.size();
  for (std::size_t i = 0; i < n; ++i) {
    const double x0 = x[i], x1 = i + 1 < n ? x[i + 1] : x[0] + 2 * kPi;
    double a = at;
    if (a < x[0]) a += 2 * kPi;
    if (a >= x0 && a <= x1) return y[i] + (y[(i + 1) % n] - y[i]) * (a - x0) / (x1 - x0);
  }
  return y[0];
}

struct Errors {
  double makima = 0, linear = 0;
};
Errors interpolation_errors(int n) {
  Errors e;
  for (unsigned seed = 1; seed <= 20; ++seed) {
    const std::vector<double> x = digitized_phases(n, seed);
    std::vector<double> y;
    for (double p : x) y.push_back(history(p));
    std::vector<double> at;
    for (int k = 0; k < 1000; ++k) at.push_back(2 * kPi * k / 1000);
    const std::vector<double> v = indicial::periodic_interpolate(x, y, at);
    for (std::size_t k = 0; k < at.size(); ++k) {
      e.makima = std::max(e.makima, std::abs(v[k] - history(at[k])));
      e.linear = std::max(e.linear, std::abs(linear_at(x, y, at[k]) - history(at[k])));
    }
  }
  return e;
}

}  // namespace

TEST_CASE("periodic_interpolate: exact at the points, periodic, and its measured error at 30 and 60 points") {
  const std::vector<double> x = digitized_phases(30, 7);
  std::vector<double> y;
  for (double p : x) y.push_back(history(p));
  const std::vector<double> at_points = indicial::periodic_interpolate(x, y, x);
  for (std::size_t i = 0; i < x.size(); ++i) CHECK(at_points[i] == doctest::Approx(y[i]).epsilon(1e-12));
  // Periodic: the value and slope match across 0 = 2 pi.
  const std::vector<double> ends = indicial::periodic_interpolate(x, y, {1e-9, 2 * kPi - 1e-9, 2 * kPi + 0.1, 0.1});
  CHECK(ends[0] == doctest::Approx(ends[1]).epsilon(1e-7));
  CHECK(ends[2] == doctest::Approx(ends[3]).epsilon(1e-12));
  // The error, relative to the peak-to-peak amplitude (about 2.2), over 20 digitizations.
  const Errors e30 = interpolation_errors(30), e60 = interpolation_errors(60);
  MESSAGE("max error / p-p: 30 points makima " << e30.makima / 2.2 << " linear " << e30.linear / 2.2
                                               << "; 60 points makima " << e60.makima / 2.2 << " linear "
                                               << e60.linear / 2.2);
  CHECK(e30.makima < 0.5 * e30.linear);
  CHECK(e60.makima < 0.5 * e60.linear);
  CHECK(e30.makima / 2.2 < 0.015);
  CHECK(e60.makima / 2.2 < 0.003);
}

TEST_CASE("runs entry files = [...]: alpha, CL and Cm at their own phases make one periodic run") {
  // alpha at 41 phases (deg), CL at 37 (rad), Cm at 52 (deg): every quantity a smooth function of
  // phase, so the resampled run is compared with the functions on its grid.
  auto alpha_deg = [](double ph) { return 10 + 8 * std::sin(ph); };
  auto cm = [](double ph) { return -0.02 + 0.01 * std::cos(ph - 0.4); };
  std::string a = "phase_deg,alpha_deg\n", l = "% digitized CL\nphase_rad  CL\n", m = "phase_deg;Cm\n";
  for (double ph : digitized_phases(41, 1)) a += indicial::format_double(ph * 180 / kPi) + "," + indicial::format_double(alpha_deg(ph)) + "\n";
  for (double ph : digitized_phases(37, 2)) l += indicial::format_double(ph) + "  " + indicial::format_double(history(ph)) + "\n";
  for (double ph : digitized_phases(52, 3)) m += indicial::format_double(ph * 180 / kPi) + ";" + indicial::format_double(cm(ph)) + "\n";
  write("alpha.csv", a);
  write("cl.txt", l);
  write("cm.csv", m);
  const std::string toml =
      "axis = \"pitch\"\ncoefficients = [\"CL\", \"Cm\"]\nreference_length_m = 0.275\nairspeed_mps = 40\n"
      "runs = [{files = [\"alpha.csv\", \"cl.txt\", \"cm.csv\"], frequency_hz = 2.0, samples = 128}]\n"
      "[static.CL]\npolynomial = [0.1, 5.0]\n[static.Cm]\npolynomial = [0.0]\n";
  const std::vector<indicial::Experiment> es = indicial::load_experiments(write("files.toml", toml));
  REQUIRE(es.size() == 2);
  for (const indicial::Experiment& e : es) {
    const indicial::Run& r = e.runs[0];
    CHECK(r.periodic);
    CHECK(r.time_grid == indicial::TimeGrid::uniform);
    REQUIRE(r.size() == 128);
    CHECK(r.dt_s() == doctest::Approx(1.0 / 256).epsilon(1e-12));
    // The files as resolved from the experiment's folder (found from any working directory).
    const std::string d = dir().string() + "/";
    CHECK(r.path == d + "alpha.csv + " + d + "cl.txt + " + d + "cm.csv");
    CHECK(r.source_files == std::vector<std::string>{d + "alpha.csv", d + "cl.txt", d + "cm.csv"});
    double worst_alpha = 0, worst_c = 0;
    for (std::size_t k = 0; k < r.size(); ++k) {
      const double ph = 2 * kPi * static_cast<double>(k) / 128;
      worst_alpha = std::max(worst_alpha, std::abs(r.motion_angle_rad[k] * 180 / kPi - alpha_deg(ph)));
      worst_c = std::max(worst_c, std::abs(r.coefficient[k] - (e.coefficient == "CL" ? history(ph) : cm(ph))));
    }
    CHECK(worst_alpha < 0.02 * 16);  // 2 % of alpha's peak-to-peak
    CHECK(worst_c < (e.coefficient == "CL" ? 0.03 : 0.0005));
  }
  bool noted = false;
  for (const auto& n : es[0].notes) noted = noted || n.find("alpha_deg at 41, CL at 37 phases, interpolated") != std::string::npos;
  CHECK(noted);
  // Written back as files = [...] and read again to the same run.
  const std::string back = indicial::write_experiment_toml(es[0], {});
  const std::string d = dir().string() + "/";
  CHECK(back.find("{files = [\"" + d + "alpha.csv\", \"" + d + "cl.txt\", \"" + d + "cm.csv\"], frequency_hz = 2, samples = 128}") !=
        std::string::npos);
  const indicial::Experiment again = indicial::load_experiment(write("files_back.toml", back));
  CHECK(again.runs[0].coefficient == es[0].runs[0].coefficient);
  // Wrong entries name the problem.
  auto error_of = [&](const std::string& name, const std::string& text) {
    try {
      indicial::load_experiments(write(name, text));
    } catch (const indicial::InputError& err) {
      return std::string(err.what());
    }
    return std::string("(no error)");
  };
  auto with_runs = [&](const std::string& runs) {
    std::string t = toml;
    const std::size_t b = t.find("runs = "), e = t.find('\n', b);
    return t.replace(b, e - b, "runs = " + runs);
  };
  CHECK(error_of("nofreq.toml", with_runs("[{files = [\"alpha.csv\", \"cl.txt\", \"cm.csv\"]}]"))
            .find("needs the cycle's frequency") != std::string::npos);
  const std::string noalpha = error_of("noalpha.toml", with_runs("[{files = [\"cl.txt\", \"cm.csv\"], frequency_hz = 2.0}]"));
  CHECK(noalpha.find("no file of the run has the motion angle column") != std::string::npos);
  CHECK(noalpha.find("noalpha.toml:5: runs entry ") != std::string::npos);  // where the entry is
  CHECK(error_of("twice.toml", with_runs("[{files = [\"alpha.csv\", \"cl.txt\", \"cl.txt\", \"cm.csv\"], frequency_hz = 2.0}]"))
            .find("'CL' is in both") != std::string::npos);
  CHECK(error_of("both.toml", with_runs("[{file = \"alpha.csv\", files = [\"cl.txt\"], frequency_hz = 2.0}]"))
            .find("give 'runs.file' or 'runs.files', not both") != std::string::npos);
  CHECK(error_of("samples.toml", with_runs("[{file = \"alpha.csv\", samples = 64, frequency_hz = 2.0}]"))
            .find("'runs.samples' is used only with 'runs.files'") != std::string::npos);
}

// Digitized-series mistakes a user's trial hit (2026-11-27), each read through an experiment:
// radians under a phase_deg heading cover 1.7 % of the cycle (refused, the unit named); a
// series with a stretch left out is interpolated across it (warned, the gap's rows named); the
// motion angle in radians under alpha_deg is warned as for a run of one file.
TEST_CASE("files = [...]: a phase gap over half the cycle is refused, over 60 deg warned, radians named") {
  std::string alpha = "phase_deg,alpha_deg\n", alpha_rad = "phase_deg,alpha_deg\n", phase_rad = "phase_deg,CL\n",
              gap = "phase_deg,CL\n", full = "phase_deg,CL\n";
  for (double ph : digitized_phases(40, 4)) {
    const std::string p = indicial::format_double(ph * 180 / kPi);
    alpha += p + "," + indicial::format_double(10 + 8 * std::sin(ph)) + "\n";
    alpha_rad += p + "," + indicial::format_double((10 + 8 * std::sin(ph)) * kPi / 180) + "\n";
    phase_rad += indicial::format_double(ph) + "," + indicial::format_double(history(ph)) + "\n";  // rad as deg
    full += p + "," + indicial::format_double(history(ph)) + "\n";
    if (ph < 100 * kPi / 180 || ph > 190 * kPi / 180)  // 90 deg left out
      gap += p + "," + indicial::format_double(history(ph)) + "\n";
  }
  write("g_alpha.csv", alpha);
  write("g_alpha_rad.csv", alpha_rad);
  write("g_phase_rad.csv", phase_rad);
  write("g_gap.csv", gap);
  write("g_cl.csv", full);
  auto experiment = [](const std::string& files) {
    return "axis = \"pitch\"\ncoefficient = \"CL\"\nreference_length_m = 0.275\nairspeed_mps = 40\n"
           "runs = [{files = [" + files + "], frequency_hz = 2.0}]\n[static]\npolynomial = [0.1, 5.0]\n";
  };
  try {
    indicial::load_experiment(write("g1.toml", experiment("\"g_alpha.csv\", \"g_phase_rad.csv\"")));
    FAIL("radians under phase_deg were accepted");
  } catch (const indicial::InputError& err) {
    const std::string m = err.what();
    CAPTURE(m);
    CHECK(m.find("g_phase_rad.csv:2: column 'phase_deg': the phases leave a gap of") != std::string::npos);
    CHECK(m.find("more than half the cycle") != std::string::npos);
    CHECK(m.find("look like radians in a degree column") != std::string::npos);
  }
  // Degrees under a phase_rad heading: refused at the first phase past 2 pi, the unit named.
  std::string deg_as_rad = "phase_rad,CL\n";
  for (double ph : digitized_phases(40, 6))
    deg_as_rad += indicial::format_double(ph * 180 / kPi) + "," + indicial::format_double(history(ph)) + "\n";
  write("g_deg_as_rad.csv", deg_as_rad);
  try {
    indicial::load_experiment(write("g0.toml", experiment("\"g_alpha.csv\", \"g_deg_as_rad.csv\"")));
    FAIL("degrees under phase_rad were accepted");
  } catch (const indicial::InputError& err) {
    CHECK(std::string(err.what()).find("looks like degrees in a radian column") != std::string::npos);
  }
  // A repeated end point (360 deg) and a cycle in [-180, 180): refused with what to do.
  std::string end360 = "phase_deg,CL\n", signed_phase = "phase_deg,CL\n";
  for (double ph : digitized_phases(40, 7)) {
    end360 += indicial::format_double(ph * 180 / kPi) + "," + indicial::format_double(history(ph)) + "\n";
    signed_phase += indicial::format_double(ph * 180 / kPi - 180) + "," + indicial::format_double(history(ph)) + "\n";
  }
  end360 += "360," + indicial::format_double(history(0)) + "\n";
  write("g_end360.csv", end360);
  write("g_signed.csv", signed_phase);
  for (const auto& [file, hint] : {std::pair<std::string, std::string>{"g_end360.csv", "drop that row"},
                                   {"g_signed.csv", "add a full cycle to the negative phases"}}) {
    CAPTURE(file);
    try {
      indicial::load_experiment(write("g5.toml", experiment("\"g_alpha.csv\", \"" + file + "\"")));
      FAIL("accepted");
    } catch (const indicial::InputError& err) {
      CHECK(std::string(err.what()).find(hint) != std::string::npos);
    }
  }
  const indicial::Experiment g = indicial::load_experiment(write("g2.toml", experiment("\"g_alpha.csv\", \"g_gap.csv\"")));
  bool gap_warned = false;
  for (const std::string& w : g.warnings) gap_warned = gap_warned || (w.find("g_gap.csv:") != std::string::npos &&
                                                                      w.find("interpolated across it") != std::string::npos);
  CHECK(gap_warned);
  const indicial::Experiment r = indicial::load_experiment(write("g3.toml", experiment("\"g_alpha_rad.csv\", \"g_gap.csv\"")));
  bool radians_warned = false;
  for (const std::string& w : r.warnings) radians_warned = radians_warned || w.find("looks like radians") != std::string::npos;
  CHECK(radians_warned);
  // The complete series warn of nothing.
  const indicial::Experiment ok = indicial::load_experiment(write("g4.toml", experiment("\"g_alpha.csv\", \"g_cl.csv\"")));
  for (const std::string& w : ok.warnings) {
    CAPTURE(w);
    CHECK(w.find("gap") == std::string::npos);
    CHECK(w.find("radians") == std::string::npos);
  }
}

// A run of several files is found from any working directory (its files resolved from the
// experiment's folder, as a one-file run's) and each file is digested for the provenance: the
// run's path is a label, not a file (a user's trial: every fit of such a run failed at its
// SHA-256 after fitting).
TEST_CASE("files = [...]: each file resolved from the experiment's folder and digested for the provenance") {
  std::string a = "phase_deg,alpha_deg\n", l = "phase_deg,CL\n";
  for (double ph : digitized_phases(40, 5)) {
    a += indicial::format_double(ph * 180 / kPi) + "," + indicial::format_double(10 + 8 * std::sin(ph)) + "\n";
    l += indicial::format_double(ph * 180 / kPi) + "," + indicial::format_double(history(ph)) + "\n";
  }
  fs::create_directories(dir() / "sub");
  write("sub/p_alpha.csv", a);
  write("sub/p_cl.csv", l);
  const std::string toml = write("sub/p.toml", "axis = \"pitch\"\ncoefficient = \"CL\"\nreference_length_m = 0.275\n"
                                               "airspeed_mps = 40\nruns = [{files = [\"p_alpha.csv\", \"p_cl.csv\"], "
                                               "frequency_hz = 2.0}]\n[static]\npolynomial = [0.1, 5.0]\n");
  const indicial::Experiment e = indicial::load_experiment(toml);
  const indicial::Provenance p = indicial::experiment_provenance(e, "test", "commit");
  REQUIRE(p.inputs.size() == 3);  // the experiment and the run's two files
  CHECK(p.inputs[1].path == (dir() / "sub" / "p_alpha.csv").string());
  CHECK(p.inputs[2].path == (dir() / "sub" / "p_cl.csv").string());
  CHECK(p.inputs[1].sha256 == indicial::sha256_hex(a));
  CHECK(p.inputs[2].sha256 == indicial::sha256_hex(l));
  CHECK(indicial::experiment_input_paths(e) ==
        std::vector<std::string>{toml, p.inputs[1].path, p.inputs[2].path});
}

// A digitizer's export (2026-11-30 trial): every file headed x,y. The experiment's [columns]
// cannot say that y is alpha in one file and C_L in another (a map sending 'y' to both is
// refused: one of the two was silently lost), so each file carries its own map, which
// resolves to the same run as files with our names, and is written back with the run.
TEST_CASE("files = [...]: a file's own column map reads x,y files, one column mapped twice is refused") {
  std::string named_a = "phase_deg,alpha_deg\n", named_l = "phase_deg,CL\n", xy_a = "x,y\n", xy_l = "x,y\n";
  for (double ph : digitized_phases(44, 11)) {
    const std::string p = indicial::format_double(ph * 180 / kPi), v = indicial::format_double(10 + 8 * std::sin(ph));
    named_a += p + "," + v + "\n";
    xy_a += p + "," + v + "\n";
  }
  for (double ph : digitized_phases(39, 12)) {
    const std::string p = indicial::format_double(ph * 180 / kPi), v = indicial::format_double(history(ph));
    named_l += p + "," + v + "\n";
    xy_l += p + "," + v + "\n";
  }
  write("n_alpha.csv", named_a);
  write("n_cl.csv", named_l);
  write("xy_alpha.csv", xy_a);
  write("xy_cl.csv", xy_l);
  const std::string head = "axis = \"pitch\"\ncoefficient = \"CL\"\nreference_length_m = 0.275\nairspeed_mps = 40\n";
  const std::string tail = "[static]\npolynomial = [0.1, 5.0]\n";
  const indicial::Experiment named = indicial::load_experiment(write(
      "named.toml", head + "runs = [{files = [\"n_alpha.csv\", \"n_cl.csv\"], frequency_hz = 2.0}]\n" + tail));
  const indicial::Experiment own = indicial::load_experiment(
      write("own.toml", head +
                            "runs = [{files = [{file = \"xy_alpha.csv\", columns = {phase_deg = \"x\", alpha_deg = "
                            "\"y\"}}, {file = \"xy_cl.csv\", columns = {phase_deg = \"x\", CL = \"y\"}}], "
                            "frequency_hz = 2.0}]\n" + tail));
  REQUIRE(own.runs.size() == 1);
  CHECK(own.runs[0].motion_angle_rad == named.runs[0].motion_angle_rad);
  CHECK(own.runs[0].coefficient == named.runs[0].coefficient);
  // Written back with each file's map, and read again to the same run.
  const std::string back = indicial::write_experiment_toml(own, {});
  CHECK(back.find("columns = {CL = \"y\", phase_deg = \"x\"}}") != std::string::npos);
  const indicial::Experiment again = indicial::load_experiment(write("own_back.toml", back));
  CHECK(again.runs[0].coefficient == own.runs[0].coefficient);
  // One map sending 'y' to two quantities: refused, at its line, with the way out.
  std::string clash;
  try {
    indicial::load_experiment(write("clash.toml", head + "runs = [{files = [\"xy_alpha.csv\", \"xy_cl.csv\"], "
                                                         "frequency_hz = 2.0}]\n" + tail +
                                                         "[columns]\nphase_deg = \"x\"\nalpha_deg = \"y\"\nCL = \"y\"\n"));
  } catch (const indicial::InputError& e) {
    clash = e.what();
  }
  CHECK(clash.find("clash.toml:10: 'columns' maps the file column 'y' to both 'CL' and 'alpha_deg'") != std::string::npos);
  CHECK(clash.find("each need a map of their own") != std::string::npos);
  // A file's own map wins over [columns] for the file columns it names (the review's case:
  // [columns] CL = "y" must not take the alpha file's y), and the other files keep [columns].
  const indicial::Experiment layered = indicial::load_experiment(
      write("layered.toml", head +
                                "runs = [{files = [{file = \"xy_alpha.csv\", columns = {alpha_deg = \"y\"}}, "
                                "\"xy_cl.csv\"], frequency_hz = 2.0}]\n" + tail +
                                "[columns]\nphase_deg = \"x\"\nCL = \"y\"\n"));
  CHECK(layered.runs[0].motion_angle_rad == named.runs[0].motion_angle_rad);
  CHECK(layered.runs[0].coefficient == named.runs[0].coefficient);
  // A file's own map naming a column the file lacks: refused, naming that file's map.
  std::string lacking;
  try {
    indicial::load_experiment(write("lacking.toml", head + "runs = [{files = [{file = \"xy_alpha.csv\", columns = "
                                                           "{phase_deg = \"x\", alpha_deg = \"Y\"}}, {file = "
                                                           "\"xy_cl.csv\", columns = {phase_deg = \"x\", CL = "
                                                           "\"y\"}}], frequency_hz = 2.0}]\n" + tail));
  } catch (const indicial::InputError& e) {
    lacking = e.what();
  }
  CHECK(lacking.find("lacking.toml:5: runs entry: the map of 'xy_alpha.csv' names its column 'Y' (for alpha_deg), "
                     "which the file does not have (columns found: x, y)") != std::string::npos);
  // One column twice with a sign flip is still one column twice.
  std::string flipped;
  try {
    indicial::load_experiment(write("flipped.toml", head + "runs = [{files = [\"xy_alpha.csv\", \"xy_cl.csv\"], "
                                                            "frequency_hz = 2.0}]\n" + tail +
                                                            "[columns]\nalpha_deg = \"y\"\nCL = \"-y\"\n"));
  } catch (const indicial::InputError& e) {
    flipped = e.what();
  }
  CHECK(flipped.find("maps the file column 'y' to both 'CL' and 'alpha_deg'") != std::string::npos);
  // A file table's keys are checked like every other table's.
  std::string unknown;
  try {
    indicial::load_experiment(write("unknown.toml", head + "runs = [{files = [{file = \"n_alpha.csv\", colums = {}}, "
                                                           "\"n_cl.csv\"], frequency_hz = 2.0}]\n" + tail));
  } catch (const indicial::InputError& e) {
    unknown = e.what();
  }
  CHECK(unknown.find("colums") != std::string::npos);
}

// A quantity no file of the run has: each file's columns and the nearest name, as a one-file
// run's missing column says (the trial's Cm file was headed 'cm').
TEST_CASE("files = [...]: a missing column names each file's columns and the nearest name") {
  std::string a = "phase_deg,alpha_deg\n", m = "phase_deg,cm\n";
  for (double ph : digitized_phases(40, 21)) a += indicial::format_double(ph * 180 / kPi) + ",10\n";
  for (double ph : digitized_phases(40, 22)) m += indicial::format_double(ph * 180 / kPi) + ",-0.01\n";
  write("m_alpha.csv", a);
  write("m_cm.csv", m);
  std::string message;
  try {
    indicial::load_experiment(write("missing.toml",
                                    "axis = \"pitch\"\ncoefficient = \"Cm\"\nreference_length_m = 0.275\nairspeed_mps "
                                    "= 40\nruns = [{files = [\"m_alpha.csv\", \"m_cm.csv\"], frequency_hz = 2.0}]\n"
                                    "[static]\npolynomial = [0.0]\n"));
  } catch (const indicial::InputError& e) {
    message = e.what();
  }
  const std::string d = dir().string() + "/";
  CHECK(message.find("no file of the run has the 'Cm' column (columns found: " + d + "m_alpha.csv: phase_deg, alpha_deg; " +
                     d + "m_cm.csv: phase_deg, cm); did you mean 'cm' in " + d + "m_cm.csv? (map it in [columns]: Cm = \"cm\")") !=
        std::string::npos);
}

// CL and Cm of one run on one grid: the default size counts every file of the run, so the two
// coefficients of `coefficients = ["CL", "Cm"]` share their phases (and their envelope).
TEST_CASE("files = [...]: every coefficient of a run is resampled onto the same default grid") {
  std::string a = "phase_deg,alpha_deg\n", l = "phase_deg,CL\n", m = "phase_deg,Cm\n";
  for (double ph : digitized_phases(50, 31)) a += indicial::format_double(ph * 180 / kPi) + "," + indicial::format_double(10 + 8 * std::sin(ph)) + "\n";
  for (double ph : digitized_phases(60, 32)) l += indicial::format_double(ph * 180 / kPi) + "," + indicial::format_double(history(ph)) + "\n";
  for (double ph : digitized_phases(90, 33)) m += indicial::format_double(ph * 180 / kPi) + ",-0.01\n";
  write("g2_alpha.csv", a);
  write("g2_cl.csv", l);
  write("g2_cm.csv", m);
  const std::vector<indicial::Experiment> es = indicial::load_experiments(write(
      "grid.toml", "axis = \"pitch\"\ncoefficients = [\"CL\", \"Cm\"]\nreference_length_m = 0.275\nairspeed_mps = 40\n"
                   "runs = [{files = [\"g2_alpha.csv\", \"g2_cl.csv\", \"g2_cm.csv\"], frequency_hz = 2.0}]\n"
                   "[static.CL]\npolynomial = [0.1, 5.0]\n[static.Cm]\npolynomial = [0.0]\n"));
  REQUIRE(es.size() == 2);
  CHECK(es[0].runs[0].size() == 90);  // Cm's file has the most rows; CL's run takes its grid too
  CHECK(es[1].runs[0].size() == 90);
  CHECK(es[0].runs[0].motion_angle_rad == es[1].runs[0].motion_angle_rad);
}

// The phase as the fraction of the cycle (t / T), as digitized histories are often plotted:
// phase_cycles reads as phase_deg / 360; a phase_deg column that never exceeds 1 is refused
// (its gap) with the hint to name it so (the trial's message said "radians").
TEST_CASE("phase_cycles: a phase as the fraction of the cycle, a t / T column under phase_deg is named") {
  std::string deg = "phase_deg,alpha_deg\n", cyc = "phase_cycles,alpha_deg\n", wrong = "phase_deg,alpha_deg\n",
              cl = "phase_deg,CL\n";
  for (double ph : digitized_phases(45, 41)) {
    const std::string v = indicial::format_double(10 + 8 * std::sin(ph));
    deg += indicial::format_double(ph * 180 / kPi) + "," + v + "\n";
    cyc += indicial::format_double(ph / (2 * kPi)) + "," + v + "\n";
    wrong += indicial::format_double(ph / (2 * kPi)) + "," + v + "\n";
  }
  for (double ph : digitized_phases(45, 42))
    cl += indicial::format_double(ph * 180 / kPi) + "," + indicial::format_double(history(ph)) + "\n";
  write("c_deg.csv", deg);
  write("c_cyc.csv", cyc);
  write("c_wrong.csv", wrong);
  write("c_cl.csv", cl);
  auto experiment = [&](const std::string& name, const std::string& alpha_file) {
    return write(name, "axis = \"pitch\"\ncoefficient = \"CL\"\nreference_length_m = 0.275\nairspeed_mps = 40\n"
                       "runs = [{files = [\"" + alpha_file + "\", \"c_cl.csv\"], frequency_hz = 2.0}]\n"
                       "[static]\npolynomial = [0.1, 5.0]\n");
  };
  const indicial::Experiment in_deg = indicial::load_experiment(experiment("c_deg.toml", "c_deg.csv"));
  const indicial::Experiment in_cycles = indicial::load_experiment(experiment("c_cyc.toml", "c_cyc.csv"));
  REQUIRE(in_cycles.runs[0].size() == in_deg.runs[0].size());
  for (std::size_t k = 0; k < in_deg.runs[0].size(); ++k)
    CHECK(in_cycles.runs[0].motion_angle_rad[k] == doctest::Approx(in_deg.runs[0].motion_angle_rad[k]).epsilon(1e-12));
  std::string message;
  try {
    indicial::load_experiment(experiment("c_wrong.toml", "c_wrong.csv"));
  } catch (const indicial::InputError& e) {
    message = e.what();
  }
  CHECK(message.find("they look like a fraction of the cycle, t / T; name it phase_cycles if so") != std::string::npos);
  // Radians under phase_cycles: every value past the first exceeds 1, and the hint says radians
  // (judged on the column's largest value, not on the first row out of range).
  std::string rad = "phase_cycles,alpha_deg\n";
  for (double ph : digitized_phases(45, 43)) rad += indicial::format_double(ph) + ",10\n";
  write("c_rad.csv", rad);
  message.clear();
  try {
    indicial::load_experiment(experiment("c_rad.toml", "c_rad.csv"));
  } catch (const indicial::InputError& e) {
    message = e.what();
  }
  CHECK(message.find("they look like radians in a column of cycles; name it phase_rad if so") != std::string::npos);
}
