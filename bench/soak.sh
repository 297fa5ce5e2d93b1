#!/bin/sh
# Soak: arlight-load at 8 sessions for 10 minutes against one arlightd that is killed with
# kill -9 every 2 minutes and started again at once on the same ports and data folder; the
# sessions reconnect and resume. Reports sessions failed, frames lost per restart and
# arlightd's RSS (after the first minute, before each kill, at the end) into OUT/soak.json.
#   bench/soak.sh [BUILD_DIR] [OUT]     (SOAK_SECONDS=600 SOAK_SESSIONS=8 SOAK_EVERY=120)
set -eu
build=${1:-build}
out=${2:-out/soak}
seconds=${SOAK_SECONDS:-600}
sessions=${SOAK_SESSIONS:-8}
every=${SOAK_EVERY:-120}
mkdir -p "$out"
out=$(cd "$out" && pwd)
rm -rf "$out/data" "$out/rss.tsv"
trap 'kill -9 $(cat "$out/daemon.pid" 2>/dev/null) 2>/dev/null || true' EXIT
"$build/bin/arlight-sim" --env data/probes/venice.exr --out "$out/rec" --frames 120 --seed 3 \
  > /dev/null
echo "load soak-token-0123456789" > "$out/tokens"
port=${SOAK_PORT:-7978}
admin=$((port + 1))

start_daemon() {  # the same ports and data folder every time, one checkpoint a second
  "$build/bin/arlightd" --tokens "$out/tokens" --data-dir "$out/data" \
    --listen "127.0.0.1:$port" --admin "127.0.0.1:$admin" --checkpoint-interval 1 \
    >> "$out/arlightd.out" 2>> "$out/arlightd.log" &
  echo $! > "$out/daemon.pid"
  for _ in $(seq 100); do
    python3 -c 'import sys, urllib.request; urllib.request.urlopen(sys.argv[1], timeout=1)' \
      "http://127.0.0.1:$admin/healthz" 2> /dev/null && return
    sleep 0.05
  done
  echo "soak: arlightd did not start" >&2
  exit 1
}
rss() { awk '/VmRSS/ {print $2}' "/proc/$(cat "$out/daemon.pid")/status"; }
# instance (1 = the first arlightd, 2 after the first kill, ...), what, seconds since the start, KiB
sample() { printf '%s\t%s\t%s\t%s\n' "$instance" "$1" "$(( $(date +%s) - t0 ))" "$(rss)" >> "$out/rss.tsv"; }

start_daemon
t0=$(date +%s)
instance=1 born=0 sampled=
"$build/bin/arlight-load" --server "127.0.0.1:$port" --token soak-token-0123456789 \
  --recording "$out/rec" --device load --sessions "$sessions" --duration "$seconds" --rate 30 \
  --reconnect 30 --json "$out/load.json" > "$out/load.out" 2>&1 &
load=$!
restarts=0
next_kill=$every
while kill -0 $load 2>/dev/null; do
  sleep 1
  now=$(( $(date +%s) - t0 ))
  if [ $((now - born)) -ge 60 ] && [ -z "$sampled" ]; then sample minute; sampled=1; fi
  if [ "$now" -ge "$next_kill" ] && [ "$now" -lt "$seconds" ]; then
    sample killed
    kill -9 "$(cat "$out/daemon.pid")"
    wait "$(cat "$out/daemon.pid")" 2>/dev/null || true
    start_daemon
    restarts=$((restarts + 1))
    instance=$((instance + 1)) born=$now sampled=
    next_kill=$((next_kill + every))
  fi
done
sample end
status=0
wait $load || status=$?
python3 - "$out" "$restarts" "$status" <<'PY'
import json, sys
out, restarts, status = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
load = json.load(open(f"{out}/load.json"))
rss = [line.split("\t") for line in open(f"{out}/rss.tsv").read().split("\n") if line]
first = next((int(r[3]) for r in rss if r[1] == "minute"), int(rss[0][3]))
end = int(rss[-1][3])
# Each arlightd's own growth: from a minute into its life to its last sample (a leak grows here).
growth = {}
for inst in sorted({r[0] for r in rss}, key=int):
    mine = [r for r in rss if r[0] == inst]
    minute = next((int(r[3]) for r in mine if r[1] == "minute"), None)
    if minute is not None and mine[-1][1] != "minute":
        growth[inst] = int(mine[-1][3]) / minute - 1
per_restart = {}
for o in load["outages"]:
    lost = o["frames_lost"] / load["rate"]
    k = round(o["at_s"])
    per_restart[k] = max(per_restart.get(k, 0), lost)
summary = {
    "seconds": load["duration_s"], "sessions": load["sessions"], "restarts": restarts,
    "sessions_failed": load["failed"], "errors": load["errors"],
    "outages": len(load["outages"]),
    "worst_frames_lost_s": load["worst_outage_frames_lost_s"],
    "worst_frames_lost_s_per_restart": per_restart,
    "rss_kib": {"first_minute": first, "end": end, "samples": rss},
    "rss_end_vs_first_minute": end / first - 1,
    "rss_growth_per_instance": growth,
    "frames_sent": load["frames_sent"], "frames_dropped": load["frames_dropped"],
    "frames_resent": load["frames_resent"], "frames_lost": load["frames_lost"],
    "latency_ms": load["latency_ms"], "load_status": status,
}
json.dump(summary, open(f"{out}/soak.json", "w"), indent=2)
print(f"soak: {summary['seconds']:.0f} s, {summary['sessions']} sessions, {restarts} kill -9 "
      f"restarts: {summary['sessions_failed']} sessions failed, {summary['outages']} outages, "
      f"{summary['frames_lost']} frames lost ({summary['frames_resent']} sent again after resumes), "
      f"worst {summary['worst_frames_lost_s']:.2f} s of frames lost in one; RSS {first} KiB after "
      f"the first minute, {end} KiB at the end ({100 * summary['rss_end_vs_first_minute']:+.1f} %); "
      f"each arlightd from its first minute to its end: "
      + ", ".join(f"{100 * g:+.1f} %" for g in growth.values()))
PY
