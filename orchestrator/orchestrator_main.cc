// coins-orchestrator: runs the chain state machine (paper Algorithm 1, chain_machine.h) over DDS
// (chain_adapter.h): publishes ChainCommand and ChainStatus, reads InteractionScores,
// LearnerStatus, ActorStats and ReplayStats, cuts checkpoint epochs, and persists its state in
// RUN_DIR/chain. A restarted orchestrator continues from chain.json; --resume-epoch N continues
// from chain-epoch-N.json. A corrupt state file or one of another config stops it at start with
// one line, and the file is left as it is.
#include <spdlog/spdlog.h>

#include <filesystem>

#include "actors/envs/env.h"
#include "common/dds/heartbeat.h"
#include "common/dds/qos.h"
#include "common/dds/topics.h"
#include "common/process.h"
#include "idl/controlPubSubTypes.h"
#include "idl/statusPubSubTypes.h"
#include "orchestrator/chain_adapter.h"

namespace coins {
namespace {

// the writers the adapter needs, or the first error
Result<ChainAdapter::Io> OpenTopics(dds::Node& node, dds::Heartbeat* heartbeat, StatusCollector* collector) {
  auto command = node.MakeWriter<msg::ChainCommandPubSubType>(dds::kChainCommandTopic, dds::LatchedWriterQos());
  auto status = node.MakeWriter<msg::ChainStatusPubSubType>(dds::kChainStatusTopic, dds::LatchedWriterQos());
  auto control = node.MakeWriter<msg::ControlPubSubType>(dds::kControlTopic, dds::CommandWriterQos());
  for (const Status* s : {&command.status(), &status.status(), &control.status()})
    if (!s->ok()) return *s;
  return ChainAdapter::Io{*command, *status, *control, collector, heartbeat};
}

int OrchestratorMain(int argc, char** argv) {
  ProcessMain main("coins-orchestrator", "Runs the chain of interaction skills and publishes ChainStatus.");
  SystemConfig config;
  int64_t resume_epoch = -1;
  for (auto& section : config.Sections(false)) main.AddSection(section);
  main.app()
      .add_option("--resume-epoch", resume_epoch,
                  "continue from chain-epoch-N.json (coins run --resume); default: chain.json")
      ->check(CLI::NonNegativeNumber);
  if (int rc = main.Parse(argc, argv); rc >= 0) return rc;
  if (main.name() == "coins-orchestrator") main.name() = "orchestrator";

  auto env = envs::MakeEnv(config.run.env);
  if (!env.ok()) return ExitWithError(env.status().WithContext("run.env"), 2);
  chain::ChainStore store = OpenChainStore(config.run.dir, config);
  auto machine = OpenChain(store, (*env)->spec(), config.orchestrator, resume_epoch);
  if (!machine.ok()) return ExitWithError(machine.status(), 1);

  auto dds = main.OpenNode("orchestrator");
  if (!dds.ok()) return ExitWithError(dds.status(), 1);
  auto collector = StatusCollector::Start(*dds->node);
  if (!collector.ok()) return ExitWithError(collector.status().WithContext("cannot open DDS topics"), 1);
  auto io = OpenTopics(*dds->node, &dds->heartbeat, collector->get());
  if (!io.ok()) return ExitWithError(io.status().WithContext("cannot open DDS topics"), 1);
  config.dds = main.dds();
  ChainAdapter adapter(std::move(*machine), std::move(store), *io, config);
  return adapter.Run();
}

}  // namespace
}  // namespace coins

int main(int argc, char** argv) { return coins::OrchestratorMain(argc, argv); }
