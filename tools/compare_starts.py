#!/usr/bin/env python3
"""Which parts of a starting model carry over from three measured cycles (issue 21).

Usage: nice python3 tools/compare_starts.py DIR INDICIAL SCRATCH > docs/validation-starts.md

docs/validation-real.md fits and diagnoses two starting models; this study takes them apart.
For each of its training choices (tools/validate_real.py's rules: three cycles of one frequency
sweep, three cycles across mean angles) and each coefficient, it fits (`indicial fit`, no
diagnose) the variants of VARIANTS below, each one change from the report's model or from the
Beddoes-Leishman start, and predicts every other cycle of the catalogue at its periodic steady
state, as validate_real.py does (the same static polar, held-out cycles and regimes). The ratio
is to the static table's own RMS (the quasi-steady model of validate_real.py, C_aq = 0).
Nothing is chosen on the held-out cycles: the script reports every variant, with the fit
cycles' error s(v) (what a user sees without held-out data). A variant that holds the C_m
fit's separation time constants at the C_L fit's (`stall_known`) reads them from the C_L fit
of the same variant without the hold, which runs first. Standard library only; about two
minutes on a shared 2-core machine.
"""
import concurrent.futures
import json
import os
import statistics
import sys
import time

import cycle_catalog
import validate_real as vr

FAMILIES = 'stall = "separation_and_vortex"\nstall_polar = "{static}"\nstall_polar_column = "CL"\n'
REPORT = 'a_degree = 2\na_knots_deg = [{knots}]\nb1_degree = 0\nbias = false\nstructure = "fixed"\n'
CONSTANT_LAG = 'a_degree = 0\nb1_degree = 0\nbias = false\nstructure = "fixed"\n'
ROTARY = 'rotary_correction_powers = [0]\n'
FIRST_ORDER = 'stall_forcing_lag = "first_order"\n'

# (name, what it is, [model] keys; "{knots}" and "{static}" filled in, HOLD: the hold of T1, T2
# at the C_L fit of the variant named after it).
VARIANTS = (
    ('report', "the report's model (a(x) of degree 2, knots every 5 deg inside the training range)", REPORT),
    ('report+families', "the report's model with the separation and vortex families", REPORT + FAMILIES),
    ('report+families+C_aq', 'the same with a constant C_aq estimated', REPORT + ROTARY + FAMILIES),
    ('bl', 'the Beddoes-Leishman start (a, b1 constant, C_aq constant estimated, families)',
     CONSTANT_LAG + ROTARY + FAMILIES),
    ('bl-families', 'the Beddoes-Leishman start without the families', CONSTANT_LAG + ROTARY),
    ('bl-C_aq', 'the Beddoes-Leishman start without the C_aq estimate', CONSTANT_LAG + FAMILIES),
    ('bl+first_order', 'the Beddoes-Leishman start with stall_forcing_lag = "first_order"',
     CONSTANT_LAG + ROTARY + FAMILIES + FIRST_ORDER),
    ('bl+hold', "C_m: the Beddoes-Leishman start with T1, T2 held at the C_L fit's (variant bl)",
     CONSTANT_LAG + ROTARY + FAMILIES + 'HOLD bl'),
    ('bl+first_order+hold', "C_m: the same, first_order, T1, T2 held at the C_L fit's (variant bl+first_order)",
     CONSTANT_LAG + ROTARY + FAMILIES + FIRST_ORDER + 'HOLD bl+first_order'),
)
REGIMES = ('attached', 'light', 'deep')


def separation_time_constants(coef_path):
    """T1, T2 of the first coefficient block's sep_time_constants line."""
    with open(coef_path) as f:
        for line in f:
            if line.startswith('sep_time_constants '):
                t1, t2 = line.split()[1:3]
                return t1, t2
    raise RuntimeError(f'{coef_path}: no sep_time_constants line')


def model_keys(template, knots, static_csv, held_fits):
    keys = template.replace('{knots}', ', '.join(str(k) for k in knots)).replace('{static}', static_csv)
    if 'HOLD ' in keys:
        keys, source = keys.split('HOLD ')
        t1, t2 = separation_time_constants(held_fits[source.strip()])
        keys += f'stall_known = {{ T1 = {t1}, T2 = {t2} }}\n'
    return keys


def fit_and_predict(work, text, held):
    """Fit the experiment `text` in `work`, predict every held-out cycle. Returns s(v) and, per
    cycle id, (model RMS, predict's quasi-steady RMS)."""
    os.makedirs(work, exist_ok=True)
    exp = os.path.join(work, 'experiment.toml')
    with open(exp, 'w') as f:
        f.write(text)
    vr.run([vr.EXE, 'fit', exp, '--out', os.path.join(work, 'fit'), '--force', '--no-plots', '--quiet'])
    with open(os.path.join(work, 'fit', 'fit.json')) as f:
        s_v = json.load(f)['fit_error']
    model = os.path.join(work, 'fit', 'model.coef')

    def one(c):
        d = os.path.join(work, 'p' + c['id'])
        os.makedirs(d, exist_ok=True)
        return c['id'], vr.predict_rms(model, c, exp, d)

    with concurrent.futures.ThreadPoolExecutor(2) as pool:
        return s_v, dict(pool.map(one, held))


def main():
    if len(sys.argv) != 4:
        sys.exit(__doc__.split('\n\n')[1])
    vr.parse_args([sys.argv[0], sys.argv[1], sys.argv[2], sys.argv[3], '/dev/null'])
    t0 = time.time()
    catalog = cycle_catalog.read_catalog(vr.DATA)
    os.makedirs(vr.SCRATCH, exist_ok=True)
    static_csv = os.path.join(vr.SCRATCH, 'static.dat')
    info = vr.static_table(catalog, static_csv)
    regime = lambda c: cycle_catalog.regime(vr.peak_deg(c), info[4])
    out = ['# Which parts of a starting model carry over from three measured cycles (issue 21)', '',
           'Written by `tools/compare_starts.py DIR INDICIAL SCRATCH` (do not edit by hand; rerun it; '
           'its docstring has the method). Data: DIR\'s pitching cycles, for the committed file the '
           'development set of docs/validation-real.md (University of Glasgow NACA 0012 database, '
           'campaigns 4, 5, 6; cited there), read from DIR, not from this repository. Tool: '
           f'`{vr.tool_version()}`.', '',
           'Each variant is fitted (`indicial fit`, no diagnose) to the three training cycles and predicts '
           'every other cycle that is not one of the static polar\'s at its periodic steady state. '
           '"<= 0.5x": held-out cycles at half the static table\'s RMS or less; "median": the median of '
           'the ratio; regimes by the cycle\'s largest angle (' + cycle_catalog.regime_rule(info[4]) + ').', '']
    for name, label, train in vr.training_choices(catalog, info):
        ids = {c['id'] for c in train}
        held = [c for c in catalog if c['id'] not in ids and c['id'] not in info[5]]
        v_ref = round(sum(c['v'] for c in train) / len(train), 3)
        a_lo = min(cycle_catalog.measured_range_deg(vr.DATA, c)[0] for c in train)
        a_hi = max(vr.peak_deg(c) for c in train)
        knots = [k for k in range(0, 40, 5) if a_lo + 2.0 < k < a_hi - 2.0]
        out += [f'## Training `{name}` ({label})', '',
                'Training cycles: ' + ', '.join(c['id'] for c in train) + f'; {len(held)} held out.', '']
        for coef in ('CL', 'Cm'):
            out += [f'### {coef}', '',
                    '| variant | fit s(v) | ' + ' | '.join(f'{r}: <= 0.5x' for r in REGIMES) +
                    ' | all: <= 0.5x | all: median ratio |',
                    '|---|---|' + '---|' * (len(REGIMES) + 2)]
            qs = {}
            for vname, vlabel, template in VARIANTS:
                if 'HOLD' in template and coef != 'Cm':
                    continue
                work = os.path.join(vr.SCRATCH, f'{name}-{coef}-{vname}')
                keys = model_keys(template, knots, static_csv, CL_FITS.get(name, {}))
                try:
                    s_v, rms = fit_and_predict(work, vr.experiment_toml(coef, train, static_csv, v_ref, keys), held)
                except RuntimeError as e:  # a refused fit is a result too
                    out.append(f'| `{vname}`: {vlabel} | fit refused: ' + str(e).splitlines()[-1][:200] + ' |' +
                               ' |' * (len(REGIMES) + 2))
                    continue
                if coef == 'CL':
                    CL_FITS.setdefault(name, {})[vname] = os.path.join(work, 'fit', 'model.coef')
                if vname == 'report':  # C_aq = 0: predict's quasi-steady column is the static table alone
                    qs = {i: q for i, (_, q) in rms.items()}
                ratio = {c['id']: rms[c['id']][0] / qs[c['id']] for c in held}
                counts = [sum(ratio[c['id']] <= 0.5 for c in held if regime(c) == r) for r in REGIMES]
                sizes = [sum(regime(c) == r for c in held) for r in REGIMES]
                out.append(f'| `{vname}`: {vlabel} | {s_v:.4g} | ' +
                           ' | '.join(f'{n} of {m}' for n, m in zip(counts, sizes)) +
                           f' | {sum(counts)} of {len(held)} | {statistics.median(ratio.values()):.2f} |')
            out.append('')
    out.append(f'Total wall time: {time.time() - t0:.0f} s (nice, shared 2-core machine).')
    print('\n'.join(out))


CL_FITS = {}  # training choice -> variant -> the C_L fit's model.coef (for the C_m holds)

if __name__ == '__main__':
    main()
