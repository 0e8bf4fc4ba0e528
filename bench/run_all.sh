#!/usr/bin/env bash
# bench/run_all.sh -- build the benchmarks in Release, run them all, write bench/RESULTS.md.
#
#   bench/run_all.sh [BUILD_DIR]          (default: build-bench beside the sources)
#
# Environment: HIL_SECONDS (default 60: the 10 kHz loaded loop of the goal), HIL_SHORT_SECONDS
# (default 10: the other loops), REPS (default 5:
# Google Benchmark repetitions; medians are reported), SKIP_FITTER=1 (runtime only),
# SKIP_CALLGRIND=1, SKIP_CORTEX_M=1 (no tools/run-cortex-m.sh section), NATIVE=1 (build for this CPU, INDICIAL_NATIVE), RESULTS_MD (default
# bench/RESULTS.md: where the report goes; make_results.py also prints the README's headline
# line from this run). The runs take about 6 minutes on an idle 2-core machine, plus the build. Needs cmake, ninja, a C++17
# compiler, Google Benchmark, python3; valgrind for the instruction counts (optional).
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
src="$(dirname "$here")"
build="${1:-$src/build-bench}"
hil_seconds="${HIL_SECONDS:-60}"
hil_short="${HIL_SHORT_SECONDS:-10}"
reps="${REPS:-5}"
out="$build/bench-out"
mkdir -p "$out"
rm -f "$out"/*.json "$out"/*.txt "$out"/*.md "$out"/*.out

echo "== configure and build (Release) in $build"
# NATIVE=1: every target for this machine's CPU (INDICIAL_NATIVE: -march=native, AVX-512 here).
cmake -S "$src" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release \
  -DINDICIAL_NATIVE="$([[ "${NATIVE:-0}" == 1 ]] && echo ON || echo OFF)" >"$out/cmake.log"
targets=(bench_step bench_throughput hil)
[[ "${SKIP_FITTER:-0}" == 1 ]] || targets+=(bench_fitter)
cmake --build "$build" -j2 --target "${targets[@]}" >"$out/build.log" 2>&1 || {
  tail -30 "$out/build.log"; exit 1; }
bin="$build/bench"

# Machine description.
{
  echo "date: $(date -u +%Y-%m-%dT%H:%M:%SZ)"
  echo "commit: $(git -C "$src" rev-parse --short HEAD 2>/dev/null || echo unknown)"
  echo "cpu: $(lscpu | sed -n 's/^Model name: *//p' | head -1)"
  echo "cpus: $(nproc) online; $(lscpu | sed -n 's/^Thread(s) per core: *//p') thread(s) per core; $(lscpu | sed -n 's/^Hypervisor vendor: *//p' | head -1) guest"
  echo "caches: L1d $(lscpu | sed -n 's/^L1d cache: *//p'), L2 $(lscpu | sed -n 's/^L2 cache: *//p'), L3 $(lscpu | sed -n 's/^L3 cache: *//p')"
  echo "kernel: $(uname -sr)"
  cxx="$(sed -n 's/^CMAKE_CXX_COMPILER:[A-Z]*=//p' "$build/CMakeCache.txt")"
  echo "compiler: $("$cxx" --version | head -1), flags: $(sed -n 's/^CMAKE_CXX_FLAGS_RELEASE:[A-Z]*=//p' "$build/CMakeCache.txt")"
  echo "benchmark library: Google Benchmark $(dpkg-query -W -f='${Version}' libbenchmark-dev 2>/dev/null || echo '?')"
  echo "load average at start: $(cut -d' ' -f1-3 /proc/loadavg)"
} >"$out/machine.txt"
cat "$out/machine.txt"

gb_flags=(--benchmark_repetitions="$reps" --benchmark_report_aggregates_only=true
          --benchmark_format=console --benchmark_out_format=json)

echo "== bench_step"
"$bin/bench_step" "${gb_flags[@]}" --benchmark_min_time=0.2 \
  --benchmark_out="$out/step.json" | grep -E '_median|^-' || true

echo "== C vs C++, state vs floor and the dynamic-stall step, Model II, interleaved (random order, medians)"
"$bin/bench_step" --benchmark_filter='^((state|c|floor)/model2|state/stall2)/double$' \
  --benchmark_enable_random_interleaving=true --benchmark_repetitions="$((reps * 3))" \
  --benchmark_min_time=0.1 --benchmark_report_aggregates_only=true --benchmark_format=console \
  --benchmark_out_format=json --benchmark_out="$out/interleaved.json" | grep -E '_median' || true

if [[ "${SKIP_CALLGRIND:-0}" != 1 ]] && command -v valgrind >/dev/null; then
  echo "== callgrind instruction counts per step"
  steps=50000
  : >"$out/callgrind.txt"
  for v in step/model1/double step/model2/double step/twolag/double step/model2/float \
           state/model2/double c/model2/double model/model2/double \
           floor/model1/double floor/model2/double floor/twolag/double floor/model2/float \
           update/model2/double update/model2/float \
           state/stall2/double state/stall2/float state/stall2h/double; do
    f="$out/callgrind.$(echo "$v" | tr / _).out"
    valgrind --tool=callgrind --instr-atstart=no --callgrind-out-file="$f" \
      "$bin/bench_step" --callgrind "$v" "$steps" >/dev/null 2>&1
    ir="$(sed -n 's/^totals: *//p' "$f" | head -1)"
    echo "$v $ir $steps $f" | tee -a "$out/callgrind.txt"
  done
fi

echo "== bench_throughput"
# Interleaved: every variant sees the same machine (a noisy neighbour hits all of them alike).
"$bin/bench_throughput" --benchmark_repetitions=5 --benchmark_enable_random_interleaving=true \
  --benchmark_report_aggregates_only=true \
  --benchmark_out_format=json --benchmark_out="$out/throughput.json" | grep -E '_median' || true

if [[ "${SKIP_FITTER:-0}" != 1 ]]; then
  echo "== bench_fitter"
  "$bin/bench_fitter" --benchmark_filter='^fit/|^montecarlo' --benchmark_repetitions=3 \
    --benchmark_report_aggregates_only=true --benchmark_out_format=json \
    --benchmark_out="$out/fitter.json" | grep -E '_median' || true
  "$bin/bench_fitter" --benchmark_filter='^ml_iteration' --benchmark_out_format=json \
    --benchmark_out="$out/fitter_ml.json" | grep -E 'ml_iteration' || true
fi

echo "== hil (1 kHz and 10 kHz idle, 10 s each; 1 kHz loaded 10 s; 10 kHz loaded ${hil_seconds} s)"
"$bin/hil" --rate-hz 1000,10000 --seconds "$hil_short" | tee "$out/hil_idle.md"
"$bin/hil" --rate-hz 1000 --seconds "$hil_short" --load | tee "$out/hil_load_1k.md"
"$bin/hil" --rate-hz 10000 --seconds "$hil_seconds" --load | tee "$out/hil_load_10k.md"

# The Cortex-M4F figures (deterministic instruction counts under QEMU), when the cross
# toolchain and QEMU are installed (tools/install-deps.sh cortex-m); SKIP_CORTEX_M=1 skips.
if [[ "${SKIP_CORTEX_M:-0}" != 1 ]] && command -v arm-none-eabi-g++ >/dev/null &&
   command -v qemu-system-arm >/dev/null; then
  echo "== Cortex-M4F under QEMU (tools/run-cortex-m.sh)"
  cmake --build "$build" -j2 --target indicial >>"$out/build.log" 2>&1
  INDICIAL_BUILD_DIR="$build" INDICIAL_CORTEX_M_DIR="$build/cortex-m" "$src/tools/run-cortex-m.sh" \
    >"$out/cortex-m.log" 2>&1 || { tail -30 "$out/cortex-m.log"; exit 1; }
  cp "$build/cortex-m/footprint.md" "$out/cortex-m.md"
fi

echo "load average at end: $(cut -d' ' -f1-3 /proc/loadavg)" >>"$out/machine.txt"
results="${RESULTS_MD:-$here/RESULTS.md}"
python3 "$here/make_results.py" "$out" "$results"
echo "== wrote $results"
