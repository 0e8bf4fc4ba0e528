// The coefficient file (.coef, version 1): round trip, size, checksum and every refusal.
#include <doctest/doctest.h>

#include <cstring>
#include <string>

#include "indicial/coef_file.hpp"
#include "indicial/fitter/output.hpp"
#include "runtime_test_models.hpp"

TEST_SUITE_BEGIN("unit");  // the ctest label (tests/CMakeLists.txt)

namespace {

using Set = indicial::ModelSet<double, indicial::DefaultCapacity>;
using indicial::LoadStatus;

std::string write(const Set& m) {
  char buffer[16384];
  std::size_t n = 0;
  const indicial::WriteStatus s = indicial::write_coef_file(m, buffer, sizeof buffer, &n);
  REQUIRE(s == indicial::WriteStatus::ok);
  return std::string(buffer, n);
}

LoadStatus parse(const std::string& text, Set* out = nullptr,
                 indicial::ParseDiagnostic* diag = nullptr) {
  Set local{};
  return indicial::parse_coef_file(text.data(), text.size(), out ? out : &local, diag);
}

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

template <int P, int K>
void check_spline_equal(const indicial::Spline<double, P, K>& a, const indicial::Spline<double, P, K>& b) {
  REQUIRE(a.n_powers == b.n_powers);
  REQUIRE(a.n_knots == b.n_knots);
  for (int i = 0; i < a.n_powers; ++i) CHECK(same_bits(a.power_coef[i], b.power_coef[i]));
  for (int j = 0; j < a.n_knots; ++j) {
    CHECK(same_bits(a.knot_rad[j], b.knot_rad[j]));
    CHECK(a.knot_power[j] == b.knot_power[j]);
    CHECK(same_bits(a.knot_coef[j], b.knot_coef[j]));
  }
}

void check_models_equal(const Set& a, const Set& b) {
  CHECK(a.axis == b.axis);
  CHECK(same_bits(a.reference_length_m, b.reference_length_m));
  CHECK(same_bits(a.airspeed_mps, b.airspeed_mps));
  CHECK(same_bits(a.alpha0_rad, b.alpha0_rad));
  CHECK(same_bits(a.x_min_rad, b.x_min_rad));
  CHECK(same_bits(a.x_max_rad, b.x_max_rad));
  REQUIRE(a.n_coefficients == b.n_coefficients);
  for (int c = 0; c < a.n_coefficients; ++c) {
    const auto& x = a.coefficients[c];
    const auto& y = b.coefficients[c];
    CHECK(std::string(x.name) == std::string(y.name));
    REQUIRE(x.static_curve.kind == y.static_curve.kind);
    check_spline_equal(x.static_curve.polynomial, y.static_curve.polynomial);
    REQUIRE(x.static_curve.n_table == y.static_curve.n_table);
    for (int i = 0; i < x.static_curve.n_table; ++i) {
      CHECK(same_bits(x.static_curve.table_x_rad[i], y.static_curve.table_x_rad[i]));
      CHECK(same_bits(x.static_curve.table_value[i], y.static_curve.table_value[i]));
    }
    check_spline_equal(x.static_correction, y.static_correction);
    check_spline_equal(x.rotary, y.rotary);
    check_spline_equal(x.a, y.a);
    REQUIRE(x.n_lags == y.n_lags);
    for (int j = 0; j < x.n_lags; ++j) {
      check_spline_equal(x.lags[j].b, y.lags[j].b);
      CHECK(same_bits(x.lags[j].gain, y.lags[j].gain));
    }
    CHECK(same_bits(x.con, y.con));
    CHECK(same_bits(x.delay_s, y.delay_s));
  }
}

// Rewrites the checksum line so that a deliberately edited body passes the checksum and the
// refusal under test is the one the edit causes.
std::string with_checksum(std::string text) {
  const std::size_t at = text.rfind("checksum ");
  REQUIRE(at != std::string::npos);
  text.resize(at);
  char hex[16];
  std::snprintf(hex, sizeof hex, "%08x", static_cast<unsigned>(indicial::crc32(text.data(), text.size())));
  return text + "checksum " + hex + "\n";
}

std::string replace_once(std::string text, const std::string& from, const std::string& to) {
  const std::size_t at = text.find(from);
  REQUIRE(at != std::string::npos);
  return text.replace(at, from.size(), to);
}

}  // namespace

TEST_CASE("crc32 matches the IEEE / zlib check value") {
  CHECK(indicial::crc32("123456789", 9) == 0xCBF43926u);
  CHECK(indicial::crc32("", 0) == 0u);
  // Continuation equals one pass.
  const std::uint32_t part = indicial::crc32("12345", 5);
  CHECK(indicial::crc32("6789", 4, part) == 0xCBF43926u);
  CHECK(indicial::crc32("The quick brown fox jumps over the lazy dog", 43) == 0x414FA339u);
}

TEST_CASE("write -> read -> write is byte-identical and doubles round-trip exactly") {
  const Set models[4] = {indicial::test_models::table_one_model_one(),
                         indicial::test_models::table_one_model_two(),
                         indicial::test_models::lift_and_moment(),
                         indicial::test_models::roll_three()};
  for (const Set& m : models) {
    const std::string first = write(m);
    Set back{};
    indicial::ParseDiagnostic diag;
    REQUIRE_MESSAGE(parse(first, &back, &diag) == LoadStatus::ok, diag.line, ": ", diag.reason);
    check_models_equal(m, back);
    CHECK(write(back) == first);
  }
}

TEST_CASE("awkward doubles survive exactly (shortest round-trip form)") {
  Set m = indicial::test_models::table_one_model_one();
  auto& c = m.coefficients[0];
  c.a.power_coef[0] = -0.0;
  c.a.power_coef[1] = 0.1 + 0.2;            // 0.30000000000000004
  c.a.power_coef[2] = 1.0 / 3.0;
  c.rotary.power_coef[1] = 5e-324;          // smallest subnormal
  c.rotary.power_coef[2] = 1.7976931348623157e308;
  c.con = -0.0;
  const std::string text = write(m);
  CHECK(text.find("a_poly -0 0.30000000000000004 0.3333333333333333\n") != std::string::npos);
  CHECK(text.find("con -0\n") != std::string::npos);
  Set back{};
  indicial::ParseDiagnostic diag;
  REQUIRE_MESSAGE(parse(text, &back, &diag) == LoadStatus::ok, diag.line, ": ", diag.reason);
  check_models_equal(m, back);
  CHECK(std::signbit(back.coefficients[0].con));
  CHECK(write(back) == text);
}

TEST_CASE("delay_s round trip: written after con when not +0, byte-identical, bit for bit") {
  Set m = indicial::test_models::lift_and_moment();
  m.coefficients[0].delay_s = 0.1 + 0.2;  // 0.30000000000000004: shortest form needed
  m.coefficients[1].delay_s = 0.0237;
  const std::string text = write(m);
  CHECK(text.find("con 0.125\ndelay_s 0.30000000000000004\nend_coefficient\n") != std::string::npos);
  CHECK(text.find("delay_s 0.0237\nend_coefficient\n") != std::string::npos);
  Set back{};
  indicial::ParseDiagnostic diag;
  REQUIRE_MESSAGE(parse(text, &back, &diag) == LoadStatus::ok, diag.line, ": ", diag.reason);
  check_models_equal(m, back);
  CHECK(write(back) == text);
  // -0 survives like con's; +0 is not written, so undelayed files are unchanged.
  m.coefficients[0].delay_s = -0.0;
  m.coefficients[1].delay_s = 0.0;
  const std::string signed_zero = write(m);
  CHECK(signed_zero.find("delay_s -0\n") != std::string::npos);
  REQUIRE(parse(signed_zero, &back) == LoadStatus::ok);
  CHECK(std::signbit(back.coefficients[0].delay_s));
  CHECK(write(back) == signed_zero);
  CHECK(write(indicial::test_models::lift_and_moment()).find("delay_s") == std::string::npos);
}

TEST_CASE("the report's models are compact: Model II well under 2 KB") {
  const std::string one = write(indicial::test_models::table_one_model_one());
  const std::string two = write(indicial::test_models::table_one_model_two());
  MESSAGE("Model I: ", one.size(), " bytes; Model II: ", two.size(), " bytes");
  CHECK(one.size() < 1024);
  CHECK(two.size() < 1024);
}

TEST_CASE("the committed examples are what the writer produces from Table I") {
  const std::string dir = std::string(INDICIAL_SOURCE_DIR) + "/examples/";
  CHECK(indicial::read_text(dir + "tailless-model-1.coef") ==
        write(indicial::test_models::table_one_model_one()));
  CHECK(indicial::read_text(dir + "tailless-model-2.coef") ==
        write(indicial::test_models::table_one_model_two()));
  CHECK(indicial::read_text(dir + "synthetic-lift-moment.coef") ==
        write(indicial::test_models::lift_and_moment()));
}

TEST_CASE("table curves are prepared after parsing") {
  const Set m = indicial::test_models::lift_and_moment();
  Set back{};
  REQUIRE(parse(write(m), &back) == LoadStatus::ok);
  Set expected = m;
  indicial::prepare_static_table(expected.coefficients[0].static_curve);
  const auto& got = back.coefficients[0].static_curve;
  bool some_curvature = false;
  for (int i = 0; i < got.n_table; ++i) {
    CHECK(same_bits(got.table_second_derivative[i],
                    expected.coefficients[0].static_curve.table_second_derivative[i]));
    some_curvature = some_curvature || got.table_second_derivative[i] != 0.0;
  }
  CHECK(some_curvature);
}

TEST_CASE("comments, blank lines and CRLF line ends are accepted") {
  const std::string text = write(indicial::test_models::table_one_model_two());
  std::string edited = "# Model II, Table I\n\n" + replace_once(text, "coefficient Cm\n",
                                                                "coefficient Cm\n  # unsteady\n\n");
  Set back{};
  REQUIRE(parse(with_checksum(edited), &back) == LoadStatus::ok);
  check_models_equal(indicial::test_models::table_one_model_two(), back);
  std::string crlf;
  for (char ch : text.substr(0, text.rfind("checksum "))) {
    if (ch == '\n') crlf += '\r';
    crlf += ch;
  }
  REQUIRE(parse(with_checksum(crlf + "checksum 0\n"), &back) == LoadStatus::ok);
}

TEST_CASE("a file written with LF loads after its line ends became CRLF, unsigned again") {
  // git's core.autocrlf on Windows, or a Windows editor, turns every LF into CRLF, the
  // checksum line's included: the checksum of the LF bytes still matches (crc32_lf). Any other
  // change, a lone CR included, is still a mismatch.
  const std::string text = write(indicial::test_models::lift_and_moment());
  std::string crlf;
  for (char ch : text) {
    if (ch == '\n') crlf += '\r';
    crlf += ch;
  }
  Set back{};
  indicial::ParseDiagnostic diag;
  REQUIRE_MESSAGE(parse(crlf, &back, &diag) == LoadStatus::ok, diag.reason);
  check_models_equal(indicial::test_models::lift_and_moment(), back);
  CHECK(parse(replace_once(crlf, "con 0.125", "con 0.126"), &back) == LoadStatus::checksum_mismatch);
  CHECK(parse(replace_once(text, "con 0.125", "con 0.125\r"), &back) == LoadStatus::ok);  // CR before LF
  CHECK(parse(replace_once(text, "con 0.125", "con\r 0.125"), &back) == LoadStatus::checksum_mismatch);
  CHECK(indicial::crc32_lf(crlf.data(), crlf.rfind("checksum ")) ==
        indicial::crc32(text.data(), text.rfind("checksum ")));
}

TEST_CASE("damaged files are refused, each with its own status, and *out is untouched") {
  const std::string good = write(indicial::test_models::lift_and_moment());
  const Set sentinel = indicial::test_models::roll_three();

  auto expect = [&](const std::string& text, LoadStatus status) {
    Set out = sentinel;
    indicial::ParseDiagnostic diag;
    const LoadStatus s = parse(text, &out, &diag);
    CHECK_MESSAGE(s == status, "got ", indicial::to_string(s), " (line ", diag.line, ": ",
                  diag.reason, ") expected ", indicial::to_string(status));
    if (s != LoadStatus::ok) {
      CHECK(std::strlen(diag.reason) > 0);
      check_models_equal(out, sentinel);
    }
    return diag;
  };

  SUBCASE("empty") {
    expect("", LoadStatus::empty_input);
    expect(" \n\t\n", LoadStatus::empty_input);
  }
  SUBCASE("truncated anywhere") {
    // Every proper prefix is refused; prefixes that cut the file before its checksum is
    // complete say truncated.
    const std::size_t checksum_at = good.rfind("checksum ");
    for (std::size_t n = 1; n + 1 < good.size(); ++n) {
      Set out{};
      const LoadStatus s = parse(good.substr(0, n), &out);
      CHECK(s != LoadStatus::ok);
      if (n > good.find('\n') + 1 && n < checksum_at + 17) CHECK(s == LoadStatus::truncated);
    }
    // Without its trailing newline the file is complete and still accepted.
    CHECK(parse(good.substr(0, good.size() - 1)) == LoadStatus::ok);
  }
  SUBCASE("block without end_coefficient") {
    const indicial::ParseDiagnostic d =
        expect(with_checksum(replace_once(good, "con 0.125\nend_coefficient\ncoefficient Cm",
                                          "con 0.125\ncoefficient Cm")),
               LoadStatus::syntax_error);
    CHECK(d.line > 0);
    std::string last = good.substr(0, good.rfind("end_coefficient\n"));
    expect(with_checksum(last + "checksum 0\n"), LoadStatus::truncated);
  }
  SUBCASE("one byte flipped anywhere") {
    const std::size_t body_from = good.find('\n') + 1;
    const std::size_t checksum_at = good.rfind("checksum ");
    for (std::size_t i = 0; i < good.size(); ++i) {
      std::string bad = good;
      bad[i] = static_cast<char>(bad[i] ^ 0x01);
      Set out{};
      const LoadStatus s = parse(bad, &out);
      CHECK(s != LoadStatus::ok);
      if (i >= body_from && i + 1 < checksum_at) CHECK(s == LoadStatus::checksum_mismatch);
    }
  }
  SUBCASE("wrong version") {
    expect(replace_once(good, "indicial-coef 1", "indicial-coef 3"), LoadStatus::wrong_version);
    expect(replace_once(good, "indicial-coef 1", "bogus-format 1"), LoadStatus::syntax_error);
  }
  SUBCASE("over capacity") {
    // Nine powers (capacity 8), a third lag (capacity 2), a fourth coefficient (capacity 3),
    // nine knots, and 65 table rows (capacity 64).
    expect(with_checksum(replace_once(good, "rotary_poly 3.1", "rotary_poly 3.1 1 2 3 4 5 6 7 8")),
           LoadStatus::over_capacity);
    expect(with_checksum(replace_once(good, "lag_gain 2 -0.35\n", "lag_gain 2 -0.35\nlag_poly 3 1\n")),
           LoadStatus::over_capacity);
    std::string knots;
    for (int k = 0; k < 9; ++k) knots += "a_knot 0." + std::to_string(k + 1) + " 2 1\n";
    expect(with_checksum(replace_once(good, "con 0.125\n", knots)), LoadStatus::over_capacity);
    std::string rows;
    for (int i = 0; i < 65; ++i) rows += "static_table_point " + std::to_string(i) + " 1\n";
    Set m = indicial::test_models::table_one_model_one();
    std::string one = write(m);
    expect(with_checksum(replace_once(one, "static_poly 0 0.42 0.34 -1 0.4\n", rows)),
           LoadStatus::over_capacity);
    const std::string roll = write(indicial::test_models::roll_three());
    const std::size_t at = roll.rfind("checksum ");
    const std::string block = roll.substr(roll.find("coefficient CY"),
                                          roll.find("coefficient Cl") - roll.find("coefficient CY"));
    expect(with_checksum(roll.substr(0, at) + replace_once(block, "CY", "CD") + "checksum 0\n"),
           LoadStatus::over_capacity);
  }
  SUBCASE("syntax errors") {
    expect(with_checksum(replace_once(good, "con 0.125", "cone 0.125")), LoadStatus::syntax_error);
    expect(with_checksum(replace_once(good, "con 0.125", "con 0.12.5")), LoadStatus::syntax_error);
    expect(with_checksum(replace_once(good, "con 0.125", "con 0.125 7")), LoadStatus::syntax_error);
    expect(with_checksum(replace_once(good, "con 0.125", "con")), LoadStatus::syntax_error);
    expect(with_checksum(replace_once(good, "con 0.125", "con 0.125\ncon 1")), LoadStatus::syntax_error);
    expect(with_checksum(replace_once(good, "airspeed_mps", "airspeed_kts")), LoadStatus::syntax_error);
    expect(good + "axis pitch\n", LoadStatus::syntax_error);  // text after the checksum
    const indicial::ParseDiagnostic d =
        expect(with_checksum(replace_once(good, "con 0.125", "con 1x")), LoadStatus::syntax_error);
    std::size_t line = 1;
    for (char ch : good.substr(0, good.find("con 0.125"))) line += (ch == '\n');
    CHECK(d.line == line);
  }
  SUBCASE("invalid values") {
    expect(with_checksum(replace_once(good, "con 0.125", "con nan")), LoadStatus::invalid_value);
    expect(with_checksum(replace_once(good, "con 0.125", "con inf")), LoadStatus::invalid_value);
    expect(with_checksum(replace_once(good, "con 0.125", "con -inf")), LoadStatus::invalid_value);
    expect(with_checksum(replace_once(good, "con 0.125", "con 1e999")), LoadStatus::invalid_value);
    expect(with_checksum(replace_once(good, "static_table_point 0.13962634015954636",
                                      "static_table_point 0")),
           LoadStatus::invalid_value);  // not increasing
    expect(with_checksum(replace_once(good, "lag_gain 2 -0.35\n", "lag_gain 2 -0.35\nlag_gain 1 0.5\n")),
           LoadStatus::invalid_value);
    expect(with_checksum(replace_once(good, "a_knot 0.4363 2 8", "a_knot 0.4363 9 8")),
           LoadStatus::invalid_value);
    expect(with_checksum(replace_once(good, "a_knot 0.4363 2 8", "a_knot 0.4363 -1 8")),
           LoadStatus::invalid_value);
    expect(with_checksum(replace_once(good, "airspeed_mps 17.667762", "airspeed_mps 0")),
           LoadStatus::invalid_value);
    expect(with_checksum(replace_once(good, "reference_length_m 0.3765", "reference_length_m -1")),
           LoadStatus::invalid_value);
    expect(with_checksum(replace_once(good, "envelope_rad 0 1.2217304763960306",
                                      "envelope_rad 1.2217304763960306 0")),
           LoadStatus::invalid_value);
  }
  SUBCASE("a delay: >= 0 and finite, given once") {
    Set out{};
    CHECK(parse(with_checksum(replace_once(good, "con 0.125", "con 0.125\ndelay_s 0.01")), &out) ==
          LoadStatus::ok);
    CHECK(out.coefficients[0].delay_s == 0.01);
    CHECK(out.coefficients[1].delay_s == 0.0);
    CHECK(parse(with_checksum(replace_once(good, "con 0.125", "con 0.125\ndelay_s 0")), &out) ==
          LoadStatus::ok);
    CHECK(out.coefficients[0].delay_s == 0.0);
    expect(with_checksum(replace_once(good, "con 0.125", "con 0.125\ndelay_s -0.01")),
           LoadStatus::invalid_value);
    expect(with_checksum(replace_once(good, "con 0.125", "con 0.125\ndelay_s nan")),
           LoadStatus::invalid_value);
    expect(with_checksum(replace_once(good, "con 0.125", "con 0.125\ndelay_s 1e999")),
           LoadStatus::invalid_value);
    expect(with_checksum(replace_once(good, "con 0.125", "con 0.125\ndelay_s 0.01 0.02")),
           LoadStatus::syntax_error);
    expect(with_checksum(replace_once(good, "con 0.125", "con 0.125\ndelay_s 0.01\ndelay_s 0.01")),
           LoadStatus::syntax_error);
  }
}

TEST_CASE("the writer refuses what would not read back, and a small buffer") {
  std::size_t n = 1;
  char buffer[4096];
  Set m = indicial::test_models::table_one_model_two();
  const std::string full = write(m);
  CHECK(indicial::write_coef_file(m, buffer, full.size() - 1, &n) ==
        indicial::WriteStatus::buffer_too_small);
  CHECK(indicial::write_coef_file(m, buffer, full.size(), &n) == indicial::WriteStatus::ok);
  CHECK(n == full.size());
  m.coefficients[0].a.power_coef[1] = std::nan("");
  CHECK(indicial::write_coef_file(m, buffer, sizeof buffer, &n) == indicial::WriteStatus::invalid_model);
  m = indicial::test_models::table_one_model_two();
  m.coefficients[0].delay_s = -0.01;
  CHECK(indicial::write_coef_file(m, buffer, sizeof buffer, &n) == indicial::WriteStatus::invalid_model);
  m.coefficients[0].delay_s = std::nan("");
  CHECK(indicial::write_coef_file(m, buffer, sizeof buffer, &n) == indicial::WriteStatus::invalid_model);
  m = indicial::test_models::table_one_model_two();
  m.coefficients[0].lags[0].gain = 2.0;
  CHECK(indicial::write_coef_file(m, buffer, sizeof buffer, &n) == indicial::WriteStatus::invalid_model);
  CHECK(std::string(indicial::to_string(LoadStatus::checksum_mismatch)) == "checksum_mismatch");
}
