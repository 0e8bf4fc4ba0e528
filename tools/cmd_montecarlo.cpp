// `indicial montecarlo`: repeat a simulated case over N noise seeds and compare the scatter of
// the estimates with their Cramer-Rao and colored bounds.
//
//   indicial montecarlo --case NAME --seeds N [--snr S] [--first-seed K] [--threads T] --out DIR [--force]
//
// Writes DIR/montecarlo.json and DIR/montecarlo.md (fitter/include/indicial/fitter/montecarlo.hpp
// says what is computed). Progress goes to stderr: a live counter when stderr is a terminal,
// otherwise one line every 10 %; none with --quiet.
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <memory>
#include <string>

#include "command.hpp"
#include "indicial/fitter/error.hpp"
#include "indicial/fitter/montecarlo.hpp"
#include "indicial/fitter/output.hpp"

namespace {

struct MonteCarloCli {
  indicial::MonteCarloOptions mc;
  std::string out;
  std::string noise = "white";
  bool force = false;
  bool quiet = false;
};

void run_montecarlo(const MonteCarloCli& o) {
  using namespace indicial;
  if (o.out.empty()) throw InputError("--out", 0, "an output directory is required");
  const Overwrite overwrite = o.force ? Overwrite::replace : Overwrite::refuse;
  find_simulation_case(o.mc.case_name);  // an unknown case fails here, before any work
  MonteCarloOptions mc = o.mc;
  mc.noise = parse_noise_spec(o.noise);
  { OutputDir probe(o.out, overwrite); }  // refuse a non-empty DIR before the long run

  const bool tty = ::isatty(STDERR_FILENO) != 0;
  const auto t0 = std::chrono::steady_clock::now();
  int last_decile = 0;
  auto progress = [&](int done, int total) {
    const double el = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const double eta = done > 0 ? el * (total - done) / done : 0.0;
    if (tty) {
      std::fprintf(stderr, "\rmontecarlo: %d/%d seeds fitted (%.0f s elapsed, about %.0f s left)   ", done,
                   total, el, eta);
      if (done == total) std::fputc('\n', stderr);
    } else {
      // Why deciles: a log file gets ten lines, not one per seed.
      const int decile = static_cast<int>((10LL * done) / total);
      if (decile > last_decile) {
        last_decile = decile;
        std::fprintf(stderr, "montecarlo: %d%% (%d/%d seeds, %.0f s elapsed)\n", decile * 10, done, total, el);
      }
    }
    std::fflush(stderr);
  };
  const MonteCarloResult res = o.quiet ? run_monte_carlo(mc) : run_monte_carlo(mc, progress);

  OutputDir out(o.out, overwrite);
  const std::string md = monte_carlo_markdown(res);
  out.write("montecarlo.json", monte_carlo_json(res).dump(2) + "\n");
  out.write("montecarlo.md", md);
  out.commit();

  std::printf("montecarlo: %s, noise %s, SNR %g, seeds %llu..%llu, noise sigma %.6g, %d fitted, %zu failed, %.1f s\n",
              o.mc.case_name.c_str(), noise_spec_text(mc.noise).c_str(), o.mc.snr, static_cast<unsigned long long>(o.mc.first_seed),
              static_cast<unsigned long long>(o.mc.first_seed + static_cast<std::uint64_t>(o.mc.seeds) - 1),
              res.noise_sigma, res.fitted, res.failed_seeds.size(), res.elapsed_s);
  std::printf("  %-10s %10s %12s %11s %11s %9s %11s %9s\n", "parameter", "truth", "mean", "std", "mean CR",
              "std/CR", "mean col.", "std/col.");
  for (const MonteCarloParameter& p : res.parameters) {
    std::printf("  %-10s %10.5g %12.6g %11.4g %11.4g %9.3f %11.4g %9.3f\n", p.name.c_str(), p.truth, p.mean,
                p.std_dev, p.mean_cr_bound, p.ratio, p.mean_cr_bound_colored, p.ratio_colored);
  }
  std::printf("montecarlo: wrote %s/montecarlo.json and montecarlo.md\n", o.out.c_str());
}

const indicial::tools::RegisterCommand register_montecarlo([](CLI::App& app) {
  auto opt = std::make_shared<MonteCarloCli>();
  CLI::App* sub = app.add_subcommand(
      "montecarlo",
      "Repeat a built-in simulated case over N noise seeds (fitted on T threads) and report, per\n"
      "parameter: truth, mean estimate, empirical std, mean Cramer-Rao bound, mean colored bound,\n"
      "and std / bound. Writes DIR/montecarlo.json and DIR/montecarlo.md.");
  sub->add_option("--case", opt->mc.case_name, "built-in case (see `indicial simulate --list`)")->required();
  sub->add_option("--seeds", opt->mc.seeds, "number of noise seeds (>= 2)")->required();
  sub->add_option("--snr", opt->mc.snr, "signal-to-noise ratio (default 40)");
  sub->add_option("--noise", opt->noise,
                  "noise: white (default), ar1:phi=0.8 or turbulence:cutoff_hz=2[,zeta=0.7]; sigma is "
                  "the noise's marginal std");
  sub->add_option("--first-seed", opt->mc.first_seed, "first seed (default 1): seeds K..K+N-1");
  sub->add_option("--threads", opt->mc.threads, "worker threads (default 2)");
  sub->add_option("--out", opt->out, "output directory (refused if not empty, unless --force)")->required();
  sub->add_flag("--force", opt->force, "replace the contents of a non-empty output directory");
  sub->add_flag("--quiet", opt->quiet, "no progress lines on stderr");
  sub->callback([opt]() { run_montecarlo(*opt); });
});

}  // namespace
