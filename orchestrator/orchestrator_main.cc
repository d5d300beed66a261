// coins-orchestrator: runs the chain state machine (paper Algorithm 1) and publishes
// ChainStatus. At this stage the chain has one phase, collecting random-policy data; the
// detection and skill phases join as the learner grows.
#include <spdlog/spdlog.h>

#include "common/dds/heartbeat.h"
#include "common/dds/qos.h"
#include "common/dds/topics.h"
#include "common/process.h"
#include "common/run_options.h"
#include "idl/statusPubSubTypes.h"
#include "orchestrator/orchestrator_options.h"
#include "orchestrator/status_collector.h"

namespace coins {
namespace {

int OrchestratorMain(int argc, char** argv) {
  ProcessMain main("coins-orchestrator", "Runs the chain of interaction skills and publishes ChainStatus.");
  RunOptions run;
  OrchestratorOptions options;
  main.AddSection(ConfigSection::Of("run", run));
  main.AddSection(ConfigSection::Of("orchestrator", options));
  if (int rc = main.Parse(argc, argv); rc >= 0) return rc;
  if (main.name() == "coins-orchestrator") main.name() = "orchestrator";

  auto node = dds::Node::Create(main.dds(), main.name());
  if (!node.ok()) {
    spdlog::error("{}", node.status().message());
    return 1;
  }
  auto chain_writer = (*node)->MakeWriter<msg::ChainStatusPubSubType>(dds::kChainStatusTopic, dds::LatchedWriterQos());
  auto heartbeat = dds::Heartbeat::Create(**node, main.name(), "orchestrator");
  auto collector = StatusCollector::Start(**node);
  if (!chain_writer.ok() || !heartbeat.ok() || !collector.ok()) {
    spdlog::error("cannot open DDS topics: {}{}{}", chain_writer.status().message(), heartbeat.status().message(),
                  collector.status().message());
    return 1;
  }
  msg::ChainStatus chain;
  chain.schema_version(msg::STATUS_SCHEMA);
  chain.run_id(run.dir);
  chain.phase("collecting");
  auto period = std::chrono::milliseconds(static_cast<int64_t>(options.status_period_s * 1000));
  while (!SleepUnlessStopped(period)) {
    chain.env_steps((*collector)->Snapshot().total_steps());
    chain_writer->Write(chain);
    heartbeat->Publish("running");
  }
  heartbeat->Publish("stopping");
  spdlog::info("stopped at {} env steps", chain.env_steps());
  return 0;
}

}  // namespace
}  // namespace coins

int main(int argc, char** argv) { return coins::OrchestratorMain(argc, argv); }
