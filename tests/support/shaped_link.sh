#!/bin/sh
# A shaped network link for the link tests and bench/shaped_links.sh (issue 36 §3): a network
# namespace "the phone" joined to this one by a veth pair, shaped both ways with tbf (the host
# end's egress is the downlink, the phone end's the uplink) and random packet loss with nftables
# in the phone's namespace (numgen random: this kernel has no netem). Addresses: 10.77.K.1 on
# this side, 10.77.K.2 on the phone's; nothing else is touched. Needs root. The namespace is
# held by a process of its own (unshare) and entered with nsenter, so nothing is mounted (`ip
# netns` needs / to be a mount point, which a chroot's is not).
#   shaped_link.sh up K RATE_MBIT LOSS_PCT   make it (K in 1..250: one link per K at a time)
#   shaped_link.sh loss K LOSS_PCT           change the loss (100: a blackout, 0: none)
#   shaped_link.sh on-phone K                print the prefix that runs a command on the phone
#   shaped_link.sh down K                    remove it (and whatever runs in its namespace)
set -eu
cmd=${1:?usage: shaped_link.sh up|loss|on-phone|down K ...}
k=${2:?K}
case $k in *[!0-9]*) echo "shaped_link: K must be a number" >&2; exit 2 ;; esac
host=arlh-$k peer=arlp-$k
holder_file=${TMPDIR:-/tmp}/arlight-link-$k.pid

holder() {  # the pid holding the phone's namespace, if the link is up
  [ -f "$holder_file" ] || return 1
  pid=$(cat "$holder_file")
  [ -e "/proc/$pid/ns/net" ] || return 1
  echo "$pid"
}
on_phone() { echo "nsenter --net=/proc/$(holder)/ns/net"; }

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
  $(on_phone) nft -f - <<NFT
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
  # The namespace's holder: a process of its own session, so the caller's exit leaves it be.
  setsid unshare --net sleep 86400 < /dev/null > /dev/null 2>&1 &
  echo $! > "$holder_file"
  for _ in $(seq 50); do  # until unshare has made the namespace (its own, not ours)
    [ "$(readlink "/proc/$!/ns/net")" != "$(readlink /proc/self/ns/net)" ] && break
    sleep 0.02
  done
  phone=$(on_phone)
  ip link add "$host" type veth peer name "$peer"
  ip link set "$peer" netns "$(holder)"
  ip addr add "10.77.$k.1/30" dev "$host"
  ip link set "$host" up
  $phone ip addr add "10.77.$k.2/30" dev "$peer"
  $phone ip link set "$peer" up
  $phone ip link set lo up
  # A token bucket each way; packets wait at most 200 ms in its queue (a phone link's buffer),
  # then drop.
  tc qdisc add dev "$host" root tbf rate "${rate}mbit" burst 32kbit latency 200ms
  $phone tc qdisc add dev "$peer" root tbf rate "${rate}mbit" burst 32kbit latency 200ms
  set_loss "$loss"
  ;;
loss) set_loss "${3:?LOSS_PCT}" ;;
on-phone) on_phone ;;
down)
  # Whatever still runs in the namespace goes with it, the holder last.
  if pid=$(holder); then
    ns=$(readlink "/proc/$pid/ns/net")
    for p in /proc/[0-9]*; do
      [ "$(readlink "$p/ns/net" 2>/dev/null)" = "$ns" ] && [ "${p#/proc/}" != "$pid" ] &&
        kill -9 "${p#/proc/}" 2>/dev/null || true
    done
    kill -9 "$pid" 2>/dev/null || true
  fi
  rm -f "$holder_file"
  ip link del "$host" 2>/dev/null || true
  ;;
*) echo "shaped_link: unknown command $cmd" >&2; exit 2 ;;
esac
