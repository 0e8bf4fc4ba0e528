// spec_keys.hpp (internal) -- the "kind:key=value,key=value" option spellings of --motion and
// --noise, and the numbers of such options (--snr), parsed once.
#pragma once

#include <cmath>
#include <map>
#include <sstream>
#include <string>

#include "indicial/fitter/error.hpp"

namespace indicial::detail {

// The whole of `text` as a double (std::stod: decimal, exponent, "inf", "nan"); false when
// text is empty or has anything after the number.
inline bool parse_whole_number(const std::string& text, double& value) {
  std::size_t used = 0;
  try {
    value = std::stod(text, &used);
  } catch (const std::exception&) {
    return false;
  }
  return !text.empty() && used == text.size();
}

// The numeric keys of one spec. Every error is InputError(option, 0, ...): a bad number, a
// key without '=', a key given twice, a required key missing, a key nobody took.
class SpecKeys {
 public:
  enum class Need { required, optional };

  SpecKeys(std::string option, std::string kind, const std::string& body)
      : option_(std::move(option)), kind_(std::move(kind)) {
    std::stringstream ss(body);
    std::string item;
    while (std::getline(ss, item, ',')) {
      const std::size_t eq = item.find('=');
      if (eq == std::string::npos) fail("expected key=value, found '" + item + "'");
      const std::string key = item.substr(0, eq);
      if (values_.count(key)) fail("key '" + key + "' given twice");
      values_[key] = number(key, item.substr(eq + 1));
    }
  }

  bool has(const std::string& key) const { return values_.count(key) > 0; }

  // The key's value (removed from the spec), or fallback when optional and absent.
  double take(const std::string& key, Need need, double fallback = 0.0) {
    const auto it = values_.find(key);
    if (it == values_.end()) {
      if (need == Need::required) fail(kind_ + " needs '" + key + "'");
      return fallback;
    }
    const double v = it->second;
    values_.erase(it);
    return v;
  }

  // Refuses a key no take() consumed.
  void require_all_taken() const {
    if (!values_.empty()) fail("unknown key '" + values_.begin()->first + "' in " + kind_);
  }

  [[noreturn]] void fail(const std::string& problem) const { throw InputError(option_, 0, problem); }

 private:
  double number(const std::string& key, const std::string& text) const {
    double v = 0.0;
    if (!parse_whole_number(text, v) || !std::isfinite(v))
      fail("'" + key + "' needs a finite number, found '" + text + "'");
    return v;
  }

  std::string option_, kind_;
  std::map<std::string, double> values_;
};

}  // namespace indicial::detail
