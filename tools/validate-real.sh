#!/usr/bin/env bash
# Writes docs/validation-real.md: issue 21's study on MEASURED pitching cycles.
#   For each training choice (three cycles of one frequency sweep; three cycles across mean
#   angles) and each coefficient (CL, Cm): `indicial fit` the configured model, `indicial
#   diagnose` it (leave-one-run-out), predict every other cycle of the catalogue at its periodic
#   steady state, and count per regime (attached / light / deep stall) the cycles whose RMS is
#   at most half the quasi-steady model's; what each diagnosed effect bought on them.
# Usage: tools/validate-real.sh DIR [BUILD_DIR]
#   DIR: the development set (catalog.csv, cycles/*.dat; see its README). Nothing from DIR is
#   copied into the repository; the scratch files live in a temporary directory.
# Runs under nice (a few minutes on the shared 2-core machine). The study itself is
# tools/validate_real.py (columns are a list there: add a model column by appending to it).
set -euo pipefail
if [ $# -lt 1 ]; then
  echo "usage: tools/validate-real.sh DIR [BUILD_DIR]" >&2
  exit 2
fi
data=$(cd "$1" && pwd)
cd "$(dirname "$0")/.."
build=${2:-build}
[ -f "$data/catalog.csv" ] || { echo "tools/validate-real.sh: $data/catalog.csv: not found" >&2; exit 1; }
cmake --build "$build" --target indicial >/dev/null
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
nice -n 10 python3 tools/validate_real.py "$data" "$build/tools/indicial" "$tmp/work" "$tmp/validation-real.md"
mv "$tmp/validation-real.md" docs/validation-real.md
echo "wrote docs/validation-real.md"
