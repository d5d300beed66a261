// RunRoles: which processes of a run `coins run` starts on this host (`--role`, `--actor-ids`,
// `--shard-ids`). A cluster is several hosts, each running its share of one config:
//
//   discovery     the discovery servers of dds.discovery_server whose address is this host's
//   replay        replay shards (all of run.shards, or --shard-ids)
//   learner       the learner
//   orchestrator  the orchestrator
//   actors        actors (all of run.actors, or --actor-ids)
//
// Without --role a host runs everything (and its discovery servers when dds.discovery is server).
#pragma once

#include <cstdint>
#include <set>
#include <string>
#include <vector>

#include "common/status.h"

namespace coins {

struct RunRoles {
  std::set<std::string> roles;
  std::vector<int64_t> actor_ids, shard_ids;
  bool all = true;  // no --role: the whole run on this host

  bool Has(const std::string& role) const { return roles.count(role) > 0; }
  // "replay 0-1, learner" for the start line
  std::string Describe() const;

  // role_list: "" or "replay,learner,..."; ids: "" (all), "K" or "A-B"; errors name the flag
  static Result<RunRoles> Parse(const std::string& role_list, const std::string& actor_ids,
                                const std::string& shard_ids, int64_t actors, int64_t shards, bool discovery_server);
};

// the IPv4 addresses of this host's interfaces (for the discovery servers it runs)
std::set<std::string> LocalAddresses();

}  // namespace coins
