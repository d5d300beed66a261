// DDS Security for a run (Fast DDS builtin plugins: PKI-DH authentication, Access-Permissions,
// AES-GCM-GMAC encryption).
//
// `coins security init DIR` writes into DIR:
//   ca.pem, ca.key                 the run's certificate authority (identities and permissions)
//   governance.xml, governance.p7s the domain rules, signed by the CA: participants without a
//                                  valid identity are refused, discovery and liveliness are
//                                  encrypted, every topic's data and metadata too, and reads and
//                                  writes are checked against the permissions
//   ROLE.pem, ROLE.key             one identity per role (subject "CN=ROLE, O=coins")
//   ROLE-permissions.xml/.p7s      what ROLE may publish and subscribe, signed by the CA
// With dds.security: DIR a participant authenticates as its role (dds.identity; the coins
// processes set their own) and may write and read only its role's topics (SecurityRoles). Fast DDS 2.9 cannot
// secure a run that discovers through a discovery server (that came in 2.10): a secured cluster
// discovers by static peers (dds.discovery: peers) or multicast, and the combination is refused.
#pragma once

#include <string>
#include <vector>

#include <fastdds/dds/domain/qos/DomainParticipantQos.hpp>

#include "common/dds/dds_options.h"
#include "common/status.h"

namespace coins::dds {

struct SecurityRole {
  const char* name;
  std::vector<std::string> publishes;   // topics it may write
  std::vector<std::string> subscribes;  // topic patterns it may read
};

// actor, replay, learner, orchestrator, monitor (reads status only), operator (a person or tool
// that may stop a run: writes Control, reads status). Each reads only the topics its process
// takes: only shards read transitions, only the learner reads samples.
const std::vector<SecurityRole>& SecurityRoles();

// the identity of the coins process `binary` ("coins-actor" -> "actor"), or "" for others
std::string IdentityOfBinary(const std::string& binary);

// nothing without options.security; else the security plugins with options.identity's files
Status ApplySecurity(const DdsOptions& options, const std::string& participant,
                     eprosima::fastdds::dds::DomainParticipantQos& qos);

// the permissions document of a role (XML, unsigned) for domains [0, 232]
std::string PermissionsXml(const SecurityRole& role, int valid_days);
// the governance document (XML, unsigned)
std::string GovernanceXml();

}  // namespace coins::dds
