#!/bin/bash
# Times `diagnose` on the real UR10 series C (2,773 poses, all candidates) with two or more
# `kinecal` builds, run alternately so that the machine's changing speed hits them alike, and
# prints per build the median and the least of its JSON `seconds` and the median CPU time.
#
#     host-tests/scripts/diagnose_ab.sh RUNS OLD_KINECAL NEW_KINECAL [MORE…]
#
# e.g. an older commit built with `git worktree add /tmp/old <commit>` and
# `CARGO_TARGET_DIR=/tmp/old_target cargo build --release -p kinecal-cli` there, against
# target/release/kinecal. The builds take turns starting each round. Needs python3 and GNU time
# (/usr/bin/time).
set -uo pipefail
if [ $# -lt 3 ]; then
    echo "usage: $0 RUNS KINECAL KINECAL [KINECAL…]" >&2
    exit 2
fi
runs=$1
shift
here=$(cd "$(dirname "$0")/../.." && pwd)
log=$(mktemp)
out=$(mktemp)
times=$(mktemp)
trap 'rm -f "$log" "$out" "$times"' EXIT
bins=("$@")
for round in $(seq "$runs"); do
    # Rotate the order every round, so that no build always runs first.
    k=$(( (round - 1) % ${#bins[@]} ))
    for bin in "${bins[@]:k}" "${bins[@]:0:k}"; do
        /usr/bin/time -o "$times" -f "%U %S" "$bin" diagnose --robot "$here/data/ur10/robot.toml" \
            --data "$here/data/ur10/ur10_random_poses.csv" --json > "$out" 2> /dev/null
        status=$?
        # 0, or 3 (a result judged no calibration): both print the report.
        if [ "$status" != 0 ] && [ "$status" != 3 ]; then
            echo "$bin: diagnose exited with $status" >&2
            exit 1
        fi
        cpu=$(grep -v "status" "$times" | tail -1 | awk '{print $1 + $2}')
        seconds=$(python3 -c "import json, sys; print(json.load(open(sys.argv[1]))['seconds'])" "$out")
        printf '%s\t%s\t%s\n' "$bin" "$seconds" "$cpu" >> "$log"
    done
done
python3 - "$log" <<'PY'
import statistics, sys
runs = {}
for line in open(sys.argv[1]):
    b, s, c = line.rstrip("\n").split("\t")
    runs.setdefault(b, []).append((float(s), float(c)))
for b, v in runs.items():
    s = [x[0] for x in v]
    print(f"{b}: seconds median {statistics.median(s):.3f}, least {min(s):.3f}; "
          f"CPU median {statistics.median(x[1] for x in v):.2f} s ({len(v)} runs)")
PY
