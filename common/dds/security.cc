#include "common/dds/security.h"

#include <unistd.h>

#include <ctime>
#include <filesystem>

#include <fmt/format.h>

#include "common/dds/security_files.h"
#include "common/dds/topics.h"

namespace coins::dds {

namespace {

std::string Iso(std::time_t t) {
  char text[32];
  std::tm tm{};
  gmtime_r(&t, &tm);
  std::strftime(text, sizeof(text), "%Y-%m-%dT%H:%M:%S", &tm);
  return text;
}

std::string Topics(const std::vector<std::string>& topics) {
  std::string out;
  for (const auto& t : topics) out += fmt::format("            <topic>{}</topic>\n", t);
  return out;
}

}  // namespace

const std::vector<SecurityRole>& SecurityRoles() {
  // what each role's processes write and read, and nothing more: only the shards read
  // transitions, so an actor's key gives no copy of another actor's stream
  static const std::string status = "coins.status.*";
  static const std::vector<SecurityRole> roles = {
      {"actor",
       {kTransitionTopic, kActorStatsTopic, kHeartbeatTopic},
       {kChainCommandTopic, kChainStatusTopic, kWeightsTopic, kLearnerStatusTopic, kReplayStatsTopic}},
      {"replay",
       {kSampleReplyTopic, kReplayStatsTopic, kHeartbeatTopic},
       {kTransitionTopic, kSampleRequestTopic, kPriorityUpdateTopic, kControlTopic}},
      {"learner",
       {kWeightsTopic, kSampleRequestTopic, kPriorityUpdateTopic, kScoresTopic, kLearnerStatusTopic, kHeartbeatTopic},
       {kSampleReplyTopic, kChainCommandTopic, kControlTopic, kActorStatsTopic}},
      {"orchestrator", {kControlTopic, kChainCommandTopic, kChainStatusTopic, kHeartbeatTopic}, {status}},
      {"monitor", {}, {status}},
      {"operator", {kControlTopic, kHeartbeatTopic}, {status}},
  };
  return roles;
}

std::string IdentityOfBinary(const std::string& binary) {
  const std::string prefix = "coins-";
  if (binary.rfind(prefix, 0) != 0) return "";
  const std::string role = binary.substr(prefix.size());
  for (const auto& r : SecurityRoles())
    if (role == r.name) return role;
  return "";
}

Status ApplySecurity(const DdsOptions& options, const std::string& participant,
                     eprosima::fastdds::dds::DomainParticipantQos& qos) {
  if (options.security.empty()) return Status::Ok();
  const std::string& id = options.identity;
  bool known = false;
  for (const auto& r : SecurityRoles()) known = known || id == r.name;
  if (!known)
    return Errorf(
        "dds.security is set but participant '{}' has no identity (dds.identity: actor, replay, learner, "
        "orchestrator, monitor or operator; got '{}')",
        participant, id);
  const std::string dir = options.security;
  const std::vector<std::string> files = {"ca.pem", id + ".pem", id + ".key", "governance.p7s",
                                          id + "-permissions.p7s"};
  for (const auto& f : files)
    if (::access((dir + "/" + f).c_str(), R_OK) != 0)
      return Errorf("dds.security: {}/{} is missing or unreadable (make the directory with `coins security init {}`)",
                    dir, f, dir);
  COINS_RETURN_IF_ERROR(CheckSecurityFiles(dir, id));
  auto& p = qos.properties().properties();
  auto set = [&](const std::string& key, const std::string& value) { p.emplace_back(key, value); };
  const std::string file = "file://" + std::filesystem::absolute(dir).string() + "/";
  set("dds.sec.auth.plugin", "builtin.PKI-DH");
  set("dds.sec.auth.builtin.PKI-DH.identity_ca", file + "ca.pem");
  set("dds.sec.auth.builtin.PKI-DH.identity_certificate", file + id + ".pem");
  set("dds.sec.auth.builtin.PKI-DH.private_key", file + id + ".key");
  set("dds.sec.access.plugin", "builtin.Access-Permissions");
  set("dds.sec.access.builtin.Access-Permissions.permissions_ca", file + "ca.pem");
  set("dds.sec.access.builtin.Access-Permissions.governance", file + "governance.p7s");
  set("dds.sec.access.builtin.Access-Permissions.permissions", file + id + "-permissions.p7s");
  set("dds.sec.crypto.plugin", "builtin.AES-GCM-GMAC");
  return Status::Ok();
}

std::string PermissionsXml(const SecurityRole& role, int valid_days) {
  const std::time_t now = std::time(nullptr);
  std::string rules;
  if (!role.publishes.empty())
    rules += "        <publish>\n          <topics>\n" + Topics(role.publishes) +
             "          </topics>\n          <partitions><partition>*</partition></partitions>\n        </publish>\n";
  rules += "        <subscribe>\n          <topics>\n" + Topics(role.subscribes) +
           "          </topics>\n          <partitions><partition>*</partition></partitions>\n        </subscribe>\n";
  return fmt::format(R"(<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance">
  <permissions>
    <grant name="{0}">
      <subject_name>CN={0}, O=coins</subject_name>
      <validity>
        <not_before>{1}</not_before>
        <not_after>{2}</not_after>
      </validity>
      <allow_rule>
        <domains><id_range><min>0</min><max>232</max></id_range></domains>
{3}      </allow_rule>
      <default>DENY</default>
    </grant>
  </permissions>
</dds>
)",
                     role.name, Iso(now - 3600), Iso(now + std::time_t(valid_days) * 86400), rules);
}

std::string GovernanceXml() {
  return R"(<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance">
  <domain_access_rules>
    <domain_rule>
      <domains><id_range><min>0</min><max>232</max></id_range></domains>
      <allow_unauthenticated_participants>false</allow_unauthenticated_participants>
      <enable_join_access_control>true</enable_join_access_control>
      <discovery_protection_kind>ENCRYPT</discovery_protection_kind>
      <liveliness_protection_kind>ENCRYPT</liveliness_protection_kind>
      <rtps_protection_kind>NONE</rtps_protection_kind>
      <topic_access_rules>
        <topic_rule>
          <topic_expression>*</topic_expression>
          <enable_discovery_protection>true</enable_discovery_protection>
          <enable_liveliness_protection>true</enable_liveliness_protection>
          <enable_read_access_control>true</enable_read_access_control>
          <enable_write_access_control>true</enable_write_access_control>
          <metadata_protection_kind>ENCRYPT</metadata_protection_kind>
          <data_protection_kind>ENCRYPT</data_protection_kind>
        </topic_rule>
      </topic_access_rules>
    </domain_rule>
  </domain_access_rules>
</dds>
)";
}

}  // namespace coins::dds
