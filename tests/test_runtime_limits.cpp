// Never write a model the runtime refuses (issue 12 item 1): the runtime's own validation on a
// fitted model before any command writes it, input-time capacity warnings, and the ways it
// happened in the issue (fit/diagnose exiting 0 with b_j(x) <= 0; predict naming "model").
#include <doctest/doctest.h>

#include <filesystem>
#include <fstream>
#include <random>

#include "cli_test_support.hpp"
#include "indicial/fitter/dynamic_stall.hpp"
#include "indicial/fitter/error.hpp"
#include "indicial/fitter/io.hpp"
#include "indicial/fitter/runtime_limits.hpp"
#include "indicial/runtime.hpp"
#include "test_support.hpp"

TEST_SUITE_BEGIN("cli");  // the ctest label (tests/CMakeLists.txt)

namespace fs = std::filesystem;
namespace ds = indicial::dynamic_stall;

namespace {

using indicial::testing::kPi;

// Model I with b1(x) = 2.5 - 4 x: negative above 0.625 rad, inside the 0..70 deg envelope.
indicial::TruthModel unstable_model() {
  indicial::TruthModel m = indicial::find_simulation_case("tailless-model-1").truth;
  auto& b = m.coefficients[0].lags[0].b;
  b.n_powers = 2;
  b.power_coef[1] = -4.0;
  return m;
}

// A fresh directory per tag under this process's scratch directory (removed at exit).
fs::path fresh_dir(const std::string& tag) {
  const fs::path d = indicial::testing::scratch_directory("runtime-limits") / tag;
  fs::create_directories(d);
  return d;
}

// The dynamic-stall Cm fit cycles at SNR 5 (seed 1) as time-column CSVs with a b1(x) of
// degree 3: the angle-dependent b1 with which, before the constrained fit, the output-error fit
// ended with b1(x) <= 0 inside the envelope (measured with `indicial validate-realistic --snr 5
// --b1-degree 3`).
fs::path write_weak_b1_experiment(const fs::path& dir) {
  const ds::Campaign& c = ds::default_campaign();
  const auto cycles = ds::simulate_campaign(c, 5.0, 1, c.default_noise);
  indicial::Experiment e = ds::campaign_experiment(c, cycles, "Cm", ds::CycleRole::fit);
  e.model.b1 = indicial::SplineConfig{{0, 1, 2, 3}, {}, 1};
  e.static_curve.table_path = "static.csv";
  for (const indicial::Run& r : e.runs) {
    std::vector<double> deg = r.motion_angle_rad, degps = r.rate_radps;
    for (double& v : deg) v *= 180.0 / kPi;
    for (double& v : degps) v *= 180.0 / kPi;
    std::ofstream(dir / r.path) << indicial::write_run_csv(
        {{"time_s", r.time_s}, {"alpha_deg", deg}, {"q_degps", degps}, {"Cm", r.coefficient}}, {});
  }
  std::vector<double> sdeg = e.static_curve.table_x_rad;
  for (double& v : sdeg) v *= 180.0 / kPi;
  std::ofstream(dir / "static.csv") << indicial::write_run_csv({{"alpha_deg", sdeg}, {"Cm", e.static_curve.table_value}}, {});
  std::ofstream(dir / "experiment.toml") << indicial::write_experiment_toml(e, {});
  return dir / "experiment.toml";
}

// The invariant of the issue: a model.coef a command wrote is one the runtime loads (whatever
// the exit status: diagnose's 6, fit's 4 and 5 write outputs too), exit 0 always comes with one,
// and a command that refused the model wrote nothing and said why in one line.
void check_never_refused(const indicial::testing::CliRun& r, const fs::path& out) {
  INFO("exit " << r.exit_code << "; stderr: " << r.err);
  if (fs::exists(out / "model.coef")) {
    const std::string text = indicial::testing::slurp(out / "model.coef");
    auto p = std::make_unique<indicial::Predictor<double, indicial::FitCapacity>>();
    CHECK(p->load(text.data(), text.size()) == indicial::LoadStatus::ok);
  } else {
    CHECK(r.exit_code != 0);
    CHECK(r.err.find((out / "model.coef").string() + ": not written: the runtime refuses the model") != std::string::npos);
  }
}

}  // namespace

TEST_CASE("runtime limits: a model with b1(x) <= 0 in the envelope is refused, naming the file") {
  const indicial::RuntimeAcceptance a = indicial::runtime_acceptance(unstable_model());
  CHECK(a.capacity == indicial::RuntimeCapacity::refused);
  CHECK(a.status == indicial::LoadStatus::unstable_lag);
  try {
    indicial::require_runtime_accepts(unstable_model(), "out/model.coef", indicial::ModelFile::to_write);
    FAIL("not refused");
  } catch (const indicial::InputError& e) {
    const std::string m = e.what();
    CHECK(m.rfind("out/model.coef: not written: the runtime refuses the model: b_j(x) <= 0", 0) == 0);
    CHECK(m.find("unstable_lag") != std::string::npos);
  }
  const indicial::TruthModel good = indicial::find_simulation_case("tailless-model-2").truth;
  CHECK(indicial::runtime_acceptance(good).capacity == indicial::RuntimeCapacity::default_capacity);
}

TEST_CASE("runtime limits: the feasibility predicate is the runtime's b_j(x) > 0 check") {
  const indicial::TruthModel bad = unstable_model();
  const auto& cb = bad.coefficients[0];
  // b1 = 2.5 - 4 x on [0, 70 deg]: the minimum at the upper end.
  CHECK(indicial::min_lag_decay(cb, 0, bad.x_min_rad, bad.x_max_rad) ==
        doctest::Approx(2.5 - 4.0 * bad.x_max_rad));
  CHECK_FALSE(indicial::lag_decay_positive(cb, bad.x_min_rad, bad.x_max_rad));
  // ...and feasible on a smaller envelope, where the runtime accepts it too.
  indicial::TruthModel shrunk = bad;
  shrunk.x_max_rad = 0.6;
  CHECK(indicial::lag_decay_positive(shrunk.coefficients[0], 0.0, 0.6));
  CHECK(indicial::runtime_acceptance(shrunk).capacity != indicial::RuntimeCapacity::refused);
  // Model II: b1 = 2.5 - 5.73 (x - 0.349)_+ + 5.73 (x - 0.5236)_+ + ...: minimum 2.5 - 5.73 * 0.1746.
  const indicial::TruthModel m2 = indicial::find_simulation_case("tailless-model-2").truth;
  CHECK(indicial::min_lag_decay(m2.coefficients[0], 0, m2.x_min_rad, m2.x_max_rad) ==
        doctest::Approx(2.5 - 5.73 * (0.5236 - 0.349)).epsilon(1e-9));
  // A NaN coefficient is infeasible.
  indicial::TruthModel nan_model = m2;
  nan_model.coefficients[0].lags[0].b.power_coef[0] = std::nan("");
  CHECK_FALSE(indicial::lag_decay_positive(nan_model.coefficients[0], 0.0, 1.0));
}

TEST_CASE("runtime limits: a 70-row static table fits only the fitter's capacity") {
  indicial::TruthModel m = indicial::find_simulation_case("tailless-model-1").truth;
  auto& s = m.coefficients[0].static_curve;
  s.kind = indicial::StaticKind::table;
  s.polynomial.n_powers = 0;
  s.n_table = 70;
  for (int i = 0; i < 70; ++i) {
    s.table_x_rad[i] = i * (70.0 / 69.0) * kPi / 180.0;
    s.table_value[i] = 0.01 * i;
  }
  const indicial::RuntimeAcceptance a = indicial::runtime_acceptance(m);
  CHECK(a.capacity == indicial::RuntimeCapacity::fit_capacity_only);
  CHECK(a.reason.find("FitCapacity") != std::string::npos);

}

TEST_CASE("runtime limits: predict with a refused model names the file, not 'model'") {
  const fs::path dir = fresh_dir("predict");
  std::ofstream(dir / "bad.coef") << indicial::truth_coef_text(unstable_model());
  std::ofstream(dir / "run.csv") << "time_s,alpha_deg\n0,10\n0.01,10.1\n0.02,10.2\n0.03,10.3\n0.04,10.4\n0.05,10.5\n"
                                    "0.06,10.6\n0.07,10.7\n0.08,10.8\n0.09,10.9\n0.1,11\n";
  const auto r = indicial::testing::run_indicial(
      "predict '" + (dir / "bad.coef").string() + "' '" + (dir / "run.csv").string() + "' --out '" +
          (dir / "p.csv").string() + "'", dir);
  CHECK(r.exit_code == 1);
  CHECK(r.err.find("indicial: error: " + (dir / "bad.coef").string() + ": the runtime refuses the model: b_j(x) <= 0") == 0);
  CHECK(r.err.find("unstable_lag") != std::string::npos);
  CHECK(!fs::exists(dir / "p.csv"));
  fs::remove_all(dir);
}

TEST_CASE("runtime limits: fit and diagnose never exit 0 with a model the runtime refuses") {
  const fs::path dir = fresh_dir("fit");
  const fs::path toml = write_weak_b1_experiment(dir);
  const auto fit = indicial::testing::run_indicial(
      "fit '" + toml.string() + "' --no-plots --out '" + (dir / "fit").string() + "'", dir);
  check_never_refused(fit, dir / "fit");
  MESSAGE("fit: exit " << fit.exit_code << ": " << fit.err);
  const auto diag = indicial::testing::run_indicial(
      "diagnose '" + toml.string() + "' --no-plots --max-steps 1 --out '" + (dir / "diag").string() + "'", dir);
  check_never_refused(diag, dir / "diag");
  fs::remove_all(dir);
}
