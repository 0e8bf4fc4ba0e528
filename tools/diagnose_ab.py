#!/usr/bin/env python3
"""A/B of two `indicial` builds' diagnose on many three-cycle training choices of a measured
pitching-cycle database in the Glasgow layout (tools/cycle_catalog.py).

Usage: python3 tools/diagnose_ab.py DIR OLD_INDICIAL NEW_INDICIAL SCRATCH
(DIR: a database in the Glasgow layout, as tools/validate-real.sh takes it; nothing of it is
in this repository. AB_N in the environment: about how many training triples, default 12;
AB_ONLY: a regular expression, the triples whose name matches it instead, e.g.
AB_ONLY="sweep \\('5', 15.0")

Training triples: every (campaign, mean, amplitude) frequency sweep with three or more reduced
frequencies (cycle_catalog.spread_pick) and every (campaign, amplitude, k) set of three or more
mean angles (ends_and_middle), inside the polar's rows, thinned to about AB_N of them. For each
triple, coefficient (CL, Cm) and starting model (validate_real.py's `report` and `bl`), both
builds run `indicial diagnose`; where their final models differ (effects or fit error), both
predict every cycle that is neither trained on nor the polar's, at its periodic steady state,
and the line gives the median and mean of RMS / quasi-steady RMS over those cycles and how many
are at <= 0.5x. One line per case on stdout, then a summary of the wall times (summarize).
Written for the change of commit 4b48f3c (diagnose fits the models it compares against to
convergence): docs/diagnose.md cites its output; docs/diagnose-speed.md its wall times.

       python3 tools/diagnose_ab.py --summary OUT
prints the summary of a saved output OUT (its case lines) alone.
"""
import json, os, re, sys, statistics, time
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

CASE = re.compile(r" old (\[.*?\]) (\S+) +([0-9.]+)s \| new (\[.*?\]) (\S+) +([0-9.]+)s")


def quartiles(xs):
    q = statistics.quantiles(xs, n=4, method='inclusive') if len(xs) > 1 else [xs[0]] * 3
    return q[0], q[1], q[2]


def summarize(lines, limit_s=10.0):
    """The summary of the case lines: how many final models are the same (effects, and the fit
    error as printed: 5 decimals), each build's wall times (quartiles, largest, total, cases within limit_s)
    and the per-case ratio new / old."""
    cases = [m.groups() for m in map(CASE.search, lines) if m]
    if not cases:
        return ['no case lines']
    same = sum(o_eff == n_eff and o_err == n_err for o_eff, o_err, _, n_eff, n_err, _ in cases)
    out = [f'{len(cases)} cases; the final model the same (effects, fit error to 5 decimals) in {same}']
    for name, col in (('old', 2), ('new', 5)):
        t = [float(c[col]) for c in cases]
        q1, q2, q3 = quartiles(t)
        within = sum(x <= limit_s for x in t)
        out.append(f'{name}: wall time median {q2:.1f} s (quartiles {q1:.1f}-{q3:.1f}), largest {max(t):.1f} s, '
                   f'total {sum(t):.0f} s; {within} of {len(t)} within {limit_s:g} s')
    r = [float(c[5]) / float(c[2]) for c in cases]
    q1, q2, q3 = quartiles(r)
    out.append(f'new / old per case: median {q2:.2f} (quartiles {q1:.2f}-{q3:.2f}, range {min(r):.2f}-{max(r):.2f})')
    return out + heldout_summary(lines)


HELD = re.compile(r"^\S+ \(.*?\)\s+(\S+) (\S+)\s+old .* \|\| held-out median/QS old ([0-9.]+) \((\d+)\) "
                  r"new ([0-9.]+) \((\d+)\)")


def heldout_summary(lines, tie=0.005):
    """Over the cases whose final models differ (the lines with held-out predictions): per
    group (all, each coefficient, each starting model) how many predict their held-out cycles
    better / worse by the median ratio to quasi-steady (a change above `tie`), the held-out
    cycles at <= 0.5x quasi-steady summed over those cases, and the median of the per-case
    medians."""
    rows = [m.groups() for m in map(HELD.search, lines) if m]
    if not rows:
        return []
    out = []
    for group in ('all', 'CL', 'Cm', 'report', 'bl'):
        sel = [r for r in rows if group in ('all', r[0], r[1])]
        if not sel:
            continue
        old = [float(r[2]) for r in sel]
        new = [float(r[4]) for r in sel]
        better = sum(b < a - tie for a, b in zip(old, new))
        worse = sum(b > a + tie for a, b in zip(old, new))
        out.append(f'held-out, {group}: {len(sel)} changed models, {better} better, {worse} worse (median ratio); '
                   f'cycles at <= 0.5x {sum(int(r[3]) for r in sel)} -> {sum(int(r[5]) for r in sel)}; '
                   f'median of the medians {statistics.median(old):.3f} -> {statistics.median(new):.3f}')
    return out


def main():
    import cycle_catalog, validate_real as vr
    if len(sys.argv) != 5:
        sys.exit('usage: diagnose_ab.py DIR OLD_INDICIAL NEW_INDICIAL SCRATCH')
    vr.DATA = os.path.abspath(sys.argv[1])
    EXES = {'old': sys.argv[2], 'new': sys.argv[3]}
    vr.SCRATCH = sys.argv[4]
    os.makedirs(vr.SCRATCH, exist_ok=True)
    cat = cycle_catalog.read_catalog(vr.DATA)
    static_csv = os.path.join(vr.SCRATCH, 'static.dat')
    info = vr.static_table(cat, static_csv)
    lo, hi, _, _, stall, polar_ids = info
    # training triples: every sweep group (campaign, mean, amp) with >= 3 k, and every means group
    sweeps, means = {}, {}
    for c in cat:
        if c['id'] in polar_ids or cycle_catalog.is_quasi_static(c) or not cycle_catalog.within(vr.DATA, c, lo, hi): continue
        sweeps.setdefault((c['campaign'], c['mean'], c['amp']), {}).setdefault(cycle_catalog.k_key(c), c)
        means.setdefault((c['campaign'], c['amp'], cycle_catalog.k_key(c)), {}).setdefault(c['mean'], c)
    triples = []
    for g, ks in sorted(sweeps.items()):
        if len(ks) >= 3:
            by_k = {c['k']: c for c in ks.values()}
            triples.append((f"sweep {g}", [by_k[k] for k in cycle_catalog.spread_pick(list(by_k))]))
    for g, ms in sorted(means.items()):
        if len(ms) >= 3:
            triples.append((f"means {g}", [ms[m] for m in cycle_catalog.ends_and_middle(list(ms))]))
    if os.environ.get('AB_ONLY'):  # the triples whose name matches, unthinned
        triples = [t for t in triples if re.search(os.environ['AB_ONLY'], t[0])]
    else:
        step = max(1, len(triples) // int(os.environ.get('AB_N', '12')))
        triples = triples[::step]
    print(len(triples), 'training triples', flush=True)
    printed = []
    for name, train in triples:
        ids = {c['id'] for c in train}
        held = [c for c in cat if c['id'] not in ids and c['id'] not in polar_ids]
        v_ref = round(sum(c['v'] for c in train) / len(train), 3)
        a_lo = min(cycle_catalog.measured_range_deg(vr.DATA, c)[0] for c in train)
        a_hi = max(cycle_catalog.measured_range_deg(vr.DATA, c)[1] for c in train)
        knots = [k for k in range(0, 40, 5) if a_lo + 2.0 < k < a_hi - 2.0]
        for coef in ('CL', 'Cm'):
            for config in ('report', 'bl'):
                work = os.path.join(vr.SCRATCH, f"{name.replace(' ', '_').replace(',', '').replace('(', '').replace(')', '')}-{coef}-{config}")
                os.makedirs(work, exist_ok=True)
                exp = os.path.join(work, 'experiment.toml')
                with open(exp, 'w') as f: f.write(vr.experiment_toml(coef, train, static_csv, v_ref, vr.model_keys(config, knots, static_csv)))
                res = {}
                for v, exe in EXES.items():
                    t0 = time.time()
                    vr.run([exe, 'diagnose', exp, '--out', os.path.join(work, v), '--force', '--no-plots', '--quiet'], ok=(0, 6))
                    dj = json.load(open(os.path.join(work, v, 'diagnosis.json')))
                    res[v] = (dj['effects_added'], dj['final_fit_error'], time.time() - t0)
                same = res['old'][0] == res['new'][0] and abs(res['old'][1] / res['new'][1] - 1) < 1e-6
                line = f"{name:28s} {coef} {config:6s} old {res['old'][0]} {res['old'][1]:.5f} {res['old'][2]:5.1f}s | new {res['new'][0]} {res['new'][1]:.5f} {res['new'][2]:5.1f}s"
                if not same:
                    stats = {}
                    for v in EXES:
                        vr.EXE = EXES[v]
                        ratios = []
                        for c in held:
                            m, q = vr.predict_rms(os.path.join(work, v, 'model.coef'), c, exp, work)
                            ratios.append(m / q)
                        stats[v] = (statistics.median(ratios), sum(r <= 0.5 for r in ratios), statistics.mean(ratios))
                    line += f" || held-out median/QS old {stats['old'][0]:.3f} ({stats['old'][1]}) new {stats['new'][0]:.3f} ({stats['new'][1]}); mean old {stats['old'][2]:.3f} new {stats['new'][2]:.3f}"
                print(line, flush=True)
                printed.append(line)
    print('\n'.join(summarize(printed)))


if __name__ == '__main__':
    if len(sys.argv) == 3 and sys.argv[1] == '--summary':
        with open(sys.argv[2]) as f:
            print('\n'.join(summarize(f.read().splitlines())))
    else:
        main()
