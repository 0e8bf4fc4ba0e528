#!/bin/sh
# Held-out validation of the dynamic-stall families on the Glasgow NACA 0012 development set
# (issue 22): tools/validate-stall.sh DATA_DIR [INDICIAL] > docs/validation-stall.md
# Slow (minutes: several fits over ~100 measured cycles); run it niced. See validate_stall.py.
set -eu
here=$(dirname "$0")
exec nice -n 10 python3 "$here/validate_stall.py" "$@"
