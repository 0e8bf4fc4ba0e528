// indicial/fitter/prediction_output.hpp -- what `indicial predict` writes: the CSV, the
// metrics (JSON and one-line summaries), the warnings and the overlay plot of a Prediction.
//
// predict.hpp computes a Prediction and its metrics; this header only words and draws them,
// so that no file both computes and formats. The CSV goes through write_run_csv (io.hpp), the
// plot through write_gnuplot_png (gnuplot.hpp, the one gnuplot runner), every file through
// write_file_atomically (output.hpp).
//
// Usage
// -----
//   indicial::Prediction p = indicial::predict_motion(model, t, angle, rate, model.airspeed_mps);
//   indicial::score_coefficients(p);
//   indicial::write_file_atomically("out.csv", indicial::prediction_csv(p, "alpha_deg", {}),
//                                   indicial::Overwrite::refuse);
//   indicial::write_prediction_plot(p, "out.png", "title", indicial::Overwrite::refuse);
#pragma once

#include <string>
#include <vector>

#include "indicial/fitter/output.hpp"
#include "indicial/fitter/predict.hpp"

namespace indicial {

// predict's CSV: time_s, the angle column (angle_column: "<base>_deg" or "<base>_rad"), then
// per coefficient <c>_pred, <c>_quasi_steady and, where measured, <c>. Metrics go into the
// comment lines as well.
std::string prediction_csv(const Prediction& p, const std::string& angle_column,
                           const std::vector<std::string>& comment_lines);

// The metrics as a JSON document: {"coefficients": [{"name", "n_samples", "model": {rms_error,
// max_error, theil_inequality}, "quasi_steady": {...}}], "clamped_samples": n}.
std::string prediction_metrics_json(const Prediction& p);

// One-line human summaries of the metrics (for stdout and the CSV comments).
std::vector<std::string> prediction_metrics_lines(const Prediction& p);

// The prediction's warnings (samples outside the envelope), one line each without a prefix: the
// command line prints them on stderr as "indicial: warning: ...", the CSV keeps them as comments.
std::vector<std::string> prediction_warnings(const Prediction& p);

// Overlay plot (gnuplot, pngcairo): per coefficient, measured / predicted / quasi-steady
// against time (left) and against the motion angle in degrees (right). Writes `png_path`
// atomically through write_gnuplot_png (gnuplot.hpp: refuses an existing file unless
// overwrite; `gnuplot` is the executable). Throws InputError if gnuplot fails.
void write_prediction_plot(const Prediction& p, const std::string& png_path,
                           const std::string& title, Overwrite overwrite,
                           const std::string& gnuplot = "gnuplot");

}  // namespace indicial
