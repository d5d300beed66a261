#!/bin/bash
# Discovery of MEMBERS participants: a discovery server against multicast.
#
# Four network namespaces on a bridge stand for four hosts, each with a /dev/shm of its own. Host 1
# runs the discovery server (dds.discovery: server; in multicast mode it runs nothing); hosts 2-4
# run the members, coins-discovery-member processes, each one participant with one writer and one
# reader of a benchmark topic (the discovery load of an actor that publishes at a trickle). A
# member is done when its reader has matched every member's writer. Figures, median of REPEATS
# runs alternating the modes:
#   seconds from the first member's start until every member matched all the others
#   packets the hosts sent over the bridge in that time (discovery: SPDP/EDP and their acks)
# Needs root.
#
#   bash bench/cluster/discovery.sh [BUILD_DIR] [MEMBERS] [REPEATS]
set -euo pipefail
BUILD=${1:-build}
MEMBERS=${2:-64}
REPEATS=${3:-3}
BIN=$(cd "$BUILD/bin" && pwd)
TAG=$$
NET=10.251.$((TAG % 250))
WORK=$(mktemp -d /tmp/coins-discovery.XXXXXX)
DOMAIN=$((180 + TAG % 19))
HOSTS=4

source "$(dirname "$0")/hosts.sh"
cleanup() {
  hosts_down
  rm -rf "$WORK"
}
trap cleanup EXIT
hosts_up "$HOSTS" "$NET"

# packets the hosts sent into the bridge so far
sent_packets() {
  local n=0
  for ((h = 1; h <= HOSTS; h++)); do n=$((n + $(cat "/sys/class/net/$(host_link $h)/statistics/rx_packets"))); done
  echo $n
}

# one measurement; prints "seconds packets"
measure() {
  local mode=$1 dds
  if [ "$mode" = server ]; then
    dds="--set dds.discovery=server --set dds.discovery_server=$NET.1:11811"
  else
    dds="--set dds.discovery=multicast"
  fi
  dds="$dds ${EXTRA:-}"
  local common="--quiet-config --log-level warn --set dds.domain=$DOMAIN $dds"
  rm -f "$WORK"/m-*.log
  local server_pid=""
  if [ "$mode" = server ]; then
    ip netns exec "$(host_ns 1)" sh -c "mount -t tmpfs tmpfs /dev/shm && exec $BIN/coins discovery-server --index 0 --set dds.domain=$DOMAIN $dds" \
      > "$WORK/server.log" 2>&1 &
    server_pid=$!
    sleep 1
  fi
  local p0 t0
  p0=$(sent_packets)
  t0=$(date +%s.%N)
  # one shell a host: its members share the host's /dev/shm
  local pids=()
  for ((h = 2; h <= HOSTS; h++)); do
    local script="mount -t tmpfs tmpfs /dev/shm"
    for ((m = h - 2; m < MEMBERS; m += HOSTS - 1)); do
      script="$script
$BIN/coins-discovery-member --name m-$m --members $MEMBERS $common > $WORK/m-$m.log 2>&1 &"
    done
    ip netns exec "$(host_ns $h)" sh -c "$script
wait" &
    pids+=($!)
  done
  local deadline=$((SECONDS + 120)) done_n=0
  while [ $SECONDS -lt $deadline ]; do
    done_n=$(cat "$WORK"/m-*.log 2> /dev/null | grep -c all_matched_s || true)
    [ "$done_n" -ge "$MEMBERS" ] && break
    sleep 0.05
  done
  local p1
  p1=$(sent_packets)
  for ((h = 2; h <= HOSTS; h++)); do ip netns pids "$(host_ns $h)" | xargs -r kill -TERM 2> /dev/null || true; done
  wait "${pids[@]}" 2> /dev/null || true
  if [ -n "$server_pid" ]; then kill -TERM "$server_pid" 2> /dev/null || true; wait "$server_pid" 2> /dev/null || true; fi
  if [ "$done_n" -lt "$MEMBERS" ]; then
    echo "discovery.sh: $mode: only $done_n of $MEMBERS members matched everyone in 120 s" >&2
    grep -h . "$WORK"/m-*.log | grep -v all_matched | head -5 >&2
    exit 1
  fi
  python3 - "$WORK" "$t0" "$((p1 - p0))" << 'PY'
import glob, sys
work, t0, packets = sys.argv[1], float(sys.argv[2]), int(sys.argv[3])
last = max(float(l.split()[2]) for f in glob.glob(work + "/m-*.log") for l in open(f) if l.startswith("all_matched_s"))
print(f"{last - t0:.2f} {packets}")
PY
  sleep 2 # leases of the gone participants
}

declare -A secs=([server]="" [multicast]="") pkts=([server]="" [multicast]="")
for ((r = 0; r < REPEATS; r++)); do
  for mode in ${MODES:-server multicast}; do
    out=$(measure $mode) || exit 1
    read -r s p <<< "$out"
    secs[$mode]="${secs[$mode]} $s"
    pkts[$mode]="${pkts[$mode]} $p"
    echo "run $((r + 1)) $mode: all $MEMBERS matched after $s s, $p packets" >&2
  done
done
python3 - "$MEMBERS" "${secs[server]}" "${pkts[server]}" "${secs[multicast]}" "${pkts[multicast]}" << 'PY'
import statistics, sys
n = sys.argv[1]
ss, ps, sm, pm = ([float(x) for x in a.split()] for a in sys.argv[2:6])
print(f"discovery_all_matched_s_server_{n} {statistics.median(ss):.2f}")
print(f"discovery_all_matched_s_multicast_{n} {statistics.median(sm):.2f}")
print(f"discovery_packets_server_{n} {statistics.median(ps):.0f}")
print(f"discovery_packets_multicast_{n} {statistics.median(pm):.0f}")
print(f"packets_server_over_multicast {statistics.median(ps) / statistics.median(pm):.2f}")
PY
