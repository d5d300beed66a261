#include "replay/replay_service.h"

#include <spdlog/spdlog.h>

namespace coins {

ReplayService::ReplayService(uint32_t shard_id, const ReplayOptions& options)
    : options_(options),
      shard_(shard_id, options),
      limiter_(options.rate()),
      sampler_(SamplerOptions{options.importance_exponent, options.max_segment_rows, 64}),
      rng_(0x5eed0000ULL + shard_id) {}

Result<std::unique_ptr<ReplayService>> ReplayService::Open(uint32_t shard_id, ReplayOptions options,
                                                           ResumeReport* report, uint64_t resume_command) {
  auto start = std::chrono::steady_clock::now();
  SnapshotImage image;
  bool have = false;
  // newest valid snapshot first; a corrupt one is reported and the previous one tried
  if (!options.snapshot_dir.empty()) {
    for (const auto& path : ListSnapshots(options.snapshot_dir, shard_id)) {
      // a snapshot of another command is passed over on its META alone, without reading its data
      if (resume_command != 0) {
        auto command = ReadSnapshotCommand(path);
        if (command.ok() && *command != resume_command) {
          report->other_command.push_back(fmt::format("{} (command {})", path.string(), *command));
          continue;
        }
      }
      auto img = ReadSnapshot(path);
      if (!img.ok()) {
        report->corrupt.push_back(img.status().message());
        continue;
      }
      image = std::move(*img);
      report->snapshot = path.string();
      have = true;
      break;
    }
  }
  if (have) {
    report->config_changes = ConfigDifferences(image.config, options);
    report->new_config_won = options.prefer_new_config;
    if (!report->config_changes.empty() && !options.prefer_new_config) ApplySnapshotConfig(image.config, &options);
    COINS_RETURN_IF_ERROR(options.Validate());
  }
  // the priority trees are allocated here; a shard too large for the machine is refused by
  // ReplayOptions::Validate first, and this is the backstop
  std::unique_ptr<ReplayService> s;
  try {
    s.reset(new ReplayService(shard_id, options));
  } catch (const std::bad_alloc&) {
    return Errorf("shard {}: cannot allocate its indexes ({} bytes estimated); lower replay.capacity", shard_id,
                  ShardMemoryBytes(options));
  }
  if (have) {
    COINS_RETURN_IF_ERROR(RestoreShard(image, &s->shard_, &s->limiter_).WithContext(report->snapshot));
    s->size_ = s->shard_.store().transitions();
    report->transitions = uint64_t(s->size_.load());
  }
  report->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return s;
}

ReplayService::InsertResult ReplayService::Insert(const TransitionBatch& b, std::chrono::milliseconds timeout,
                                                  std::string* why) {
  // the limiter counts the batch's transitions up front (flags are bounded by the IDL, so this
  // is safe on a malformed batch) and takes them back when the shard does not store it
  const int64_t m = CountTransitions(b);
  if (!limiter_.CanInsert(m, size_.load())) {
    std::lock_guard lock(mu_);
    counters_.insert_waits++;
  }
  if (!limiter_.AwaitInsert(m, size_.load(), timeout)) return InsertResult::kTimedOut;
  Shard::Outcome o;
  uint32_t also_stored = 0;
  {
    std::lock_guard lock(mu_);
    o = shard_.Receive(b, why, &also_stored);
    size_ = shard_.store().transitions();
  }
  if (o != Shard::Outcome::kStored) limiter_.CancelInsert(m);
  // a held batch stored with this one counts as inserted too (it did not wait)
  if (also_stored) limiter_.AddInserted(also_stored);
  limiter_.Notify();
  switch (o) {
    case Shard::Outcome::kStored: return InsertResult::kStored;
    case Shard::Outcome::kDuplicate: return InsertResult::kDuplicate;
    case Shard::Outcome::kHeld: return InsertResult::kHeld;
    case Shard::Outcome::kRejected: break;
  }
  return InsertResult::kRejected;
}

void ReplayService::Sample(const msg::SampleRequest& req, msg::SampleReply* reply, std::chrono::milliseconds max_wait) {
  reply->schema_version(msg::SAMPLING_SCHEMA);
  reply->correlation_id(req.correlation_id());
  reply->shard_id(shard_.id());
  reply->n(0);
  reply->error("");
  auto fail = [&](uint8_t status, const std::string& error) {
    reply->status(status);
    reply->error(error);
    ClearSampleColumns(reply);
  };
  uint32_t state_dim;
  {
    std::lock_guard lock(mu_);
    state_dim = shard_.store().state_dim();
  }
  if (Status s = ValidateSampleRequest(req, state_dim == 0 ? COINS_BATCH_MAX_STATE : state_dim); !s.ok()) {
    std::lock_guard lock(mu_);
    counters_.bad_requests++;
    reply->shard_size(uint64_t(size_.load()));
    return fail(msg::SAMPLE_BAD_REQUEST, s.message());
  }
  auto wait = std::min(max_wait, std::chrono::milliseconds(req.timeout_ms()));
  if (!limiter_.AwaitSample(
          req.batch_size(), [this] { return size_.load(); }, wait)) {
    std::lock_guard lock(mu_);
    counters_.rate_limited++;
    reply->shard_size(uint64_t(size_.load()));
    return fail(msg::SAMPLE_NOT_READY,
                fmt::format("shard {}: rate limiter: {} transitions held, not ready within {} ms", shard_.id(),
                            size_.load(), wait.count()));
  }
  std::lock_guard lock(mu_);
  reply->shard_size(uint64_t(shard_.store().transitions()));
  Status s = ValidateSampleRequest(req, shard_.store().state_dim());
  if (s.ok()) s = sampler_.Sample(shard_.store(), shard_.priorities(), req, reply, &rng_, &shard_.levels());
  if (!s.ok()) {
    counters_.bad_requests++;
    return fail(msg::SAMPLE_BAD_REQUEST, s.message());
  }
  reply->status(msg::SAMPLE_OK);
  counters_.samples_served += req.batch_size();
}

void ReplayService::Update(uint8_t kind, std::span<const uint64_t> keys, std::span<const float> values) {
  std::lock_guard lock(mu_);
  const uint64_t first = shard_.store().first_row(), end = shard_.store().end_row();
  for (size_t i = 0; i < keys.size() && i < values.size(); ++i) {
    if (keys[i] < first || keys[i] >= end || !(values[i] >= 0) || !std::isfinite(values[i])) continue;
    if (kind == msg::UPDATE_PRIORITY)
      shard_.priorities().SetPriority(keys[i], values[i]);
    else
      shard_.priorities().SetWeight(keys[i], values[i]);
  }
}

Result<SnapshotWriteResult> ReplayService::Snapshot(uint64_t command_id) {
  std::lock_guard one(snapshot_mu_);
  if (options_.snapshot_dir.empty()) return Errorf("shard {}: replay.snapshot_dir is not set", shard_.id());
  {
    // nothing stored yet: nothing to write, and a command counts as done
    std::lock_guard lock(mu_);
    if (!shard_.store().configured()) {
      counters_.last_snapshot_command = std::max(counters_.last_snapshot_command, command_id);
      return SnapshotWriteResult{};
    }
  }
  std::error_code ec;
  std::filesystem::create_directories(options_.snapshot_dir, ec);
  auto path = NextSnapshotPath(options_.snapshot_dir, shard_.id());
  auto r = WriteSnapshot(mu_, shard_, limiter_, options_, command_id, path);
  if (r.ok()) PruneSnapshots(options_.snapshot_dir, shard_.id(), options_.snapshot_keep);  // files only: not under mu_
  std::lock_guard lock(mu_);
  if (!r.ok()) {
    counters_.snapshot_failures++;
    return r;
  }
  counters_.snapshots_written++;
  counters_.last_snapshot_command = std::max(counters_.last_snapshot_command, command_id);
  counters_.last_snapshot_s = r->seconds;
  return r;
}

ReplayService::View ReplayService::Stats(bool with_stored) const {
  std::lock_guard lock(mu_);
  View v{shard_.id(),
         shard_.store().transitions(),
         shard_.store().capacity(),
         shard_.counters(),
         shard_.ledger().duplicates(),
         shard_.ledger().gaps(),
         shard_.ledger().seq_jumps(),
         shard_.held(),
         shard_.ledger().actors(),
         {},
         counters_};
  if (with_stored) v.stored = shard_.StoredByActor();
  return v;
}

}  // namespace coins
