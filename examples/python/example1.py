#!/usr/bin/env python3
"""Example 1 of the reference report from numpy arrays: fit, plot, diagnose.

    python3 examples/python/example1.py [--out example1-out] [--snr 40] [--seed 1]

1. Simulate the report's tailless aircraft, Model II (b1(alpha) a spline with four knots), with
   the accurate reference integration and measurement noise (indicial.simulation_case): three
   forced-oscillation runs as numpy arrays.
2. Build an Experiment from those arrays with Model II's structure and fit it
   (indicial.fit: equation error, then ML output error with Cramer-Rao bounds).
3. Plot with matplotlib: measured vs predicted C_m for every run (the runtime's prediction,
   indicial.predict, from the fitted model), and a(alpha), b1(alpha) with +/- 2 sigma bounds
   beside the truth: OUT/runs.png, OUT/functions.png.
4. Diagnose Model I's structure (constant b1, the report's Table III modelling error) on the
   same arrays: indicial.diagnose names the missing effect (b1_alpha), adds it, and shows the
   fit error shrink: OUT/diagnose.png.
"""
import argparse
import tomllib
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import indicial  # noqa: E402


def experiment_from_arrays(case, b1_knots_rad):
    """The case's runs as arrays, with its configuration but the given b1(alpha) knots."""
    cfg = tomllib.loads(case.experiment_toml)
    runs = [indicial.Run(time_s=r.time_s, alpha_rad=r.motion_angle_rad, q_radps=r.rate_radps,
                         coefficient=r.measured["Cm"], name=r.name) for r in case.runs]
    return indicial.Experiment(
        coefficient="Cm", reference_length_m=cfg["reference_length_m"], airspeed_mps=cfg["airspeed_mps"], runs=runs,
        static_polynomial=cfg["static"]["polynomial"], rotary_polynomial=cfg["rotary"]["polynomial"],
        a_powers=[0, 1, 2], a_knots_rad=np.radians(cfg["model"]["a_knots_deg"]),
        b1_powers=[0], b1_knots_rad=b1_knots_rad)


def plot_runs(result, runs, out):
    fig, axes = plt.subplots(len(result.runs), 1, figsize=(9, 2.6 * len(result.runs)), sharex=False)
    for ax, run, series in zip(np.atleast_1d(axes), runs, result.runs):
        p = indicial.predict(result.model, time_s=run["time_s"], alpha_rad=run["motion_angle_rad"],
                             q_radps=run["rate_radps"], measured={"Cm": run["coefficient"]})
        ax.plot(run["time_s"], run["coefficient"], ".", ms=2, color="0.6", label="measured")
        ax.plot(run["time_s"], p.predicted["Cm"], "-", lw=1.2, label="predicted (runtime, from rest)")
        ax.plot(series["time_s"], series["model"], "--", lw=1, label="fitted (estimated initial state)")
        tic = p.metrics["Cm"]["model"]["theil_inequality"]
        ax.set_title(f"{run['name']}: Theil inequality {tic:.3f}", fontsize=9)
        ax.set_ylabel("C_m")
    np.atleast_1d(axes)[-1].set_xlabel("time, s")
    np.atleast_1d(axes)[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "runs.png", dpi=110)


def plot_functions(result, truth, out):
    lo, hi = result.model.envelope_rad
    x = np.linspace(lo, hi, 300)
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8))
    for ax, name, true in ((axes[0], "a", truth.a(x)), (axes[1], "b1", truth.b(x))):
        value, sigma = result.band(name, x)
        ax.fill_between(np.degrees(x), value - 2 * sigma, value + 2 * sigma, alpha=0.3, label="+/- 2 sigma (CR)")
        ax.plot(np.degrees(x), value, label="estimated")
        ax.plot(np.degrees(x), true, "k--", lw=1, label="truth")
        ax.set_xlabel("alpha, deg")
        ax.set_ylabel(f"{name}(alpha)" + (", 1/s" if name == "b1" else ""))
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "functions.png", dpi=110)


def plot_diagnosis(d, out):
    errors = [d.initial_fit_error] + [s["fit_error_after"] for s in d.steps]
    labels = ["configured"] + [f"+ {s['effect']}\n({s['detail']})" for s in d.steps]
    fig, ax = plt.subplots(figsize=(7, 3.5))
    ax.bar(range(len(errors)), errors)
    ax.axhline(d.noise["sigma"], color="k", ls="--", lw=1, label="noise level estimated from residuals")
    ax.set_xticks(range(len(errors)), labels, fontsize=7)
    ax.set_ylabel("fit error s(v)")
    ax.set_title(f"indicial.diagnose: verdict {d.verdict}", fontsize=9)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "diagnose.png", dpi=110)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default="example1-out")
    ap.add_argument("--snr", type=float, default=40.0)
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    case = indicial.simulation_case("tailless-model-2", snr=args.snr, seed=args.seed)
    cfg = tomllib.loads(case.experiment_toml)
    model2 = experiment_from_arrays(case, np.radians(cfg["model"]["b1_knots_deg"]))
    result = indicial.fit(model2)
    print(f"fit (Model II structure): {result.termination} after {result.iterations} iterations, "
          f"s(v) = {result.fit_error:.6g} (noise sigma {case.sigma[0]:.6g})")
    print(f"{'name':>8} {'value':>12} {'CR bound':>10} {'colored':>10}")
    for p in result.parameters:
        print(f"{p.name:>8} {p.value:12.5g} {p.cr_bound:10.3g} {p.cr_bound_colored:10.3g}")
    plot_runs(result, model2.runs, out)
    plot_functions(result, case.truth, out)
    result.model.save(str(out / "model.coef"), force=True)

    model1 = experiment_from_arrays(case, [])
    d = indicial.diagnose(model1, max_steps=3)
    print(f"diagnose (Model I structure, constant b1): verdict {d.verdict}; fit error "
          f"{d.initial_fit_error:.6g} -> {d.final_fit_error:.6g} (noise {d.noise['sigma']:.6g})")
    for s in d.steps:
        print(f"  step {s['step']}: {s['effect']} ({s['detail']}), LR/kappa {s['statistic']:.1f}, "
              f"log10 p {s['log10_p']:.1f}")
    plot_diagnosis(d, out)
    print(f"wrote {out}/runs.png, functions.png, diagnose.png, model.coef")


if __name__ == "__main__":
    main()
