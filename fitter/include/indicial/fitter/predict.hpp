// indicial/fitter/predict.hpp -- run a fitted model on a new motion and score it.
//
// What it is for
// --------------
// A model is only as good as its predictions on motions it was NOT fitted to (other
// amplitudes, other frequencies, ramps). predict_motion() runs a model set over a sampled
// motion with the embedded runtime itself (indicial::Predictor: the same load-time
// validation, clamping and discrete update a simulator would use), and returns, per
// coefficient, the full model (static + rotary + unsteady, report eq. 4b) and the
// quasi-steady model (static + rotary only). score_prediction() compares either with a
// measured coefficient: RMS error, maximum absolute error and Theil's inequality coefficient
//
//   TIC = sqrt(mean e^2) / (sqrt(mean m^2) + sqrt(mean p^2)),   e = p - m,
//
// which is 0 for a perfect prediction and 1 for the worst (p = -m, or one of them zero); it is
// scale-free, so a TIC can be compared across coefficients. The quasi-steady metrics show what
// the unsteady term buys.
//
// Usage
// -----
//   indicial::Run run = indicial::read_run_csv("ramp.csv", model.axis, "Cm",
//                                              indicial::CoefficientPresence::optional);
//   indicial::Prediction p = indicial::predict_motion(model, run.time_s, run.motion_angle_rad,
//                                                     run.rate_radps, model.airspeed_mps);
//   indicial::ErrorMetrics m = indicial::score_prediction(run.coefficient, p.coefficients[0].predicted);
//   // its CSV, metrics and plot: indicial/fitter/prediction_output.hpp
//
// Warnings
// --------
// 1. predict_motion resets the predictor to the steady state at the FIRST sample (y_0 = con / b_1(x), other
//    lags 0) and then stepped sample by sample; the first output is that steady state. A run
//    that begins in motion (or a simulated run that begins with y = 0 while con != 0) starts
//    with a transient error that decays like exp(-b t). For one cycle of a periodic motion
//    use predict_periodic (its periodic steady state) instead.
// 2. Outside the model's envelope the runtime holds the unsteady and fitted terms at the
//    envelope's edge and evaluates a static table at the true angle (runtime.hpp warning 3);
//    the quasi-steady column does the same. The number of such samples is reported
//    (Prediction::clamped_samples; `indicial predict` warns on stderr) -- a prediction there
//    is an extrapolation the unsteady model was never fitted for.
// 3. Bad model files throw InputError naming the file and line (parse or runtime validation,
//    e.g. b_j(x) <= 0 in the envelope). A runtime step refusal (non-finite result) throws too.
// 4. predict_motion steps with each sample's own dt, so any strictly increasing grid works
//    (read_run_csv checks the step unless given TimeGrid::nonuniform); every step must be at
//    most the runtime's Predictor::max_dt_s.
#pragma once

#include <cstddef>
#include <limits>
#include <string>
#include <vector>

#include "indicial/model.hpp"

namespace indicial {

// Error metrics of a prediction p against a measurement m (same length, e = p - m).
struct ErrorMetrics {
  std::size_t n_samples = 0;
  double rms_error = 0.0;   // sqrt(mean e^2)
  double max_error = 0.0;   // max |e|
  double theil_inequality = 0.0;  // TIC, see the essay; 0 when m and p are both identically 0
  // Theil's decomposition of the mean square error, MSE = mean_error^2 + rms_about_mean^2:
  // the bias a constant could remove (a tunnel run's zero drift, a static table offset) apart
  // from the error in the shape. bias_proportion = mean_error^2 / MSE (Theil's U^M, 0 when
  // MSE = 0).
  double mean_error = 0.0;       // mean e (the bias: > 0 predicts high)
  double rms_about_mean = 0.0;   // sqrt(mean (e - mean e)^2)
  double bias_proportion = 0.0;  // mean_error^2 / rms_error^2, in [0, 1]
};

// Throws std::invalid_argument when the lengths differ or are zero.
ErrorMetrics score_prediction(const std::vector<double>& measured,
                              const std::vector<double>& predicted);

struct CoefficientPrediction {
  std::string name;                   // "CL", "Cm", ...
  std::vector<double> predicted;      // full model (runtime output)
  std::vector<double> quasi_steady;   // static + static correction + rotary
  std::vector<double> measured;       // empty when the data had no such column
  // Filled by score_coefficients when measured is not empty.
  enum class Scored { no_measurement, scored };
  Scored scored = Scored::no_measurement;
  ErrorMetrics model_metrics;
  ErrorMetrics quasi_steady_metrics;
};

struct Prediction {
  Axis axis = Axis::pitch;
  std::vector<double> time_s;
  std::vector<double> motion_angle_rad;  // alpha, phi or psi as given
  std::vector<double> rate_radps;
  std::vector<double> x_rad;             // model angle (alpha or beta), before clamping
  std::size_t clamped_samples = 0;       // samples whose model angle left the envelope
  std::vector<CoefficientPrediction> coefficients;  // in model-file order
  // The samples score_coefficients scored: time_s >= score_from_s (-inf: every sample), their
  // count, the first scored index. Every sample is predicted and written either way.
  double score_from_s = -std::numeric_limits<double>::infinity();
  std::size_t scored_samples = 0;
  std::size_t first_scored = 0;
};

// Runs the runtime Predictor (FitCapacity, so any model the fitter writes fits) over the
// motion. rate_radps is q, p or r; airspeed_mps the tunnel speed (normally the model's
// reference airspeed). Throws InputError(model_label, 0, ...) if the runtime refuses the
// model or a step (model_label: the model file's path), std::invalid_argument for
// inconsistent vector lengths.
Prediction predict_motion(const ModelSet<double, FitCapacity>& model,
                          const std::vector<double>& time_s,
                          const std::vector<double>& motion_angle_rad,
                          const std::vector<double>& rate_radps, double airspeed_mps,
                          const std::string& model_label = "model");

// The periodic steady state of one cycle (`indicial predict --periodic`): the samples are one
// period of a periodic motion (an ensemble-averaged cycle). The cycle closes on its last
// sample when the last angle repeats the first (within 1e-9 rad), otherwise with one more
// step of the mean sample step from the last sample back to the first. The state at the
// cycle's start is the fixed point of the cycle map, found as the fitter finds it for a
// periodic run: every lag is linear in its own state, so the runtime propagates the cycle
// from y = 0 and from y = 1 (Predictor snapshot/restore; after one warm-up cycle that fills
// a delay's history), Phi = y_b - y_a, y0 = y_a / (1 - Phi); then it steps the cycle from y0
// and reports every sample. Dynamic-stall states start at their own periodic state
// (periodic_stall.hpp, from the runtime's cycle; the fitter's for a periodic run). Throws
// InputError(model_label, ...) when some lag has no periodic steady state (Phi >= 1) or the
// runtime refuses the model or a step.
Prediction predict_periodic(const ModelSet<double, FitCapacity>& model,
                            const std::vector<double>& time_s,
                            const std::vector<double>& motion_angle_rad,
                            const std::vector<double>& rate_radps, double airspeed_mps,
                            const std::string& model_label = "model");

// Scores every coefficient whose measured vector is filled (model and quasi-steady), over the
// samples at time_s >= score_from_s (`predict --score-from-s`: a raw multi-cycle log is
// predicted from a state at rest or at the first sample's steady state, and its start-up
// transient is the initial state's error, not the model's; the default scores every sample).
// Throws InputError(option_name, 0, ...) naming the data's time range when a given
// score_from_s (not -inf) leaves fewer than two samples, or is NaN.
void score_coefficients(Prediction& p, double score_from_s = -std::numeric_limits<double>::infinity(),
                        const std::string& option_name = "--score-from-s");

// Reads a coefficient file (parse_coef_file, FitCapacity); throws InputError(path, line, ...).
ModelSet<double, FitCapacity> read_model_file(const std::string& path);

}  // namespace indicial
