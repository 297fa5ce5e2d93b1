#!/bin/sh
# What a lower JPEG quality costs the light (issue 36 §1: on a narrow uplink the clients encode
# at 80, 70, 60 or 50 instead of 90). The simulated sweeps `make test` checks, at 320x240 (the size
# arlightd's frame advice asks for), encoded at each quality, captured with arlightd's settings
# and their irradiance and s = 80 maps compared with the truth's (bench/sweeps.sh). One table row
# per probe and quality.
#   bench/jpeg_quality.sh [BUILD_DIR] [OUT]   (QUALITIES="90 70 50" to choose)
set -eu
build=${1:-build}
out=${2:-out/bench/jpeg_quality}
. "$(dirname "$0")/sweeps.sh"
mkdir -p "$out"
echo "| probe | JPEG quality | kB a frame | irradiance error | s = 80 error | orientation RMS |"
echo "|---|---|---|---|---|---|"
# A row for each quality of probe $1 (seed $2, arlight-sim flags after them).
quality_rows() {
  name=$1 seed=$2
  shift 2
  for q in ${QUALITIES:-90 70 50}; do
    rec="$out/$name/q$q"
    make_sweep "$rec" "$name" "$seed" --jpeg-quality "$q" "$@"
    capture_and_diff "$rec" "$rec"
    bytes=$(du -sb "$rec/frames" | cut -f1)
    python3 - "$rec.json" "$rec-diff.json" "$name" "$q" "$bytes" <<'PY'
import json, sys
c, d = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
err = {m["shininess"]: m["mean_error"] for m in d["maps"]}
print(f"| {sys.argv[3]} | {sys.argv[4]} | {int(sys.argv[5]) / 1e3 / c['frames']:.1f} | {100 * err[1]:.2f} % | "
      f"{100 * err[80]:.2f} % | {c['orientation_rms_deg']:.3f}° |")
PY
  done
}
for_each_sweep quality_rows
