// Two participants of one process (an actor's node and its transition sink): they exchange
// samples like participants of two processes, and deleting either one first leaves the other
// able to delete its writers. With Fast DDS's intraprocess delivery on, a writer deleted after
// the other participant could send a gap through a dangling reader pointer (a SIGSEGV at exit,
// about one actor exit in 30 on a loaded machine); node.cc turns that delivery off for the
// process before its first participant.
#include "common/dds/node.h"

#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include <fastrtps/xmlparser/XMLProfileManager.h>

#include "common/dds/domain_lease.h"
#include "common/dds/qos.h"
#include "common/dds/topics.h"
#include "idl/statusPubSubTypes.h"

namespace coins::dds {
namespace {

using namespace std::chrono_literals;

std::unique_ptr<Node> MakeNode(int domain, const std::string& name) {
  DdsOptions o;
  o.domain = uint32_t(domain);
  auto n = Node::Create(o, name);
  EXPECT_TRUE(n.ok()) << n.status().message();
  return n.ok() ? std::move(*n) : nullptr;
}

template <class W, class R>
bool AwaitMatch(const W& writer, const R& reader, std::chrono::seconds timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < end) {
    if (writer.matched() > 0 && reader.matched() > 0) return true;
    std::this_thread::sleep_for(10ms);
  }
  return false;
}

TEST(Node, TwoParticipantsOfOneProcessTalkAndEitherMayBeDeletedFirst) {
  auto lease = DomainLease::Acquire();
  ASSERT_TRUE(lease.ok()) << lease.status().message();
  for (int round = 0; round < 6; ++round) {
    SCOPED_TRACE("round " + std::to_string(round));
    auto writer_node = MakeNode(lease->domain(), "node-test-writer");
    auto reader_node = MakeNode(lease->domain(), "node-test-reader");
    ASSERT_TRUE(writer_node && reader_node);
    auto writer = writer_node->MakeWriter<msg::ProcessHeartbeatPubSubType>(kHeartbeatTopic, StatusWriterQos());
    auto reader = reader_node->MakeReader<msg::ProcessHeartbeatPubSubType>(kHeartbeatTopic, StatusReaderQos());
    ASSERT_TRUE(writer.ok() && reader.ok());
    ASSERT_TRUE(AwaitMatch(*writer, *reader, 20s)) << "the two participants never matched";
    msg::ProcessHeartbeat sent;
    sent.name("round-" + std::to_string(round));
    sent.pid(uint32_t(1000 + round));
    writer->Write(sent);
    std::string got;
    const auto end = std::chrono::steady_clock::now() + 10s;
    while (got.empty() && std::chrono::steady_clock::now() < end) {
      reader->Wait(200ms);
      reader->TakeAll([&](const msg::ProcessHeartbeat& s, const eprosima::fastdds::dds::SampleInfo&) {
        got = s.name() + "/" + std::to_string(s.pid());
      });
    }
    EXPECT_EQ(got, sent.name() + "/" + std::to_string(1000 + round));
    // the reader's participant goes first (the actor's sink before its node), then the writer's
    if (round % 2 == 0) {
      reader_node.reset();
      writer_node.reset();
    } else {
      writer_node.reset();
      reader_node.reset();
    }
  }
  EXPECT_EQ(eprosima::fastrtps::xmlparser::XMLProfileManager::library_settings().intraprocess_delivery,
            eprosima::fastrtps::INTRAPROCESS_OFF);
}

}  // namespace
}  // namespace coins::dds
