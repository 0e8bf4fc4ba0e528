// Run files as real databases write them (csv_reader.hpp, experiment [columns] and [csv]):
// whitespace-separated text with a `%` header line, a phase column under the database's own
// name, normal- and chord-force coefficients from which CL and CD are derived, and the `Cn`
// ambiguity (indicial's Cn is the yawing moment).
#include <doctest/doctest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "indicial/fitter/error.hpp"
#include "indicial/fitter/experiment_toml.hpp"
#include "indicial/fitter/io.hpp"
#include "test_support.hpp"

namespace fs = std::filesystem;

namespace {

using indicial::testing::kPi;

const fs::path& dir() {
  static const indicial::testing::TempDir d("test-csv-reader");
  return d.path;
}

std::string write(const std::string& name, const std::string& text) {
  return indicial::testing::write_text(dir() / name, text);
}

// The database's layout: a `%` header typed with spaces, 128 tab-separated rows, the phase in
// rad printed to 2 decimals under "Time()", the angle under "Angle(deg)", normal and chord
// force Cn, Ct, and Cm. alpha = 10 + 8 sin(phase) deg; Cn = 2 pi sin(alpha) (attached flow),
// Ct = 0.01 + 0.1 sin(alpha)^2.
struct Cycle {
  std::vector<double> alpha_deg, cn, ct, cm;
};
Cycle database_cycle() {
  Cycle c;
  for (int k = 0; k < 128; ++k) {
    const double phase = 2 * kPi * k / 128;
    const double a = 10.0 + 8.0 * std::sin(phase);
    const double s = std::sin(a * kPi / 180);
    c.alpha_deg.push_back(a);
    c.cn.push_back(2 * kPi * s);
    c.ct.push_back(0.01 + 0.1 * s * s);
    c.cm.push_back(-0.02 * s);
  }
  return c;
}
std::string database_text(const Cycle& c, const char* header = "% Time() Angle(deg) Cn Ct Cm") {
  std::string s = std::string(header) + "\n";
  for (int k = 0; k < 128; ++k) {
    char row[160];
    std::snprintf(row, sizeof row, "%.2f\t%.17g\t%.17g\t%.17g\t%.17g\n", 2 * kPi * k / 128, c.alpha_deg[k],
                  c.cn[k], c.ct[k], c.cm[k]);
    s += row;
  }
  return s;
}

const char* kMapped = R"toml([columns]
phase_rad = "Time()"
alpha_deg = "Angle(deg)"
Cnormal = "Cn"
Ctangential = "Ct"
)toml";

std::string experiment(const std::string& coefficient, const std::string& columns, const std::string& extra = "") {
  return "axis = \"pitch\"\ncoefficient = \"" + coefficient +
         "\"\nreference_length_m = 0.275\nairspeed_mps = 40\n"
         "runs = [{file = \"cycle.dat\", reduced_frequency = 0.05}]\n" + extra +
         "[static]\npolynomial = [0.1, 5.0]\n\n[model]\na_degree = 1\n\n" + columns;
}

std::string load_error(const std::string& name, const std::string& text) {
  try {
    indicial::load_experiment(write(name, text));
  } catch (const indicial::InputError& e) {
    return e.what();
  }
  return "(no error)";
}

bool any_has(const std::vector<std::string>& v, const std::string& s) {
  for (const auto& x : v)
    if (x.find(s) != std::string::npos) return true;
  return false;
}

// A database cycle, two static tables (static_lift.csv with Cnormal, Ctangential and Cm;
// static_cm.csv with Cm only) and a Cm experiment whose [static] table is static_lift.csv.
std::string cm_experiment_with_lift_table() {
  std::string with_lift = "alpha_deg;Cnormal;Ctangential;Cm\n", cm_only = "alpha_deg;Cm\n";
  for (int k = 0; k <= 20; ++k) {
    with_lift += std::to_string(k) + ";" + std::to_string(0.1 * k) + ";0,01;-0,01\n";
    cm_only += std::to_string(k) + ";-0,01\n";
  }
  write("cycle.dat", database_text(database_cycle()));
  write("static_lift.csv", with_lift);
  write("static_cm.csv", cm_only);
  std::string t = experiment("Cm", kMapped);
  t.replace(t.find("polynomial = [0.1, 5.0]"), 23, "table = \"static_lift.csv\"");
  return t;
}

}  // namespace

TEST_CASE("a database cycle: % header, whitespace, mapped phase and angle, CL and CD derived from Cn and Ct") {
  const Cycle c = database_cycle();
  write("cycle.dat", database_text(c));
  for (const char* coefficient : {"CL", "CD"}) {
    CAPTURE(coefficient);
    const indicial::Experiment e = indicial::load_experiment(write("db.toml", experiment(coefficient, kMapped)));
    REQUIRE(e.runs.size() == 1);
    const indicial::Run& r = e.runs[0];
    CHECK(r.time_source == indicial::TimeSource::phase_column);
    CHECK(r.periodic);
    CHECK(r.time_grid == indicial::TimeGrid::uniform);  // the 0.01-rad rounding snapped
    REQUIRE(r.size() == 128);
    // f = k V / (2 pi l): the grid is k / (128 f).
    const double f = 0.05 * 40 / (2 * kPi * 0.275);
    CHECK(r.time_s[64] == doctest::Approx(64 / (128 * f)).epsilon(1e-9));
    for (int k = 0; k < 128; ++k) {
      const double a = c.alpha_deg[k] * kPi / 180;
      const double want = std::string(coefficient) == "CL" ? c.cn[k] * std::cos(a) + c.ct[k] * std::sin(a)
                                                           : c.cn[k] * std::sin(a) - c.ct[k] * std::cos(a);
      CHECK(r.motion_angle_rad[k] == doctest::Approx(a).epsilon(1e-15));
      CHECK(r.coefficient[k] == doctest::Approx(want).epsilon(1e-14));
    }
    CHECK(any_has(e.notes, "the column names are read from this comment line"));
    CHECK(any_has(e.notes, "read as whitespace-separated"));
    CHECK(any_has(e.notes, std::string(coefficient) + " derived from 'Cn' (Cnormal) and 'Ct' (Ctangential)"));
  }
  // Cm straight from the file; the unused Cn (mapped) is not the yawing moment and nothing warns.
  const indicial::Experiment m = indicial::load_experiment(write("db_cm.toml", experiment("Cm", kMapped)));
  CHECK(m.runs[0].coefficient[5] == c.cm[5]);
  CHECK_FALSE(any_has(m.warnings, "Cn"));
}

TEST_CASE("the dialect declared in [csv] reads the same, a wrong one is named") {
  const Cycle c = database_cycle();
  write("cycle.dat", database_text(c));
  const indicial::Experiment detected = indicial::load_experiment(write("det.toml", experiment("Cm", kMapped)));
  const indicial::Experiment declared = indicial::load_experiment(
      write("decl.toml", experiment("Cm", kMapped, "[csv]\ndelimiter = \"whitespace\"\ncomment = \"%\"\n")));
  CHECK(declared.runs[0].coefficient == detected.runs[0].coefficient);
  CHECK(declared.runs[0].time_s == detected.runs[0].time_s);
  // Declared tab: the header typed with spaces is one field, not the data's five.
  CHECK_HAS(load_error("tab.toml", experiment("Cm", kMapped, "[csv]\ndelimiter = \"tab\"\n")),
            "cycle.dat:1: no header row: the first data row is numbers, and this comment line has 1 tab-separated "
            "fields, not the data's 5");
  // '#' only: the % line is then the header row itself, with a stray '%' field.
  CHECK_HAS(load_error("hash.toml", experiment("Cm", kMapped, "[csv]\ncomment = \"#\"\n")), "cycle.dat:2: expected 6");
  CHECK_HAS(load_error("bad.toml", experiment("Cm", kMapped, "[csv]\ndelimiter = \"space\"\n")),
            "'csv.delimiter' must be \"detect\", \"comma\", \"semicolon\", \"tab\" or \"whitespace\"");
  CHECK_HAS(load_error("badc.toml", experiment("Cm", kMapped, "[csv]\ncomment = \"-\"\n")), "cannot start a comment");
  CHECK_HAS(load_error("badk.toml", experiment("Cm", kMapped, "[csv]\nquote = \"'\"\n")), "csv.quote");
  // No header anywhere: numbers from the first line.
  std::string bare = database_text(c);
  bare.erase(0, bare.find('\n') + 1);
  write("cycle.dat", bare);
  CHECK_HAS(load_error("bare.toml", experiment("Cm", kMapped)),
            "cycle.dat:1: no header row: the first row is numbers (add a header row of column names)");
}

TEST_CASE("Cn: the yawing moment, never silently the normal force") {
  const Cycle c = database_cycle();
  write("cycle.dat", database_text(c));
  const std::string phase_only = "[columns]\nphase_rad = \"Time()\"\nalpha_deg = \"Angle(deg)\"\n";
  // CL from a file with Cn and Ct unmapped: the error says how to map them.
  const std::string m1 = load_error("cl.toml", experiment("CL", phase_only));
  CHECK_HAS(m1, "cycle.dat:1: missing column 'CL'; this file's 'Cn' and 'Ct' look like the normal- and chord-force");
  CHECK_HAS(m1, "[columns] Cnormal = \"Cn\" and Ctangential = \"Ct\"");
  // Fitting "Cn" from it: refused, with both ways out.
  const std::string m2 = load_error("cn.toml", experiment("Cn", phase_only));
  CHECK_HAS(m2, "column 'Cn' beside a chord-force column looks like the normal-force coefficient");
  CHECK_HAS(m2, "[columns] Cn = \"Cn\"");
  // Declared the yawing moment: read, with the pitch-experiment warning.
  const indicial::Experiment yaw = indicial::load_experiment(write("cnyaw.toml", experiment("Cn", phase_only + "Cn = \"Cn\"\n")));
  CHECK(yaw.runs[0].coefficient[3] == c.cn[3]);
  CHECK(any_has(yaw.warnings, "coefficient Cn in a pitch experiment: indicial's Cn is the yawing moment"));
  // Half a pair.
  CHECK_HAS(load_error("half.toml", experiment("CL", phase_only + "Cnormal = \"Cn\"\n")),
            "CL from body-axis forces needs both 'Cnormal' and 'Ctangential'; only 'Cnormal' is here");
  // The other half mapped to a column the file does not have (its spelling is 'Ct'): named.
  const std::string miss = load_error("miss.toml", experiment("CL", phase_only + "Cnormal = \"Cn\"\nCtangential = \"-CC\"\n"));
  CHECK_HAS(miss, "only 'Cnormal' is here; [columns] maps Ctangential to '-CC', not in this file (columns found: "
                  "Time(), Angle(deg), Cn, Ct, Cm)");
  // Not a pitch run: no angle of attack to rotate by.
  std::string roll = database_text(c, "% Time() phi_deg Cnormal Ctangential Cm");
  write("cycle.dat", roll);
  std::string rt = experiment("CL", "[columns]\nphase_rad = \"Time()\"\n");
  rt.replace(rt.find("axis = \"pitch\""), 14, "axis = \"roll\"\nalpha0_deg = 20");
  CHECK_HAS(load_error("roll.toml", rt), "needs the angle of attack of a pitch run; this is a roll run");
}

TEST_CASE("a static table of normal and chord force gives CL") {
  std::string table = "alpha_deg;Cnormal;Ctangential\n";
  for (int k = 0; k <= 20; ++k) table += std::to_string(k) + ";" + std::to_string(0.1 * k) + ";0,01\n";
  const Cycle c = database_cycle();
  write("cycle.dat", database_text(c));
  write("static.csv", table);
  std::string t = experiment("CL", kMapped);
  t.replace(t.find("polynomial = [0.1, 5.0]"), 23, "table = \"static.csv\"");
  const indicial::Experiment e = indicial::load_experiment(write("table.toml", t));
  const double a = 7 * kPi / 180;
  CHECK(e.static_curve.table_value[7] == doctest::Approx(0.7 * std::cos(a) + 0.01 * std::sin(a)).epsilon(1e-15));
}

TEST_CASE("a static table in another delimiter than the declared [csv] one is named as such") {
  // [csv] delimiter applies to the runs and the static table alike: a comma table read as
  // whitespace-separated is one column, and the error says which delimiter would split it.
  std::string table = "alpha_deg,Cnormal,Ctangential\n";
  for (int k = 0; k <= 20; ++k) table += std::to_string(k) + "," + std::to_string(0.1 * k) + ",0.01\n";
  write("cycle.dat", database_text(database_cycle()));
  write("static_comma.csv", table);
  std::string t = experiment("CL", kMapped, "[csv]\ndelimiter = \"whitespace\"\ncomment = \"%\"\n");
  t.replace(t.find("polynomial = [0.1, 5.0]"), 23, "table = \"static_comma.csv\"");
  const std::string m = load_error("comma_table.toml", t);
  CHECK_HAS(m, "static_comma.csv:1: missing column");
  CHECK_HAS(m, "the header is one column when read with the whitespace delimiter but splits at comma");
  // Detected (no [csv]): the same table reads.
  std::string d = experiment("CL", kMapped);
  d.replace(d.find("polynomial = [0.1, 5.0]"), 23, "table = \"static_comma.csv\"");
  CHECK(indicial::load_experiment(write("comma_detect.toml", d)).static_curve.table_value.size() == 21);
}

TEST_CASE("a Cm experiment's static table that also has the lift gives diagnose its lift polar") {
  std::string t = cm_experiment_with_lift_table();
  const indicial::Experiment e = indicial::load_experiment(write("cm_lift.toml", t));
  REQUIRE(e.table_lift_polar.x_rad.size() == 21);
  const double a = 7 * kPi / 180;
  CHECK(e.table_lift_polar.lift[7] == doctest::Approx(0.7 * std::cos(a) + 0.01 * std::sin(a)).epsilon(1e-15));
  CHECK(e.table_lift_polar.path.find("static_lift.csv") != std::string::npos);
  CHECK(e.static_curve.table_value[7] == doctest::Approx(-0.01));
  t.replace(t.find("static_lift.csv"), 15, "static_cm.csv");
  CHECK(indicial::load_experiment(write("cm_only.toml", t)).table_lift_polar.empty());
}

TEST_CASE("a Cm experiment's stall families take their lift polar from its static table") {
  // The polar diagnose offers the families with (Experiment::table_lift_polar) is the one the
  // experiment file's model.stall takes without a model.stall_polar: an experiment diagnose
  // writes, and one a user writes by hand, mean the same.
  std::string t = cm_experiment_with_lift_table();
  t.replace(t.find("a_degree = 1\n"), 13, "a_degree = 1\nstall = \"separation\"\n");
  const indicial::Experiment e = indicial::load_experiment(write("cm_stall.toml", t));
  REQUIRE(e.model.stall.polar_lift.size() == 21);
  CHECK(e.model.stall.polar_lift == e.table_lift_polar.lift);
  CHECK(e.model.stall.polar_x_rad == e.table_lift_polar.x_rad);
  // ... and that polar is the lift of the table's rows (CL = Cn cos(alpha) + Ct sin(alpha)),
  // computed here from the values the test wrote, not from the reader's own polar.
  const double a7 = 7 * kPi / 180;
  CHECK(e.model.stall.polar_x_rad[7] == doctest::Approx(a7).epsilon(1e-15));
  CHECK(e.model.stall.polar_lift[7] == doctest::Approx(0.7 * std::cos(a7) + 0.01 * std::sin(a7)).epsilon(1e-15));
  CHECK(e.model.stall.polar_path.find("static_lift.csv") != std::string::npos);
  // The model.stall_polar_column names another column: not the table's lift.
  std::string other = t;
  other.replace(other.find("stall = \"separation\"\n"), 21, "stall = \"separation\"\nstall_polar_column = \"CN\"\n");
  CHECK_HAS(load_error("cm_stall_cn.toml", other), "'model.stall' needs the static lift polar");
  // A table without the lift: refused, naming the key that gives the polar.
  t.replace(t.find("static_lift.csv"), 15, "static_cm.csv");
  CHECK_HAS(load_error("cm_stall_no_lift.toml", t), "'model.stall' needs the static lift polar");
}

TEST_CASE("a phase column not uniform to its digits: nonuniform with a note, refused when uniform is declared") {
  // 40 digitized phases (deg) at irregular spacing.
  std::string s = "phase_deg,alpha_deg,Cm\n";
  for (int k = 0; k < 40; ++k) {
    const double ph = 9.0 * k + 3.0 * std::sin(1.7 * k);
    s += indicial::format_double(ph) + "," + indicial::format_double(10 + 5 * std::sin(ph * kPi / 180)) + ",0.1\n";
  }
  const std::string path = write("digitized.csv", s);
  indicial::RunCsvOptions o;
  o.frequency_hz = 1.0;
  const indicial::Run r = indicial::read_run_csv(path, indicial::Axis::pitch, "Cm",
                                                 indicial::CoefficientPresence::required, o);
  CHECK(r.time_grid == indicial::TimeGrid::nonuniform);
  CHECK(any_has(r.notes, "'phase_deg' is not uniform even to its printed digits"));
  o.grid = indicial::TimeGrid::uniform;
  std::string m;
  try {
    indicial::read_run_csv(path, indicial::Axis::pitch, "Cm", indicial::CoefficientPresence::required, o);
  } catch (const indicial::InputError& e) {
    m = e.what();
  }
  CHECK_HAS(m, "but a uniform grid was declared");
  // Without a frequency: the advice names where the caller takes it from.
  o.grid.reset();
  o.frequency_hz = 0.0;
  for (auto [source, advice] : {std::pair{indicial::FrequencySource::experiment_entry, "in the experiment's runs entry"},
                                std::pair{indicial::FrequencySource::command_line, "--frequency-hz or --reduced-frequency"},
                                std::pair{indicial::FrequencySource::none, "'simulate --motion csv:' cannot take"}}) {
    o.frequency_source = source;
    std::string msg;
    try {
      indicial::read_run_csv(path, indicial::Axis::pitch, "Cm", indicial::CoefficientPresence::required, o);
    } catch (const indicial::InputError& e) {
      msg = e.what();
    }
    CHECK_HAS(msg, advice);
  }
}

// Tunnel exports put the units in a row under the column names ("s,deg,-"): skipped with a
// note (a user's trial: it was refused as "non-numeric value 'deg'"). Only a row of no numbers
// straight under the header; a non-numeric cell among data rows is still an error.
TEST_CASE("a units row under the header is skipped with a note") {
  std::string text = "time_s,alpha_deg,Cm\ns,deg,-\n";
  for (int i = 0; i < 20; ++i)
    text += indicial::format_double(0.01 * i) + "," + indicial::format_double(5 + i) + "," +
            indicial::format_double(-0.01 * i) + "\n";
  const std::string path = write("units.csv", text);
  const indicial::Run r = indicial::read_run_csv(path, indicial::Axis::pitch, "Cm", indicial::CoefficientPresence::required);
  REQUIRE(r.size() == 20);
  CHECK(r.motion_angle_rad[3] == doctest::Approx(8 * kPi / 180).epsilon(1e-15));
  CHECK(any_has(r.notes, "units.csv:2: read as a units row (s, deg, -) and skipped"));
  CHECK(r.warnings.empty());
  // A units row that contradicts a name is warned: the name is what is read.
  std::string contradicting = text;
  contradicting.replace(contradicting.find("s,deg,-"), 7, "s,rad,-");
  const indicial::Run c = indicial::read_run_csv(write("units_rad.csv", contradicting), indicial::Axis::pitch, "Cm",
                                                 indicial::CoefficientPresence::required);
  CHECK(c.motion_angle_rad[3] == r.motion_angle_rad[3]);
  CHECK(any_has(c.warnings, "units_rad.csv:2: the units row gives 'rad' for column 'alpha_deg'"));
  std::string bad = text;
  bad.insert(bad.find("0.05,"), "s,deg,-\n");  // the same row among the data
  CHECK_THROWS_WITH_AS(indicial::read_run_csv(write("units_bad.csv", bad), indicial::Axis::pitch, "Cm",
                                              indicial::CoefficientPresence::required),
                       doctest::Contains("non-numeric"), indicial::InputError);
}

TEST_CASE("a time step longer than the runtime's largest is refused, a mapped column's unit contradiction warned") {
  // A facility's `t [ms]` column mapped to time_s: 2 ms samples read as 2 s steps, which the
  // runtime refuses (max_step_dt_s = 1 s): a fit of them could be neither replayed nor predicted.
  std::string text = "t [ms]\tAoA [deg]\tCm\n";
  for (int i = 0; i < 40; ++i)
    text += indicial::format_double(2.0 * i) + "\t" + indicial::format_double(5 + 0.1 * i) + "\t" +
            indicial::format_double(-0.001 * i) + "\n";
  write("ms.txt", text);
  const std::string columns = "[columns]\ntime_s = \"t [ms]\"\nalpha_deg = \"AoA [deg]\"\n";
  const std::string exp = "axis = \"pitch\"\ncoefficient = \"Cm\"\nreference_length_m = 0.15\nairspeed_mps = 30\n"
                          "runs = [\"ms.txt\"]\n[static]\npolynomial = [0.0, -0.1]\n\n[model]\na_degree = 1\n\n" + columns;
  const std::string err = load_error("ms.toml", exp);
  CHECK(err.find("ms.txt:3: column 't [ms]' (read as time_s, seconds): a time step of 2 s (2 after 0) is longer "
                 "than the runtime's largest step (1 s): is the column in seconds?") != std::string::npos);
  // The same file in seconds (0.002 s steps) loads; a name that says ms is still warned.
  std::string seconds = "t [ms]\tAoA [deg]\tCm\n";
  for (int i = 0; i < 40; ++i)
    seconds += indicial::format_double(0.002 * i) + "\t" + indicial::format_double(5 + 0.1 * i) + "\t" +
               indicial::format_double(-0.001 * i) + "\n";
  write("ms.txt", seconds);
  const indicial::Experiment e = indicial::load_experiment(write("ms.toml", exp));
  CHECK(any_has(e.warnings, "column 't [ms]' is read as time_s (in s), but its name says ms"));
  // A name in the column's own unit: nothing said about units.
  write("s.txt", "t [s]\tAoA [deg]\tCm\n" + seconds.substr(seconds.find('\n') + 1));
  std::string in_seconds = exp;
  in_seconds.replace(in_seconds.find("ms.txt"), 6, "s.txt");
  in_seconds.replace(in_seconds.find("t [ms]"), 6, "t [s]");
  const indicial::Experiment ok = indicial::load_experiment(write("s.toml", in_seconds));
  CHECK_FALSE(any_has(ok.warnings, "but its name says"));
}

TEST_CASE("periodic = true on a record of several cycles is refused, one whole cycle accepted") {
  // 1.1 Hz, 200 samples per period: one period, then 5.3 periods.
  auto record = [](double periods) {
    std::string text = "time_s,alpha_deg,Cm\n";
    const int n = static_cast<int>(periods * 200 + 0.5);
    for (int i = 0; i < n; ++i) {
      const double t = i / (200 * 1.1);
      const double a = 10 + 8 * std::sin(2 * kPi * 1.1 * t);
      text += indicial::format_double(t) + "," + indicial::format_double(a) + "," + indicial::format_double(-0.002 * a) + "\n";
    }
    return text;
  };
  const std::string exp = "axis = \"pitch\"\ncoefficient = \"Cm\"\nreference_length_m = 0.15\nairspeed_mps = 30\n"
                          "runs = [{file = \"rec.csv\", periodic = true, frequency_hz = 1.1}]\n"
                          "[static]\npolynomial = [0.0, -0.1]\n\n[model]\na_degree = 1\n";
  write("rec.csv", record(1.0));
  const indicial::Experiment one = indicial::load_experiment(write("rec.toml", exp));
  CHECK(one.runs[0].periodic);
  CHECK(one.runs[0].frequency_hz == 1.1);  // a time column's frequency is kept (replicate_cycles)
  write("rec.csv", record(5.3));
  const std::string err = load_error("rec.toml", exp);
  CHECK(err.find("rec.toml:5: run 'rec.csv' is declared periodic (one cycle, wrapping from its last sample back to "
                 "its first), but the angle jumps from") != std::string::npos);
  CHECK(err.find("at 1.1 Hz it holds 5.3 cycles: not one whole cycle") != std::string::npos);
  // Without `periodic`, the record of several cycles is an ordinary run.
  std::string plain = exp;
  plain.replace(plain.find("periodic = true, "), 17, "");
  CHECK_FALSE(indicial::load_experiment(write("rec.toml", plain)).runs[0].periodic);
}

TEST_CASE("a chord force positive aft is mapped with a minus, and uppercase CN / CC draw the right advice") {
  // The same cycle as a facility writes it: `CN`, and the chord force `CC` positive aft (-Ct).
  Cycle c = database_cycle();
  const Cycle original = c;
  for (double& ct : c.ct) ct = -ct;
  write("cycle.dat", database_text(c, "% Time() Angle(deg) CN CC Cm"));
  // Unmapped: the advice names the file's columns and the minus, not `CL = "CN"`.
  const std::string err = load_error("aft.toml", experiment("CL", "[columns]\nphase_rad = \"Time()\"\nalpha_deg = \"Angle(deg)\"\n"));
  CHECK(err.find("this file's 'CN' and 'CC' look like the normal- and chord-force coefficients: map them: "
                 "[columns] Cnormal = \"CN\" and Ctangential = \"CC\"") != std::string::npos);
  CHECK(err.find("Ctangential = \"-CC\"") != std::string::npos);
  CHECK(err.find("CL = \"CN\"") == std::string::npos);
  // Mapped with the minus: the same CL as from the database's own convention.
  const indicial::Experiment e = indicial::load_experiment(write(
      "aft.toml", experiment("CL", "[columns]\nphase_rad = \"Time()\"\nalpha_deg = \"Angle(deg)\"\nCnormal = \"CN\"\n"
                                   "Ctangential = \"-CC\"\n")));
  for (int k = 0; k < 128; k += 9) {
    const double a = original.alpha_deg[k] * kPi / 180;
    CHECK(e.runs[0].coefficient[k] == doctest::Approx(original.cn[k] * std::cos(a) + original.ct[k] * std::sin(a)).epsilon(1e-14));
  }
  CHECK(any_has(e.notes, "column 'CC' read with its sign flipped as Ctangential ([columns] Ctangential = \"-CC\")"));
  // A bad cell names the file's column, then ours.
  std::string text = database_text(c, "% Time() Angle(deg) CN CC Cm");
  text.replace(text.find('\n', text.find('\n') + 1) + 1, 4, "x.xx");
  write("cycle.dat", text);
  const std::string cell = load_error("aft.toml", experiment("CL", "[columns]\nphase_rad = \"Time()\"\nalpha_deg = \"Angle(deg)\"\n"
                                                                  "Cnormal = \"CN\"\nCtangential = \"-CC\"\n"));
  CHECK(cell.find("column 'Time()' (read as phase_rad)") != std::string::npos);
}

TEST_CASE("a phase column printed at exact half units is uniform at every frequency") {
  // Bin centres (k + 1/2) 360 / 128 deg printed with 4 decimals: 1.40625 -> "1.4062", 4.21875 ->
  // "4.2188": each value sits exactly half a unit from the truth. Read as uniform at some
  // frequencies and not at others, since the grid was anchored at the first (rounded) value.
  std::string text = "phase_deg,alpha_deg,Cm\n";
  for (int k = 0; k < 128; ++k) {
    char row[96];
    const double phase = (k + 0.5) * 360.0 / 128;
    std::snprintf(row, sizeof row, "%.4f,%.6f,%.6f\n", phase, 10 + 8 * std::sin(phase * kPi / 180),
                  -0.01 * std::sin(phase * kPi / 180));
    text += row;
  }
  const std::string path = write("half_units.csv", text);
  for (double f : {1.341146, 2.422975, 3.0, 3.721043, 1.0}) {
    CAPTURE(f);
    indicial::RunCsvOptions o;
    o.frequency_hz = f;
    o.frequency_source = indicial::FrequencySource::command_line;
    const indicial::Run r = indicial::read_run_csv(path, indicial::Axis::pitch, "Cm", indicial::CoefficientPresence::required, o);
    CHECK(r.time_grid == indicial::TimeGrid::uniform);
    CHECK(r.time_s[1] - r.time_s[0] == doctest::Approx(1.0 / (128 * f)).epsilon(1e-12));
  }
}

// The database's "Time()" is the cycle's phase in rad: a missing time column whose nearest name
// holds one cycle's phase (0 to 2 pi, non-decreasing) is advised as phase_rad, with the
// frequency it needs; a real time column of that name is still advised as time_s.
TEST_CASE("a missing time column whose nearest name holds a phase is advised as phase_rad") {
  write("cycle.dat", database_text(database_cycle()));
  const char* unmapped_phase = "[columns]\nalpha_deg = \"Angle(deg)\"\nCnormal = \"Cn\"\nCtangential = \"Ct\"\n";
  const std::string m = load_error("no_phase.toml", experiment("CL", unmapped_phase));
  CHECK_HAS(m, "cycle.dat:1: missing column 'time_s' (or 'phase_rad' / 'phase_deg' / 'phase_cycles')");
  CHECK_HAS(m, "'Time()' runs from 0 to 2 pi: if it is the cycle's phase in rad, map it in the experiment: "
               "[columns] phase_rad = \"Time()\"");
  CHECK(m.find("time_s = \"Time()\"") == std::string::npos);
  // Times of 0 to 0.5 s under the same name: a time column, advised as such.
  std::string timed = "% Time() Angle(deg) Cn Ct Cm\n";
  for (int k = 0; k < 50; ++k) timed += std::to_string(0.01 * k) + " 5 0.5 0.01 -0.01\n";
  write("cycle.dat", timed);
  const std::string t = load_error("no_time.toml", experiment("CL", unmapped_phase));
  CHECK_HAS(t, "did you mean 'Time()'? (rename it, or map it in the experiment: [columns] time_s = \"Time()\")");
  CHECK(t.find("phase_rad = \"Time()\"") == std::string::npos);
}
