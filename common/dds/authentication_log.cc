#include "common/dds/authentication_log.h"

#include <sstream>

#include <spdlog/spdlog.h>

namespace coins::dds {

void AuthenticationLog::onParticipantAuthentication(eprosima::fastdds::dds::DomainParticipant*,
                                                    eprosima::fastrtps::rtps::ParticipantAuthenticationInfo&& info) {
  using Info = eprosima::fastrtps::rtps::ParticipantAuthenticationInfo;
  if (info.status == Info::AUTHORIZED_PARTICIPANT) {
    authorized_.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  const uint64_t n = refused_.fetch_add(1, std::memory_order_relaxed) + 1;
  std::ostringstream guid;
  guid << info.guid.guidPrefix;
  std::lock_guard lock(mu_);
  if (refused_seen_.size() >= kRemembered || !refused_seen_.insert(guid.str()).second) return;
  spdlog::warn("dds security: {} refused participant {}: authentication failed ({} refusals so far)", owner_,
               guid.str(), n);
}

}  // namespace coins::dds
