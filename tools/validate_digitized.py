#!/usr/bin/env python3
"""Does a fit from digitized cycles predict as well as a fit from the measured ones?

Usage: nice python3 tools/validate_digitized.py DIR INDICIAL SCRATCH > docs/validation-digitized.md

Why: issue 22 is accepted in part on another facility's cycles that exist only as digitized
histories (30-130 points per cycle, each quantity at its own phases, read off plots), while
every measured study here (docs/validation-real.md, docs/validation-stall.md) fits 128 evenly
spaced samples. This study makes digitized copies of the same training cycles and compares.

Method (standard library only; every choice is a rule, not a list of cycles):
 1. DIR's static polar and its two training choices, as tools/validate_real.py makes them (three
    cycles of one frequency sweep; three across mean angles), and every other cycle that is not
    the polar's held out (168 on the development set).
 2. Per training choice and coefficient (CL, Cm), the Beddoes-Leishman start of
    validate_real.py (a, b1 constants, C_aq estimated, separation and vortex families; `indicial
    fit` with its start search, no diagnose) fitted three times: from the measured files, and
    from digitized copies at N = 80 and N = 40 points per quantity per cycle.
 3. A digitized copy of a cycle (digitize()): the angle and the coefficient each in their own
    file at their own N phases, jittered about an even spacing (phase_k = (k + u_k) 2 pi / N,
    u_k uniform in [-0.35, 0.35], seeded by the cycle id and the quantity), each value the
    measured cycle's periodic linear interpolation there plus a reading error, normal with a
    standard deviation of 0.5 % of the quantity's peak-to-peak over the cycle (a digitizer's
    error on a plot; CL = Cn cos(alpha) + Ct sin(alpha) first, as a publication plots it). The
    runs entry is `files = [...]` with samples = 128 (docs/formats.md, "Columns sampled at their
    own phases"): the reader resamples by a periodic Akima cubic.
 4. Every held-out cycle predicted from its measured file at its periodic steady state
    (`indicial predict --periodic`); per model: the median over cycles of RMS / quasi-steady
    RMS, the cycles at <= 0.5x, and the mean RMS; attached / light / deep stall apart.
"""
import json
import math
import os
import random
import sys
import time

import compare_starts
import cycle_catalog
import validate_real as vr

N_POINTS = (80, 40)         # digitized points per quantity per cycle (the 30-130)
JITTER = 0.35               # of the even spacing: the phases stay strictly increasing
READ_ERROR = 0.005          # of the quantity's peak-to-peak over the cycle (1 sigma)
SAMPLES = 128               # the resampled cycle, as the measured files have


def periodic_linear(values, phase_rad):
    """The evenly sampled periodic cycle `values` (sample i at 2 pi i / n) at phase_rad."""
    n = len(values)
    x = (phase_rad / (2.0 * math.pi)) * n
    i = int(math.floor(x)) % n
    t = x - math.floor(x)
    return values[i] * (1.0 - t) + values[(i + 1) % n] * t


def digitize(values, n_points, seed):
    """(phases_rad, readings): values' cycle read at n_points jittered phases in [0, 2 pi),
    strictly increasing, each reading off by a normal error of READ_ERROR of the peak-to-peak."""
    rng = random.Random(seed)
    spread = max(values) - min(values)
    step = 2.0 * math.pi / n_points
    out_ph, out_v = [], []
    for k in range(n_points):
        ph = (k + rng.uniform(-JITTER, JITTER)) * step
        ph = min(max(ph, 0.0), 2.0 * math.pi - 1e-9)
        out_ph.append(ph)
        out_v.append(periodic_linear(values, ph) + rng.gauss(0.0, READ_ERROR * spread))
    return out_ph, out_v


def write_quantity(path, name, phases, values):
    """One digitized quantity in the database's layout (a % header, whitespace), phase in
    `Time()` as the measured files have it (the experiment's [columns] map it)."""
    with open(path, "w") as f:
        f.write(f"% Time() {name}\n")
        for ph, v in zip(phases, values):
            f.write(f"{ph:.9f} {v:.9g}\n")


def digitized_runs(train, coef, n_points, work):
    """The runs entries of the digitized copies of the training cycles: an angle file and a
    coefficient file per cycle, each at its own phases."""
    entries = []
    for c in train:
        rows = cycle_catalog.read_cycle(vr.cycle_file(c))
        col = 5 if coef == "CL" else 4
        files = []
        for name, values in (("Angle(deg)", [r[1] for r in rows]), (coef, [r[col] for r in rows])):
            tag = "alpha" if name.startswith("Angle") else coef
            ph, v = digitize(values, n_points, f"{c['id']}-{tag}-{n_points}")
            path = os.path.join(work, f"{c['id']}_{tag}_{n_points}.dat")
            write_quantity(path, name, ph, v)
            files.append(path)
        entries.append(f'{{files = ["{files[0]}", "{files[1]}"], samples = {SAMPLES}, frequency_hz = {c["f"]}, '
                       f'airspeed_mps = {c["v"]}}}')
    return ", ".join(entries)


def experiment_text(coef, train, static_csv, v_ref, n_points, work):
    """validate_real's experiment (the Beddoes-Leishman start); with n_points the runs are the
    digitized copies."""
    text = vr.experiment_toml(coef, train, static_csv, v_ref, vr.model_keys("bl", [], static_csv))
    if n_points is None:
        return text
    lines = text.split("\n")
    at = next(i for i, line in enumerate(lines) if line.startswith("runs = ["))
    lines[at] = f"runs = [{digitized_runs(train, coef, n_points, work)}]"
    return "\n".join(lines)


def fit_and_predict(work, text, held):
    """compare_starts.fit_and_predict (fit, then every held-out cycle predicted), with the fit's
    parameter values: (fit error, {parameter: value}, per held-out cycle in `held`'s order
    (model RMS, quasi-steady RMS))."""
    fit_error, by_id = compare_starts.fit_and_predict(work, text, held)
    with open(os.path.join(work, "fit", "fit.json")) as f:
        params = {p["name"]: p["value"] for p in json.load(f).get("parameters", [])}
    return fit_error, params, [by_id[c["id"]] for c in held]


def summary(rows, cycles, stall_deg, regime_name):
    sel = [(m, q) for (m, q), c in zip(rows, cycles)
           if regime_name == "all" or cycle_catalog.regime(vr.peak_deg(c), stall_deg) == regime_name]
    if not sel:
        return 0, float("nan"), 0, float("nan")
    ratios = sorted(m / q for m, q in sel)
    med = ratios[len(ratios) // 2] if len(ratios) % 2 else 0.5 * (ratios[len(ratios) // 2 - 1] + ratios[len(ratios) // 2])
    return len(sel), med, sum(1 for r in ratios if r <= 0.5), sum(m for m, _ in sel) / len(sel)


def main():
    if len(sys.argv) != 4:
        sys.exit("usage: validate_digitized.py DIR INDICIAL SCRATCH > OUT.md")
    # Absolute: the experiment files name the cycles, the polar and the copies, and the reader
    # resolves names from the experiment's folder.
    vr.DATA, vr.EXE, scratch = (os.path.abspath(a) for a in sys.argv[1:4])
    t0 = time.time()
    catalog = cycle_catalog.read_catalog(vr.DATA)
    os.makedirs(scratch, exist_ok=True)
    static_csv = os.path.join(scratch, "static.dat")
    static_info = vr.static_table(catalog, static_csv)
    stall_deg = static_info[4]
    sections = []
    for name, label, train in vr.training_choices(catalog, static_info):
        train_ids = {c["id"] for c in train}
        held = [c for c in catalog if c["id"] not in train_ids and c["id"] not in static_info[5]]
        v_ref = round(sum(c["v"] for c in train) / len(train), 3)
        for coef in ("CL", "Cm"):
            variants = []
            for n_points in (None,) + N_POINTS:
                tag = "measured" if n_points is None else f"n{n_points}"
                work = os.path.join(scratch, f"{name}-{coef}-{tag}")
                os.makedirs(work, exist_ok=True)
                text = experiment_text(coef, train, static_csv, v_ref, n_points, work)
                variants.append((n_points,) + fit_and_predict(work, text, held))
            sections.append((name, label, coef, train, held, variants))
    write_md(sections, stall_deg, time.time() - t0)


def write_md(sections, stall_deg, seconds):
    p = print
    p("<!-- Written by `nice python3 tools/validate_digitized.py DIR INDICIAL SCRATCH` (its docstring has the "
      "method); do not edit the tables by hand. -->")
    p("# Fits from digitized cycles against fits from the measured ones\n")
    p(f"Tool: `{vr.tool_version()}`. Wall time {seconds:.0f} s (nice, shared 2-core machine). Data: DIR's "
      "cycles (the development set for the committed file; not in this repository). Model: the Beddoes-Leishman "
      "start of tools/validate_real.py, `indicial fit` (start search), no diagnose. Digitized: each quantity at its "
      f"own {' or '.join(str(n) for n in N_POINTS)} jittered phases per cycle, reading error {READ_ERROR * 100:g} % "
      "of its peak-to-peak (1 sigma), resampled by the reader to 128 phases. Held out: every other cycle but the "
      "polar's, predicted from its measured file. Columns: median of RMS / quasi-steady RMS, cycles at <= 0.5x, "
      "mean RMS.\n")
    for name, label, coef, train, held, variants in sections:
        p(f"## {coef}, training `{name}` ({label})\n")
        p("Training cycles: " + ", ".join(f"{c['id']} (mean {c['mean']:g}, k {c['k']:.3f})" for c in train) + "\n")
        names = sorted({k for v in variants for k in v[2]} & {"T1", "T2", "CN1", "Tv", "Tvl", "cv", "Caq_0"})
        p("| training data | fit error | " + " | ".join(names) + " |")
        p("|---|---|" + "---|" * len(names))
        for n_points, fit_error, params, _ in variants:
            tag = "measured (128 samples)" if n_points is None else f"digitized, {n_points} points"
            p(f"| {tag} | {fit_error:.4g} | " + " | ".join(f"{params[k]:.4g}" if k in params else "-" for k in names) + " |")
        p("")
        p("| regime | cycles | " + " | ".join(
            ("measured" if n is None else f"N = {n}") + ": median ratio, <= 0.5x, mean RMS" for n, *_ in variants) + " |")
        p("|---|---|" + "---|" * len(variants))
        for regime_name in ("attached", "light", "deep", "all"):
            cells = []
            count = 0
            for _, _, _, rows in variants:
                count, med, good, mean = summary(rows, held, stall_deg, regime_name)
                cells.append(f"{med:.2f}, {good}, {mean:.4f}")
            p(f"| {regime_name} | {count} | " + " | ".join(cells) + " |")
        p("")


if __name__ == "__main__":
    main()
