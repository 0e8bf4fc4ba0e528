#!/usr/bin/env bash
# Writes docs/validation-realistic.md: issue 12's study on tunnel-realistic data.
#   1. the dynamic-stall campaign (Goman-Khrabrov truth, outside the model class): fit three
#      cycles at one amplitude, predict the eleven others at their periodic steady state
#      (`indicial validate-realistic`), for b1 constant and for an angle-dependent b1;
#   2. Monte Carlo on AR(1) noise (phi 0.8) and band-limited turbulence, 200 seeds each
#      (`indicial montecarlo --noise ...`): empirical std / colored-residual bound.
# Usage: tools/validate-realistic.sh [BUILD_DIR]   (default build/; about 30 s on 2 cores)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
exe="$build/tools/indicial"
cmake --build "$build" --target indicial >/dev/null
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
doc=docs/validation-realistic.md

"$exe" validate-realistic --out "$tmp/constant.md" >/dev/null
"$exe" validate-realistic --b1-knots-deg 14 --out "$tmp/knot.md" >/dev/null
"$exe" validate-realistic --snr 5 --b1-degree 3 --out "$tmp/cubic.md" >/dev/null
"$exe" montecarlo --case tailless-model-1 --seeds 200 --first-seed 1001 --noise ar1:phi=0.8 --out "$tmp/mc1" >/dev/null 2>&1
"$exe" montecarlo --case tailless-model-2 --seeds 200 --first-seed 2001 --noise ar1:phi=0.8 --out "$tmp/mc2" >/dev/null 2>&1
"$exe" montecarlo --case tailless-model-1 --seeds 200 --first-seed 3001 \
  --noise turbulence:cutoff_hz=2,zeta=0.7 --out "$tmp/mc3" >/dev/null 2>&1

# The Monte Carlo markdown without its title line (the sections below give one).
body() { tail -n +2 "$1"; }

{
  cat <<'TEXT'
# Validation on tunnel-realistic data (issue 12)

Written by `tools/validate-realistic.sh` (do not edit by hand; rerun it). Every number below
is measured by the commands named in each section.

## The data: a dynamic-stall campaign outside the model class

`indicial simulate --case dynamic-stall --snr 20 --out DIR` writes what a pitching-airfoil
campaign delivers: 14 ensemble-averaged cycles (20 cycles of 128 samples averaged after 3
transient cycles) with a phase column rounded to 0.01 rad and no time column, CL and Cm
columns, the reduced frequency and airspeed of each cycle in the runs table, a static polar
(`static.csv`, 49 rows at 0.5 deg) and one experiment file per coefficient. The truth is the
Goman-Khrabrov separation-point model with Kirchhoff lift and a centre-of-pressure moment term,
NACA 0012-like constants from Leishman & Beddoes (1989), integrated by Boost.Odeint
Dormand-Prince 5(4) at tolerance 1e-11; every constant is in
`fitter/include/indicial/fitter/dynamic_stall.hpp`. The indicial model (one lag, a(x) a
spline) is NOT this model: the separation point enters C_L through sqrt(f) and the lag acts on
a delayed angle, so the best fit keeps a model error (RMS full vs truth below) 5-30 times the averaged noise.

Noise: AR(1) with phi = 0.8 on the raw samples, sigma = RMS(C - C_static) / SNR, SNR 20,
seed 1; averaging over 20 cycles leaves about sigma / sqrt(20).

Cycles: mean 12 deg; amplitude 8 deg at k = 0.02 ... 0.15 (7 cycles) and 6 deg at the same
k (7 cycles). Fit: the three 8 deg cycles at k = 0.04 (25 m/s), 0.08 (30 m/s) and 0.12
(35 m/s), so the fit itself has runs at three airspeeds (V_ref = 30 m/s; each run's
airspeed_mps in the runs table: b1, con and the delay act at V / V_ref on a run at V, the
rotary term at its l / V, as in the runtime). Hold-out: the other 11, at 25, 30 and 35 m/s.
Each hold-out cycle is predicted at its periodic steady state (`predict --periodic`,
`predict_periodic`) with the runtime, and scored against the measured (noisy, averaged)
cycle; "RMS full vs truth" is against the noise-free cycle. The quasi-steady model is the
static table plus the (zero) rotary term. Target: RMS(full) <= 0.5 RMS(quasi-steady) on at
least 9 of 11 hold-out cycles, for C_L and for C_m.

The study builds the fit runs in memory as the phase-averaged reader does (t = phase / (2 pi
f) on the snapped uniform grid, periodic runs, each run's airspeed):
`dynamic_stall::campaign_experiment`; the same fit through the written files (`indicial
simulate --case dynamic-stall`, then `indicial fit experiment-CL.toml` and `indicial predict
--reduced-frequency K --airspeed-mps V`) is `tests/test_dynamic_stall.cpp`.

Runs at several airspeeds: the truth and the sample-indexed noise are functions of the
non-dimensional time V t / l, so a cycle at one reduced frequency is the same data at every
airspeed. With each run's V / V_ref applied, the fit of the cycles at 25, 30 and 35 m/s is
therefore the fit the same cycles give all at 30 m/s: the two tables below (b1 constant, b1
with a knot) are unchanged to the printed digits from the study's earlier all-30 m/s fit (the
SNR-5 cubic-b1 fit of the constraint section, which ends on the feasible set's boundary at a
poor local minimum, moved slightly: its ratios by at most 0.02), and `tests/test_fit_airspeed.cpp`
("dynamic stall, truth outside the model class ...") checks the estimates agree within 1e-3
Cramer-Rao bounds. Taking the three runs at V_ref instead (the airspeed ignored) fits worse:
b1_0 moves by 2.8 bounds for C_L (s(v) +13%) and 1.3 bounds for C_m (s(v) +4%).

### b1 constant (the campaign's experiment files)

TEXT
  tail -n +1 "$tmp/constant.md"
  cat <<'TEXT'
### b1(x) with a knot at 14 deg (angle-dependent decay)

TEXT
  tail -n +1 "$tmp/knot.md"
  cat <<'TEXT'
## Positive decay rates by construction: the constrained fit

The output-error Levenberg-Marquardt fit takes a trial step only to a model whose every
b_j(x) is positive on the envelope (the model-angle range of the data, which is the envelope
written into model.coef); a step to any other model is rejected like a cost increase (the LM's
feasibility predicate, `fit_output_error.cpp`). The check is `min_lag_decay`
(`fitter/include/indicial/fitter/runtime_limits.hpp`): b_j at the runtime's own validation
points (4097 evenly spaced angles, the envelope ends, and either side of every knot), so a
model the fit accepts is one `validate_for_runtime` accepts; for the default b(x) (knot power
1, degree <= 1: piecewise linear) the minimum is at an end or a knot, which are checked, so it
is exact over the continuum too. Where the equation-error start is infeasible, the start is
projected: b_j_0 is raised until min b_j(x) is a tenth of max |b_j(x)| on the envelope (at
least ten decays over the longest run), and
the fit's message says so ("start projected: b1_0 raised from ... to ..."). Why a
bounded/projected step and not a reparameterisation (b = exp(.)): b_j(x) is a spline with
plus-function knots whose coefficients are the contract's parameters (b1_0, B1, ...) and
whose bounds are reported; a reparameterisation would change both, and positivity of a
spline is not a bound on any one coefficient. If a fit still ends outside what the runtime
accepts (e.g. a non-finite value), `fit`/`diagnose` exit 1 naming DIR/model.coef, nothing
written.

The cost of the constraint, measured: on the campaign at SNR 5 with a cubic b1(x) (the
case where, unconstrained, the Cm fit ended with b1(x) <= 0 and the runtime refused it), the
constrained fit ends at a feasible model the runtime loads, but at a poor local minimum on
the feasible set's boundary:

TEXT
  tail -n +1 "$tmp/cubic.md"
  cat <<'TEXT'
## Monte Carlo on colored noise

`indicial montecarlo --case NAME --seeds 200 --first-seed K --noise SPEC --out DIR`: the
report's Example 1 cases fitted 200 times with colored noise of the given marginal sigma.
std / CR is the empirical std over the white Cramer-Rao bound (wrong under colored noise:
about sqrt((1 + phi) / (1 - phi)) = 3 for an AR(1) mean), std / colored over the
colored-residual bound (the sandwich covariance with the residual autocorrelation); the
issue's acceptance band for the latter is [0.8, 1.25]. The ctest check is
`tests/test_montecarlo.cpp` "Monte Carlo, AR(1) noise phi 0.8" (Model I, seeds 5001-5200).

### Model I, AR(1) phi 0.8

TEXT
  body "$tmp/mc1/montecarlo.md"
  printf '\n### Model II, AR(1) phi 0.8\n\n'
  body "$tmp/mc2/montecarlo.md"
  printf '\n### Model I, band-limited turbulence (2nd-order low pass, 2 Hz, zeta 0.7)\n\n'
  body "$tmp/mc3/montecarlo.md"
} > "$doc.tmp"
mv "$doc.tmp" "$doc"
echo "wrote $doc"
