#include "common/dds/discovery.h"

#include <arpa/inet.h>

#include <chrono>
#include <memory>
#include <sstream>

#include <fastdds/rtps/transport/UDPv4TransportDescriptor.h>
#include <fastdds/rtps/transport/shared_mem/SharedMemTransportDescriptor.h>
#include <fastrtps/utils/IPLocator.h>
#include <fmt/format.h>

#include "common/dds/node.h"
#include "common/dds/participant_ids.h"

namespace coins::dds {

namespace {

using eprosima::fastdds::rtps::SharedMemTransportDescriptor;
using eprosima::fastdds::rtps::UDPv4TransportDescriptor;
using eprosima::fastrtps::rtps::DiscoveryProtocol_t;
using eprosima::fastrtps::rtps::IPLocator;
using eprosima::fastrtps::rtps::Locator_t;
using eprosima::fastrtps::rtps::RemoteServerAttributes;

// the entries of a comma-separated list, without blanks; empty entries are kept (and refused)
std::vector<std::string> Split(const std::string& list) {
  std::vector<std::string> out;
  if (list.find_first_not_of(" ") == std::string::npos) return out;
  size_t from = 0;
  for (;;) {
    size_t comma = list.find(',', from);
    std::string entry = list.substr(from, comma == std::string::npos ? std::string::npos : comma - from);
    entry.erase(0, entry.find_first_not_of(' '));
    entry.erase(entry.find_last_not_of(' ') + 1);
    out.push_back(entry);
    if (comma == std::string::npos) return out;
    from = comma + 1;
  }
}

bool IsIPv4(const std::string& ip) {
  in_addr a{};
  return ::inet_pton(AF_INET, ip.c_str(), &a) == 1;
}

Locator_t UdpLocator(const Endpoint& e) {
  Locator_t l;
  l.kind = LOCATOR_KIND_UDPv4;
  IPLocator::setIPv4(l, e.ip);
  IPLocator::setPhysicalPort(l, e.port);
  return l;
}

// the GUID prefix Fast DDS tools give server `index` ("44.53.<index>.5f.45.50.52.4f.53.49.4d.41")
std::string ServerPrefix(int index) { return fmt::format("44.53.{:02x}.5f.45.50.52.4f.53.49.4d.41", index); }

RemoteServerAttributes RemoteServer(const Endpoint& e, int index) {
  RemoteServerAttributes remote;
  remote.ReadguidPrefix(ServerPrefix(index).c_str());
  remote.metatrafficUnicastLocatorList.push_back(UdpLocator(e));
  return remote;
}

void AddTransports(const DdsOptions& options, eprosima::fastdds::dds::DomainParticipantQos& qos) {
  // shared memory with a large segment (used between participants of one host only), plus UDP
  // (loopback only in local mode)
  qos.transport().use_builtin_transports = false;
  auto shm = std::make_shared<SharedMemTransportDescriptor>();
  shm->segment_size(static_cast<uint32_t>(options.shm_segment_mb) * 1024 * 1024);
  qos.transport().user_transports.push_back(shm);
  auto udp = std::make_shared<UDPv4TransportDescriptor>();
  udp->maxInitialPeersRange = kParticipantIdLimit;
  if (options.discovery == "local") udp->interfaceWhiteList.push_back("127.0.0.1");
  qos.transport().user_transports.push_back(udp);
}

void SetLease(const DdsOptions& options, eprosima::fastdds::dds::DomainParticipantQos& qos) {
  auto& discovery = qos.wire_protocol().builtin.discovery_config;
  auto lease = std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::duration<double>(options.lease_s));
  discovery.leaseDuration = ToDuration(lease);
  discovery.leaseDuration_announcementperiod = ToDuration(lease / 4);
}

}  // namespace

Result<std::vector<Endpoint>> ParseServers(const std::string& list) {
  std::vector<Endpoint> out;
  for (const std::string& entry : Split(list)) {
    const size_t colon = entry.rfind(':');
    const std::string ip = colon == std::string::npos ? entry : entry.substr(0, colon);
    if (colon == std::string::npos || !IsIPv4(ip))
      return Errorf("'{}' is not ip:port (an IPv4 address, a colon and a port)", entry);
    const std::string port = entry.substr(colon + 1);
    if (port.empty() || port.size() > 5 || port.find_first_not_of("0123456789") != std::string::npos ||
        std::stoi(port) < 1 || std::stoi(port) > 65535)
      return Errorf("'{}': the port must be 1..65535", entry);
    out.push_back({ip, static_cast<uint16_t>(std::stoi(port))});
  }
  return out;
}

Result<std::vector<std::string>> ParsePeers(const std::string& list) {
  std::vector<std::string> out = Split(list);
  for (const std::string& ip : out)
    if (!IsIPv4(ip)) return Errorf("'{}' is not an IPv4 address", ip);
  return out;
}

Status ConfigureParticipant(const DdsOptions& options, eprosima::fastdds::dds::DomainParticipantQos& qos) {
  SetLease(options, qos);
  AddTransports(options, qos);
  auto& builtin = qos.wire_protocol().builtin;
  if (options.discovery == "server") {
    auto servers = ParseServers(options.discovery_server);
    if (!servers.ok()) return servers.status().WithContext("dds.discovery_server");
    builtin.discovery_config.discoveryProtocol = DiscoveryProtocol_t::CLIENT;
    for (size_t i = 0; i < servers->size(); ++i)
      builtin.discovery_config.m_DiscoveryServers.push_back(RemoteServer((*servers)[i], int(i)));
  } else if (options.discovery == "local") {
    // discovery and security handshakes on one UDP loopback port per participant, announced to
    // the ports of every participant id on loopback; no multicast, no shared memory (user data
    // still prefers shared memory). One metatraffic socket means one receive thread, which Fast
    // DDS 2.9.1 needs: its security manager matches a newly discovered participant's handshake
    // endpoints through scratch data that two receive threads (multicast and unicast, shared
    // memory and UDP) may fill at once, and the pair whose endpoints were mixed up never finishes
    // its handshake (seen: 2-6 of ~36 pairs of a secured run stuck for good; fixed upstream in 2.10)
    // port 0: Fast DDS fills in the participant's well-known port (each id's, as a peer)
    const Locator_t loopback = UdpLocator({"127.0.0.1", 0});
    builtin.metatrafficUnicastLocatorList.push_back(loopback);
    builtin.initialPeersList.push_back(loopback);
    builtin.avoid_builtin_multicast = true;
  } else if (options.discovery == "peers") {
    auto peers = ParsePeers(options.peers);
    if (!peers.ok()) return peers.status().WithContext("dds.peers");
    // the well-known metatraffic port of every participant id of the domain on each peer
    // port 0: Fast DDS fills in the port of each participant id (maxInitialPeersRange)
    for (const std::string& ip : *peers) builtin.initialPeersList.push_back(UdpLocator({ip, 0}));
    builtin.avoid_builtin_multicast = true;
  }
  return Status::Ok();
}

bool IsServerPrefix(const eprosima::fastrtps::rtps::GuidPrefix_t& prefix) {
  // the prefixes differ only in byte 2, the server's index
  static const eprosima::fastrtps::rtps::GuidPrefix_t server = [] {
    eprosima::fastrtps::rtps::GuidPrefix_t p;
    std::istringstream(ServerPrefix(0)) >> p;
    return p;
  }();
  for (size_t i = 0; i < eprosima::fastrtps::rtps::GuidPrefix_t::size; ++i)
    if (i != 2 && prefix.value[i] != server.value[i]) return false;
  return true;
}

Status ConfigureServer(const DdsOptions& options, int index, eprosima::fastdds::dds::DomainParticipantQos& qos) {
  auto servers = ParseServers(options.discovery_server);
  if (!servers.ok()) return servers.status().WithContext("dds.discovery_server");
  if (index < 0 || size_t(index) >= servers->size())
    return Errorf("dds.discovery_server '{}' has no server {} (it lists {})", options.discovery_server, index,
                  servers->size());
  SetLease(options, qos);
  AddTransports(options, qos);
  auto& builtin = qos.wire_protocol().builtin;
  builtin.discovery_config.discoveryProtocol = DiscoveryProtocol_t::SERVER;
  std::istringstream(ServerPrefix(index)) >> qos.wire_protocol().prefix;
  builtin.metatrafficUnicastLocatorList.push_back(UdpLocator((*servers)[size_t(index)]));
  for (size_t i = 0; i < servers->size(); ++i)
    if (int(i) != index) builtin.discovery_config.m_DiscoveryServers.push_back(RemoteServer((*servers)[i], int(i)));
  return Status::Ok();
}

}  // namespace coins::dds
