#!/bin/sh
# Frames that add nothing (issue 37 §1): the accuracy and cost of arlight-capture's two ways of
# merging frames in one run, on the simulated sweeps `make test` checks (240 frames, 320x240,
# 0.5 deg/s gyro drift): `--merge changes` (arlightd's: frames that agree with the map are not
# merged, a changed room replaces what was there) against `--merge all` (a plain weighted mean of
# every frame, before issue 37). Each sweep is captured with arlightd's settings (cube face 192,
# alignment every 4th frame at 160 px, in the background) over PASSES passes (default 2: a phone
# that keeps looking round), and its irradiance and s = 80 maps compared with the truth's
# (`arlight-maps diff`, auto method, 128). One table row per probe and way.
#   bench/capture_merge.sh [BUILD_DIR] [OUT]
set -eu
build=${1:-build}
out=${2:-out/bench/capture_merge}
passes=${PASSES:-2}
mkdir -p "$out"
echo "| probe | merge | irradiance error | s = 80 error | orientation RMS | frames not merged (pass 1 / later) | median ms a frame (pass 1 / later) |"
echo "|---|---|---|---|---|---|---|"
for spec in venice:1: city:3: "lab:4:--hdr-stops 5"; do
  name=${spec%%:*}
  rest=${spec#*:}
  seed=${rest%%:*}
  extra=${rest#*:}
  rec="$out/$name/rec"
  [ -d "$rec" ] || "$build/bin/arlight-sim" --env "data/probes/$name.exr" --out "$rec" --frames 240 \
    --size 320x240 --gyro-drift 0.5 --seed "$seed" $extra > /dev/null 2>&1
  for merge in changes all; do
    "$build/bin/arlight-capture" --recording "$rec" --projection cube --size 192 --align-async \
      --align-every 4 --align-width 160 --passes "$passes" --merge $merge \
      --out "$out/$name/$merge.exr" --json "$out/$name/$merge.json" > /dev/null
    "$build/bin/arlight-maps" diff --reference "$rec/truth/env.exr" --test "$out/$name/$merge.exr" \
      --method auto --size 128 --json "$out/$name/$merge-diff.json" > /dev/null
    python3 - "$out/$name/$merge.json" "$out/$name/$merge-diff.json" "$name" "$merge" <<'PY'
import json, statistics, sys
c, d = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
err = {m["shininess"]: m["mean_error"] for m in d["maps"]}
p = c["passes"]
later_unchanged = sum(x["frames_unchanged"] for x in p[1:])
later_frames = sum(x["frames"] for x in p[1:])
later_ms = statistics.median(r["ms"] for r in c["per_frame"] if r["pass"] > 0) if later_frames else 0
print(f"| {sys.argv[3]} | {sys.argv[4]} | {100 * err[1]:.2f} % | {100 * err[80]:.2f} % | "
      f"{c['orientation_rms_deg']:.3f}° | {p[0]['frames_unchanged']} of {p[0]['frames']} / "
      f"{later_unchanged} of {later_frames} | {p[0]['median_frame_ms']:.2f} / {later_ms:.2f} |")
PY
  done
done
