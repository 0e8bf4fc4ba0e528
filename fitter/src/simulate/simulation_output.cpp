// What `indicial simulate` writes (see indicial/fitter/simulate.hpp): a simulated run as CSV,
// the truth model as a coefficient file, a whole case as a directory through OutputDir.
#include <string>
#include <vector>

#include "indicial/coef_file.hpp"
#include "indicial/fitter/error.hpp"
#include "indicial/fitter/experiment_toml.hpp"
#include "indicial/fitter/io.hpp"
#include "indicial/fitter/output.hpp"
#include "indicial/fitter/simulate.hpp"

namespace indicial {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kRadToDeg = 180.0 / kPi;

}  // namespace

std::string simulated_run_csv(const TruthModel& model, const SimulatedRun& run,
                              const std::vector<std::string>& comment_lines) {
  const char* angle = model.axis == Axis::pitch ? "alpha" : model.axis == Axis::roll ? "phi" : "psi";
  const char* rate = model.axis == Axis::pitch ? "q" : model.axis == Axis::roll ? "p" : "r";
  std::vector<CsvColumn> cols;
  cols.push_back({"time_s", run.time_s});
  CsvColumn a{std::string(angle) + "_deg", run.motion_angle_rad};
  for (double& v : a.values) v *= kRadToDeg;
  CsvColumn q{std::string(rate) + "_degps", run.rate_radps};
  for (double& v : q.values) v *= kRadToDeg;
  cols.push_back(a);
  cols.push_back(q);
  const auto nc = static_cast<std::size_t>(model.n_coefficients);
  for (std::size_t c = 0; c < nc; ++c) {
    const std::string name = model.coefficients[c].name;
    cols.push_back({name, run.coefficient_measured[c]});
    cols.push_back({name + "_true", run.coefficient_true[c]});
  }
  for (std::size_t c = 0; c < nc; ++c) {
    const std::string name = model.coefficients[c].name;
    cols.push_back({nc == 1 ? std::string("y_true") : "y_true_" + name, run.y_true[c]});
  }
  return write_run_csv(cols, comment_lines);
}

std::string truth_coef_text(const TruthModel& model) {
  std::vector<char> buffer(1 << 16);
  std::size_t length = 0;
  const WriteStatus st = write_coef_file(model, buffer.data(), buffer.size(), &length);
  if (st != WriteStatus::ok) {
    throw InputError("truth.coef", 0, std::string("cannot write the truth model: ") + to_string(st));
  }
  return std::string(buffer.data(), length);
}

std::vector<double> write_simulation_case(const SimulationCase& c, const std::string& out_dir,
                                          double snr, std::uint64_t seed, Overwrite overwrite,
                                          const NoiseModel& noise) {
  OutputDir out(out_dir, overwrite);
  std::vector<SimulatedRun> runs;
  for (const auto& m : c.motions) runs.push_back(simulate_reference(c.truth, m));
  const std::vector<double> sigma = add_measurement_noise(runs, snr, seed, noise);
  std::vector<std::string> comments = {
      "indicial simulate --case " + c.name + " (" + c.description + ")",
      "truth: continuous model integrated by Dormand-Prince 5(4), abs/rel tolerance 1e-12",
  };
  for (std::size_t i = 0; i < sigma.size(); ++i) {
    comments.push_back(std::string("noise: ") + c.truth.coefficients[i].name + " sigma " +
                       format_double(sigma[i]) + " (SNR " + format_double(snr) + ", seed " +
                       std::to_string(seed) + ", noise " + noise_spec_text(noise) +
                       ", sigma = RMS(y) / SNR, the noise's marginal std)");
  }
  for (std::size_t r = 0; r < runs.size(); ++r) {
    out.write(c.run_files[r], simulated_run_csv(c.truth, runs[r], comments));
  }
  out.write("experiment.toml", write_experiment_toml(c.experiment, comments));
  out.write("truth.coef", truth_coef_text(c.truth));
  out.commit();
  return sigma;
}

}  // namespace indicial
