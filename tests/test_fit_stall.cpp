// The dynamic-stall families' inputs and the start grid, cheaply (the sanitizer build runs
// this file): the experiment file's stall keys, the grid's points, and one default fit on a few
// cycles of the seeded odeint truth (stall_truth_data.hpp) through the runtime. The recovery
// within 3 bounds, the reattachment time constant, held parameters and what the grid reaches
// are test_fit_stall_recovery.cpp's.
#include <doctest/doctest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "estimate/fit_internal.hpp"
#include "indicial/fitter/error.hpp"
#include "indicial/fitter/experiment_toml.hpp"
#include "indicial/fitter/fit.hpp"
#include "indicial/fitter/model_merge.hpp"
#include "indicial/fitter/report.hpp"
#include "indicial/model.hpp"
#include "stall_truth_data.hpp"

TEST_SUITE_BEGIN("unit");  // the ctest label (tests/CMakeLists.txt)

using namespace indicial;
using namespace indicial::testing;

// The stall start grid scales T1r with T1, so that each of its points with T1r starts as the
// symmetric model of the same point (fit_stall_starts.cpp).
TEST_CASE("the stall start grid moves T1r with T1") {
  fit_detail::UnsteadyStructure s;
  s.stall.families = StallFamilies::separation_and_vortex;
  s.stall.reattachment = StallReattachment::estimated;
  const fit_detail::ParameterLayout L(s, {});
  ParamId t1, t1r;
  t1.kind = ParamKind::stall_tau1;
  t1r.kind = ParamKind::stall_tau1_reattach;
  const int i1 = L.find(t1), ir = L.find(t1r);
  REQUIRE(i1 >= 0);
  REQUIRE(ir >= 0);
  const Eigen::VectorXd theta0 = Eigen::VectorXd::LinSpaced(L.size(), 1.0, 2.0);
  const auto grid = fit_detail::stall_start_grid(L, theta0);
  CHECK(grid.size() == 18);
  int t1_moved = 0;
  for (const auto& pt : grid) {
    CHECK(pt.theta(ir) / theta0(ir) == doctest::Approx(pt.theta(i1) / theta0(i1)));
    t1_moved += pt.theta(i1) != theta0(i1);
  }
  CHECK(t1_moved == 12);
}

// The experiment file's stall keys: read, defaults, refusals, and written back.
TEST_CASE("experiment stall keys are read, refused without stall, and written back") {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "indicial-test-fit-stall";
  std::filesystem::create_directories(dir);
  {
    std::ofstream s(dir / "static.csv");
    s << "alpha_deg,CL\n";
    for (int a = -10; a <= 30; ++a) s << a << "," << polar_lift(a * kDeg) << "\n";
    std::ofstream r(dir / "run.csv");
    r << "time_s,alpha_deg,CL\n";
    for (int i = 0; i < 64; ++i) {
      const double a = 12.0 + 8.0 * std::sin(2 * kPi * i / 64.0);
      r << i * 0.01 << "," << a << "," << polar_lift(a * kDeg) << "\n";
    }
  }
  auto write_toml = [&](const std::string& model) {
    std::ofstream t(dir / "e.toml");
    t << "axis = \"pitch\"\ncoefficient = \"CL\"\nreference_length_m = 0.275\nairspeed_mps = 30.0\n"
         "runs = [\"run.csv\"]\n[static]\ntable = \"static.csv\"\n[rotary]\npolynomial = [0.0]\n[model]\n"
      << model;
  };
  write_toml("stall = \"separation_and_vortex\"\nstall_T1_start = 2.5\nstall_f0_correction_degree = 1\n");
  const Experiment e = load_experiment((dir / "e.toml").string());
  CHECK(e.model.stall.families == StallFamilies::separation_and_vortex);
  CHECK(e.model.stall.tau1_start == 2.5);
  CHECK(e.model.stall.polar_column == "CL");
  CHECK(e.model.stall.polar_x_rad.size() == 41);  // the [static] table: it models CL
  CHECK(e.model.stall.f0_correction.powers == std::vector<int>{0, 1});
  const std::string back = write_experiment_toml(e, {});
  CHECK(back.find("stall = \"separation_and_vortex\"") != std::string::npos);
  CHECK(back.find("stall_T1_start = 2.5") != std::string::npos);
  CHECK(back.find("stall_f0_correction_degree = 1") != std::string::npos);
  // A stall key without stall, and an unknown family, are refused with the file and line.
  write_toml("stall_T1_start = 2.5\n");
  CHECK_THROWS_WITH_AS(load_experiment((dir / "e.toml").string()),
                       doctest::Contains("is used only with model.stall"), InputError);
  write_toml("stall = \"vortex\"\n");
  CHECK_THROWS_AS(load_experiment((dir / "e.toml").string()), InputError);
  // model.stall_known: read in order, written back; a vortex name without the vortex, an
  // unknown name, a value outside the feasible set and a start value for a held parameter are
  // refused with the file and line.
  write_toml("stall = \"separation_and_vortex\"\nstall_known = { T1 = 3.25, T2 = 0.0, xv = -0.1 }\n");
  const Experiment k = load_experiment((dir / "e.toml").string());
  REQUIRE(k.model.stall.known.size() == 3);
  CHECK(k.model.stall.known[0] == std::pair<std::string, double>("T1", 3.25));
  CHECK(k.model.stall.known[2] == std::pair<std::string, double>("xv", -0.1));
  const std::string known_back = write_experiment_toml(k, {});
  CHECK(known_back.find("stall_known = { T1 = 3.25, T2 = 0, xv = -0.1 }") != std::string::npos);
  // Written back without start values for the held T1 and T2 (the reader refuses both together),
  // so the written file reads back (diagnose writes its experiment.toml this way).
  CHECK(known_back.find("stall_T1_start") == std::string::npos);
  CHECK(known_back.find("stall_T2_start") == std::string::npos);
  CHECK(known_back.find("stall_Tv_start = 6") != std::string::npos);
  {
    std::ofstream t(dir / "back.toml");
    t << known_back;
  }
  CHECK(load_experiment((dir / "back.toml").string()).model.stall.known == k.model.stall.known);
  // stall_reattachment = "estimated" (T1r): read, its start and a held value, written back.
  write_toml("stall = \"separation\"\nstall_reattachment = \"estimated\"\nstall_T1r_start = 8.5\n");
  const Experiment r = load_experiment((dir / "e.toml").string());
  CHECK(r.model.stall.reattachment == StallReattachment::estimated);
  CHECK(r.model.stall.tau1_reattach_start == 8.5);
  const std::string r_back = write_experiment_toml(r, {});
  CHECK(r_back.find("stall_reattachment = \"estimated\"") != std::string::npos);
  CHECK(r_back.find("stall_T1r_start = 8.5") != std::string::npos);
  CHECK(known_back.find("stall_reattachment") == std::string::npos);  // the default is not written
  CHECK(known_back.find("stall_T1r_start") == std::string::npos);     // (it would be refused)
  // stall_forcing_lag (model.hpp's ForcingLag): read, written back when not the default.
  CHECK(r.model.stall.forcing_lag == ForcingLag::delay);
  CHECK(r_back.find("stall_forcing_lag") == std::string::npos);
  write_toml("stall = \"separation\"\nstall_forcing_lag = \"first_order\"\n");
  const Experiment fo = load_experiment((dir / "e.toml").string());
  CHECK(fo.model.stall.forcing_lag == ForcingLag::first_order);
  CHECK(write_experiment_toml(fo, {}).find("stall_forcing_lag = \"first_order\"\n") != std::string::npos);
  write_toml("stall = \"separation\"\nstall_reattachment = \"estimated\"\nstall_known = { T1r = 9.0 }\n");
  CHECK(load_experiment((dir / "e.toml").string()).model.stall.known[0] == std::pair<std::string, double>("T1r", 9.0));
  const struct { const char* model; const char* message; } bad[] = {
      {"stall = \"separation\"\nstall_known = { Tv = 5.0 }\n", "e.toml:12: 'model.stall_known.Tv' is a vortex parameter"},
      {"stall = \"separation\"\nstall_known = { tau1 = 5.0 }\n", "names 'tau1', not a dynamic-stall parameter"},
      {"stall = \"separation\"\nstall_known = { T1 = 0.0 }\n", "'model.stall_known.T1' must be > 0"},
      {"stall = \"separation\"\nstall_known = { T2 = -1.0 }\n", "'model.stall_known.T2' must be >= 0"},
      {"stall = \"separation\"\nstall_T1_start = 2.0\nstall_known = { T1 = 3.0 }\n", "drop one of the two"},
      {"stall_known = { T1 = 3.0 }\n", "is used only with model.stall"},
      {"stall = \"separation\"\nstall_known = { T1r = 9.0 }\n", "it needs model.stall_reattachment = \"estimated\""},
      {"stall = \"separation\"\nstall_T1r_start = 9.0\n", "'model.stall_T1r_start' is used only with"},
      {"stall = \"separation\"\nstall_reattachment = \"slow\"\n", "model.stall_reattachment"},
      {"stall_reattachment = \"estimated\"\n", "is used only with model.stall"},
      {"stall = \"separation\"\nstall_forcing_lag = \"filter\"\n", "model.stall_forcing_lag"},
      {"stall_forcing_lag = \"first_order\"\n", "is used only with model.stall"}};
  for (const auto& b : bad) {
    CAPTURE(b.model);
    write_toml(b.model);
    CHECK_THROWS_WITH_AS(load_experiment((dir / "e.toml").string()), doctest::Contains(b.message), InputError);
  }
  std::filesystem::remove_all(dir);
}

// The representative that runs under the sanitizers (test_fit_stall_recovery.cpp does not): the
// product's default fit -- the grid of 18 stall starts, fitted on two threads -- on four of the
// truth's cycles at 64 samples, through the coefficient file to the runtime. What it checks is
// structural (the statistics are test_fit_stall_recovery.cpp's): every trial reported, the
// lowest kept and reported, a converged fit inside the runtime's feasible set, and the runtime
// replaying it to 1e-12 with every step ok.
TEST_CASE("fit stall families from the start grid on four cycles: the lowest start kept, replayed by the runtime") {
  TruthDesign small;
  small.airspeeds_mps = {30.0};
  small.means_deg = {10.0, 18.0};
  small.samples_per_cycle = 64;
  const TruthExperiment te = truth_experiment({}, small);
  REQUIRE(te.e.runs.size() == 4);
  FitOptions grid;
  grid.threads = 2;
  const FitResult fit = fit_experiment(te.e, grid);
  MESSAGE("s(v) / sigma " << fit.fit_error / kNoiseSigma << ", start " << fit.stall_start_search.chosen << " kept");
  REQUIRE(fit.stall_start_search.trials.size() == 18);
  for (const StallStartTrial& t : fit.stall_start_search.trials)
    if (std::isfinite(t.fit_error)) CHECK(fit.fit_error <= t.fit_error);
  REQUIRE(fit.stall_start_search.chosen >= 0);  // with the grid a trial is always the one kept
  CHECK(fit.stall_start_search.trials[static_cast<std::size_t>(fit.stall_start_search.chosen)].fit_error ==
        fit.fit_error);
  CHECK(fit.output_error.termination == Termination::converged);
  CHECK(check_stall_parameters(fit.model.coefficients[0].stall) == StallCheck::valid);
  const RuntimeCheck rc = replay_in_runtime(fit, te.e, coef_file_text(fit.model, "stall.coef"));
  CHECK(rc.load_status == LoadStatus::ok);
  CHECK(rc.samples_compared == 4 * 63);
  CHECK(rc.steps_not_ok == 0);
  CHECK(rc.max_abs_difference < 1e-12);
}
