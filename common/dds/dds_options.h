// DdsOptions: the "dds" section of the config, shared by every process.
#pragma once

#include <cstdint>
#include <string>

#include "common/config/config.h"

namespace coins {

// the highest DDS domain id Fast DDS's default well-known ports can serve
inline constexpr int kMaxDdsDomain = 232;

struct DdsOptions {
  // DDS domain id; processes of one run share it, concurrent runs must differ
  int64_t domain = 0;
  // how participants find each other (common/dds/discovery.h): local (this machine only),
  // multicast, server (discovery servers at discovery_server) or peers (static peers at peers)
  std::string discovery = "local";
  // "ip:port[,ip:port]": the discovery server, then its backup
  std::string discovery_server = "127.0.0.1:11811";
  // "ip[,ip...]": the hosts of a peers-discovery cluster
  std::string peers;
  // a directory made by `coins security init` turns on DDS Security (common/dds/security.h);
  // "" runs unsecured
  std::string security;
  // the role a participant authenticates as when secured, for tools and tests: the coins processes
  // use their own (coins run and coins snapshot "operator", coins monitor "monitor" when empty)
  std::string identity;
  // shared-memory transport segment per participant, in MiB (the default 0.5 MiB throttles
  // large samples several-fold)
  int64_t shm_segment_mb = 16;
  // writer history depth, in batches, of the transition stream
  int64_t transition_history = 256;
  // seconds without discovery traffic after which a participant counts as gone
  double lease_s = 4.0;
  // seconds a process waits at start for a discovery server to answer (dds.discovery: server)
  // before it exits with an error naming the addresses
  double server_wait_s = 10.0;
  // seconds a transition writer may find its history full while its shard reports no progress
  // before the actor replaces the writer (actors/batch_sink.h)
  double writer_stall_s = 3.0;

  void Visit(ConfigVisitor& v) {
    v.Int("domain", domain, 0, kMaxDdsDomain, "DDS domain id");
    v.String("discovery", discovery, {"local", "multicast", "server", "peers"}, "discovery mode");
    v.String("discovery_server", discovery_server, {}, "ip:port of the discovery server[,ip:port of its backup]");
    v.String("peers", peers, {}, "ip[,ip...] of the hosts (discovery: peers)");
    v.String("security", security, {}, "DDS Security directory (coins security init), empty: unsecured");
    v.String("identity", identity, {}, "security role of this process (empty: its own)");
    v.Int("shm_segment_mb", shm_segment_mb, 1, 1024, "shared-memory segment size (MiB)");
    v.Int("transition_history", transition_history, 2, 4096, "transition writer history (batches)");
    v.Float("lease_s", lease_s, 0.5, 600, "participant lease duration (s)");
    v.Float("server_wait_s", server_wait_s, 0.1, 3600, "wait at start for a discovery server (s)");
    v.Float("writer_stall_s", writer_stall_s, 0.5, 3600, "stalled transition writer replaced after (s)");
  }
  // the server and peer lists parse, and a mode that needs one has it
  Status Validate() const;
};

}  // namespace coins
