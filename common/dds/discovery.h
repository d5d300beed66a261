// How a participant finds the others (the dds.discovery modes of DdsOptions) and the discovery
// servers of a cluster.
//
//   local     - this machine only: discovery and security handshakes on one UDP loopback port
//               per participant, announced to the ports of participant ids 0..119 (no multicast);
//               data over shared memory, or UDP on 127.0.0.1
//   multicast - standard SPDP multicast on every interface (one LAN)
//   server    - discovery servers at dds.discovery_server ("ip:port[,ip:port]"): the first is the
//               primary, the second a backup; every participant is a client of all of them and
//               the servers are clients of each other, so either alone keeps the run discovering
//   peers     - static unicast initial peers at dds.peers ("ip[,ip...]"): each host sends its
//               announcements to the listed hosts (no server, no multicast)
//
// Local discovery keeps each participant's discovery traffic on one socket, hence one receive
// thread: Fast DDS 2.9.1 can leave a security handshake stalled for good when two participants
// are discovered at once on two threads (discovery.cc). The multi-host modes still listen on
// several sockets, so a secured cluster run can meet that stall (a restarted process clears it).
//
// Between hosts only UDP is used: Fast DDS offers shared memory only to participants of the same
// host. A server's GUID prefix is the well-known one of its index (the `fastdds discovery -i N`
// convention), so a Fast DDS server started by other tools can serve a run too.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <fastdds/dds/domain/qos/DomainParticipantQos.hpp>

#include "common/dds/dds_options.h"
#include "common/status.h"

namespace coins::dds {

struct Endpoint {
  std::string ip;  // IPv4, dotted
  uint16_t port = 0;
};

// "ip:port[,ip:port...]"; an error names the entry that is not one
Result<std::vector<Endpoint>> ParseServers(const std::string& list);
// "ip[,ip...]"; an error names the entry that is not an IPv4 address
Result<std::vector<std::string>> ParsePeers(const std::string& list);

// sets the transports and discovery of a participant as `options` say
Status ConfigureParticipant(const DdsOptions& options, eprosima::fastdds::dds::DomainParticipantQos& qos);
// true for the GUID prefix of a coins discovery server (any index)
bool IsServerPrefix(const eprosima::fastrtps::rtps::GuidPrefix_t& prefix);
// makes `qos` the discovery server number `index` of options.discovery_server: it listens on
// that entry's address and connects to the other servers
Status ConfigureServer(const DdsOptions& options, int index, eprosima::fastdds::dds::DomainParticipantQos& qos);

}  // namespace coins::dds
