// `indicial freqresp`: the linearised response of a model about a mean angle.
//
//   indicial freqresp MODEL.coef --alpha0-deg 20 --k-list 0.05,0.1,0.2 [--out F.csv]
//                     [--plot F.png] [--gnuplot EXE] [--airspeed-mps V] [--force]
//   (roll / yaw models: --mean-deg PHI0 or PSI0 instead of --alpha0-deg; alpha0 is the model's)
//
// Prints and writes, per coefficient and reduced frequency k = omega l / V, the in-phase
// component Re H (forced-oscillation derivative C_a_alpha-bar, per rad) and the out-of-phase
// component Im H / k (the C_a_q-bar equivalent). The derivation is in
// fitter/include/indicial/fitter/freqresp.hpp.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <sstream>
#include <string>

#include "command.hpp"
#include "indicial/fitter/error.hpp"
#include "indicial/fitter/freqresp.hpp"
#include "indicial/fitter/freqresp_output.hpp"
#include "indicial/fitter/io.hpp"
#include "indicial/fitter/output.hpp"
#include "indicial/fitter/predict.hpp"

namespace {

constexpr double kPi = 3.14159265358979323846;

struct FreqrespOptions {
  std::string model_path;
  std::string k_list;
  std::string out;
  std::string plot;
  std::string gnuplot = "gnuplot";
  double alpha0_deg = std::nan("");
  double mean_deg = std::nan("");
  double airspeed_mps = 0.0;
  bool force = false;
};

std::vector<double> parse_k_list(const std::string& text) {
  std::vector<double> ks;
  std::stringstream ss(text);
  std::string cell;
  while (std::getline(ss, cell, ',')) {
    std::size_t used = 0;
    double v = 0.0;
    try {
      v = std::stod(cell, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != cell.size() || !(v >= 0.0))
      throw indicial::InputError("--k-list", 0, "expected comma-separated numbers >= 0, found '" + cell + "'");
    ks.push_back(v);
  }
  if (ks.empty()) throw indicial::InputError("--k-list", 0, "no reduced frequencies given");
  return ks;
}

// Why refused: a linearised response is the model's response to a vanishing amplitude. With
// dynamic-stall families that limit says nothing useful: the f0 table is linear between its
// rows (half a degree apart in a polar), the shedding criterion is a switch of width w (0.05
// in C_N, about half a degree of angle), and a cycle through stall is what the families
// describe -- its hysteresis and its lift overshoot grow with the amplitude, not in proportion
// to it. A response per frequency is then a simulation at the amplitude of interest.
void refuse_stall_families(const indicial::ModelSet<double, indicial::FitCapacity>& m, const std::string& path) {
  using namespace indicial;
  for (int c = 0; c < m.n_coefficients; ++c)
    if (m.coefficients[c].stall.families != StallFamilies::none)
      throw InputError(path, 0, std::string("coefficient ") + m.coefficients[c].name +
                                    " has dynamic-stall families: its response depends on the amplitude (the "
                                    "separation table is linear only between rows, the shedding switch is a "
                                    "step about half a degree wide), so a linearised frequency response "
                                    "describes only fractions of a degree and none of the stall hysteresis; "
                                    "simulate the cycles at the amplitudes of interest instead (indicial simulate "
                                    "--model FILE --motion sine:..., or indicial predict)");
}

void run_freqresp(const FreqrespOptions& o) {
  using namespace indicial;
  const Overwrite overwrite = o.force ? Overwrite::replace : Overwrite::refuse;
  const auto model = std::make_unique<ModelSet<double, FitCapacity>>(read_model_file(o.model_path));
  refuse_stall_families(*model, o.model_path);
  double mean_deg = 0.0;
  // Why per axis: in pitch the oscillation is about alpha0; in roll and yaw alpha0 is fixed by
  // the model and the oscillation is about a mean roll / yaw angle.
  if (model->axis == Axis::pitch) {
    if (std::isnan(o.alpha0_deg)) throw InputError("--alpha0-deg", 0, "required for a pitch model");
    if (!std::isnan(o.mean_deg)) throw InputError("--mean-deg", 0, "pitch models take --alpha0-deg");
    mean_deg = o.alpha0_deg;
  } else {
    if (!std::isnan(o.alpha0_deg))
      throw InputError("--alpha0-deg", 0, std::string("a ") + axis_name(model->axis) +
                                              " model has its own alpha0; give --mean-deg (the mean " +
                                              (model->axis == Axis::roll ? "phi" : "psi") + ", default 0)");
    mean_deg = std::isnan(o.mean_deg) ? 0.0 : o.mean_deg;
  }
  if (o.airspeed_mps < 0.0) throw InputError("--airspeed-mps", 0, "must be > 0");
  const double airspeed = o.airspeed_mps > 0.0 ? o.airspeed_mps : model->airspeed_mps;
  const std::vector<double> ks = parse_k_list(o.k_list);
  const auto r = linearised_response(*model, mean_deg * kPi / 180.0, ks, airspeed);

  std::printf("freqresp: %s about %s = %g deg (model angle %g deg), V = %g m/s, l = %g m\n",
              o.model_path.c_str(), model->axis == Axis::pitch ? "alpha" : model->axis == Axis::roll ? "phi" : "psi",
              mean_deg, r.front().x0_rad * 180.0 / kPi, airspeed, model->reference_length_m);
  for (const auto& c : r) {
    std::printf("%s: static slope %.6g /rad, steady-state slope H(0) %.6g /rad, C_aq(x0) %.6g\n",
                c.coefficient.c_str(), c.static_slope, c.steady_state_slope, c.rotary);
    std::printf("  %8s %10s %14s %14s %12s %10s\n", "k", "f_hz", "in_phase", "out_of_phase", "|H|", "phase_deg");
    for (const auto& p : c.points)
      std::printf("  %8.4g %10.4g %14.6g %14.6g %12.6g %10.4g\n", p.k, p.freq_hz, p.in_phase,
                  p.out_of_phase, p.magnitude, p.phase_deg);
  }
  // Refuse before writing anything, and draw the plot (the step that can fail on gnuplot) before
  // the table, so that outputs appear all or none (barring disk errors).
  if (overwrite == Overwrite::refuse)
    for (const std::string& f : {o.out, o.plot})
      if (!f.empty() && std::filesystem::exists(f)) throw InputError(f, 0, "output file exists (use --force to replace it)");
  if (!o.plot.empty()) {
    write_frequency_response_plot(r, o.plot,
                                  "indicial freqresp: " + std::filesystem::path(o.model_path).filename().string() +
                                      " about " + format_double(mean_deg) + " deg",
                                  overwrite, o.gnuplot);
    std::printf("freqresp: plot -> %s\n", o.plot.c_str());
  }
  if (!o.out.empty()) {
    std::vector<std::string> comments = {
        "indicial freqresp " + o.model_path + " (mean angle " + format_double(mean_deg) + " deg, V " +
            format_double(airspeed) + " m/s)",
        "H = dC/d(motion angle) per rad; in_phase = Re H; out_of_phase = Im H / k; k = omega l / V"};
    refuse_output_onto_input(o.out, {o.model_path});
    write_file_atomically(o.out, frequency_response_csv(r, comments), overwrite);
    std::printf("freqresp: table -> %s\n", o.out.c_str());
  }
}

const indicial::tools::RegisterCommand register_freqresp([](CLI::App& app) {
  auto opt = std::make_shared<FreqrespOptions>();
  CLI::App* sub = app.add_subcommand(
      "freqresp",
      "Linearised frequency response of a model about the steady state at a mean angle:\n"
      "in-phase Re H and out-of-phase Im H / k (forced-oscillation derivatives, per rad)\n"
      "against the reduced frequency k = omega l / V. H = dC/d(angle) for a small oscillation.");
  sub->add_option("MODEL", opt->model_path, "coefficient file (.coef)")->required();
  sub->add_option("--alpha0-deg", opt->alpha0_deg, "pitch: the mean angle of attack, deg");
  sub->add_option("--mean-deg", opt->mean_deg, "roll / yaw: the mean phi or psi, deg (default 0)");
  sub->add_option("--k-list", opt->k_list, "comma-separated reduced frequencies, e.g. 0.05,0.1,0.2")
      ->required();
  sub->add_option("--out", opt->out, "CSV table");
  sub->add_option("--plot", opt->plot, "PNG plot (gnuplot)");
  sub->add_option("--gnuplot", opt->gnuplot, "gnuplot executable (default: gnuplot on PATH)");
  sub->add_option("--airspeed-mps", opt->airspeed_mps, "airspeed (default: the model's reference airspeed)");
  sub->add_flag("--force", opt->force, "replace existing outputs");
  sub->callback([opt]() { run_freqresp(*opt); });
});

}  // namespace
