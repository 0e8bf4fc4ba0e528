// test_mat_file.cpp -- runs from MATLAB .mat files (v5 and v7.3, written here with libmatio):
// the same Run as the CSV of the same numbers, bit for bit, whether the columns are top-level
// variables or the fields of one struct; `indicial predict` on a .mat writes what it writes for
// the CSV; and every kind of missing or mistyped variable is refused naming the variable.
#include <matio.h>

#include <cmath>
#include <cstdio>
#include <doctest/doctest.h>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "cli_test_support.hpp"
#include "indicial/fitter/csv_reader.hpp"
#include "indicial/fitter/error.hpp"
#include "indicial/fitter/experiment.hpp"
#include "indicial/fitter/experiment_toml.hpp"

namespace fs = std::filesystem;
using indicial::testing::run_indicial;
using indicial::testing::slurp;

namespace {

const fs::path& dir() { return indicial::testing::scratch_directory("mat"); }

struct Column {
  std::string name;
  std::vector<double> values;
};

// A pitch run: 200 samples at 100 Hz, alpha in degrees, q in deg/s, Cm.
std::vector<Column> run_columns() {
  std::vector<Column> c = {{"time_s", {}}, {"alpha_deg", {}}, {"q_degps", {}}, {"Cm", {}}};
  for (int i = 0; i < 200; ++i) {
    const double t = 0.01 * i;
    c[0].values.push_back(t);
    c[1].values.push_back(10.0 + 8.0 * std::sin(2.0 * M_PI * 1.1 * t));
    c[2].values.push_back(8.0 * 2.0 * M_PI * 1.1 * std::cos(2.0 * M_PI * 1.1 * t));
    c[3].values.push_back(0.01 * std::sin(2.0 * M_PI * 1.1 * t - 0.3));
  }
  return c;
}

void write_csv(const std::vector<Column>& cols, const fs::path& p) {
  std::ofstream f(p);
  for (std::size_t k = 0; k < cols.size(); ++k) f << (k ? "," : "") << cols[k].name;
  f << "\n";
  char cell[40];
  for (std::size_t i = 0; i < cols[0].values.size(); ++i) {
    for (std::size_t k = 0; k < cols.size(); ++k) {
      std::snprintf(cell, sizeof cell, "%.17g", cols[k].values[i]);
      f << (k ? "," : "") << cell;
    }
    f << "\n";
  }
}

matvar_t* vector_var(const char* name, const std::vector<double>& v, bool row) {
  std::size_t dims[2] = {row ? 1 : v.size(), row ? v.size() : 1};
  return Mat_VarCreate(name, MAT_C_DOUBLE, MAT_T_DOUBLE, 2, dims, const_cast<double*>(v.data()), 0);
}

enum class Layout { variables, one_struct };

void write_mat(const std::vector<Column>& cols, const fs::path& p, mat_ft version, Layout layout) {
  mat_t* m = Mat_CreateVer(p.c_str(), nullptr, version);
  REQUIRE(m != nullptr);
  if (layout == Layout::variables) {
    for (std::size_t k = 0; k < cols.size(); ++k) {
      matvar_t* v = vector_var(cols[k].name.c_str(), cols[k].values, k % 2 == 1);  // rows and columns
      REQUIRE(Mat_VarWrite(m, v, MAT_COMPRESSION_NONE) == 0);
      Mat_VarFree(v);
    }
  } else {
    std::vector<const char*> names;
    for (const Column& c : cols) names.push_back(c.name.c_str());
    std::size_t dims[2] = {1, 1};
    matvar_t* s = Mat_VarCreateStruct("run", 2, dims, names.data(), static_cast<unsigned>(names.size()));
    for (const Column& c : cols) Mat_VarSetStructFieldByName(s, c.name.c_str(), 0, vector_var(nullptr, c.values, false));
    REQUIRE(Mat_VarWrite(m, s, MAT_COMPRESSION_NONE) == 0);
    Mat_VarFree(s);
  }
  Mat_Close(m);
}

indicial::Run read(const fs::path& p) {
  return indicial::read_run_csv(p.string(), indicial::Axis::pitch, "Cm", indicial::CoefficientPresence::required);
}

std::string refusal(const fs::path& p) {
  try {
    (void)read(p);
  } catch (const indicial::InputError& e) {
    return e.what();
  }
  return "(no error)";
}

}  // namespace

TEST_CASE("mat: v5 and v7.3, variables or one struct, give the CSV's run bit for bit") {
  const auto cols = run_columns();
  write_csv(cols, dir() / "run.csv");
  const indicial::Run csv = read(dir() / "run.csv");
  struct Case {
    const char* file;
    mat_ft version;
    Layout layout;
  };
  for (const Case& c : {Case{"v5.mat", MAT_FT_MAT5, Layout::variables}, Case{"v73.mat", MAT_FT_MAT73, Layout::variables},
                        Case{"v5-struct.mat", MAT_FT_MAT5, Layout::one_struct},
                        Case{"v73-struct.MAT", MAT_FT_MAT73, Layout::one_struct}}) {
    INFO(c.file);
    write_mat(cols, dir() / c.file, c.version, c.layout);
    const indicial::Run mat = read(dir() / c.file);
    CHECK(mat.time_s == csv.time_s);
    CHECK(mat.motion_angle_rad == csv.motion_angle_rad);
    CHECK(mat.rate_radps == csv.rate_radps);
    CHECK(mat.rate_from_file);
    CHECK(mat.coefficient == csv.coefficient);
    CHECK(mat.time_grid == csv.time_grid);
  }
}

TEST_CASE("mat: an experiment (what fit and diagnose load) takes .mat runs as it takes CSVs") {
  const auto cols = run_columns();
  write_csv(cols, dir() / "e.csv");
  write_mat(cols, dir() / "e.mat", MAT_FT_MAT73, Layout::one_struct);
  auto experiment = [](const std::string& run) {
    const fs::path p = dir() / ("experiment-" + run + ".toml");
    std::ofstream(p) << "axis = \"pitch\"\ncoefficient = \"Cm\"\nreference_length_m = 0.3765\n"
                        "airspeed_mps = 17.667762\nruns = [\"" << run << "\"]\n[static]\n"
                        "polynomial = [0.0, 0.42]\n";
    return indicial::load_experiment(p.string());
  };
  const indicial::Experiment from_csv = experiment("e.csv");
  const indicial::Experiment from_mat = experiment("e.mat");
  REQUIRE(from_mat.runs.size() == 1);
  CHECK(from_mat.runs[0].time_s == from_csv.runs[0].time_s);
  CHECK(from_mat.runs[0].motion_angle_rad == from_csv.runs[0].motion_angle_rad);
  CHECK(from_mat.runs[0].rate_radps == from_csv.runs[0].rate_radps);
  CHECK(from_mat.runs[0].coefficient == from_csv.runs[0].coefficient);
}

TEST_CASE("mat: indicial predict on a .mat writes what it writes for the CSV") {
  const auto cols = run_columns();
  write_csv(cols, dir() / "p.csv");
  write_mat(cols, dir() / "p.mat", MAT_FT_MAT73, Layout::variables);
  const std::string model = std::string(INDICIAL_SOURCE_DIR) + "/examples/synthetic-lift-moment.coef";
  auto a = run_indicial("predict '" + model + "' '" + (dir() / "p.csv").string() + "' --out '" +
                            (dir() / "from-csv.csv").string() + "'", dir());
  auto b = run_indicial("predict '" + model + "' '" + (dir() / "p.mat").string() + "' --out '" +
                            (dir() / "from-mat.csv").string() + "'", dir());
  REQUIRE_MESSAGE(a.exit_code == 0, a.err);
  REQUIRE_MESSAGE(b.exit_code == 0, b.err);
  // The comment lines name the input file; the numbers must be identical.
  auto numbers = [](const std::string& text) {
    std::string out;
    std::size_t start = 0;
    while (start < text.size()) {
      const std::size_t end = text.find('\n', start);
      const std::string line = text.substr(start, end - start);
      if (!line.empty() && line[0] != '#') out += line + "\n";
      start = end == std::string::npos ? text.size() : end + 1;
    }
    return out;
  };
  CHECK(numbers(slurp(dir() / "from-mat.csv")) == numbers(slurp(dir() / "from-csv.csv")));
  CHECK(numbers(slurp(dir() / "from-mat.csv")).size() > 1000);
}

TEST_CASE("mat: missing and mistyped variables are refused naming the variable") {
  auto cols = run_columns();
  // Missing: no angle.
  std::vector<Column> no_angle = {cols[0], cols[2], cols[3]};
  write_mat(no_angle, dir() / "no-angle.mat", MAT_FT_MAT5, Layout::variables);
  CHECK(refusal(dir() / "no-angle.mat").find("missing column 'alpha_deg' or 'alpha_rad'") != std::string::npos);
  CHECK(refusal(dir() / "no-angle.mat").find("columns found: time_s, q_degps, Cm") != std::string::npos);

  // Mistyped: the angle as a matrix, the rate complex, the coefficient a string.
  auto write_with = [&](const fs::path& p, matvar_t* odd, mat_ft version) {
    mat_t* m = Mat_CreateVer(p.c_str(), nullptr, version);
    for (const Column& c : cols) {
      if (c.name == odd->name) continue;
      matvar_t* v = vector_var(c.name.c_str(), c.values, false);
      Mat_VarWrite(m, v, MAT_COMPRESSION_NONE);
      Mat_VarFree(v);
    }
    Mat_VarWrite(m, odd, MAT_COMPRESSION_NONE);
    Mat_VarFree(odd);
    Mat_Close(m);
  };
  std::vector<double> two(400, 1.0);
  std::size_t matrix_dims[2] = {200, 2};
  write_with(dir() / "matrix.mat", Mat_VarCreate("alpha_deg", MAT_C_DOUBLE, MAT_T_DOUBLE, 2, matrix_dims, two.data(), 0),
             MAT_FT_MAT73);
  CHECK(refusal(dir() / "matrix.mat").find("variable alpha_deg (200x2) is a matrix") != std::string::npos);
  double re[200] = {}, im[200] = {};
  mat_complex_split_t z = {re, im};
  std::size_t vec_dims[2] = {200, 1};
  write_with(dir() / "complex.mat",
             Mat_VarCreate("q_degps", MAT_C_DOUBLE, MAT_T_DOUBLE, 2, vec_dims, &z, MAT_F_COMPLEX), MAT_FT_MAT5);
  CHECK(refusal(dir() / "complex.mat").find("variable q_degps (200x1) is complex") != std::string::npos);
  char text[] = "not numbers";
  std::size_t text_dims[2] = {1, sizeof text - 1};
  write_with(dir() / "char.mat", Mat_VarCreate("Cm", MAT_C_CHAR, MAT_T_UTF8, 2, text_dims, text, 0), MAT_FT_MAT5);
  CHECK(refusal(dir() / "char.mat").find("variable Cm (1x11) is a char array") != std::string::npos);
  // A coefficient of another length than time_s.
  std::vector<double> short_cm(150, 0.0);
  write_with(dir() / "short.mat", vector_var("Cm", short_cm, false), MAT_FT_MAT5);
  CHECK(refusal(dir() / "short.mat").find("Cm has 150 samples, time_s has 200") != std::string::npos);

  // Variables that are not columns indicial reads are ignored, with a note.
  char note_text[] = "entry 42, run 3";
  std::size_t note_dims[2] = {1, sizeof note_text - 1};
  write_with(dir() / "extra.mat", Mat_VarCreate("description", MAT_C_CHAR, MAT_T_UTF8, 2, note_dims, note_text, 0),
             MAT_FT_MAT5);
  const indicial::Run extra = read(dir() / "extra.mat");
  bool noted = false;
  for (const std::string& n : extra.notes) noted = noted || n.find("description") != std::string::npos;
  CHECK(noted);

  // Not a MAT-file, a struct array, two structs.
  std::ofstream(dir() / "fake.mat") << "time_s,alpha_deg\n0,1\n";
  CHECK(refusal(dir() / "fake.mat").find("cannot open as a MAT-file") != std::string::npos);
  {
    mat_t* m = Mat_CreateVer((dir() / "two-structs.mat").c_str(), nullptr, MAT_FT_MAT5);
    for (const char* name : {"run_a", "run_b"}) {
      const char* fields[1] = {"time_s"};
      std::size_t one[2] = {1, 1};
      matvar_t* s = Mat_VarCreateStruct(name, 2, one, fields, 1);
      Mat_VarSetStructFieldByName(s, "time_s", 0, vector_var(nullptr, cols[0].values, false));
      Mat_VarWrite(m, s, MAT_COMPRESSION_NONE);
      Mat_VarFree(s);
    }
    Mat_Close(m);
  }
  CHECK(refusal(dir() / "two-structs.mat").find("several structs (run_a, run_b)") != std::string::npos);
}
