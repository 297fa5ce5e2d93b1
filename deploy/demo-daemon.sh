#!/usr/bin/env bash
# The daemon part of `make demo`: starts arlightd on a free loopback port with a fresh token,
# replays a recording into it as a phone would (arlight-replay), saves what came back and the
# admin endpoints' answers; then, given an AR recording (a phone looking at a marker in the same
# room), runs arlight-client on it in the same session, so the virtual object is lit by the
# room that was captured; and stops the daemon (SIGTERM: it checkpoints its sessions).
# With COMPOSITING_OUT, the client runs again once per other compositing mode (hemisphere
# shading, with and without occlusion; the object as glass showing the live frame through it; as
# gold, glTF metallic-roughness lit by the room's GGX chain, whose light files land beside; the
# textured tiled ball, data/models/tiles.glb, with its own glTF materials)
# into COMPOSITING_OUT/<mode>/, for the side-by-side sheet. With EVAL_OUT (the AR recording
# has references: arlight-sim --object), the client runs at the true pose with the maps and
# with SH-9 alone, and arlight-eval scores those and the tracked run against the references
# (EVAL_OUT/table.md, <run>.json, <run>/frames, <run>/seen).
# Usage: deploy/demo-daemon.sh BUILD_DIR RECORDING OUT_DIR [AR_RECORDING MODEL CLIENT_OUT
#        [COMPOSITING_OUT [EVAL_OUT]]]
set -euo pipefail
build=$1 rec=$2 out=$3 ar_rec=${4:-} model=${5:-} client_out=${6:-} compositing_out=${7:-}
eval_out=${8:-}
rm -rf "$out"
mkdir -p "$out"
token=$(od -An -N16 -tx1 /dev/urandom | tr -d ' \n')
device=$(sed -n 's/.*"device_id": *"\([^"]*\)".*/\1/p' "$rec/recording.json" | head -1)
printf '# written by make demo\n%s %s\n' "${device:-arlight-sim}" "$token" > "$out/tokens"
"$build/bin/arlightd" --listen 127.0.0.1:0 --admin 127.0.0.1:0 --data-dir "$out/data" \
  --tokens "$out/tokens" > "$out/arlightd.out" 2> "$out/arlightd.log" &
pid=$!
trap 'kill -TERM $pid 2>/dev/null || true; wait $pid 2>/dev/null || true' EXIT
for _ in $(seq 100); do
  grep -q 'listening on' "$out/arlightd.out" 2>/dev/null && break
  sleep 0.1
done
port=$(sed -n 's/.*listening on 127\.0\.0\.1:\([0-9]*\),.*/\1/p' "$out/arlightd.out")
admin=$(sed -n 's/.*admin on \([0-9]*\).*/\1/p' "$out/arlightd.out")
[ -n "$port" ] || { echo "arlightd did not start:"; cat "$out/arlightd.log"; exit 1; }
echo "arlightd on 127.0.0.1:$port (admin $admin)"
"$build/bin/arlight-replay" --server "127.0.0.1:$port" --token "$token" --recording "$rec" \
  --out "$out/replay"
# The admin endpoints, with bash's /dev/tcp (no curl needed) and the admin token arlightd made
# in its data folder (/sessions and a session's map need it).
admin_token=$(grep -v '^#' "$out/data/admin.token" | tail -1)
http_get() {
  exec 3<>"/dev/tcp/127.0.0.1/$admin"
  printf 'GET %s HTTP/1.0\r\nHost: localhost\r\nAuthorization: Bearer %s\r\n\r\n' "$1" \
    "$admin_token" >&3
  sed '1,/^\r$/d' <&3
  exec 3<&-
}
http_get /metrics > "$out/metrics.txt"
http_get /sessions > "$out/sessions.json"
session=$(sed -n 's/.*"session_id": *"\([^"]*\)".*/\1/p' "$out/replay/replay.json")
http_get "/sessions/$session/envmap.png" > "$out/envmap.png"

if [ -n "$ar_rec" ]; then
  rm -rf "$client_out"
  "$build/bin/arlight-client" --server "127.0.0.1:$port" --token "$token" \
    --source "replay:$ar_rec" --model "$model" --marker 7,0.2 --material 0.7,0.3,80 \
    --resume "$session" --wait-maps 60 --out "$client_out" > "$client_out.log"
  tail -1 "$client_out.log"
  if [ -n "$compositing_out" ]; then
    rm -rf "$compositing_out"
    mkdir -p "$compositing_out"
    # name:flags of each other mode.
    for mode in "hemisphere:--shading hemisphere" \
      "hemisphere-occlusion:--shading hemisphere-occlusion" "glass:--glass live" \
      "gold:--material pbr:1,0.78,0.34,1,0.3" \
      "tiles:--model data/models/tiles.glb --material model"; do
      name=${mode%%:*} flags=${mode#*:}
      # The demo's Phong material and model, unless the mode brings its own.
      material="--material 0.7,0.3,80" model_flag="--model $model"
      case "$flags" in *--material*) material= ;; esac
      case "$flags" in *--model*) model_flag= ;; esac
      # shellcheck disable=SC2086  # the flags are words
      "$build/bin/arlight-client" --server "127.0.0.1:$port" --token "$token" \
        --source "replay:$ar_rec" $model_flag --marker 7,0.2 $material \
        --resume "$session" --wait-maps 60 $flags --out "$compositing_out/$name" \
        --json "$compositing_out/$name.json" > "$compositing_out/$name.log"
    done
  fi
  if [ -n "$eval_out" ]; then
    rm -rf "$eval_out"
    mkdir -p "$eval_out"
    for run in "maps:" "sh-9:--maps ''"; do
      name=${run%%:*} flags=${run#*:}
      eval "\"$build/bin/arlight-client\" --server 127.0.0.1:$port --token $token \
        --source replay:$ar_rec --model $model --marker 7,0.2 --material 0.7,0.3,80 \
        --resume $session --wait-maps 60 --pose truth $flags --out $eval_out/$name" \
        > "$eval_out/$name.log"
    done
    {
      echo "| run | object PSNR (dB) | object SSIM | shadow PSNR (dB) | shadow SSIM | differences seen |"
      echo "|---|---|---|---|---|---|"
      for run in "maps:$eval_out/maps/frames" "sh-9:$eval_out/sh-9/frames" \
        "maps, tracked pose:$client_out/frames"; do
        name=${run%%:*} frames=${run#*:} slug=$(echo "${run%%:*}" | tr -c 'a-z0-9\n-' '_')
        "$build/bin/arlight-eval" composite --recording "$ar_rec" --frames "$frames" \
          --json "$eval_out/$slug.json" --out "$eval_out/$slug/seen" --row "$name" | tail -1
      done
    } > "$eval_out/table.md"
    cat "$eval_out/table.md"
  fi
fi
