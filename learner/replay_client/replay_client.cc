#include "learner/replay_client/replay_client.h"

#include <algorithm>
#include <random>
#include <thread>

#include "idl/samplingPubSubTypes.h"
#include "replay/sampling_topics.h"

namespace coins {

namespace {
constexpr int kPending = -1;
constexpr int kNoReply = -2;
constexpr int kRounds = 4;
}  // namespace

Result<std::unique_ptr<ReplayClient>> ReplayClient::Create(dds::Node& node, const ReplayClientOptions& o) {
  if (o.shards < 1) return Errorf("replay client: shards {} must be at least 1", o.shards);
  std::unique_ptr<ReplayClient> c(new ReplayClient(o));
  auto req = node.MakeWriter<msg::SampleRequestPubSubType>(dds::kSampleRequestTopic, dds::SamplingWriterQos(64));
  auto rep = node.MakeReader<msg::SampleReplyPubSubType>(dds::kSampleReplyTopic, dds::SamplingReaderQos(64));
  auto upd = node.MakeWriter<msg::PriorityUpdatePubSubType>(dds::kPriorityUpdateTopic, dds::SamplingWriterQos(64));
  if (!req.ok()) return req.status();
  if (!rep.ok()) return rep.status();
  if (!upd.ok()) return upd.status();
  c->requests_ = *req;
  c->replies_reader_ = *rep;
  c->updates_ = *upd;
  // correlation ids unique across client restarts
  c->next_id_ = (std::random_device{}() | (uint64_t(std::random_device{}()) << 32)) & ((uint64_t(1) << 62) - 1);
  c->update_msgs_.resize(size_t(o.shards));
  c->slots_.resize(size_t(kRounds) * size_t(o.shards));
  return c;
}

bool ReplayClient::WaitForShards(std::chrono::milliseconds timeout) {
  auto end = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    dds::fdds::SubscriptionMatchedStatus s;
    replies_reader_.raw()->get_subscription_matched_status(s);
    if (requests_.matched() >= options_.shards && s.current_count >= options_.shards &&
        updates_.matched() >= options_.shards)
      return true;
    if (std::chrono::steady_clock::now() >= end) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
}

void ReplayClient::Round(const std::vector<uint32_t>& counts, std::chrono::steady_clock::time_point deadline,
                         std::vector<int>* status, std::vector<std::string>* errors) {
  const int K = options_.shards;
  std::vector<uint64_t> ids(size_t(K), 0);
  // one request per shard with something to ask
  for (int k = 0; k < K; ++k) {
    if (counts[size_t(k)] == 0) continue;
    request_.schema_version(msg::SAMPLING_SCHEMA);
    request_.correlation_id(ids[size_t(k)] = next_id_++);
    request_.client(options_.name);
    request_.shard_id(k);
    request_.batch_size(counts[size_t(k)]);
    request_.strategy(options_.strategy);
    request_.skill_level(options_.skill_level);
    request_.n_step(options_.n_step);
    request_.gamma(options_.gamma);
    request_.her_strategy(options_.her_strategy);
    request_.her_ratio(options_.her_ratio);
    request_.goal_mask(options_.goal_mask);
    request_.target_offset(options_.target_offset);
    request_.goal_epsilon(options_.goal_epsilon);
    auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    request_.timeout_ms(uint32_t(std::max<int64_t>(0, left.count() * 3 / 4)));
    (*status)[size_t(k)] = kPending;
    if (!requests_.Write(request_)) {
      (*status)[size_t(k)] = kNoReply;
      (*errors)[size_t(k)] = "request not sent";
    }
  }
  // replies until every pending shard answered or the deadline passed
  auto pending = [&] { return std::count(status->begin(), status->end(), kPending); };
  while (pending() > 0) {
    auto now = std::chrono::steady_clock::now();
    if (now >= deadline) break;
    replies_reader_.Wait(std::min<std::chrono::nanoseconds>(deadline - now, std::chrono::milliseconds(50)));
    replies_reader_.TakeAll(scratch_, [&](const msg::SampleReply& r, const auto&) {
      uint32_t k = r.shard_id();
      if (k >= uint32_t(K) || ids[k] != r.correlation_id() || (*status)[k] != kPending) return;  // stale or foreign
      (*status)[k] = r.status();
      sizes_[k] = r.shard_size();
      if (r.status() == msg::SAMPLE_OK) {
        // keep the reply by swapping buffers: no copy, no allocation once warm
        size_t slot = size_t(round_) * size_t(K) + k;
        std::swap(slots_[slot], scratch_);
        used_.push_back(slot);
      } else {
        (*errors)[k] = r.error();
      }
    });
  }
  for (int k = 0; k < K; ++k)
    if ((*status)[size_t(k)] == kPending) {
      (*status)[size_t(k)] = kNoReply;
      (*errors)[size_t(k)] = "no reply within the timeout";
    }
}

Status ReplayClient::Sample(int batch_size, rl::Batch* batch) {
  if (batch_size < 1) return Errorf("replay client: batch_size {} must be positive", batch_size);
  const int K = options_.shards;
  const auto deadline = std::chrono::steady_clock::now() + options_.timeout;
  used_.clear();
  // split in proportion to the shard sizes last seen (largest remainder); equal when unknown
  std::vector<uint32_t> counts(size_t(K), 0);
  uint64_t total = 0;
  for (uint64_t s : sizes_) total += s;
  std::vector<std::pair<double, int>> rem;
  uint32_t given = 0;
  for (int k = 0; k < K; ++k) {
    double share = total ? double(batch_size) * double(sizes_[size_t(k)]) / double(total) : double(batch_size) / K;
    counts[size_t(k)] = uint32_t(share);
    given += counts[size_t(k)];
    rem.push_back({share - counts[size_t(k)], k});
  }
  std::sort(rem.rbegin(), rem.rend());
  for (size_t i = 0; given < uint32_t(batch_size); ++i, ++given) counts[size_t(rem[i % rem.size()].second)]++;

  // rounds until every sample came or the deadline passed: a shard that did not answer (a
  // lost reply, a shard still matching) is asked again; a shard that answered NOT_READY or
  // BAD_REQUEST has its share moved to shards that answered
  std::vector<std::string> errors(static_cast<size_t>(K));
  std::vector<bool> good(size_t(K), false);
  uint32_t missing = uint32_t(batch_size);
  const auto round_wait = std::max<std::chrono::milliseconds>(options_.timeout / 4, std::chrono::milliseconds(250));
  for (round_ = 0; round_ < kRounds && missing > 0 && std::chrono::steady_clock::now() < deadline; ++round_) {
    std::vector<int> status(size_t(K), msg::SAMPLE_OK);
    Round(counts, std::min(deadline, std::chrono::steady_clock::now() + round_wait), &status, &errors);
    uint32_t moved = 0;
    std::vector<uint32_t> refused(size_t(K), 0);
    for (int k = 0; k < K; ++k) {
      uint32_t& n = counts[size_t(k)];
      if (n == 0) continue;
      if (status[size_t(k)] == msg::SAMPLE_OK) {
        missing -= n;
        n = 0;
        good[size_t(k)] = sizes_[size_t(k)] > 0;
      } else if (status[size_t(k)] != kNoReply) {
        moved += n;
        refused[size_t(k)] = n;
        n = 0;
      }
    }
    std::vector<int> targets;
    for (int k = 0; k < K; ++k)
      if (good[size_t(k)]) targets.push_back(k);
    if (targets.empty()) {
      // nobody else can take the share: ask the same shards again (the limiter may open)
      for (int k = 0; k < K; ++k) counts[size_t(k)] += refused[size_t(k)];
      continue;
    }
    for (uint32_t i = 0; i < moved; ++i) counts[size_t(targets[i % targets.size()])]++;
  }
  if (missing > 0) {
    std::string why;
    for (int k = 0; k < K; ++k)
      if (!errors[size_t(k)].empty()) why += fmt::format("{}shard {}: {}", why.empty() ? "" : "; ", k, errors[size_t(k)]);
    return Errorf("replay client: {} of {} samples missing after {} ms ({})", missing, batch_size,
                  options_.timeout.count(), why);
  }

  // merge the replies into the batch's columns
  const auto& first = slots_[used_.front()];
  const int S = int(first.state_dim()), G = int(first.goal_dim()), A = int(first.action_dim());
  batch->Resize(S + G, A, batch_size);
  int j = 0;
  std::vector<float> next(static_cast<size_t>(S));
  for (size_t slot : used_) {
    const msg::SampleReply& r = slots_[slot];
    if (int(r.state_dim()) != S || int(r.goal_dim()) != G || int(r.action_dim()) != A)
      return Errorf("replay client: shard {} replied with dims {}/{}/{}, others {}/{}/{}", r.shard_id(), r.state_dim(),
                    r.action_dim(), r.goal_dim(), S, A, G);
    for (uint32_t i = 0; i < r.n(); ++i, ++j) {
      const float* s = r.state().data() + size_t(i) * S;
      const float* g = r.goal().data() + size_t(i) * G;
      std::copy_n(s, S, next.begin());
      for (uint32_t k = i ? r.next_end()[i - 1] : 0; k < r.next_end()[i]; ++k) next[r.next_index()[k]] = r.next_value()[k];
      for (int d = 0; d < S; ++d) {
        batch->obs(d, j) = s[d];
        batch->next_obs(d, j) = next[size_t(d)];
      }
      for (int d = 0; d < G; ++d) batch->obs(S + d, j) = batch->next_obs(S + d, j) = g[d];
      for (int d = 0; d < A; ++d) batch->actions(d, j) = r.action()[size_t(i) * A + d];
      batch->rewards(0, j) = r.reward()[i];
      batch->discounts(0, j) = r.discount()[i];
      batch->weights(0, j) = r.weight()[i];
      batch->keys[size_t(j)] = Key(r.shard_id(), r.key()[i]);
    }
  }
  return Status::Ok();
}

void ReplayClient::SendUpdates(uint8_t kind, std::span<const uint64_t> keys, std::span<const float> values) {
  for (auto& m : update_msgs_) {
    m.key().clear();
    m.value().clear();
  }
  for (size_t i = 0; i < keys.size() && i < values.size(); ++i) {
    uint32_t k = KeyShard(keys[i]);
    if (k >= update_msgs_.size()) continue;
    update_msgs_[k].key().push_back(KeyRow(keys[i]));
    update_msgs_[k].value().push_back(values[i]);
  }
  for (size_t k = 0; k < update_msgs_.size(); ++k) {
    auto& m = update_msgs_[k];
    if (m.key().empty()) continue;
    m.schema_version(msg::SAMPLING_SCHEMA);
    m.shard_id(uint32_t(k));
    m.kind(kind);
    updates_.Write(m);
  }
}

void ReplayClient::UpdatePriorities(std::span<const uint64_t> keys, std::span<const float> priorities) {
  SendUpdates(msg::UPDATE_PRIORITY, keys, priorities);
}

void ReplayClient::UpdateWeights(std::span<const uint64_t> keys, std::span<const float> weights) {
  SendUpdates(msg::UPDATE_WEIGHT, keys, weights);
}

}  // namespace coins
