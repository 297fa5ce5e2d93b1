#!/bin/sh
# Frame -> LightingUpdate latency over the web port's wss://.../ws against the TCP port, one
# arlightd, interleaved runs (the machine is noisy: each pair is measured back to back).
#   bench/web_latency.sh [BUILD_DIR] [SESSIONS] [SECONDS] [PAIRS]
# Prints one line per run: transport, sessions, sent, processed, dropped, p50, p95, p99 (ms).
set -eu
build=${1:-build}
sessions=${2:-8}
seconds=${3:-10}
pairs=${4:-3}
work=$(mktemp -d /tmp/arlight-web-latency.XXXXXX)
trap 'kill $daemon 2>/dev/null || true; rm -rf "$work"' EXIT
"$build/bin/arlight-sim" --env data/probes/venice.exr --out "$work/rec" --frames 120 --seed 3 \
  > /dev/null
echo "load load-token-0123456789" > "$work/tokens"
"$build/bin/arlightd" --tokens "$work/tokens" --data-dir "$work/data" --listen 127.0.0.1:0 \
  --admin '' --web 127.0.0.1:0 --web-root "$work" > "$work/out" 2> "$work/err" &
daemon=$!
for _ in $(seq 50); do grep -q "listening on" "$work/out" && break; sleep 0.1; done
tcp=$(sed -n 's/.*listening on 127.0.0.1:\([0-9]*\),.*/\1/p' "$work/out")
web=$(sed -n 's/.*web on \([0-9]*\).*/\1/p' "$work/out")
cert="$work/data/tls/self-signed-cert.pem"
run() {  # transport port extra-flags...
  name=$1 port=$2
  shift 2
  "$build/bin/arlight-load" --server "127.0.0.1:$port" --token load-token-0123456789 \
    --recording "$work/rec" --device load --sessions "$sessions" --duration "$seconds" --rate 30 \
    --json "$work/load.json" "$@" > /dev/null
  python3 - "$name" "$work/load.json" <<'PY'
import json, sys
j = json.load(open(sys.argv[2]))
lat = j["latency_ms"]
print(f"{sys.argv[1]:4} sent {j['frames_sent']} processed {j['frames_processed']} "
      f"dropped {j['frames_dropped']} p50 {lat['p50']:.1f} p95 {lat['p95']:.1f} "
      f"p99 {lat['p99']:.1f} ms")
PY
}
run tcp "$tcp" > /dev/null  # warm-up
for _ in $(seq "$pairs"); do
  run tcp "$tcp"
  run wss "$web" --websocket --tls-ca "$cert"
done
