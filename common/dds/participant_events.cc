#include "common/dds/participant_events.h"

#include <sstream>

#include <spdlog/spdlog.h>

#include "common/dds/discovery.h"

namespace coins::dds {

void ParticipantEvents::onParticipantAuthentication(eprosima::fastdds::dds::DomainParticipant*,
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

void ParticipantEvents::on_participant_discovery(eprosima::fastdds::dds::DomainParticipant*,
                                                 eprosima::fastrtps::rtps::ParticipantDiscoveryInfo&& info) {
  using Info = eprosima::fastrtps::rtps::ParticipantDiscoveryInfo;
  if (info.status != Info::DISCOVERED_PARTICIPANT || !IsServerPrefix(info.info.m_guid.guidPrefix)) return;
  {
    std::lock_guard lock(mu_);
    server_seen_ = true;
  }
  server_cv_.notify_all();
}

bool ParticipantEvents::AwaitServer(std::chrono::nanoseconds timeout) {
  std::unique_lock lock(mu_);
  return server_cv_.wait_for(lock, timeout, [&] { return server_seen_; });
}

}  // namespace coins::dds
