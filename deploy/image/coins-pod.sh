#!/bin/bash
# coins-pod: the entrypoint of the coins image in a pod (deploy/k8s/). It turns the pod's
# environment into one `coins run --role ...` (or `coins discovery-server`), forwards SIGTERM to
# it, resumes the pod's part of the run after a container restart, and idles once that part has
# ended cleanly (a Deployment or StatefulSet restarts every container that exits).
#
#   coins-pod ROLE [coins run flags...]      ROLE: discovery | replay | learner | orchestrator |
#                                            actors | all (the whole run in this container; it
#                                            exits with coins run instead of idling)
#   coins-pod COMMAND [ARGS...]              anything else runs as it is (coins --help, bash)
#
# Environment (all optional):
#   COINS_CONFIG     the config (default /etc/coins/breakout.yaml, the ConfigMap, else the image's
#                    /opt/coins/configs/breakout.yaml)
#   COINS_DISCOVERY  the discovery servers, HOST:PORT[,HOST:PORT] (primary, backup). Host names
#                    (Kubernetes Service names) are resolved to IPv4 here, because
#                    dds.discovery_server takes IP literals only. Sets dds.discovery=server.
#                    Unset: the config's dds section as it is.
#   COINS_RUN_DIR    this pod's run directory (default /data/run); a new run when it holds no
#                    config.yaml, else `coins run --resume`
#   COINS_ID         discovery: server index; replay: shard id; actors: actor id. Default: the
#                    ordinal that ends the host name (a StatefulSet pod "coins-replay-1" is 1);
#                    discovery without an ordinal: 0
#   COINS_ACTORS     run.actors, the number of actor pods (the actors split the chain's step
#                    allowance by it, so it must equal the actors StatefulSet's replicas)
#   COINS_QUIET      1: no progress lines (default: 1 except for orchestrator and all)
#   POD_IP           discovery: the address the server listens on (default: the address of
#                    this pod's host name); the other pods reach it through its Service
#   COINS_RESOLVE_TIMEOUT  seconds to wait for the names of COINS_DISCOVERY (default 180)
set -uo pipefail

# a stop while this script still prepares (PID 1 ignores signals it has no handler for)
trap 'exit 143' TERM INT

log() { echo "coins-pod: $*" >&2; }
die() { log "$*"; exit 2; }

is_ipv4() { [[ $1 =~ ^[0-9]{1,3}(\.[0-9]{1,3}){3}$ ]]; }

# the first IPv4 address of a host name, waiting for DNS (Services and pods appear late)
resolve() {
  local name=$1 deadline=$((SECONDS + ${COINS_RESOLVE_TIMEOUT:-180})) ip
  if is_ipv4 "$name"; then echo "$name"; return 0; fi
  while :; do
    ip=$(getent ahostsv4 "$name" 2>/dev/null | awk 'NR == 1 { print $1 }')
    if [ -n "$ip" ]; then echo "$ip"; return 0; fi
    [ $SECONDS -ge $deadline ] && return 1
    sleep 2
  done
}

# COINS_DISCOVERY with every host name replaced by its IPv4 address; entry $1 (if >= 0) by
# $2 (the server's own listening address)
servers() {
  local own=${1:--1} own_ip=${2:-} out="" i=0 entry host port ip
  IFS=',' read -ra entries <<< "$COINS_DISCOVERY"
  for entry in "${entries[@]}"; do
    entry=${entry// /}
    host=${entry%:*} port=${entry##*:}
    [ "$host" != "$entry" ] && [ -n "$port" ] || die "COINS_DISCOVERY entry '$entry' is not host:port"
    if [ "$i" -eq "$own" ]; then
      ip=$own_ip
    else
      ip=$(resolve "$host") || die "cannot resolve '$host' (COINS_DISCOVERY) within ${COINS_RESOLVE_TIMEOUT:-180} s"
    fi
    out+="${out:+,}$ip:$port"
    i=$((i + 1))
  done
  echo "$out"
}

ordinal() {
  if [ -n "${COINS_ID:-}" ]; then echo "$COINS_ID"; return; fi
  local host=$HOSTNAME
  local n=${host##*-}
  if [[ $n =~ ^[0-9]+$ ]] && [ "$n" != "$host" ]; then echo "$n"; else echo "${1:-}"; fi
}

role=${1:-}
case "$role" in
  discovery | replay | learner | orchestrator | actors | all) shift ;;
  "") exec coins --help ;;
  *) exec "$@" ;;
esac

config=${COINS_CONFIG:-}
if [ -z "$config" ]; then
  config=/etc/coins/breakout.yaml
  [ -f "$config" ] || config=/opt/coins/configs/breakout.yaml
fi
[ -f "$config" ] || die "config $config not found"
run_dir=${COINS_RUN_DIR:-/data/run}

dds=()
if [ -n "${COINS_DISCOVERY:-}" ]; then
  if [ "$role" = discovery ]; then
    index=$(ordinal 0)
    own=${POD_IP:-$(resolve "$HOSTNAME")} || die "cannot tell this pod's address (set POD_IP)"
    list=$(servers "$index" "$own") || exit 2
  else
    list=$(servers) || exit 2
  fi
  dds=(--set dds.discovery=server --set "dds.discovery_server=$list")
fi

if [ "$role" = discovery ]; then
  [ ${#dds[@]} -gt 0 ] || die "discovery needs COINS_DISCOVERY"
  log "discovery server $index of $list"
  exec coins discovery-server --config "$config" --index "$index" "${dds[@]}" "$@"
fi

# the rest is one `coins run` of this pod's share
share=()
case "$role" in
  replay)
    id=$(ordinal) || true
    [ -n "$id" ] || die "replay: no shard id (set COINS_ID or run as a StatefulSet pod)"
    share=(--role replay --shard-ids "$id") ;;
  actors)
    id=$(ordinal) || true
    [ -n "$id" ] || die "actors: no actor id (set COINS_ID or run as a StatefulSet pod)"
    share=(--role actors --actor-ids "$id") ;;
  learner | orchestrator) share=(--role "$role") ;;
  all) share=() ;;
esac
[ -n "${COINS_ACTORS:-}" ] && share+=(--set "run.actors=$COINS_ACTORS")
quiet=${COINS_QUIET:-}
[ -z "$quiet" ] && { [ "$role" = orchestrator ] || [ "$role" = all ]; } && quiet=0
[ "${quiet:-1}" = 1 ] && share+=(--quiet)

done_mark=$run_dir/.coins-pod-done
idle() {
  log "$1; idle (delete $done_mark, or use a new COINS_RUN_DIR, to start again)"
  trap 'exit 0' TERM INT
  sleep infinity &
  wait $!
  exit 0
}
[ -f "$done_mark" ] && idle "this pod's part of the run in $run_dir has ended"
mkdir -p "$run_dir" || die "cannot create $run_dir"

child=0 stopping=0
trap 'stopping=1; [ "$child" -gt 0 ] && kill -TERM "$child" 2>/dev/null' TERM INT

# runs `coins run "$@"` in the background (so that the trap can forward SIGTERM) and returns its
# exit code; its stderr is also kept in $errors
errors=$(mktemp)
run() {
  log "coins run $*"
  coins run "$@" 2> >(tee "$errors" >&2) &
  child=$!
  local rc
  while :; do
    wait "$child"
    rc=$?
    # a trapped signal interrupts wait while the child still runs: wait again
    if [ $rc -gt 128 ] && kill -0 "$child" 2>/dev/null; then continue; fi
    break
  done
  child=0
  return $rc
}

# actors keep no state: always a new start. The others resume when their directory holds a run.
if [ "$role" != actors ] && [ -f "$run_dir/config.yaml" ]; then
  run --resume "$run_dir" "${share[@]}" "${dds[@]}" "$@"
  rc=$?
  # an orchestrator that never completed an epoch has nothing to resume from: a new start
  [ $rc -eq 2 ] && sleep 1  # tee may still be writing
  if [ $rc -eq 2 ] && [ $stopping -eq 0 ] && grep -q "no complete checkpoint epoch" "$errors"; then
    log "nothing to resume in $run_dir: a new start"
    run --config "$config" --dir "$run_dir" "${share[@]}" "${dds[@]}" "$@"
    rc=$?
  fi
else
  run --config "$config" --dir "$run_dir" "${share[@]}" "${dds[@]}" "$@"
  rc=$?
fi
rm -f "$errors"

[ $stopping -eq 1 ] && { log "stopped (coins run exit $rc)"; exit $rc; }
# the whole run in one container (podman run, a Job) ends with it
[ "$role" = all ] && exit $rc
if [ $rc -eq 0 ]; then
  touch "$done_mark"
  idle "coins run ended cleanly"
fi
log "coins run exit $rc; the container restarts and resumes"
exit $rc
