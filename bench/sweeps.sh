# The simulated sweeps `make test` checks (240 frames, 320x240, 0.5 deg/s gyro drift), captured
# with arlightd's settings and compared with the truth: what the bench scripts that measure the
# captured light share (capture_merge.sh, jpeg_quality.sh). Sourced; they set $build.

# for_each_sweep FN: FN NAME SEED [arlight-sim flags...] for venice, city and lab.
for_each_sweep() {
  "$1" venice 1
  "$1" city 3
  "$1" lab 4 --hdr-stops 5
}

# make_sweep REC NAME SEED [arlight-sim flags...]: the sweep of probe NAME into REC, unless it
# is there already.
make_sweep() {
  sweep_rec=$1 sweep_name=$2 sweep_seed=$3
  shift 3
  [ -d "$sweep_rec" ] || "$build/bin/arlight-sim" --env "data/probes/$sweep_name.exr" \
    --out "$sweep_rec" --frames 240 --size 320x240 --gyro-drift 0.5 --seed "$sweep_seed" "$@" \
    > /dev/null 2>&1
}

# capture_and_diff REC OUT [arlight-capture flags...]: REC captured as arlightd does (cube face
# 192, alignment every 4th frame at 160 px, in the background) into OUT.exr and OUT.json, and
# its irradiance and s = 80 maps compared with the truth's in OUT-diff.json (`arlight-maps diff`,
# auto method, 128).
capture_and_diff() {
  capture_rec=$1 capture_out=$2
  shift 2
  "$build/bin/arlight-capture" --recording "$capture_rec" --projection cube --size 192 \
    --align-async --align-every 4 --align-width 160 "$@" --out "$capture_out.exr" \
    --json "$capture_out.json" > /dev/null
  "$build/bin/arlight-maps" diff --reference "$capture_rec/truth/env.exr" \
    --test "$capture_out.exr" --method auto --size 128 --json "$capture_out-diff.json" > /dev/null
}
