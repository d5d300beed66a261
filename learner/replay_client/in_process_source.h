// InProcessSource: a SampleSource over ReplayService objects in this process (replay shards
// without DDS), for tests and in-process experiments. It takes the path the DDS client takes
// (split the batch by shard sizes, one SampleRequest per shard, ReplayService::Sample answers a
// SampleReply, MergeReplies), so what a learner sees from it matches what it sees over DDS.
// A shard that refuses its share (NOT_READY, BAD_REQUEST) has it asked from the shards that
// answered, up to 4 rounds; the error names every shard's reason.
//
// services[k] answers as shard k: keys carry k, and updates go back to services[k]. The
// services must outlive the source. Threads: as ReplayClient (Sample from one thread at a time;
// updates may come from another thread, ReplayService is thread-safe).
#pragma once

#include <chrono>
#include <string>
#include <vector>

#include "learner/replay_client/sample_source.h"
#include "replay/replay_service.h"

namespace coins {

struct InProcessSourceOptions {
  // how long each shard may wait for its rate limiter, per round
  std::chrono::milliseconds timeout{2000};
  std::string name = "in-process";
};

class InProcessSource final : public SampleSource {
 public:
  explicit InProcessSource(std::vector<ReplayService*> services, InProcessSourceOptions options = {});

  Status Sample(const SampleSpec& spec, int batch, SampleColumns* out) override;
  void UpdatePriorities(std::span<const uint64_t> keys, std::span<const float> priorities) override;
  void UpdateWeights(std::span<const uint64_t> keys, std::span<const float> weights) override;

  // the replies of the last Sample() (columns as the shards answered)
  const std::vector<ShardReply>& last_replies() const { return merged_; }
  const std::vector<uint64_t>& shard_sizes() const { return sizes_; }

 private:
  void Update(uint8_t kind, std::span<const uint64_t> keys, std::span<const float> values);

  std::vector<ReplayService*> services_;
  InProcessSourceOptions options_;
  uint64_t next_id_ = 1;
  msg::SampleRequest request_;
  std::vector<msg::SampleReply> slots_;  // rounds x shards
  std::vector<ShardReply> merged_;
  std::vector<uint64_t> sizes_;
  std::vector<uint32_t> counts_;
  std::vector<std::string> errors_;
  std::vector<uint64_t> update_rows_;
  std::vector<float> update_values_;
};

}  // namespace coins
