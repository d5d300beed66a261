# Sourced by the scripts of bench/cluster: network namespaces joined by a bridge stand for hosts.
#   hosts_up COUNT NET   namespaces $(host_ns 1..COUNT), host h at NET.h/24 on a veth pair into
#                        one bridge, multicast routed over that link; needs root
#   hosts_down           kills what runs in them and removes namespaces, links and bridge
#   host_ns H            the namespace of host H; host_link H the bridge side of its link
#   on_host H CMD...     runs CMD on host H with a /dev/shm of its own
# HOSTS_TAG (default: the script's pid) keeps the names of concurrent scripts apart.
HOSTS_TAG=${HOSTS_TAG:-$$}
HOSTS_COUNT=0

host_ns() { echo "coins$HOSTS_TAG-h$1"; }
host_link() { echo "cvh$HOSTS_TAG$1"; }

hosts_up() {
  HOSTS_COUNT=$1
  local net=$2 h
  ip link add "cbh$HOSTS_TAG" type bridge
  ip link set "cbh$HOSTS_TAG" up
  for ((h = 1; h <= HOSTS_COUNT; h++)); do
    ip netns add "$(host_ns $h)"
    ip link add "$(host_link $h)" type veth peer name "$(host_link $h)i"
    ip link set "$(host_link $h)i" netns "$(host_ns $h)"
    ip link set "$(host_link $h)" master "cbh$HOSTS_TAG" up
    ip netns exec "$(host_ns $h)" ip link set lo up
    ip netns exec "$(host_ns $h)" ip addr add "$net.$h/24" dev "$(host_link $h)i"
    ip netns exec "$(host_ns $h)" ip link set "$(host_link $h)i" up multicast on
    ip netns exec "$(host_ns $h)" ip route add 224.0.0.0/4 dev "$(host_link $h)i"
  done
}

hosts_down() {
  local h
  for ((h = 1; h <= HOSTS_COUNT; h++)); do
    ip netns pids "$(host_ns $h)" 2> /dev/null | xargs -r kill -9 || true
    ip netns del "$(host_ns $h)" 2> /dev/null || true
  done
  ip link del "cbh$HOSTS_TAG" 2> /dev/null || true
}

on_host() {
  local h=$1
  shift
  ip netns exec "$(host_ns "$h")" sh -c 'mount -t tmpfs tmpfs /dev/shm && exec "$@"' sh "$@"
}
