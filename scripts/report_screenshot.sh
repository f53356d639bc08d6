#!/usr/bin/env bash
# The calibration report of the UR10 series (data/ur10: first 1,000 poses identify,
# the 1,773 others held out) rendered in headless Chromium: a desktop screenshot, a phone-width
# screenshot and an A4 PDF (its first page as PNG when pdftoppm is installed).
#
#   scripts/report_screenshot.sh [OUT_DIR]        (default: out/report)
#
# KINECAL=path/to/kinecal uses that binary (default: builds target/release/kinecal).
# UR10_DIR=… points at the data (default: data/ur10 in the repository).
# Needs `chromium` (Debian: apt-get install chromium); exits 0 with a message when absent.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-out/report}
mkdir -p "$out"
ur10=${UR10_DIR:-data/ur10}
if [ ! -f "$ur10/ur10_random_poses.csv" ]; then
  echo "report_screenshot: no UR10 data at $ur10 (set UR10_DIR)" >&2
  exit 1
fi
if [ -z "${KINECAL:-}" ]; then
  cargo build --release --bin kinecal >&2
  KINECAL=target/release/kinecal
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

"$KINECAL" identify --robot "$ur10/robot.toml" --data "$ur10/ur10_random_poses.csv" \
  --holdout 1773 --out "$out/ur10_model.toml" --json > "$out/ur10_identify.json"
start=$(date +%s.%N)
"$KINECAL" report --robot "$ur10/robot.toml" --model "$out/ur10_model.toml" \
  --data "$ur10/ur10_random_poses.csv" --holdout 1773 --out "$out/ur10_report.html" --json \
  > "$out/ur10_report.json"
end=$(date +%s.%N)
echo "report: $(wc -c < "$out/ur10_report.html") bytes, $(echo "$end - $start" | bc) s" >&2

if ! command -v chromium > /dev/null; then
  echo "report_screenshot: chromium is not installed: browser step skipped (apt-get install chromium)" >&2
  exit 0
fi
page="file://$(realpath "$out/ur10_report.html")"
shot() { # shot WIDTH HEIGHT FILE [extra flags…]
  local w=$1 h=$2 file=$3
  shift 3
  chromium --headless --no-sandbox --disable-gpu --disable-quic --no-first-run \
    --disable-background-networking --disable-component-update --disable-sync \
    --hide-scrollbars --user-data-dir="$(mktemp -d -p "$work")" \
    --window-size="$w,$h" "$@" --screenshot="$file" "$page" 2> "$work/chromium.log" \
    || { cat "$work/chromium.log" >&2; return 1; }
  test -s "$file"
}
shot 1000 2100 "$out/report_desktop.png"
shot 390 1600 "$out/report_phone.png" --force-device-scale-factor=1
chromium --headless --no-sandbox --disable-gpu --disable-quic --no-first-run \
  --disable-background-networking --disable-component-update --disable-sync \
  --user-data-dir="$(mktemp -d -p "$work")" --no-pdf-header-footer \
  --print-to-pdf="$out/report_a4.pdf" "$page" 2> "$work/chromium.log" \
  || { cat "$work/chromium.log" >&2; exit 1; }
test -s "$out/report_a4.pdf"
if command -v pdfinfo > /dev/null; then
  pages=$(pdfinfo "$out/report_a4.pdf" | awk '/^Pages:/ {print $2}')
  size=$(pdfinfo "$out/report_a4.pdf" | awk -F': *' '/^Page size:/ {print $2}')
  echo "A4 PDF: $pages pages, $size" >&2
  case "$size" in
    *"595.92 x 842.88"*|*"595 x 842"*|*"595.28 x 841.89"*|*A4*) ;;
    *) echo "report_screenshot: the PDF page is not A4: $size" >&2; exit 1 ;;
  esac
fi
if command -v pdftoppm > /dev/null; then
  pdftoppm -png -r 60 -f 1 -l 1 -singlefile "$out/report_a4.pdf" "$out/report_a4_page1"
fi
ls -l "$out" >&2
