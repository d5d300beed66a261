// AuthenticationLog: the participant listener of a secured Node. Fast DDS reports the outcome of
// every remote participant's authentication; a refused one (no identity of the run's CA, an
// expired or foreign certificate, a failed handshake) is counted and logged with its GUID prefix,
// once per participant, so an operator can tell who knocked. Fast DDS calls it on its discovery
// threads: the counters are atomic and the seen-set is locked.
#pragma once

#include <atomic>
#include <cstdint>
#include <mutex>
#include <set>
#include <string>

#include <fastdds/dds/domain/DomainParticipantListener.hpp>

namespace coins::dds {

class AuthenticationLog : public eprosima::fastdds::dds::DomainParticipantListener {
 public:
  // `owner` names the local participant in the log lines
  explicit AuthenticationLog(std::string owner) : owner_(std::move(owner)) {}

  void onParticipantAuthentication(eprosima::fastdds::dds::DomainParticipant* participant,
                                   eprosima::fastrtps::rtps::ParticipantAuthenticationInfo&& info) override;

  // remote participants refused / authenticated so far
  uint64_t refused() const { return refused_.load(std::memory_order_relaxed); }
  uint64_t authorized() const { return authorized_.load(std::memory_order_relaxed); }

 private:
  static constexpr size_t kRemembered = 1024;  // refused participants logged one by one
  const std::string owner_;
  std::atomic<uint64_t> refused_{0};
  std::atomic<uint64_t> authorized_{0};
  std::mutex mu_;
  std::set<std::string> refused_seen_;
};

}  // namespace coins::dds
