// The discovery settings of DdsOptions: server and peer lists, and participants that find each
// other through static peers only.
#include "common/dds/discovery.h"

#include <gtest/gtest.h>

#include <thread>

#include "common/dds/domain_lease.h"
#include "common/dds/node.h"
#include "common/dds/qos.h"
#include "idl/statusPubSubTypes.h"

namespace coins::dds {
namespace {

TEST(Discovery, ServerListsParse) {
  auto s = ParseServers("10.0.0.3:11811, 10.0.0.4:11812");
  ASSERT_TRUE(s.ok()) << s.status().message();
  ASSERT_EQ(s->size(), 2u);
  EXPECT_EQ((*s)[0].ip, "10.0.0.3");
  EXPECT_EQ((*s)[0].port, 11811);
  EXPECT_EQ((*s)[1].ip, "10.0.0.4");
  EXPECT_EQ((*s)[1].port, 11812);
  EXPECT_TRUE(ParseServers("")->empty());
}

TEST(Discovery, BadServerEntriesAreNamed) {
  for (const char* bad : {"server:11811", "10.0.0.3", "10.0.0.3:0", "10.0.0.3:70000", "10.0.0.3:", "10.0.0.3:1x",
                          "10.0.0.3:11811,", "1.2.3:11811"}) {
    auto s = ParseServers(bad);
    EXPECT_FALSE(s.ok()) << bad;
    if (!s.ok()) {
      EXPECT_NE(s.status().message().find('\''), std::string::npos) << s.status().message();
    }
  }
  auto p = ParsePeers("10.0.0.1,host2");
  ASSERT_FALSE(p.ok());
  EXPECT_EQ(p.status().message(), "'host2' is not an IPv4 address");
}

TEST(Discovery, OptionsNeedTheListOfTheirMode) {
  DdsOptions o;
  EXPECT_TRUE(o.Validate().ok());
  o.discovery = "peers";
  EXPECT_FALSE(o.Validate().ok());
  o.peers = "127.0.0.1";
  EXPECT_TRUE(o.Validate().ok());
  o.discovery = "server";
  o.discovery_server = "10.0.0.1:1,10.0.0.2:2,10.0.0.3:3";
  auto s = o.Validate();
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("at most a server and a backup"), std::string::npos) << s.message();
}

TEST(Discovery, ServerIndexOutOfTheListIsRefused) {
  DdsOptions o;
  eprosima::fastdds::dds::DomainParticipantQos qos;
  auto s = ConfigureServer(o, 1, qos);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("has no server 1"), std::string::npos) << s.message();
}

// two participants that know each other only as static peers (no multicast, no server) match
TEST(Discovery, ParticipantsFindEachOtherThroughStaticPeers) {
  auto lease = DomainLease::Acquire();
  ASSERT_TRUE(lease.ok()) << lease.status().message();
  DdsOptions o;
  o.domain = lease->domain();
  o.discovery = "peers";
  o.peers = "127.0.0.1";
  auto a = Node::Create(o, "peers-a");
  auto b = Node::Create(o, "peers-b");
  ASSERT_TRUE(a.ok() && b.ok());
  auto w = (*a)->MakeWriter<msg::ProcessHeartbeatPubSubType>("peers_test", StatusWriterQos());
  auto r = (*b)->MakeReader<msg::ProcessHeartbeatPubSubType>("peers_test", StatusReaderQos());
  ASSERT_TRUE(w.ok() && r.ok());
  auto end = std::chrono::steady_clock::now() + std::chrono::seconds(15);
  while ((w->matched() == 0 || r->matched() == 0) && std::chrono::steady_clock::now() < end)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  EXPECT_EQ(w->matched(), 1);
  EXPECT_EQ(r->matched(), 1);
}

// a client refuses to go on without its discovery server, naming it, and joins once it answers
TEST(Discovery, AClientWaitsForItsServerAndNamesOneThatDoesNotAnswer) {
  auto lease = DomainLease::Acquire();
  ASSERT_TRUE(lease.ok()) << lease.status().message();
  DdsOptions o;
  o.domain = lease->domain();
  o.discovery = "server";
  o.discovery_server = "127.0.0.1:" + std::to_string(21000 + lease->domain());
  o.server_wait_s = 0.5;
  auto alone = Node::Join(o, "client-alone");
  ASSERT_FALSE(alone.ok());
  EXPECT_EQ(alone.status().message(),
            "dds: no discovery server answered at " + o.discovery_server + " (dds.discovery_server) within 0.5 s");
  auto server = Node::CreateDiscoveryServer(o, 0);
  ASSERT_TRUE(server.ok()) << server.status().message();
  EXPECT_TRUE(IsServerPrefix((*server)->participant()->guid().guidPrefix));
  o.server_wait_s = 15;
  auto client = Node::Join(o, "client");
  ASSERT_TRUE(client.ok()) << client.status().message();
  EXPECT_FALSE(IsServerPrefix((*client)->participant()->guid().guidPrefix));
}

}  // namespace
}  // namespace coins::dds
