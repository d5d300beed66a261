// ReplayClient: the learner's side of the sampling service (idl/sampling.idl) over DDS, as a
// SampleSource (sample_source.h) and, for existing users, an rl::BatchSource that samples with
// options() as its spec. One Sample() call splits the batch over the K shards in proportion to
// their sizes (as last reported in their replies; equal at first), sends one SampleRequest per
// shard (correlation ids), and merges the replies (MergeReplies). A shard with no rows known
// (it never answered, or it was empty) is still asked for one sample of a call at most once per
// second, so a shard whose first reply was late, or that filled later, is sampled again as soon
// as it says its size; any reply, a late one included, updates the shard's size. Up to 4 rounds within the
// timeout: a shard that did not answer a round, or answered NOT_READY or BAD_REQUEST, has its
// share asked from the shards that did answer; when none did, the same shards are asked again.
// If samples are still missing at the timeout, Sample() fails with a message naming the shards
// and why ("no reply within the timeout" when a shard is away: transient, the caller waits).
//
// A shard away (stopped, restarting, unreachable) is "silent" from the round it missed until any
// reply of it arrives (logged both ways, naming the shard). Later calls still ask a silent shard
// for its share but wait for it only when no other shard can take the share, so sampling goes on
// at full rate from the shards that answer and takes a restarted shard back by itself. A shard
// silent for longer than options.shard_wait makes Sample() fail with a message naming it.
//
// Keys: SampleKey(shard, the shard's global row number); UpdatePriorities / UpdateWeights route
// them back to their shard. A shard resumed from a snapshot keeps the row numbers it saved;
// keys of rows that were never saved (inserted after the snapshot) may later name other rows.
// As an rl::BatchSource, observations are [state; goal] (ColumnsToBatch).
//
// Threads: Sample is called from one thread at a time; UpdatePriorities / UpdateWeights may be
// called from another thread concurrently with Sample (they share no state with it). Create
// the client from the thread that owns the Node (Node is not thread-safe for entity creation).
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "common/dds/node.h"
#include "common/status.h"
#include "idl/sampling.h"
#include "learner/replay_client/sample_source.h"
#include "learner/rl/batch.h"

namespace coins {

// the spec used by the rl::BatchSource interface, and the client's own settings
struct ReplayClientOptions : SampleSpec {
  int shards = 2;
  std::chrono::milliseconds timeout{2000};  // per Sample() call, retries included
  // how long a shard may stay silent before Sample() fails (learner.shard_wait_s)
  std::chrono::milliseconds shard_wait{300000};
  std::string name = "learner";
};

class ReplayClient final : public SampleSource, public rl::BatchSource {
 public:
  static Result<std::unique_ptr<ReplayClient>> Create(dds::Node& node, const ReplayClientOptions& options);

  // waits until every shard's request reader and reply writer are matched
  bool WaitForShards(std::chrono::milliseconds timeout);
  // SampleSource
  Status Sample(const SampleSpec& spec, int batch, SampleColumns* out) override;
  void UpdatePriorities(std::span<const uint64_t> keys, std::span<const float> priorities) override;
  void UpdateWeights(std::span<const uint64_t> keys, std::span<const float> weights) override;
  // rl::BatchSource: samples with options() as the spec
  Status Sample(int batch_size, rl::Batch* batch) override;

  // the replies of the last Sample() that answered (columns as sent)
  std::vector<const msg::SampleReply*> last_replies() const {
    std::vector<const msg::SampleReply*> out;
    for (const ShardReply& r : merged_) out.push_back(r.reply);
    return out;
  }
  // the columns of the last rl::BatchSource sample
  const SampleColumns& last_columns() const { return columns_; }
  const std::vector<uint64_t>& shard_sizes() const { return sizes_; }
  ReplayClientOptions& options() { return options_; }

  static uint64_t Key(uint32_t shard, uint64_t row) { return SampleKey(shard, row); }
  static uint32_t KeyShard(uint64_t key) { return coins::KeyShard(key); }
  static uint64_t KeyRow(uint64_t key) { return coins::KeyRow(key); }

 private:
  using Clock = std::chrono::steady_clock;
  ReplayClient(const ReplayClientOptions& o)
      : options_(o), sizes_(size_t(o.shards), 0), silent_since_(size_t(o.shards)), next_probe_(size_t(o.shards)) {}
  // rounds until every share came or the deadline passed; fills merged_
  Status Gather(const SampleSpec& spec, uint32_t batch, Clock::time_point deadline);
  // one round: asks each shard k for counts_[k]; fills status[k] (a SAMPLE_* or kNoReply). A
  // silent shard is not waited for once a shard that answered (good, or OK in this round) can
  // take its share; a shard without a reply in time becomes silent
  void Round(Clock::time_point deadline, const std::vector<bool>& good, std::vector<int>* status,
             std::vector<std::string>* errors);
  // after a round: answered shares are done, the others move to shards that answered
  uint32_t Rebalance(const std::vector<int>& status, std::vector<bool>* good);
  bool silent(uint32_t k) const { return silent_since_[k] != Clock::time_point{}; }
  // a reply of shard k came (of this call or an older one): it is no longer silent
  void Heard(uint32_t k);
  // gives a shard with no known rows one sample of counts_ (from the largest share), at most once
  // per kProbePeriod per shard: the reply tells its size
  void ProbeUnsizedShards();
  // an error naming the first shard silent for longer than options_.shard_wait (ok when none)
  Status CheckSilence() const;
  void SendUpdates(uint8_t kind, std::span<const uint64_t> keys, std::span<const float> values);

  ReplayClientOptions options_;
  dds::Writer<msg::SampleRequest> requests_;
  dds::Reader<msg::SampleReply> replies_reader_;
  dds::Writer<msg::PriorityUpdate> updates_;
  std::vector<uint64_t> sizes_;
  std::vector<Clock::time_point> silent_since_;  // {}: the shard answers
  std::vector<Clock::time_point> next_probe_;    // when a shard without known rows is asked next
  std::vector<uint32_t> counts_;
  uint64_t next_id_ = 1;
  msg::SampleRequest request_;
  msg::SampleReply scratch_;
  std::vector<msg::SampleReply> slots_;  // rounds x shards
  std::vector<ShardReply> merged_;       // replies answered in the last call
  int round_ = 0;
  SampleColumns columns_;
  std::vector<msg::PriorityUpdate> update_msgs_;
};

}  // namespace coins
