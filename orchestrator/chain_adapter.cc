#include "orchestrator/chain_adapter.h"

#include <spdlog/spdlog.h>

#include "common/checkpoint.h"
#include "common/process.h"

namespace coins {

namespace {
using Clock = std::chrono::steady_clock;
constexpr auto kTick = std::chrono::milliseconds(100);
}  // namespace

Result<chain::ChainMachine> OpenChain(const chain::ChainStore& store, const envs::EnvSpec& spec,
                                      const OrchestratorOptions& options, int64_t resume_epoch) {
  auto current = store.Load();
  if (resume_epoch < 0) {
    if (!current.ok()) return current.status();
    if (!current->has_value()) return chain::ChainMachine(spec, options);
    spdlog::info("continuing the chain from {}", store.StatePath().string());
    return chain::ChainMachine::Restore(spec, options, **current);
  }
  auto state = store.LoadEpoch(uint64_t(resume_epoch));
  if (!state.ok()) return state.status();
  // epochs cut after the one resumed keep their numbers: the next cut is above them all
  if (current.ok() && current->has_value())
    state->last_cut_epoch = std::max(state->last_cut_epoch, (*current)->last_cut_epoch);
  spdlog::info("resuming the chain from epoch {} ({})", resume_epoch, store.EpochPath(uint64_t(resume_epoch)).string());
  return chain::ChainMachine::Restore(spec, options, std::move(*state));
}

ChainAdapter::ChainAdapter(chain::ChainMachine machine, chain::ChainStore store, Io io, const SystemConfig& config)
    : machine_(std::move(machine)),
      store_(std::move(store)),
      io_(io),
      config_(config),
      cutter_(config.run.shards, EpochCutter::Seconds(config.orchestrator.checkpoint_period_s),
              EpochCutter::Seconds(config.orchestrator.checkpoint_timeout_s), machine_.state().last_cut_epoch,
              Clock::now()) {}

int ChainAdapter::Run() {
  spdlog::info("chain: {} (seq {}, epoch {})", machine_.Describe(), machine_.state().seq, machine_.state().epoch);
  Persist(true);
  PublishCommand();
  next_status_ = Clock::now();
  while (!SleepUnlessStopped(kTick)) Tick(Clock::now());
  Persist(true);
  PublishStatus();
  io_.heartbeat->Publish("stopping");
  spdlog::info("stopped in phase {} at {} env steps (epoch {})", chain::PhaseName(machine_.state().phase),
               machine_.state().env_steps, machine_.state().epoch);
  return 0;
}

void ChainAdapter::Tick(Clock::time_point now) {
  const StatusView v = io_.collector->Snapshot();
  const uint64_t seq = machine_.state().seq;
  Feed(v);
  if (machine_.state().seq != seq) {
    spdlog::info("transition to {} (seq {}): {}", chain::PhaseName(machine_.state().phase), machine_.state().seq,
                 machine_.state().note);
    cutter_.RequestCut();
  }
  // the run's step budget spent: one more epoch holds everything trained on it
  if (config_.run.steps > 0 && !budget_cut_ && machine_.state().env_steps >= uint64_t(config_.run.steps)) {
    budget_cut_ = true;
    spdlog::info("step budget of {} env steps spent: cutting a final epoch", config_.run.steps);
    cutter_.RequestCut();
  }
  Checkpoint(now, v);
  Persist(false);
  PublishCommand();
  if (now >= next_status_) {
    PublishStatus();
    io_.heartbeat->Publish("running");
    next_status_ = now + std::chrono::duration_cast<Clock::duration>(
                             std::chrono::duration<double>(config_.orchestrator.status_period_s));
  }
}

void ChainAdapter::Feed(const StatusView& v) {
  machine_.OnEnvSteps(v.total_steps());
  for (const auto& s : io_.collector->TakeScores()) machine_.OnScores(FromMessage(s));
  if (v.learner && v.learner_reports != learner_reports_seen_) {
    learner_reports_seen_ = v.learner_reports;
    machine_.OnLearner(FromMessage(v.learner->sample));
  }
  for (const auto& [id, a] : v.actors) goals_.Add(a.sample);
  for (int level = 1; level <= int(machine_.state().links.size()); ++level) {
    auto [started, reached] = goals_.Level(level);
    machine_.OnSkillCounts(level, started, reached);
  }
}

void ChainAdapter::Persist(bool steps_too) {
  if (saved_) {
    chain::ChainState unchanged = *saved_;
    if (!steps_too) unchanged.env_steps = machine_.state().env_steps;
    if (unchanged == machine_.state()) return;
  }
  if (Status s = store_.Save(machine_.state()); !s.ok()) {
    spdlog::error("cannot persist the chain state: {}", s.message());
    return;
  }
  saved_ = machine_.state();
}

void ChainAdapter::PublishCommand() {
  chain::Command c = machine_.command();
  if (published_ && *published_ == c) return;
  if (!io_.command.Write(ToMessage(c, config_.run.dir))) {
    spdlog::warn("chain command seq {} not written (writer busy); retrying", c.seq);
    return;
  }
  published_ = c;
}

void ChainAdapter::Checkpoint(Clock::time_point now, const StatusView& v) {
  if (auto epoch = cutter_.Due(now)) {
    machine_.SetLastCutEpoch(*epoch);
    pending_epoch_state_ = machine_.state();
    pending_epoch_state_.epoch = *epoch;
    SendCheckpoint(*epoch);
  } else if (cutter_.ShouldResend(now)) {
    SendCheckpoint(cutter_.pending_epoch());
  }
  EpochAcks acks;
  for (const auto& [id, s] : v.shards) acks.shards[id] = s.sample.last_snapshot_command();
  if (v.learner) acks.learner = v.learner->sample.checkpoint_command();
  std::string missing;
  const uint64_t epoch = cutter_.pending_epoch();
  switch (cutter_.Check(now, acks, &missing)) {
    case EpochCutter::Outcome::kComplete: CompleteEpoch(); break;
    case EpochCutter::Outcome::kAbandoned:
      checkpoint_note_ = fmt::format("epoch {} incomplete: no acknowledgement from {} within {} s", epoch, missing,
                                     config_.orchestrator.checkpoint_timeout_s);
      spdlog::warn("{}; the next period cuts a new epoch", checkpoint_note_);
      break;
    default: break;
  }
}

void ChainAdapter::SendCheckpoint(uint64_t epoch) {
  msg::Control c;
  c.schema_version(msg::CONTROL_SCHEMA);
  c.command_id(CheckpointCommandId(epoch));
  c.target("all");
  c.command(msg::CONTROL_CHECKPOINT);
  c.argument(std::to_string(epoch));
  if (!io_.control.Write(c)) spdlog::warn("checkpoint command of epoch {} not written; resent later", epoch);
}

void ChainAdapter::CompleteEpoch() {
  if (Status s = store_.SaveEpoch(pending_epoch_state_); !s.ok()) {
    spdlog::error("epoch {} acknowledged but not persisted: {}", pending_epoch_state_.epoch, s.message());
    return;
  }
  machine_.SetEpoch(pending_epoch_state_.epoch);
  checkpoint_note_.clear();
  spdlog::info("epoch {} complete ({})", pending_epoch_state_.epoch,
               store_.EpochPath(pending_epoch_state_.epoch).string());
}

void ChainAdapter::PublishStatus() {
  // what the chain does now, and its last transition with the reason (e.g. a skill learned by
  // convergence or by its budget); done: the reason it ended
  std::string message = machine_.Describe();
  const chain::ChainState& s = machine_.state();
  if (s.phase != chain::Phase::kDone && !s.note.empty()) message += " (last: " + s.note + ")";
  if (!checkpoint_note_.empty()) message += "; " + checkpoint_note_;
  io_.status.Write(ToChainStatus(machine_, config_.run.dir, message));
}

}  // namespace coins
