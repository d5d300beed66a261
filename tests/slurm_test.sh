#!/usr/bin/env bash
# deploy/slurm/coins.sbatch for real: a private Slurm cluster on this machine (its own munged and
# key, slurmctld, and two slurmd as nodes n1 and n2 of one host, everything under a temporary
# directory and on ports of its own), then two jobs:
#   1. sbatch -N 1: the whole run on one node, 20000 steps with the chain followed; the shards'
#      final snapshots hold the 20000 transitions and the orchestrator accepted Action->Paddle.
#   2. sbatch -N 2: node 1 discovery servers, orchestrator, shards and learner, node 2 the
#      actors (random actions); node 1's shards hold the 20000 transitions node 2's actors
#      published, and the script stopped node 1 cleanly once node 2 was done.
# Needs root and Debian's slurm-wlm and munge (deploy/install-deps.sh); exits 77 (skipped)
# without them. Usage: [KEEP=1] bash tests/slurm_test.sh [BUILD_DIR]   (default: build; KEEP=1
# keeps the temporary directory)
set -euo pipefail

skip() { echo "slurm_test: skipped: $*"; exit 77; }
fail() { echo "slurm_test: FAILED: $*" >&2; exit 1; }
[ "$(id -u)" -eq 0 ] || skip "needs root"
for tool in slurmctld slurmd sbatch scontrol sinfo scancel munged mungekey flock; do
  command -v "$tool" >/dev/null || skip "$tool is missing (Debian packages slurm-wlm and munge)"
done
repo=$(cd "$(dirname "$0")/.." && pwd)
coins=$(realpath -m "${1:-$repo/build}")/bin/coins
[ -x "$coins" ] || fail "no $coins (build first)"
steps=20000
start_time=$SECONDS
# sanitizer builds run slower: job limits and the partition's time limit scale (CMake passes it)
scale=${COINS_TEST_TIME_SCALE:-1}
[[ $scale =~ ^[1-9][0-9]?$ ]] || fail "COINS_TEST_TIME_SCALE '$scale' is not a whole number from 1 to 99"

# a DDS domain of the tests' leases (common/dds/domain_lease.h), held until this script ends
locks=${COINS_DOMAIN_LOCK_DIR:-/tmp/coins-dds-domains}
mkdir -p "$locks"
domain=
for d in $(seq 120 219); do
  exec 9>"$locks/domain-$d.lock"
  if flock -n 9; then domain=$d && break; fi
done
[ -n "$domain" ] || fail "every DDS domain 120..219 is leased"
port=$((6900 + 5 * (domain - 120)))  # slurmctld, slurmd n1, slurmd n2, discovery server, backup

tmp=$(mktemp -d /tmp/coins-slurm-XXXXXX)
chmod 755 "$tmp"  # munged wants its socket's directory open to all
export SLURM_CONF=$tmp/slurm.conf

stop_pid() {  # stop_pid PIDFILE: SIGTERM, then SIGKILL after 10 s
  [ -s "$1" ] || return 0
  local pid
  pid=$(cat "$1")
  kill "$pid" 2>/dev/null || return 0
  for _ in $(seq 100); do kill -0 "$pid" 2>/dev/null || return 0; sleep 0.1; done
  kill -9 "$pid" 2>/dev/null || true
}
cleanup() {
  local code=$?
  if [ -s "$tmp/slurmctld.pid" ]; then
    scancel --user=root 2>/dev/null || true
    for _ in $(seq 60); do [ -z "$(squeue -h 2>/dev/null)" ] && break; sleep 0.5; done
  fi
  stop_pid "$tmp/slurmd-n1.pid"
  stop_pid "$tmp/slurmd-n2.pid"
  stop_pid "$tmp/slurmctld.pid"
  stop_pid "$tmp/munged.pid"
  if [ "$code" -ne 0 ] && [ "$code" -ne 77 ]; then
    for f in "$tmp"/*.out "$tmp"/*/host*.log "$tmp"/slurmctld.log; do
      [ -f "$f" ] && { echo "---- $f (end)"; tail -n 30 "$f"; }
    done
  fi
  if [ -n "${KEEP:-}" ]; then echo "slurm_test: kept $tmp"; else rm -rf "$tmp"; fi
  echo "slurm_test: $((SECONDS - start_time)) s"
}
trap cleanup EXIT

# munge with a key of its own on a socket of its own
mungekey -c -k "$tmp/munge.key"
munged -S "$tmp/munge.sock" --key-file="$tmp/munge.key" --pid-file="$tmp/munged.pid" \
  --log-file="$tmp/munged.log" --seed-file="$tmp/munged.seed" 9>&-

host=$(hostname -s)
mkdir -p "$tmp/state"
cat >"$SLURM_CONF" <<EOF
ClusterName=coinstest
SlurmctldHost=$host
SlurmctldPort=$port
SlurmUser=root
AuthType=auth/munge
AuthInfo=socket=$tmp/munge.sock
CredType=cred/munge
StateSaveLocation=$tmp/state
SlurmdSpoolDir=$tmp/spool-%n
SlurmctldPidFile=$tmp/slurmctld.pid
SlurmdPidFile=$tmp/slurmd-%n.pid
SlurmctldLogFile=$tmp/slurmctld.log
SlurmdLogFile=$tmp/slurmd-%n.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
MpiDefault=none
ReturnToService=2
KillWait=5
NodeName=n1 NodeHostname=$host NodeAddr=127.0.0.1 Port=$((port + 1)) CPUs=$(nproc) RealMemory=1000
NodeName=n2 NodeHostname=$host NodeAddr=127.0.0.1 Port=$((port + 2)) CPUs=$(nproc) RealMemory=1000
PartitionName=coins Nodes=n1,n2 Default=YES MaxTime=$((10 * scale)) State=UP
EOF
slurmctld -f "$SLURM_CONF" 9>&-
slurmd -f "$SLURM_CONF" -N n1 9>&-
slurmd -f "$SLURM_CONF" -N n2 9>&-
for _ in $(seq 60); do
  [ "$(sinfo -h -N -o '%t' 2>/dev/null | grep -c '^idle$')" -eq 2 ] && break
  sleep 0.5
done
[ "$(sinfo -h -N -o '%t' | grep -c '^idle$')" -eq 2 ] || fail "the nodes are not idle after 30 s: $(sinfo -N 2>&1)"
echo "slurm_test: cluster up (domain $domain, ports $port..$((port + 4))) after $((SECONDS - start_time)) s"

# run_job NAME SECONDS SBATCH_ARGS... -- SCRIPT_ARGS...: submits coins.sbatch, waits for the end
# (bounded) and checks that the job completed with exit code 0; the wait for a discovery server
# (10 s in breakout.yaml) scales with the test's time scale like every other window here
run_job() {
  local name=$1 limit=$(($2 * scale)) args=()
  shift 2
  while [ "$1" != -- ]; do args+=("$1") && shift; done
  shift
  local t0=$SECONDS id state=
  id=$(COINS_BIN=$coins COINS_CONFIG=$repo/deploy/configs/breakout.yaml COINS_DIR=$tmp/$name COINS_STEPS=$steps \
    COINS_DISCOVERY_PORT=$((port + 3)) sbatch --parsable -o "$tmp/$name.out" "${args[@]}" \
    "$repo/deploy/slurm/coins.sbatch" --set "dds.domain=$domain" --set "dds.server_wait_s=$((10 * scale))" "$@")
  while ((SECONDS - t0 < limit)); do
    state=$(scontrol show job -o "$id" | grep -o 'JobState=[A-Z_]*' | cut -d= -f2)
    case $state in PENDING | RUNNING | CONFIGURING | COMPLETING | SUSPENDED) sleep 0.5 ;; *) break ;; esac
  done
  local exit_code
  exit_code=$(scontrol show job -o "$id" | grep -o 'ExitCode=[0-9:]*' | cut -d= -f2)
  echo "slurm_test: job $name ($id) $state, exit code $exit_code, after $((SECONDS - t0)) s"
  if [ "$state" != COMPLETED ] || [ "$exit_code" != 0:0 ]; then
    fail "job $name: $state with exit code $exit_code (limit $limit s); $(cat "$tmp/$name.out")"
  fi
}

# the final snapshot of each shard in REPLAY_DIR: transitions held, all intact
snapshot_transitions() {
  local total=0 shard newest info
  for shard in $(find "$1" -name 'shard-*.snap' -printf '%f\n' | cut -d- -f2 | sort -u); do
    newest=$(find "$1" -name "shard-$shard-*.snap" | sort | tail -n 1)
    info=$("$coins" replay inspect "$newest") || fail "snapshot $newest: $info"
    total=$((total + $(sed -n 's/^counts .* chunks, \([0-9]*\) transitions.*/\1/p' <<<"$info")))
  done
  echo "$total"
}
# transitions the shards stored of the actors of a host's output ("actor-0: 10000 transitions
# published, 10000 stored (all stored)", or when the actor's final report did not reach the host
# "actor-0: no final report; shards stored 10000 of its transitions"); fails unless there are 2
# and each stored all it published
actors_stored() {
  awk '/^coins run: actor-[0-9]+: / {
         n++
         if ($4 == "no") { if ($9 == "none") bad = 1; s += $9 } else { if ($4 != $7) bad = 1; s += $7 }
       }
       END { if (bad || n != 2) exit 1; print s }' "$1" || fail "actor counts in $1: $(grep 'actor-' "$1")"
}
# a field of the chain state in RUN_DIR/chain/chain.json (the state's keys are indented by 2)
chain_field() {
  [ -f "$1/chain/chain.json" ] || fail "no $1/chain/chain.json"
  sed -n "s/^  \"$2\": //p" "$1/chain/chain.json" | sed 's/,$//; s/^"//; s/"$//'
}
expect() { [ "$2" = "$3" ] || fail "$1: expected $3, got '$2'"; }

# 1. one node: the whole run, chain followed
run_job one 200 -N 1 --
run=$tmp/one/host0
expect "job one: stored of the actors" "$(actors_stored "$tmp/one/host0.log")" $steps
expect "job one: transitions in the final snapshots" "$(snapshot_transitions "$run/replay")" $steps
expect "job one: chain phase" "$(chain_field "$run" phase)" training-skill
seen=$(chain_field "$run" env_steps)
((${seen:-0} >= 10000)) || fail "job one: the orchestrator saw ${seen:-no} env steps"
sed -n '/^  "links": \[/,/^  \],/p' "$run/chain/chain.json" | tr -d ' \n' | grep -q '"source":"Action","target":"Paddle"' ||
  fail "job one: no link Action->Paddle in $run/chain/chain.json"
grep -q "listening on .*:$((port + 3))" "$run/logs/discovery-0.log" || fail "job one: no discovery server"
echo "slurm_test: job one: $steps transitions stored, chain: $(chain_field "$run" note)"

# 2. two nodes: node 1 the services, node 2 the actors (random actions: fast)
run_job two 90 -N 2 -- --set actor.follow_chain=false --set replay.capacity_mb=64
head=$tmp/two/host0
grep -q 'this host runs discovery, learner, orchestrator, replay 0-1' "$tmp/two/host0.log" || fail "job two: node 1's roles"
grep -q 'this host runs actors 0-1' "$tmp/two/host1.log" || fail "job two: node 2's roles"
expect "job two: stored of the actors" "$(actors_stored "$tmp/two/host1.log")" $steps
expect "job two: transitions in node 1's final snapshots" "$(snapshot_transitions "$head/replay")" $steps
grep -q 'stopping every node: the actor nodes are done' "$tmp/two.out" || fail "job two: node 1 was not stopped by the script"
grep -q 'coins run: stopping (interrupted)' "$tmp/two/host0.log" || fail "job two: node 1 did not stop cleanly"
seen=$(chain_field "$head" env_steps) round=$(chain_field "$head" round)
((${seen:-0} >= 10000 && ${round:-0} >= 1)) || fail "job two: the orchestrator saw ${seen:-no} env steps, round ${round:-none}"
for i in 0 1; do
  grep -q "server $i of domain $domain listening on .*:$((port + 3 + i))" "$head/logs/discovery-$i.log" ||
    fail "job two: discovery server $i: $(cat "$head/logs/discovery-$i.log")"
done
echo "slurm_test: job two: $steps transitions from node 2 stored on node 1"
echo "slurm_test: passed"
