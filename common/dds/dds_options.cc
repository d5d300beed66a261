#include "common/dds/dds_options.h"

#include "common/dds/discovery.h"

namespace coins {

Status DdsOptions::Validate() const {
  auto servers = dds::ParseServers(discovery_server);
  if (!servers.ok()) return servers.status().WithContext("discovery_server");
  if (servers->size() > 2) return Errorf("discovery_server '{}': at most a server and a backup", discovery_server);
  auto hosts = dds::ParsePeers(peers);
  if (!hosts.ok()) return hosts.status().WithContext("peers");
  if (discovery == "server" && servers->empty()) return Errorf("discovery 'server' needs a discovery_server");
  if (discovery == "peers" && hosts->empty()) return Errorf("discovery 'peers' needs the peers' addresses");
  if (!security.empty() && discovery == "server")
    return Errorf(
        "security with discovery 'server' is not supported by Fast DDS 2.9 (it came in 2.10): a secured run "
        "discovers by static peers (discovery: peers) or multicast");
  return Status::Ok();
}

}  // namespace coins
