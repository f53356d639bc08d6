#!/bin/bash
# Times `diagnose` on the real UR10 series C (2,773 poses, all candidates) with two or more
# `kinecal` builds, run alternately so that the machine's changing speed hits them alike, and
# prints per build the median and the least of its JSON `seconds` and the median CPU time.
#
#     host-tests/scripts/diagnose_ab.sh RUNS OLD_KINECAL NEW_KINECAL [MORE…]
#
# e.g. an older commit built with `git worktree add /tmp/old <commit>` and
# `CARGO_TARGET_DIR=/tmp/old_target cargo build --release -p kinecal-cli` there, against
# target/release/kinecal. Needs python3; the CPU time needs GNU time (/usr/bin/time).
set -euo pipefail
runs=$1
shift
here=$(cd "$(dirname "$0")/../.." && pwd)
log=$(mktemp)
out=$(mktemp)
times=$(mktemp)
trap 'rm -f "$log" "$out" "$times"' EXIT
for _ in $(seq "$runs"); do
    for bin in "$@"; do
        /usr/bin/time -o "$times" -f "%U %S" "$bin" diagnose --robot "$here/data/ur10/robot.toml" \
            --data "$here/data/ur10/ur10_random_poses.csv" --json > "$out" 2> /dev/null
        cpu=$(tail -1 "$times" | awk '{print $1 + $2}')
        seconds=$(python3 -c "import json, sys; print(json.load(open(sys.argv[1]))['seconds'])" "$out")
        echo "$bin $seconds $cpu" >> "$log"
    done
done
python3 - "$log" <<'PY'
import statistics, sys
runs = {}
for line in open(sys.argv[1]):
    b, s, c = line.split()
    runs.setdefault(b, []).append((float(s), float(c)))
for b, v in runs.items():
    s = [x[0] for x in v]
    print(f"{b}: seconds median {statistics.median(s):.3f}, least {min(s):.3f}; "
          f"CPU median {statistics.median(x[1] for x in v):.2f} s ({len(v)} runs)")
PY
