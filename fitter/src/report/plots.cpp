// The fit report's plots (see report.hpp): the data files and gnuplot script of DIR/plots,
// thinned to kMaxPlotPoints, and run_gnuplot_script, which the fit and diagnose reports share
// and which runs gnuplot through the one runner (gnuplot.hpp).
#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <string>
#include <vector>

#include "indicial/fitter/experiment_toml.hpp"
#include "indicial/fitter/gnuplot.hpp"
#include "indicial/fitter/report.hpp"
#include "report/report_internal.hpp"

namespace fs = std::filesystem;

namespace indicial {

std::vector<std::size_t> thinned_indices(std::size_t n, std::size_t max_points) {
  std::vector<std::size_t> idx;
  if (n == 0) return idx;
  // Why max_points - 1: the last sample is always kept, so the stride leaves room for it.
  const std::size_t slots = std::max<std::size_t>(max_points, 2) - 1;
  const std::size_t stride = n <= max_points ? 1 : (n - 1 + slots - 1) / slots;
  for (std::size_t k = 0; k < n; k += stride) idx.push_back(k);
  if (idx.back() != n - 1) idx.push_back(n - 1);
  return idx;
}

namespace {

bool rotary_terms_estimated(const FitResult& r) {
  for (const ParameterEstimate& p : r.parameters)
    if (p.id.kind == ParamKind::rotary_power || p.id.kind == ParamKind::rotary_knot) return true;
  return false;
}

}  // namespace

namespace report_detail {

PlotSet make_plots(const FitResult& r, const Experiment& e, const OutputDir& out,
                   const ReportOptions& ro) {
  if (ro.plots == PlotRequest::none) {
    PlotSet ps;
    ps.message = "plots not requested";
    return ps;
  }
  std::string gp;
  gp += "# gnuplot script written by indicial fit; run `gnuplot plots.gp` in this directory.\n";
  gp += "set terminal pngcairo size 960,540 enhanced font ',10'\n";
  gp += "set grid\nset key outside right top\n";
  std::vector<std::string> expected;
  const std::string coef = e.coefficient;
  for (std::size_t ri = 0; ri < r.runs.size(); ++ri) {
    const RunSeries& s = r.runs[ri];
    const std::string dat = fmt::format("run{}.dat", ri + 1);
    const std::vector<std::size_t> shown = thinned_indices(s.time_s.size());
    std::string text = fmt::format("# time_s measured model quasi_steady residual x_deg ({} of {} samples)\n",
                                   shown.size(), s.time_s.size());
    for (std::size_t k : shown) {
      text += fmt::format("{} {} {} {} {} {}\n", s.time_s[k], s.measured[k], s.model[k],
                          s.quasi_steady[k], s.residual[k], s.x_rad[k] * kDegPerRad);
    }
    out.write("plots/" + dat, text);
    const std::string fit_png = fmt::format("run{}_fit.png", ri + 1);
    const std::string res_png = fmt::format("run{}_residual.png", ri + 1);
    gp += fmt::format("set output {}\n", gnuplot_quote(fit_png));
    gp += fmt::format("set title {} noenhanced\n", gnuplot_quote("run " + std::to_string(ri + 1) + ": " + display_path(s.path, e)));
    gp += fmt::format("set xlabel 'time, s'\nset ylabel {}\n", gnuplot_quote(coef));
    gp += fmt::format(
        "plot {0} using 1:2 with lines lw 1 lc rgb '#888888' title 'measured', \\\n"
        "     {0} using 1:3 with lines lw 2 lc rgb '#d62728' title 'model', \\\n"
        "     {0} using 1:4 with lines lw 1.5 dt 2 lc rgb '#1f77b4' title 'quasi-steady'\n",
        gnuplot_quote(dat));
    gp += fmt::format("set output {}\n", gnuplot_quote(res_png));
    gp += fmt::format("set title {} noenhanced\n",
                      gnuplot_quote("residuals, run " + std::to_string(ri + 1) + ": " + display_path(s.path, e) +
                               fmt::format("  (rms {:.4g})", run_fit_error(s))));
    gp += fmt::format("set ylabel {}\n", gnuplot_quote(coef + " measured - model"));
    gp += fmt::format("plot {} using 1:5 with lines lc rgb '#2ca02c' title 'residual'\n", gnuplot_quote(dat));
    expected.push_back(fit_png);
    expected.push_back(res_png);
  }
  // The functions over the data's angle range.
  const double lo = e.data_x_min_rad, hi = e.data_x_max_rad;
  const int n = 241;
  std::string ftext =
      "# x_deg a a_lo a_hi a_lo_col a_hi_col b1 b1_lo b1_hi b1_lo_col b1_hi_col caq caq_lo caq_hi "
      "(bands: value -/+ 2 sigma, white and colored)\n";
  for (int i = 0; i < n; ++i) {
    const double x = lo + (hi - lo) * static_cast<double>(i) / static_cast<double>(n - 1);
    ftext += fmt::format("{}", x * kDegPerRad);
    for (ModelFunction f : {ModelFunction::a, ModelFunction::b1, ModelFunction::rotary}) {
      const FunctionBand w = function_band(r, f, x, BoundKind::white);
      ftext += fmt::format(" {} {} {}", w.value, w.value - 2.0 * w.sigma, w.value + 2.0 * w.sigma);
      if (f != ModelFunction::rotary) {
        const FunctionBand c = function_band(r, f, x, BoundKind::colored);
        ftext += fmt::format(" {} {}", c.value - 2.0 * c.sigma, c.value + 2.0 * c.sigma);
      }
    }
    ftext += "\n";
  }
  out.write("plots/functions.dat", ftext);
  const std::string xname = e.axis == Axis::pitch ? "alpha" : "beta";
  gp += "unset title\n";
  gp += fmt::format("set xlabel {}\n", gnuplot_quote(xname + ", deg"));
  struct FPlot {
    const char* png;
    const char* label;
    int col;  // value column
    bool colored;
  };
  const bool rotary_estimated = e.rotary.estimate && rotary_terms_estimated(r);
  for (const FPlot& f : {FPlot{"a_band.png", "a(x)", 2, true}, FPlot{"b1_band.png", "b1(x), 1/s", 7, true},
                         FPlot{"caq_band.png", "C_aq(x)", 12, false}}) {
    gp += fmt::format("set output {}\nset ylabel {} noenhanced\n", gnuplot_quote(f.png), gnuplot_quote(f.label));
    const bool band = f.colored || rotary_estimated;
    std::string cmd = "plot ";
    if (band) {
      cmd += fmt::format(
          "'functions.dat' using 1:{}:{} with filledcurves fc rgb '#9ecae1' fs transparent solid 0.5 "
          "title '+/- 2 sigma (Cramer-Rao)' noenhanced, \\\n     ",
          f.col + 1, f.col + 2);
    }
    if (f.colored) {
      cmd += fmt::format(
          "'functions.dat' using 1:{} with lines dt 2 lc rgb '#555555' title '+/- 2 sigma (colored)' noenhanced, \\\n"
          "     'functions.dat' using 1:{} with lines dt 2 lc rgb '#555555' notitle, \\\n     ",
          f.col + 3, f.col + 4);
    }
    cmd += fmt::format("'functions.dat' using 1:{} with lines lw 2 lc rgb '#08519c' title {} noenhanced\n", f.col,
                       gnuplot_quote(std::string(f.label) +
                                (f.col == 12 && !rotary_estimated ? " (a priori)" : " (estimate)")));
    gp += cmd;
    expected.push_back(f.png);
  }
  return run_gnuplot_script(out, gp, expected, ro);
}

}  // namespace report_detail

PlotSet run_gnuplot_script(const OutputDir& out, const std::string& script,
                           const std::vector<std::string>& expected_pngs, const ReportOptions& ro) {
  PlotSet ps;
  out.write("plots/plots.gp", script);
  const fs::path plots_dir = out.path("plots");
  const GnuplotRun g = run_gnuplot(ro.gnuplot, plots_dir, "plots.gp", "gnuplot.log");
  std::error_code ec;
  if (g.outcome == GnuplotOutcome::not_found) {
    ps.status = PlotStatus::gnuplot_not_found;
    ps.message = "gnuplot (" + ro.gnuplot + ") could not be run; no plots were made "
                 "(install gnuplot, then run `gnuplot plots.gp` in plots/)";
    fs::remove(plots_dir / "gnuplot.log", ec);
    return ps;
  }
  std::vector<std::string> missing;
  for (const std::string& png : expected_pngs) {
    if (fs::exists(plots_dir / png, ec) && fs::file_size(plots_dir / png, ec) > 0)
      ps.images.push_back("plots/" + png);
    else
      missing.push_back(png);
  }
  if (g.outcome != GnuplotOutcome::ran || !missing.empty()) {
    ps.status = PlotStatus::gnuplot_failed;
    ps.message = fmt::format("gnuplot exited with status {} and {} of {} images are missing; see plots/gnuplot.log",
                             g.exit_code, missing.size(), expected_pngs.size());
    return ps;
  }
  if (fs::exists(plots_dir / "gnuplot.log", ec) && fs::file_size(plots_dir / "gnuplot.log", ec) == 0)
    fs::remove(plots_dir / "gnuplot.log", ec);
  ps.status = PlotStatus::written;
  ps.message = fmt::format("{} plots written by gnuplot", ps.images.size());
  return ps;
}
}  // namespace indicial
