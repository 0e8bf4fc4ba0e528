#!/usr/bin/env bash
# The report's prediction study (figures 11-16) on the F-16XL-like cases, with the CLI only:
# simulate the four 35 deg-amplitude oscillations, fit, then predict motions the fit never saw
# (20 deg-amplitude oscillations, ramps at 15 and 60 deg/s) and score them.
# The static curves of these cases are ASSUMED, not measured (docs/validation-prediction.md).
#
#   examples/f16xl-prediction.sh [INDICIAL_EXE] [OUT_DIR]
set -euo pipefail
I=${1:-build/tools/indicial}
OUT=${2:-f16xl-prediction}
mkdir -p "$OUT"
for C in CL Cm; do
  D="$OUT/$C"
  "$I" simulate --case "f16xl-like-$C" --out "$D/data" --snr 20 --seed 5 --force
  "$I" fit "$D/data/experiment.toml" --out "$D/fit" --force > "$D/fit.log"
  for M in "sine20_f0.42:sine:alpha0_deg=35,amp_deg=20,freq_hz=0.42,cycles=3,dt_s=0.01" \
           "sine20_f1.00:sine:alpha0_deg=35,amp_deg=20,freq_hz=1.0,cycles=3,dt_s=0.01" \
           "ramp15:ramp:from_deg=0,to_deg=60,rate_dps=15,dt_s=0.01" \
           "ramp60:ramp:from_deg=0,to_deg=60,rate_dps=60,dt_s=0.01"; do
    NAME=${M%%:*}
    SPEC=${M#*:}
    # Held-out "measurements": the TRUE model on the new motion, plus noise.
    "$I" simulate --model "$D/data/truth.coef" --motion "$SPEC" --out "$D/$NAME.csv" --snr 20 --seed 9 --force > /dev/null
    echo "== $C $NAME"
    "$I" predict "$D/fit/model.coef" "$D/$NAME.csv" --out "$D/pred_$NAME.csv" --plot "$D/pred_$NAME.png" --force |
      grep -E "model|quasi"
  done
done
