#!/usr/bin/env python3
"""The part of each cycle's quasi-steady error that is its mean offset (issue 21).

Usage: python3 tools/qs_floor.py DIR > docs/validation-floor.md

Issue 21 asks for held-out cycles at <= 0.5x the quasi-steady RMS (the static table alone,
evaluated at the measured angle: tools/validate_real.py's denominator). Part of a cycle's
quasi-steady error is its mean over the cycle, the offset between that cycle's mean
coefficient and the static polar's at its angles (from the test point -- tunnel, day,
airspeed, Reynolds number -- or from the motion itself). A
model that predicts the error's every variation over the cycle exactly but not that offset has
the RMS of the offset alone, so its ratio to the quasi-steady RMS is

    floor = |mean e| / rms e,        e = measured - static table at the measured angle,

and it reaches <= 0.5x only where floor <= 0.5. The floor bounds every prediction whose
cycle-mean error is the quasi-steady one (rms >= |mean|); a model goes lower only by shifting
the cycle's mean, which dynamic terms partly do (a stall cycle's mean lift is not the static
polar's), so it is a floor for the offset's share, not for every model. The script counts, per regime, the cycles where the
floor allows 0.5x, lists the offsets by campaign, airspeed and reduced frequency (to show
whether they follow the motion, which a model could learn, or the test point, which it
cannot), and counts on the peer's cycles (DIR/bl-reference.csv, when present) how many a
published Beddoes-Leishman model brings to 0.5x. Only the data are read: no model is fitted.

The static polar, the regimes and the cycles are tools/validate_real.py's (the polar's own
cycles are neither counted nor listed). Standard library only; a few seconds.
"""
import csv
import math
import os
import statistics
import sys
import tempfile

import cycle_catalog
import validate_real as vr

REGIMES = ('attached', 'light', 'deep')
COEFFICIENTS = (('CL', 5, 'CL'), ('Cm', 4, 'Cm'))  # name, read_cycle column, static-table column


def read_table(path):
    """The static table validate_real.py writes: rows of angle (deg), Cn, Ct, Cm; CL derived."""
    return [(a, {'CL': cycle_catalog.lift(a, cn, ct), 'Cm': cm})
            for a, cn, ct, cm in (r[:4] for r in cycle_catalog.numeric_rows(path))]


def static_value(table, column, alpha_deg):
    """Linear between rows, held at the end rows (as the runtime evaluates a static table)."""
    if alpha_deg <= table[0][0]:
        return table[0][1][column]
    for (a0, v0), (a1, v1) in zip(table, table[1:]):
        if alpha_deg <= a1:
            w = (alpha_deg - a0) / (a1 - a0)
            return v0[column] + w * (v1[column] - v0[column])
    return table[-1][1][column]


def cycle_errors(data, c, table):
    """{coefficient: (rms e, mean e)} of the static table's error e over the cycle's samples."""
    rows = cycle_catalog.read_cycle(cycle_catalog.cycle_path(data, c))
    out = {}
    for name, col, tcol in COEFFICIENTS:
        e = [r[col] - static_value(table, tcol, r[1]) for r in rows]
        out[name] = (math.sqrt(sum(v * v for v in e) / len(e)), sum(e) / len(e))
    return out


def floor_ratio(rms, mean):
    return abs(mean) / rms if rms > 0 else 0.0


def by_regime(cycles, regime_of, columns, cells_of):
    """A markdown table, one row per regime (and all): for each coefficient the `columns`, filled
    by cells_of(cycles of the row, coefficient name)."""
    out = ['| regime | cycles | ' + ' | '.join(f'{n}: {c}' for n, _, _ in COEFFICIENTS for c in columns) + ' |',
           '|---|---|' + '---|' * (len(columns) * len(COEFFICIENTS))]
    for g in REGIMES + ('all',):
        sel = [c for c in cycles if g == 'all' or regime_of(c) == g]
        if sel:
            cells = [x for n, _, _ in COEFFICIENTS for x in cells_of(sel, n)]
            out.append(f'| {g} | {len(sel)} | ' + ' | '.join(cells) + ' |')
    return out


def regime_table(cycles, errors, regime_of):
    def cells(sel, n):
        fl = [floor_ratio(*errors[c['id']][n]) for c in sel]
        return [f'{statistics.median(fl):.2f}', f'{sum(f <= 0.5 for f in fl)} of {len(sel)}']
    return by_regime(cycles, regime_of, ('median floor', 'floor <= 0.5'), cells)


def offsets_table(cycles, errors, regime_of):
    """Mean offset per (campaign, airspeed to 1 m/s, reduced frequency to 0.005), attached cycles."""
    groups = {}
    for c in cycles:
        if regime_of(c) != 'attached':
            continue
        key = (c['campaign'], round(c['v']), round(c['k'] / 0.005) * 0.005)
        groups.setdefault(key, []).append(c)
    out = ['| campaign | airspeed (m/s) | k | cycles | CL offset | CL rms | Cm offset | Cm rms |',
           '|---|---|---|---|---|---|---|---|']
    for key in sorted(groups, key=lambda k: (k[0], k[2], k[1])):
        sel = groups[key]
        cell = []
        for n in ('CL', 'Cm'):
            cell += [f'{statistics.mean(errors[c["id"]][n][1] for c in sel):+.4f}',
                     f'{statistics.mean(errors[c["id"]][n][0] for c in sel):.4f}']
        out.append(f'| {key[0]} | {key[1]} | {key[2]:.3f} | {len(sel)} | ' + ' | '.join(cell) + ' |')
    return out


def peer_table(data, cycles, errors, regime_of):
    path = os.path.join(data, 'bl-reference.csv')
    if not os.path.exists(path):
        return ['(No bl-reference.csv in DIR: the peer\'s counts are not available.)']
    with open(path) as f:
        peer = {r['id']: r for r in csv.DictReader(f)}

    def cells(sel, n):
        ratio = [float(peer[c['id']][f'bl_rms_{n}']) / errors[c['id']][n][0] for c in sel]
        fl = [floor_ratio(*errors[c['id']][n]) for c in sel]
        return [f'{sum(r <= 0.5 for r in ratio)} of {len(sel)}', f'{sum(f <= 0.5 for f in fl)} of {len(sel)}',
                f'{statistics.median(ratio):.2f}']
    return by_regime([c for c in cycles if c['id'] in peer], regime_of,
                     ('peer <= 0.5x', 'floor <= 0.5', 'peer median ratio'), cells)


def main(argv):
    if len(argv) != 2:
        sys.exit(__doc__.split('\n\n')[1])
    data = argv[1]
    vr.DATA = data
    catalog = cycle_catalog.read_catalog(data)
    with tempfile.TemporaryDirectory() as tmp:
        info = vr.static_table(catalog, os.path.join(tmp, 'static.dat'))
        table = read_table(os.path.join(tmp, 'static.dat'))
    cycles = [c for c in catalog if c['id'] not in info[5]]
    errors = {c['id']: cycle_errors(data, c, table) for c in cycles}
    peak = {c['id']: cycle_catalog.measured_range_deg(data, c)[1] for c in cycles}
    regime_of = lambda c: cycle_catalog.regime(peak[c['id']], info[4])
    out = ['# The mean offset in the quasi-steady error of measured cycles (issue 21)', '',
           'Written by `tools/qs_floor.py DIR` (do not edit by hand; rerun it; its docstring has the '
           'method). Data: DIR\'s pitching cycles, for the committed file the development set of '
           'docs/validation-real.md (University of Glasgow NACA 0012 database, campaigns 4, 5, 6; cited '
           'there), read from DIR, not from this repository. No model is fitted: only the data and the '
           'static polar are read.', '',
           f'Static polar: {info[3]}, as tools/validate_real.py builds it ({info[2]} rows, {info[0]:g} to '
           f'{info[1]:g} deg); every other cycle ({len(cycles)}) is counted. e = measured - static table at '
           'the measured angle; the floor |mean e| / rms e is the ratio to the quasi-steady RMS of a '
           'prediction that is exact except for the cycle\'s mean offset, and a lower bound for every '
           'prediction whose cycle mean is the static polar\'s: where it is above 0.5, a prediction '
           'reaches 0.5x only by predicting the offset (a dynamic term that shifts the cycle\'s mean, '
           'as stall does, can). Regimes by the cycle\'s largest angle ('
           + cycle_catalog.regime_rule(info[4]) + ').', '',
           '## The floor, by regime', '']
    out += regime_table(cycles, errors, regime_of)
    out += ['', '## The peer\'s cycles', '',
            'The cycles of DIR/bl-reference.csv, the error of a Beddoes-Leishman model with published '
            'parameters (not fitted to these cycles) over the same quasi-steady RMS.', '']
    out += peer_table(data, cycles, errors, regime_of)
    out += ['', '## The offsets of the attached cycles', '',
            'Mean over the cycles of each group of the offset mean e and of rms e. An offset that '
            'follows the motion (k, amplitude, mean angle) could be learned from other cycles; one '
            'that changes between campaigns or airspeeds at one k cannot.', '']
    out += offsets_table(cycles, errors, regime_of)
    print('\n'.join(out))


if __name__ == '__main__':
    main(sys.argv)
