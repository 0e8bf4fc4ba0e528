#!/usr/bin/env python3
"""Held-out validation of the dynamic-stall families on the Glasgow NACA 0012 cycles (issue 22).

Usage: tools/validate-stall.sh DATA_DIR [INDICIAL] > docs/validation-stall.md
       python3 tools/validate_stall.py --static-polar DATA_DIR static.csv   (the polar only)
       python3 tools/validate_stall.py --choices DATA_DIR   (what it would fit and hold out)
DATA_DIR is the Glasgow development set (README there: Green & Giuni, University of Glasgow
dynamic-stall database, campaigns 4-6) or any directory in its layout (tools/cycle_catalog.py:
every choice below is a rule on the catalog; the numbers in brackets are what the rules give
on the development set); nothing of it is copied into the repository. The
script writes every intermediate file into a temporary directory, runs `indicial fit` and
`indicial predict`, and prints the Markdown report on stdout.

What it does (every choice is stated in the report it prints):
 1. Runs: each cycle's phase (rad), Angle (deg), CL = Cn cos(alpha) + Ct sin(alpha) and Cm,
    as phase-averaged run CSVs (phase_rad column, periodic), at the catalog's airspeed and
    frequency.
 2. The static polar: the quasi-static cycles (k <= 0.015; cycle_catalog.polar_cycles, which
    says what it does without any) [the 15 campaign-4 cycles at k = 0.010], the UPSTROKE
    samples only (the angle rising: the data's README suggests upstrokes; a downstroke's flow
    stays separated below the static stall angle and reattaches late, so pooling both strokes
    puts that hysteresis into the static curve: measured, it raised the quasi-steady C_m error
    of the attached held-out cycles from 0.0195 to 0.0239), in 1-deg bins of the measured angle
    (bin mean of CL and Cm; bins with fewer than 4 samples dropped), held at the end values one
    row 4 deg beyond each end: static.csv with alpha_deg, CL, Cm.
 3. Held-out and fit cycles by choose_cycles' rule: held out, the cycles the Beddoes-Leishman
    peer was run on (bl-reference.csv; without that file, a campaign) [the 35 campaign-4 cycles
    of amplitude 10 deg]; fit, the other campaigns' non-quasi-static cycles, one per (campaign,
    mean angle, amplitude, reduced frequency to 0.025) [104 cycles of campaigns 5 and 6,
    amplitude 8 deg] -- another campaign and another amplitude than the fit.
 4. Four models per coefficient: quasi-steady (the static table alone), the report's model
    (a(x) of degree 2 with knots 3 deg below and 1 deg above the polar's stall angle [12 and
    16 deg], b1 constant; V_ref the fit cycles' median airspeed to 5 m/s [40]), the extended model (the
    same plus the separation and vortex families, stall = "separation_and_vortex", every stall
    parameter free: holding C_m's T1, T2 at the extended C_L fit's values (model.stall_known, as
    Beddoes-Leishman's moment does) raised the C_m fit error from 0.0461 to 0.0537; plus a
    constant pitch-rate derivative C_aq (rotary_correction_powers = [0]), the moment's pitch
    damping that Beddoes-Leishman's moment has too: with it the fit error on the FIT cycles fell
    from 0.0378 to 0.0312 (C_m) and 0.1077 to 0.1066 (C_L), measured with the stall start grid
    that `indicial fit` runs by default; no choice here was made on the held-out cycles); for C_L
    also a reattachment time constant of its own (stall_reattachment = "estimated", T1r: the fit
    cycles' error 0.1066 -> 0.1051 with T1r = 10.8 against T1 = 2.7; for C_m the fit with T1r
    ended at 0.0342 against 0.0312 without; since the fit also starts from the symmetric fit
    (commit f46d886) it ends at 0.03122 with T1r = T1: T1r buys C_m nothing, so C_m has none); for
    C_L also the static hysteresis (stall_hysteresis = "estimated", dxr: the fit cycles' error
    0.1051 -> 0.0984 with dxr = 4.0 deg; for C_m the fit took dxr to 0, the fit without it, so
    C_m has none); for C_L also the forcing lag's limit (stall_lag_limit = "estimated", D: the fit
    cycles' error 0.0984 -> 0.0979 with D = 6.4 deg; for C_m 0.03134 -> 0.03133, from the fit's
    nested start without D: D buys C_m nothing, so C_m has none), and the
    diagnosed model: `indicial diagnose` started from the report's model on the fit cycles,
    deciding by cross-validation over folds of the fit cycles (--max-folds 10: the held-out
    campaign is never seen by any choice), a stall candidate's own start from the fit's grid of
    18 starts (--stall-start-search grid, `indicial fit`'s default; diagnose's default is the
    configured start, for speed on few runs; chosen before this run's results were seen: with
    104 runs the ten folds guard the choice and the time is affordable), its final model.coef.
 5. Per held-out cycle: RMS of prediction minus measurement over the 128 samples (the
    periodic steady state, `indicial predict --periodic`), grouped by the cycle's largest
    angle (cycle_catalog.regime) [attached < 15 deg <= light stall < 22 deg <= deep stall],
    and by reduced frequency (the catalog's k to 0.025).
"""
import csv
import json
import math
import os
import subprocess
import sys
import tempfile
import time

import cycle_catalog

# Reference length: half the chord (0.55 m in the development set; INDICIAL_CHORD_M for another).
L_M = float(os.environ.get('INDICIAL_CHORD_M', '0.55')) / 2.0
KINDS = ('report', 'extended', 'diagnosed')


def read_cycle(path):
    """(phase_rad, alpha_deg, CL, Cm) per row: CL = Cn cos(alpha) + Ct sin(alpha)."""
    return [(ph, a, cl, cm) for ph, a, _, _, cm, cl in cycle_catalog.read_cycle(path)]


def write_run(path, rows):
    with open(path, 'w') as f:
        f.write('phase_rad,alpha_deg,CL,Cm\n')
        for i, (_, a, cl, cm) in enumerate(rows):
            # The phase of sample i: 2 pi i / n (the file's Time() column rounded to 0.01).
            f.write(f'{2 * math.pi * i / len(rows):.9f},{a:.6f},{cl:.6f},{cm:.6f}\n')


def static_polar(data, catalog, out):
    """The polar (cycle_catalog.polar_cycles: the quasi-static cycles' upstrokes) in 1-deg bins
    of >= 4 samples, held at its end values one row 4 deg beyond each end; written as
    alpha_deg, CL, Cm. Returns the rows, the sentence naming the source, the stall angle."""
    cycles, source = cycle_catalog.polar_cycles(catalog)
    bins = cycle_catalog.upstroke_bins(data, cycles)
    rows = sorted((a, b[4] / b[0], b[3] / b[0]) for a, b in bins.items() if b[0] >= cycle_catalog.MIN_BIN_SAMPLES)
    # Beyond the measured bins the polar is held at its end values (what the runtime does with
    # a table outside its rows), 4 deg further, so that the table covers every fit cycle.
    rows = [(rows[0][0] - 4, rows[0][1], rows[0][2])] + rows + [(rows[-1][0] + 4, rows[-1][1], rows[-1][2])]
    with open(out, 'w') as f:
        f.write('alpha_deg,CL,Cm\n')
        for a, cl, cm in rows:
            f.write(f'{a:.1f},{cl:.6f},{cm:.6f}\n')
    return rows, source, cycle_catalog.stall_angle_deg(bins)


def choose_cycles(data, catalog):
    """Held out: the peer's cycles (bl-reference.csv) when the directory has the peer's file,
    else every cycle of the campaign whose name sorts first (another catalog: a campaign never
    seen by the fit); with one campaign only, every third cycle. Fit: the cycles of the
    campaigns that hold no held-out cycle (with one campaign, the rest), one per (campaign,
    mean, amplitude, reduced frequency to 0.025). The polar's cycles are never either."""
    peer_path = os.path.join(data, 'bl-reference.csv')
    bl = {}
    if os.path.exists(peer_path):
        with open(peer_path) as f:
            bl = {r['id']: r for r in csv.DictReader(f)}
    polar_ids = {c['id'] for c in cycle_catalog.polar_cycles(catalog)[0]}
    moving = [c for c in catalog if c['id'] not in polar_ids]
    campaigns = sorted({c['campaign'] for c in moving})
    if bl:
        held = [c for c in moving if c['id'] in bl]
    elif len(campaigns) > 1:
        held = [c for c in moving if c['campaign'] == campaigns[0]]
    else:
        held = moving[::3]
    held_ids = {c['id'] for c in held}
    held_campaigns = {c['campaign'] for c in held}
    pool = [c for c in moving if c['id'] not in held_ids and
            (len(campaigns) == 1 or c['campaign'] not in held_campaigns)]
    fit, seen = [], set()
    for c in pool:
        key = (c['campaign'], c['mean'], c['amp'], round(c['k'] / 0.025))
        if key not in seen:
            seen.add(key)
            fit.append(c)
    if not held or not fit:
        raise SystemExit(f'{data}: no held-out or no fit cycles by the rule of choose_cycles')
    return fit, held, bl


def describe(cycles):
    camp = sorted({c['campaign'] for c in cycles})
    amps = sorted({c['amp'] for c in cycles})
    return (f"{len(cycles)} cycles of campaign{'s' if len(camp) > 1 else ''} {', '.join(camp)} "
            f"(amplitude{'s' if len(amps) > 1 else ''} {', '.join(f'{a:g}' for a in amps)} deg)")


def experiment(path, coefficient, runs, stall, vref, knots):
    lines = [f'axis = "pitch"', f'coefficient = "{coefficient}"', f'reference_length_m = {L_M}',
             f'airspeed_mps = {vref}', 'runs = [']
    for r in runs:
        lines.append(f'  {{file = "{r["file"]}", frequency_hz = {r["f"]}, airspeed_mps = {r["v"]}}},')
    lines += [']', '', '[static]', 'table = "static.csv"', '', '[model]', 'a_degree = 2',
              f'a_knots_deg = [{knots[0]:.1f}, {knots[1]:.1f}]', 'b1_degree = 0']
    if stall:
        lines += ['stall = "separation_and_vortex"', 'stall_polar = "static.csv"', 'stall_polar_column = "CL"',
                  'rotary_correction_powers = [0]']
        if coefficient == 'CL':  # T1r, dxr, D: chosen on the fit cycles' error (docstring, item 4)
            lines += ['stall_reattachment = "estimated"', 'stall_hysteresis = "estimated"',
                      'stall_lag_limit = "estimated"']
    with open(path, 'w') as f:
        f.write('\n'.join(lines) + '\n')


def run(cmd, ok=(0,)):
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode not in ok:
        sys.stderr.write(' '.join(cmd) + '\n' + p.stdout + p.stderr)
        return False
    return True


def rms(a, b):
    return math.sqrt(sum((x - y) ** 2 for x, y in zip(a, b)) / len(a))


def bias(a, b):
    """The mean of a - b: the part of the error a constant removes (Theil's decomposition,
    RMS^2 = bias^2 + spread^2; `indicial predict`'s mean_error)."""
    return sum(x - y for x, y in zip(a, b)) / len(a)


def main():
    usage = __doc__.split('\n\n')[1]
    if sys.argv[1:2] in (['-h'], ['--help']):
        print(usage)
        return
    if len(sys.argv) < 2 or sys.argv[1].startswith('-') and sys.argv[1] not in ('--static-polar', '--choices'):
        sys.exit(usage)
    if len(sys.argv) == 4 and sys.argv[1] == '--static-polar':
        # Only the static polar (step 2 above), as a [static] table / model.stall_polar CSV.
        data = sys.argv[2]
        catalog = cycle_catalog.read_catalog(data)
        _, source, stall_deg = static_polar(data, catalog, sys.argv[3])
        sys.stderr.write(f'static polar: {source}; stall angle {stall_deg:g} deg\n')
        return
    if len(sys.argv) == 3 and sys.argv[1] == '--choices':
        # What the study would fit and hold out, without running anything.
        data = sys.argv[2]
        catalog = cycle_catalog.read_catalog(data)
        with tempfile.TemporaryDirectory() as tmp:
            polar, source, stall_deg = static_polar(data, catalog, os.path.join(tmp, 'static.csv'))
        fit, held, bl = choose_cycles(data, catalog)
        print(f'static polar: {source}; {len(polar)} rows; stall angle {stall_deg:g} deg')
        print(f'fit: {describe(fit)}: ' + ' '.join(c['id'] for c in fit))
        print(f'held out: {describe(held)}' + (' (the peer\'s cycles)' if bl else '') + ': ' +
              ' '.join(c['id'] for c in held))
        return
    data = sys.argv[1]
    exe = sys.argv[2] if len(sys.argv) > 2 else 'indicial'
    catalog = cycle_catalog.read_catalog(data)
    work = tempfile.mkdtemp(prefix='indicial-stall-')
    polar, source, stall_deg = static_polar(data, catalog, os.path.join(work, 'static.csv'))
    fit, held, bl = choose_cycles(data, catalog)
    fit_runs = []
    for c in fit:
        name = f"fit_{c['id']}.csv"
        write_run(os.path.join(work, name), read_cycle(cycle_catalog.cycle_path(data, c)))
        fit_runs.append({'file': name, 'f': c['f'], 'v': c['v']})
    # V_ref: the fit cycles' median airspeed to 5 m/s (40 on the development set); it sets only
    # the units of b1 (1/s at V_ref), not the model.
    speeds = sorted(c['v'] for c in fit)
    vref = 5.0 * round(speeds[len(speeds) // 2] / 5.0)
    # The report model's a(x) knots: 3 deg below and 1 deg above the static stall angle (12 and
    # 16 deg on the development set, where they were chosen on the fit cycles).
    knots = (stall_deg - 3.0, stall_deg + 1.0)
    models = {}
    for coef in ('CL', 'Cm'):
        for kind, stall in (('report', False), ('extended', True)):
            exp = os.path.join(work, f'exp-{coef}-{kind}.toml')
            experiment(exp, coef, fit_runs, stall, vref, knots)
            out = os.path.join(work, f'fit-{coef}-{kind}')
            # 200 iterations: the extended C_L fit needs 61 (it stopped at the default 50 in the
            # run of 2026-11-27; rerun alone to convergence, s(v) 0.1051 -> 0.10512, the held-out
            # means unchanged to four digits).
            ok = run([exe, 'fit', exp, '--out', out, '--no-plots', '--quiet', '--max-iterations', '200'])
            models[(coef, kind)] = os.path.join(out, 'model.coef') if ok else None
            if ok:
                fj = json.load(open(os.path.join(out, 'fit.json')))
                models[(coef, kind, 'json')] = fj
        # The diagnosed model: every choice made on the fit cycles alone (folds of them).
        out = os.path.join(work, f'diag-{coef}')
        t0 = time.time()
        ok = run([exe, 'diagnose', os.path.join(work, f'exp-{coef}-report.toml'), '--out', out, '--no-plots',
                  '--quiet', '--max-folds', '10', '--stall-start-search', 'grid'], ok=(0, 6))
        models[(coef, 'diagnosed')] = os.path.join(out, 'model.coef') if ok else None
        if ok:
            dj = json.load(open(os.path.join(out, 'diagnosis.json')))
            dj['wall_s'] = time.time() - t0
            models[(coef, 'diagnosed', 'json')] = dj
    results = []
    for c in held:
        rows = read_cycle(cycle_catalog.cycle_path(data, c))
        path = os.path.join(work, f"held_{c['id']}.csv")
        write_run(path, rows)
        regime = cycle_catalog.regime(max(r[1] for r in rows), stall_deg)
        peer = bl.get(c['id'], {})
        res = {'id': c['id'], 'mean': c['mean'], 'k': c['k'], 'regime': regime,
               'bl_CL': float(peer.get('bl_rms_CL', 'nan')), 'bl_Cm': float(peer.get('bl_rms_Cm', 'nan'))}
        for coef, col in (('CL', 2), ('Cm', 3)):
            meas = [r[col] for r in rows]
            for kind in KINDS:
                m = models.get((coef, kind))
                if not m:
                    res[f'{kind}_{coef}'] = float('nan')
                    continue
                out = os.path.join(work, f"pred_{c['id']}_{coef}_{kind}.csv")
                ok = run([exe, 'predict', m, path, '--out', out, '--frequency-hz', str(c['f']),
                          '--airspeed-mps', str(c['v']), '--force'])
                if not ok:
                    res[f'{kind}_{coef}'] = float('nan')
                    continue
                pred = list(csv.DictReader(line for line in open(out) if not line.startswith('#')))
                res[f'{kind}_{coef}'] = rms([float(p[f'{coef}_pred']) for p in pred], meas)
                res[f'{kind}_{coef}_bias'] = bias([float(p[f'{coef}_pred']) for p in pred], meas)
                # Quasi-steady = the static table alone: the report model's column (C_aq = 0;
                # a diagnosed model's quasi-steady column includes its rotary term).
                if kind == 'report':
                    qs = [float(p[f'{coef}_quasi_steady']) for p in pred] if f'{coef}_quasi_steady' in pred[0] else []
                    res[f'qs_{coef}'] = rms(qs, meas) if qs else float('nan')
                    res[f'qs_{coef}_bias'] = bias(qs, meas) if qs else float('nan')
        results.append(res)
    report(results, (polar, source, stall_deg), (fit, held), models)


def mean(v):
    v = [x for x in v if not math.isnan(x)]
    return sum(v) / len(v) if v else float('nan')


def diagnosis_lines(coef, dj):
    p = print
    p(f'* diagnose {coef} (from the report model, on the fit cycles): rule `{dj.get("rule")}` '
      f'({dj.get("rule_reason", "")}); verdict `{dj.get("verdict")}`, effects added {dj.get("effects_added")}, '
      f'stopped `{dj.get("stopped")}`, fit error {dj.get("initial_fit_error", float("nan")):.4g} -> '
      f'{dj.get("final_fit_error", float("nan")):.4g}, {dj.get("fits_run", "?")} fits, {dj["wall_s"]:.0f} s wall')
    for i, st in enumerate(dj.get('steps', []), start=1):
        before, after = st.get('held_out_rms_before') or [], st.get('held_out_rms_after') or []
        if before and after:
            mb = math.sqrt(sum(v * v for v in before) / len(before))
            ma = math.sqrt(sum(v * v for v in after) / len(after))
            p(f'  * step {i}: `{st.get("effect")}` ({st.get("term")}): held-out RMS over the '
              f"fit cycles' folds {mb:.4f} -> {ma:.4f}")
        else:
            p(f'  * step {i}: `{st.get("effect")}` ({st.get("term")})')


def by_regime(results):
    """(regime, its results) for attached, light, deep and all."""
    for regime in ('attached', 'light', 'deep', 'all'):
        yield regime, [r for r in results if regime == 'all' or r['regime'] == regime]


def model_means(rs, coef):
    """Mean RMS over the cycles rs of quasi-steady, the report, extended and diagnosed models and
    the peer, in that order (a failed prediction, NaN, left out)."""
    return [mean([r.get(f'{m}_{coef}', float('nan')) for r in rs])
            for m in ('qs', 'report', 'extended', 'diagnosed', 'bl')]


def k_table(results):
    """Mean held-out RMS per reduced frequency (to 0.025, as the fit cycles are chosen): where in
    k each model stands against the peer."""
    p = print
    p('\nMean held-out RMS per reduced frequency (the catalog\'s k, to 0.025):\n')
    p('| k | cycles | coef | quasi-steady | report model | extended | diagnosed | BL peer | extended / BL | '
      'diagnosed / BL |')
    p('|---|---|---|---|---|---|---|---|---|---|')
    groups = {}
    for r in results:
        groups.setdefault(round(r['k'] / 0.025) * 0.025, []).append(r)
    for k in sorted(groups):
        rs = groups[k]
        for coef in ('CL', 'Cm'):
            qs, rep, ext, dia, blv = model_means(rs, coef)
            p(f'| {k:.3f} | {len(rs)} | {coef} | {qs:.4f} | {rep:.4f} | {ext:.4f} | {dia:.4f} | {blv:.4f} | '
              f'{ext / blv:.2f} | {dia / blv:.2f} |')


def bias_table(results):
    """Theil's decomposition of the held-out error: each cycle's own bias (mean error) apart
    from its shape. The data's per-run zero drift is in the bias, and no model of the motion
    predicts it; the peer's share cannot be given (bl-reference.csv has its RMS only)."""
    p = print
    p('\nThe bias in the held-out error (Theil\'s decomposition, RMS^2 = bias^2 + spread^2 per cycle, '
      'bias = the cycle\'s mean error; `indicial predict`\'s `mean_error`): share of the mean square error '
      'over the cycles that is bias, and the mean RMS about each cycle\'s own bias. Where the measured '
      'cycles carry a zero drift of their own (a tunnel run\'s), no model of the motion predicts it: it '
      'bounds what any model reaches. The peer\'s decomposition is not known (its RMS only).\n')
    p('| regime | coef | QS: bias share | report: bias share | extended: bias share | diagnosed: bias share | '
      'diagnosed: mean RMS | diagnosed: mean RMS about the bias |')
    p('|---|---|---|---|---|---|---|---|')
    for regime, rs in by_regime(results):
        for coef in ('CL', 'Cm'):
            cells = []
            for k in ('qs', 'report', 'extended', 'diagnosed'):
                pairs = [(r.get(f'{k}_{coef}', float('nan')), r.get(f'{k}_{coef}_bias', float('nan'))) for r in rs]
                pairs = [(e, b) for e, b in pairs if not (math.isnan(e) or math.isnan(b))]
                mse = sum(e * e for e, _ in pairs)
                cells.append(f'{sum(b * b for _, b in pairs) / mse:.2f}' if mse > 0 else 'n/a')
            # A failed prediction is NaN in both columns (mean() leaves it out), never a 0.
            spread = mean([math.sqrt(max(0.0, d)) if not math.isnan(d) else float('nan')
                           for d in (r.get(f'diagnosed_{coef}', float('nan')) ** 2 -
                                     r.get(f'diagnosed_{coef}_bias', float('nan')) ** 2 for r in rs)])
            dia = mean([r.get(f'diagnosed_{coef}', float('nan')) for r in rs])
            p(f'| {regime} | {coef} | ' + ' | '.join(cells) + f' | {dia:.4f} | {spread:.4f} |')


def report(results, static, cycles, models):
    p = print
    p('# Held-out validation of the dynamic-stall families on measured cycles (issue 22)\n')
    p('Data: University of Glasgow dynamic-stall database, NACA 0012 (Green, R. B. & Giuni, M., '
      '"Dynamic stall database R and D 1570-AM-01: Final Report", University of Glasgow, 2017), '
      'campaigns ' + ', '.join(sorted({c['campaign'] for c in cycles[0] + cycles[1]})) + ' (for the committed file the '
      'development set, as in its README; the script reads any '
      'directory in that layout). Peer: the Beddoes-Leishman model of dos '
      'Santos & Marques (2021) with its published parameters (bl-reference.csv). Produced by '
      '`tools/validate-stall.sh DATA_DIR` (the method is in tools/validate_stall.py\'s docstring; every choice '
      'is a rule of tools/cycle_catalog.py or choose_cycles, not a list of cycles).\n')
    polar, source, stall_deg = static
    fit, held = cycles
    p(f'Static polar: {len(polar)} 1-deg bins of {source} (angle rising); static stall angle {stall_deg:g} deg. '
      f'Fit: {describe(fit)}, one per mean angle, amplitude and k, CL and Cm fitted apart. '
      f'Held out: {describe(held)}.\n')
    for coef in ('CL', 'Cm'):
        for kind in ('report', 'extended'):
            fj = models.get((coef, kind, 'json'))
            if fj:
                p(f'* fit {coef} {kind}: {fj.get("termination", "?")}, s(v) = {fj.get("fit_error", float("nan")):.4g}, '
                  f'{fj.get("n_parameters", "?")} parameters, {fj.get("iterations", "?")} iterations, '
                  f'runtime replay: {fj.get("runtime_check", {})}')
            else:
                p(f'* fit {coef} {kind}: FAILED (see stderr)')
        dj = models.get((coef, 'diagnosed', 'json'))
        if dj:
            diagnosis_lines(coef, dj)
        else:
            p(f'* diagnose {coef}: FAILED (see stderr)')
    p('')
    p(f'Mean held-out RMS per regime ({cycle_catalog.regime_rule(stall_deg)}):\n')
    p('| regime | cycles | coef | quasi-steady | report model | extended | diagnosed | BL peer | extended / BL | '
      'diagnosed / BL | diagnosed / QS | diagnosed <= 0.5x QS |')
    p('|---|---|---|---|---|---|---|---|---|---|---|---|')
    for regime, rs in by_regime(results):
        for coef in ('CL', 'Cm'):
            qs, rep, ext, dia, blv = model_means(rs, coef)
            half = sum(1 for r in rs if r.get(f'diagnosed_{coef}', float('nan')) <= 0.5 * r.get(f'qs_{coef}', float('nan')))
            p(f'| {regime} | {len(rs)} | {coef} | {qs:.4f} | {rep:.4f} | {ext:.4f} | {dia:.4f} | {blv:.4f} | '
              f'{ext / blv:.2f} | {dia / blv:.2f} | {dia / qs:.2f} | {half} of {len(rs)} |')
    k_table(results)
    bias_table(results)
    p('\nPer cycle (RMS):\n')
    cols = [(f'{k}_{c}', f'{lab} {c}') for c in ('CL', 'Cm')
            for k, lab in (('qs', 'QS'), ('report', 'report'), ('extended', 'ext'), ('diagnosed', 'diag'), ('bl', 'BL'))]
    p('| id | mean deg | k | regime | ' + ' | '.join(lab for _, lab in cols) + ' |')
    p('|---|---|---|---|' + '---|' * len(cols))
    for r in sorted(results, key=lambda r: (r['mean'], r['k'])):
        p(f"| {r['id']} | {r['mean']:g} | {r['k']:.3f} | {r['regime']} | " +
          ' | '.join(f"{r.get(k, float('nan')):.4f}" for k, _ in cols) + ' |')


if __name__ == '__main__':
    main()
