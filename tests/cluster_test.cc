// A run across three hosts: three network namespaces on a bridge, each with its own /dev/shm, so
// the hosts share nothing but UDP. Host 3 runs the discovery servers (a server and its backup)
// and the orchestrator, host 2 the replay shard and the learner, host 1 the actors; each is one
// `coins run --role ...`. The test itself joins from the bridge as a fourth host, through the
// discovery servers, and reads every process's status over DDS. Needs root (CI runs as root).
#include <signal.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <iostream>
#include <memory>
#include <regex>
#include <sstream>

#include <fmt/format.h>

#include "common/dds/node.h"
#include "common/dds/qos.h"
#include "common/dds/topics.h"
#include "idl/controlPubSubTypes.h"
#include "orchestrator/status_collector.h"
#include "tests/process_harness.h"

namespace coins {
namespace {

using namespace coins::testing;
using namespace std::chrono_literals;
namespace fs = std::filesystem;

// three namespaces "coins<pid>-h1..3" with addresses SUBNET.1..3 on bridge "cbr<pid>" (SUBNET.254)
class Hosts {
 public:
  Hosts() : tag_(std::to_string(getpid())), subnet_("10.251." + std::to_string(getpid() % 250)) {}
  ~Hosts() {
    for (int h = 1; h <= 3; ++h) {
      KillAll(h);
      RunCommand("ip netns del " + Ns(h));
    }
    RunCommand("ip link del cbr" + tag_);
  }
  // the commands that build the hosts; "" when all of them worked, else what failed
  std::string Build() {
    std::vector<std::string> cmds = {"ip link add cbr" + tag_ + " type bridge", "ip link set cbr" + tag_ + " up",
                                     "ip addr add " + subnet_ + ".254/24 dev cbr" + tag_};
    for (int h = 1; h <= 3; ++h) {
      const std::string veth = "cv" + tag_ + "h" + std::to_string(h);
      cmds.insert(cmds.end(), {"ip netns add " + Ns(h), "ip link add " + veth + " type veth peer name " + veth + "i",
                               "ip link set " + veth + "i netns " + Ns(h), "ip link set " + veth + " master cbr" + tag_,
                               "ip link set " + veth + " up", "ip netns exec " + Ns(h) + " ip link set lo up",
                               "ip netns exec " + Ns(h) + " ip addr add " + Ip(h) + "/24 dev " + veth + "i",
                               "ip netns exec " + Ns(h) + " ip link set " + veth + "i up"});
    }
    for (const auto& c : cmds) {
      auto r = RunCommand(c, 20s);
      if (r.code != 0) return c + ": " + r.output;
    }
    return "";
  }
  std::string Ns(int h) const { return "coins" + tag_ + "-h" + std::to_string(h); }
  std::string Ip(int h) const { return subnet_ + "." + std::to_string(h); }
  std::string BridgeIp() const { return subnet_ + ".254"; }
  // starts `command` on host h with a /dev/shm of its own; output to `log`
  ChildProcess Start(int h, const std::string& command, const fs::path& log) const {
    auto c = ChildProcess::Spawn(
        Ns(h), {"/usr/sbin/ip", "netns", "exec", Ns(h), "sh", "-c", "mount -t tmpfs tmpfs /dev/shm && exec " + command},
        log.string());
    EXPECT_TRUE(c.ok()) << c.status().message();
    return std::move(*c);
  }
  // kill -9 of every process of host h
  void KillAll(int h) const { RunCommand("ip netns pids " + Ns(h) + " | xargs -r kill -9"); }

 private:
  std::string tag_, subnet_;
};

// transitions the shards stored of `actor`, as their last ReplayStats say
uint64_t StoredOf(const StatusView& v, uint32_t actor) {
  uint64_t n = 0;
  for (const auto& [id, s] : v.shards)
    for (const auto& a : s.sample.actors())
      if (a.actor_id() == actor) n += a.transitions();
  return n;
}

TEST(Cluster, ThreeHostsStoreEveryTransitionOnceAndSurviveTheLossOfTheActorHost) {
  if (geteuid() != 0) GTEST_SKIP() << "network namespaces need root";
  Hosts hosts;
  if (std::string failed = hosts.Build(); !failed.empty()) FAIL() << "cannot build the hosts: " << failed;
  const fs::path dir = TempDir("cluster");
  const int domain = TestDomain();
  const std::string servers = hosts.Ip(3) + ":11811," + hosts.Ip(3) + ":11812";
  const std::string common = Bin("coins") +
                             " run --quiet --actors 2 --shards 1 --set dds.domain=" + std::to_string(domain) +
                             " --set dds.discovery=server --set dds.discovery_server=" + servers +
                             " --set actor.follow_chain=false --set replay.capacity_mb=64"
                             " --set actor.status_period_s=0.2 --set replay.status_period_s=0.2";
  auto on = [&](int h) { return common + " --dir " + (dir / ("host" + std::to_string(h))).string(); };
  ChildProcess h3 = hosts.Start(3, on(3) + " --steps 0 --role discovery,orchestrator", dir / "host3.log");
  ChildProcess h2 = hosts.Start(2, on(2) + " --steps 0 --role replay,learner", dir / "host2.log");

  // the test joins as a fourth host, from the bridge
  DdsOptions o;
  o.domain = domain;
  o.discovery = "server";
  o.discovery_server = servers;
  auto node = dds::Node::Create(o, "cluster-test");
  ASSERT_TRUE(node.ok()) << node.status().message();
  auto collector = StatusCollector::Start(**node);
  ASSERT_TRUE(collector.ok()) << collector.status().message();
  ASSERT_TRUE(WaitUntil([&] { return (*collector)->Snapshot().shards.count(0) > 0; }, 60s))
      << "the shard on host 2 was not seen from the bridge; host 2:\n"
      << ReadText(dir / "host2.log") << "\nhost 3:\n"
      << ReadText(dir / "host3.log");

  // 1. a step budget: the actor host ends by itself once the shard on host 2 holds everything
  auto first = RunCommand("ip netns exec " + hosts.Ns(1) + " sh -c 'mount -t tmpfs tmpfs /dev/shm && exec " + on(1) +
                              " --steps 40000 --role actors'",
                          180s);
  ASSERT_EQ(first.code, 0) << first.output;
  for (int a = 0; a < 2; ++a)
    EXPECT_TRUE(std::regex_search(
        first.output,
        std::regex("actor-" + std::to_string(a) + R"(: (\d+) transitions published, \1 stored \(all stored\))")))
        << first.output;
  // exactly once: per actor, the shard's count and payload checksum are the actor's own
  StatusView v = (*collector)->Snapshot();
  for (uint32_t a = 0; a < 2; ++a) {
    ASSERT_TRUE(v.actors.count(a)) << "no status of actor " << a;
    const auto& sent = v.actors.at(a).sample;
    EXPECT_GE(sent.transitions_published(), 20000u);
    bool found = false;
    for (const auto& [id, s] : v.shards)
      for (const auto& got : s.sample.actors())
        if (got.actor_id() == a) {
          found = true;
          EXPECT_EQ(got.transitions(), sent.transitions_published()) << "actor " << a;
          EXPECT_EQ(got.payload_checksum(), sent.payload_checksum()) << "actor " << a;
        }
    EXPECT_TRUE(found) << "the shard has no ledger of actor " << a;
  }

  // 2. the actor host runs unbounded, loses every process at once (kill -9), and is started
  // again: the shard takes the restarted actors' data and hosts 2 and 3 never noticed
  ChildProcess h1 = hosts.Start(1, on(1) + " --steps 0 --role actors", dir / "host1.log");
  const uint64_t before = StoredOf((*collector)->Snapshot(), 0);
  ASSERT_TRUE(WaitUntil([&] { return StoredOf((*collector)->Snapshot(), 0) > before + 5000; }, 60s))
      << ReadText(dir / "host1.log");
  hosts.KillAll(1);
  ASSERT_TRUE(h1.WaitFor(Scaled(10s)));
  std::this_thread::sleep_for(1s);
  const uint64_t at_kill = StoredOf((*collector)->Snapshot(), 0);
  const auto restarted = std::chrono::steady_clock::now();
  ChildProcess again = hosts.Start(1, on(1) + " --steps 0 --role actors", dir / "host1-again.log");
  // rejoined: the restarted actors' first data is stored on host 2
  ASSERT_TRUE(WaitUntil([&] { return StoredOf((*collector)->Snapshot(), 0) > at_kill; }, 60s))
      << "the restarted actors' data did not reach host 2: " << ReadText(dir / "host1-again.log");
  const double rejoin_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - restarted).count();
  std::cout << "host 1 rejoined " << rejoin_s << " s after its restart (first data stored on host 2)\n";
  RecordProperty("rejoin_s", std::to_string(rejoin_s));
  EXPECT_TRUE(WaitUntil([&] { return StoredOf((*collector)->Snapshot(), 0) > at_kill + 5000; }, 60s))
      << "the restarted actors' data stopped: " << ReadText(dir / "host1-again.log");
  EXPECT_FALSE(h2.Poll()) << "host 2 ended: " << ReadText(dir / "host2.log");
  EXPECT_FALSE(h3.Poll()) << "host 3 ended: " << ReadText(dir / "host3.log");

  // a clean stop, actor host first: every host's `coins run` ends with 0
  for (ChildProcess* p : {&again, &h2, &h3}) {
    p->Signal(SIGTERM);
    EXPECT_TRUE(p->WaitFor(90s)) << p->Describe();
    EXPECT_TRUE(p->succeeded()) << p->Describe();
  }
  for (int server = 0; server < 2; ++server) {
    const std::string log = ReadText(dir / "host3" / "logs" / fmt::format("discovery-{}.log", server));
    EXPECT_NE(
        log.find(fmt::format("server {} of domain {} listening on {}:{}", server, domain, hosts.Ip(3), 11811 + server)),
        std::string::npos)
        << log;
  }
}

// frames seen on `iface` for `seconds` and how many hold `marker` (a python3 raw-socket capture,
// started as a child: call Finish after the traffic)
class Capture {
 public:
  Capture(const std::string& iface, const std::string& marker, int seconds, const fs::path& out) : out_(out) {
    const std::string script = fmt::format(
        "import socket, time\n"
        "s = socket.socket(socket.AF_PACKET, socket.SOCK_RAW, socket.ntohs(3))\n"
        "s.bind(('{}', 0)); s.settimeout(0.2)\n"
        "end = time.time() + {}; frames = found = 0\n"
        "while time.time() < end:\n"
        "    try: d = s.recv(65535)\n"
        "    except socket.timeout: continue\n"
        "    frames += 1; found += b'{}' in d\n"
        "print(frames, found)\n",
        iface, seconds, marker);
    auto c = ChildProcess::Spawn("capture", {"/usr/bin/python3", "-c", script}, out.string());
    EXPECT_TRUE(c.ok()) << c.status().message();
    child_ = std::move(*c);
  }
  // (frames, frames holding the marker)
  std::pair<int, int> Finish() {
    EXPECT_TRUE(child_.WaitFor(Scaled(60s)));
    int frames = -1, found = -1;
    std::istringstream(ReadText(out_)) >> frames >> found;
    return {frames, found};
  }

 private:
  fs::path out_;
  ChildProcess child_;
};

// an operator on the bridge sends Control commands carrying a marker to a shard on host 2, with
// static-peer discovery; returns (frames captured on the bridge, frames holding the marker)
std::pair<int, int> SendMarkedCommands(const Hosts& hosts, const fs::path& dir, const std::string& security,
                                       const std::string& marker) {
  const int domain = TestDomain();
  const std::string peers = hosts.Ip(2) + "," + hosts.BridgeIp();
  std::string shard_cmd = Bin("coins-replay") +
                          " --name replay-0 --id 0 --quiet-config --set dds.domain=" + std::to_string(domain) +
                          " --set dds.discovery=peers --set dds.peers=" + peers + " --set replay.capacity_mb=16";
  if (!security.empty()) shard_cmd += " --set dds.security=" + security;
  const fs::path shard_log = dir / ("shard-" + std::to_string(domain) + ".log");
  ChildProcess shard = hosts.Start(2, shard_cmd, shard_log);
  DdsOptions o;
  o.domain = domain;
  o.discovery = "peers";
  o.peers = peers;
  if (!security.empty()) o.security = security, o.identity = "operator";
  auto node = dds::Node::Create(o, "cluster-operator");
  EXPECT_TRUE(node.ok()) << node.status().message();
  if (!node.ok()) return {-1, -1};
  auto w = (*node)->MakeWriter<msg::ControlPubSubType>(dds::kControlTopic, dds::CommandWriterQos());
  EXPECT_TRUE(w.ok()) << w.status().message();
  if (!w.ok()) return {-1, -1};
  EXPECT_TRUE(WaitUntil([&] { return w->matched() > 0; }, 30s)) << ReadText(shard_log);
  Capture capture("cbr" + std::to_string(getpid()), marker, 4, dir / ("capture-" + std::to_string(domain) + ".txt"));
  std::this_thread::sleep_for(500ms);  // the capture is listening
  msg::Control c;
  c.schema_version(msg::CONTROL_SCHEMA);
  c.target("nobody");  // no process acts on it
  c.command(msg::CONTROL_SNAPSHOT);
  c.argument(marker);
  for (int i = 0; i < 20; ++i) {
    c.command_id(uint64_t(i + 1));
    w->Write(c);
    std::this_thread::sleep_for(100ms);
  }
  auto seen = capture.Finish();
  shard.Signal(SIGTERM);
  shard.WaitFor(Scaled(20s));
  return seen;
}

TEST(Cluster, SecuredTrafficBetweenHostsHoldsNoPlaintext) {
  if (geteuid() != 0) GTEST_SKIP() << "network namespaces need root";
  Hosts hosts;
  if (std::string failed = hosts.Build(); !failed.empty()) FAIL() << "cannot build the hosts: " << failed;
  const fs::path dir = TempDir("cluster-secured");
  const std::string marker = "coins-plaintext-marker-" + std::to_string(getpid());
  // unsecured, the capture sees the marker: it would see a leak
  auto [plain_frames, plain_found] = SendMarkedCommands(hosts, dir, "", marker);
  EXPECT_GT(plain_frames, 0);
  EXPECT_GT(plain_found, 0) << "the capture did not see plaintext traffic";
  // secured, the same commands cross the bridge encrypted
  auto init = RunCommand(Bin("coins") + " security init " + (dir / "security").string());
  ASSERT_EQ(init.code, 0) << init.output;
  auto [frames, found] = SendMarkedCommands(hosts, dir, (dir / "security").string(), marker);
  EXPECT_GT(frames, 0);
  EXPECT_EQ(found, 0) << "the marker crossed the bridge in plaintext";
}

}  // namespace
}  // namespace coins
