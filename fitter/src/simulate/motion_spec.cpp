// The --motion spec parser: "sine:...", "ramp:...", "csv:FILE" -> MotionSpec (see
// indicial/fitter/simulate.hpp, parse_motion_spec). Text in, numbers out; the motion itself is
// evaluated by the reference integrator (simulate.cpp).
#include <cmath>
#include <string>
#include <vector>

#include "indicial/fitter/error.hpp"
#include "indicial/fitter/io.hpp"
#include "indicial/fitter/simulate.hpp"
#include "simulate/spec_keys.hpp"

namespace indicial {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegToRad = kPi / 180.0;

}  // namespace

// ==========================================================================================
// Motions
// ==========================================================================================
MotionSpec parse_motion_spec(const std::string& spec, Axis axis) {
  const std::size_t colon = spec.find(':');
  if (colon == std::string::npos) {
    throw InputError("--motion", 0, "expected sine:..., ramp:... or csv:PATH, found '" + spec + "'");
  }
  const std::string kind = spec.substr(0, colon);
  const std::string rest = spec.substr(colon + 1);
  MotionSpec m;
  if (kind == "csv") {
    RunCsvOptions read;
    read.frequency_source = FrequencySource::none;
    const Run run = read_run_csv(rest, axis, "", CoefficientPresence::optional, read);
    m.kind = MotionKind::samples;
    m.time_s = run.time_s;
    m.angle_rad = run.motion_angle_rad;
    m.dt_s = (run.time_s.back() - run.time_s.front()) / static_cast<double>(run.size() - 1);
    m.source = rest;
    return m;
  }
  detail::SpecKeys kv("--motion", kind + " motion", rest);
  using Need = detail::SpecKeys::Need;
  auto take = [&](const std::string& key, bool required, double fallback) {
    return kv.take(key, required ? Need::required : Need::optional, fallback);
  };
  if (kind == "sine") {
    m.kind = MotionKind::sine;
    const bool has_alpha0 = kv.has("alpha0_deg");
    if (has_alpha0 && axis != Axis::pitch) {
      throw InputError("--motion", 0, "in roll and yaw the sine's mean is 'mean_deg' (alpha0 is "
                                      "the model's fixed angle of attack)");
    }
    if (has_alpha0 && kv.has("mean_deg")) {
      throw InputError("--motion", 0, "give 'alpha0_deg' or 'mean_deg', not both");
    }
    m.mean_rad = (has_alpha0 ? take("alpha0_deg", true, 0) : take("mean_deg", true, 0)) * kDegToRad;
    m.amplitude_rad = take("amp_deg", true, 0) * kDegToRad;
    m.freq_hz = take("freq_hz", true, 0);
    m.cycles = take("cycles", false, 3.0);
    m.dt_s = take("dt_s", false, 0.01);
    if (!(m.freq_hz > 0)) throw InputError("--motion", 0, "'freq_hz' must be > 0");
    if (!(m.cycles > 0)) throw InputError("--motion", 0, "'cycles' must be > 0");
  } else if (kind == "ramp") {
    m.kind = MotionKind::ramp;
    m.from_rad = take("from_deg", true, 0) * kDegToRad;
    m.to_rad = take("to_deg", true, 0) * kDegToRad;
    m.rate_radps = take("rate_dps", true, 0) * kDegToRad;
    m.dt_s = take("dt_s", false, 0.01);
    m.hold_before_s = take("hold_before_s", false, 0.5);
    m.hold_after_s = take("hold_after_s", false, 2.0);
    if (!(m.rate_radps > 0)) throw InputError("--motion", 0, "'rate_dps' must be > 0");
    if (m.hold_before_s < 0 || m.hold_after_s < 0) {
      throw InputError("--motion", 0, "hold times must be >= 0");
    }
  } else {
    throw InputError("--motion", 0, "unknown motion kind '" + kind + "' (sine, ramp or csv)");
  }
  kv.require_all_taken();
  if (!(m.dt_s > 0)) throw InputError("--motion", 0, "'dt_s' must be > 0");
  return m;
}

}  // namespace indicial
