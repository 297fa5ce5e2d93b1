#!/usr/bin/env bash
# The composite against the truth in three rooms (issue 18's evaluation, tutorial §8): for each
# probe, a simulated phone sweeps the room into arlightd (arlight-sim, arlight-replay), then an
# orbit of the marker is simulated with references of the bunny ray traced under the true room
# (arlight-sim --object); arlight-client composites the orbit at the true pose lit by the
# room's maps (with the bunny's occlusion and transfer baked and 16 shadow lights, the defaults;
# with one shadow light; without the bake), by the
# live SH alone (ARCore's SH-9) and by the maps with the dissertation's colour matching, and
# arlight-eval scores each. Writes OUT/<room>/<lighting>.json and
# OUT/table.md.
# Usage: bench/eval_rooms.sh BUILD_DIR OUT_DIR PROBE...
set -euo pipefail
build=$1 out=$2
shift 2
bin=$build/bin
material=0.3,0.7,160
model=data/models/bunny.glb
mkdir -p "$out"
token=$(od -An -N16 -tx1 /dev/urandom | tr -d ' \n')
printf 'arlight-sim %s\n' "$token" > "$out/tokens"
rm -rf "$out/daemon"
"$bin/arlightd" --listen 127.0.0.1:0 --admin 127.0.0.1:0 --data-dir "$out/daemon" \
  --tokens "$out/tokens" > "$out/arlightd.out" 2> "$out/arlightd.log" &
pid=$!
trap 'kill -TERM $pid 2>/dev/null || true; wait $pid 2>/dev/null || true' EXIT
for _ in $(seq 100); do
  grep -q 'listening on' "$out/arlightd.out" 2>/dev/null && break
  sleep 0.1
done
port=$(sed -n 's/.*listening on 127\.0\.0\.1:\([0-9]*\),.*/\1/p' "$out/arlightd.out")
[ -n "$port" ] || { echo "arlightd did not start:"; cat "$out/arlightd.log"; exit 1; }
server=127.0.0.1:$port

{
  echo "| room | lighting | object PSNR (dB) | object SSIM | shadow PSNR (dB) | shadow SSIM | differences seen |"
  echo "|---|---|---|---|---|---|---|"
} > "$out/table.md"
for probe in "$@"; do
  room=$(basename "$probe" .exr)
  dir=$out/$room
  rm -rf "$dir"
  mkdir -p "$dir"
  "$bin/arlight-sim" --env "$probe" --out "$dir/sweep" --frames 120 --size 320x240 --seed 11 \
    > "$dir/sim.log"
  "$bin/arlight-sim" --env "$probe" --out "$dir/orbit" --frames 24 --size 320x240 \
    --trajectory orbit --marker 7,0.2 --seed 12 --object "$model" --object-material "$material" \
    --reference-every 4 >> "$dir/sim.log"
  "$bin/arlight-replay" --server "$server" --token "$token" --recording "$dir/sweep" --maps '' \
    --out "$dir/replay" > "$dir/replay.log"
  session=$(sed -n 's/.*"session_id": *"\([^"]*\)".*/\1/p' "$dir/replay/replay.json")
  for mode in "maps:--wait-maps 60" "maps, one shadow light:--wait-maps 60 --shadow-lights 1" \
    "maps without occlusion:--wait-maps 60 --occlusion none" \
    "sh-9:--maps ''" "maps + colour matching:--wait-maps 60 --tone camera,match"; do
    name=${mode%%:*} flags=${mode#*:} slug=$(echo "${mode%%:*}" | tr -c 'a-z0-9\n' '_')
    eval "\"$bin/arlight-client\" --server $server --token $token --source replay:$dir/orbit \
      --model $model --material $material --marker 7,0.2 --pose truth --resume $session $flags \
      --out $dir/$slug" > "$dir/$slug.log"
    "$bin/arlight-eval" composite --recording "$dir/orbit" --frames "$dir/$slug/frames" \
      --json "$dir/$slug.json" --out "$dir/$slug/seen" --row "$room | $name" | tail -1 \
      >> "$out/table.md"
  done
done
cat "$out/table.md"
