#!/bin/sh
# What a lower JPEG quality costs the light (issue 36 §1: on a narrow uplink the clients encode
# at 80, 70, 60 or 50 instead of 90). The simulated sweeps `make test` checks (240 frames,
# 320x240: the size arlightd's frame advice asks for, 0.5 deg/s gyro drift) encoded at each
# quality, captured with arlightd's settings (cube face 192, alignment every 4th frame at 160 px,
# in the background), and the irradiance and s = 80 maps compared with the truth's
# (`arlight-maps diff`, auto method, 128). One table row per probe and quality.
#   bench/jpeg_quality.sh [BUILD_DIR] [OUT]   (QUALITIES="90 70 50" to choose)
set -eu
build=${1:-build}
out=${2:-out/bench/jpeg_quality}
mkdir -p "$out"
echo "| probe | JPEG quality | kB a frame | irradiance error | s = 80 error | orientation RMS |"
echo "|---|---|---|---|---|---|"
for spec in venice:1: city:3: "lab:4:--hdr-stops 5"; do
  name=${spec%%:*}
  rest=${spec#*:}
  seed=${rest%%:*}
  extra=${rest#*:}
  for q in ${QUALITIES:-90 70 50}; do
    rec="$out/$name/q$q"
    [ -d "$rec" ] || "$build/bin/arlight-sim" --env "data/probes/$name.exr" --out "$rec" \
      --frames 240 --size 320x240 --gyro-drift 0.5 --seed "$seed" --jpeg-quality "$q" $extra \
      > /dev/null 2>&1
    "$build/bin/arlight-capture" --recording "$rec" --projection cube --size 192 --align-async \
      --align-every 4 --align-width 160 --out "$rec.exr" --json "$rec.json" > /dev/null
    "$build/bin/arlight-maps" diff --reference "$rec/truth/env.exr" --test "$rec.exr" \
      --method auto --size 128 --json "$rec-diff.json" > /dev/null
    bytes=$(du -sb "$rec/frames" | cut -f1)
    python3 - "$rec.json" "$rec-diff.json" "$name" "$q" "$bytes" <<'PY'
import json, sys
c, d = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
err = {m["shininess"]: m["mean_error"] for m in d["maps"]}
print(f"| {sys.argv[3]} | {sys.argv[4]} | {int(sys.argv[5]) / 1e3 / c['frames']:.1f} | {100 * err[1]:.2f} % | "
      f"{100 * err[80]:.2f} % | {c['orientation_rms_deg']:.3f}° |")
PY
  done
done
