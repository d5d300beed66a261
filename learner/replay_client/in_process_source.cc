#include "learner/replay_client/in_process_source.h"

namespace coins {

namespace {
constexpr int kRounds = 4;
}  // namespace

InProcessSource::InProcessSource(std::vector<ReplayService*> services, InProcessSourceOptions options)
    : services_(std::move(services)), options_(std::move(options)) {
  slots_.resize(size_t(kRounds) * services_.size());
  sizes_.assign(services_.size(), 0);
  errors_.resize(services_.size());
}

Status InProcessSource::Sample(const SampleSpec& spec, int batch, SampleColumns* out) {
  const size_t K = services_.size();
  if (K == 0) return Errorf("in-process replay: no shards");
  if (batch < 1 || uint32_t(batch) > COINS_SAMPLE_MAX_BATCH)
    return Errorf("in-process replay: batch {} not in [1, {}]", batch, COINS_SAMPLE_MAX_BATCH);
  for (size_t k = 0; k < K; ++k) sizes_[k] = uint64_t(services_[k]->size());
  SplitBatch(sizes_, uint32_t(batch), &counts_);
  FillRequest(spec, &request_);
  request_.client(options_.name);
  request_.timeout_ms(uint32_t(options_.timeout.count()));
  merged_.clear();
  for (auto& e : errors_) e.clear();
  uint32_t missing = uint32_t(batch);
  for (int round = 0; round < kRounds && missing > 0; ++round) {
    // each shard answers its share; a refused share goes to the shards that answered
    uint32_t refused = 0;
    for (size_t k = 0; k < K; ++k) {
      if (counts_[k] == 0) continue;
      msg::SampleReply& reply = slots_[size_t(round) * K + k];
      request_.correlation_id(next_id_++);
      request_.shard_id(int32_t(k));
      request_.batch_size(counts_[k]);
      services_[k]->Sample(request_, &reply, options_.timeout);
      if (reply.status() == msg::SAMPLE_OK) {
        merged_.push_back({&reply, uint32_t(k)});
        missing -= counts_[k];
      } else {
        errors_[k] = reply.error();
        refused += counts_[k];
      }
      counts_[k] = 0;
    }
    std::vector<size_t> good;
    for (const ShardReply& r : merged_)
      if (r.reply->shard_size() > 0) good.push_back(r.shard);
    if (good.empty()) break;
    for (uint32_t i = 0; i < refused; ++i) counts_[good[i % good.size()]]++;
  }
  if (missing > 0) {
    std::string why;
    for (size_t k = 0; k < K; ++k)
      if (!errors_[k].empty()) why += fmt::format("{}shard {}: {}", why.empty() ? "" : "; ", k, errors_[k]);
    return Errorf("in-process replay: {} of {} samples missing ({})", missing, batch, why);
  }
  return MergeReplies(merged_, out).WithContext("in-process replay");
}

void InProcessSource::Update(uint8_t kind, std::span<const uint64_t> keys, std::span<const float> values) {
  // one call per shard with that shard's rows
  for (size_t k = 0; k < services_.size(); ++k) {
    update_rows_.clear();
    update_values_.clear();
    for (size_t i = 0; i < keys.size() && i < values.size(); ++i)
      if (KeyShard(keys[i]) == k) {
        update_rows_.push_back(KeyRow(keys[i]));
        update_values_.push_back(values[i]);
      }
    if (!update_rows_.empty()) services_[k]->Update(kind, update_rows_, update_values_);
  }
}

void InProcessSource::UpdatePriorities(std::span<const uint64_t> keys, std::span<const float> priorities) {
  Update(msg::UPDATE_PRIORITY, keys, priorities);
}

void InProcessSource::UpdateWeights(std::span<const uint64_t> keys, std::span<const float> weights) {
  Update(msg::UPDATE_WEIGHT, keys, weights);
}

}  // namespace coins
