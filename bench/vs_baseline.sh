#!/usr/bin/env bash
# bench/vs_baseline.sh -- the dynamic-stall step against the step of an earlier commit, on this
# machine (issue 22 item 6: "a step with every family for C_L + C_m at most 2x today's step
# (73 ns) on the same machine, instructions per step recorded").
#
#   bench/vs_baseline.sh [BASE_REV] [BUILD_DIR]
#
# BASE_REV (default 0438e75): the commit whose step is the reference. 0438e75 is the last commit
# on main before issue 22's work began (2026-11-25); its bench/RESULTS.md reads "state 73.1 ns"
# for Model II C_L + C_m in double, the issue's "today's step (73 ns)". BUILD_DIR (default
# build-bench beside the sources): where this checkout's bench_step is built.
#
# What it measures. The two steps live in two binaries (the reference is another commit's
# code), so the CPU-time ratio cannot come from one process as bench/RESULTS.md's ratios do.
# Instead: ROUNDS rounds (default 15), each running the reference's state/model2/double and this
# checkout's state/stall2/double and state/model2/double back to back (the order alternating
# from round to round), each a median of 3 Google Benchmark repetitions; the ratio is taken
# within a round (neighbours in time see the same machine load) and the report gives the
# median and the quartiles of the per-round ratios. Instructions per step (valgrind's callgrind,
# noise-free, optional) are the second measure. The benchmark's model and motion are the same
# in both binaries (bench/bench_models.hpp: Model II of Table I, alpha = 35 + 35 sin(2 pi t)
# deg at 1 kHz); the script checks that the reference binary has the variant.
#
# Needs git, cmake, ninja, a C++17 compiler, Google Benchmark, python3; valgrind optional.
# Takes about 3 minutes plus the builds (the reference's bench_step alone, in a temporary
# worktree removed at the end).
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
src="$(dirname "$here")"
base_rev="${1:-0438e75}"
build="${2:-$src/build-bench}"
rounds="${ROUNDS:-15}"

base_commit="$(git -C "$src" rev-parse --verify --quiet "$base_rev^{commit}")" || {
  echo "vs_baseline.sh: $base_rev is not a commit of $src" >&2; exit 2; }
work="$(mktemp -d "${TMPDIR:-/tmp}/indicial-vs-baseline.XXXXXX")"
cleanup() {
  git -C "$src" worktree remove --force "$work/base" >/dev/null 2>&1 || true
  rm -rf "$work"
}
trap cleanup EXIT

echo "== build the reference's bench_step ($base_rev) and this checkout's"
git -C "$src" worktree add --detach --quiet "$work/base" "$base_commit"
cmake -S "$work/base" -B "$work/base-build" -G Ninja -DCMAKE_BUILD_TYPE=Release >"$work/base-cmake.log"
cmake --build "$work/base-build" -j2 --target bench_step >"$work/base-build.log" 2>&1 || {
  tail -30 "$work/base-build.log"; exit 1; }
cmake -S "$src" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release >"$work/cmake.log"
cmake --build "$build" -j2 --target bench_step >"$work/build.log" 2>&1 || {
  tail -30 "$work/build.log"; exit 1; }
base_bin="$work/base-build/bench/bench_step"
head_bin="$build/bench/bench_step"
"$base_bin" --benchmark_list_tests | grep -qx 'state/model2/double' || {
  echo "vs_baseline.sh: $base_rev's bench_step has no state/model2/double" >&2; exit 2; }

one() {  # one() BINARY FILTER: "name median_ns" lines
  "$1" --benchmark_filter="$2" --benchmark_repetitions=3 --benchmark_min_time=0.1 \
    --benchmark_report_aggregates_only=true --benchmark_format=json 2>/dev/null |
    python3 -c 'import json, sys
for b in json.load(sys.stdin)["benchmarks"]:
    if b.get("aggregate_name") == "median": print(b["run_name"], b["cpu_time"])'
}

echo "== $rounds rounds on $(nproc) CPUs, load average at start $(cut -d' ' -f1-3 /proc/loadavg)"
: >"$work/rounds.txt"
for ((r = 0; r < rounds; ++r)); do
  if ((r % 2 == 0)); then
    one "$base_bin" '^state/model2/double$' | sed "s|^|$r base |" >>"$work/rounds.txt"
    one "$head_bin" '^state/(model2|stall2)/double$' | sed "s|^|$r head |" >>"$work/rounds.txt"
  else
    one "$head_bin" '^state/(model2|stall2)/double$' | sed "s|^|$r head |" >>"$work/rounds.txt"
    one "$base_bin" '^state/model2/double$' | sed "s|^|$r base |" >>"$work/rounds.txt"
  fi
done

ins_base="" ins_head_model2="" ins_head_stall2=""
if command -v valgrind >/dev/null; then
  echo "== callgrind instruction counts per step (50000 steps)"
  count() {  # count BINARY VARIANT: instructions per step ("" when the binary has no --callgrind mode)
    local f="$work/cg.$RANDOM.out"
    valgrind --tool=callgrind --instr-atstart=no --callgrind-out-file="$f" "$1" --callgrind "$2" 50000 \
      >/dev/null 2>&1 || { echo "vs_baseline.sh: no instruction count of $2 from $1" >&2; return 0; }
    python3 -c "import sys; print(int(sys.argv[1]) / 50000)" "$(sed -n 's/^totals: *//p' "$f" | head -1)"
  }
  ins_base="$(count "$base_bin" state/model2/double)"
  ins_head_model2="$(count "$head_bin" state/model2/double)"
  ins_head_stall2="$(count "$head_bin" state/stall2/double)"
fi

python3 - "$work/rounds.txt" "$base_rev" "$(git -C "$src" rev-parse --short HEAD)" \
  "$ins_base" "$ins_head_model2" "$ins_head_stall2" <<'EOF'
import statistics, sys
path, base_rev, head_rev, ins_base, ins_m2, ins_s2 = sys.argv[1:7]
rounds = {}
for line in open(path):
    r, who, name, ns = line.split()
    rounds.setdefault(int(r), {})[(who, name)] = float(ns)
def column(key):
    return [v[key] for v in rounds.values() if key in v]
def quartiles(v):
    q = statistics.quantiles(v, n=4) if len(v) > 1 else [v[0]] * 3
    return f"{q[1]:.3g} ({q[0]:.3g} .. {q[2]:.3g})"
B, M, S = ('base', 'state/model2/double'), ('head', 'state/model2/double'), ('head', 'state/stall2/double')
both = [v for v in rounds.values() if B in v and S in v and M in v]
print(f"\nreference: {base_rev}'s state/model2/double; this checkout: {head_rev}; {len(both)} rounds")
print("| measure | median (quartiles) |\n|---|---|")
print(f"| reference step, ns | {quartiles(column(B))} |")
print(f"| this checkout's Model II step, ns | {quartiles(column(M))} |")
print(f"| this checkout's step with every family (stall2), ns | {quartiles(column(S))} |")
print(f"| stall2 / reference step, per round | {quartiles([v[S] / v[B] for v in both])} |")
print(f"| stall2 / this checkout's Model II step, per round | {quartiles([v[S] / v[M] for v in both])} |")
print(f"| this checkout's Model II step / reference step, per round | {quartiles([v[M] / v[B] for v in both])} |")
if ins_base and ins_m2 and ins_s2:
    b, m, s = float(ins_base), float(ins_m2), float(ins_s2)
    print(f"\nInstructions per step (callgrind): reference {b:.0f}, this checkout's Model II {m:.0f}, "
          f"stall2 {s:.0f}: stall2 / reference {s / b:.2f}, stall2 / Model II {s / m:.2f}")
EOF
