// tests/fuzz/fuzz_experiment.cpp -- libFuzzer target: the experiment-file loader
// (indicial::load_experiments, fitter/include/indicial/fitter/experiment_toml.hpp) on any byte string.
//
// The input is the TOML text, written to experiment.toml in a private scratch directory that
// also holds valid run and static-table CSVs (run.csv for every axis; static.csv with alpha_deg,
// static_beta.csv with beta_deg), so inputs that name them reach the checks that need data.
// Properties:
//  1. the only exception is indicial::InputError, and its message names a file;
//  2. an accepted experiment has at least one run, a known coefficient, positive length and
//     airspeed, a finite alpha0, and knots strictly inside the data's model-angle range.
// Inputs that mention /dev, /proc or /sys, or use \u escapes (which could spell those), are
// skipped: the loader reads whatever path a run entry names, and a device such as /dev/zero is
// an endless file, not a parser input.
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "fuzz_common.hpp"
#include "indicial/fitter/error.hpp"
#include "indicial/fitter/io.hpp"

namespace {

using indicial_fuzz::fuzz_fail;

std::string make_run_csv() {
  // 41 samples at 100 Hz of a 1 Hz sine in every axis's columns.
  std::string s = "# fuzz seed run\ntime_s,alpha_deg,q_degps,phi_deg,p_degps,psi_deg,r_degps,CL,Cm,CD,CY,Cl,Cn\n";
  for (int i = 0; i <= 40; ++i) {
    const double t = 0.01 * i;
    const double w = 2.0 * 3.141592653589793;
    const double a = 20.0 + 15.0 * std::sin(w * t);
    const double q = 15.0 * w * std::cos(w * t);
    const double c = 0.02 * a;
    s += indicial::format_double(t) + "," + indicial::format_double(a) + "," +
         indicial::format_double(q) + "," + indicial::format_double(a - 20.0) + "," +
         indicial::format_double(q) + "," + indicial::format_double(a - 20.0) + "," +
         indicial::format_double(q);
    for (int k = 0; k < 6; ++k) s += "," + indicial::format_double(c * (k + 1));
    s += "\n";
  }
  return s;
}

std::string make_static_csv(const char* angle_column) {
  std::string s = std::string(angle_column) + ",CL,Cm,CD,CY,Cl,Cn\n";
  for (int i = 0; i <= 16; ++i) {
    const double x = -60.0 + 7.5 * i;
    s += indicial::format_double(x);
    for (int k = 0; k < 6; ++k) s += "," + indicial::format_double(0.01 * x * (k + 1));
    s += "\n";
  }
  return s;
}

bool skipped(const std::string& text) {
  return text.find("/dev") != std::string::npos || text.find("/proc") != std::string::npos ||
         text.find("/sys") != std::string::npos || text.find("\\u") != std::string::npos ||
         text.find("\\U") != std::string::npos;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string dir = [] {
    const std::string d = indicial_fuzz::scratch_dir("toml");
    indicial_fuzz::write_file(d + "/run.csv", make_run_csv());
    indicial_fuzz::write_file(d + "/static.csv", make_static_csv("alpha_deg"));
    indicial_fuzz::write_file(d + "/static_beta.csv", make_static_csv("beta_deg"));
    return d;
  }();
  static const std::string path = dir + "/experiment.toml";
  const std::string text(reinterpret_cast<const char*>(data), size);
  if (skipped(text)) return 0;
  indicial_fuzz::write_file(path, text);
  try {
    // load_experiments: the single- and the multi-coefficient paths.
    const std::vector<indicial::Experiment> es = indicial::load_experiments(path);
    if (es.empty() || es.size() > 3) fuzz_fail("accepted no coefficient or more than the runtime holds");
    for (const indicial::Experiment& e : es) {
    if (e.runs.empty()) fuzz_fail("accepted with no runs");
    if (!(e.reference_length_m > 0.0) || !(e.airspeed_mps > 0.0) || !std::isfinite(e.alpha0_rad) ||
        !std::isfinite(e.reference_length_m) || !std::isfinite(e.airspeed_mps))
      fuzz_fail("accepted a bad length, airspeed or alpha0");
    const auto knots_inside = [&](const std::vector<double>& knots) {
      for (double k : knots)
        if (!(k > e.data_x_min_rad && k < e.data_x_max_rad)) fuzz_fail("accepted a knot outside the data");
    };
    knots_inside(e.model.a.knots_rad);
    knots_inside(e.model.b1.knots_rad);
    if (e.rotary.estimate) knots_inside(e.rotary.candidates.knots_rad);
    if (e.static_curve.kind == indicial::StaticKind::table &&
        e.static_curve.table_x_rad.size() > static_cast<std::size_t>(indicial::DefaultCapacity::max_table_points))
      fuzz_fail("accepted a static table beyond the runtime's capacity");
    }
  } catch (const indicial::InputError& e) {
    // The message names the experiment file or a file it names (a run, a static table).
    if (std::strchr(e.what(), ':') == nullptr) fuzz_fail("message names no file:", e.what());
  }
  return 0;
}
