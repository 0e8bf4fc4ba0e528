// The dynamic-stall families identified by output error (issue 22 item 2, validation 5a): a
// truth of this family (stall_truth_data.hpp: the report's lag plus separation and vortex,
// integrated by Boost.Odeint, never by the fitter's advance_stall, parameters drawn from a seed
// fixed before the fitter was first run on it), phase-averaged periodic cycles at two airspeeds
// with white noise; every stall parameter recovered within 3 Cramer-Rao bounds; T1r, dxr, held
// parameters and the start grid's reach on the same truth.
// ctest: skipped under sanitizers -- each case fits 12 cycles, from the 18-start grid in most (15 minutes under ASan); test_fit_stall's four-cycle grid fit runs the same code there
#include <doctest/doctest.h>

#include <cmath>
#include <string>
#include <vector>

#include "indicial/fitter/diagnose.hpp"
#include "indicial/fitter/error.hpp"
#include "indicial/fitter/fit.hpp"
#include "indicial/fitter/model_merge.hpp"
#include "indicial/fitter/report.hpp"
#include "indicial/model.hpp"
#include "stall_truth_data.hpp"

TEST_SUITE_BEGIN("unit");  // the ctest label (tests/CMakeLists.txt)

using namespace indicial;
using namespace indicial::testing;

namespace {

// A family term of its own (sep_reattachment, sep_hysteresis): the fit's coefficient file
// carries its line and the runtime steps it as the fitter; the model fitted without it
// (`without`, on the same cycles) cannot reach the noise and has no such line.
void check_term_written_and_needed(const FitResult& fit, const Experiment& e, const FitResult& without,
                                   const std::string& line_key) {
  const std::string text = coef_file_text(fit.model, "stall.coef");
  CHECK(text.find(line_key + " ") != std::string::npos);
  const RuntimeCheck rc = replay_in_runtime(fit, e, text);
  CHECK(rc.load_status == LoadStatus::ok);
  CHECK(rc.steps_not_ok == 0);
  CHECK(rc.max_abs_difference < 1e-12);
  MESSAGE("s(v): with " << line_key << " " << fit.fit_error << ", without " << without.fit_error);
  CHECK(without.fit_error > 1.2 * kNoiseSigma);
  CHECK(coef_file_text(without.model, "s.coef").find(line_key) == std::string::npos);
}

}  // namespace

TEST_CASE("fit stall families recovers a seeded odeint truth within 3 bounds") {
  TruthExperiment te = truth_experiment();
  Experiment& e = te.e;
  const auto& p = te.t.cm.stall.separation;
  const auto& v = te.t.cm.stall.vortex;
  Truth& t = te.t;
  const double sigma = kNoiseSigma;
  const FitResult fit = fit_experiment(e, FitOptions{});
  MESSAGE("termination " << std::string(termination_name(fit.output_error.termination)) << ", s(v) " << fit.fit_error
                         << ", " << fit.output_error.message);
  CHECK(fit.output_error.termination == Termination::converged);
  const struct { const char* name; double value; } truth[] = {
      {"T1", p.tau1_semichords}, {"T2", p.tau2_semichords}, {"k0", p.cp_k0}, {"k1", p.cp_k1},
      {"k2", p.cp_k2}, {"CN1", v.shedding_threshold}, {"Tv", v.decay_semichords},
      {"Tvl", v.travel_semichords}, {"cv", v.lift_gain}, {"xv", v.cp_travel},
      {"a0", t.cm.a.power_coef[0]}, {"b1_0", t.cm.lags[0].b.power_coef[0]}};
  for (const auto& tr : truth) {
    const ParameterEstimate* est = nullptr;
    for (const auto& q : fit.parameters)
      if (q.name == tr.name) est = &q;
    REQUIRE(est != nullptr);
    MESSAGE(std::string(tr.name) << " = " << est->value << " (" << est->cr_bound << ", colored " << est->cr_bound_colored
                    << "), truth " << tr.value << ": " << (est->value - tr.value) / est->cr_bound << " bounds");
    CHECK(std::isfinite(est->cr_bound));
    CHECK(std::abs(est->value - tr.value) < 3.0 * est->cr_bound);
  }
  // The fit reaches the noise: s(v) within 10% of sigma (a model outside the class would not).
  CHECK(std::abs(fit.fit_error / sigma - 1.0) < 0.1);
  // The written model is the runtime's feasible model with the families.
  CHECK(fit.model.coefficients[0].stall.families == StallFamilies::separation_and_vortex);
  CHECK(check_stall_parameters(fit.model.coefficients[0].stall) == StallCheck::valid);
  // Fitter and runtime agree: model.coef (with the families' keys) replayed by the runtime's
  // Predictor from each cycle's sample-0 states (lags and stall) reproduces the fit's output.
  const RuntimeCheck rc = replay_in_runtime(fit, e, coef_file_text(fit.model, "stall.coef"));
  MESSAGE("runtime replay: " << rc.samples_compared << " samples, max |runtime - fitter| " << rc.max_abs_difference
                             << " " << rc.detail);
  CHECK(rc.load_status == LoadStatus::ok);
  CHECK(rc.samples_compared == 12 * 127);
  CHECK(rc.steps_not_ok == 0);
  CHECK(rc.max_abs_difference < 1e-12);
}

// model.stall_reattachment = "estimated" (model.hpp's T1r): a truth whose flow reattaches 2.5
// times slower than it separates (the factor fixed before the fitter was run on it), the same
// seeded odeint truth otherwise. T1r and T1 are told apart within 3 bounds and the fit reaches
// the noise; the symmetric model (T1 both ways) fitted to the same cycles cannot.
TEST_CASE("fit stall families recovers a reattachment time constant of its own") {
  TruthExperiment te = truth_experiment([](StallModel<double, FitCapacity>& m) {
    m.separation.tau1_reattach_semichords = 2.5 * m.separation.tau1_semichords;
  });
  const auto& p = te.t.cm.stall.separation;
  Experiment e = te.e;
  e.model.stall.reattachment = StallReattachment::estimated;
  FitOptions one_start;  // the configured start (T1r = 3 as T1): one fit, not the grid's 18
  one_start.stall_start_search = StallStartSearch::configured;
  const FitResult fit = fit_experiment(e, one_start);
  CHECK(fit.output_error.termination == Termination::converged);
  const std::vector<TruthValue> truth = {
      {"T1", p.tau1_semichords}, {"T1r", p.tau1_reattach_semichords}, {"T2", p.tau2_semichords}};
  check_within_3_bounds(fit, truth);
  CHECK(std::abs(fit.fit_error / kNoiseSigma - 1.0) < 0.1);
  CHECK(fit.model.coefficients[0].stall.separation.tau1_reattach_semichords > 0.0);
  // One time constant both ways cannot reach the noise on these cycles.
  check_term_written_and_needed(fit, e, fit_experiment(te.e, one_start), "sep_reattachment");
}

// model.stall_hysteresis = "estimated" (model.hpp's dxr): a truth whose flow reattaches only 2.5
// deg below where it separates (fixed before the fitter was run on it), the same seeded odeint
// truth otherwise (stall_derivatives with the band). dxr is recovered within 3 bounds and the
// fit reaches the noise; the model without it fitted to the same cycles cannot; the coefficient
// file carries it (sep_hysteresis) and the runtime steps it as the fitter.
TEST_CASE("fit stall families recovers a static hysteresis") {
  TruthExperiment te = truth_experiment([](StallModel<double, FitCapacity>& m) {
    m.separation.reattach_shift_rad = 2.5 * 3.141592653589793 / 180.0;
  });
  const auto& p = te.t.cm.stall.separation;
  Experiment e = te.e;
  e.model.stall.hysteresis = StallHysteresis::estimated;
  FitOptions one_start;  // the configured start (dxr = 2 deg): one fit, not the grid's
  one_start.stall_start_search = StallStartSearch::configured;
  const FitResult fit = fit_experiment(e, one_start);
  CHECK(fit.output_error.termination == Termination::converged);
  const std::vector<TruthValue> truth = {
      {"T1", p.tau1_semichords}, {"dxr", p.reattach_shift_rad}, {"T2", p.tau2_semichords}};
  check_within_3_bounds(fit, truth);
  CHECK(std::abs(fit.fit_error / kNoiseSigma - 1.0) < 0.1);
  check_term_written_and_needed(fit, e, fit_experiment(te.e, one_start), "sep_hysteresis");
}

// model.stall_known: T1 and T2 held at the truth's values are not estimated (absent from the
// estimates, written to the model exactly as given) and the rest is still recovered within 3
// bounds; held at a wrong value they are still held, and the fit error shows it.
TEST_CASE("fit stall families holds model.stall_known at its values") {
  TruthExperiment te = truth_experiment();
  const auto& p = te.t.cm.stall.separation;
  auto fit_with_known = [&](double t1, double t2) {
    Experiment e = te.e;
    e.model.stall.known = {{"T1", t1}, {"T2", t2}};
    return fit_experiment(e, FitOptions{});
  };
  const FitResult fit = fit_with_known(p.tau1_semichords, p.tau2_semichords);
  CHECK(fit.output_error.termination == Termination::converged);
  const auto& held = fit.model.coefficients[0].stall.separation;
  CHECK(held.tau1_semichords == p.tau1_semichords);  // exactly: held, not estimated
  CHECK(held.tau2_semichords == p.tau2_semichords);
  for (const auto& q : fit.parameters) {
    CAPTURE(q.name);
    CHECK(q.name != "T1");
    CHECK(q.name != "T2");
  }
  const std::vector<TruthValue> truth = {
      {"k0", p.cp_k0}, {"k1", p.cp_k1}, {"k2", p.cp_k2}, {"Tv", te.t.cm.stall.vortex.decay_semichords},
      {"a0", te.t.cm.a.power_coef[0]}};
  check_within_3_bounds(fit, truth);
  CHECK(std::abs(fit.fit_error / kNoiseSigma - 1.0) < 0.1);
  // A start value for a held parameter says so (not "no such parameter").
  {
    Experiment e = te.e;
    e.model.stall.known = {{"T1", 3.0}};
    FitOptions o;
    o.start_values = {{"T1", 2.0}};
    CHECK_THROWS_WITH_AS(fit_experiment(e, o), doctest::Contains("T1: it is held at 3 by model.stall_known"),
                         InputError);
  }
  // Held at twice the truth's T1: still held, and the fit cannot reach the noise.
  const FitResult wrong = fit_with_known(2.0 * p.tau1_semichords, p.tau2_semichords);
  CHECK(wrong.model.coefficients[0].stall.separation.tau1_semichords == 2.0 * p.tau1_semichords);
  MESSAGE("s(v) with T1 held at the truth " << fit.fit_error << ", at twice the truth " << wrong.fit_error);
  CHECK(wrong.fit_error > 1.3 * kNoiseSigma);
}

// The stall start grid (FitOptions::stall_start_search): the same seeded truth with its vortex
// decaying slowly and its separation lagging long (T_v = 14, T1 = 8, l / V units; the
// configured starts are 6 and 3). Measured when this test was written (the same truth with
// other time constants): (T_v, T1) = (14, 8) configured start 8.86 sigma, grid 0.988; (18, 1)
// 7.11 -> 0.987; (18, 8) 2.74 -> 0.988; (14, 1) and (2, 8) reached the noise from the
// configured start already; (2, 1) 11.7 -> 4.02: the grid does not reach every truth.
TEST_CASE("fit stall families from the start grid reaches a truth the configured start misses") {
  const TruthExperiment te = truth_experiment([](StallModel<double, FitCapacity>& m) {
    m.vortex.decay_semichords = 14.0;
    m.separation.tau1_semichords = 8.0;
  });
  // The configured start alone, by maximum likelihood alone (StallPrior::none; with the default
  // prior it stops in the same minimum, 9.69 sigma against 9.67, measured): the local minimum
  // the grid is for.
  FitOptions configured;
  configured.stall_start_search = StallStartSearch::configured;
  configured.stall_prior = StallPrior::none;
  const FitResult one = fit_experiment(te.e, configured);
  FitOptions grid;
  grid.threads = 2;
  const FitResult best = fit_experiment(te.e, grid);
  MESSAGE("s(v) / sigma: configured start " << one.fit_error / kNoiseSigma << ", grid " << best.fit_error / kNoiseSigma
                                            << " (start " << best.stall_start_search.chosen << " kept)");
  // The configured start alone stays in a local minimum (this is what the grid is for) ...
  CHECK(one.stall_start_search.chosen == -1);
  CHECK(one.fit_error > 3.0 * kNoiseSigma);
  // ... the grid ends at the noise, with the truth's time constants within 3 bounds.
  REQUIRE(best.stall_start_search.trials.size() == 18);
  CHECK(best.stall_start_search.trials[0].start.size() == 3);
  CHECK(best.stall_start_search.chosen > 0);
  CHECK(std::abs(best.fit_error / kNoiseSigma - 1.0) < 0.1);
  // The kept fit is the lowest of the trials and the one reported.
  for (const StallStartTrial& t : best.stall_start_search.trials)
    if (std::isfinite(t.fit_error)) CHECK(best.fit_error <= t.fit_error);
  CHECK(best.stall_start_search.trials[static_cast<std::size_t>(best.stall_start_search.chosen)].fit_error ==
        best.fit_error);
  for (const auto& [name, truth] : {std::pair<const char*, double>{"T1", 8.0}, {"Tv", 14.0}})
    for (const ParameterEstimate& p : best.parameters)
      if (p.name == name) {
        MESSAGE(std::string(name) << " = " << p.value << " +- " << p.cr_bound << ", truth " << truth);
        CHECK(std::abs(p.value - truth) < 3.0 * p.cr_bound);
      }
  // A start value the caller gives for a stall parameter is theirs: no grid.
  FitOptions given;
  given.start_values = {{"Tv", 14.0}};
  CHECK(fit_experiment(te.e, given).stall_start_search.chosen == -1);
}

// A configured model WITH stall families is diagnose's base: it is fitted as `indicial fit`
// fits it, from the start grid, whatever DiagnoseOptions::fit says for the candidates (that
// choice is for speed over many candidate fits). A user's trial on digitized C_m cycles found
// the base fitted from the configured start alone: s(v) 0.0536 where `indicial fit` reached
// 0.0391, and diagnose wrote the worse model with verdict none. Here on the truth the
// configured start misses (the test above).
TEST_CASE("fit stall families from the start grid: diagnose fits its configured base the same way") {
  const TruthExperiment te = truth_experiment([](StallModel<double, FitCapacity>& m) {
    m.vortex.decay_semichords = 14.0;
    m.separation.tau1_semichords = 8.0;
  });
  FitOptions grid;
  grid.threads = 2;
  const FitResult best = fit_experiment(te.e, grid);
  DiagnoseOptions o;
  o.threads = 2;
  o.max_steps = 0;  // the base fit alone
  REQUIRE(o.fit.stall_start_search == StallStartSearch::configured);  // the candidates' default
  const DiagnoseResult d = diagnose_experiment(te.e, o);
  MESSAGE("s(v) / sigma: fit " << best.fit_error / kNoiseSigma << ", diagnose's base " << d.initial_fit_error / kNoiseSigma);
  CHECK(best.fit_error < 2.0 * kNoiseSigma);  // the grid reaches the noise; the configured start does not (above)
  CHECK(d.initial_fit_error == doctest::Approx(best.fit_error).epsilon(1e-9));
}

// With T1r estimated the grid has one more start: the symmetric model's best fit (its own grid,
// no T1r) with T1r = its T1 (fit_two_stage.cpp, nested_symmetric_trial). The model with T1r
// nests the symmetric one, so the kept fit cannot end above the symmetric fit; on the Glasgow
// C_m fit cycles the grid alone did (0.0342 against 0.0312). Here on the symmetric truth.
TEST_CASE("fit stall families with T1r never ends above the symmetric fit") {
  const TruthExperiment te = truth_experiment();
  FitOptions grid;
  grid.threads = 2;
  const FitResult symmetric = fit_experiment(te.e, grid);
  Experiment e = te.e;
  e.model.stall.reattachment = StallReattachment::estimated;
  const FitResult nested = fit_experiment(e, grid);
  const auto& trials = nested.stall_start_search.trials;
  REQUIRE(trials.size() == symmetric.stall_start_search.trials.size() + 1);
  for (std::size_t k = 0; k + 1 < trials.size(); ++k) CHECK(trials[k].origin.empty());
  CHECK(trials.back().origin.find("symmetric model's best fit") != std::string::npos);
  REQUIRE(trials.back().start.size() == 1);
  CHECK(trials.back().start[0].first == "T1r");
  // The nested start's T1r is the symmetric fit's T1 (the same grid, the same fits).
  for (const ParameterEstimate& p : symmetric.parameters)
    if (p.name == "T1") CHECK(trials.back().start[0].second == doctest::Approx(p.value).epsilon(1e-9));
  MESSAGE("s(v): symmetric " << symmetric.fit_error << ", with T1r " << nested.fit_error << " (start "
                             << nested.stall_start_search.chosen << " kept, nested start "
                             << trials.back().fit_error << ")");
  CHECK(trials.back().fit_error <= symmetric.fit_error * (1.0 + 1e-12));
  CHECK(nested.fit_error <= symmetric.fit_error * (1.0 + 1e-12));
  // fit.json names the start's origin.
  const nlohmann::json j = fit_json(nested, e, grid, nullptr);
  CHECK(j["stall_start_search"]["trials"].back()["origin"].get<std::string>() == trials.back().origin);
  CHECK(!j["stall_start_search"]["trials"][0].contains("origin"));
}

// With a(x) (or b1(x)) of several terms the grid has one more start: the constant-coefficient
// model's best fit (a(x), b1(x) cut to their first term, its own grid) with the cut terms at 0
// (fit_two_stage.cpp, nested_constant_trial). The model nests that one, so the kept fit cannot
// end above it; on the Glasgow C_m fit cycles of tools/validate_stall.py the grid alone did
// (0.0368 against 0.0317). Here a(x) of degree 2 with a knot on the constant-a truth.
TEST_CASE("fit stall families with a spline a(x) never ends above the constant-coefficient fit") {
  const TruthExperiment te = truth_experiment();
  FitOptions grid;
  grid.threads = 2;
  const FitResult constant = fit_experiment(te.e, grid);
  for (const StallStartTrial& t : constant.stall_start_search.trials)  // one term each: no such start
    CHECK(t.origin.find("constant-coefficient") == std::string::npos);
  Experiment e = te.e;
  e.model.a.powers = {0, 1, 2};
  e.model.a.knots_rad = {14.0 * kDeg};
  const FitResult nested = fit_experiment(e, grid);
  const auto& trials = nested.stall_start_search.trials;
  REQUIRE(trials.size() == constant.stall_start_search.trials.size() + 1);
  const std::string& origin = trials.back().origin;
  REQUIRE(origin.find("constant-coefficient model's best fit") != std::string::npos);
  // The sub-model's s(v), as the origin states it ("s(v) = X)").
  const std::size_t at = origin.find("s(v) = ");
  REQUIRE(at != std::string::npos);
  const double sub = std::stod(origin.substr(at + 7));
  MESSAGE("s(v): constant-a fit " << constant.fit_error << ", its fit inside the spline's search " << sub
                                  << ", nested start " << trials.back().fit_error << ", kept " << nested.fit_error
                                  << " (start " << nested.stall_start_search.chosen << ")");
  CHECK(sub < 1.5 * kNoiseSigma);  // the sub-model is the truth's structure: it reaches the noise
  // (The origin prints 6 significant digits: within 5e-6 of the value, relatively.)
  CHECK(trials.back().fit_error <= sub * (1.0 + 1e-5));
  CHECK(nested.fit_error <= sub * (1.0 + 1e-5));
}

// With D estimated (stall_lag_limit = "estimated") the grid has one more start: the best fit of
// the model without the limit (its whole search) with D = kLagLimitNestedStartRad
// (fit_two_stage.cpp, nested_lag_limit_trial). D -> infinity is that model, so the kept fit
// cannot end above it by more than what D <= 20 deg costs where the truth has no limit; on the
// Glasgow C_m fit cycles of tools/validate_stall.py the grid alone ended at D = 20 deg, s(v)
// 0.0391 against 0.0313 without D. Here on the truth without a limit.
TEST_CASE("fit stall families with D never ends above the fit without D") {
  const TruthExperiment te = truth_experiment();
  FitOptions grid;
  grid.threads = 2;
  const FitResult without = fit_experiment(te.e, grid);
  Experiment e = te.e;
  e.model.stall.lag_limit = StallLagLimit::estimated;
  const FitResult nested = fit_experiment(e, grid);
  const auto& trials = nested.stall_start_search.trials;
  REQUIRE(trials.size() == without.stall_start_search.trials.size() + 1);
  const std::string& origin = trials.back().origin;
  REQUIRE(origin.find("from the best fit without the lag limit") != std::string::npos);
  REQUIRE(trials.back().start.size() == 1);
  CHECK(trials.back().start[0].first == "dxl");
  CHECK(trials.back().start[0].second == kLagLimitNestedStartRad);
  // The sub-model's s(v), as the origin states it: the fit without D, its same search.
  const std::size_t at = origin.find("s(v) = ");
  REQUIRE(at != std::string::npos);
  CHECK(std::stod(origin.substr(at + 7)) == doctest::Approx(without.fit_error).epsilon(1e-5).scale(0));
  double d_rad = 0.0;
  for (const ParameterEstimate& p : nested.parameters)
    if (p.name == "dxl") d_rad = p.value;
  MESSAGE("s(v): without D " << without.fit_error << ", with D " << nested.fit_error << " (D = " << d_rad * 180 / kPi
                             << " deg, start " << nested.stall_start_search.chosen << " kept, nested start "
                             << trials.back().fit_error << ")");
  CHECK(trials.back().fit_error <= without.fit_error * (1.0 + 1e-3));
  CHECK(nested.fit_error <= without.fit_error * (1.0 + 1e-3));
}
