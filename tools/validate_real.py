#!/usr/bin/env python3
"""Issue 21, item 5: fit and diagnose measured pitching cycles, predict every other cycle.

Called by tools/validate-real.sh (read that first). Standard library only. For each training
choice and coefficient (CL, Cm) it writes an experiment file in a scratch directory whose runs
point at the data directory's own files (nothing is copied), runs `indicial fit` (the
configured model) and `indicial diagnose` (leave-one-run-out with three runs), and predicts
every other cycle of the catalogue that is not quasi-static at its periodic steady state
(`indicial predict --periodic --experiment`). Per cycle: RMS of each model column and of the
quasi-steady model. The models after each diagnose step come from `--max-steps k`. The
training cycles, the polar's cycles and the regimes are chosen by the rules of
tools/cycle_catalog.py, never by cycle id: `python3 tools/validate_real.py --choices DIR` prints
what the study would train on.

Columns are a list (`columns` in main(), one per model: the configured fit, then one per
diagnose step): another study adds a column by appending (label, coefficient file).

INDICIAL_VALIDATE_FORCING_LAG=first_order (environment) fits the Beddoes-Leishman start with
`stall_forcing_lag = "first_order"` (model.hpp's ForcingLag; default "delay", what
docs/validation-real.md is written with); docs/validation-real-first-order.md is that variant:
    INDICIAL_VALIDATE_FORCING_LAG=first_order nice python3 tools/validate_real.py DIR \
        build/tools/indicial SCRATCH docs/validation-real-first-order.md
"""
import hashlib
import json
import os
import subprocess
import sys
import time

import cycle_catalog

# Set by parse_args() from the command line (main()), so that importing this module reads no argv.
CHOICES_ONLY = False
DATA = EXE = SCRATCH = OUT_MD = None


def parse_args(argv):
    global CHOICES_ONLY, DATA, EXE, SCRATCH, OUT_MD
    CHOICES_ONLY = len(argv) == 3 and argv[1] == "--choices"
    if not CHOICES_ONLY and len(argv) != 5:
        sys.exit("usage: validate_real.py DIR INDICIAL SCRATCH OUT.md | validate_real.py --choices DIR")
    DATA = os.path.abspath(argv[2] if CHOICES_ONLY else argv[1])
    EXE = None if CHOICES_ONLY else os.path.abspath(argv[2])
    SCRATCH = None if CHOICES_ONLY else os.path.abspath(argv[3])
    OUT_MD = None if CHOICES_ONLY else argv[4]

# The reference length in pitch: the chord's half (the development set's README: c = 0.55 m).
# Another database in this layout with another chord: INDICIAL_CHORD_M.
CHORD_M = float(os.environ.get("INDICIAL_CHORD_M", "0.55"))
L_REF_M = CHORD_M / 2.0


def cycle_file(c):
    return cycle_catalog.cycle_path(DATA, c)


def static_table(catalog, path):
    """The static polar: upstrokes (alpha increasing) of the quasi-static cycles
    (cycle_catalog.polar_cycles), Cn, Ct and Cm averaged in 1 deg bins (the runtime holds 64
    rows at most); written in the database's own layout (a % header, whitespace), so that the
    experiment's [columns] read it as they read the cycles (CL derived from Cn, Ct). Returns the
    first and last rows' angles, the number of rows, the sentence naming the source, the stall
    angle and the ids of the polar's cycles (never trained on or held out)."""
    cycles, source = cycle_catalog.polar_cycles(catalog)
    bins = cycle_catalog.upstroke_bins(DATA, cycles)
    with open(path, "w") as f:
        f.write("% Angle(deg) Cn Ct Cm\n")
        for b in sorted(bins):
            s = bins[b]
            f.write(f"{b} {s[1] / s[0]:.6g} {s[2] / s[0]:.6g} {s[3] / s[0]:.6g}\n")
    keys = sorted(bins)
    return keys[0], keys[-1], len(keys), source, cycle_catalog.stall_angle_deg(bins), {c["id"] for c in cycles}


def training_choices(catalog, static_info):
    """The issue's two training choices, by cycle_catalog's rules: three cycles of one frequency
    sweep, and three cycles across mean angles."""
    lo, hi, _, _, stall, polar_ids = static_info
    sweep, group = cycle_catalog.choose_sweep(DATA, catalog, stall, lo, hi, polar_ids)
    means = cycle_catalog.choose_means(DATA, catalog, group, [c["k"] for c in sweep], lo, hi, polar_ids)
    m = means[0]
    return [
        ("sweep", f"one frequency sweep: campaign {group[0]}, mean {group[1]:g} deg, amplitude {group[2]:g} deg, "
                  "k = " + ", ".join(f"{c['k']:.3f}" for c in sweep), sweep),
        ("means", f"across mean angles: campaign {m['campaign']}, amplitude {m['amp']:g} deg, k = {m['k']:.3f}, "
                  "means " + ", ".join(f"{c['mean']:g}" for c in means) + " deg", means),
    ]


def peak_deg(c):
    return cycle_catalog.measured_range_deg(DATA, c)[1]


def experiment_toml(coef, runs, static_csv, v_ref, model_keys):
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
{model_keys}"""


# The two starting models every training choice is fitted and diagnosed from (C_aq = 0 a priori
# in both: [rotary] polynomial = [0]):
# * "report": the report's model as its Example 1 configures it, a(x) of degree 2 with knots
#   every 5 deg inside the training cycles' angle range, b1 constant.
# * "bl": the Beddoes-Leishman structure in the report's form: a and b1 constants, a constant
#   pitch-rate correction C_aq estimated (rotary_correction_powers = [0]), and the separation
#   and leading-edge-vortex families with the static table as the lift polar.
# docs/measured-cycles.md compares them (these tables and a user's trial) and recommends the second.
FORCING_LAG = os.environ.get("INDICIAL_VALIDATE_FORCING_LAG", "delay")
if FORCING_LAG not in ("delay", "first_order"):
    sys.exit(f"INDICIAL_VALIDATE_FORCING_LAG: expected delay or first_order, found '{FORCING_LAG}'")
CONFIGS = (
    ("report", "the report's model (a(x) of degree 2 with knots every 5 deg inside the training range, b1 constant)"),
    ("bl", "the Beddoes-Leishman structure (a and b1 constants, C_aq constant estimated, separation and vortex "
           "families" + ("" if FORCING_LAG == "delay" else f", stall_forcing_lag = \"{FORCING_LAG}\"") + ")"),
)


def model_keys(config, knots, static_csv):
    if config == "report":
        return (f"a_degree = 2\na_knots_deg = [{', '.join(str(k) for k in knots)}]\nb1_degree = 0\nbias = false\n"
                'structure = "fixed"\n')
    return ("a_degree = 0\nb1_degree = 0\nbias = false\nstructure = \"fixed\"\nrotary_correction_powers = [0]\n"
            f'stall = "separation_and_vortex"\nstall_polar = "{static_csv}"\nstall_polar_column = "CL"\n' +
            ("" if FORCING_LAG == "delay" else f'stall_forcing_lag = "{FORCING_LAG}"\n'))


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


def print_choices():
    import tempfile
    catalog = cycle_catalog.read_catalog(DATA)
    with tempfile.TemporaryDirectory() as tmp:
        info = static_table(catalog, os.path.join(tmp, "static.dat"))
    print(f"static polar: {info[3]}; {info[2]} rows, {info[0]:g} to {info[1]:g} deg; stall angle {info[4]:g} deg")
    print("regimes: " + cycle_catalog.regime_rule(info[4]))
    for name, label, train in training_choices(catalog, info):
        print(f"{name}: {label}: " + ", ".join(c["id"] for c in train))


REUSED = []  # the studies whose fit and diagnosis came from an earlier run (study, below)


def tool_version():
    return run([EXE, "--version"]).stdout.strip()


def reuse_key(experiment_text):
    """What a kept fit and diagnosis depend on: the experiment, the static polar's bytes, the
    tool's version and commit."""
    with open(os.path.join(SCRATCH, "static.dat"), "rb") as f:
        polar = hashlib.sha256(f.read()).hexdigest()
    return hashlib.sha256("\n".join((experiment_text, polar, tool_version())).encode()).hexdigest()


def reuse_key_matches(work, experiment_text):
    path = os.path.join(work, "reuse.key")
    if not os.path.exists(path):
        return False
    with open(path) as f:
        return f.read() == reuse_key(experiment_text)


def study(work, experiment_text, held, qs):
    """Fit and diagnose one experiment, predict every held-out cycle with each model (the fit,
    then one per diagnose step). qs: cycle id -> the quasi-steady RMS, filled by the first
    study of a training choice and coefficient (its configured model has C_aq = 0: predict's
    quasi-steady column is the static table alone; a model with an estimated C_aq has it in
    that column) and reused by the next."""
    os.makedirs(work, exist_ok=True)
    exp = os.path.join(work, "experiment.toml")
    # INDICIAL_VALIDATE_REUSE=1 with a SCRATCH kept from an earlier run (python3
    # tools/validate_real.py with a SCRATCH of your own; validate-real.sh always starts afresh)
    # reuses the fit and diagnosis of an experiment whose reuse_key (experiment text, polar
    # bytes, tool version) is unchanged: only the predictions run again, and the report says so.
    reuse = os.environ.get("INDICIAL_VALIDATE_REUSE") == "1" and reuse_key_matches(work, experiment_text)
    if reuse:
        REUSED.append(work)
    else:
        with open(exp, "w") as f:
            f.write(experiment_text)
        run([EXE, "fit", exp, "--out", os.path.join(work, "fit"), "--force", "--no-plots"])
        run([EXE, "diagnose", exp, "--out", os.path.join(work, "diag"), "--force", "--no-plots", "--quiet"],
            ok=(0, 6))
        with open(os.path.join(work, "reuse.key"), "w") as f:
            f.write(reuse_key(experiment_text))
    with open(os.path.join(work, "diag", "diagnosis.json")) as f:
        dj = json.load(f)
    t_diag = dj["elapsed_s"]  # diagnose's own wall time
    columns = [("configured", os.path.join(work, "fit", "model.coef"))]
    steps = dj["steps"]
    for k in range(1, len(steps) + 1):
        d = os.path.join(work, f"diag{k}")
        if k == len(steps):
            path = os.path.join(work, "diag", "model.coef")
        else:
            path = os.path.join(d, "model.coef")
            if not (reuse and os.path.exists(path)):
                run([EXE, "diagnose", exp, "--out", d, "--force", "--no-plots", "--quiet", "--max-steps", str(k)],
                    ok=(0, 6))
        columns.append((f"+{steps[k - 1]['effect']}", path))
    fill = not qs
    rows = []
    for c in held:
        r = {"c": c, "rms": []}
        for j, (_, model) in enumerate(columns):
            m, q = predict_rms(model, c, exp, work)
            r["rms"].append(m)
            if j == 0 and fill:
                qs[c["id"]] = q
        r["qs"] = qs[c["id"]]
        rows.append(r)
    return dj, t_diag, columns, rows


def main():
    parse_args(sys.argv)
    if CHOICES_ONLY:
        print_choices()
        return
    t0 = time.time()
    catalog = cycle_catalog.read_catalog(DATA)
    os.makedirs(SCRATCH, exist_ok=True)
    static_csv = os.path.join(SCRATCH, "static.dat")
    static_info = static_table(catalog, static_csv)
    sections = []
    for name, label, train in training_choices(catalog, static_info):
        train_ids = {c["id"] for c in train}
        # Held out: every other cycle except the polar's.
        held = [c for c in catalog if c["id"] not in train_ids and c["id"] not in static_info[5]]
        v_ref = round(sum(c["v"] for c in train) / len(train), 3)
        a_lo = min(cycle_catalog.measured_range_deg(DATA, c)[0] for c in train)
        a_hi = max(peak_deg(c) for c in train)
        # a(x) knots every 5 deg inside the training range (a generic grid, not tuned).
        knots = [k for k in range(0, 40, 5) if a_lo + 2.0 < k < a_hi - 2.0]
        for coef in ("CL", "Cm"):
            qs = {}
            for config, config_label in CONFIGS:
                work = os.path.join(SCRATCH, f"{name}-{coef}-{config}")
                keys = model_keys(config, knots, static_csv)
                dj, t_diag, columns, rows = study(work, experiment_toml(coef, train, static_csv, v_ref, keys), held, qs)
                sections.append((name, label, coef, config_label, train, knots, dj, t_diag, columns, rows))
    write_md(sections, static_info, time.time() - t0)


def write_md(sections, static_info, seconds):
    lo, hi, nrows, source, stall_deg, _ = static_info
    regime = lambda c: cycle_catalog.regime(peak_deg(c), stall_deg)
    out = []
    w = out.append
    w("# Validation on measured cycles (issue 21)\n")
    campaigns = sorted({c["campaign"] for _, _, _, _, train, *_ in sections for c in train} |
                       {r["c"]["campaign"] for *_, rows in sections for r in rows})
    n_held = len(sections[0][-1]) if sections else 0
    w("Written by `tools/validate-real.sh DIR` (do not edit by hand; rerun it). Data: the pitching cycles of DIR's "
      f"catalog.csv (campaigns {', '.join(campaigns)}); for the committed file DIR is the development set: "
      "ensemble-averaged pitching cycles of a NACA 0012 wing section, University of Glasgow dynamic-stall database "
      "(Green, R. B. & Giuni, M., \"Dynamic stall database R and D 1570-AM-01: Final Report\", University of "
      "Glasgow, 2017; as stored in the public repository luizpancini/BL-DSM-JFS-2021, folder \"Glasgow Data\"). "
      "The data are not in this repository: the script reads them from DIR. Every choice below (the polar's cycles, "
      "the training cycles, the regimes) is a rule on the catalog stated in tools/cycle_catalog.py, not a list of "
      "cycles: the script runs unchanged on another campaign or database in the same layout.\n")
    w(f"Static polar (the same for every column): {source}, CL = Cn cos(alpha) + Ct sin(alpha), averaged in 1 deg "
      f"bins: {nrows} rows, {lo:g} to {hi:g} deg; static stall angle (largest lift) {stall_deg:g} deg. Two "
      "starting models, each fitted and then diagnosed (`indicial diagnose`, three runs: leave-one-run-out, adds "
      "effects to it): " + "; ".join(f"`{c}`, {lab}" for c, lab in CONFIGS) + ". Both have one lag and C_aq = 0 "
      "a priori; the quasi-steady model every ratio below divides by is the static table alone. "
      f"Every other cycle that is not one of the polar's ({n_held}) is predicted at its periodic steady "
      "state (`indicial predict --periodic`) and scored by RMS over its samples. Regimes by the cycle's largest "
      f"measured angle: {cycle_catalog.regime_rule(stall_deg)}.\n")
    w(f"Tool: `{tool_version()}`. Total wall time of the study: {seconds:.0f} s (nice, shared 2-core machine)" +
      (f"; the fits and diagnoses of {len(REUSED)} of its {len(sections)} studies were kept from an earlier run of "
       "the same experiment files (each diagnose's own wall time is in its section)" if REUSED else "") + ".\n")
    for name, label, coef, config_label, train, knots, dj, t_diag, columns, rows in sections:
        w(f"## Training `{name}` ({label}): {coef}, from {config_label}\n")
        w("Training cycles: " + ", ".join(f"{c['id']} (mean {c['mean']:g}, k {c['k']:.3f})" for c in train) +
          f"; the report model's a(x) knots {knots} deg.\n")
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
        if len(labels) > 1:
            w("What each effect bought on the held-out cycles (median over cycles of the RMS change, previous "
              "column -> this one):\n")
        for j in range(1, len(labels)):
            ch = sorted(r["rms"][j] / r["rms"][j - 1] for r in rows if r["rms"][j - 1] > 0)
            better = sum(1 for x in ch if x < 1.0)
            w(f"* `{labels[j]}`: median RMS ratio {ch[len(ch) // 2]:.3f}, lower on {better} of {len(ch)} cycles.")
        if len(labels) > 1:
            w("")
    verdict = []
    for name, label, coef, config_label, train, knots, dj, t_diag, columns, rows in sections:
        ratios = [r["rms"][-1] / r["qs"] for r in rows if r["qs"] > 0]
        stall = [r["rms"][-1] / r["qs"] for r in rows if r["qs"] > 0 and regime(r["c"]) != "attached"]
        effects = ", ".join(f"`{e}`" for e in dj["effects_added"]) or "nothing"
        verdict.append(f"* `{name}` {coef} from {config_label.split(' (')[0]}: diagnose added {effects}; the final "
                       f"model at <= 0.5x quasi-steady on {sum(x <= 0.5 for x in ratios)} of {len(ratios)} held-out "
                       f"cycles ({sum(x <= 0.5 for x in stall)} of {len(stall)} stall cycles), median ratio "
                       f"{sorted(ratios)[len(ratios) // 2]:.2f}.")
    w("## Summary\n")
    w("\n".join(verdict) + "\n")
    w("Read honestly: where the counts above are low, the model does not reach half the quasi-steady error; "
      "attached cycles rarely can (the static table is already close there, and what is left is of the order of "
      "the differences between campaigns). Three training cycles are little data: an effect diagnose adds on the "
      "training runs' held-out error can still cost on cycles far from them (see each effect's line above). "
      "docs/validation-stall.md trains on 104 cycles.\n")
    with open(OUT_MD, "w") as f:
        f.write("\n".join(out))


if __name__ == "__main__":
    main()
