// LocalRun: the chain's parts in one process without DDS: replay shards (ReplayService), actors
// (Actor with a WeightsStore each, their batches inserted straight into their shard), and a
// LearnerCore sampling through an InProcessSource. The same code paths as the DDS processes
// minus the transport, for tests and in-process experiments; deterministic for a seed, since
// actors and learner take turns on one thread.
//
//   LocalRun run(options);
//   run.Command(cmd);              // what the orchestrator would publish
//   run.StepActors(1000);          // each actor steps up to its pacing allowance
//   run.LearnerWork(500);          // up to 500 slices of learner work
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "actors/actor.h"
#include "actors/weights_store.h"
#include "idl/control.h"
#include "learner/learner_core.h"
#include "learner/replay_client/in_process_source.h"
#include "replay/replay_options.h"
#include "replay/replay_service.h"

namespace coins {

struct LocalRunOptions {
  std::string env = "breakout";
  int actors = 2;
  int shards = 2;
  uint64_t seed = 1;
  ActorOptions actor;
  ReplayOptions replay;
  LearnerOptions learner;
};

class LocalRun {
 public:
  static Result<std::unique_ptr<LocalRun>> Create(const LocalRunOptions& options);
  ~LocalRun();

  // follows a command: the learner first (its weights reach every actor), then the actors
  Status Command(const msg::ChainCommand& command);
  // every actor steps until it has taken `steps` more or reached its pacing allowance
  Status StepActors(uint64_t steps);
  // up to `slices` of learner work; returns the slices that did something. counted_steps: the
  // env steps the learner believes were taken (its process counts them from periodic actor
  // reports, which lag); default: the actors' own count
  Result<int> LearnerWork(int slices, std::optional<uint64_t> counted_steps = std::nullopt);

  uint64_t env_steps() const;
  // every InteractionScores the learner produced, oldest first
  const std::vector<msg::InteractionScores>& scores() const { return scores_; }
  LearnerCore& learner() { return *learner_; }
  Actor& actor(int i);
  // weights rejected by the actors so far
  uint64_t rejected() const;
  const envs::EnvSpec& spec() const;

 private:
  struct LocalActor;
  class ShardSink;
  LocalRun() = default;
  void Deliver(std::vector<msg::PolicyWeights>& weights);

  LocalRunOptions options_;
  std::vector<std::unique_ptr<ReplayService>> shards_;
  std::unique_ptr<InProcessSource> source_;
  std::vector<std::unique_ptr<LocalActor>> actors_;
  std::unique_ptr<LearnerCore> learner_;
  msg::ChainCommand command_;
  std::vector<msg::InteractionScores> scores_;
};

}  // namespace coins
