#!/bin/sh
# A phone on shaped links (issue 36 §3): for each link — 20, 5 and 2 Mbit/s each way, with 0, 1
# and 3 % of the packets lost each way, and 5 Mbit/s with 2 % and a 3 s blackout — arlightd
# serves on this side of a veth pair and arlight-load, in the phone's network namespace, streams
# a 640x480 venice sweep over wss at 30 fps asking for the thesis's 8 maps (--maps), for
# LINK_SECONDS. tests/support/shaped_link.sh makes and removes each link (tbf, nftables).
# Writes OUT/<link>.json (arlight-load's reports) and OUT/shaped_links.md (the table: frame ->
# update p50/p99, map sets and their interval, frames sent, dropped and lost, bytes down a
# second, and after the blackout how long until the session was back), and the same for the
# phone page in headless Chromium run in the phone's namespace (bench/page_on_link.mjs: its own
# latency figures, frames and map sets). Needs root.
#   bench/shaped_links.sh [BUILD_DIR] [OUT]   (LINK_SECONDS=20; LINKS="20:0 5:2 ..." to choose;
#                                              OLD=DIR: also run DIR's arlightd and arlight-load,
#                                              and its page where DIR/bin/web has one; WHOLE=1:
#                                              also arlight-load --whole-sets, every map set
#                                              whole as before issue 36 §2; MAPS=0: no maps
#                                              asked for, the uplink's share of the latency alone)
set -eu
build=${1:-build}
out=${2:-out/bench/shaped_links}
seconds=${LINK_SECONDS:-20}  # whole seconds, 10 or more
links=${LINKS:-"20:0 20:1 20:3 5:0 5:1 5:3 2:0 2:1 2:3 5:2:dark"}
k=${LINK_K:-61}
maps_flag=--maps
[ "${MAPS:-1}" = 0 ] && maps_flag=
if [ "$(id -u)" -ne 0 ]; then
  echo "shaped_links: needs root (network namespaces); skipped"
  exit 0
fi
here=$(cd "$(dirname "$0")/.." && pwd)
link="$here/tests/support/shaped_link.sh"
mkdir -p "$out"
out=$(cd "$out" && pwd)
daemon_pid=
cleanup() {
  [ -n "$daemon_pid" ] && kill -9 "$daemon_pid" 2>/dev/null || true
  "$link" down "$k" || true
}
trap cleanup EXIT
trap 'exit 1' INT TERM  # through the EXIT trap
"$build/bin/arlight-sim" --env "$here/data/probes/venice.exr" --out "$out/rec" --frames 150 \
  --size 640x480 --seed 3 > /dev/null 2>&1
echo "arlight-sim shaped-link-token-0123456789" > "$out/tokens"  # the recording's device

# run_case BUILD NAME RATE LOSS [dark [arlight-load flag]]
run_case() {
  bin=$1/bin name=$2 rate=$3 loss=$4 dark=${5:-} load_flag=${6:-}
  "$link" up "$k" "$rate" "$loss"
  rm -rf "$out/data"
  fifo="$out/daemon.out"
  "$bin/arlightd" --tokens "$out/tokens" --data-dir "$out/data" --listen "10.77.$k.1:0" \
    --admin 127.0.0.1:0 --web "10.77.$k.1:0" > "$fifo" 2> "$out/$name.arlightd.log" &
  daemon_pid=$!
  web=
  for _ in $(seq 100); do
    web=$(sed -n 's/.*listening on .*web on \([0-9]*\).*/\1/p' "$fifo")
    [ -n "$web" ] && break
    sleep 0.1
  done
  [ -n "$web" ] || { echo "shaped_links: arlightd did not start" >&2; exit 1; }
  dark_pid=
  if [ -n "$dark" ]; then  # 2/5 of the way in (8 s of 20), 3 s without a packet through
    (sleep $((seconds * 2 / 5)); date +%s.%N > "$out/$name.dark_from"; "$link" loss "$k" 100; sleep 3
     "$link" loss "$k" "$loss"; date +%s.%N > "$out/$name.dark_until") &
    dark_pid=$!
  fi
  $("$link" on-phone "$k") "$bin/arlight-load" --server "10.77.$k.1:$web" --websocket \
    --tls-ca "$out/data/tls/self-signed-cert.pem" --token shaped-link-token-0123456789 \
    --recording "$out/rec" --sessions 1 --rate 30 $maps_flag --duration "$seconds" --reconnect 10 \
    --json "$out/$name.json" $load_flag > "$out/$name.out" 2>&1 || true
  [ -z "$dark_pid" ] || wait "$dark_pid" || true
  kill -9 "$daemon_pid" 2>/dev/null || true
  daemon_pid=
  # The phone page through the same link: Chromium in the phone's namespace (PAGE=0: not).
  if [ "${PAGE:-1}" = 1 ] && [ -z "$dark" ] && [ -z "$load_flag" ] && [ -f "$bin/web/index.html" ]; then
    printf '#!/bin/sh\nexec %s %s "$@"\n' "$("$link" on-phone "$k")" "${CHROMIUM:-/usr/bin/chromium}" \
      > "$out/chromium-on-link.sh"
    chmod +x "$out/chromium-on-link.sh"
    CHROMIUM="$out/chromium-on-link.sh" node "$here/bench/page_on_link.mjs" "$bin" "$seconds" \
      "10.77.$k.1" > "$out/$name.page.json" 2> "$out/$name.page.log" || true
  fi
  "$link" down "$k"
  echo "shaped_links: $name: $(head -1 "$out/$name.out")"
}

names=
for l in $links; do
  rate=$(echo "$l" | cut -d: -f1) loss=$(echo "$l" | cut -d: -f2) dark=$(echo "$l" | cut -d: -f3)
  case_name="${rate}mbit_${loss}pct${dark:+_$dark}"
  run_case "$build" "$case_name" "$rate" "$loss" "$dark"
  names="$names $case_name"
  if [ "${WHOLE:-0}" = 1 ]; then
    run_case "$build" "whole_$case_name" "$rate" "$loss" "$dark" --whole-sets
    names="$names whole_$case_name"
  fi
  if [ -n "${OLD:-}" ]; then
    run_case "$OLD" "old_$case_name" "$rate" "$loss" "$dark"
    names="$names old_$case_name"
  fi
done

python3 - "$out" $names <<'PY'
import json, os, sys
out, names = sys.argv[1], sys.argv[2:]
rows = ["| link | p50 ms | p99 ms | map sets (median interval; as changes) | frames sent / dropped / lost | frame kB, JPEG quality (advice kB) | down kB/s capturing / settled | back after the blackout | the page: p50 / p99 ms, frames, map sets, quality |",
        "|---|---|---|---|---|---|---|---|---|"]
def page(n):
    p = f"{out}/{n}.page.json"
    if not os.path.exists(p): return ""
    try:
        g = json.loads(open(p).read().strip().splitlines()[-1])
    except (ValueError, IndexError):
        return "no result"
    if g.get("failed"): return "failed: " + g.get("error", "")[:80]
    return (f"{g['latency_p50_ms']:.0f} / {g['latency_p99_ms']:.0f}, {g['frames_sent']}, {g['map_sets']}, "
            f"{g.get('jpeg_quality', '-')}")
for n in names:
    p = f"{out}/{n}.json"
    if not os.path.exists(p):
        rows.append(f"| {n} | failed: {open(f'{out}/{n}.out').read().strip()[-200:]} |||||||| {page(n)} |")
        continue
    j = json.load(open(p))
    lat, down = j["latency_ms"], j.get("download_bytes_per_s_per_session", {})
    back = ""
    if os.path.exists(f"{out}/{n}.dark_until") and j["outages"] and "started_unix_s" in j:
        o = j["outages"][0]
        until = float(open(f"{out}/{n}.dark_until").read())
        back = f"{j['started_unix_s'] + o['at_s'] + o['seconds'] - until:.2f} s"
    elif os.path.exists(f"{out}/{n}.dark_until"):
        back = f"{len(j['outages'])} outages noticed"
    interval = j["map_set_interval_ms"]["median"]
    s = j["per_session"][0] if j["per_session"] else {}
    frame = (f"{s['bytes_per_frame'] / 1e3:.1f}, {s['jpeg_quality_mean']:.0f} ({s['advised_frame_bytes'] / 1e3:.1f})"
             if "bytes_per_frame" in s else
             f"{s.get('bytes_sent', 0) / max(s.get('frames_sent', 1), 1) / 1e3:.1f}, 90")
    rows.append(f"| {n} | {lat['p50']:.0f} | {lat['p99']:.0f} | {j['map_sets_completed']} "
                f"({interval:.0f} ms; {j.get('map_sets_from_changes', '-')}) | {j['frames_sent']} / {j['frames_dropped']} / "
                f"{j.get('frames_lost', '-')} | {frame} | {down.get('capturing', 0) / 1e3:.0f} / "
                f"{down.get('settled', 0) / 1e3:.0f} | {back}{' (failed)' if j['failed'] else ''} | {page(n)} |")
open(f"{out}/shaped_links.md", "w").write("\n".join(rows) + "\n")
print("\n".join(rows))
PY
