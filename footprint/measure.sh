#!/usr/bin/env bash
# What linking kinecal costs: builds the footprint images (one feature each; release, Cortex-M4F,
# the workspace's target dir and M4F flags) and prints the README's table of flash and RAM per
# feature; exits 1 when a feature's .text is above its budget.
#   bash footprint/measure.sh            # from the repository root
# Flash: .text (code; the budget) and .rodata (constants; the compensate image's includes the
# 2,048-byte room for the binary model). Static RAM: .data + .bss, where each image keeps the
# feature's state (robot, workspace, solver, measurements). Stack is not included (the firmware
# example measures its high-water mark).
set -euo pipefail
cd "$(dirname "$0")/.."
export CARGO_INCREMENTAL=0
cargo build -q --release -p kinecal-footprint --target thumbv7em-none-eabihf
DIR=${CARGO_TARGET_DIR:-target}/thumbv7em-none-eabihf/release
# feature budget (bytes of .text) what
FEATURES="
fk 16384 forward_kinematics:_a_6-joint_robot_built_from_rows,_the_tool_point_at_readings
compensate 32768 compensation_with_effects:_a_binary_model_decoded_(every_effect_kind,_couplings),_the_joint_command_for_a_target
identify 65536 identification:_the_LM_stepper_over_24_MDH_parameters_and_50_poses,_in_slices
"
echo "| image | what | .text (flash) | budget | .rodata | static RAM (.data + .bss) | status |"
echo "|---|---|---:|---:|---:|---:|---|"
fail=0
while read -r name budget what; do
  [ -n "$name" ] || continue
  read -r text rodata ram < <(arm-none-eabi-size -A "$DIR/$name" | awk '
    $1 == ".text" { t = $2 } $1 == ".rodata" { r = $2 }
    $1 == ".data" || $1 == ".bss" || $1 == ".uninit" { m += $2 }
    END { print t + 0, r + 0, m + 0 }')
  status=ok
  [ "$text" -le "$budget" ] || { status="OVER BUDGET"; fail=1; }
  printf '| `%s` | %s | %s | %s | %s | %s | %s |\n' "$name" "${what//_/ }" "$text" "$budget" "$rodata" "$ram" "$status"
done <<<"$FEATURES"
exit "$fail"
