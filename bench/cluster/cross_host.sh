#!/bin/bash
# Actor -> replay shard transitions/s between two hosts against inside one host.
#
# Two network namespaces on a bridge stand for two hosts, each with a /dev/shm of its own. One
# actor (random actions, 2 Breakout envs) publishes STEPS transitions to one shard:
#   shm  - actor and shard on host 1: shared memory
#   udp  - actor on host 1, shard on host 2: UDP over the bridge (dds.discovery: peers)
#   udp_secured - as udp with DDS Security (authentication, access control, AES-GCM encryption;
#          `coins security init`)
# The figure is transitions stored / the actor's wall time, median of REPEATS runs alternating the
# modes, and the ratios of the medians to shm. Needs root.
#
#   bash bench/cluster/cross_host.sh [BUILD_DIR] [STEPS] [REPEATS]
set -euo pipefail
BUILD=${1:-build}
STEPS=${2:-400000}
REPEATS=${3:-3}
BIN=$(cd "$BUILD/bin" && pwd)
TAG=$$
NET=10.252.$((TAG % 250))
WORK=$(mktemp -d /tmp/coins-cross-host.XXXXXX)
DOMAIN=$((200 + TAG % 19))

source "$(dirname "$0")/hosts.sh"
cleanup() {
  hosts_down
  rm -rf "$WORK"
}
trap cleanup EXIT
hosts_up 2 "$NET"

# one measurement; prints transitions/s
measure() {
  local mode=$1 shard_host dds
  if [ "$mode" = shm ]; then
    shard_host=1
    dds=(--set dds.discovery=local)
  else
    shard_host=2
    dds=(--set dds.discovery=peers --set "dds.peers=$NET.1,$NET.2")
  fi
  if [ "$mode" = udp_secured ]; then dds+=(--set "dds.security=$WORK/security"); fi
  local common=(--quiet-config --set "dds.domain=$DOMAIN" "${dds[@]}" --set run.shards=1 --set run.actors=1
    --set replay.capacity_mb=256 --set actor.follow_chain=false --set actor.envs=2)
  # shm: both processes on host 1 in its namespace's one /dev/shm (the machine's); udp: the shard
  # on host 2, each host with a /dev/shm of its own
  local run_shard=(on_host "$shard_host") run_actor=(on_host 1)
  if [ "$mode" = shm ]; then run_shard=(ip netns exec "$(host_ns 1)") run_actor=(ip netns exec "$(host_ns 1)"); fi
  "${run_shard[@]}" "$BIN/coins-replay" --name replay-0 --id 0 --stats-out "$WORK/replay.json" "${common[@]}" \
    > "$WORK/replay.log" 2>&1 &
  local shard=$!
  sleep 1
  local start end
  start=$(date +%s.%N)
  "${run_actor[@]}" "$BIN/coins-actor" --name actor-0 --id 0 --set "actor.steps=$STEPS" \
    --stats-out "$WORK/actor.json" "${common[@]}" > "$WORK/actor.log" 2>&1
  end=$(date +%s.%N)
  echo "$start $end" > "$WORK/wall"
  kill -TERM $shard
  wait $shard || true
  python3 - "$WORK" <<'PY'
import json, sys
w = sys.argv[1]
start, end = map(float, open(w + "/wall").read().split())
shard = json.load(open(w + "/replay.json"))
actor = json.load(open(w + "/actor.json"))
stored = sum(a["transitions"] for a in shard["actors"])
assert stored == actor["transitions_published"], (stored, actor["transitions_published"])
print(f"{stored / (end - start):.0f}")
PY
}

"$BIN/coins" security init "$WORK/security" > /dev/null
declare -A runs=([shm]="" [udp]="" [udp_secured]="")
for ((r = 0; r < REPEATS; r++)); do
  for mode in shm udp udp_secured; do
    x=$(measure $mode)
    runs[$mode]="${runs[$mode]} $x"
    echo "run $((r + 1)) $mode: $x transitions/s" >&2
  done
done
python3 - "${runs[shm]}" "${runs[udp]}" "${runs[udp_secured]}" <<'PY'
import statistics, sys
shm, udp, sec = ([float(x) for x in a.split()] for a in sys.argv[1:4])
ms, mu, mc = statistics.median(shm), statistics.median(udp), statistics.median(sec)
print(f"transitions_per_s_shm_one_host {ms:.0f}")
print(f"transitions_per_s_udp_two_hosts {mu:.0f}")
print(f"transitions_per_s_udp_secured_two_hosts {mc:.0f}")
print(f"udp_over_shm {mu / ms:.2f}")
print(f"udp_secured_over_shm {mc / ms:.2f}")
print(f"udp_secured_over_udp {mc / mu:.2f}")
PY
