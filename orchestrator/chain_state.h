// The chain's state and messages as plain C++ (no DDS): what ChainMachine reads, decides on and
// persists (chain_store.h), and what the DDS adapter converts to and from the IDL types.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace coins::chain {

enum class Phase { kCollecting, kDetecting, kTrainingSkill, kTask, kDone };
// "collecting", "detecting", "training-skill", "task", "done"
const char* PhaseName(Phase p);
std::optional<Phase> ParsePhase(std::string_view name);

// an accepted link as the learner and the actors use it (idl LinkSpec)
struct LinkSpec {
  std::string source, target;
  double score = 0;         // Sc_I when accepted
  std::vector<float> mask;  // eta_b over the target's features
  std::string goal_kind;    // discrete | continuous
  std::vector<float> goal_set;
  double interaction_rate = 0;
  bool operator==(const LinkSpec&) const = default;
};

// a goal-reaching rate measured in windows of goals from cumulative counts
struct SuccessTracker {
  bool based = false;         // a first count has been seen
  uint64_t base_started = 0;  // counts at the start of the open window
  uint64_t base_reached = 0;
  uint64_t windows = 0;        // windows closed
  double rate = 0;             // the newest closed window's rate
  double best = 0;             // the best rate (meaningful once windows > 0)
  uint64_t best_at = 0;        // env steps when best last rose by more than the tolerance
  uint64_t goals = 0;          // goals in the closed windows
  uint64_t best_at_goals = 0;  // goals when best last rose by more than the tolerance
  bool operator==(const SuccessTracker&) const = default;
};

struct Link {
  LinkSpec spec;
  uint64_t accepted_at_steps = 0;
  uint64_t learned_at_steps = 0;  // 0: not learned yet
  std::string learned_by;         // "" | converged | budget
  SuccessTracker success;
  bool operator==(const Link&) const = default;
};

// one target's score of a detect round (idl InteractionScore)
struct Score {
  std::string source, target;
  double score = 0, mg_score = 0;
  uint64_t interactions = 0, transitions = 0;
  double chance_interactions = 0;  // detections with other transitions' sources
  uint64_t goal_interactions = 0;  // detections the mask and goal set came from
  bool pass = false, eligible = false;
  std::string note;
  std::vector<float> mask;
  std::string goal_kind;
  std::vector<float> goal_set;
  double interaction_rate = 0;
  double train_seconds = 0;
  bool operator==(const Score&) const = default;
};

// a detect round's answer (idl InteractionScores)
struct ScoresReport {
  uint64_t command_seq = 0, round = 0, env_steps = 0;
  std::string source;
  std::vector<Score> scores;
};

// what the machine reads of LearnerStatus
struct LearnerReport {
  uint64_t command_seq = 0;
  std::string job, state, message;  // state: waiting | running | done | failed
  uint64_t scores_round = 0;
  uint64_t eval_env_steps = 0;
  double eval_return_mean = 0, eval_return_sd = 0;
  uint32_t eval_episodes = 0;
};

struct Eval {
  uint64_t env_steps = 0;  // env steps when the evaluation started (0: none yet)
  double mean = 0, sd = 0;
  uint32_t episodes = 0;
  bool operator==(const Eval&) const = default;
};

// task-phase progress of the eval return
struct TaskTracker {
  bool started = false;  // the task phase was entered
  uint64_t evals = 0;    // evaluations seen in the task phase
  double best = 0;       // meaningful once evals > 0
  uint64_t best_at = 0;  // env steps of the eval that last raised best by > tolerance
  bool operator==(const TaskTracker&) const = default;
};

// everything the machine needs to continue; persisted after every transition
struct ChainState {
  Phase phase = Phase::kCollecting;
  uint64_t seq = 1;               // the command's seq; grows at every transition
  std::string source = "Action";  // the current source factor
  std::vector<Link> links;
  uint64_t round = 0;               // detect rounds of this source (the current one while detecting)
  uint64_t source_start = 0;        // env steps when collecting for this source began
  uint64_t next_detect = 0;         // env steps of the next (or current) detect point
  uint64_t phase_start = 0;         // env steps when the phase began (done: when the chain ended)
  uint64_t env_steps = 0;           // the newest env steps seen
  std::vector<Score> last_scores;   // the newest round's scores
  uint64_t lost_score_reports = 0;  // learner reports of a scored round whose scores never came
  uint64_t ignored_scores = 0;      // stale or duplicate score messages ignored
  Eval eval;                        // the newest evaluation
  TaskTracker task;
  uint64_t epoch = 0;           // newest complete checkpoint epoch
  uint64_t last_cut_epoch = 0;  // newest epoch cut (complete or not); the next cut is above it
  std::string note;             // the last transition and why, one line
  bool operator==(const ChainState&) const = default;
};

// the command of the current state (idl ChainCommand without the run id)
struct Command {
  uint64_t seq = 0;
  std::string phase, job, source;
  std::vector<std::string> targets;
  uint64_t round = 0;
  std::vector<LinkSpec> links;
  int64_t acting_level = 0;
  uint64_t step_base = 0;
  double steps_per_update = 0;
  uint64_t step_limit = 0;
  uint64_t epoch = 0;
  bool operator==(const Command&) const = default;
};

}  // namespace coins::chain
