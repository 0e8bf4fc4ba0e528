// The runtime with the dynamic-stall families (model.hpp's StallModel, issue 22): it steps
// them with model.hpp's one update and output and adds nothing, keeps every state on bad input
// (commit only if finite), refuses a plain State with a status, and carries them through the
// coefficient file (version 2), the batch, the float build and the Predictor.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <string>
#include <type_traits>
#include <vector>

#include "indicial/batch.hpp"
#include "indicial/coef_file.hpp"
#include "indicial/runtime.hpp"
#include "runtime_test_models.hpp"
#include "cli_test_support.hpp"
#include "test_support.hpp"

TEST_SUITE_BEGIN("unit");  // the ctest label (tests/CMakeLists.txt)

namespace {

using Cap = indicial::DefaultCapacity;
using Set = indicial::ModelSet<double, Cap>;
using Model = indicial::RuntimeModel<double, Cap>;
using Families = indicial::FamilyState<double, Cap>;
using indicial::LoadStatus;
using indicial::StepStatus;
using indicial::testing::kPi;

// A deep-stall cycle: alpha = 14 + 10 sin(2 pi f t) deg at reduced frequency k = 0.1 (f from
// k = omega l / V at 30 m/s, l = 0.15 m), 1 kHz.
constexpr double kAirspeed = 30.0;
constexpr double kDt = 0.001;
double cycle_hz() { return 0.1 * kAirspeed / 0.15 / (2.0 * kPi); }
double alpha_at(int k) { return (14.0 + 10.0 * std::sin(2.0 * kPi * cycle_hz() * kDt * k)) * kPi / 180.0; }
double q_at(int k) {
  return 10.0 * kPi / 180.0 * 2.0 * kPi * cycle_hz() * std::cos(2.0 * kPi * cycle_hz() * kDt * k);
}

std::string text_of(const Set& m) {
  static char buffer[65536];
  std::size_t n = 0;
  REQUIRE(indicial::write_coef_file(m, buffer, sizeof buffer, &n) == indicial::WriteStatus::ok);
  return std::string(buffer, n);
}

Model runtime_of(const Set& m) {
  Model r{};
  indicial::ParseDiagnostic diag;
  REQUIRE_MESSAGE(indicial::make_runtime_model(m, &r, &diag) == LoadStatus::ok, diag.reason);
  return r;
}

template <class S>
bool same_bytes(const S& a, const S& b) {
  return std::memcmp(&a, &b, sizeof a) == 0;
}

std::string with_checksum(const std::string& body) {
  char hex[16];
  std::snprintf(hex, sizeof hex, "%08x", static_cast<unsigned>(indicial::crc32(body.data(), body.size())));
  return body + "checksum " + hex + "\n";
}

// The file's text before its checksum line, with `from` replaced by `to` once.
std::string edited(const std::string& text, const std::string& from, const std::string& to) {
  std::string body = text.substr(0, text.rfind("checksum "));
  const std::size_t at = body.find(from);
  REQUIRE(at != std::string::npos);
  body.replace(at, from.size(), to);
  return with_checksum(body);
}

LoadStatus parse(const std::string& text, indicial::ParseDiagnostic* diag) {
  Set out{};
  return indicial::parse_coef_file(text.data(), text.size(), &out, diag);
}

}  // namespace

TEST_CASE("family states cost only the models that have them: 160 / 256 bytes, float 88 / 136") {
  // 160: the State keeps the model angle only, its clamp is derived (runtime.hpp
  // clamped_previous_angle_rad); 168 while it kept both.
  static_assert(sizeof(indicial::State<double, Cap>) == 160, "a State without families");
  static_assert(sizeof(indicial::State<float, Cap>) == 88, "float: unchanged (issue 25)");
  // Four scalars per coefficient (model.hpp StallState), no padding word: issue 22 item 4's
  // limit, C_L + C_m with every family in at most 256 bytes, holds in DefaultCapacity (three
  // coefficient slots, what the C API and codegen use): 256, float 136. A C_L + C_m instance
  // in a two-coefficient capacity (codegen --capacity tight of such a model): 184, float 96.
  using Two = indicial::Capacity<8, 8, 2, 64, 2>;
  static_assert(sizeof(Families) <= 256, "issue 22: C_L + C_m with every family in <= 256 bytes");
  static_assert(sizeof(Families) == 256, "DefaultCapacity (three coefficient slots)");
  static_assert(sizeof(indicial::FamilyState<float, Cap>) == 136, "float, DefaultCapacity");
  static_assert(sizeof(indicial::FamilyState<double, Two>) == 184, "C_L + C_m, two-coefficient capacity");
  static_assert(sizeof(indicial::FamilyState<float, Two>) == 96, "float, two-coefficient capacity");
  static_assert(std::is_trivially_copyable<Families>::value, "plain data");
  // No padding: the members add up to the size (bytewise comparison is meaningful).
  CHECK(sizeof(Families) ==
        sizeof(indicial::State<double, Cap>) + Cap::max_coefficients * sizeof(indicial::StallState<double>));
  CHECK(sizeof(indicial::FamilyState<float, Cap>) ==
        sizeof(indicial::State<float, Cap>) + Cap::max_coefficients * sizeof(indicial::StallState<float>));
  MESSAGE("FamilyState<double>: ", sizeof(Families), " bytes; <float>: ",
          sizeof(indicial::FamilyState<float, Cap>), " bytes");
}

// The lift-and-moment model with C_m's T2, T1 or f0 table changed (or none): which lookups
// C_m repeats from C_L (RuntimeModel::stall_sharing) changes, the numbers must not.
enum class Shared : int { everything, table_and_decay, table_and_forcing, decay_only };

Set stall_model_sharing(Shared shared) {
  Set set = indicial::test_models::lift_and_moment_stall();
  for (int c = 0; c < 2; ++c) indicial::prepare_static_table(set.coefficients[c].static_curve);
  auto& p = set.coefficients[1].stall.separation;
  if (shared == Shared::table_and_decay) p.tau2_semichords = 1.2;
  if (shared == Shared::table_and_forcing) p.tau1_semichords = 2.5;
  if (shared == Shared::decay_only) p.f0_value[20] = p.f0_value[20] * 0.5;
  return set;
}

// Steps the runtime over the deep-stall cycle beside the direct loop -- what the fitter
// evaluates (advance_lags, advance_stall, the outputs) -- and compares every output and family
// state byte for byte. moment_f >= 0: coefficient 1's separation point set to it after the
// reset, in both (no longer the bits of coefficient 0's); moment_forcing_shift_rad: the same
// for coefficient 1's forcing angle (ForcingLag::first_order's state), moved by that much.
void check_step_equals_direct_loop(const Set& set, const Model& m, double moment_f = -1.0,
                                   double moment_forcing_shift_rad = 0.0) {
  const int n = set.n_coefficients;
  Families s;
  REQUIRE(indicial::reset(m, s, alpha_at(0), kAirspeed) == StepStatus::ok);
  double y[Cap::max_coefficients][Cap::max_lags] = {};
  indicial::StallState<double> st[Cap::max_coefficients];
  for (int c = 0; c < n; ++c) {
    indicial::steady_state(set.coefficients[c], alpha_at(0), y[c]);
    indicial::stall_steady_state(set.coefficients[c].stall, alpha_at(0), &st[c]);
    CHECK(same_bytes(st[c], s.stall[c]));
  }
  if (moment_f >= 0.0) {
    s.stall[1].separation_point = moment_f;
    st[1].separation_point = moment_f;
  }
  s.stall[1].forcing_angle_rad += moment_forcing_shift_rad;
  st[1].forcing_angle_rad += moment_forcing_shift_rad;
  const indicial::AirspeedScaling<double> v = indicial::airspeed_scaling(30.0, 0.15, kAirspeed);
  double max_vortex = 0.0;
  double min_f = 1.0;
  for (int k = 1; k <= 2000; ++k) {
    double out[Cap::max_coefficients];
    REQUIRE(indicial::step(m, s, {alpha_at(k), q_at(k), kAirspeed}, kDt, out) == StepStatus::ok);
    for (int c = 0; c < n; ++c) {
      const auto& cm = set.coefficients[c];
      const indicial::StepGeometry<double> g{alpha_at(k - 1), alpha_at(k), alpha_at(k - 1), alpha_at(k), kDt,
                                             v.time_scale};
      indicial::advance_lags(cm, g, y[c]);
      indicial::advance_stall(cm.stall, indicial::StallStep<double>{alpha_at(k - 1), alpha_at(k), kDt, v.l_over_v_s},
                              &st[c]);
      const double expected = indicial::coefficient_output(cm, alpha_at(k), q_at(k), v.l_over_v_s, y[c]) +
                              indicial::stall_output(cm.stall, alpha_at(k), st[c]);
      CHECK(std::memcmp(&out[c], &expected, sizeof(double)) == 0);
      CHECK(same_bytes(st[c], s.stall[c]));
      max_vortex = std::fmax(max_vortex, std::fabs(st[c].vortex_lift));
      min_f = std::fmin(min_f, st[c].separation_point);
    }
  }
  // The cycle reaches deep stall: the separation point travels and a vortex is shed.
  MESSAGE("min f ", min_f, ", max |vortex lift| ", max_vortex);
  CHECK(min_f < 0.3);
  CHECK(max_vortex > 0.05);
}

void check_step_equals_direct_loop(Shared shared) {
  CAPTURE(static_cast<int>(shared));
  const Set set = stall_model_sharing(shared);
  const Model m = runtime_of(set);
  CHECK(m.stall == indicial::StallUse::families);
  const indicial::StallSharing& sh = m.stall_sharing[1];
  CHECK(m.stall_sharing[0].table == indicial::StallSharing::no_sharing);
  CHECK(sh.table == (shared == Shared::decay_only ? indicial::StallSharing::no_sharing : 0));
  CHECK(sh.forcing == (shared == Shared::everything || shared == Shared::table_and_forcing ? 0 : indicial::StallSharing::no_sharing));
  CHECK(sh.decay == (shared == Shared::table_and_forcing ? indicial::StallSharing::no_sharing : 0));
  CHECK(sh.separation == (shared == Shared::everything ? 0 : indicial::StallSharing::no_sharing));
  check_step_equals_direct_loop(set, m);
}

// Three coefficients, the third sharing its lookups with two DIFFERENT earlier ones: C_m has a
// table and a T1 of its own (nothing shared with C_L); the third ("CN": C_L's families with
// C_m's T1) takes its table and lagged angles (forcing) from coefficient 0 and its decay from
// coefficient 1. A step that took both from one coefficient, or kept only the last
// coefficient's lookups, gives other bits.
Set stall_model_three_sharing() {
  Set set = indicial::test_models::lift_and_moment_stall();
  auto& cm = set.coefficients[1].stall.separation;
  cm.f0_value[20] = cm.f0_value[20] * 0.5;
  cm.tau1_semichords = 2.5;
  set.coefficients[2] = set.coefficients[0];
  set.coefficients[2].name[0] = 'C';
  set.coefficients[2].name[1] = 'N';
  set.coefficients[2].stall.separation.tau1_semichords = cm.tau1_semichords;
  set.n_coefficients = 3;
  for (int c = 0; c < 3; ++c) indicial::prepare_static_table(set.coefficients[c].static_curve);
  return set;
}

TEST_CASE("step with families equals a direct loop over model.hpp's updates, bit for bit") {
  for (Shared shared : {Shared::everything, Shared::table_and_decay, Shared::table_and_forcing, Shared::decay_only})
    check_step_equals_direct_loop(shared);
}

// C_m repeats C_L's separation update (the same table, T2, T1, T1r and f0 correction) only while
// their separation points are the same bits: from another one it computes its own, and a T1r or
// an f0 correction of its own is not shared at all (issue 22 item 6; runtime.hpp's
// advance_families). A step that copied C_L's update regardless gives other bits.
TEST_CASE("a coefficient repeating another's separation update: only from the same separation point") {
  const Set shared = stall_model_sharing(Shared::everything);
  const Model m = runtime_of(shared);
  REQUIRE(m.stall_sharing[1].separation == 0);
  check_step_equals_direct_loop(shared, m, 0.6);
  check_step_equals_direct_loop(shared, m, 0.0);
  Set reattach = shared;
  reattach.coefficients[1].stall.separation.tau1_reattach_semichords = 8.0;
  const Model mr = runtime_of(reattach);
  CHECK(mr.stall_sharing[1].forcing == 0);
  CHECK(mr.stall_sharing[1].decay == 0);
  CHECK(mr.stall_sharing[1].separation == indicial::StallSharing::no_sharing);
  check_step_equals_direct_loop(reattach, mr);
  // A static hysteresis of its own (dxr) is not shared either.
  Set hysteresis = shared;
  hysteresis.coefficients[1].stall.separation.reattach_shift_rad = 0.05;
  const Model mh = runtime_of(hysteresis);
  CHECK(mh.stall_sharing[1].separation == indicial::StallSharing::no_sharing);
  check_step_equals_direct_loop(hysteresis, mh);
  // A lag limit of its own (D) changes the lagged angles: neither the forcing nor the
  // separation update is shared.
  Set limited = shared;
  limited.coefficients[1].stall.separation.lag_limit_rad = 0.03;
  const Model ml = runtime_of(limited);
  CHECK(ml.stall_sharing[1].forcing == indicial::StallSharing::no_sharing);
  CHECK(ml.stall_sharing[1].separation == indicial::StallSharing::no_sharing);
  check_step_equals_direct_loop(limited, ml);
  Set corrected = shared;
  auto& correction = corrected.coefficients[1].stall.separation.f0_correction;
  correction.n_powers = 2;
  correction.power_coef[0] = 0.02;
  correction.power_coef[1] = -0.05;
  const Model mc = runtime_of(corrected);
  CHECK(mc.stall_sharing[1].separation == indicial::StallSharing::no_sharing);
  check_step_equals_direct_loop(corrected, mc);
  // Both with the same T1r and correction: shared again.
  Set both = corrected;
  both.coefficients[0].stall.separation.f0_correction = correction;
  CHECK(runtime_of(both).stall_sharing[1].separation == 0);
  check_step_equals_direct_loop(both, runtime_of(both));
}

// ForcingLag::first_order (model.hpp): the lagged angle is each coefficient's own state, so a
// first_order coefficient shares no lagged angles (nor its separation update) with another,
// whatever their parameters; the numbers are the direct loop's, also with the two states'
// forcing angles moved apart.
TEST_CASE("first-order forcing lag: a direct loop's bits, the lagged angles never shared") {
  const auto first_order = [](Shared shared, int coefficients) {
    Set set = stall_model_sharing(shared);
    for (int c = 0; c < coefficients; ++c)
      set.coefficients[c].stall.separation.forcing_lag = indicial::ForcingLag::first_order;
    return set;
  };
  for (Shared shared : {Shared::everything, Shared::table_and_decay, Shared::table_and_forcing, Shared::decay_only}) {
    CAPTURE(static_cast<int>(shared));
    const Set set = first_order(shared, 2);
    check_step_equals_direct_loop(set, runtime_of(set));
  }
  const Set both = first_order(Shared::everything, 2);
  const Model m = runtime_of(both);
  CHECK(m.stall_sharing[1].table == 0);
  CHECK(m.stall_sharing[1].decay == 0);
  CHECK(m.stall_sharing[1].forcing == indicial::StallSharing::no_sharing);
  CHECK(m.stall_sharing[1].separation == indicial::StallSharing::no_sharing);
  check_step_equals_direct_loop(both, m, -1.0, 0.035);  // 2 deg
  check_step_equals_direct_loop(both, m, 0.6, 0.035);
  const Set mixed = first_order(Shared::everything, 1);  // C_L first_order, C_m delay
  const Model mm = runtime_of(mixed);
  CHECK(mm.stall_sharing[1].table == 0);
  CHECK(mm.stall_sharing[1].forcing == indicial::StallSharing::no_sharing);
  CHECK(mm.stall_sharing[1].separation == indicial::StallSharing::no_sharing);
  check_step_equals_direct_loop(mixed, mm);
}

TEST_CASE("three coefficients sharing the forcing with one and the decay with another: a direct loop's bits") {
  static_assert(Cap::max_coefficients >= 3, "the case needs three coefficients");
  const Set set = stall_model_three_sharing();
  const Model m = runtime_of(set);
  const indicial::StallSharing none{};
  CHECK(std::memcmp(&m.stall_sharing[0], &none, sizeof none) == 0);
  CHECK(std::memcmp(&m.stall_sharing[1], &none, sizeof none) == 0);  // C_m: its own table and T1
  CHECK(m.stall_sharing[2].table == 0);
  CHECK(m.stall_sharing[2].forcing == 0);
  CHECK(m.stall_sharing[2].decay == 1);
  CHECK(m.stall_sharing[2].separation == indicial::StallSharing::no_sharing);  // forcing and decay apart
  check_step_equals_direct_loop(set, m);
  // The batch steps the families with the same lookups per instance: its family states are the
  // single steps' byte for byte (the outputs to rounding, as in the step_batch case below: the lags are stepped by lanes).
  constexpr int n = 9;  // a full block and a partial one
  Families batch[n], single[n];
  for (int i = 0; i < n; ++i) {
    REQUIRE(indicial::reset(m, batch[i], alpha_at(29 * i), kAirspeed + i) == StepStatus::ok);
    single[i] = batch[i];
  }
  for (int k = 1; k <= 1000; ++k) {
    double angle[n], rate[n], airspeed[n], out[3 * n];
    for (int i = 0; i < n; ++i) {
      angle[i] = alpha_at(k + 29 * i);
      rate[i] = q_at(k + 29 * i);
      airspeed[i] = kAirspeed + i;
    }
    REQUIRE(indicial::step_batch(m, batch, n, angle, rate, airspeed, kDt, out) == StepStatus::ok);
    for (int i = 0; i < n; ++i) {
      double o[3];
      REQUIRE(indicial::step(m, single[i], {angle[i], rate[i], airspeed[i]}, kDt, o) == StepStatus::ok);
      for (int c = 0; c < 3; ++c) {
        CHECK(same_bytes(batch[i].stall[c], single[i].stall[c]));
        CHECK(std::fabs(out[3 * i + c] - o[c]) <= 1e-12 * std::fmax(std::fabs(o[c]), 0.01));
      }
    }
  }
}

TEST_CASE("a family model refuses a plain State, a FamilyState of a model without families steps as a State") {
  const Model fam = runtime_of(indicial::test_models::lift_and_moment_stall());
  indicial::State<double, Cap> plain;
  REQUIRE(indicial::reset(fam, plain, 0.2, kAirspeed) == StepStatus::ok);
  const indicial::State<double, Cap> before = plain;
  double out[3] = {7.0, 7.0, 7.0};
  CHECK(indicial::step(fam, plain, {0.2, 0.0, kAirspeed}, kDt, out) == StepStatus::families_need_state);
  CHECK(same_bytes(before, plain));
  CHECK(out[0] == 7.0);
  CHECK(std::string(indicial::to_string(StepStatus::families_need_state)) == "families_need_state");

  const Model report = runtime_of(indicial::test_models::lift_and_moment());
  CHECK(report.stall == indicial::StallUse::none);
  Families f;
  indicial::State<double, Cap> s;
  REQUIRE(indicial::reset(report, f, 0.5, 17.0) == StepStatus::ok);
  REQUIRE(indicial::reset(report, s, 0.5, 17.0) == StepStatus::ok);
  for (int k = 1; k <= 200; ++k) {
    double a[3], b[3];
    const indicial::MotionInput in{0.5 + 0.3 * std::sin(0.05 * k), 0.1, 17.0};
    REQUIRE(indicial::step(report, f, in, 0.01, a) == StepStatus::ok);
    REQUIRE(indicial::step(report, s, in, 0.01, b) == StepStatus::ok);
    CHECK(std::memcmp(a, b, 2 * sizeof(double)) == 0);
  }
  CHECK(same_bytes(static_cast<const indicial::State<double, Cap>&>(f), s));
}

TEST_CASE("bad input and non-finite results leave the family states untouched") {
  Set set = indicial::test_models::lift_and_moment_stall();
  set.coefficients[0].rotary.n_powers = 1;  // C_Lq = 2: finite input can overflow it
  set.coefficients[0].rotary.power_coef[0] = 2.0;
  const Model m = runtime_of(set);
  Families s;
  REQUIRE(indicial::reset(m, s, alpha_at(0), kAirspeed) == StepStatus::ok);
  double out[3] = {0.0, 0.0, 0.0};
  const double nan = std::numeric_limits<double>::quiet_NaN();
  double min_f = 1.0;
  for (int k = 1; k <= 1500; ++k) {
    min_f = std::fmin(min_f, s.stall[0].separation_point);
    const Families before = s;
    double kept[3];
    std::memcpy(kept, out, sizeof out);
    CHECK(indicial::step(m, s, {nan, 0.0, kAirspeed}, kDt, out) == StepStatus::non_finite_input);
    CHECK(indicial::step(m, s, {alpha_at(k), 0.0, kAirspeed}, -kDt, out) == StepStatus::non_positive_dt);
    CHECK(indicial::step(m, s, {alpha_at(k), 0.0, 0.0}, kDt, out) == StepStatus::non_positive_airspeed);
    CHECK(indicial::step(m, s, {alpha_at(k), 0.0, kAirspeed}, 2.0, out) == StepStatus::dt_too_large);
    // Finite but absurd: (l / V) C_Lq q overflows; the families were advanced on copies.
    CHECK(indicial::step(m, s, {alpha_at(k), 1e300, 1e-300}, kDt, out) == StepStatus::non_finite_result);
    CHECK(same_bytes(before, s));
    CHECK(std::memcmp(kept, out, sizeof out) == 0);
    REQUIRE(indicial::step(m, s, {alpha_at(k), q_at(k), kAirspeed}, kDt, out) == StepStatus::ok);
  }
  CHECK(min_f < 0.3);  // the states kept include deep-stall ones
  // A refused reset (non-finite input) keeps them too.
  const Families before = s;
  CHECK(indicial::reset(m, s, nan, kAirspeed) == StepStatus::non_finite_input);
  CHECK(same_bytes(before, s));
}

TEST_CASE("coefficient file: families round-trip byte for byte as version 2, version 1 unchanged") {
  const Set set = indicial::test_models::lift_and_moment_stall();
  const std::string text = text_of(set);
  CHECK(text.rfind("indicial-coef 2\n", 0) == 0);
  Set back{};
  indicial::ParseDiagnostic diag;
  REQUIRE_MESSAGE(indicial::parse_coef_file(text.data(), text.size(), &back, &diag) == LoadStatus::ok, diag.reason);
  CHECK(text_of(back) == text);
  CHECK(back.coefficients[1].stall.families == indicial::StallFamilies::separation_and_vortex);
  CHECK(back.coefficients[1].stall.separation.n_f0 == 27);
  // The committed example reads back byte for byte too.
  const std::string example =
      indicial::testing::slurp(std::string(INDICIAL_SOURCE_DIR) + "/examples/dynamic-stall-lift-moment.coef");
  Set ex{};
  REQUIRE(indicial::parse_coef_file(example.data(), example.size(), &ex, &diag) == LoadStatus::ok);
  CHECK(text_of(ex) == example);
  // A model without families is written as version 1, as before.
  CHECK(text_of(indicial::test_models::lift_and_moment()).rfind("indicial-coef 1\n", 0) == 0);
  // Only the separation family: no vortex keys, and it reads back as such.
  Set sep_only = set;
  sep_only.coefficients[0].stall.families = indicial::StallFamilies::separation;
  sep_only.coefficients[0].stall.vortex = indicial::VortexParameters<double>{};
  const std::string sep_text = text_of(sep_only);
  REQUIRE(indicial::parse_coef_file(sep_text.data(), sep_text.size(), &back, &diag) == LoadStatus::ok);
  CHECK(back.coefficients[0].stall.families == indicial::StallFamilies::separation);
  CHECK(text_of(back) == sep_text);
  // A reattachment time constant of its own (sep_reattachment) is written and read back; a
  // model without it (0: T1 both ways) has no such line.
  CHECK(text.find("sep_reattachment") == std::string::npos);
  Set reattach = set;
  reattach.coefficients[1].stall.separation.tau1_reattach_semichords = 8.25;
  const std::string r_text = text_of(reattach);
  CHECK(r_text.find("sep_reattachment 8.25\n") != std::string::npos);
  Set r_back{};
  REQUIRE(indicial::parse_coef_file(r_text.data(), r_text.size(), &r_back, &diag) == LoadStatus::ok);
  CHECK(r_back.coefficients[1].stall.separation.tau1_reattach_semichords == 8.25);
  CHECK(r_back.coefficients[0].stall.separation.tau1_reattach_semichords == 0.0);
  CHECK(text_of(r_back) == r_text);
  // The static hysteresis (sep_hysteresis): written only when dxr > 0, read back; a file without
  // the line has none (what every file before the key meant).
  CHECK(text.find("sep_hysteresis") == std::string::npos);
  Set hyst = set;
  hyst.coefficients[0].stall.separation.reattach_shift_rad = 0.0625;
  const std::string h_text = text_of(hyst);
  CHECK(h_text.find("sep_hysteresis 0.0625\n") != std::string::npos);
  Set h_back{};
  REQUIRE(indicial::parse_coef_file(h_text.data(), h_text.size(), &h_back, &diag) == LoadStatus::ok);
  CHECK(h_back.coefficients[0].stall.separation.reattach_shift_rad == 0.0625);
  CHECK(h_back.coefficients[1].stall.separation.reattach_shift_rad == 0.0);
  CHECK(text_of(h_back) == h_text);
  // The lag limit (sep_lag_limit): the same, written only when D > 0.
  CHECK(text.find("sep_lag_limit") == std::string::npos);
  Set lim = set;
  lim.coefficients[1].stall.separation.lag_limit_rad = 0.09375;
  const std::string l_text = text_of(lim);
  CHECK(l_text.find("sep_lag_limit 0.09375\n") != std::string::npos);
  Set l_back{};
  REQUIRE(indicial::parse_coef_file(l_text.data(), l_text.size(), &l_back, &diag) == LoadStatus::ok);
  CHECK(l_back.coefficients[1].stall.separation.lag_limit_rad == 0.09375);
  CHECK(l_back.coefficients[0].stall.separation.lag_limit_rad == 0.0);
  CHECK(text_of(l_back) == l_text);
  // The forcing lag's form (sep_forcing_lag): written only when first_order, read back; a file
  // without the line is delay (what every file before the key meant).
  CHECK(text.find("sep_forcing_lag") == std::string::npos);
  CHECK(r_back.coefficients[0].stall.separation.forcing_lag == indicial::ForcingLag::delay);
  Set filtered = set;
  filtered.coefficients[1].stall.separation.forcing_lag = indicial::ForcingLag::first_order;
  const std::string f_text = text_of(filtered);
  CHECK(f_text.find("sep_forcing_lag first_order\n") != std::string::npos);
  Set f_back{};
  REQUIRE(indicial::parse_coef_file(f_text.data(), f_text.size(), &f_back, &diag) == LoadStatus::ok);
  CHECK(f_back.coefficients[1].stall.separation.forcing_lag == indicial::ForcingLag::first_order);
  CHECK(f_back.coefficients[0].stall.separation.forcing_lag == indicial::ForcingLag::delay);
  CHECK(text_of(f_back) == f_text);
}

TEST_CASE("coefficient file: bad family values are refused with their line and reason") {
  const std::string text = text_of(indicial::test_models::lift_and_moment_stall());
  struct Case {
    std::string from, to;
    LoadStatus status;
    const char* reason_part;
  };
  const Case cases[] = {
      {"indicial-coef 2", "indicial-coef 1", LoadStatus::syntax_error, "needs 'indicial-coef 2'"},
      {"indicial-coef 2", "indicial-coef 3", LoadStatus::wrong_version, "versions 1 and 2"},
      {"sep_time_constants 3 1.7", "sep_time_constants 0 1.7", LoadStatus::invalid_value, "T1 must be > 0"},
      {"sep_time_constants 3 1.7", "sep_time_constants 3 -1", LoadStatus::invalid_value, "T2 must be >= 0"},
      {"sep_time_constants 3 1.7", "sep_time_constants 3", LoadStatus::syntax_error, "missing value"},
      {"sep_f0_point 0 0.9981402368492269", "sep_f0_point 0 1.5", LoadStatus::invalid_value, "f0 must be in [0, 1]"},
      {"sep_polar 6.47 0", "sep_polar -6.47 0", LoadStatus::invalid_value, "slope must be > 0"},
      {"vortex_shedding 1.31 0.05", "vortex_shedding 0 0.05", LoadStatus::invalid_value, "C_N1 must be > 0"},
      {"vortex_time_constants 6 7", "vortex_time_constants 6 nan", LoadStatus::invalid_value, "NaN or Inf"},
      {"vortex_clock 0.5 1\n", "", LoadStatus::syntax_error, "vortex family needs"},
      {"sep_cp 1 0 0\n", "", LoadStatus::syntax_error, "separation family needs"},
      {"sep_cp 1 0 0\n", "sep_cp 1 0 0\nsep_cp 1 0 0\n", LoadStatus::syntax_error, "key given twice"},
      {"sep_cp 1 0 0\n", "sep_cp 1 0 0\nsep_reattachment 0\n", LoadStatus::invalid_value, "T1r must be > 0"},
      {"sep_cp 1 0 0\n", "sep_cp 1 0 0\nsep_reattachment 9 1\n", LoadStatus::syntax_error, ""},
      {"sep_cp 1 0 0\n", "sep_cp 1 0 0\nsep_hysteresis 0\n", LoadStatus::invalid_value, "dxr_rad must be > 0"},
      {"sep_cp 1 0 0\n", "sep_cp 1 0 0\nsep_hysteresis 0.5\n", LoadStatus::invalid_value, "0 to 20 deg"},
      {"sep_cp 1 0 0\n", "sep_cp 1 0 0\nsep_hysteresis 0.05\nsep_hysteresis 0.05\n", LoadStatus::syntax_error,
       "key given twice"},
      {"sep_cp 1 0 0\n", "sep_cp 1 0 0\nsep_lag_limit -0.1\n", LoadStatus::invalid_value, "D_rad must be > 0"},
      {"sep_cp 1 0 0\n", "sep_cp 1 0 0\nsep_lag_limit 0.4\n", LoadStatus::invalid_value, "0 to 20 deg"},
      {"sep_cp 1 0 0\n", "sep_cp 1 0 0\nsep_lag_limit 0.05\nsep_forcing_lag first_order\n",
       LoadStatus::invalid_value, "only with the delay forcing lag"},
      {"sep_cp 1 0 0\n", "sep_cp 1 0 0\nsep_forcing_lag filtered\n", LoadStatus::invalid_value,
       "sep_forcing_lag must be delay or first_order"},
      {"sep_cp 1 0 0\n", "sep_cp 1 0 0\nsep_forcing_lag\n", LoadStatus::syntax_error, "needs one value"},
      {"sep_cp 1 0 0\n", "sep_cp 1 0 0\nsep_forcing_lag first_order\nsep_forcing_lag delay\n",
       LoadStatus::syntax_error, "key given twice"},
  };
  for (const Case& c : cases) {
    CAPTURE(c.to);
    indicial::ParseDiagnostic diag;
    CHECK(parse(edited(text, c.from, c.to), &diag) == c.status);
    CHECK(std::string(diag.reason).find(c.reason_part) != std::string::npos);
    CHECK(diag.line > 0);
  }
}

TEST_CASE("validation refuses infeasible family parameters built in code, the old model stays") {
  indicial::Predictor<double> p;
  REQUIRE(p.load(indicial::test_models::lift_and_moment_stall()) == LoadStatus::ok);
  REQUIRE(p.reset(0.2, kAirspeed) == StepStatus::ok);
  const auto before = p.snapshot();
  const auto refuse = [&](Set bad) {
    indicial::ParseDiagnostic diag;
    CHECK(p.load(bad, &diag) == LoadStatus::invalid_value);
    MESSAGE(std::string(diag.reason));
    CHECK(same_bytes(before, p.snapshot()));
  };
  Set bad = indicial::test_models::lift_and_moment_stall();
  bad.coefficients[1].stall.separation.tau1_semichords = -1.0;
  refuse(bad);
  bad = indicial::test_models::lift_and_moment_stall();
  bad.coefficients[0].stall.separation.f0_value[3] = 1.25;
  refuse(bad);
  bad = indicial::test_models::lift_and_moment_stall();
  bad.coefficients[0].stall.vortex.travel_semichords = 0.0;
  refuse(bad);
  bad = indicial::test_models::lift_and_moment_stall();
  bad.coefficients[0].stall.families = static_cast<indicial::StallFamilies>(7);
  refuse(bad);
  indicial::Predictor<double>::Outputs out;
  CHECK(p.step({0.21, 0.0, kAirspeed}, kDt, &out) == StepStatus::ok);
}

TEST_CASE("Predictor (its DelayedState) steps families like a FamilyState, with and without a delay") {
  const Set set = indicial::test_models::lift_and_moment_stall();
  const Model m = runtime_of(set);
  indicial::Predictor<double> p;
  REQUIRE(p.use(m) == LoadStatus::ok);
  Families s;
  REQUIRE(p.reset(alpha_at(0), kAirspeed) == StepStatus::ok);
  REQUIRE(indicial::reset(m, s, alpha_at(0), kAirspeed) == StepStatus::ok);
  indicial::Predictor<double>::Outputs a;
  for (int k = 1; k <= 500; ++k) {
    double b[3];
    REQUIRE(p.step({alpha_at(k), q_at(k), kAirspeed}, kDt, &a) == StepStatus::ok);
    REQUIRE(indicial::step(m, s, {alpha_at(k), q_at(k), kAirspeed}, kDt, b) == StepStatus::ok);
    CHECK(std::memcmp(a.value, b, 2 * sizeof(double)) == 0);
  }
  // A delay on C_m: the families still run (on the sample angles), the delayed lags too.
  Set delayed = set;
  delayed.coefficients[1].delay_s = 0.004;
  indicial::Predictor<double> d;
  REQUIRE(d.load(delayed) == LoadStatus::ok);
  REQUIRE(d.reset(alpha_at(0), kAirspeed) == StepStatus::ok);
  indicial::Predictor<double>::Outputs o;
  for (int k = 1; k <= 500; ++k) REQUIRE(d.step({alpha_at(k), q_at(k), kAirspeed}, kDt, &o) == StepStatus::ok);
  CHECK(d.snapshot().stall[1].separation_point < 0.9);
  // C_L (undelayed) is the same bit for bit, C_m's lag differs by its delay.
  CHECK(std::memcmp(&o.value[0], &a.value[0], sizeof(double)) == 0);
  CHECK(o.value[1] != a.value[1]);
}

TEST_CASE("float families stay close to double") {
  // The second model has a reattachment time constant of its own (T1r) on both coefficients:
  // the float conversion carries it (its double outputs differ from the first model's).
  Set with_t1r = indicial::test_models::lift_and_moment_stall();
  for (int c = 0; c < 2; ++c) with_t1r.coefficients[c].stall.separation.tau1_reattach_semichords = 9.0;
  std::vector<double> first_double;
  for (const Set& set : {indicial::test_models::lift_and_moment_stall(), with_t1r}) {
    indicial::Predictor<float> pf;
    indicial::Predictor<double> pd;
    REQUIRE(pf.load(set) == LoadStatus::ok);
    REQUIRE(pd.load(set) == LoadStatus::ok);
    REQUIRE(pf.reset(alpha_at(0), kAirspeed) == StepStatus::ok);
    REQUIRE(pd.reset(alpha_at(0), kAirspeed) == StepStatus::ok);
    double max_diff = 0.0, max_t1r_effect = 0.0;
    const bool first = first_double.empty();
    for (int k = 1; k <= 2000; ++k) {
      indicial::Predictor<float>::Outputs of;
      indicial::Predictor<double>::Outputs od;
      REQUIRE(pf.step({alpha_at(k), q_at(k), kAirspeed}, kDt, &of) == StepStatus::ok);
      REQUIRE(pd.step({alpha_at(k), q_at(k), kAirspeed}, kDt, &od) == StepStatus::ok);
      for (int c = 0; c < 2; ++c) {
        max_diff = std::fmax(max_diff, std::fabs(double(of.value[c]) - od.value[c]));
        if (first) first_double.push_back(od.value[c]);
        else max_t1r_effect = std::fmax(max_t1r_effect, std::fabs(od.value[c] - first_double[2 * (k - 1) + c]));
      }
    }
    MESSAGE("max |float - double| over a deep-stall cycle: ", max_diff, ", T1r's effect ", max_t1r_effect);
    CHECK(max_diff < 2e-3);
    if (!first) CHECK(max_t1r_effect > 1e-2);
  }
}

// A float model keeps its f0 angles as float (KnotStorage): rows distinct in double that round
// to one float are never the bracketing row (the search compares in float), so no interval
// width is 0: the float model loads and steps across them, finite and close to double.
TEST_CASE("float families: f0 rows that round to one float step finite, close to double") {
  Set set = indicial::test_models::lift_and_moment_stall();
  auto& sep = set.coefficients[0].stall.separation;
  sep.f0_x_rad[4] = std::nextafter(sep.f0_x_rad[3], 1.0);
  REQUIRE(static_cast<float>(sep.f0_x_rad[4]) == static_cast<float>(sep.f0_x_rad[3]));
  REQUIRE(sep.f0_x_rad[4] < sep.f0_x_rad[5]);
  indicial::Predictor<double> pd;
  indicial::Predictor<float> pf;
  REQUIRE(pd.load(set) == LoadStatus::ok);
  REQUIRE(pf.load(set) == LoadStatus::ok);
  const double x3 = sep.f0_x_rad[3];
  REQUIRE(pd.reset(x3 - 0.01, kAirspeed) == StepStatus::ok);
  REQUIRE(pf.reset(x3 - 0.01, kAirspeed) == StepStatus::ok);
  double max_diff = 0.0;
  for (int k = 1; k <= 400; ++k) {  // across the collapsed row and back, 1e-4 rad per step
    const double x = x3 - 0.01 + 1e-4 * (k <= 200 ? k : 400 - k);
    indicial::Predictor<float>::Outputs of;
    indicial::Predictor<double>::Outputs od;
    REQUIRE(pf.step({x, 0.0, kAirspeed}, kDt, &of) == StepStatus::ok);
    REQUIRE(pd.step({x, 0.0, kAirspeed}, kDt, &od) == StepStatus::ok);
    REQUIRE(std::isfinite(of.value[0]));
    max_diff = std::fmax(max_diff, std::fabs(double(of.value[0]) - od.value[0]));
  }
  // The bound of "float families stay close to double": the collapsed row makes f0 jump at
  // x3, and a float angle may fall on the other side of the jump than the double one.
  MESSAGE("max |float - double| across the collapsed row: ", max_diff);
  CHECK(max_diff < 2e-3);
}

TEST_CASE("step_batch of FamilyStates equals single steps within 1e-12, refusals per instance") {
  const Model m = runtime_of(indicial::test_models::lift_and_moment_stall());
  constexpr int n = 13;  // a full block and a partial one
  Families batch[n], single[n];
  for (int i = 0; i < n; ++i) {
    REQUIRE(indicial::reset(m, batch[i], 0.1 + 0.02 * i, kAirspeed + i) == StepStatus::ok);
    single[i] = batch[i];
  }
  double worst = 0.0;
  for (int k = 1; k <= 1500; ++k) {
    double angle[n], rate[n], airspeed[n], out[2 * n];
    StepStatus status[n];
    for (int i = 0; i < n; ++i) {
      angle[i] = alpha_at(k + 37 * i);
      rate[i] = q_at(k + 37 * i);
      airspeed[i] = kAirspeed + i;
    }
    if (k == 700) angle[5] = std::numeric_limits<double>::infinity();  // one refused instance
    const Families kept = batch[5];
    indicial::step_batch(m, batch, n, angle, rate, airspeed, kDt, out, status);
    if (k == 700) {
      CHECK(status[5] == StepStatus::non_finite_input);
      CHECK(same_bytes(kept, batch[5]));
    }
    for (int i = 0; i < n; ++i) {
      double o[3];
      const StepStatus s = indicial::step(m, single[i], {angle[i], rate[i], airspeed[i]}, kDt, o);
      REQUIRE(s == status[i]);
      if (s != StepStatus::ok) continue;
      for (int c = 0; c < 2; ++c)
        worst = std::fmax(worst, std::fabs(out[2 * i + c] - o[c]) / std::fmax(std::fabs(o[c]), 0.01));
    }
  }
  MESSAGE("largest relative batch - single difference: ", worst);
  CHECK(worst < 1e-12);
  // A plain State array of a family model is refused as a whole.
  indicial::State<double, Cap> plain[2];
  double a[2] = {0.1, 0.1}, z[2] = {0.0, 0.0}, v[2] = {kAirspeed, kAirspeed}, out[4];
  CHECK(indicial::step_batch(m, plain, 2, a, z, v, kDt, out) == StepStatus::families_need_state);
}
