#!/usr/bin/env bash
# Benchmark (not a test), issue 21 item 6: `indicial diagnose` with leave-one-run-out on a
# three-cycle experiment, wall time, median of 3, with --threads 1 and --threads 2 in one run.
# The experiment: the three fit cycles of `indicial simulate --case dynamic-stall` (128-sample
# ensemble-averaged cycles, CL and Cm: the shape of a measured sweep; anyone can regenerate it)
# and, when DIR is given, three measured cycles of the Glasgow set (a frequency sweep: mean 15,
# amplitude 10 deg, k = 0.05, 0.10, 0.15; the static table from the set's quasi-static cycles).
# Usage: bench/diagnose-cv.sh [BUILD_DIR] [DIR]   Writes bench/diagnose-cv.md.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
data=${2:-}
# Absolute: the experiment files name the runs from $tmp (a relative DIR would not resolve there).
[ -z "$data" ] || data=$(cd "$data" && pwd)
exe="$build/tools/indicial"
cmake --build "$build" --target indicial >/dev/null
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
"$exe" simulate --case dynamic-stall --snr 20 --out "$tmp/ds" >/dev/null 2>&1
cases=("$tmp/ds/experiment-CL.toml" "$tmp/ds/experiment-Cm.toml")
labels=("simulated dynamic stall, CL" "simulated dynamic stall, Cm")
if [ -n "$data" ]; then
  v=40.2
  # The static table as tools/validate-stall.sh makes it (the quasi-static k = 0.010 cycles'
  # upstrokes in 1-deg bins), rewritten in the runs' dialect ([csv] is one for every file).
  # With a thin-airfoil polynomial instead the fit error is 0.8 and diagnose stops at once
  # (0.2 s, verdict none): a time that says nothing about a measured experiment.
  python3 tools/validate_stall.py --static-polar "$data" "$tmp/static.csv"
  { echo "% alpha_deg CL Cm"; tail -n +2 "$tmp/static.csv" | tr ',' ' '; } > "$tmp/static.dat"
  for coef in CL Cm; do
    cat > "$tmp/real-$coef.toml" <<TOML
axis = "pitch"
coefficient = "$coef"
reference_length_m = 0.275
airspeed_mps = $v
runs = [{file = "$data/cycles/11012432_coeffs.dat", frequency_hz = 1.165, airspeed_mps = 40.545},
        {file = "$data/cycles/11012702_coeffs.dat", frequency_hz = 2.33, airspeed_mps = 40.067},
        {file = "$data/cycles/11012802_coeffs.dat", frequency_hz = 3.496, airspeed_mps = 39.886}]
[columns]
phase_rad = "Time()"
alpha_deg = "Angle(deg)"
Cnormal = "Cn"
Ctangential = "Ct"
[csv]
delimiter = "whitespace"
comment = "%"
[static]
table = "$tmp/static.dat"
[rotary]
polynomial = [0]
estimate = false
[model]
a_degree = 2
a_knots_deg = [10, 15, 20]
b1_degree = 0
TOML
    cases+=("$tmp/real-$coef.toml")
    labels+=("measured sweep (Glasgow, mean 15, amplitude 10), $coef")
  done
fi
median() { sort -g | awk '{a[NR]=$1} END{print a[int((NR+1)/2)]}'; }
# The machine's speed in the same run: the report's model step (bench_step, one thread), when
# the benchmarks are built (tools/install-deps.sh bench). Why: this VM's speed has varied
# threefold between days at the same code (bench/diagnose-cv.md); a row is comparable with
# another run's only beside this figure.
# Built here like the CLI, so that the reference is this commit's step (no target when the
# benchmarks are not configured: then "not measured").
if cmake --build "$build" --target help 2>/dev/null | grep -q '^bench_step\b'; then
  cmake --build "$build" --target bench_step >/dev/null
fi
reference() {
  local b="$build/bench/bench_step"
  [ -x "$b" ] || { echo "not measured (bench_step not built)"; return; }
  "$b" --benchmark_filter='^state/model2/double$' --benchmark_repetitions=5 \
       --benchmark_report_aggregates_only=true --benchmark_format=json 2>/dev/null |
    python3 -c "import json,sys; d=json.load(sys.stdin); print('%.1f ns' % next(b['real_time'] for b in d['benchmarks'] if b.get('aggregate_name') == 'median'))"
}
ref_start=$(reference)
{
  echo "# diagnose with leave-one-run-out on a three-cycle experiment (issue 21, item 6)"
  echo
  echo "Written by \`bench/diagnose-cv.sh\` at commit $(git rev-parse --short HEAD), $(date -u +%Y-%m-%dT%H:%MZ),"
  echo "load average $(cut -d' ' -f1-3 /proc/loadavg) at the start (shared 2-core machine). Wall time of"
  echo "\`indicial diagnose E --out D --no-plots\`, median of 3; target <= 10 s with 2 threads."
  echo "Machine reference (bench_step \`state/model2/double\`, median of 5, one thread): $ref_start before the"
  echo "table, REF_END after it."
  echo
  echo "| experiment | threads | wall (s), median of 3 | verdict | fits |"
  echo "|---|---|---|---|---|"
  for i in "${!cases[@]}"; do
    for th in 1 2; do
      times=()
      for rep in 1 2 3; do
        rm -rf "$tmp/out"
        s=$(date +%s.%N)
        rc=0
        "$exe" diagnose "${cases[$i]}" --out "$tmp/out" --force --no-plots --quiet --threads "$th" >"$tmp/log" 2>&1 || rc=$?
        # 6: stopped at --max-steps with an effect still significant (a complete output).
        if [ "$rc" -ne 0 ] && [ "$rc" -ne 6 ]; then
          echo "bench/diagnose-cv.sh: diagnose exited $rc on ${labels[$i]}:" >&2
          cat "$tmp/log" >&2
          exit 1
        fi
        e=$(date +%s.%N)
        times+=("$(echo "$e - $s" | bc)")
      done
      med=$(printf '%s\n' "${times[@]}" | median)
      info=$(python3 -c "import json;d=json.load(open('$tmp/out/diagnosis.json'));print(d['verdict'],'|',d['fits_run'])")
      printf '| %s | %s | %.2f | %s |\n' "${labels[$i]}" "$th" "$med" "$info"
    done
  done
  echo
  echo "Load average at the end: $(cut -d' ' -f1-3 /proc/loadavg)."
} > "$tmp/diagnose-cv.md"
ref_end=$(reference)
sed -i "s/REF_END/$ref_end/" "$tmp/diagnose-cv.md"
mv "$tmp/diagnose-cv.md" bench/diagnose-cv.md
cat bench/diagnose-cv.md
