#!/usr/bin/env python3
"""The moment breaks of measured deep-stall cycles: how many per cycle, and how far apart.

Usage: python3 tools/moment_breaks.py DATA_DIR > docs/moment-breaks.md

DATA_DIR is a directory in the development set's layout (catalog.csv, cycles/; see
tools/cycle_catalog.py); nothing is copied. Standard library only.

Why: the vortex family of model.hpp sheds ONE leading-edge vortex per excursion above the
criterion: one moment break per cycle. A second break in the measured C_m is a second vortex
(Beddoes-Leishman's secondary vortex shedding), which the model cannot produce. This script
measures, on every deep-stall cycle (its largest angle at least DEEP_STALL_MARGIN_DEG above the
static stall angle; cycle_catalog.regime), how often a second break occurs and how long after
the first, in semichord times (phase / k, k = omega (c/2) / V): a time that stays the same
across reduced frequencies is a convective time (a repeat in l / V, as the model's time
constants are), one that stays the same as a fraction of the period is not.

What a break is (moment_breaks): a local minimum of C_m smoothed over SMOOTH_SAMPLES samples
(circularly), the lowest within +-WINDOW_SAMPLES samples, at least MIN_DEPTH below the highest
smoothed value in that window (the sample counts are for a 128-sample cycle and scale with the
cycle's samples, which the layout has equally spaced in phase). The two deepest breaks of a cycle are the first and second
vortex; the gap is their phase difference over k. On the development set's 128-sample cycles
the window is +-17 deg of phase.
"""
import math
import os
import statistics
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import cycle_catalog  # noqa: E402

# In samples of a 128-sample cycle (the development set's); other sample counts scale them to
# the same phase (samples_for).
SMOOTH_SAMPLES = 5     # centred moving average (the ensemble averages keep some noise): 14 deg
WINDOW_SAMPLES = 6     # a break is the lowest value within this many samples either side: 17 deg
MIN_DEPTH = 0.05       # ... and this far (C_m units) below the window's highest value
REFERENCE_SAMPLES = 128


def samples_for(count_at_128, n):
    """The same phase span in a cycle of n samples (at least 1)."""
    return max(1, round(count_at_128 * n / REFERENCE_SAMPLES))


def smooth(values, n=SMOOTH_SAMPLES):
    """Centred moving average over n samples (odd: an even n is raised by one), wrapping around."""
    h, m = n // 2, len(values)
    return [sum(values[(i + j) % m] for j in range(-h, h + 1)) / (2 * h + 1) for i in range(m)]


def moment_breaks(cm, window=None, min_depth=MIN_DEPTH):
    """Indices of the breaks of a periodic C_m series (already smoothed), deepest first."""
    m = len(cm)
    window = samples_for(WINDOW_SAMPLES, m) if window is None else window
    found = []
    for i in range(m):
        around = [cm[(i + j) % m] for j in range(-window, window + 1)]
        if cm[i] == min(around) and max(around) - cm[i] >= min_depth:
            # A flat minimum over several samples: keep its first sample only.
            if not any(cm[(i - j) % m] == cm[i] for j in range(1, window + 1)):
                found.append(i)
    return sorted(found, key=lambda i: cm[i])


def cycle_breaks(rows, k):
    """(breaks as (phase_rad, alpha_deg, cm, rising)), gap in semichords between the two deepest
    (None with fewer than two)) for one cycle's rows (cycle_catalog.read_cycle)."""
    n = len(rows)
    cm = smooth([r[4] for r in rows], samples_for(SMOOTH_SAMPLES, n))
    idx = moment_breaks(cm)
    out = []
    for i in idx:
        rising = rows[(i + 1) % n][1] > rows[i - 1][1]
        out.append((rows[i][0], rows[i][1], cm[i], rising))
    gap = None
    if len(idx) >= 2:
        first, second = sorted(idx[:2])
        phase_step = 2.0 * math.pi / n  # the samples are equally spaced in phase (README)
        gap = (second - first) * phase_step / k
    return out, gap


def main():
    if len(sys.argv) != 2:
        sys.exit("usage: python3 tools/moment_breaks.py DATA_DIR")
    data = sys.argv[1]
    catalog = cycle_catalog.read_catalog(data)
    polar, _ = cycle_catalog.polar_cycles(catalog)
    stall_deg = cycle_catalog.stall_angle_deg(cycle_catalog.upstroke_bins(data, polar))
    polar_ids = {c["id"] for c in polar}
    table, gaps, fractions, counts = [], [], [], []
    for c in catalog:
        if c["id"] in polar_ids:
            continue
        rows = cycle_catalog.read_cycle(cycle_catalog.cycle_path(data, c))
        if cycle_catalog.regime(max(r[1] for r in rows), stall_deg) != "deep":
            continue
        breaks, gap = cycle_breaks(rows, c["k"])
        counts.append(len(breaks))
        if gap is not None:
            gaps.append(gap)
            fractions.append(gap * c["k"] / (2.0 * math.pi))
            second = sorted(breaks[:2], key=lambda b: b[0])[1]
            table.append((c, breaks, gap, "upstroke" if second[3] else "downstroke"))
    print("# Moment breaks of the measured deep-stall cycles\n")
    print(f"Written by `python3 tools/moment_breaks.py DIR` (do not edit by hand). Data: the cycles of DIR's "
          f"catalog.csv (for the committed file the development set: University of Glasgow dynamic-stall "
          f"database, NACA 0012, Green & Giuni 2017). Static stall angle {stall_deg:g} deg (the polar's cycles' "
          f"upstrokes, tools/cycle_catalog.py); deep stall: the cycle's largest angle at least "
          f"{cycle_catalog.DEEP_STALL_MARGIN_DEG:g} deg above it. A break: a minimum of C_m (smoothed over "
          f"{SMOOTH_SAMPLES} samples) lowest within +-{WINDOW_SAMPLES} samples and {MIN_DEPTH} below that "
          f"window's highest value (the script's docstring).\n")
    if not counts:
        print("No deep-stall cycle in the catalog.")
        return
    print(f"* Deep-stall cycles: {len(counts)}; with one break {counts.count(1)}, with two or more "
          f"{sum(1 for n in counts if n >= 2)}, with none {counts.count(0)}.")
    if gaps:
        q = statistics.quantiles(gaps, n=4) if len(gaps) >= 2 else [gaps[0]] * 3
        print(f"* Gap between the two deepest breaks: median {statistics.median(gaps):.1f} semichords "
              f"(quartiles {q[0]:.1f}, {q[2]:.1f}; range {min(gaps):.1f}-{max(gaps):.1f}); as a fraction of the "
              f"period: median {statistics.median(fractions):.3f} (range {min(fractions):.3f}-{max(fractions):.3f}).")
        up = sum(1 for t in table if t[3] == "upstroke")
        print(f"* The later break on the upstroke (angle still rising) in {up} of {len(table)} cycles, on the "
              f"downstroke in {len(table) - up}.\n")
        print("| id | campaign | mean deg | amplitude deg | k | breaks: angle deg (C_m), deepest first | gap (semichords) "
              "| later break |")
        print("|---|---|---|---|---|---|---|---|")
        for c, breaks, gap, stroke in table:
            listed = ", ".join(f"{b[1]:.1f} ({b[2]:.2f})" for b in breaks)
            print(f"| {c['id']} | {c['campaign']} | {c['mean']:g} | {c['amp']:g} | {c['k']:.3f} | {listed} | "
                  f"{gap:.1f} | {stroke} |")


if __name__ == "__main__":
    main()
