// ChainMachine: the paper's Algorithm 1 as a pure state machine (no DDS, no files, no clock).
//
// Phases (orchestrator/README.md): collecting -> detecting -> training-skill -> collecting (the
// new target as source) ... ; the chain ends in task (at least one link) then done, or done.
// Decisions come only from the inputs below, all in env steps:
//   - OnEnvSteps: env steps of the run (monotonic: a smaller value is ignored). Collecting turns
//     into detecting at the detect point; skill and task budgets are checked.
//   - OnScores: a detect round's answer; only the current command's seq, round and source count
//     (stale and duplicate messages are ignored and counted). The argmax of the eligible scores
//     with Sc_I > eps_si (a single-instance factor among the targets) becomes a link; with none,
//     one more increment is collected while the source's detect budget lasts, else the chain ends.
//   - OnSkillCounts: cumulative goals started / reached of a level, summed over actors. The
//     machine windows them (success_window_goals goals a window); a count that drops (an actor
//     restarted) starts a new window.
//   - OnLearner: the learner's status for the current seq: task evaluations (job train-task;
//     task convergence), a failed job, and "scores published" (scores that never arrive are
//     asked for again).
// Outputs: command() (its seq grows at every transition; the epoch field changes without a new
// seq), state() (persisted by chain_store.h), and Targets().
//
// Restore(state) gives a machine whose command() and reactions to the same next inputs are
// identical to those of the machine that produced the state.
#pragma once

#include <string>
#include <vector>

#include "common/env_spec.h"
#include "common/status.h"
#include "orchestrator/chain_state.h"
#include "orchestrator/orchestrator_options.h"

namespace coins::chain {

class ChainMachine {
 public:
  // a fresh chain: collecting random-action data for source "Action"
  ChainMachine(envs::EnvSpec spec, OrchestratorOptions options);
  // a chain continued from a persisted state; refuses a state that does not fit the spec
  static Result<ChainMachine> Restore(envs::EnvSpec spec, OrchestratorOptions options, ChainState state);

  // each input returns true when it caused a transition (a new command seq)
  bool OnEnvSteps(uint64_t env_steps);
  bool OnScores(const ScoresReport& report);
  bool OnSkillCounts(int level, uint64_t goals_started, uint64_t goals_reached);
  bool OnLearner(const LearnerReport& report);
  // the newest complete checkpoint epoch (no transition)
  void SetEpoch(uint64_t epoch);
  void SetLastCutEpoch(uint64_t epoch) { s_.last_cut_epoch = epoch; }

  const ChainState& state() const { return s_; }
  Command command() const;
  // the factors detection scores now: every spec factor but Action, the source, the
  // controlled ones (targets of links), Done and Reward
  std::vector<std::string> Targets() const;
  // what the chain is doing, one line (ChainStatus.message)
  std::string Describe() const;

 private:
  bool Transition(Phase next, const std::string& note);
  bool StartDetecting();
  bool Decide(const ScoresReport& report);
  const Score* BestScore(const std::vector<Score>& scores) const;
  // some target left a skill could be learned for (Targets() without multi-instance classes)
  bool AnyCandidate() const;
  bool Accept(const Score& best);
  bool NoLinkThisRound(const std::string& why);
  bool EndChain(const std::string& why);
  bool CheckSkill();
  // goals without a rise that converge the skill in training (level 1: primitive_n_complete_goals)
  int64_t Patience() const;
  bool CheckTask();
  bool LearnerFailed(const LearnerReport& report);
  void TrackEval(const LearnerReport& report);
  bool MissedScores(const LearnerReport& report);

  envs::EnvSpec spec_;
  OrchestratorOptions o_;
  ChainState s_;
};

// transfer (`coins transfer`): a chain that starts in the task phase over the links of `learned`
// up to and including the learned link whose target is `skill` (its skills already trained);
// everything else starts fresh. skill "": `learned` is a run without a chain (orchestrator.chain
// none) whose task policy is fine-tuned: the task phase without links. Errors name what the
// learned chain lacks.
Result<ChainState> TransferState(const ChainState& learned, const std::string& skill);

// the goal-reaching rate bookkeeping used by OnSkillCounts (exposed for tests): folds cumulative
// counts into t; true when a window closed
bool UpdateSuccess(SuccessTracker& t, uint64_t started, uint64_t reached, uint64_t env_steps, int64_t window_goals,
                   double tolerance);

}  // namespace coins::chain
