// ReplayClient: the learner's side of the sampling service (idl/sampling.idl) as an
// rl::BatchSource. One Sample() call splits the batch over the K shards in proportion to their
// sizes (as last reported in their replies; equal at first), sends one SampleRequest per shard
// (correlation ids), and merges the replies. Up to 4 rounds within the timeout: a shard that
// did not answer a round (lost reply, shard still matching) is asked again; a shard that
// answered NOT_READY or BAD_REQUEST has its share asked from the shards that did answer. If
// samples are still missing at the timeout, Sample() fails with a message naming the shards
// and why.
//
// Keys: shard << 48 | the shard's global row number; UpdatePriorities / UpdateWeights route
// them back to their shard. A shard resumed from a snapshot keeps the row numbers it saved;
// keys of rows that were never saved (inserted after the snapshot) may later name other rows. Observations are [state; goal] (goal appended, possibly hindsight-
// relabelled by the shard); rewards and discounts come n-step from the shard.
//
// Not thread-safe: one learner thread uses a client. Create it from the thread that owns the
// Node (Node is not thread-safe for entity creation).
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "common/dds/node.h"
#include "common/status.h"
#include "idl/sampling.h"
#include "learner/rl/batch.h"

namespace coins {

struct ReplayClientOptions {
  int shards = 2;
  std::chrono::milliseconds timeout{2000};  // per Sample() call, retries included
  uint8_t strategy = msg::SAMPLE_UNIFORM;
  int skill_level = -1;                      // -1: any
  uint32_t n_step = 1;
  float gamma = 0.99f;
  uint8_t her_strategy = msg::HER_NONE;
  float her_ratio = 0.0f;
  std::vector<float> goal_mask;              // empty: stored goals, no relabelling
  uint32_t target_offset = 0;
  float goal_epsilon = 0.0f;
  std::string name = "learner";
};

class ReplayClient final : public rl::BatchSource {
 public:
  static Result<std::unique_ptr<ReplayClient>> Create(dds::Node& node, const ReplayClientOptions& options);

  // waits until every shard's request reader and reply writer are matched
  bool WaitForShards(std::chrono::milliseconds timeout);
  Status Sample(int batch_size, rl::Batch* batch) override;
  void UpdatePriorities(std::span<const uint64_t> keys, std::span<const float> priorities) override;
  void UpdateWeights(std::span<const uint64_t> keys, std::span<const float> weights);

  // the replies of the last Sample() that answered (columns as sent)
  std::vector<const msg::SampleReply*> last_replies() const {
    std::vector<const msg::SampleReply*> out;
    for (size_t s : used_) out.push_back(&slots_[s]);
    return out;
  }
  const std::vector<uint64_t>& shard_sizes() const { return sizes_; }
  ReplayClientOptions& options() { return options_; }

  static uint64_t Key(uint32_t shard, uint64_t row) { return (uint64_t(shard) << 48) | row; }
  static uint32_t KeyShard(uint64_t key) { return uint32_t(key >> 48); }
  static uint64_t KeyRow(uint64_t key) { return key & ((uint64_t(1) << 48) - 1); }

 private:
  ReplayClient(const ReplayClientOptions& o) : options_(o), sizes_(size_t(o.shards), 0) {}
  // one round: asks each shard k for counts[k]; fills got[k] with the replies' status
  void Round(const std::vector<uint32_t>& counts, std::chrono::steady_clock::time_point deadline,
             std::vector<int>* status, std::vector<std::string>* errors);
  void SendUpdates(uint8_t kind, std::span<const uint64_t> keys, std::span<const float> values);

  ReplayClientOptions options_;
  dds::Writer<msg::SampleRequest> requests_;
  dds::Reader<msg::SampleReply> replies_reader_;
  dds::Writer<msg::PriorityUpdate> updates_;
  std::vector<uint64_t> sizes_;
  uint64_t next_id_ = 1;
  msg::SampleRequest request_;
  msg::SampleReply scratch_;
  std::vector<msg::SampleReply> slots_;  // rounds x shards
  std::vector<size_t> used_;              // slots answered in the last call
  int round_ = 0;
  std::vector<msg::PriorityUpdate> update_msgs_;
};

}  // namespace coins
