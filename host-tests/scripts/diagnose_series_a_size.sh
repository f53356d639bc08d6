#!/usr/bin/env bash
# `kinecal diagnose` at the size of the UR10 series A (11,911 poses), which is not in this
# repository: a simulated UR10 session of that size with geometric errors, 0.03 mm noise and
# joint tables on joints 1–5 (12, 18, 18, 30 and 12 knots over each joint's range, values
# ±0.4 mrad from a fixed formula), then the whole search with every candidate. Prints the
# wall time, the peak memory and the summary; asserts nothing (timing lives here, not in tests).
#
# Usage (from anywhere):  host-tests/scripts/diagnose_series_a_size.sh
# Environment: NO_BUILD=1 (use the built binary), KINECAL (path of another build), POSES
#   (default 11911), REPS (runs, default 1).
set -euo pipefail

HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
cd "$ROOT"
POSES=${POSES:-11911}
REPS=${REPS:-1}
if [[ -z ${KINECAL:-} ]]; then
    [[ -n ${NO_BUILD:-} ]] || cargo build --release -q -p kinecal-cli
    KINECAL=${CARGO_TARGET_DIR:-$ROOT/target}/release/kinecal
fi
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT

# Knot values of joint $1's table with $2 knots: 0.4 mrad · sin(1.7 k + j) (rad).
knots() {
    awk -v j="$1" -v n="$2" 'BEGIN { for (k = 0; k < n; k++) printf "%s%.6f", (k ? "," : ""), 4e-4 * sin(1.7 * k + j) }'
}
EFFECTS=()
for spec in 1:12 2:18 3:18 4:30 5:12; do
    EFFECTS+=(--effect "joint-table:${spec%%:*}:$(knots "${spec%%:*}" "${spec##*:}")")
done
"$KINECAL" simulate --robot data/ur10/robot.toml --poses "$POSES" --noise-mm 0.03 --seed 4 \
    --geom-errors "${EFFECTS[@]}" --out "$TMP/session.csv" > /dev/null 2>&1
for _ in $(seq "$REPS"); do
    /usr/bin/time -f "%e s wall, %M KB peak" "$KINECAL" diagnose --robot data/ur10/robot.toml \
        --data "$TMP/session.csv" --json 2> "$TMP/time" > "$TMP/out.json"
    python3 -c 'import json,sys; d=json.load(open(sys.argv[1])); print(d["summary"]); print([(f["effect"], f["joint"], f.get("knots")) for f in d["found"]])' "$TMP/out.json"
    tail -1 "$TMP/time"
done
