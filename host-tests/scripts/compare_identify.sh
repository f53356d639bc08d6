#!/usr/bin/env bash
# Identification speed and accuracy side by side, in one run, on the same files:
#   kinecal identify --json (its own `seconds`, and the wall-clock of the whole process),
#   scipy's MINPACK (host-tests/scripts/scipy_lm.py),
#   the levenberg-marquardt crate with an analytic Jacobian, kinecal's fit_lm and its bare solver
#   (host-tests/examples/lm_compare.rs, solve only).
#
# Usage (from anywhere):  host-tests/scripts/compare_identify.sh
# Environment: REPS (process runs of identify and scipy, default 5), LMC_REPS (timed solves
#   inside lm_compare, default 21), KINECAL_VENV (venv made when numpy/scipy are missing,
#   default target/scipy-venv), NO_BUILD=1 (use the binaries already built), KINECAL and
#   LM_COMPARE (paths of other builds of the two programs, e.g. of another commit).
#
# Data: ER20-C10 stand-in (host-tests/tests/data/er20.toml) with `simulate --geom-errors`,
# 50 identification poses (seed 7) and 50 held-out poses of the same true robot (seed 8),
# 10 µm noise. Two parameter sets, both on these files:
#   27 = the robot file as given (its [base] is known): alpha, a, theta, d per joint + tool,
#        the set scipy_lm.py fits: all methods solve the same problem;
#   33 = the same file without [base]: the base pose is estimated too (identify registers it
#        before its clock starts; lm_compare starts every solver from that registered base).
#        scipy_lm.py cannot estimate a base: it fits its 27 parameters with the base known
#        (identity, the truth here), a smaller and easier problem.
set -euo pipefail

HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
cd "$ROOT"
REPS=${REPS:-5}
LMC_REPS=${LMC_REPS:-21}
TARGET=${CARGO_TARGET_DIR:-$ROOT/target}
VENV=${KINECAL_VENV:-$TARGET/scipy-venv}

if [[ "${NO_BUILD:-0}" != 1 ]]; then
    cargo build --release -p kinecal-cli --bin kinecal >&2
    cargo build --release -p kinecal-host --features lm-compare --example lm_compare >&2
fi
K=${KINECAL:-$TARGET/release/kinecal}
LMC=${LM_COMPARE:-$TARGET/release/examples/lm_compare}
for b in "$K" "$LMC"; do
    [[ -x "$b" ]] || { echo "missing $b (build it or unset NO_BUILD)" >&2; exit 1; }
done

# A Python with numpy and scipy: this one, or a venv made once.
PY=python3
if ! "$PY" -c 'import numpy, scipy' 2>/dev/null; then
    if ! "$VENV/bin/python" -c 'import numpy, scipy' 2>/dev/null; then
        echo "numpy/scipy missing: creating $VENV" >&2
        python3 -m venv "$VENV"
        "$VENV/bin/pip" install --quiet numpy scipy >&2
    fi
    PY=$VENV/bin/python
fi

TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT

ER20=host-tests/tests/data/er20.toml
"$K" simulate --robot "$ER20" --geom-errors --poses 50 --noise-mm 0.01 --seed 7 \
    --out "$TMP/ident.csv" --truth "$TMP/truth.toml" >/dev/null
"$K" simulate --robot "$TMP/truth.toml" --poses 50 --noise-mm 0.01 --seed 8 \
    --out "$TMP/valid.csv" >/dev/null
cp "$ER20" "$TMP/er20_27.toml"
# The same robot without its [base] table (the last table of the file).
awk '/^\[base\]/ {skip = 1; next} /^\[/ {skip = 0} !skip' "$ER20" >"$TMP/er20_33.toml"

# Wall-clock seconds of a command (stdout to $1).
wall() {
    local out=$1 t0 t1
    shift
    t0=$EPOCHREALTIME
    "$@" >"$out"
    t1=$EPOCHREALTIME
    python3 -c "print($t1 - $t0)"
}

for set in 27 33; do
    robot=$TMP/er20_$set.toml
    for r in $(seq "$REPS"); do
        w=$(wall "$TMP/identify_${set}_$r.json" "$K" identify --json --robot "$robot" \
            --data "$TMP/ident.csv" --validate "$TMP/valid.csv")
        echo "$w" >"$TMP/identify_${set}_$r.wall"
        # The floor of any process: start, argument parsing, exit.
        wall "$TMP/version.txt" "$K" --version >"$TMP/startup_${set}_$r.wall"
        "$PY" host-tests/scripts/scipy_lm.py "$robot" "$TMP/ident.csv" "$TMP/valid.csv" \
            >"$TMP/scipy_${set}_$r.json"
    done
    "$LMC" --robot "$robot" --data "$TMP/ident.csv" --validate "$TMP/valid.csv" \
        --reps "$LMC_REPS" >"$TMP/lmc_$set.json"
done

echo "# kinecal identify vs scipy MINPACK vs the levenberg-marquardt crate"
echo "# $(date -u +%Y-%m-%dT%H:%MZ), $(nproc) cores, load average $(cut -d' ' -f1-3 /proc/loadavg)," \
    "git $(git rev-parse --short HEAD 2>/dev/null || echo '?')$(git diff --quiet HEAD -- src host-tests/src 2>/dev/null || echo ' + uncommitted changes')"
echo "# binaries: $K (built $(date -u -r "$K" +%Y-%m-%dT%H:%MZ)), $LMC (built $(date -u -r "$LMC" +%Y-%m-%dT%H:%MZ))$([[ -n "${KINECAL:-}${LM_COMPARE:-}" ]] && echo '; given by KINECAL/LM_COMPARE: the git line above is the tree, not these binaries')"
echo "# ER20 stand-in, simulate --geom-errors, 50 + 50 poses (seeds 7/8), 10 µm noise;" \
    "median of $REPS process runs (identify, scipy) and of $LMC_REPS solves (lm_compare)"
python3 - "$TMP" "$REPS" <<'EOF'
import json, statistics, sys
tmp, reps = sys.argv[1], int(sys.argv[2])
med = statistics.median

def load(p):
    with open(p) as f:
        return json.load(f)

checks = []
for pset in ("27", "33"):
    ident = [load(f"{tmp}/identify_{pset}_{r}.json") for r in range(1, reps + 1)]
    walls = [float(open(f"{tmp}/identify_{pset}_{r}.wall").read()) for r in range(1, reps + 1)]
    startup = med(float(open(f"{tmp}/startup_{pset}_{r}.wall").read()) for r in range(1, reps + 1))
    scipy = [load(f"{tmp}/scipy_{pset}_{r}.json") for r in range(1, reps + 1)]
    lmc = load(f"{tmp}/lmc_{pset}.json")
    k = med(i["seconds"] for i in ident)
    rms_k = ident[0]["after"]["validation_rms_mm"]
    rows = [
        ("kinecal identify (JSON `seconds`)", lmc["n_parameters"], rms_k, ident[0]["iterations"], k),
        ("kinecal identify, whole process (wall)", lmc["n_parameters"], rms_k, ident[0]["iterations"], med(walls)),
        ("(process start-up floor: `kinecal --version`, wall)", "–", None, "–", startup),
    ]
    names = {
        "levenberg-marquardt": "levenberg-marquardt crate, analytic Jacobian",
        "fit_lm": "kinecal_cli::calibration::fit_lm",
        "Levenberg::run": "kinecal::lm::Levenberg::run (library solve)",
    }
    lib = None
    crate = None
    for m in lmc["methods"]:
        name = next(v for key, v in names.items() if key in m["method"])
        rows.append((name, lmc["n_parameters"], m["validation_rms_mm"], m["iterations"], m["seconds_median"]))
        if "Levenberg::run" in m["method"]:
            lib = m["seconds_median"]
        if "levenberg-marquardt" in m["method"]:
            crate = m["seconds_median"]
    s = med(x["seconds"] for x in scipy)
    rows.append(("scipy least_squares(method='lm') (MINPACK)", 27, scipy[0]["validation_rms_mm"],
                 f"{scipy[0]['nfev']} fev", s))
    base = "[base] in the file" if pset == "27" else "no [base]: base estimated (scipy: base known)"
    print(f"\n## {pset} parameters ({base}); start held-out RMS {lmc['start_validation_rms_mm']:.4g} mm\n")
    print("| method | parameters | held-out RMS (mm) | iterations | solve seconds (median) | ÷ kinecal identify `seconds` |")
    print("|---|---:|---:|---:|---:|---:|")
    for name, n, rms, it, sec in rows:
        rms = "–" if rms is None else f"{rms:.5f}"
        print(f"| {name} | {n} | {rms} | {it} | {sec:.3g} | {sec / k:.3g} |")
    spread = lambda xs: f"{min(xs):.3g}–{max(xs):.3g}"
    print(f"\nspread over the {reps} runs: identify `seconds` {spread([i['seconds'] for i in ident])}, "
          f"wall {spread(walls)}, scipy {spread([x['seconds'] for x in scipy])}; "
          f"crate Jacobian check (max rel. error vs central differences) {lmc['jacobian_check_max_rel_error']:.1e}")
    checks.append((pset, s / k, crate / k, med(walls) / lib, (med(walls) - startup) / lib))

print("\n## Targets (50 poses)\n")
print("| parameters | scipy ÷ identify (target ≥ 300) | crate ÷ identify (target ≥ 3) "
      "| identify wall ÷ library solve (target ≤ 3) | (wall − start-up floor) ÷ library solve |")
print("|---:|---:|---:|---:|---:|")
for pset, a, b, c, d in checks:
    print(f"| {pset} | {a:.3g} | {b:.3g} | {c:.3g} | {d:.3g} |")
print("\n(identify's `seconds` is one solve in a fresh process; the lm_compare rows are the median of"
      " warm repeated solves: the same fit_lm is faster there.)")
EOF
