#pragma once
// A static table from quasi-static cycles (`indicial polar`): the samples of an experiment's
// runs binned by the model angle, each bin's mean angle and mean coefficients one row.
//
// Why a command: the static curve C_a(x) is an input of every model (`[static] table`) and the
// dynamic-stall families' lift polar (`model.stall_polar`); a tunnel entry often has no static
// test but has cycles slow enough to be quasi-static (the Glasgow database's k = 0.010). The
// recipe was a script for one database's layout (tools/validate_stall.py); here it reads any
// runs an experiment file can name (one file per cycle, files at their own phases, Cn / Ct,
// [columns]).
//
// The recipe (defaults measured on the development set, docs/formats.md "Getting a static
// polar"): the OUTWARD samples only (the model angle moving away from zero: above zero the
// upstroke, below zero the downstroke; the return stroke's flow stays separated inside the
// static stall angle and reattaches late, so pooling both strokes puts that hysteresis into the
// static curve: the quasi-steady C_m error of the attached held-out cycles 0.0195 -> 0.0239,
// with the upstrokes of cycles that barely go below zero), in bins `bin_deg` wide centred on multiples of it, a bin kept with
// at least `min_samples` samples. Each row is at its samples' mean angle (not the bin's centre:
// exact for a linear stretch, whatever the samples' spread in the bin). Nothing is held beyond
// the rows unless hold_deg says so.
//
// Hand-written (a mean per bin): no library function bins by one column and averages others.
#include <string>
#include <vector>

#include "indicial/fitter/experiment.hpp"
#include "indicial/fitter/experiment_toml.hpp"

namespace indicial {

// outward: the samples whose model angle moves away from zero (rising above 0, falling below):
// the stroke on which the flow separates, on either side of a cycle through zero; rising: the
// angle increasing only; both: every sample.
enum class PolarStroke { outward, rising, both };
// The names `indicial polar --stroke` and Python's `stroke=` take (one table for both).
inline constexpr std::array<NamedValue<PolarStroke>, 3> polar_stroke_names{
    {{"outward", PolarStroke::outward}, {"rising", PolarStroke::rising}, {"both", PolarStroke::both}}};
inline constexpr const auto& names_of(PolarStroke) { return polar_stroke_names; }

struct QuasiStaticPolarOptions {
  double bin_deg = 1.0;                      // > 0: bins centred on multiples of it
  int min_samples = 4;                       // >= 1: a bin with fewer is dropped
  PolarStroke stroke = PolarStroke::outward;  // the separating stroke (above)
  // >= 0: one more row this far beyond each end, holding the end values (what the runtime does
  // outside a table), so that the table covers cycles that reach beyond the quasi-static ones
  // (a static table must cover the fit's runs). Caveat: as a lift polar, a held row beyond the
  // attached part reads as separation in the Kirchhoff inversion (a flat C_L against a rising
  // attached line), also on the negative side. 0: none.
  double hold_deg = 0.0;
  // Empty when valid; else what is wrong (`polar` refuses with it).
  std::string invalid_reason() const;
};

struct QuasiStaticPolar {
  std::vector<double> x_rad;                  // each row's mean model angle, strictly increasing
  std::vector<std::string> coefficients;      // the experiment's coefficients, in its order
  std::vector<std::vector<double>> values;    // [coefficient][row]: the bin means
  std::vector<int> samples;                   // per row: the samples averaged
  int bins_dropped = 0;                       // bins with fewer than min_samples samples
  int samples_used = 0;                       // samples in the rows kept
  int runs = 0;
  int held_rows = 0;                          // rows added by hold_deg (0 or 2)
};

// The polar of the experiments' runs (load_experiment_runs: one Experiment per coefficient,
// the same runs and samples in each). Throws InputError (naming the experiment file) when the
// options are invalid, the runs differ between coefficients, fewer than two bins keep enough
// samples, or the rows (held rows included) exceed the runtime's static table
// (DefaultCapacity::max_table_points): a table no experiment could load is never made.
QuasiStaticPolar quasi_static_polar(const std::vector<Experiment>& experiments, const QuasiStaticPolarOptions& options);

// The polar as a static-table CSV: `alpha_deg` (pitch) or `beta_deg` (roll, yaw), then one
// column per coefficient, every value to eight significant digits; `comments` as leading '#'
// lines.
std::string quasi_static_polar_csv(const QuasiStaticPolar& polar, Axis axis, const std::vector<std::string>& comments);

}  // namespace indicial
