// `indicial simulate`: built-in simulated cases, or any model on any motion.
//
//   indicial simulate --case tailless-model-1 --out DIR [--snr 40] [--seed 1] [--force]
//   indicial simulate --model FILE.coef --motion SPEC --out FILE.csv [--snr S] [--seed N] [--force]
//
// The truth comes from the reference integration in fitter/include/indicial/fitter/simulate.hpp.
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>

#include "command.hpp"
#include "indicial/coef_file.hpp"
#include "indicial/fitter/dynamic_stall.hpp"
#include "indicial/fitter/error.hpp"
#include "indicial/fitter/io.hpp"
#include "indicial/fitter/output.hpp"
#include "indicial/fitter/simulate.hpp"

namespace {

struct SimulateOptions {
  std::string case_name;
  std::string model_path;
  std::string motion;
  std::string out;
  std::string snr = "inf";
  std::string noise;  // empty: the case's default (white; ar1:phi=0.8 for dynamic-stall)
  std::uint64_t seed = 1;
  bool force = false;
  bool list = false;
};

void run_simulate(const SimulateOptions& o) {
  using namespace indicial;
  const Overwrite overwrite = o.force ? Overwrite::replace : Overwrite::refuse;
  if (o.list) {
    for (const auto& c : simulation_cases()) std::printf("%-20s %s\n", c.name.c_str(), c.description.c_str());
    std::printf("%-20s %s\n", "dynamic-stall",
                "Goman-Khrabrov NACA 0012-like dynamic stall (truth outside the model class): 14 "
                "phase-averaged cycles, CL and Cm, AR(1) noise");
    return;
  }
  const double snr = parse_snr(o.snr);
  const NoiseModel noise = parse_noise_spec(o.noise.empty() ? "white" : o.noise);
  if (o.out.empty()) throw InputError("--out", 0, "an output path is required");
  if (o.case_name == "dynamic-stall") {
    const auto& campaign = dynamic_stall::default_campaign();
    const NoiseModel ds_noise = o.noise.empty() ? campaign.default_noise : noise;
    const std::vector<double> sigma =
        dynamic_stall::write_campaign(campaign, o.out, snr, o.seed, ds_noise, overwrite);
    std::printf("simulate: wrote %zu phase-averaged cycles, static.csv, cycles.csv, experiment-CL.toml and "
                "experiment-Cm.toml to %s\n", campaign.cycles.size(), o.out.c_str());
    std::printf("simulate: noise %s, SNR %s, seed %llu: sigma CL %.6g, Cm %.6g (raw samples)\n",
                noise_spec_text(ds_noise).c_str(), o.snr.c_str(), static_cast<unsigned long long>(o.seed),
                sigma.at(0), sigma.at(1));
    return;
  }
  if (!o.case_name.empty()) {
    const SimulationCase& c = find_simulation_case(o.case_name);
    const std::vector<double> sigma = write_simulation_case(c, o.out, snr, o.seed, overwrite, noise);
    std::printf("simulate: wrote %zu runs, experiment.toml and truth.coef to %s\n", c.run_files.size(),
                o.out.c_str());
    for (std::size_t i = 0; i < sigma.size(); ++i) {
      std::printf("simulate: %s noise sigma %.6g (SNR %s, seed %llu, noise %s)\n", c.truth.coefficients[i].name,
                  sigma[i], o.snr.c_str(), static_cast<unsigned long long>(o.seed), noise_spec_text(noise).c_str());
    }
    return;
  }
  if (o.model_path.empty()) throw InputError("simulate", 0, "give --case NAME or --model FILE.coef --motion SPEC");
  if (o.motion.empty()) throw InputError("--motion", 0, "--model needs --motion SPEC");
  const std::string text = read_text(o.model_path);
  auto loaded = std::make_unique<ModelSet<double, FitCapacity>>();
  ParseDiagnostic diag;
  const LoadStatus st = parse_coef_file(text.data(), text.size(), loaded.get(), &diag);
  if (st != LoadStatus::ok) {
    throw InputError(o.model_path, static_cast<long>(diag.line),
                     std::string(diag.reason) + " (" + to_string(st) + ")");
  }
  const MotionSpec motion = parse_motion_spec(o.motion, loaded->axis);
  std::vector<SimulatedRun> runs{simulate_reference(*loaded, motion)};
  const std::vector<double> sigma = add_measurement_noise(runs, snr, o.seed, noise);
  std::vector<std::string> comments = {"indicial simulate --model " + o.model_path + " --motion " + o.motion,
                                       "truth: continuous model integrated by Dormand-Prince 5(4), "
                                       "abs/rel tolerance 1e-12"};
  for (std::size_t i = 0; i < sigma.size(); ++i) {
    comments.push_back(std::string("noise: ") + loaded->coefficients[i].name + " sigma " +
                       format_double(sigma[i]) + " (SNR " + o.snr + ", seed " + std::to_string(o.seed) +
                       ", noise " + noise_spec_text(noise) + ", sigma = the noise's marginal std)");
  }
  // (A csv: motion names its file after the prefix.)
  refuse_output_onto_input(o.out, {o.model_path, o.motion.rfind("csv:", 0) == 0 ? o.motion.substr(4) : std::string()});
  write_file_atomically(o.out, simulated_run_csv(*loaded, runs.front(), comments), overwrite);
  std::printf("simulate: wrote %zu samples to %s\n", runs.front().time_s.size(), o.out.c_str());
}

const indicial::tools::RegisterCommand register_simulate([](CLI::App& app) {
  auto opt = std::make_shared<SimulateOptions>();
  CLI::App* sub = app.add_subcommand(
      "simulate",
      "Simulate a model with an accurate reference integration (Dormand-Prince, tolerance 1e-12).\n"
      "  --case NAME --out DIR          a built-in case: run CSVs, experiment.toml, truth.coef\n"
      "      (--case dynamic-stall: phase-averaged cycles with CL and Cm, static.csv, cycles.csv,\n"
      "       experiment-CL.toml and experiment-Cm.toml; truth outside the model class)\n"
      "  --model F.coef --motion SPEC --out F.csv   any model on a motion (its lags and any\n"
      "      dynamic-stall families: separation point, vortex lift and clock):\n"
      "      sine:alpha0_deg=35,amp_deg=35,freq_hz=0.5,cycles=3,dt_s=0.01  (roll/yaw: mean_deg)\n"
      "      ramp:from_deg=0,to_deg=70,rate_dps=30,dt_s=0.01[,hold_before_s=0.5,hold_after_s=2]\n"
      "      csv:PATH  (time_s and the angle column; C2 cubic spline between samples)\n"
      "Noise: Gaussian on the coefficient with marginal std sigma = RMS(y over all runs) / SNR;\n"
      "  --noise white (default), ar1:phi=0.8 (AR(1), lag-1 correlation phi) or\n"
      "  turbulence:cutoff_hz=2[,zeta=0.7] (white noise through a 2nd-order low pass).");
  auto* c = sub->add_option("--case", opt->case_name, "built-in case (see --list)");
  auto* m = sub->add_option("--model", opt->model_path, "coefficient file to simulate");
  sub->add_option("--motion", opt->motion, "motion SPEC for --model")->needs(m);
  c->excludes(m);
  sub->add_option("--out", opt->out, "output directory (--case) or CSV file (--model)");
  sub->add_option("--snr", opt->snr, "signal-to-noise ratio, or inf for no noise (default inf)");
  sub->add_option("--seed", opt->seed, "noise seed (default 1)");
  sub->add_option("--noise", opt->noise, "white (default; dynamic-stall: ar1:phi=0.8), ar1:phi=P or turbulence:cutoff_hz=F[,zeta=Z]");
  sub->add_flag("--force", opt->force, "replace existing output");
  sub->add_flag("--list", opt->list, "list the built-in cases");
  sub->callback([opt]() { run_simulate(*opt); });
});

}  // namespace
