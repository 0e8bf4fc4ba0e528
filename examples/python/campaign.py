#!/usr/bin/env python3
"""A Monte Carlo campaign of fits on Dask: are the Cramer-Rao bounds the real scatter?

    python3 examples/python/campaign.py [--fits 200] [--workers 1 2] [--snr 40]
    python3 examples/python/campaign.py --scheduler tcp://HOST:8786 --fits 400    # a cluster

Each task simulates Example 1's Model I (indicial.simulation_case, its own noise seed), fits it
from the arrays (indicial.fit) and returns the estimates and their bounds: plain numbers, so
only seeds and small dicts cross the network. The campaign then compares, per parameter, the
standard deviation of the estimates over the fits with the mean Cramer-Rao bound (white and
colored): the bounds are honest when the ratio is near 1.

Scaling: with --workers 1 2 the same task list runs on a LocalCluster of 1, then 2 worker
processes (one thread each; indicial.fit releases the GIL, but a process per core keeps the
Python work apart too), each --repeat times; the median wall times and their ratio are
printed. On a shared machine the load is printed with them.

On a multi-machine cluster: start `dask scheduler` on one machine and `dask worker
tcp://HOST:8786 --nthreads 1 --nworkers N` on every machine (each with indicial installed as in
the README: the venv and `pip install --no-build-isolation --no-index ./python`, the same
version everywhere), then pass --scheduler tcp://HOST:8786: the script is unchanged, Dask sends
each seed to a worker and gathers the results.
"""
import argparse
import os
import statistics
import time

import numpy as np

# The configuration of Example 1, Model I (the report's Table I; the simulation case's).
CONFIG = dict(coefficient="Cm", reference_length_m=0.3765, airspeed_mps=17.667761614265604,
              static_polynomial=[0, 0.42, 0.34, -1, 0.4], rotary_polynomial=[-2, 0, 0.8], a_powers=[0, 1, 2],
              a_knots_rad=list(np.radians([24.99814860155782, 54.99821875460772])), b1_powers=[0])


def one_fit(seed: int, snr: float) -> dict:
    """Simulate, fit, return {name: (value, cr_bound, cr_bound_colored)} (runs on a worker)."""
    import indicial
    case = indicial.simulation_case("tailless-model-1", snr=snr, seed=seed)
    runs = [indicial.Run(time_s=r.time_s, alpha_rad=r.motion_angle_rad, q_radps=r.rate_radps,
                         coefficient=r.measured["Cm"], name=r.name) for r in case.runs]
    r = indicial.fit(indicial.Experiment(runs=runs, **CONFIG), warn=False)
    return {"termination": r.termination,
            "parameters": {p.name: (p.value, p.cr_bound, p.cr_bound_colored) for p in r.parameters
                           if not p.name.startswith("y0")}}


def campaign(client, seeds, snr):
    futures = client.map(one_fit, seeds, snr=snr, pure=False)
    return client.gather(futures)


def summary(results):
    names = list(results[0]["parameters"])
    print(f"{len(results)} fits, {sum(r['termination'] == 'converged' for r in results)} converged")
    print(f"{'name':>6} {'mean':>10} {'std of estimates':>17} {'mean CR bound':>14} {'ratio':>6} "
          f"{'mean colored':>13} {'ratio':>6}")
    for n in names:
        v = np.array([r["parameters"][n] for r in results])
        sd = v[:, 0].std(ddof=1)
        print(f"{n:>6} {v[:, 0].mean():10.4g} {sd:17.3g} {v[:, 1].mean():14.3g} {sd / v[:, 1].mean():6.2f} "
              f"{v[:, 2].mean():13.3g} {sd / v[:, 2].mean():6.2f}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--fits", type=int, default=200)
    ap.add_argument("--snr", type=float, default=40.0)
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--scheduler", help="address of a running Dask scheduler (tcp://HOST:8786)")
    args = ap.parse_args()
    from dask.distributed import Client, LocalCluster

    seeds = list(range(1, args.fits + 1))
    if args.scheduler:
        with Client(args.scheduler) as client:
            t0 = time.perf_counter()
            results = campaign(client, seeds, args.snr)
            print(f"{args.fits} fits on {args.scheduler}: {time.perf_counter() - t0:.2f} s")
            summary(results)
        return
    wall = {}
    results = None
    for workers in args.workers:
        with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, \
                Client(cluster) as client:
            campaign(client, seeds[:workers], args.snr)  # warm-up: import indicial on every worker
            wall[workers] = []
            for _ in range(args.repeat):
                load = os.getloadavg()[0]
                t0 = time.perf_counter()
                results = campaign(client, seeds, args.snr)
                wall[workers].append(time.perf_counter() - t0)
                print(f"{workers} worker(s): {args.fits} fits in {wall[workers][-1]:.2f} s (load average {load:.1f})")
    summary(results)
    base = statistics.median(wall[args.workers[0]])
    for workers in args.workers:
        med = statistics.median(wall[workers])
        print(f"scaling: {workers} worker(s) median {med:.2f} s, speed-up {base / med:.2f}x over "
              f"{args.workers[0]} (os.cpu_count() = {os.cpu_count()})")


if __name__ == "__main__":
    main()
