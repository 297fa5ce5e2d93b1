#!/bin/sh
# Map sets while capturing (issue 16 §3): for each session count, a fresh arlightd, a 3 s
# warm-up session, then `arlight-load --sessions N --duration 10 --rate 30 --maps` on the
# 120-frame 640x480 venice recording; prints one table row per run (map sets in 10 s, the
# median session's and the slowest session's median interval between its map sets while it
# sends, frames dropped, frame->update p99, the daemon's CPU time). With OLD=PATH_TO_ARLIGHTD,
# each run is made with that daemon first, then with this build's, alternately (the machine is
# noisy). MAPS_FLAGS replaces what the sessions ask for (default --maps; e.g. "--ggx 256" for
# GGX chains, issue 34 §2; " " for none). LOAD_FLAGS go to arlight-load too (e.g.
# --ignore-advice: every frame at full size and rate, issue 37 §1). BUSY=N runs N CPU-bound shell loops of normal priority beside
# arlightd during each measured run (a workstation someone uses; issue 37 §2). LOAD_DURATION
# replaces the 10 s (the sessions all start capturing at once: a longer run shows more of
# their settled state).
#   bench/load_maps.sh [BUILD_DIR] [OUT] [SESSIONS...]      (default sessions: 1 4 8)
set -eu
build=${1:-build}
out=${2:-out/bench/load_maps}
shift 2 2>/dev/null || shift $#
counts=${*:-1 4 8}
mkdir -p "$out"
out=$(cd "$out" && pwd)
token=load-maps-token-0123456789
[ -d "$out/rec" ] || "$build/bin/arlight-sim" --env data/probes/venice.exr --out "$out/rec" \
  --frames 120 --seed 3 > /dev/null
echo "load $token" > "$out/tokens"
port=${LOAD_MAPS_PORT:-7988}
pid=
busy=
trap '[ -n "$pid" ] && kill $pid 2>/dev/null; [ -n "$busy" ] && kill $busy 2>/dev/null || true' EXIT

run() {  # run DAEMON LABEL SESSIONS
  rm -rf "$out/data"
  rm -f "$out/arlightd.log"
  "$1" --tokens "$out/tokens" --data-dir "$out/data" --listen "127.0.0.1:$port" --admin '' ${ARLIGHTD_FLAGS:-} \
    > "$out/arlightd.out" 2> "$out/arlightd.log" &
  pid=$!
  # Until it listens (it logs so): a fixed second was once not enough on a loaded machine.
  tries=0
  until grep -q listening "$out/arlightd.log" 2> /dev/null; do
    tries=$((tries + 1))
    if [ $tries -gt 200 ] || ! kill -0 $pid 2> /dev/null; then
      echo "load_maps: $1 did not start listening:" >&2
      cat "$out/arlightd.log" >&2
      exit 1
    fi
    sleep 0.05
  done
  "$build/bin/arlight-load" --server "127.0.0.1:$port" --token $token --recording "$out/rec" \
    --device load --sessions 1 --duration 3 > /dev/null
  cpu_before=$(cpu_ticks $pid)
  for _ in $(seq "${BUSY:-0}"); do sh -c 'while :; do :; done' & busy="$busy $!"; done
  "$build/bin/arlight-load" --server "127.0.0.1:$port" --token $token --recording "$out/rec" \
    --device load --sessions "$3" --duration ${LOAD_DURATION:-10} --rate 30 ${MAPS_FLAGS:---maps} ${LOAD_FLAGS:-} --json "$out/$2-$3.json" \
    > /dev/null || true
  [ -n "$busy" ] && kill $busy
  busy=
  cpu=$(( $(cpu_ticks $pid) - cpu_before ))
  kill $pid
  wait $pid 2> /dev/null || echo "load_maps: $1 exited with $?" >&2
  pid=
  python3 - "$out/$2-$3.json" "$2" "$3" "$cpu" "$(getconf CLK_TCK)" <<'PY'
import json, sys
j = json.load(open(sys.argv[1]))
i = j["map_set_interval_ms"]
cpu = int(sys.argv[4]) / int(sys.argv[5])
processed = max(1, j['frames_processed'])
print(f"| {sys.argv[2]} | {sys.argv[3]} | {j['map_sets_completed']} | {i['median']:.0f} ms / "
      f"{i['worst_session']:.0f} ms | {j['frames_dropped']} of {j['frames_sent']} | "
      f"{j.get('frames_held_back', 0)} | {j['latency_ms']['p99']:.1f} ms | {cpu:.1f} s "
      f"({1000 * cpu / processed:.2f} ms a frame) | "
      f"{j.get('upload_bytes_per_s_per_session', 0) / 1e3:.0f} kB/s |")
PY
}

# The daemon's CPU time so far (user + system), in clock ticks: what it cost, whatever else
# the machine ran meanwhile (a shared machine's steal time is not in it).
cpu_ticks() { awk '{print $14 + $15}' "/proc/$1/stat"; }

echo "| arlightd | sessions x 30 fps | map sets in the run | interval while sending (median / slowest session) | dropped of sent | held back (frame advice) | p99 frame->update | daemon CPU in the run | upload a session |"
echo "|---|---|---|---|---|---|---|---|---|"
for n in $counts; do
  [ -n "${OLD:-}" ] && run "$OLD" old "$n"
  run "$build/bin/arlightd" new "$n"
done
