// ParticipantEvents: the participant listener of every Node. It hears what Fast DDS reports about
// remote participants:
//   - authentication (secured runs): a refused participant (no identity of the run's CA, an
//     expired or foreign certificate, a failed handshake) is counted and logged with its GUID
//     prefix, once per participant, so an operator can tell who knocked;
//   - discovery: whether a discovery server of this run (GUID prefix ServerPrefix) answered, so
//     a client can refuse to start when none is reachable (Node::AwaitDiscoveryServer).
// Fast DDS calls it on its own threads: counters are atomic, the rest is locked.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <set>
#include <string>

#include <fastdds/dds/domain/DomainParticipantListener.hpp>

namespace coins::dds {

class ParticipantEvents : public eprosima::fastdds::dds::DomainParticipantListener {
 public:
  // `owner` names the local participant in the log lines
  explicit ParticipantEvents(std::string owner) : owner_(std::move(owner)) {}

  void onParticipantAuthentication(eprosima::fastdds::dds::DomainParticipant* participant,
                                   eprosima::fastrtps::rtps::ParticipantAuthenticationInfo&& info) override;
  void on_participant_discovery(eprosima::fastdds::dds::DomainParticipant* participant,
                                eprosima::fastrtps::rtps::ParticipantDiscoveryInfo&& info) override;

  // remote participants refused / authenticated so far
  uint64_t refused() const { return refused_.load(std::memory_order_relaxed); }
  uint64_t authorized() const { return authorized_.load(std::memory_order_relaxed); }
  // waits up to `timeout` until a discovery server has been discovered; true when one was
  bool AwaitServer(std::chrono::nanoseconds timeout);

 private:
  static constexpr size_t kRemembered = 1024;  // refused participants logged one by one
  const std::string owner_;
  std::atomic<uint64_t> refused_{0};
  std::atomic<uint64_t> authorized_{0};
  std::mutex mu_;
  std::condition_variable server_cv_;
  bool server_seen_ = false;
  std::set<std::string> refused_seen_;
};

}  // namespace coins::dds
