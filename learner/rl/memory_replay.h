// MemoryReplay: an in-process replay buffer that is a BatchSource, for tests and small runs.
//
// It stores steps in preallocated rings (capacity columns) and builds n-step samples at
// sample time, mirroring what the replay service does: uniform sampling; for goal-conditioned
// learners, hindsight relabelling inside the step's segment (her.h) with the reward and
// termination recomputed for the chosen goal. Segments are runs of steps ended by
// Step::segment_end (episode end, skill timeout or goal change); n-step windows and hindsight
// goals never cross a segment's end. Keys are absolute step numbers.
#pragma once

#include <cstdint>
#include <random>
#include <span>
#include <vector>

#include <Eigen/Dense>

#include "learner/rl/batch.h"
#include "common/hindsight.h"
#include "common/sum_tree.h"

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
  float step_reward = -1.0f;     // reward while the goal is not reached
  float success_reward = 0.0f;   // reward on the step that reaches it
  bool terminate_on_success = true;
  HerStrategy her = HerStrategy::kFuture;
  float her_ratio = 0.5f;        // fraction of samples relabelled (the paper's p = 0.5)
  // prioritised sampling (the ball skill's alpha 0.2, beta 0.4); new steps get the max priority
  bool prioritized = false;
  float priority_alpha = 0.2f;
  float priority_beta = 0.4f;
  float priority_eps = 1e-3f;   // added to reported priorities so none is zero
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

  void Add(const ReplayStep& step);
  int64_t size() const { return std::min(total_, options_.capacity); }
  int64_t total_steps() const { return total_; }
  int sample_obs_dim() const { return options_.obs_dim + options_.goal_dim; }

  Status Sample(int batch_size, Batch* batch) override;
  // keys no longer in the buffer are ignored
  void UpdatePriorities(std::span<const uint64_t> keys, std::span<const float> priorities) override;

 private:
  int64_t Slot(int64_t abs) const { return abs % options_.capacity; }
  bool Reached(int64_t abs, const Eigen::VectorXf& goal) const;

  MemoryReplayOptions options_;
  Eigen::MatrixXf obs_, next_obs_, actions_, goals_, achieved_;
  std::vector<float> rewards_;
  std::vector<uint8_t> terminal_;
  std::vector<int64_t> seg_begin_, seg_end_;  // absolute; seg_end_ = -1 while open
  int64_t total_ = 0;
  int64_t open_begin_ = 0;  // first step of the open segment
  SumTree tree_;            // prioritized only: priority^alpha per slot
  double max_priority_ = 1.0;
  std::mt19937_64 rng_;
  Eigen::VectorXf goal_;    // sampling scratch
};

}  // namespace coins::rl
