#include "learner/replay_client/replay_client.h"

#include <algorithm>
#include <random>
#include <thread>

#include <spdlog/spdlog.h>

#include "idl/samplingPubSubTypes.h"
#include "replay/sampling_topics.h"

namespace coins {

namespace {
constexpr int kPending = -1;
constexpr int kNoReply = -2;
constexpr int kRounds = 4;
constexpr std::chrono::seconds kProbePeriod{1};
}  // namespace

Result<std::unique_ptr<ReplayClient>> ReplayClient::Create(dds::Node& node, const ReplayClientOptions& o) {
  if (o.shards < 1) return Errorf("replay client: shards {} must be at least 1", o.shards);
  std::unique_ptr<ReplayClient> c(new ReplayClient(o));
  // requests and updates are small: written synchronously, they skip the async writer's thread
  auto small = dds::SamplingWriterQos(64);
  small.publish_mode().kind = dds::fdds::SYNCHRONOUS_PUBLISH_MODE;
  auto req = node.MakeWriter<msg::SampleRequestPubSubType>(dds::kSampleRequestTopic, small);
  auto rep = node.MakeReader<msg::SampleReplyPubSubType>(dds::kSampleReplyTopic, dds::SamplingReaderQos(64));
  auto upd = node.MakeWriter<msg::PriorityUpdatePubSubType>(dds::kPriorityUpdateTopic, small);
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

void ReplayClient::Round(Clock::time_point deadline, const std::vector<bool>& good, std::vector<int>* status,
                         std::vector<std::string>* errors) {
  const int K = options_.shards;
  const auto start = Clock::now();
  std::vector<uint64_t> ids(size_t(K), 0);
  // one request per shard with something to ask
  for (int k = 0; k < K; ++k) {
    if (counts_[size_t(k)] == 0) continue;
    request_.correlation_id(ids[size_t(k)] = next_id_++);
    request_.shard_id(k);
    request_.batch_size(counts_[size_t(k)]);
    auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now());
    request_.timeout_ms(uint32_t(std::max<int64_t>(0, left.count() * 3 / 4)));
    (*status)[size_t(k)] = kPending;
    if (!requests_.Write(request_)) {
      (*status)[size_t(k)] = kNoReply;
      (*errors)[size_t(k)] = "request not sent";
    }
  }
  // replies until every shard waited for answered or the deadline passed: a silent shard is
  // waited for only while no shard that answered could take its share
  auto waiting = [&] {
    bool taker = std::find(good.begin(), good.end(), true) != good.end();
    for (int k = 0; k < K; ++k) taker = taker || ((*status)[size_t(k)] == msg::SAMPLE_OK && sizes_[size_t(k)] > 0);
    for (int k = 0; k < K; ++k)
      if ((*status)[size_t(k)] == kPending && !(taker && silent(uint32_t(k)))) return true;
    return false;
  };
  while (waiting()) {
    auto now = Clock::now();
    if (now >= deadline) break;
    replies_reader_.Wait(std::min<std::chrono::nanoseconds>(deadline - now, std::chrono::milliseconds(50)));
    replies_reader_.TakeAll(scratch_, [&](const msg::SampleReply& r, const auto&) {
      uint32_t k = r.shard_id();
      if (k >= uint32_t(K)) return;  // foreign
      Heard(k);
      sizes_[k] = r.shard_size();                                            // a late reply's size is news too
      if (ids[k] != r.correlation_id() || (*status)[k] != kPending) return;  // stale
      (*status)[k] = r.status();
      if (r.status() == msg::SAMPLE_OK) {
        // keep the reply by swapping buffers: no copy, no allocation once warm
        size_t slot = size_t(round_) * size_t(K) + k;
        std::swap(slots_[slot], scratch_);
        merged_.push_back({&slots_[slot], k});
      } else {
        (*errors)[k] = r.error();
      }
    });
  }
  for (int k = 0; k < K; ++k) {
    if ((*status)[size_t(k)] == kPending) {
      (*status)[size_t(k)] = kNoReply;
      (*errors)[size_t(k)] = "no reply within the timeout";
    }
    if ((*status)[size_t(k)] != kNoReply || silent(uint32_t(k))) continue;
    silent_since_[size_t(k)] = start;
    spdlog::warn("replay shard {}: no reply within {} ms; sampling from the shards that answer until it does", k,
                 std::chrono::duration_cast<std::chrono::milliseconds>(Clock::now() - start).count());
  }
}

void ReplayClient::Heard(uint32_t k) {
  if (!silent(k)) return;
  spdlog::info("replay shard {} answers again after {:.1f} s", k,
               std::chrono::duration<double>(Clock::now() - silent_since_[k]).count());
  silent_since_[k] = {};
}

void ReplayClient::ProbeUnsizedShards() {
  const auto now = Clock::now();
  for (size_t k = 0; k < counts_.size(); ++k) {
    if (sizes_[k] > 0 || counts_[k] > 0 || now < next_probe_[k]) continue;
    auto largest = std::max_element(counts_.begin(), counts_.end());
    if (*largest < 2) return;  // nothing to spare
    --*largest;
    counts_[k] = 1;
    next_probe_[k] = now + kProbePeriod;
  }
}

Status ReplayClient::CheckSilence() const {
  const auto now = Clock::now();
  for (size_t k = 0; k < silent_since_.size(); ++k)
    if (silent(uint32_t(k)) && now - silent_since_[k] > options_.shard_wait)
      return Errorf(
          "replay client: shard {} has not answered for {:.1f} s, longer than a shard may be away "
          "(learner.shard_wait_s = {} s)",
          k, std::chrono::duration<double>(now - silent_since_[k]).count(),
          std::chrono::duration<double>(options_.shard_wait).count());
  return Status::Ok();
}

uint32_t ReplayClient::Rebalance(const std::vector<int>& status, std::vector<bool>* good) {
  const int K = options_.shards;
  uint32_t done = 0, moved = 0;
  std::vector<uint32_t> unanswered(size_t(K), 0);
  for (int k = 0; k < K; ++k) {
    uint32_t& n = counts_[size_t(k)];
    if (n == 0) continue;
    if (status[size_t(k)] == msg::SAMPLE_OK) {
      done += n;
      n = 0;
      (*good)[size_t(k)] = sizes_[size_t(k)] > 0;
    } else {
      moved += n;
      unanswered[size_t(k)] = n;
      n = 0;
    }
  }
  std::vector<int> targets;
  for (int k = 0; k < K; ++k)
    if ((*good)[size_t(k)]) targets.push_back(k);
  if (targets.empty()) {
    // nobody else can take the share: ask the same shards again (the limiter may open, a shard
    // may come back)
    for (int k = 0; k < K; ++k) counts_[size_t(k)] += unanswered[size_t(k)];
  } else {
    for (uint32_t i = 0; i < moved; ++i) counts_[size_t(targets[i % targets.size()])]++;
  }
  return done;
}

Status ReplayClient::Gather(const SampleSpec& spec, uint32_t batch, Clock::time_point deadline) {
  const int K = options_.shards;
  FillRequest(spec, &request_);
  request_.client(options_.name);
  // rounds until every sample came or the deadline passed: the share of a shard that did not
  // answer (away, a lost reply, still matching) or answered NOT_READY or BAD_REQUEST moves to
  // shards that answered
  std::vector<std::string> errors(static_cast<size_t>(K));
  std::vector<bool> good(size_t(K), false);
  uint32_t missing = batch;
  const auto round_wait = std::max<std::chrono::milliseconds>(options_.timeout / 4, std::chrono::milliseconds(250));
  for (round_ = 0; round_ < kRounds && missing > 0 && Clock::now() < deadline; ++round_) {
    std::vector<int> status(size_t(K), msg::SAMPLE_OK);
    Round(std::min(deadline, Clock::now() + round_wait), good, &status, &errors);
    missing -= Rebalance(status, &good);
  }
  if (missing == 0) return Status::Ok();
  std::string why;
  for (int k = 0; k < K; ++k)
    if (!errors[size_t(k)].empty()) why += fmt::format("{}shard {}: {}", why.empty() ? "" : "; ", k, errors[size_t(k)]);
  return Errorf("replay client: {} of {} samples missing after {} ms ({})", missing, batch, options_.timeout.count(),
                why);
}

Status ReplayClient::Sample(const SampleSpec& spec, int batch, SampleColumns* out) {
  if (batch < 1 || uint32_t(batch) > COINS_SAMPLE_MAX_BATCH)
    return Errorf("replay client: batch {} not in [1, {}]", batch, COINS_SAMPLE_MAX_BATCH);
  const auto deadline = Clock::now() + options_.timeout;
  merged_.clear();
  SplitBatch(sizes_, uint32_t(batch), &counts_);
  ProbeUnsizedShards();
  Status gathered = Gather(spec, uint32_t(batch), deadline);
  COINS_RETURN_IF_ERROR(CheckSilence());
  COINS_RETURN_IF_ERROR(gathered);
  return MergeReplies(merged_, out).WithContext("replay client");
}

Status ReplayClient::Sample(int batch_size, rl::Batch* batch) {
  COINS_RETURN_IF_ERROR(Sample(static_cast<const SampleSpec&>(options_), batch_size, &columns_));
  ColumnsToBatch(columns_, batch);
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
