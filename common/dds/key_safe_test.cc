// Keys of a keyed type computed from two threads at once through one type object, as a
// participant does for a topic it both writes and reads (heartbeats in the orchestrator): every
// handle must be the one a lone thread computes. The generated getKey alone shares its key
// buffer and MD5 state between the threads.
#include <gtest/gtest.h>

#include <atomic>
#include <thread>

#include "common/dds/node.h"
#include "idl/statusPubSubTypes.h"

namespace coins::dds {
namespace {

using eprosima::fastrtps::rtps::InstanceHandle_t;

// wrong handles among `rounds` keys computed by each of two threads at once
template <typename Type>
int Mismatches(Type& type, int rounds) {
  std::atomic<int> wrong{0};
  auto worker = [&](const std::string& prefix) {
    std::vector<msg::ProcessHeartbeat> samples(8);
    std::vector<InstanceHandle_t> expected(samples.size());
    for (size_t i = 0; i < samples.size(); ++i) {
      samples[i].name(prefix + std::to_string(i) + std::string(40, 'x'));
      msg::ProcessHeartbeatPubSubType lone;  // a type object of its own: no sharing
      lone.getKey(&samples[i], &expected[i], false);
    }
    for (int r = 0; r < rounds; ++r) {
      size_t i = size_t(r) % samples.size();
      InstanceHandle_t h;
      type.getKey(&samples[i], &h, false);
      if (!(h == expected[i])) wrong++;
    }
  };
  std::thread a(worker, "writer-"), b(worker, "reader-");
  a.join();
  b.join();
  return wrong.load();
}

TEST(KeySafeType, KeysFromTwoThreadsAtOnceAreTheSingleThreadedOnes) {
  KeySafeType<msg::ProcessHeartbeatPubSubType> type;
  EXPECT_EQ(Mismatches(type, 200000), 0);
}

}  // namespace
}  // namespace coins::dds
