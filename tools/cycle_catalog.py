"""A pitching-airfoil cycle database laid out as the Glasgow development set, and the choices the
validation studies make on it by stated rules (tools/validate_real.py, tools/validate_stall.py).

Layout (the development set's README): `catalog.csv` with `id, campaign, mean_deg,
amplitude_deg, frequency_hz, reduced_frequency, airspeed_mps` (further columns ignored) and one
cycle per `cycles/<id>_coeffs.dat`: a `%` header, then whitespace-separated rows of phase (rad),
angle (deg), Cn, Ct, Cm. Nothing here names a campaign, a mean angle or a frequency of the
development set: every selection is a rule on the catalog and the static polar, so that the
studies run unchanged on another campaign or another database in this layout (issue 21: the
acceptance is measured on cycles we do not have). Standard library only.

The rules:
* quasi-static cycles: reduced frequency <= QUASI_STATIC_K; they give the static polar. The
  polar's cycles (these, or the fallback's below) are never a training or held-out cycle. A catalog without any gives the polar from its slowest
  cycles (reduced frequency within 10 % of the lowest), which carry their own lag: the study
  then says so, because its "quasi-steady" column is no longer a static model.
* the static stall angle: the angle of the polar's largest lift (bins of >= 4 samples).
* regimes by a cycle's largest angle: attached below the static stall angle, deep stall from
  DEEP_STALL_MARGIN_DEG beyond it, light stall between (15 and 22 deg on the development set).
"""
import csv
import math
import os

QUASI_STATIC_K = 0.015
DEEP_STALL_MARGIN_DEG = 7.0
MIN_BIN_SAMPLES = 4
K_RESOLUTION = 0.005  # reduced frequencies closer than this are one frequency (one nominal k at two airspeeds)


def read_catalog(data):
    """The catalog's rows: id, campaign (text), mean, amp (deg), f (Hz), k, v (m/s). A row that
    cannot be read, a value out of its range, a repeated id or a missing cycle file stops the
    study with the file, the line and the problem."""
    path = os.path.join(data, "catalog.csv")
    if not os.path.exists(path):
        raise SystemExit(f"{path}: not found (a catalog.csv and cycles/<id>_coeffs.dat are needed)")
    rows, seen = [], {}
    with open(path) as f:
        for line, r in enumerate(csv.DictReader(f), start=2):
            try:
                c = {"id": r["id"].strip(), "campaign": r["campaign"].strip(),
                     "mean": float(r["mean_deg"]), "amp": float(r["amplitude_deg"]),
                     "f": float(r["frequency_hz"]), "k": float(r["reduced_frequency"]),
                     "v": float(r["airspeed_mps"])}
            except (KeyError, ValueError, TypeError, AttributeError) as e:
                raise SystemExit(f"{path}:{line}: cannot read the row ({e!r}); the columns needed are id, "
                                 "campaign, mean_deg, amplitude_deg, frequency_hz, reduced_frequency, airspeed_mps")
            bad = [k for k in ("amp", "f", "k", "v") if not (math.isfinite(c[k]) and c[k] > 0)]
            if bad or not math.isfinite(c["mean"]):
                raise SystemExit(f"{path}:{line}: cycle {c['id']}: amplitude_deg, frequency_hz, reduced_frequency "
                                 "and airspeed_mps must be finite and > 0, mean_deg finite")
            if c["id"] in seen:
                raise SystemExit(f"{path}:{line}: cycle id {c['id']} repeats line {seen[c['id']]}")
            seen[c["id"]] = line
            if not os.path.exists(cycle_path(data, c)):
                raise SystemExit(f"{path}:{line}: {cycle_path(data, c)}: cycle file not found")
            rows.append(c)
    if not rows:
        raise SystemExit(f"{path}: no cycles")
    return rows


def cycle_path(data, c):
    return os.path.join(data, "cycles", c["id"] + "_coeffs.dat")


def numeric_rows(path):
    """The database's layout: whitespace-separated numbers, `%` comment lines skipped."""
    with open(path) as f:
        for line in f:
            s = line.split()
            if s and not s[0].startswith("%"):
                yield [float(v) for v in s]


def lift(alpha_deg, cn, ct):
    """CL = Cn cos(alpha) + Ct sin(alpha)."""
    ar = math.radians(alpha_deg)
    return cn * math.cos(ar) + ct * math.sin(ar)


def read_cycle(path):
    """The cycle's rows as (phase_rad, alpha_deg, Cn, Ct, Cm, CL), CL = Cn cos(alpha) + Ct sin(alpha)."""
    return [(ph, a, cn, ct, cm, lift(a, cn, ct)) for ph, a, cn, ct, cm in (r[:5] for r in numeric_rows(path))]


def is_quasi_static(c):
    return c["k"] <= QUASI_STATIC_K


def k_key(c):
    return round(c["k"] / K_RESOLUTION)


def polar_cycles(catalog):
    """The cycles the static polar is built from, and a sentence saying which."""
    qs = [c for c in catalog if is_quasi_static(c)]
    if qs:
        return qs, f"the upstrokes of the {len(qs)} quasi-static cycles (k <= {QUASI_STATIC_K})"
    k_min = min(c["k"] for c in catalog)
    slow = [c for c in catalog if c["k"] <= 1.1 * k_min]
    k_max = max(c["k"] for c in slow)
    return slow, (f"NO quasi-static cycle (k <= {QUASI_STATIC_K}) in the catalog: the upstrokes of its "
                  f"{len(slow)} slowest cycles (k = {k_min:.4f} to {k_max:.4f}), which carry their own lag, so "
                  "the quasi-steady column is not a static model here and the stall angle (the regimes) is "
                  "a dynamic one")


def upstroke_bins(data, cycles):
    """Per 1-deg bin of the measured angle (rounded), over the samples where the angle rises:
    [count, sum Cn, sum Ct, sum Cm, sum CL]."""
    bins = {}
    for c in cycles:
        rows = read_cycle(cycle_path(data, c))
        n = len(rows)
        for i in range(n):
            if rows[(i + 1) % n][1] - rows[i - 1][1] <= 0.0:
                continue  # the downstroke: its separated flow reattaches late (hysteresis)
            b = bins.setdefault(float(round(rows[i][1])), [0, 0.0, 0.0, 0.0, 0.0])
            b[0] += 1
            for j, v in enumerate((rows[i][2], rows[i][3], rows[i][4], rows[i][5]), start=1):
                b[j] += v
    return bins


def stall_angle_deg(bins):
    """The static stall angle: the bin of the largest mean lift among bins of enough samples."""
    ok = {a: b[4] / b[0] for a, b in bins.items() if b[0] >= MIN_BIN_SAMPLES}
    if not ok:
        raise SystemExit("static polar: no 1-deg bin holds enough upstroke samples")
    return max(ok, key=ok.get)


def regime(peak_deg, stall_deg):
    if peak_deg < stall_deg:
        return "attached"
    return "deep" if peak_deg >= stall_deg + DEEP_STALL_MARGIN_DEG else "light"


def regime_rule(stall_deg):
    return (f"attached: largest angle < {stall_deg:g} deg (the static stall angle); light stall: < "
            f"{stall_deg + DEEP_STALL_MARGIN_DEG:g} deg; deep stall: beyond")


def spread_pick(values, n=3):
    """n distinct values spread over the range: the nearest to lo + span (2 i + 1) / (2 n)."""
    vs = sorted(set(values))
    if len(vs) <= n:
        return vs
    lo, hi = vs[0], vs[-1]
    picked = []
    for i in range(n):
        target = lo + (hi - lo) * (2 * i + 1) / (2 * n)
        best = min((v for v in vs if v not in picked), key=lambda v: abs(v - target))
        picked.append(best)
    return sorted(picked)


def ends_and_middle(values):
    """The lowest, the highest and the value nearest their middle (all of them when three or fewer)."""
    vs = sorted(set(values))
    if len(vs) <= 3:
        return vs
    mid = min(vs[1:-1], key=lambda v: abs(v - (vs[0] + vs[-1]) / 2))
    return [vs[0], mid, vs[-1]]


def measured_range_deg(data, c):
    """The cycle's measured angle range (deg), read once."""
    if "lo" not in c:
        a = [r[1] for r in read_cycle(cycle_path(data, c))]
        c["lo"], c["hi"] = min(a), max(a)
    return c["lo"], c["hi"]


def within(data, c, angle_lo, angle_hi):
    """The cycle's measured angles inside [angle_lo, angle_hi] (the static polar's rows: fit
    refuses a table that does not cover its runs)."""
    lo, hi = measured_range_deg(data, c)
    return lo >= angle_lo and hi <= angle_hi


def choose_sweep(data, catalog, stall_deg, angle_lo, angle_hi, exclude=frozenset()):
    """Three cycles of one frequency sweep: among the (campaign, mean, amplitude) groups of
    non-quasi-static cycles whose measured angles lie inside the polar's rows with three or more reduced frequencies,
    the group whose mean is nearest the static stall angle (its cycles pass from attached flow
    through stall), then the most frequencies, then the larger amplitude, then the lower mean;
    cycles of the ids in `exclude` (the polar's) never count; from it the three
    frequencies spread over its range (spread_pick)."""
    groups = {}
    for c in catalog:
        if c["id"] not in exclude and not is_quasi_static(c) and within(data, c, angle_lo, angle_hi):
            groups.setdefault((c["campaign"], c["mean"], c["amp"]), {}).setdefault(k_key(c), c)
    eligible = [(g, ks) for g, ks in groups.items() if len(ks) >= 3]
    if not eligible:
        raise SystemExit("no frequency sweep: no (campaign, mean, amplitude) group holds three reduced frequencies")
    g, ks = min(eligible, key=lambda e: (abs(e[0][1] - stall_deg), -len(e[1]), -e[0][2], e[0][1], e[0][0]))
    by_k = {c["k"]: c for c in ks.values()}
    return [by_k[k] for k in spread_pick(list(by_k))], g


def choose_means(data, catalog, sweep_group, sweep_ks, angle_lo, angle_hi, exclude=frozenset()):
    """Three cycles across mean angles at one amplitude and reduced frequency: among the
    (campaign, amplitude, k to K_RESOLUTION) groups of cycles (not in `exclude`) inside the polar's rows with three or more means,
    the sweep's campaign and amplitude first, then the k nearest the sweep's middle frequency,
    then the most means; from it the lowest mean, the highest, and the one nearest their middle."""
    groups = {}
    for c in catalog:
        if c["id"] not in exclude and not is_quasi_static(c) and within(data, c, angle_lo, angle_hi):
            key = (c["campaign"], c["amp"], k_key(c))
            groups.setdefault(key, {}).setdefault(c["mean"], c)
    eligible = [(g, ms) for g, ms in groups.items() if len(ms) >= 3]
    if not eligible:
        raise SystemExit("no mean-angle set: no (campaign, amplitude, k) group holds three mean angles")
    k_mid = sorted(sweep_ks)[len(sweep_ks) // 2]
    same = lambda g: g[0] == sweep_group[0] and g[1] == sweep_group[2]
    g, ms = min(eligible, key=lambda e: (not same(e[0]), abs(e[0][2] * K_RESOLUTION - k_mid), -len(e[1]), e[0]))
    return [ms[m] for m in ends_and_middle(list(ms))]
