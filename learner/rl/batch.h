// Batch and BatchSource: how RL algorithms in coins_rl read training data.
//
// A Batch holds B transitions as column matrices (features x B). Returns are already n-step:
// rewards = sum_{k<n} gamma^k r_{t+k}, next_obs is the observation n steps later (or at the
// segment's end), and discounts = gamma^n, or 0 when a terminal state was reached inside the
// window (so targets are rewards + discounts * V(next_obs) with no other special cases).
// Goal-conditioned learners receive obs = [observation; goal] with the (possibly hindsight-
// relabelled) goal already appended and the reward recomputed for it.
//
// The system's source is the replay service (over DDS); tests use MemoryReplay. Sources that
// prioritise set weights (importance-sampling corrections) and keys; algorithms report new
// priorities through UpdatePriorities.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include <Eigen/Dense>

#include "common/status.h"

namespace coins::rl {

struct Batch {
  Eigen::MatrixXf obs;         // obs_dim x B
  Eigen::MatrixXf actions;     // action_dim x B; discrete: 1 x B holding action indices
  Eigen::MatrixXf rewards;     // 1 x B, n-step discounted reward sums
  Eigen::MatrixXf next_obs;    // obs_dim x B
  Eigen::MatrixXf discounts;   // 1 x B, gamma^n or 0 after a terminal state
  Eigen::MatrixXf weights;     // 1 x B importance weights; all ones for uniform sampling
  std::vector<uint64_t> keys;  // per-sample replay keys for priority updates (may be empty)

  int size() const { return int(obs.cols()); }
  // resizes every field for B samples of the given dims (no allocation when unchanged)
  void Resize(int obs_dim, int action_dim, int batch);
};

class BatchSource {
 public:
  virtual ~BatchSource() = default;
  // fills batch with batch_size samples; errors when the source cannot (e.g. empty, closed)
  virtual Status Sample(int batch_size, Batch* batch) = 0;
  // priority hook: new priorities (>= 0) for the keys of a sampled batch; default: ignored
  virtual void UpdatePriorities(std::span<const uint64_t> keys, std::span<const float> priorities) {}
};

inline void Batch::Resize(int obs_dim, int action_dim, int batch) {
  obs.resize(obs_dim, batch);
  actions.resize(action_dim, batch);
  rewards.resize(1, batch);
  next_obs.resize(obs_dim, batch);
  discounts.resize(1, batch);
  weights.resize(1, batch);
  keys.resize(size_t(batch));
}

}  // namespace coins::rl
