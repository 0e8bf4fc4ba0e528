// `indicial polar E.toml --out static.csv`: a static table from quasi-static cycles (the runs
// of E, read as fit reads them; E needs no [static] yet), for `[static] table` and
// `model.stall_polar`. See fitter/.../quasi_static_polar.hpp for the recipe.
//
//   indicial polar E.toml --out static.csv [--bin-deg 1] [--min-samples 4]
//                  [--stroke outward|rising|both] [--hold-deg 0] [--force]
#include <algorithm>
#include <cstdio>
#include <fmt/format.h>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "command.hpp"
#include "indicial/fitter/error.hpp"
#include "indicial/fitter/experiment_toml.hpp"
#include "indicial/fitter/output.hpp"
#include "indicial/fitter/provenance.hpp"
#include "indicial/fitter/quasi_static_polar.hpp"

namespace {

struct PolarCommandOptions {
  std::string experiment;
  std::string out;
  indicial::QuasiStaticPolarOptions polar;
  bool force = false;
};

std::map<std::string, indicial::PolarStroke> stroke_names() {
  std::map<std::string, indicial::PolarStroke> names;
  for (const auto& nv : indicial::polar_stroke_names) names[nv.name] = nv.value;
  return names;
}

void run_polar(const PolarCommandOptions& o) {
  using namespace indicial;
  if (const std::string why = o.polar.invalid_reason(); !why.empty())
    throw InputError("--bin-deg / --min-samples / --hold-deg", 0, why);
  const Overwrite overwrite = o.force ? Overwrite::replace : Overwrite::refuse;
  const std::vector<Experiment> es = load_experiment_runs(o.experiment);
  for (const Experiment& e : es) tools::print_warnings(e.warnings);
  const QuasiStaticPolar p = quasi_static_polar(es, o.polar);
  // --force replaces outputs, never an input: the experiment file and every run file it names.
  refuse_output_onto_input(o.out, experiment_input_paths(es.front()));
  const char* stroke = o.polar.stroke == PolarStroke::outward ? "the outward samples (model angle moving away from zero)"
                       : o.polar.stroke == PolarStroke::rising ? "the rising samples (model angle increasing)"
                                                               : "every sample";
  std::vector<std::string> comments = {
      "indicial polar " + o.experiment,
      fmt::format("{} of {} run(s), in {:g} deg bins centred on multiples of it; a row per bin of >= {} samples (its "
                  "mean angle and mean coefficients; {} bin(s) dropped, {} samples used)",
                  stroke, p.runs, o.polar.bin_deg, o.polar.min_samples, p.bins_dropped, p.samples_used)};
  if (p.held_rows > 0)
    comments.push_back(fmt::format("the first and last rows hold the end values {:g} deg beyond the binned rows (--hold-deg)",
                                   o.polar.hold_deg));
  write_file_atomically(o.out, quasi_static_polar_csv(p, es.front().axis, comments), overwrite);
  constexpr double kDegPerRad = 57.29577951308232;
  std::printf("polar: %zu rows, %.4g to %.4g deg, from %d run(s) -> %s\n", p.x_rad.size(), p.x_rad.front() * kDegPerRad,
              p.x_rad.back() * kDegPerRad, p.runs, o.out.c_str());
  for (std::size_t c = 0; c < p.coefficients.size(); ++c) {
    const std::vector<double>& v = p.values[c];
    const auto top = std::max_element(v.begin(), v.end());
    std::printf("polar: %s %.4g ... %.4g, largest at %.4g deg\n", p.coefficients[c].c_str(),
                *std::min_element(v.begin(), v.end()), *top,
                p.x_rad[static_cast<std::size_t>(top - v.begin())] * kDegPerRad);
  }
}

const indicial::tools::RegisterCommand register_polar([](CLI::App& app) {
  auto opt = std::make_shared<PolarCommandOptions>();
  CLI::App* sub = app.add_subcommand(
      "polar",
      "A static table from quasi-static cycles: the runs of an experiment file (read as fit reads\n"
      "them; it needs no [static] yet) binned by the model angle, a row per bin: the samples' mean\n"
      "angle and mean coefficient(s). By default the outward samples only (the angle moving away\n"
      "from zero: the return stroke stays separated inside the static stall angle). Writes\n"
      "alpha_deg (beta_deg in roll and yaw) and a column per coefficient: a [static] table and a\n"
      "model.stall_polar.");
  sub->add_option("EXPERIMENT", opt->experiment, "experiment file (.toml) naming the quasi-static runs")->required();
  sub->add_option("--out", opt->out, "output CSV")->required();
  sub->add_option("--bin-deg", opt->polar.bin_deg, "bin width, deg (bins centred on multiples of it; default 1)");
  sub->add_option("--min-samples", opt->polar.min_samples, "a bin with fewer samples is dropped (default 4)");
  sub->add_option("--stroke", opt->polar.stroke,
                  "outward (default: the model angle moving away from zero, the stroke on which the flow "
                  "separates, either side of zero), rising (the angle increasing) or both")
      ->transform(CLI::CheckedTransformer(stroke_names()));
  sub->add_option("--hold-deg", opt->polar.hold_deg,
                  "one more row this far beyond each end, holding the end values, so that the table covers "
                  "cycles reaching beyond the quasi-static ones (default 0: none; as a lift polar a held row "
                  "reads as separation)");
  sub->add_flag("--force", opt->force, "replace an existing output");
  sub->callback([opt]() { run_polar(*opt); });
});

}  // namespace
