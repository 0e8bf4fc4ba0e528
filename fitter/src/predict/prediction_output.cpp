// predict's outputs: CSV, metrics, warnings, overlay plot. See
// indicial/fitter/prediction_output.hpp.
#include "indicial/fitter/prediction_output.hpp"

#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <sstream>

#include "indicial/fitter/gnuplot.hpp"
#include "indicial/fitter/io.hpp"

namespace indicial {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kRadToDeg = 180.0 / kPi;

const char* motion_base(Axis axis) {
  return axis == Axis::pitch ? "alpha" : axis == Axis::roll ? "phi" : "psi";
}

std::string fmt_num(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

// The overlay plot's gnuplot script, data inline, drawing into `output`.
std::string prediction_plot_script(const Prediction& p, const std::string& output, const std::string& title) {
  const std::size_t nc = p.coefficients.size();
  const char* base = motion_base(p.axis);

  std::ostringstream s;
  s.precision(10);
  // Data inline as a gnuplot datablock: no temporary data files to clean up.
  s << "$d << EOD\n";
  for (std::size_t i = 0; i < p.time_s.size(); ++i) {
    s << p.time_s[i] << ' ' << p.motion_angle_rad[i] * kRadToDeg;
    for (const auto& c : p.coefficients) {
      s << ' ' << c.predicted[i] << ' ' << c.quasi_steady[i] << ' '
        << (c.measured.empty() ? std::string("NaN") : fmt_num(c.measured[i]));
    }
    s << '\n';
  }
  s << "EOD\n";
  s << "set terminal pngcairo size 1200," << 360 * nc + 40 << " font 'sans,10'\n";
  s << "set output " << gnuplot_quote(output) << "\n";
  s << "set datafile missing 'NaN'\nset grid\nset key below horizontal\n";
  s << "set multiplot layout " << nc << ",2 title " << gnuplot_quote(title) << "\n";
  for (std::size_t c = 0; c < nc; ++c) {
    const std::string& name = p.coefficients[c].name;
    const std::size_t col = 3 + 3 * c;  // predicted; quasi-steady col + 1; measured col + 2
    const bool has_measured = !p.coefficients[c].measured.empty();
    for (int panel = 0; panel < 2; ++panel) {
      const std::string xcol = panel == 0 ? "1" : "2";
      s << "set xlabel '" << (panel == 0 ? std::string("time, s") : std::string(base) + ", deg")
        << "'\nset ylabel '" << name << "'\n";
      s << "plot ";
      if (has_measured)
        s << "$d using " << xcol << ":" << col + 2 << " with lines lw 2 lc rgb '#000000' title 'measured', ";
      s << "$d using " << xcol << ":" << col << " with lines lw 1.5 lc rgb '#d62728' title 'predicted', "
        << "$d using " << xcol << ":" << col + 1
        << " with lines lw 1.5 dt 2 lc rgb '#1f77b4' title 'quasi-steady'\n";
    }
  }
  s << "unset multiplot\nset output\n";

  return s.str();
}

}  // namespace

std::string prediction_csv(const Prediction& p, const std::string& angle_column,
                           const std::vector<std::string>& comment_lines) {
  std::vector<CsvColumn> cols;
  cols.push_back({"time_s", p.time_s});
  CsvColumn a{angle_column, p.motion_angle_rad};
  // Why the branch: echo the angle in the unit the input used.
  if (angle_column.size() > 4 && angle_column.compare(angle_column.size() - 4, 4, "_deg") == 0)
    for (double& v : a.values) v *= kRadToDeg;
  cols.push_back(a);
  for (const auto& c : p.coefficients) {
    cols.push_back({c.name + "_pred", c.predicted});
    cols.push_back({c.name + "_quasi_steady", c.quasi_steady});
    if (!c.measured.empty()) cols.push_back({c.name, c.measured});
  }
  return write_run_csv(cols, comment_lines);
}

std::string prediction_metrics_json(const Prediction& p) {
  nlohmann::json j;
  j["clamped_samples"] = p.clamped_samples;
  j["n_samples"] = p.time_s.size();
  // --score-from-s: the first time scored (null: every sample) and how many samples were.
  j["score_from_s"] = std::isfinite(p.score_from_s) ? nlohmann::json(p.score_from_s) : nlohmann::json(nullptr);
  j["scored_samples"] = p.scored_samples;
  auto metrics = [](const ErrorMetrics& m) {
    return nlohmann::json{{"rms_error", m.rms_error},
                          {"max_error", m.max_error},
                          {"theil_inequality", m.theil_inequality},
                          {"mean_error", m.mean_error},
                          {"rms_about_mean", m.rms_about_mean},
                          {"bias_proportion", m.bias_proportion}};
  };
  nlohmann::json arr = nlohmann::json::array();
  for (const auto& c : p.coefficients) {
    nlohmann::json e;
    e["name"] = c.name;
    e["measured"] = c.scored == CoefficientPrediction::Scored::scored;
    if (c.scored == CoefficientPrediction::Scored::scored) {
      e["n_samples"] = c.model_metrics.n_samples;
      e["model"] = metrics(c.model_metrics);
      e["quasi_steady"] = metrics(c.quasi_steady_metrics);
    }
    arr.push_back(e);
  }
  j["coefficients"] = arr;
  return j.dump(2) + "\n";
}

std::vector<std::string> prediction_metrics_lines(const Prediction& p) {
  std::vector<std::string> lines;
  if (p.first_scored > 0)
    lines.push_back("scored from t = " + fmt_num(p.time_s[p.first_scored]) + " s (--score-from-s): " +
                    std::to_string(p.scored_samples) + " of " + std::to_string(p.time_s.size()) + " samples");
  for (const auto& c : p.coefficients) {
    if (c.scored != CoefficientPrediction::Scored::scored) {
      lines.push_back(c.name + ": no measured column; prediction only");
      continue;
    }
    const auto& a = c.model_metrics;
    const auto& q = c.quasi_steady_metrics;
    lines.push_back(c.name + " model:        RMS " + fmt_num(a.rms_error) + "  max " +
                    fmt_num(a.max_error) + "  TIC " + fmt_num(a.theil_inequality) + "  bias " +
                    fmt_num(a.mean_error) + "  RMS about bias " + fmt_num(a.rms_about_mean));
    lines.push_back(c.name + " quasi-steady: RMS " + fmt_num(q.rms_error) + "  max " +
                    fmt_num(q.max_error) + "  TIC " + fmt_num(q.theil_inequality) + "  bias " +
                    fmt_num(q.mean_error) + "  RMS about bias " + fmt_num(q.rms_about_mean));
  }
  return lines;
}

std::vector<std::string> prediction_warnings(const Prediction& p) {
  std::vector<std::string> lines;
  if (p.clamped_samples > 0)
    lines.push_back(std::to_string(p.clamped_samples) + " of " + std::to_string(p.time_s.size()) +
                    " samples are outside the model's envelope: there the unsteady term and the fitted terms "
                    "are held at the envelope's edge (a static table is used at the true angle, over its rows)");
  return lines;
}

void write_prediction_plot(const Prediction& p, const std::string& png_path,
                           const std::string& title, Overwrite overwrite, const std::string& gnuplot) {
  write_gnuplot_png(png_path, [&](const std::string& output) { return prediction_plot_script(p, output, title); },
                    gnuplot, overwrite);
}

}  // namespace indicial
