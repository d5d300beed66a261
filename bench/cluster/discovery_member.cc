// coins-discovery-member: one participant of the discovery benchmark
// (bench/cluster/discovery.sh). It joins the domain with the dds section's discovery, writes one
// latched sample on a benchmark topic and reads the topic; when its reader has matched the
// writers of all --members participants it prints
//   all_matched_s <seconds since the process started> <unix time>
// and stays until SIGTERM (others may still be matching it) or --wait-s passes.
#include <chrono>
#include <cstdio>
#include <thread>

#include <spdlog/spdlog.h>

#include "common/dds/qos.h"
#include "common/process.h"
#include "idl/statusPubSubTypes.h"

namespace coins {
namespace {

constexpr char kTopic[] = "coins.bench.discovery";

int Member(int argc, char** argv) {
  const auto start = std::chrono::steady_clock::now();
  ProcessMain main("coins-discovery-member", "One participant of the discovery benchmark.");
  int64_t members = 2;
  double wait_s = 120;
  main.app().add_option("--members", members, "participants to match, this one included")->check(CLI::Range(1, 1000));
  main.app().add_option("--wait-s", wait_s, "give up (exit 1) after this many seconds")->check(CLI::Range(1.0, 3600.0));
  if (int rc = main.Parse(argc, argv); rc >= 0) return rc;
  auto node = main.OpenNode("bench");
  if (!node.ok()) return ExitWithError(node.status(), 1);
  auto writer = node->node->MakeWriter<msg::ProcessHeartbeatPubSubType>(kTopic, dds::LatchedWriterQos());
  auto reader = node->node->MakeReader<msg::ProcessHeartbeatPubSubType>(kTopic, dds::LatchedReaderQos());
  if (!writer.ok() || !reader.ok()) return ExitWithError(Errorf("cannot open the benchmark topic"), 1);
  msg::ProcessHeartbeat me;
  me.name(main.name());
  writer->Write(me);
  const auto deadline = start + std::chrono::duration<double>(wait_s);
  bool reported = false;
  while (!StopRequested() && std::chrono::steady_clock::now() < deadline) {
    if (!reported && reader->matched() >= members) {
      const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      const double unix_s = std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
      std::printf("all_matched_s %.3f %.3f\n", s, unix_s);
      std::fflush(stdout);
      reported = true;
    }
    reader->TakeAll([](const msg::ProcessHeartbeat&, const auto&) {});
    std::this_thread::sleep_for(std::chrono::milliseconds(reported ? 100 : 10));
  }
  if (!reported) spdlog::error("{}: matched {} of {} writers in {} s", main.name(), reader->matched(), members, wait_s);
  return reported ? 0 : 1;
}

}  // namespace
}  // namespace coins

int main(int argc, char** argv) { return coins::Member(argc, argv); }
