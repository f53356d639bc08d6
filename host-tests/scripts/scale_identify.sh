#!/usr/bin/env bash
# How `kinecal identify` and `kinecal diagnose` grow with the number of poses: wall
# time and peak memory of the whole process (CSV reading included), from `/usr/bin/time -v`.
#
# Usage (from anywhere):  host-tests/scripts/scale_identify.sh
# Environment: POSES (default "1000 10000 100000 1000000"), REPS (runs per row, median;
#   default 3), PARAM_POSES (poses of the parameter rows, default 10000; 0 skips them),
#   NO_BUILD=1 (use the built binary),
#   KINECAL (path of another build of the binary, e.g. of another commit),
#   UR10_DATA (default data/ur10 in the repository; the diagnose rows are skipped
#   when it is missing), DIAGNOSE_HOLDOUTS (the diagnose rows' --holdout counts, 0: none;
#   default "0 1773"; empty: no diagnose rows).
# Budgets (CI, .ci/run): IDENTIFY_MAX_MB and DIAGNOSE_MAX_MB, the most peak resident memory
#   (MB, median of the runs) any identify or diagnose row may take; the script then exits 1
#   when a row takes more, after printing every row. Times are printed, never asserted.
#
# identify: simulated UR10 (host-tests/tests/data/ur10.toml: no [base], so 33 parameters),
#   `simulate --geom-errors --noise-mm 0.01 --seed 1 --poses N`, then
#   `identify --holdout 0.2` (the last 20 % held out). The CSV is written to a temporary
#   folder and deleted after its row (1M poses: ~100 MB). Then the growth with parameters:
#   the same at PARAM_POSES poses with joint corrections added (`--effect`), 33 to ~1,200.
# diagnose: the real UR10 series (2,773 poses), all catalogue candidates (defaults), once with
#   every pose searched and once with the first 1,000 searched and 1,773 held out (the README's
#   figure).
set -euo pipefail

HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
cd "$ROOT"
TARGET=${CARGO_TARGET_DIR:-$ROOT/target}
POSES=${POSES:-"1000 10000 100000 1000000"}
REPS=${REPS:-3}
PARAM_POSES=${PARAM_POSES:-10000}
UR10_DATA=${UR10_DATA:-$ROOT/data/ur10}
DIAGNOSE_HOLDOUTS=${DIAGNOSE_HOLDOUTS-"0 1773"}
IDENTIFY_MAX_MB=${IDENTIFY_MAX_MB:-}
DIAGNOSE_MAX_MB=${DIAGNOSE_MAX_MB:-}
OVER=()

# Notes a row whose peak resident memory ($2, MB) is over the budget $3 (MB; empty: none).
budget() {
    local what=$1 peak=$2 max=$3
    [[ -n $max ]] || return 0
    if python3 -c 'import sys; sys.exit(0 if float(sys.argv[1]) <= float(sys.argv[2]) else 1)' "$peak" "$max"; then
        return 0
    fi
    OVER+=("$what: peak resident memory $(printf '%.0f' "$peak") MB, over the budget of $max MB")
}

if [[ "${NO_BUILD:-0}" != 1 ]]; then
    cargo build --release -p kinecal-cli --bin kinecal >&2
fi
K=${KINECAL:-$TARGET/release/kinecal}
[[ -x "$K" ]] || { echo "missing $K (build it or unset NO_BUILD)" >&2; exit 1; }

# GNU time: /usr/bin/time -v. Without it (and without root to install it), a Python wrapper
# reads the same figures from getrusage.
TIMEV=(/usr/bin/time -v)
if ! /usr/bin/time -v true >/dev/null 2>&1; then
    if [[ $(id -u) == 0 ]] && command -v apt-get >/dev/null; then
        (apt-get install -y time >/dev/null 2>&1 || { apt-get update >/dev/null && apt-get install -y time >/dev/null; }) >&2
    fi
    if ! /usr/bin/time -v true >/dev/null 2>&1; then
        TIMEV=(python3 -c '
import os, resource, subprocess, sys, time
t0 = time.perf_counter()
rc = subprocess.call(sys.argv[1:])
dt = time.perf_counter() - t0
ru = resource.getrusage(resource.RUSAGE_CHILDREN)
sys.stderr.write(f"\tElapsed (wall clock) time (h:mm:ss or m:ss): 0:{dt:.2f}\n")
sys.stderr.write(f"\tUser time (seconds): {ru.ru_utime:.2f}\n\tSystem time (seconds): {ru.ru_stime:.2f}\n")
sys.stderr.write(f"\tMaximum resident set size (kbytes): {ru.ru_maxrss}\n")
sys.exit(rc)')
    fi
fi

TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT

# Runs a command under time -v, REPS times; appends "wall_s cpu_s peak_MB" per run to $2
# (the command's stdout to $1; wall from the shell's clock, CPU and memory from time -v).
measure() {
    local out=$1 stats=$2 t0 t1 rc
    shift 2
    : >"$stats"
    for _ in $(seq "$REPS"); do
        t0=$EPOCHREALTIME
        rc=0
        "${TIMEV[@]}" "$@" >"$out" 2>"$TMP/time.txt" || rc=$?
        t1=$EPOCHREALTIME
        # exit 3 (not converged) still writes its JSON: report it, do not stop
        if [[ $rc != 0 && $rc != 3 ]]; then
            cat "$TMP/time.txt" >&2
            return "$rc"
        fi
        python3 - "$TMP/time.txt" "$t0" "$t1" >>"$stats" <<'EOF'
import re, sys
t = open(sys.argv[1]).read()
wall = float(sys.argv[3]) - float(sys.argv[2])
kb = int(re.search(r"Maximum resident set size \(kbytes\): (\d+)", t).group(1))
cpu = sum(float(re.search(rf"{k} time \(seconds\): (\S+)", t).group(1)) for k in ("User", "System"))
print(f"{wall:.4f} {cpu:.3f} {kb / 1024:.1f}")
EOF
    done
}

# Median over the runs in file $1: "wall cpu peak".
medians() {
    python3 -c '
import statistics, sys
rows = [list(map(float, l.split())) for l in open(sys.argv[1]) if l.strip()]
print(*(statistics.median(c) for c in zip(*rows)))' "$1"
}

echo "# kinecal identify / diagnose: time and peak memory against the number of poses"
echo "# $(date -u +%Y-%m-%dT%H:%MZ), $(nproc) cores, load average $(cut -d' ' -f1-3 /proc/loadavg)," \
    "git $(git rev-parse --short HEAD 2>/dev/null || echo '?')$(git diff --quiet HEAD -- src host-tests/src 2>/dev/null || echo ' + uncommitted changes')"
echo "# binary: $K, built $(date -u -r "$K" +%Y-%m-%dT%H:%MZ)$([[ -n "${KINECAL:-}" ]] && echo ' (KINECAL: the git line above is the tree, not this binary)'); median of $REPS runs per row"
echo
echo "| command | poses (identify / held out) | parameters | CSV MB | process wall s | process CPU s | own JSON \`seconds\` (last run) | peak RSS MB | held-out RMS mm | iterations |"
echo "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
for n in $POSES; do
    csv=$TMP/ur10_$n.csv
    "$K" simulate --robot host-tests/tests/data/ur10.toml --geom-errors --noise-mm 0.01 \
        --seed 1 --poses "$n" --out "$csv" >/dev/null 2>&1
    mb=$(python3 -c "import os, sys; print(f'{os.path.getsize(sys.argv[1]) / 1e6:.1f}')" "$csv")
    measure "$TMP/identify.json" "$TMP/stats.txt" "$K" identify --json \
        --robot host-tests/tests/data/ur10.toml --data "$csv" --holdout 0.2
    rm -f "$csv"
    read -r wall cpu peak <<<"$(medians "$TMP/stats.txt")"
    budget "identify, $n poses" "$peak" "$IDENTIFY_MAX_MB"
    python3 - "$TMP/identify.json" "$mb" "$wall" "$cpu" "$peak" <<'EOF'
import json, sys
r = json.load(open(sys.argv[1]))
mb, wall, cpu, peak = sys.argv[2:]
print(f"| identify, simulated UR10 | {r['n_identification']:,} / {r['n_validation']:,} | {len(r['changes'])} "
      f"| {mb} | {float(wall):.3g} | {float(cpu):.3g} | {r['seconds']:.3g} | {float(peak):.0f} "
      f"| {r['after']['validation_rms_mm']:.4g} | {r['iterations']} |")
EOF
done

# Parameters: the same simulated UR10 at PARAM_POSES poses, with effects added to the model
# (joint-cyclic order 1: 2 values per joint; joint-table: a knot every 3.6° over the joint range
# the data cover, ~200 per joint here).
if [[ $PARAM_POSES != 0 ]]; then
    csv=$TMP/ur10_params.csv
    "$K" simulate --robot host-tests/tests/data/ur10.toml --geom-errors --noise-mm 0.01 \
        --seed 1 --poses "$PARAM_POSES" --out "$csv" >/dev/null 2>&1
    mb=$(python3 -c "import os, sys; print(f'{os.path.getsize(sys.argv[1]) / 1e6:.1f}')" "$csv")
    for effects in "" "cyclic:1-6" "table:2" "table:2,3" "table:1-6"; do
        extra=()
        case $effects in
            cyclic:1-6) for j in 1 2 3 4 5 6; do extra+=(--effect "joint-cyclic:$j"); done ;;
            table:2) extra=(--effect joint-table:2) ;;
            table:2,3) extra=(--effect joint-table:2 --effect joint-table:3) ;;
            table:1-6) for j in 1 2 3 4 5 6; do extra+=(--effect "joint-table:$j"); done ;;
        esac
        measure "$TMP/identify.json" "$TMP/stats.txt" "$K" identify --json \
            --robot host-tests/tests/data/ur10.toml --data "$csv" --holdout 0.2 "${extra[@]}"
        read -r wall cpu peak <<<"$(medians "$TMP/stats.txt")"
        budget "identify, $PARAM_POSES poses, effects ${effects:-none}" "$peak" "$IDENTIFY_MAX_MB"
        python3 - "$TMP/identify.json" "$mb" "$wall" "$cpu" "$peak" "${effects:-none}" <<'EOF'
import json, sys
r = json.load(open(sys.argv[1]))
mb, wall, cpu, peak, effects = sys.argv[2:]
print(f"| identify, simulated UR10, effects: {effects} | {r['n_identification']:,} / {r['n_validation']:,} "
      f"| {len(r['changes'])} | {mb} | {float(wall):.3g} | {float(cpu):.3g} | {r['seconds']:.3g} "
      f"| {float(peak):.0f} | {r['after']['validation_rms_mm']:.4g} | {r['iterations']} |")
EOF
    done
    rm -f "$csv"
fi

if [[ -z $DIAGNOSE_HOLDOUTS ]]; then
    :
elif [[ -f "$UR10_DATA/ur10_random_poses.csv" ]]; then
    data=$UR10_DATA/ur10_random_poses.csv
    mb=$(python3 -c "import os, sys; print(f'{os.path.getsize(sys.argv[1]) / 1e6:.1f}')" "$data")
    rows=$(($(grep -cvE '^[[:space:]]*(#|$)' "$data") - 1))
    for holdout in $DIAGNOSE_HOLDOUTS; do
        extra=()
        [[ $holdout == 0 ]] || extra=(--holdout "$holdout")
        measure "$TMP/diagnose.json" "$TMP/stats.txt" "$K" diagnose --json \
            --robot "$UR10_DATA/robot.toml" --data "$data" "${extra[@]}"
        read -r wall cpu peak <<<"$(medians "$TMP/stats.txt")"
        budget "diagnose, UR10 series, --holdout $holdout" "$peak" "$DIAGNOSE_MAX_MB"
        python3 - "$TMP/diagnose.json" "$rows" "$holdout" "$mb" "$wall" "$cpu" "$peak" <<'EOF'
import json, sys
r = json.load(open(sys.argv[1]))
rows, holdout = int(sys.argv[2]), int(sys.argv[3])
mb, wall, cpu, peak = sys.argv[4:]
if "holdout" in r:
    rms = f"{r['holdout']['geometric_rms_mm']:.4g} → {r['holdout']['final_rms_mm']:.4g}"
else:
    rms = f"{r['baseline_validation_rms_mm']:.4g} → {r['final_validation_rms_mm']:.4g} ({r['folds']}-fold CV)"
print(f"| diagnose, real UR10 (all candidates) | {rows - holdout:,} / {holdout:,} | – | {mb} | {float(wall):.3g} "
      f"| {float(cpu):.3g} | {r['seconds']:.3g} | {float(peak):.0f} | {rms} "
      f"| {len(r['found'])} effects, {len(r['rounds'])} rounds |")
EOF
    done
else
    echo "(no $UR10_DATA/ur10_random_poses.csv: diagnose rows skipped)"
fi

if ((${#OVER[@]})); then
    printf 'OVER BUDGET: %s\n' "${OVER[@]}" >&2
    exit 1
fi
