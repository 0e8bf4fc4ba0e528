// report/report_internal.hpp -- what the files of the fit report share (private to report/).
//
// The fit report is split by job so that no file both computes and formats:
//   replay_check.cpp     the runtime replay of the written model.coef (numbers)
//   run_fit_error.cpp    the RMS of a run's residuals (numbers)
//   fit_warnings.cpp     the warnings about a finished fit (compares numbers, words them)
//   report_json.cpp      fit.json
//   report_markdown.cpp  report.md and the terminal table of estimates
//   plots.cpp            the gnuplot script and data of the fit's plots, thinning, running it
//   report.cpp           write_fit_outputs: the order in which the above are written
#pragma once

#include <string>

#include "indicial/fitter/report.hpp"

namespace indicial::report_detail {

inline constexpr double kDegPerRad = 57.29577951308232;

// A run or experiment path as the report shows it: relative to the experiment's directory when
// it lies inside it (so a report does not carry a temporary or absolute prefix).
std::string display_path(const std::string& path, const Experiment& e);

// The fit's plots in DIR/plots (staged in out): data files, plots.gp, gnuplot run.
PlotSet make_plots(const FitResult& r, const Experiment& e, const OutputDir& out, const ReportOptions& ro);

// report.md's text.
std::string report_markdown(const FitResult& r, const Experiment& e, const FitOptions& o, const RuntimeCheck& rc,
                            const PlotSet& ps, const ReportOptions& ro);

}  // namespace indicial::report_detail
