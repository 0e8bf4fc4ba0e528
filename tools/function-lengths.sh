#!/usr/bin/env bash
# Lists the longest functions (lines from the signature to the closing brace) of the C++ sources,
# longest first: the check behind "no function over ~120 lines" (docs/architecture.md).
#
#   tools/function-lengths.sh            # the 10 longest in fitter/ runtime/ shared/ tools/
#   tools/function-lengths.sh -n 30 tests  # the 30 longest under tests/
#
# Uses Universal Ctags (Debian package universal-ctags) for the function extents (--fields=+ne:
# start and end line), so lambdas count as part of their enclosing function.
set -euo pipefail
count=10
if [[ "${1:-}" == "-n" ]]; then count="$2"; shift 2; fi
cd "$(dirname "$0")/.."
dirs=("$@")
[[ ${#dirs[@]} -eq 0 ]] && dirs=(fitter runtime shared tools)
command -v ctags >/dev/null || { echo "function-lengths.sh: needs ctags (apt-get install universal-ctags)" >&2; exit 2; }
find "${dirs[@]}" \( -name '*.cpp' -o -name '*.hpp' -o -name '*.h' \) -print0 |
  xargs -0 ctags --fields=+ne --kinds-c++=f --language-force=c++ -o - |
  awk -F'\t' '{
      start = 0; end = 0
      for (i = 4; i <= NF; ++i) {
        if ($i ~ /^line:/) start = substr($i, 6)
        if ($i ~ /^end:/) end = substr($i, 5)
      }
      if (start > 0 && end >= start) printf "%5d  %s:%d  %s\n", end - start + 1, $2, start, $1
    }' |
  sort -k1,1nr -k2,2 | awk -v n="$count" 'NR <= n'  # not head: sort's SIGPIPE fails pipefail (exit 141)
