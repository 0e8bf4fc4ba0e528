// Typed access to a parsed TOML table with one-line errors naming the file and line. Internal
// to the experiment reader (experiment_toml.cpp, experiment_sections.cpp).
#pragma once

#include <cmath>
#include <cstdint>
#include <set>
#include <string>
#include <utility>
#include <vector>
#include <toml++/toml.h>

#include "indicial/fitter/error.hpp"
#include "indicial/fitter/experiment_checks.hpp"
#include "indicial/fitter/experiment_toml.hpp"

namespace indicial::detail {

inline constexpr double kDegToRad = 3.14159265358979323846 / 180.0;
inline constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;

class TomlReader {
 public:
  explicit TomlReader(std::string file) : file_(std::move(file)) {}

  [[noreturn]] void fail(const toml::source_region& where, const std::string& problem) const {
    throw InputError(file_, static_cast<long>(where.begin.line), problem);
  }
  [[noreturn]] void fail(const toml::node& node, const std::string& problem) const {
    fail(node.source(), problem);
  }

  // Every key of `table` must be in `allowed`; `where` prefixes the key in messages.
  void check_keys(const toml::table& table, const std::set<std::string>& allowed,
                  const std::string& where) const {
    for (auto&& [key, node] : table) {
      (void)node;
      if (allowed.count(std::string(key.str())) == 0) {
        std::string list;
        for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
        fail(key.source(), "unknown key '" + where + std::string(key.str()) +
                               "' (allowed here: " + list + ")");
      }
    }
  }

  static std::string type_name(const toml::node& n) {
    switch (n.type()) {
      case toml::node_type::string: return "a string";
      case toml::node_type::integer: return "an integer";
      case toml::node_type::floating_point: return "a number";
      case toml::node_type::boolean: return "a boolean";
      case toml::node_type::array: return "an array";
      case toml::node_type::table: return "a table";
      default: return "a date/time";
    }
  }

  double number(const toml::node& n, const std::string& key) const {
    if (n.is_integer()) return static_cast<double>(*n.value<int64_t>());
    if (n.is_floating_point()) {
      const double v = *n.value<double>();
      if (!std::isfinite(v)) fail(n, "'" + key + "' must be finite");
      return v;
    }
    fail(n, "wrong type: '" + key + "' must be a number, found " + type_name(n));
  }
  long integer(const toml::node& n, const std::string& key) const {
    if (!n.is_integer()) fail(n, "wrong type: '" + key + "' must be an integer, found " + type_name(n));
    return static_cast<long>(*n.value<int64_t>());
  }
  bool boolean(const toml::node& n, const std::string& key) const {
    if (!n.is_boolean()) fail(n, "wrong type: '" + key + "' must be true or false, found " + type_name(n));
    return *n.value<bool>();
  }
  // A string naming a value of enum E (its table in experiment_toml.hpp, names_of); refuses
  // anything else with the list: 'model.delay' must be "none" or "estimated", found "yes".
  template <class E>
  E choice(const toml::node& n, const std::string& key) const {
    const std::string s = string(n, key);
    const auto& choices = names_of(E{});
    std::string list;
    for (std::size_t i = 0; i < choices.size(); ++i) {
      if (s == choices[i].name) return choices[i].value;
      list += std::string(i == 0 ? "" : i + 1 == choices.size() ? " or " : ", ") + "\"" +
              choices[i].name + "\"";
    }
    fail(n, "'" + key + "' must be " + list + ", found \"" + s + "\"");
  }
  std::string string(const toml::node& n, const std::string& key) const {
    if (!n.is_string()) fail(n, "wrong type: '" + key + "' must be a string, found " + type_name(n));
    return *n.value<std::string>();
  }
  const toml::array& array(const toml::node& n, const std::string& key) const {
    if (!n.is_array()) fail(n, "wrong type: '" + key + "' must be an array, found " + type_name(n));
    return *n.as_array();
  }
  const toml::table& table(const toml::node& n, const std::string& key) const {
    if (!n.is_table()) fail(n, "wrong type: '" + key + "' must be a table, found " + type_name(n));
    return *n.as_table();
  }
  std::vector<double> numbers(const toml::node& n, const std::string& key) const {
    std::vector<double> out;
    for (const auto& e : array(n, key)) out.push_back(number(e, key + " entry"));
    return out;
  }
  std::vector<int> powers(const toml::node& n, const std::string& key) const {
    std::vector<int> out;
    for (const auto& e : array(n, key)) {
      const long p = integer(e, key + " entry");
      if (p < 0 || p >= FitCapacity::max_powers) {
        fail(e, "'" + key + "': power " + std::to_string(p) + " is outside 0.." +
                    std::to_string(FitCapacity::max_powers - 1));
      }
      if (!out.empty() && p <= out.back()) fail(e, "'" + key + "' must be strictly increasing");
      out.push_back(static_cast<int>(p));
    }
    return out;
  }
  std::vector<int> degree_powers(const toml::node& n, const std::string& key) const {
    const long d = integer(n, key);
    if (d < 0 || d >= FitCapacity::max_powers) {
      fail(n, "'" + key + "' must be 0.." + std::to_string(FitCapacity::max_powers - 1));
    }
    std::vector<int> out;
    for (int p = 0; p <= static_cast<int>(d); ++p) out.push_back(p);
    return out;
  }
  // A spline's knots in deg, as rad, with the checks Python's knots get too (check_knot_list).
  std::vector<double> knots_deg(const toml::node& n, const std::string& key) const {
    std::vector<double> out;
    const toml::array& entries = array(n, key);
    for (const auto& e : entries) out.push_back(number(e, key + " entry") * kDegToRad);
    check_knot_list(out, key, [&](std::size_t i, const std::string& problem) {
      const toml::node& at = i < entries.size() ? *entries.get(i) : n;
      return InputError(file_, static_cast<long>(at.source().begin.line), problem);
    });
    return out;
  }

  const std::string& file() const { return file_; }

 private:
  std::string file_;
};

}  // namespace indicial::detail
