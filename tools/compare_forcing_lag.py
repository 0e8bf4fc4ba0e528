#!/usr/bin/env python3
"""The two forms of the stall families' forcing lag, held out on measured cycles (issue 22);
and the first-order form with a fitted f0 correction.

Usage: nice python3 tools/compare_forcing_lag.py DATA_DIR [INDICIAL] > docs/validation-forcing-lag.md

model.hpp's ForcingLag: T2 lags the angle that forces the separation point and the shedding
criterion either as a first-order time shift, x - T2 (l/V) x' ("delay", the default), or as a
first-order filter, T2 (l/V) x_e' + x_e = x ("first_order"). On a sinusoid of reduced frequency
k the shift multiplies the amplitude by sqrt(1 + (k T2)^2), the filter by 1 / sqrt(1 + (k T2)^2).

What it does: tools/validate_stall.py's data, static polar, fit and held-out cycles and its
extended model (report model + separation and vortex families + a constant C_aq; for C_L a
reattachment time constant), fitted once with each form (`indicial fit`, its default grid of
stall starts) on the fit cycles; every held-out cycle predicted at its periodic steady state;
mean RMS per regime beside the Beddoes-Leishman peer's. Only the forcing lag differs between
the two fits of a coefficient. A third fit, `first_order_f0c1`, adds a fitted correction of the
separation table f0(x) of degree 1 (`stall_f0_correction_degree = 1`: f0 + f0c_0 + f0c_1 x,
clipped to [0, 1]; model.hpp), which moves the static stall onset the families see. No choice is
made on the held-out cycles: the script reports every variant and the fit cycles' error of each
(what a user can compare without held-out data).
Slow: six fits over ~100 cycles (about 20-45 minutes on a shared 2-core machine).
"""
import csv
import json
import os
import subprocess
import sys
import tempfile
import time

import cycle_catalog
import validate_stall as vs

# Each variant's [model] keys over the extended model's (the name is the table's column).
VARIANTS = {
    'delay': 'stall_forcing_lag = "delay"\n',
    'first_order': 'stall_forcing_lag = "first_order"\n',
    'first_order_f0c1': 'stall_forcing_lag = "first_order"\nstall_f0_correction_degree = 1\n',
}
FORMS = tuple(VARIANTS)


def variant_experiment(exp, coef, form, runs, vref, knots):
    """Writes the extended model's experiment file with the variant's [model] keys."""
    vs.experiment(exp, coef, runs, True, vref, knots)
    with open(exp) as f:
        text = f.read()
    text = text.replace('[model]\n', '[model]\n' + VARIANTS[form])
    with open(exp, 'w') as f:
        f.write(text)


def fit_model(exe, work, coef, form, runs, vref, knots):
    exp = os.path.join(work, f'exp-{coef}-{form}.toml')
    variant_experiment(exp, coef, form, runs, vref, knots)
    out = os.path.join(work, f'fit-{coef}-{form}')
    t0 = time.time()
    # 200 iterations, as tools/validate_stall.py's fits (the first-order C_m fit stopped at the
    # default 50 in the run of 2026-11-30, s(v) 0.02996 and still falling).
    if not vs.run([exe, 'fit', exp, '--out', out, '--no-plots', '--quiet', '--max-iterations', '200']):
        return None, None
    fj = json.load(open(os.path.join(out, 'fit.json')))
    fj['wall_s'] = time.time() - t0
    return os.path.join(out, 'model.coef'), fj


def held_out_rms(exe, work, model, coef, cycle, path, rows):
    out = os.path.join(work, f"pred_{cycle['id']}_{coef}.csv")
    if not vs.run([exe, 'predict', model, path, '--out', out, '--frequency-hz', str(cycle['f']),
                   '--airspeed-mps', str(cycle['v']), '--force', '--quiet']):
        return float('nan')
    with open(out) as f:
        pred = list(csv.DictReader(line for line in f if not line.startswith('#')))
    col = {'CL': 2, 'Cm': 3}[coef]
    return vs.rms([float(p[f'{coef}_pred']) for p in pred], [r[col] for r in rows])


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    data = sys.argv[1]
    exe = sys.argv[2] if len(sys.argv) > 2 else 'indicial'
    catalog = cycle_catalog.read_catalog(data)
    work = tempfile.mkdtemp(prefix='indicial-forcing-')
    _, source, stall_deg = vs.static_polar(data, catalog, os.path.join(work, 'static.csv'))
    fit, held, bl = vs.choose_cycles(data, catalog)
    runs = []
    for c in fit:
        name = f"fit_{c['id']}.csv"
        vs.write_run(os.path.join(work, name), vs.read_cycle(cycle_catalog.cycle_path(data, c)))
        runs.append({'file': name, 'f': c['f'], 'v': c['v']})
    speeds = sorted(c['v'] for c in fit)
    vref = 5.0 * round(speeds[len(speeds) // 2] / 5.0)
    knots = (stall_deg - 3.0, stall_deg + 1.0)
    models = {(coef, form): fit_model(exe, work, coef, form, runs, vref, knots)
              for coef in ('CL', 'Cm') for form in FORMS}
    results = []
    for c in held:
        rows = vs.read_cycle(cycle_catalog.cycle_path(data, c))
        path = os.path.join(work, f"held_{c['id']}.csv")
        vs.write_run(path, rows)
        peer = bl.get(c['id'], {})
        r = {'id': c['id'], 'mean': c['mean'], 'k': c['k'],
             'regime': cycle_catalog.regime(max(x[1] for x in rows), stall_deg)}
        for coef in ('CL', 'Cm'):
            r[f'bl_{coef}'] = float(peer.get(f'bl_rms_{coef}', 'nan'))
            for form in FORMS:
                model = models[(coef, form)][0]
                r[f'{form}_{coef}'] = held_out_rms(exe, work, model, coef, c, path, rows) if model else float('nan')
        results.append(r)
    report(results, source, stall_deg, fit, held, models)


def report(results, source, stall_deg, fit, held, models):
    p = print
    p('# The stall families\' forcing lag: delay or first-order filter (and a fitted f0 correction), held out (issue 22)\n')
    p('Generated by `tools/compare_forcing_lag.py DATA_DIR` (its docstring has the method). Data: University of '
      'Glasgow dynamic-stall database, NACA 0012 (Green, R. B. & Giuni, M., "Dynamic stall database R and D '
      '1570-AM-01: Final Report", University of Glasgow, 2017), as in tools/validate_stall.py. Peer: the '
      'Beddoes-Leishman model of dos Santos & Marques (2021) with its published parameters.\n')
    p(f'Static polar: {source}; stall angle {stall_deg:g} deg. Fit: {vs.describe(fit)}. '
      f'Held out: {vs.describe(held)}. The extended model of tools/validate_stall.py, fitted with '
      '`stall_forcing_lag = "delay"`, with `"first_order"`, and with `"first_order"` and '
      '`stall_f0_correction_degree = 1` (`first_order_f0c1`).\n')
    p('| coefficient | variant | fit cycles: s(v) | termination | T1 | T2 | CN1 | f0c_0 | f0c_1 | fit wall s |')
    p('|---|---|---|---|---|---|---|---|---|---|')
    for coef in ('CL', 'Cm'):
        for form in FORMS:
            fj = models[(coef, form)][1]
            if not fj:
                p(f'| {coef} | {form} | FAILED | | | | | | | |')
                continue
            par = {q['name']: q['value'] for q in fj.get('parameters', [])}
            t1, t2, cn1, c0, c1 = (par.get(n, float('nan')) for n in ('T1', 'T2', 'CN1', 'f0c_0', 'f0c_1'))
            p(f"| {coef} | {form} | {fj['fit_error']:.5f} | {fj.get('termination')} | {t1:.3f} | {t2:.3f} | "
              f"{cn1:.3f} | {c0:.3f} | {c1:.3f} | {fj['wall_s']:.0f} |")
    p('')
    p(f'Mean held-out RMS per regime ({cycle_catalog.regime_rule(stall_deg)}), and over the Beddoes-Leishman '
      'peer\'s:\n')
    p('| regime | cycles | coefficient | ' + ' | '.join(FORMS) + ' | BL peer | ' +
      ' | '.join(f'{f} / BL' for f in FORMS) + ' |')
    p('|---|---|---|' + '---|' * (2 * len(FORMS) + 1))
    for regime, rs in vs.by_regime(results):
        for coef in ('CL', 'Cm'):
            m = [vs.mean([r[f'{k}_{coef}'] for r in rs]) for k in FORMS]
            b = vs.mean([r[f'bl_{coef}'] for r in rs])
            p(f'| {regime} | {len(rs)} | {coef} | ' + ' | '.join(f'{x:.4f}' for x in m) + f' | {b:.4f} | ' +
              ' | '.join(f'{x / b:.2f}' for x in m) + ' |')
    p('')
    p('Per cycle (RMS):\n')
    cols = [(f'{k}_{c}', f'{k} {c}') for c in ('CL', 'Cm') for k in FORMS + ('bl',)]
    p('| id | mean deg | k | regime | ' + ' | '.join(lab.replace('bl ', 'BL ') for _, lab in cols) + ' |')
    p('|---|---|---|---|' + '---|' * len(cols))
    for r in results:
        p(f"| {r['id']} | {r['mean']:g} | {r['k']:.3f} | {r['regime']} | " +
          ' | '.join(f'{r[k]:.4f}' for k, _ in cols) + ' |')


if __name__ == '__main__':
    main()
