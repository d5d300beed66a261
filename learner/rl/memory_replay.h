// MemoryReplay: an in-process replay buffer that is a BatchSource, for tests and small runs.
//
// It is the replay service's sampling over an in-memory shard: steps are stored in a replay
// Shard (replay/shard.h: chunk store, priorities) and sampled by the service's Sampler
// (replay/sampler.h), whose reply becomes a Batch the way the learner's does (MergeReplies,
// ColumnsToBatch in learner/replay_client/sample_source.h). So n-step returns, hindsight
// relabelling and prioritised sampling have one implementation, the service's:
//   - uniform sampling, or prioritised (P(i) = p_i^alpha / sum; importance weights
//     (N P(i))^-beta normalised by the batch maximum; new steps get the largest priority seen)
//   - n-step returns inside a segment: reward = sum gamma^j r_j, discount gamma^k, or 0 after a
//     terminal step; next_obs is the obs after the window's last step
//   - goal-conditioned learners (goal_dim > 0): the goal is the step's goal, or for a fraction
//     her_ratio of samples the goal achieved at a step of the segment from the sampled one on
//     (kFinal: its last step, kFuture: a uniformly chosen one); every step of the window gets
//     success_reward when the step's achieved goal is within goal_epsilon of the goal (distance
//     scaled by goal_mask), else step_reward, and a reached goal is terminal
// Segments are runs of steps ended by Step::segment_end or Step::terminal (episode end, skill
// timeout or goal change); n-step windows and hindsight goals never cross a segment's end. Inside
// a segment a step's obs is the previous step's next_obs (the store keeps one state per step); a
// step whose obs differs starts a new segment. Keys are absolute step numbers (0, 1, ...).
// Steps are sampleable as soon as they are added. Steps holding non-finite values are refused
// by the shard's validation and not stored (nor counted). Not thread-safe.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "common/hindsight.h"
#include "learner/rl/batch.h"

namespace coins::rl {

struct MemoryReplayOptions {
  int64_t capacity = 100000;  // steps kept (the paddle skill's buffer 1e5)
  int obs_dim = 0;            // the policy's observation without the goal
  int action_dim = 1;         // 1 for discrete actions
  int n_step = 1;
  float gamma = 0.99f;
  // goal-conditioned learners (goal_dim > 0): the sampled obs is [obs; goal]
  int goal_dim = 0;
  std::vector<float> goal_mask;  // goal_dim scales of the distance (empty: all ones)
  float goal_epsilon = 0.0f;
  GoalNorm goal_norm = GoalNorm::kL1;
  float step_reward = -1.0f;               // reward while the goal is not reached
  float success_reward = 0.0f;             // reward on the step that reaches it
  bool terminate_on_success = true;        // the service always terminates on success: must be true
  HerStrategy her = HerStrategy::kFuture;  // kNone, kFinal or kFuture (the service's strategies)
  float her_ratio = 0.5f;                  // fraction of samples relabelled (the paper's p = 0.5)
  // prioritised sampling (the ball skill's alpha 0.2, beta 0.4); new steps get the max priority
  bool prioritized = false;
  float priority_alpha = 0.2f;
  float priority_beta = 0.4f;
  float priority_eps = 1e-3f;  // added to reported priorities so none is zero
  uint64_t seed = 0;
  Status Validate() const;
};

// One environment step as the actor records it.
struct ReplayStep {
  std::span<const float> obs;       // obs_dim
  std::span<const float> action;    // action_dim
  std::span<const float> next_obs;  // obs_dim
  std::span<const float> goal;      // goal_dim: the goal in force (goal-conditioned only)
  std::span<const float> achieved;  // goal_dim: the goal achieved at next_obs
  float reward = 0.0f;              // environment reward (used when goal_dim == 0)
  bool terminal = false;            // next_obs is terminal: never bootstrap past it
  bool segment_end = false;         // last step of its episode / skill segment
};

class MemoryReplay : public BatchSource {
 public:
  explicit MemoryReplay(MemoryReplayOptions options);  // asserts options.Validate()
  ~MemoryReplay() override;

  void Add(const ReplayStep& step);
  int64_t size() const;  // steps held (at most capacity)
  int64_t total_steps() const { return total_; }
  int sample_obs_dim() const { return options_.obs_dim + options_.goal_dim; }

  // batch_size up to the service's bound (COINS_SAMPLE_MAX_BATCH)
  Status Sample(int batch_size, Batch* batch) override;
  // keys no longer in the buffer are ignored
  void UpdatePriorities(std::span<const uint64_t> keys, std::span<const float> priorities) override;

 private:
  struct State;  // the service's shard, sampler and scratch (memory_replay.cc)

  MemoryReplayOptions options_;
  std::unique_ptr<State> state_;
  int64_t total_ = 0;
};

}  // namespace coins::rl
