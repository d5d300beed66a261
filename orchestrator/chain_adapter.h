// ChainAdapter: the orchestrator's DDS side around ChainMachine.
//
// Every tick (100 ms) it feeds the machine what the status topics say (env steps, detect
// scores, the learner's status, goal counts per level), persists the state when it changed
// (chain.json, atomic), publishes the ChainCommand when it changed (latched; a transition
// gives a new seq, an epoch update republishes the same seq), and cuts checkpoint epochs
// (epoch_cutter.h): Control CHECKPOINT N to all, then chain-epoch-N.json once every shard and
// the learner acknowledged. ChainStatus and the heartbeat go out every status period. Nothing
// here blocks: a missing acknowledgement is reported and the epoch abandoned after its timeout.
#pragma once

#include <chrono>
#include <optional>
#include <string>

#include "common/dds/heartbeat.h"
#include "common/dds/node.h"
#include "idl/control.h"
#include "orchestrator/chain_machine.h"
#include "orchestrator/chain_messages.h"
#include "orchestrator/chain_store.h"
#include "orchestrator/epoch_cutter.h"
#include "orchestrator/status_collector.h"
#include "orchestrator/system_config.h"

namespace coins {

class ChainAdapter {
 public:
  struct Io {
    dds::Writer<msg::ChainCommand> command;
    dds::Writer<msg::ChainStatus> status;
    dds::Writer<msg::Control> control;
    StatusCollector* collector;
    dds::Heartbeat* heartbeat;
  };
  ChainAdapter(chain::ChainMachine machine, chain::ChainStore store, Io io, const SystemConfig& config);
  // runs until a stop is requested; returns the exit code
  int Run();

 private:
  void Tick(std::chrono::steady_clock::time_point now);
  void Feed(const StatusView& v);
  // writes chain.json (atomically, fsynced) when the state changed. The env step count alone
  // moves with every actor report: it is written with the other changes (a transition, a success
  // window, an epoch) unless `steps_too`, so the loop does not fsync several times a second
  void Persist(bool steps_too);
  void PublishCommand();
  void Checkpoint(std::chrono::steady_clock::time_point now, const StatusView& v);
  void SendCheckpoint(uint64_t epoch);
  void CompleteEpoch();
  void PublishStatus();

  chain::ChainMachine machine_;
  chain::ChainStore store_;
  Io io_;
  SystemConfig config_;
  EpochCutter cutter_;
  GoalCounter goals_;
  uint64_t learner_reports_seen_ = 0;
  std::optional<chain::ChainState> saved_;   // what chain.json holds
  std::optional<chain::Command> published_;  // the newest command written
  chain::ChainState pending_epoch_state_;    // the state at the cut of the pending epoch
  std::string checkpoint_note_;              // the last abandoned epoch, for ChainStatus
  bool budget_cut_ = false;                  // the epoch at run.steps was asked for
  std::chrono::steady_clock::time_point next_status_;
};

// the machine to run: chain-epoch-N.json when resume_epoch >= 0, else chain.json when there is
// one, else a fresh chain. Errors (corrupt file, another config, unknown epoch) name the file.
Result<chain::ChainMachine> OpenChain(const chain::ChainStore& store, const envs::EnvSpec& spec,
                                      const OrchestratorOptions& options, int64_t resume_epoch);

}  // namespace coins
