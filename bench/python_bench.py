#!/usr/bin/env python3
"""The Python package's speed against C++ (issue 23 item 6): a benchmark, not a test.

  PYTHONPATH=build/python /usr/bin/python3 bench/python_bench.py [--repeat 15] > bench/PYTHON-RESULTS.md

1. Batch stepping, 1024 instances of Example 1's Model II (examples/tailless-model-2.coef,
   C_m, DefaultCapacity), each on its own phase of a 35 +/- 35 deg, 1 Hz motion at 1 kHz,
   1000 steps (1 s) per repetition, three ways in ONE process on the same arrays:
     cpp    the C++ loop: step_batch once per time step (indicial._indicial._bench_step_batch,
            timed inside C++; what a C++ program calling step_batch does)
     step   BatchStepper.step from a Python loop: one call per time step (1000 calls)
     run    BatchStepper.run: the whole (1000, 1024) history in one call
   Repetitions are interleaved (cpp, step, run, cpp, ...) so the machine's load hits all three
   alike; reported are medians and the median of the per-repetition ratios.
2. Fit: Example 1 (tailless-model-1, SNR 40, seed 1, from arrays): the wall time of
   indicial.fit() seen from Python against FitResult.elapsed_s, the C++ fit_experiment's own
   wall time in the same call; the difference is the binding (argument conversion, the
   runtime's check of the fitted model and its coefficient text, the result objects).
"""
import argparse
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

import indicial
from indicial import _indicial

REPO = Path(__file__).resolve().parents[1]


def motion(n=1024, steps=1000, dt=1e-3):
    t = np.arange(1, steps + 1)[:, None] * dt
    phase = np.arange(n)[None, :] * (2 * np.pi / n)
    amp = np.radians(35.0)
    alpha = np.ascontiguousarray(amp - amp * np.cos(2 * np.pi * t + phase))
    q = np.ascontiguousarray(amp * 2 * np.pi * np.sin(2 * np.pi * t + phase))
    return alpha, q


def bench_batch(repeat):
    model = indicial.Model.load(str(REPO / "examples" / "tailless-model-2.coef"))
    alpha, q = motion()
    steps, n = alpha.shape
    v, dt = model.airspeed_mps, 1e-3
    s = indicial.BatchStepper(model, n)
    times = {"cpp": [], "step": [], "run": []}
    cpu = {"cpp": [], "step": [], "run": []}
    last = {}
    for _ in range(repeat):
        sec, out, cpu_sec = _indicial._bench_step_batch(model._m, alpha, q, v, dt)
        times["cpp"].append(sec)
        cpu["cpp"].append(cpu_sec)
        last["cpp"] = out
        s.reset(alpha_rad=alpha[0], airspeed_mps=v)
        t0, c0 = time.perf_counter(), time.thread_time()
        for k in range(steps):
            s.step(alpha_rad=alpha[k], q_radps=q[k], dt_s=dt, airspeed_mps=v)
        times["step"].append(time.perf_counter() - t0)
        cpu["step"].append(time.thread_time() - c0)
        last["step"] = s.outputs[:, 0].copy()
        s.reset(alpha_rad=alpha[0], airspeed_mps=v)
        t0, c0 = time.perf_counter(), time.thread_time()
        hist = s.run(alpha_rad=alpha, q_radps=q, dt_s=dt, airspeed_mps=v)
        times["run"].append(time.perf_counter() - t0)
        cpu["run"].append(time.thread_time() - c0)
        last["run"] = hist[-1, :, 0].copy()
    assert np.array_equal(last["cpp"], last["step"]) and np.array_equal(last["cpp"], last["run"])
    return times, cpu, steps * n


def bench_fit(repeat):
    case = indicial.simulation_case("tailless-model-1", snr=40, seed=1)
    runs = [indicial.Run(time_s=r.time_s, alpha_rad=r.motion_angle_rad, q_radps=r.rate_radps,
                         coefficient=r.measured["Cm"], name=r.name) for r in case.runs]
    e = indicial.Experiment(coefficient="Cm", reference_length_m=0.3765, airspeed_mps=17.667761614265604, runs=runs,
                            static_polynomial=[0, 0.42, 0.34, -1, 0.4], rotary_polynomial=[-2, 0, 0.8],
                            a_powers=[0, 1, 2], a_knots_rad=np.radians([24.99814860155782, 54.99821875460772]),
                            b1_powers=[0])
    wall, inner = [], []
    for _ in range(repeat):
        t0 = time.perf_counter()
        r = indicial.fit(e, warn=False)
        wall.append(time.perf_counter() - t0)
        inner.append(r.elapsed_s)
    return wall, inner


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeat", type=int, default=15)
    args = ap.parse_args()
    med = statistics.median
    load = os.getloadavg()
    times, cpu, instance_steps = bench_batch(args.repeat)
    wall, inner = bench_fit(3 * args.repeat)
    w = print
    w("# Python package speed (bench/python_bench.py)")
    w()
    w(f"Measured {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, {os.cpu_count()} CPUs, load average at "
      f"start {load[0]:.1f} / {load[1]:.1f} / {load[2]:.1f} (a shared machine: medians of {args.repeat} "
      f"interleaved repetitions), Python {sys.version.split()[0]}, step_batch kernel as built (automatic).")
    w()
    w("## Batch stepping: 1024 instances x 1000 steps (Model II C_m, DefaultCapacity)")
    w()
    w("| way | median wall s | median thread CPU s | M instance-steps/s (CPU) | CPU ratio to cpp | wall ratio to cpp |")
    w("|---|---|---|---|---|---|")
    for k in ("cpp", "step", "run"):
        w(f"| {k} | {med(times[k]):.5f} | {med(cpu[k]):.5f} | {instance_steps / med(cpu[k]) / 1e6:.1f} | "
          f"{med(cpu[k]) / med(cpu['cpp']):.3f} | {med(times[k]) / med(times['cpp']):.3f} |")
    w()
    w("`cpp`: step_batch from a C++ loop (timed in C++); `step`: BatchStepper.step once per time step from a "
      "Python loop; `run`: BatchStepper.run, the whole history in one call. All three give bit-identical outputs "
      "(checked). Ratios are of the medians; the thread CPU time (CLOCK_THREAD_CPUTIME_ID in C++, "
      "time.thread_time() in Python, the same clock) is what a loaded machine inflates least. Goal: within 10 % "
      "of cpp.")
    w()
    w("## Fit: Example 1, Model I, SNR 40 (3 runs, from arrays)")
    w()
    ratios = [a / b for a, b in zip(wall, inner)]
    w(f"| {len(wall)} fits | median s |")
    w("|---|---|")
    w(f"| indicial.fit() wall time seen from Python | {med(wall):.4f} |")
    w(f"| fit_experiment in-process (FitResult.elapsed_s) | {med(inner):.4f} |")
    w(f"| ratio of the medians | {med(wall) / med(inner):.4f} |")
    w(f"| median of the per-fit ratios | {med(ratios):.4f} |")
    w()
    w("Goal: within 5 %.")


if __name__ == "__main__":
    main()
