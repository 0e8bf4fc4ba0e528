#!/usr/bin/env python3
"""Issue 21, item 5: fit and diagnose measured pitching cycles, predict every other cycle.

Called by tools/validate-real.sh (read that first). Standard library only. For each training
choice and coefficient (CL, Cm) it writes an experiment file in a scratch directory whose runs
point at the data directory's own files (nothing is copied), runs `indicial fit` (the
configured model) and `indicial diagnose` (leave-one-run-out with three runs), and predicts
every cycle of the catalogue that is not a training cycle at its periodic steady state
(`indicial predict --periodic --experiment`). Per cycle: RMS of each model column and of the
quasi-steady model. The models after each diagnose step come from `--max-steps k`.

Columns are a list (MODEL_COLUMNS below, built per training choice): another study adds a
column by appending (label, coefficient file) -- the extended dynamic-stall model, or a peer
read from bl-reference.csv (PEER_COLUMNS).
"""
import csv
import json
import math
import os
import subprocess
import sys
import time

DATA = os.path.abspath(sys.argv[1])
EXE = os.path.abspath(sys.argv[2])
SCRATCH = os.path.abspath(sys.argv[3])
OUT_MD = sys.argv[4]

CHORD_M = 0.55
L_REF_M = CHORD_M / 2.0  # the README: l = c / 2 in pitch

# Training choices (the issue's two): three cycles of one frequency sweep, and cycles across
# mean angles at one reduced frequency. Campaign 4, amplitude 10 deg (the peer's cycles).
TRAINING = [
    ("sweep", "one frequency sweep: mean 15 deg, amplitude 10 deg, k = 0.05, 0.10, 0.15",
     lambda c: c["campaign"] == 4 and c["mean"] == 15.0 and c["amp"] == 10.0 and
     any(abs(c["k"] - k) < 0.006 for k in (0.0497, 0.1005, 0.1515))),
    # Means 6, 8, 15 rather than 4: the mean-4 cycle reaches -6.49 deg, below the quasi-static
    # polar's lowest bin (-6 deg), and fit refuses a static table that does not cover its runs.
    ("means", "across mean angles: amplitude 10 deg, k = 0.10, means 6, 8 and 15 deg",
     lambda c: c["campaign"] == 4 and c["amp"] == 10.0 and abs(c["k"] - 0.1005) < 0.003 and
     c["mean"] in (6.0, 8.0, 15.0)),
]


def read_catalog():
    rows = []
    with open(os.path.join(DATA, "catalog.csv")) as f:
        for r in csv.DictReader(f):
            rows.append({"id": r["id"], "campaign": int(r["campaign"]), "mean": float(r["mean_deg"]),
                         "amp": float(r["amplitude_deg"]), "f": float(r["frequency_hz"]),
                         "k": float(r["reduced_frequency"]), "v": float(r["airspeed_mps"])})
    return rows


def cycle_file(c):
    return os.path.join(DATA, "cycles", c["id"] + "_coeffs.dat")


def read_cycle(c):
    """alpha (deg), Cn, Ct, Cm of one cycle, as the database stores them."""
    a, cn, ct, cm = [], [], [], []
    with open(cycle_file(c)) as f:
        for line in f:
            s = line.split()
            if not s or s[0].startswith("%"):
                continue
            a.append(float(s[1]))
            cn.append(float(s[2]))
            ct.append(float(s[3]))
            cm.append(float(s[4]))
    return a, cn, ct, cm


def regime(c):
    """Flow regime by the cycle's peak angle (static stall of this airfoil at these Reynolds
    numbers is near 13 deg): attached below 13 deg, deep stall from 22 deg, light between."""
    peak = c["mean"] + c["amp"]
    return "attached" if peak < 13.0 else ("deep" if peak >= 22.0 else "light")


def static_table(catalog, path):
    """The static polar: upstrokes (alpha increasing) of every k ~ 0.010 cycle, Cn, Ct and Cm
    averaged in 1 deg bins (the runtime holds 64 rows at most); written in the database's own layout (a % header, whitespace), so
    that the experiment's [columns] read it as they read the cycles (CL derived from Cn, Ct)."""
    bins = {}
    n_cycles = 0
    for c in catalog:
        if c["k"] > 0.011:
            continue
        n_cycles += 1
        a, cn, ct, cm = read_cycle(c)
        n = len(a)
        for i in range(n):
            if a[(i + 1) % n] - a[i - 1] <= 0.0:
                continue  # the downstroke
            b = float(round(a[i]))
            s = bins.setdefault(b, [0.0, 0.0, 0.0, 0])
            s[0] += cn[i]
            s[1] += ct[i]
            s[2] += cm[i]
            s[3] += 1
    with open(path, "w") as f:
        f.write("% Angle(deg) Cn Ct Cm\n")
        for b in sorted(bins):
            s = bins[b]
            f.write(f"{b} {s[0] / s[3]:.6g} {s[1] / s[3]:.6g} {s[2] / s[3]:.6g}\n")
    keys = sorted(bins)
    return keys[0], keys[-1], len(keys), n_cycles


def experiment_toml(coef, runs, static_csv, v_ref, knots):
    entries = ", ".join(
        f'{{file = "{cycle_file(c)}", frequency_hz = {c["f"]}, airspeed_mps = {c["v"]}}}' for c in runs)
    return f"""# validate-real: {coef} on {len(runs)} measured cycles (University of Glasgow NACA 0012 database)
axis = "pitch"
coefficient = "{coef}"
reference_length_m = {L_REF_M}
airspeed_mps = {v_ref}
runs = [{entries}]

[columns]
phase_rad = "Time()"
alpha_deg = "Angle(deg)"
Cnormal = "Cn"
Ctangential = "Ct"

[csv]
delimiter = "whitespace"
comment = "%"

[static]
table = "{static_csv}"

[rotary]
polynomial = [0]
estimate = false

[model]
a_degree = 2
a_knots_deg = [{", ".join(str(k) for k in knots)}]
b1_degree = 0
bias = false
structure = "fixed"
"""


def run(cmd, ok=(0,)):
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode not in ok:
        raise RuntimeError(f"{' '.join(cmd)} -> {p.returncode}\n{p.stderr[-2000:]}")
    return p


def predict_rms(model, c, exp_path, work):
    out = os.path.join(work, "p.csv")
    met = os.path.join(work, "p.json")
    run([EXE, "predict", model, cycle_file(c), "--experiment", exp_path, "--periodic", "--frequency-hz",
         str(c["f"]), "--airspeed-mps", str(c["v"]), "--out", out, "--metrics", met, "--force"])
    with open(met) as f:
        m = json.load(f)
    co = m["coefficients"][0] if isinstance(m.get("coefficients"), list) else m
    return co["model"]["rms_error"], co["quasi_steady"]["rms_error"]


def main():
    t0 = time.time()
    catalog = read_catalog()
    os.makedirs(SCRATCH, exist_ok=True)
    static_csv = os.path.join(SCRATCH, "static.dat")
    static_info = static_table(catalog, static_csv)
    sections = []
    for name, label, pick in TRAINING:
        train = [c for c in catalog if pick(c)]
        train_ids = {c["id"] for c in train}
        held = [c for c in catalog if c["id"] not in train_ids]
        v_ref = round(sum(c["v"] for c in train) / len(train), 3)
        a_lo = min(c["mean"] - c["amp"] for c in train)
        a_hi = max(c["mean"] + c["amp"] for c in train)
        # a(x) knots every 5 deg inside the training range (a generic grid, not tuned).
        knots = [k for k in range(0, 40, 5) if a_lo + 2.0 < k < a_hi - 2.0]
        for coef in ("CL", "Cm"):
            work = os.path.join(SCRATCH, f"{name}-{coef}")
            os.makedirs(work, exist_ok=True)
            exp = os.path.join(work, "experiment.toml")
            with open(exp, "w") as f:
                f.write(experiment_toml(coef, train, static_csv, v_ref, knots))
            run([EXE, "fit", exp, "--out", os.path.join(work, "fit"), "--force", "--no-plots"])
            td = time.time()
            run([EXE, "diagnose", exp, "--out", os.path.join(work, "diag"), "--force", "--no-plots", "--quiet"],
                ok=(0, 6))
            t_diag = time.time() - td
            with open(os.path.join(work, "diag", "diagnosis.json")) as f:
                dj = json.load(f)
            columns = [("configured", os.path.join(work, "fit", "model.coef"))]
            steps = dj["steps"]
            for k in range(1, len(steps) + 1):
                d = os.path.join(work, f"diag{k}")
                if k == len(steps):
                    path = os.path.join(work, "diag", "model.coef")
                else:
                    run([EXE, "diagnose", exp, "--out", d, "--force", "--no-plots", "--quiet", "--max-steps", str(k)],
                        ok=(0, 6))
                    path = os.path.join(d, "model.coef")
                columns.append((f"+{steps[k - 1]['effect']}", path))
            rows = []
            for c in held:
                r = {"c": c, "qs": None, "rms": []}
                for j, (_, model) in enumerate(columns):
                    m, qs = predict_rms(model, c, exp, work)
                    r["rms"].append(m)
                    # The reference is the configured model's quasi-steady part (the static
                    # table; C_aq = 0): a diagnosed C_aq would move predict's quasi-steady column.
                    if j == 0:
                        r["qs"] = qs
                rows.append(r)
            sections.append((name, label, coef, train, knots, dj, t_diag, columns, rows))
    write_md(sections, static_info, time.time() - t0)


def write_md(sections, static_info, seconds):
    lo, hi, nrows, n_cycles = static_info
    out = []
    w = out.append
    w("# Validation on measured cycles (issue 21)\n")
    w("Written by `tools/validate-real.sh DIR` (do not edit by hand; rerun it). Data: 186 ensemble-averaged "
      "pitching cycles of a NACA 0012 wing section, University of Glasgow dynamic-stall database (Green, R. B. & "
      "Giuni, M., \"Dynamic stall database R and D 1570-AM-01: Final Report\", University of Glasgow, 2017; as "
      "stored in the public repository luizpancini/BL-DSM-JFS-2021, folder \"Glasgow Data\"), campaigns 4-6. The "
      "data are not in this repository: the script reads them from DIR.\n")
    w(f"Static polar (the same for every column): the upstrokes of the {n_cycles} k ~ 0.010 cycles "
      f"(quasi-static), CL = Cn cos(alpha) + Ct sin(alpha), averaged in 1 deg bins: {nrows} rows, {lo} to {hi} "
      "deg. Model: one lag, a(x) of degree 2 with knots every 5 deg inside the training cycles' angle range, b1 "
      "constant, C_aq = 0 a priori (not estimated): the configured model. `indicial diagnose` (three runs: "
      "leave-one-run-out) adds effects to it. Every non-training cycle is predicted at its periodic steady state "
      "(`indicial predict --periodic`) and scored by RMS over its 128 samples. Regimes by the peak angle "
      "(mean + amplitude): attached < 13 deg, light stall 13-22 deg, deep stall >= 22 deg.\n")
    w(f"Total wall time of the study: {seconds:.0f} s (nice, shared 2-core machine).\n")
    for name, label, coef, train, knots, dj, t_diag, columns, rows in sections:
        w(f"## Training `{name}` ({label}): {coef}\n")
        w("Training cycles: " + ", ".join(f"{c['id']} (mean {c['mean']:g}, k {c['k']:.3f})" for c in train) +
          f"; a(x) knots {knots} deg.\n")
        w(f"Diagnose: rule `{dj['rule']}`, noise source `{dj.get('noise_source')}`, verdict `{dj['verdict']}`, "
          f"effects added {dj['effects_added'] or 'none'}, fit error {dj['initial_fit_error']:.4g} -> "
          f"{dj['final_fit_error']:.4g}, {dj['fits_run']} fits, {t_diag:.1f} s wall.\n")
        if dj["steps"]:
            w("| step | effect | terms | held-out RMS per training run before | after |\n|---|---|---|---|---|")
            for i, s in enumerate(dj["steps"], start=1):
                b = ", ".join(f"{v:.4g}" for v in s.get("held_out_rms_before", []))
                a = ", ".join(f"{v:.4g}" for v in s.get("held_out_rms_after", []))
                w(f"| {i} | `{s['effect']}` | {s['term']} | {b} | {a} |")
            w("")
        labels = [lab for lab, _ in columns]
        w("Held-out cycles, by regime: median RMS of each column over the quasi-steady model's, and the cycles "
          "at <= 0.5x quasi-steady:\n")
        w("| regime | cycles | " + " | ".join(f"{lab}: median ratio | {lab}: <= 0.5x" for lab in labels) +
          " |\n|---|---|" + "---|---|" * len(labels))
        for reg in ("attached", "light", "deep", "all"):
            sel = [r for r in rows if reg == "all" or regime(r["c"]) == reg]
            if not sel:
                continue
            cells = []
            for j in range(len(labels)):
                ratios = sorted(r["rms"][j] / r["qs"] for r in sel if r["qs"] > 0)
                med = ratios[len(ratios) // 2] if ratios else float("nan")
                good = sum(1 for x in ratios if x <= 0.5)
                cells.append(f"{med:.2f} | {good} of {len(ratios)}")
            w(f"| {reg} | {len(sel)} | " + " | ".join(cells) + " |")
        w("")
        w("What each effect bought on the held-out cycles (median over cycles of the RMS change, previous column "
          "-> this one):\n")
        for j in range(1, len(labels)):
            ch = sorted(r["rms"][j] / r["rms"][j - 1] for r in rows if r["rms"][j - 1] > 0)
            better = sum(1 for x in ch if x < 1.0)
            w(f"* `{labels[j]}`: median RMS ratio {ch[len(ch) // 2]:.3f}, lower on {better} of {len(ch)} cycles.")
        w("")
    verdict = []
    for name, label, coef, train, knots, dj, t_diag, columns, rows in sections:
        stall = [r for r in rows if regime(r["c"]) != "attached"]
        good = sum(1 for r in stall if r["qs"] > 0 and r["rms"][-1] / r["qs"] <= 0.5)
        verdict.append(f"* `{name}` {coef}: final model <= 0.5x quasi-steady on {good} of {len(stall)} stall cycles.")
    w("## Summary\n")
    w("\n".join(verdict) + "\n")
    w("Read honestly: where the counts above are low, the configured model with the diagnosed effects does not "
      "reach half the quasi-steady error on stall cycles. The dynamic-stall families of issue 22 are among diagnose's "
      "candidates (for Cm too, with the lift from the static table) and are named above where they lowered the "
      "held-out error of the training runs; from three training cycles they do not carry C_m to half the "
      "quasi-steady error (docs/validation-stall.md trains on 104 cycles).\n")
    with open(OUT_MD, "w") as f:
        f.write("\n".join(out))


if __name__ == "__main__":
    main()
