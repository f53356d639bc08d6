#!/usr/bin/env bash
# Calibration from distances alone on real data: the UR10 series in data/ur10 (a laser tracker's
# points) turned into ball-bar-like distances between pairs of its poses, and the model fitted
# to them compared with the model fitted to the tracker points of the same poses.
#
# Usage: host-tests/scripts/ur10_distances.sh
# Environment: SEED (default 1), PAIRS (identification pairs, default 3000), HELD_PAIRS (held-out
#   pairs, default 2000), POSES (identification poses, default 1500; the other poses of the
#   series are the held-out poses), NO_BUILD=1 (use target/release/kinecal as built),
#   KINECAL (path of another build), KEEP=DIR (keep the files there).
#
# The poses are shuffled with SEED; the first POSES are the identification poses, the rest the
# held-out ones. PAIRS random pairs of identification poses and HELD_PAIRS of held-out poses
# become `distance` groups (length_mm: the tracker's distance between the two points; sigma_mm
# 0.02). Then
#   identify --data distances.csv        (the constraint fit: no base, no tracker frame)
#   identify --data points.csv           (the same identification poses' tracker points)
# and `validate` of each model on the held-out distances. Printed: both models' held-out distance
# RMS and their ratio (distances / tracker). Exits 1 when a command fails.
set -euo pipefail

HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
cd "$ROOT"
SEED=${SEED:-1}
PAIRS=${PAIRS:-3000}
HELD_PAIRS=${HELD_PAIRS:-2000}
POSES=${POSES:-1500}
if [[ "${NO_BUILD:-0}" != 1 && -z "${KINECAL:-}" ]]; then
    cargo build --release -p kinecal-cli --bin kinecal >&2
fi
K=${KINECAL:-${CARGO_TARGET_DIR:-$ROOT/target}/release/kinecal}
[[ -x "$K" ]] || { echo "missing $K (build it or unset NO_BUILD)" >&2; exit 1; }
DIR=${KEEP:-$(mktemp -d)}
mkdir -p "$DIR"
[[ -n "${KEEP:-}" ]] || trap 'rm -rf "$DIR"' EXIT
ROBOT=data/ur10/robot.toml

python3 - "$DIR" "$SEED" "$PAIRS" "$HELD_PAIRS" "$POSES" <<'EOF'
import csv, math, random, sys
out, seed, pairs, held_pairs, poses = sys.argv[1], *map(int, sys.argv[2:])
with open("data/ur10/ur10_random_poses.csv", newline="") as f:
    rows = [r for r in csv.DictReader(f)]
rng = random.Random(seed)
order = list(range(len(rows)))
rng.shuffle(order)
ident, held = order[:poses], order[poses:]
if len(held) < 2:
    sys.exit(f"POSES={poses} leaves no held-out poses (the series has {len(rows)})")
q = [f"q{j}" for j in range(1, 7)]

def point(i):
    return [float(rows[i][a]) for a in "xyz"]

def distances(path, pool, n, tag):
    seen = set()
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["kind", "group", *q, "length_mm", "sigma_mm"])
        while len(seen) < n:
            a, b = rng.sample(pool, 2)
            if (a, b) in seen or (b, a) in seen:
                continue
            seen.add((a, b))
            length = math.dist(point(a), point(b))
            for i in (a, b):
                w.writerow(["distance", f"{tag}{len(seen)}", *(rows[i][c] for c in q),
                            f"{length:.5f}", "0.02"])

distances(f"{out}/distances.csv", ident, pairs, "d")
distances(f"{out}/held_distances.csv", held, held_pairs, "h")
with open(f"{out}/points.csv", "w", newline="") as f:
    w = csv.writer(f)
    w.writerow([*q, "x", "y", "z"])
    for i in ident:
        w.writerow([rows[i][c] for c in [*q, "x", "y", "z"]])
print(f"{len(ident)} identification poses ({pairs} pairs), {len(held)} held-out poses "
      f"({held_pairs} pairs), seed {seed}", file=sys.stderr)
EOF

"$K" identify --robot "$ROBOT" --data "$DIR/distances.csv" --out "$DIR/from_distances.toml" --json \
    >"$DIR/identify_distances.json"
"$K" identify --robot "$ROBOT" --data "$DIR/points.csv" --out "$DIR/from_points.toml" --json \
    >"$DIR/identify_points.json"
# validate exits 3 when a model predicts the session worse than the nominal robot: the figures
# are printed either way.
for m in distances points; do
    set +e
    "$K" validate --robot "$ROBOT" --model "$DIR/from_$m.toml" --data "$DIR/held_distances.csv" \
        --json >"$DIR/validate_$m.json"
    rc=$?
    set -e
    [[ $rc == 0 || $rc == 3 ]] || { echo "validate of the $m model failed (exit $rc)" >&2; exit 1; }
done
python3 - "$DIR" <<'EOF'
import json, sys
d = sys.argv[1]
v = {m: json.load(open(f"{d}/validate_{m}.json")) for m in ("distances", "points")}
i = json.load(open(f"{d}/identify_distances.json"))
print("| model | held-out distance RMS mm | max mm | nominal RMS mm |")
print("|---|---|---|---|")
for m, name in (("points", "tracker points of the identification poses"),
                ("distances", "distances between them")):
    r = v[m]
    print(f"| {name} | {r['model']['rms_mm']:.4f} | {r['model']['max_mm']:.4f} | {r['nominal']['rms_mm']:.4f} |")
ratio = v["distances"]["model"]["rms_mm"] / v["points"]["model"]["rms_mm"]
print(f"\nratio (distances / tracker points): {ratio:.3f}")
print(f"held by the distance fit (unidentifiable): {', '.join(i.get('unidentifiable', [])) or 'none'}")
EOF
