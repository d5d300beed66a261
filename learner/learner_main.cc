// coins-learner: trains the interaction detectors, the skills and the task policy from replay
// samples, and publishes their weights. At this stage it joins the run, reports a heartbeat
// and follows the replay shards' fill; training joins with the chain.
#include <spdlog/spdlog.h>

#include "common/dds/heartbeat.h"
#include "common/dds/qos.h"
#include "common/dds/topics.h"
#include "common/process.h"
#include "common/run_options.h"
#include "idl/statusPubSubTypes.h"
#include "learner/learner_options.h"

namespace coins {
namespace {

int LearnerMain(int argc, char** argv) {
  ProcessMain main("coins-learner", "Trains detectors, skills and the task policy from replay samples.");
  RunOptions run;
  LearnerOptions options;
  main.AddSection(ConfigSection::Of("run", run));
  main.AddSection(ConfigSection::Of("learner", options));
  if (int rc = main.Parse(argc, argv); rc >= 0) return rc;
  if (main.name() == "coins-learner") main.name() = "learner";

  auto node = dds::Node::Create(main.dds(), main.name());
  if (!node.ok()) {
    spdlog::error("{}", node.status().message());
    return 1;
  }
  auto heartbeat = dds::Heartbeat::Create(**node, main.name(), "learner");
  auto shards = (*node)->MakeReader<msg::ReplayStatsPubSubType>(dds::kReplayStatsTopic, dds::StatusReaderQos());
  if (!heartbeat.ok() || !shards.ok()) {
    spdlog::error("cannot open DDS topics: {}{}", heartbeat.status().message(), shards.status().message());
    return 1;
  }
  std::map<uint32_t, uint64_t> sizes;
  auto period = std::chrono::milliseconds(static_cast<int64_t>(options.status_period_s * 1000));
  while (!SleepUnlessStopped(period)) {
    shards->TakeAll([&](const msg::ReplayStats& s, const auto&) { sizes[s.shard_id()] = s.size(); });
    heartbeat->Publish("running");
  }
  uint64_t total = 0;
  for (const auto& [id, n] : sizes) total += n;
  heartbeat->Publish("stopping");
  spdlog::info("stopped; replay held {} transitions over {} shards", total, sizes.size());
  return 0;
}

}  // namespace
}  // namespace coins

int main(int argc, char** argv) { return coins::LearnerMain(argc, argv); }
