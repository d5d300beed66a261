// SampleSource: how the learner draws transitions from the replay service, whatever carries
// them. A SampleSpec says what to sample (the SampleRequest fields of idl/sampling.idl without
// the ids and the transport's timeout); SampleColumns is the merged answer as plain columns.
//
// Implementations:
//   ReplayClient       (replay_client.h)       the shards over DDS
//   InProcessSource    (in_process_source.h)   ReplayService objects in this process, the same
//                                              request -> reply -> merge path without DDS
//   PrefetchingSource  (prefetcher.h)          samples ahead on a thread, over either
// and SampleBatchSource adapts any of them to rl::BatchSource (obs = [state; goal]).
//
// Keys: shard << 48 | the shard's global row number (SampleKey); UpdatePriorities and
// UpdateWeights route them back to their shard.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "common/status.h"
#include "idl/sampling.h"
#include "learner/rl/batch.h"

namespace coins {

// what to sample: the request's fields (idl/sampling.idl documents each) without the ids
struct SampleSpec {
  uint8_t strategy = msg::SAMPLE_UNIFORM;
  int skill_level = -1;     // -1: any (see level_mask)
  uint32_t level_mask = 0;  // non-zero: rows whose level L has bit L set
  uint32_t n_step = 1;
  float gamma = 0.99f;
  uint8_t her_strategy = msg::HER_NONE;
  float her_ratio = 0.0f;
  std::vector<float> goal_mask;  // empty: stored goals and rewards, no relabelling
  uint32_t target_offset = 0;
  float goal_epsilon = 0.0f;
  uint8_t goal_norm = msg::GOAL_NORM_LINF;
  std::vector<uint16_t> features;  // state features to return, in order (empty: all)
  // goal-conditioned rewards (goal_mask not empty); defaults: the paddle skill's -1 / 0
  float step_reward = -1.0f;
  float success_reward = 0.0f;
  float interaction_reward = -1.0f;
  float episode_end_reward = 0.0f;  // added at an episode's end without success
  bool require_interaction = false;
  bool terminate_on_interaction = false;

  bool operator==(const SampleSpec&) const = default;
};

// a merged batch: n samples, row-major columns
struct SampleColumns {
  uint32_t n = 0;
  uint32_t state_dim = 0;    // the shards' full state
  uint32_t feature_dim = 0;  // columns of state / next_state (the requested features)
  uint32_t action_dim = 0;
  uint32_t goal_dim = 0;
  std::vector<float> state;              // n x feature_dim
  std::vector<float> next_state;         // n x feature_dim, decoded
  std::vector<float> action;             // n x action_dim
  std::vector<float> goal;               // n x goal_dim (relabelled when hindsight chose so)
  std::vector<float> reward;             // n, n-step sums
  std::vector<float> discount;           // n, gamma^k or 0 after a terminal step
  std::vector<float> weight;             // n, importance weights
  std::vector<uint64_t> key;             // n, SampleKey(shard, row)
  std::vector<uint32_t> interactions;    // n, ground truth of the sampled step
  std::vector<uint16_t> flags;           // n, ROW_* of the sampled row
  std::vector<uint8_t> skill_level;      // n
  std::vector<uint64_t> policy_version;  // n, weights version of the row's level (0: random)

  // sizes every column for n samples (no allocation when the capacity suffices)
  void Resize(uint32_t n, uint32_t feature_dim, uint32_t action_dim, uint32_t goal_dim);
};

class SampleSource {
 public:
  virtual ~SampleSource() = default;
  // fills out with `batch` samples drawn as spec says; the error says which shard or field failed
  virtual Status Sample(const SampleSpec& spec, int batch, SampleColumns* out) = 0;
  // new priorities (>= 0) / sampling weights for keys of sampled batches; keys no longer held
  // are ignored by their shard
  virtual void UpdatePriorities(std::span<const uint64_t> keys, std::span<const float> priorities) = 0;
  virtual void UpdateWeights(std::span<const uint64_t> keys, std::span<const float> weights) = 0;
};

inline uint64_t SampleKey(uint32_t shard, uint64_t row) { return (uint64_t(shard) << 48) | row; }
inline uint32_t KeyShard(uint64_t key) { return uint32_t(key >> 48); }
inline uint64_t KeyRow(uint64_t key) { return key & ((uint64_t(1) << 48) - 1); }

// the request's fields from spec (ids, shard, batch size and timeout are the caller's)
void FillRequest(const SampleSpec& spec, msg::SampleRequest* request);

// splits batch over shards in proportion to sizes (largest remainder; equal when all are 0)
void SplitBatch(std::span<const uint64_t> sizes, uint32_t batch, std::vector<uint32_t>* counts);

// one shard's answer and the shard its keys route to
struct ShardReply {
  const msg::SampleReply* reply;
  uint32_t shard;
};
// checks each reply (status OK, schema, one layout across replies, column lengths, delta
// indices inside the feature columns) and merges them in order into out, next_state decoded;
// the error names the shard and the column
Status MergeReplies(std::span<const ShardReply> replies, SampleColumns* out);

// obs = [state; goal], next_obs = [next_state; goal] (features x n), and the other columns
void ColumnsToBatch(const SampleColumns& columns, rl::Batch* batch);

// any SampleSource as an rl::BatchSource that asks with one spec
class SampleBatchSource final : public rl::BatchSource {
 public:
  SampleBatchSource(SampleSource* source, SampleSpec spec) : source_(source), spec_(std::move(spec)) {}
  Status Sample(int batch_size, rl::Batch* batch) override;
  void UpdatePriorities(std::span<const uint64_t> keys, std::span<const float> priorities) override {
    source_->UpdatePriorities(keys, priorities);
  }
  SampleSpec& spec() { return spec_; }
  // the columns of the last batch (skill levels, versions, flags ...)
  const SampleColumns& last() const { return columns_; }

 private:
  SampleSource* source_;
  SampleSpec spec_;
  SampleColumns columns_;
};

}  // namespace coins
