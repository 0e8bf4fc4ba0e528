#!/usr/bin/env bash
# Builds the libFuzzer targets of tests/fuzz/ with clang in build-fuzz/ and runs each for a
# bounded time. Fails on any crash, hang, sanitizer report (ASan, UBSan), leak, out-of-memory
# or property violation (each target aborts when a parser accepts something it must refuse).
#
#   tools/run-fuzz.sh                         # every target, 60 s each
#   INDICIAL_FUZZ_SECONDS=10 tools/run-fuzz.sh fuzz_coef_file
#
# Environment: INDICIAL_FUZZ_SECONDS (per target, default 60), INDICIAL_FUZZ_BUILD_DIR
# (default build-fuzz), INDICIAL_JOBS (build parallelism, default nproc).
# The seed corpora in tests/fuzz/corpus/<target>/ are read, never written: new inputs go to
# <build dir>/corpus/<target>/, and a failing input is saved as
# <build dir>/artifacts/<target>-crash-* (or leak-*, timeout-*, oom-*); reproduce it with
#   build-fuzz/<target> build-fuzz/artifacts/<target>-crash-...
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir=${INDICIAL_FUZZ_BUILD_DIR:-build-fuzz}
seconds=${INDICIAL_FUZZ_SECONDS:-60}
jobs=${INDICIAL_JOBS:-$(nproc)}
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(fuzz_coef_file fuzz_run_csv fuzz_experiment)

# clang 14 with libFuzzer: the fuzz extra of tools/install-deps.sh (installed only if missing).
tools/install-deps.sh fuzz
command -v clang++ >/dev/null || { echo "run-fuzz: clang++ not found (tools/install-deps.sh fuzz)" >&2; exit 2; }
start=$(date +%s)
cmake -S tests/fuzz -B "$build_dir" -G Ninja -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_BUILD_TYPE=None
cmake --build "$build_dir" -j"$jobs" --target "${targets[@]}"
built=$(date +%s)

mkdir -p "$build_dir/artifacts"
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1:strict_string_checks=1:detect_stack_use_after_return=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
failed=()
for t in "${targets[@]}"; do
  work="$build_dir/corpus/$t"
  mkdir -p "$work"
  dict=()
  [ -f "tests/fuzz/$t.dict" ] && dict=(-dict="tests/fuzz/$t.dict")
  echo "=== $t: ${seconds} s"
  # -timeout: one input taking over 10 s is a hang; -max_len keeps inputs file-sized;
  # -rss_limit_mb: a parser that needs 2 GB for a 4 KB input is a bug too.
  if ! "$build_dir/$t" "${dict[@]}" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 \
      -max_len=4096 -detect_leaks=1 -print_final_stats=1 \
      -artifact_prefix="$build_dir/artifacts/$t-" "$work" "tests/fuzz/corpus/$t" \
      > "$build_dir/$t.log" 2>&1; then
    failed+=("$t")
    echo "--- $t FAILED; last lines of $build_dir/$t.log:"
    tail -n 60 "$build_dir/$t.log"
  else
    grep -E "^stat::number_of_executed_units|^Done " "$build_dir/$t.log" || true
  fi
done
done_s=$(date +%s)
echo "run-fuzz: build $((built - start)) s, fuzzing $((done_s - built)) s"
if [ ${#failed[@]} -gt 0 ]; then
  echo "run-fuzz: FAILED: ${failed[*]} (inputs in $build_dir/artifacts/)" >&2
  exit 1
fi
echo "run-fuzz: all targets clean"
