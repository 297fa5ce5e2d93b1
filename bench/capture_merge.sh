#!/bin/sh
# Frames that add nothing (issue 37 §1): the accuracy and cost of arlight-capture's two ways of
# merging frames in one run, on the simulated sweeps `make test` checks (240 frames, 320x240,
# 0.5 deg/s gyro drift): `--merge changes` (arlightd's: frames that agree with the map are not
# merged, a changed room replaces what was there) against `--merge all` (a plain weighted mean of
# every frame, before issue 37). Each sweep is captured with arlightd's settings over PASSES
# passes (default 2: a phone that keeps looking round), and its irradiance and s = 80 maps
# compared with the truth's (bench/sweeps.sh). One table row per probe and way.
#   bench/capture_merge.sh [BUILD_DIR] [OUT]
set -eu
build=${1:-build}
out=${2:-out/bench/capture_merge}
passes=${PASSES:-2}
. "$(dirname "$0")/sweeps.sh"
mkdir -p "$out"
echo "| probe | merge | irradiance error | s = 80 error | orientation RMS | frames not merged (pass 1 / later) | median ms a frame (pass 1 / later) |"
echo "|---|---|---|---|---|---|---|"
# Two rows for probe $1 (seed $2, arlight-sim flags after them).
merge_rows() {
  name=$1 seed=$2
  shift 2
  rec="$out/$name/rec"
  make_sweep "$rec" "$name" "$seed" "$@"
  for merge in changes all; do
    capture_and_diff "$rec" "$out/$name/$merge" --passes "$passes" --merge $merge
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
}
for_each_sweep merge_rows
