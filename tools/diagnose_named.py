#!/usr/bin/env python3
"""Does what diagnose names lower the error on cycles it never saw? (issue 21's acceptance:
"diagnose names an effect in each real experiment and the effect lowers the held-out error")

Usage: nice python3 tools/diagnose_named.py DIR INDICIAL AB_SCRATCH [BUILD] > OUT.md

AB_SCRATCH: the SCRATCH of a run of tools/diagnose_ab.py on DIR (its case directories
`<triple>-<coefficient>-<start>/` with `experiment.toml` and the diagnosis of build BUILD,
default `new`, in `BUILD/`). For every case the script fits the configured model of the same
experiment file with INDICIAL (`indicial fit`, no diagnose) and, where diagnose named an
effect, predicts every cycle of DIR that is neither trained on nor the static polar's (at its
periodic steady state, tools/validate_real.py's predict_rms) with the configured model and with
diagnose's final model. It prints, per starting model and coefficient: the diagnoses, how many
named an effect, and of those how many predict the other cycles better than the configured
model by the median and by the mean of RMS / quasi-steady RMS, with the held-out cycles at
<= 0.5x summed. INDICIAL should be the build whose diagnosis is read (the configured fit is
its). Standard library only; about ten minutes on a shared 2-core machine for 184 cases.
"""
import concurrent.futures
import json
import os
import re
import statistics
import sys

import cycle_catalog
import validate_real as vr

RUN_FILE = re.compile(r'cycles/(\w+)_coeffs\.dat')


def case_result(case_dir, build, catalog, polar_ids):
    """(start, coefficient, named, configured ratios, final ratios) of one case; ratios None
    when nothing was named."""
    name = os.path.basename(case_dir)
    coef, start = name.rsplit('-', 2)[1:]
    with open(os.path.join(case_dir, build, 'diagnosis.json')) as f:
        named = json.load(f)['effects_added']
    if not named:
        return start, coef, named, None, None
    exp = os.path.join(case_dir, 'experiment.toml')
    with open(exp) as f:
        trained = set(RUN_FILE.findall(f.read()))
    fit_dir = os.path.join(case_dir, 'named-fit')
    vr.run([vr.EXE, 'fit', exp, '--out', fit_dir, '--force', '--no-plots'])
    work = os.path.join(case_dir, 'named-predict')
    os.makedirs(work, exist_ok=True)
    held = [c for c in catalog if c['id'] not in trained and c['id'] not in polar_ids]
    ratios = {}
    for label, model in (('configured', os.path.join(fit_dir, 'model.coef')),
                         ('final', os.path.join(case_dir, build, 'model.coef'))):
        ratios[label] = []
        for c in held:
            m, q = vr.predict_rms(model, c, exp, work)
            ratios[label].append(m / q)
    return start, coef, named, ratios['configured'], ratios['final']


def summary(results):
    out = ['| start | coefficient | diagnoses | named an effect | final better by the median ratio | '
           'by the mean ratio | held-out cycles at <= 0.5x, configured -> final (named cases) | '
           'median of the median ratios, configured -> final |', '|---|---|---|---|---|---|---|---|']
    for start in ('report', 'bl'):
        for coef in ('CL', 'Cm', 'all'):
            sel = [r for r in results if r[0] == start and coef in ('all', r[1])]
            if not sel:
                continue
            named = [r for r in sel if r[2]]
            med = [(statistics.median(r[3]), statistics.median(r[4])) for r in named]
            mean = [(statistics.mean(r[3]), statistics.mean(r[4])) for r in named]
            better_med = sum(b < a for a, b in med)
            better_mean = sum(b < a for a, b in mean)
            half = (sum(sum(x <= 0.5 for x in r[3]) for r in named), sum(sum(x <= 0.5 for x in r[4]) for r in named))
            mm = (f'{statistics.median(a for a, _ in med):.3f} -> {statistics.median(b for _, b in med):.3f}'
                  if med else '-')
            out.append(f'| {start} | {coef} | {len(sel)} | {len(named)} | {better_med} of {len(named)} | '
                       f'{better_mean} of {len(named)} | {half[0]} -> {half[1]} | {mm} |')
    return out


def main(argv):
    if len(argv) not in (4, 5):
        sys.exit(__doc__.split('\n\n')[1])
    vr.DATA = os.path.abspath(argv[1])
    vr.EXE = argv[2]
    scratch = argv[3]
    build = argv[4] if len(argv) == 5 else 'new'
    catalog = cycle_catalog.read_catalog(vr.DATA)
    polar_ids = {c['id'] for c in cycle_catalog.polar_cycles(catalog)[0]}
    cases = sorted(os.path.join(scratch, d) for d in os.listdir(scratch)
                   if os.path.exists(os.path.join(scratch, d, build, 'diagnosis.json')))
    with concurrent.futures.ThreadPoolExecutor(2) as pool:
        results = list(pool.map(lambda d: case_result(d, build, catalog, polar_ids), cases))
    print(f'# What diagnose named, on the cycles it never saw ({len(cases)} diagnoses)\n')
    print(f'Written by `tools/diagnose_named.py DIR INDICIAL AB_SCRATCH` (its docstring has the method); '
          f'tool `{vr.tool_version()}`. Data: DIR\'s cycles, not in this repository. A case is one '
          'diagnosis of tools/diagnose_ab.py (a three-cycle training choice, a coefficient, a starting '
          'model); "better": the final model\'s ratio of RMS to the quasi-steady RMS over the other cycles '
          'is below the configured model\'s.\n')
    print('\n'.join(summary(results)))
    print('\nPer case (named effects; median ratio configured -> final, cycles at <= 0.5x):\n')
    for d, r in zip(cases, results):
        if r[2]:
            print(f'* {os.path.basename(d)}: {", ".join(r[2])}; {statistics.median(r[3]):.3f} -> '
                  f'{statistics.median(r[4]):.3f}, {sum(x <= 0.5 for x in r[3])} -> {sum(x <= 0.5 for x in r[4])}')


if __name__ == '__main__':
    main(sys.argv)
