// Parameter identity (ParamId: names made and read in one place each; fit_params.cpp). The
// solver's tests are test_levenberg_marquardt.cpp.
#include <doctest/doctest.h>

#include <Eigen/Core>
#include <cmath>
#include <string>
#include <unordered_map>
#include <vector>

#include "indicial/fitter/fit.hpp"

TEST_SUITE_BEGIN("unit");  // the ctest label (tests/CMakeLists.txt)

using namespace indicial;

namespace {

ParamId id_of(ParamKind kind, int lag = 0, int power = 0, int knot = 0, double knot_rad = 0.0,
              int run = 0) {
  ParamId id;
  id.kind = kind;
  id.lag = lag;
  id.power = power;
  id.knot = knot;
  id.knot_rad = knot_rad;
  id.run = run;
  return id;
}

}  // namespace

TEST_CASE("parameter names: the contract spelling, and parse_parameter_name inverts it") {
  struct Row { ParamId id; const char* name; };
  const Row rows[] = {
      {id_of(ParamKind::a_power, 0, 2), "a2"},
      {id_of(ParamKind::a_knot, 0, 2, 1, 0.9), "A2"},
      {id_of(ParamKind::b_power, 0, 0), "b1_0"},
      {id_of(ParamKind::b_knot, 0, 1, 3, 0.5), "B4"},
      {id_of(ParamKind::b_power, 2, 1), "b3_1"},
      {id_of(ParamKind::b_knot, 1, 1, 0, 0.5), "B2_1"},
      {id_of(ParamKind::con), "con"},
      {id_of(ParamKind::gain, 1), "c2"},
      {id_of(ParamKind::delay), "delay_s"},
      {id_of(ParamKind::rotary_power, 0, 2), "Caq_2"},
      {id_of(ParamKind::rotary_knot, 0, 1, 0, 0.3), "CaqK1"},
      {id_of(ParamKind::static_power, 0, 1), "dCa_1"},
      {id_of(ParamKind::static_knot, 0, 2, 1, 0.7), "dCaK2"},
      {id_of(ParamKind::initial_state, 0, 0, 0, 0.0, 2), "y0_3"},
      {id_of(ParamKind::initial_state, 1, 0, 0, 0.0, 2), "y0_3_2"},
  };
  for (const Row& r : rows) {
    CAPTURE(r.name);
    CHECK(parameter_name(r.id) == r.name);
    ParamId back;
    REQUIRE(parse_parameter_name(r.name, &back));
    CHECK(back.kind == r.id.kind);
    CHECK(back.lag == r.id.lag);
    CHECK(back.knot == r.id.knot);
    CHECK(back.run == r.id.run);
    CHECK(parameter_name(back) == r.name);
  }
  for (const char* bad : {"", "a", "A0", "b1", "b1_01", "B1_2", "c1", "c", "y0_0", "y0_1_1",
                          "Caq", "con2", "delay", "x1", "a-1", "b0_0"}) {
    CAPTURE(bad);
    ParamId id;
    CHECK_FALSE(parse_parameter_name(bad, &id));
  }
}

TEST_CASE("parameter identity: a knot is where it is, not its number") {
  const ParamId a_at_05_first = id_of(ParamKind::a_knot, 0, 2, 0, 0.5);
  const ParamId a_at_05_second = id_of(ParamKind::a_knot, 0, 2, 1, 0.5);  // renumbered
  const ParamId a_at_06 = id_of(ParamKind::a_knot, 0, 2, 0, 0.6);
  CHECK(a_at_05_first == a_at_05_second);
  CHECK(ParamIdHash{}(a_at_05_first) == ParamIdHash{}(a_at_05_second));
  CHECK(a_at_05_first != a_at_06);
  CHECK(parameter_name(a_at_05_first) != parameter_name(a_at_05_second));
  CHECK(id_of(ParamKind::b_power, 0, 0) != id_of(ParamKind::b_power, 1, 0));
  CHECK(id_of(ParamKind::initial_state, 0, 0, 0, 0, 1) != id_of(ParamKind::initial_state, 0, 0, 0, 0, 2));
  CHECK((a_at_05_first < a_at_06) != (a_at_06 < a_at_05_first));
  std::unordered_map<ParamId, int, ParamIdHash> m;
  m[a_at_05_first] = 1;
  m[a_at_05_second] += 1;
  m[a_at_06] = 5;
  CHECK(m.size() == 2);
  CHECK(m[a_at_05_first] == 2);
}
