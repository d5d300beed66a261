#!/usr/bin/env bash
# A run of the deploy/k8s manifests on this machine, without a cluster: podman kube play of the
# file deploy/k8s/podman-play.py makes from them (8 pods: 2 discovery servers, 2 replay shards,
# learner, orchestrator, 2 actors, each pod with its own network namespace on an internal podman
# network, so the pods share nothing but UDP, as in a cluster). Passes when both actor pods end
# with every transition stored by the shards of other pods and the orchestrator saw both actors
# and the chain's first link; then removes the pods, volumes and network.
#
# Usage, as root, after deploy/image/build.sh:
#   deploy/k8s/podman-test.sh [--steps N] [--image NAME] [--keep]
#     --steps  run.steps (default 20000: 10000 per actor, the first detect round at 10000)
#     --keep   leave the pods running (podman kube down FILE removes them; the file is printed)
# Needs podman and runc (apt-get install podman runc). Where podman's defaults do not work (no
# CAP_SYS_RESOURCE, a hybrid cgroup v1/v2 layout) it runs with a containers.conf of its own:
# the machine's file limits, runc.
set -euo pipefail

here=$(cd "$(dirname "$0")" && pwd)
steps=20000
image=localhost/coins:latest
keep=0
while [ $# -gt 0 ]; do
  case "$1" in
    --steps) steps=$2; shift 2 ;;
    --image) image=$2; shift 2 ;;
    --keep) keep=1; shift ;;
    *) echo "podman-test.sh: unknown argument $1" >&2; exit 2 ;;
  esac
done
[ "$(id -u)" -eq 0 ] || { echo "podman-test.sh: run as root" >&2; exit 2; }
podman image exists "$image" || { echo "podman-test.sh: no image $image (deploy/image/build.sh)" >&2; exit 2; }

work=$(mktemp -d /tmp/coins-podman-test.XXXXXX)
conf=$work/containers.conf
{
  echo "[containers]"
  # containers may not raise a limit above podman's own without CAP_SYS_RESOURCE
  echo "default_ulimits = [\"nofile=$(ulimit -Hn):$(ulimit -Hn)\", \"nproc=$(($(ulimit -Hu) < 32768 ? $(ulimit -Hu) : 32768)):$(($(ulimit -Hu) < 32768 ? $(ulimit -Hu) : 32768))\"]"
  # crun refuses a hybrid cgroup layout (v1 controllers beside a v2 mount); runc takes it
  if [ -d /sys/fs/cgroup/unified ] && command -v runc >/dev/null; then printf '[engine]\nruntime = "runc"\n'; fi
} > "$conf"
export CONTAINERS_CONF=$conf

network=coins-k8s-test
play=$work/play.yaml
/usr/bin/python3 "$here/podman-play.py" --image "$image" --set "run.steps=$steps" > "$play"
passed=0 failed=0
ok() { echo "ok: $*"; passed=$((passed + 1)); }
fail() { echo "FAIL: $*"; failed=$((failed + 1)); }
cleanup() {
  if [ $keep -eq 1 ]; then
    echo "podman-test.sh: pods left running; remove them with CONTAINERS_CONF=$conf podman kube down $play"
    return
  fi
  podman kube down "$play" > /dev/null 2>&1 || true
  /usr/bin/python3 -c 'import sys, yaml
for d in yaml.safe_load_all(open(sys.argv[1])):
    if d and d["kind"] in ("PersistentVolumeClaim", "ConfigMap"): print(d["metadata"]["name"])' "$play" |
    xargs -r podman volume rm -f > /dev/null 2>&1 || true
  podman network rm -f "$network" > /dev/null 2>&1 || true
  rm -rf "$work"
}
trap cleanup EXIT

podman network exists "$network" || podman network create --internal "$network" > /dev/null
if podman kube play --network "$network" "$play" > "$work/play.log" 2>&1; then
  ok "podman kube play started $(podman pod ps --filter "network=$network" -q | wc -l) pods"
else
  fail "podman kube play: $(grep -v '^[0-9a-f]\{64\}$' "$work/play.log" | tail -3)"
  exit 1
fi

logs() { podman logs "$1" 2>&1; }
deadline=$((SECONDS + 240 + steps / 100))
for a in 0 1; do
  until grep -q "coins-pod: coins run ended cleanly\|coins run exit" <<< "$(logs "coins-actor-$a-actor")"; do
    [ $SECONDS -lt $deadline ] || break
    sleep 5
  done
  line=$(logs "coins-actor-$a-actor" | grep "actor-$a: .* transitions published" || true)
  if [[ $line =~ actor-$a:\ ([0-9]+)\ transitions\ published,\ ([0-9]+)\ stored\ \(all\ stored\) ]] &&
    [ "${BASH_REMATCH[1]}" -gt 0 ]; then
    ok "$line"
  else
    fail "actor pod $a: ${line:-no final count}"
  fi
done
for s in 0 1; do
  line=$(logs "coins-discovery-$s-discovery" | grep "listening on" || true)
  [ -n "$line" ] && ok "$line" || fail "discovery server $s did not start"
done
progress() { logs coins-orchestrator-orchestrator | grep '^\[' | tail -1; }
until [[ $(progress) == *"Action->Paddle"* ]] || [ $SECONDS -ge $deadline ]; do sleep 5; done
progress=$(progress)
[[ $progress == *"2/2 actors"* ]] && ok "orchestrator saw both actors" || fail "orchestrator: $progress"
[[ $progress == *"Action->Paddle"* ]] && ok "the chain found Action->Paddle: ${progress##*| chain }" ||
  fail "no link found: $progress"
# coins monitor from inside a pod, through the discovery servers (the pod's effective config)
shards=$(podman exec coins-orchestrator-orchestrator coins monitor --config /data/run/config.yaml --seconds 3 --json \
  2> /dev/null | /usr/bin/python3 -c 'import json, sys; print(len(json.load(sys.stdin)["shards"]))' 2> /dev/null || true)
[ "$shards" = 2 ] && ok "coins monitor in the orchestrator pod sees 2 shards" || fail "coins monitor: ${shards:-no view}"
echo "$passed passed, $failed failed"
[ $failed -eq 0 ]
