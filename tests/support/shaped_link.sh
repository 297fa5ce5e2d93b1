#!/bin/sh
# A shaped network link for the link tests and bench/shaped_links.sh (issue 36 §3): a network
# namespace "the phone" (arlphone-K) joined to this one by a veth pair, shaped both ways with tbf
# (the host end's egress is the downlink, the phone end's the uplink) and random packet loss
# with nftables in the phone's namespace (numgen random: this kernel has no netem). Addresses:
# 10.77.K.1 on this side, 10.77.K.2 on the phone's; nothing else is touched. Needs root.
#   shaped_link.sh up K RATE_MBIT LOSS_PCT   make it (K in 1..250: one link per K at a time)
#   shaped_link.sh loss K LOSS_PCT           change the loss (100: a blackout, 0: none)
#   shaped_link.sh down K                    remove it (and whatever runs in its namespace)
set -eu
cmd=${1:?usage: shaped_link.sh up|loss|down K ...}
k=${2:?K}
case $k in *[!0-9]*) echo "shaped_link: K must be a number" >&2; exit 2 ;; esac
ns=arlphone-$k host=arlh-$k peer=arlp-$k

set_loss() {  # the phone's namespace drops this percentage of packets each way
  pct=$1
  rules=""
  if [ "$pct" -ge 100 ]; then  # a blackout
    rules="chain down { type filter hook input priority 0; iifname \"$peer\" drop; }
  chain up { type filter hook output priority 0; oifname \"$peer\" drop; }"
  elif [ "$pct" -gt 0 ]; then
    rules="chain down { type filter hook input priority 0; iifname \"$peer\" numgen random mod 100 < $pct drop; }
  chain up { type filter hook output priority 0; oifname \"$peer\" numgen random mod 100 < $pct drop; }"
  fi
  ip netns exec "$ns" nft -f - <<NFT
table inet arlight_link
delete table inet arlight_link
table inet arlight_link {
  $rules
}
NFT
}

case $cmd in
up)
  rate=${3:?RATE_MBIT} loss=${4:?LOSS_PCT}
  "$0" down "$k"
  ip netns add "$ns"
  ip link add "$host" type veth peer name "$peer"
  ip link set "$peer" netns "$ns"
  ip addr add "10.77.$k.1/30" dev "$host"
  ip link set "$host" up
  ip netns exec "$ns" ip addr add "10.77.$k.2/30" dev "$peer"
  ip netns exec "$ns" ip link set "$peer" up
  ip netns exec "$ns" ip link set lo up
  # A token bucket each way; packets wait at most 200 ms in its queue (a phone link's buffer),
  # then drop.
  tc qdisc add dev "$host" root tbf rate "${rate}mbit" burst 32kbit latency 200ms
  ip netns exec "$ns" tc qdisc add dev "$peer" root tbf rate "${rate}mbit" burst 32kbit latency 200ms
  set_loss "$loss"
  ;;
loss) set_loss "${3:?LOSS_PCT}" ;;
down)
  # Whatever still runs in the namespace goes with it.
  if [ -e "/run/netns/$ns" ]; then
    for pid in $(ip netns pids "$ns" 2>/dev/null); do kill -9 "$pid" 2>/dev/null || true; done
    ip netns del "$ns"
  fi
  ip link del "$host" 2>/dev/null || true
  ;;
*) echo "shaped_link: unknown command $cmd" >&2; exit 2 ;;
esac
