#include "replay/snapshot.h"

#include <fcntl.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <fstream>

#include "common/files.h"

namespace coins {

namespace fs = std::filesystem;

namespace {

constexpr char kMagic[8] = {'C', 'O', 'I', 'N', 'S', 'R', 'P', 'L'};
constexpr size_t kSectionHeader = 24;
constexpr int64_t kSliceBytes = 1 << 20;  // the longest an insert or sample waits: one 1 MiB copy

// a file being written: appends, hashes sections, patches headers
class Out {
 public:
  explicit Out(const fs::path& path) : path_(path) {
    fd_ = ::open(path.c_str(), O_CREAT | O_TRUNC | O_WRONLY | O_CLOEXEC, 0644);
  }
  ~Out() {
    if (fd_ >= 0) ::close(fd_);
  }
  bool ok() const { return fd_ >= 0 && !failed_; }
  void Write(const void* p, size_t n) {
    const char* c = static_cast<const char*>(p);
    while (n > 0 && !failed_) {
      ssize_t w = ::write(fd_, c, n);
      if (w <= 0) {
        failed_ = true;
        return;
      }
      c += w;
      n -= size_t(w);
      pos_ += uint64_t(w);
    }
  }
  // starts a section: a placeholder header patched by End()
  void Begin(const char tag[4]) {
    std::memcpy(tag_, tag, 4);
    start_ = pos_;
    hash_ = 0xcbf29ce484222325ULL;
    char zero[kSectionHeader] = {};
    Write(zero, kSectionHeader);
  }
  void Payload(const void* p, size_t n) {
    hash_ = HashBytes(p, n, hash_);
    Write(p, n);
  }
  // DATA: the section hash is the hash of the per-chunk hashes, so a reader can recompute it
  // from chunk sizes (seed-chained HashBytes calls can lose a difference confined to the top bit)
  void SetHash(uint64_t h) { hash_ = h; }
  void End() {
    uint8_t h[kSectionHeader] = {};
    std::memcpy(h, tag_, 4);
    uint64_t length = pos_ - start_ - kSectionHeader;
    std::memcpy(h + 8, &length, 8);
    std::memcpy(h + 16, &hash_, 8);
    if (::pwrite(fd_, h, kSectionHeader, off_t(start_)) != ssize_t(kSectionHeader)) failed_ = true;
  }
  void Section(const char tag[4], const std::string& text) {
    Begin(tag);
    Payload(text.data(), text.size());
    End();
  }
  bool Sync() { return ok() && ::fsync(fd_) == 0; }
  uint64_t size() const { return pos_; }

 private:
  fs::path path_;
  int fd_ = -1;
  bool failed_ = false;
  uint64_t pos_ = 0, start_ = 0, hash_ = 0;
  char tag_[4] = {};
};

}  // namespace

void LowerThreadPriority() { setpriority(PRIO_PROCESS, pid_t(syscall(SYS_gettid)), 10); }

nlohmann::json SnapshotConfig(const ReplayOptions& o) {
  return {{"capacity", o.capacity},         {"capacity_mb", o.capacity_mb},
          {"min_size", o.min_size},         {"samples_per_insert", o.samples_per_insert},
          {"error_buffer", o.error_buffer}, {"priority_exponent", o.priority_exponent}};
}

std::vector<std::string> ConfigDifferences(const nlohmann::json& snapshot, const ReplayOptions& o) {
  std::vector<std::string> out;
  nlohmann::json now = SnapshotConfig(o);
  for (auto it = now.begin(); it != now.end(); ++it) {
    if (!snapshot.contains(it.key())) continue;
    if (snapshot[it.key()] != it.value())
      out.push_back(fmt::format("replay.{}: {} -> {}", it.key(), snapshot[it.key()].dump(), it.value().dump()));
  }
  return out;
}

void ApplySnapshotConfig(const nlohmann::json& s, ReplayOptions* o) {
  auto get = [&](const char* key, auto& field) {
    if (s.contains(key) && s[key].is_number()) field = s[key].get<std::decay_t<decltype(field)>>();
  };
  get("capacity", o->capacity);
  get("capacity_mb", o->capacity_mb);
  get("min_size", o->min_size);
  get("samples_per_insert", o->samples_per_insert);
  get("error_buffer", o->error_buffer);
  get("priority_exponent", o->priority_exponent);
}

namespace {

// what a snapshot describes beside its chunks, taken together under the lock
struct ShardDescription {
  nlohmann::json meta, ledger = nlohmann::json::array();
  uint64_t first_id = 0, end_id = 0;  // the chunk ids stored
};

Result<ShardDescription> DescribeShard(std::mutex& mu, const Shard& shard, const RateLimiter& limiter,
                                       uint64_t command_id) {
  const ChunkStore& store = shard.store();
  ShardDescription d;
  std::lock_guard lock(mu);
  if (!store.configured()) return Errorf("snapshot of shard {}: nothing stored yet", shard.id());
  d.first_id = store.first_id();
  d.end_id = store.end_id();
  RateLimiterCounters rc = limiter.counters();
  d.meta = {
      {"shard_id", shard.id()},
      {"created_unix", std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count()},
      {"command_id", command_id},
      {"layout_hash", store.layout_hash()},
      {"state_dim", store.state_dim()},
      {"action_dim", store.action_dim()},
      {"goal_dim", store.goal_dim()},
      {"inserted_transitions", shard.counters().inserted_transitions},
      {"inserted_batches", shard.counters().inserted_batches},
      {"rejected", shard.counters().rejected},
      {"duplicates", shard.ledger().duplicates()},
      {"gaps", shard.ledger().gaps()},
      {"seq_jumps", shard.ledger().seq_jumps()},
      {"rate_inserted", rc.inserted},
      {"rate_sampled", rc.sampled},
      {"max_priority", shard.priorities().max_priority()}};
  for (const auto& [id, a] : shard.ledger().actors())
    d.ledger.push_back({{"actor_id", id},
                        {"incarnation", a.incarnation},
                        {"next_seq", a.next_seq},
                        {"batches", a.batches},
                        {"transitions", a.transitions},
                        {"checksum", a.checksum},
                        {"incarnations", a.incarnations},
                        {"seq_jumps", a.seq_jumps}});
  return d;
}

// the chunks' descriptions and the rows' priorities and weights, gathered while DATA is written
struct ChunkTables {
  std::vector<SnapshotChunk> chunks;
  std::vector<float> prio;  // priority, weight per row
  uint64_t transitions = 0;
};

// writes the DATA section: chunk bytes in slices, each copied under the lock and written
// outside it (chunks evicted meanwhile are skipped); sets meta's first_id and first_row
ChunkTables WriteChunkData(std::mutex& mu, const Shard& shard, ShardDescription& d, Out& out) {
  const ChunkStore& store = shard.store();
  ChunkTables t;
  std::vector<uint64_t> chunk_hashes;
  std::vector<uint8_t> slice;
  slice.reserve(size_t(kSliceBytes) + (size_t(1) << 20));
  out.Begin("DATA");
  for (uint64_t id = d.first_id; id < d.end_id;) {
    slice.clear();
    {
      std::lock_guard lock(mu);
      for (; id < d.end_id && int64_t(slice.size()) < kSliceBytes; ++id) {
        int64_t i = store.IndexOf(id);
        if (i < 0) continue;  // evicted meanwhile
        const ChunkInfo& c = store.chunk(size_t(i));
        const uint8_t* b = store.bytes(size_t(i));
        if (t.chunks.empty()) {
          d.meta["first_id"] = c.id;
          d.meta["first_row"] = c.row_base;
        }
        slice.insert(slice.end(), b, b + c.bytes);
        chunk_hashes.push_back(HashBytes(b, size_t(c.bytes)));
        t.chunks.push_back({uint64_t(c.bytes), c.n_rows, c.transitions, c.n_deltas, c.actor_id, c.env_id, c.seq,
                            c.incarnation, c.episode_base, c.continues ? 1u : 0u});
        t.transitions += c.transitions;
        for (uint32_t r = 0; r < c.n_rows; ++r) {
          t.prio.push_back(shard.priorities().RawPriority(c.row_base + r));
          t.prio.push_back(shard.priorities().RawWeight(c.row_base + r));
        }
      }
    }
    out.Write(slice.data(), slice.size());
  }
  out.SetHash(HashBytes(chunk_hashes.data(), chunk_hashes.size() * 8));
  out.End();
  return t;
}

}  // namespace

Result<SnapshotWriteResult> WriteSnapshot(std::mutex& mu, const Shard& shard, const RateLimiter& limiter,
                                          const ReplayOptions& options, uint64_t command_id, const fs::path& path) {
  auto start = std::chrono::steady_clock::now();
  auto d = DescribeShard(mu, shard, limiter, command_id);
  if (!d.ok()) return d.status();

  fs::path tmp = path;
  tmp += ".tmp";
  Out out(tmp);
  if (!out.ok()) return Errorf("snapshot {}: cannot create: {}", tmp.string(), std::strerror(errno));
  out.Write(kMagic, 8);
  uint32_t version[2] = {kSnapshotFormat, 0};
  out.Write(version, 8);
  const ChunkTables t = WriteChunkData(mu, shard, *d, out);
  out.Begin("CHKD");
  out.Payload(t.chunks.data(), t.chunks.size() * sizeof(SnapshotChunk));
  out.End();
  out.Begin("PRIO");
  out.Payload(t.prio.data(), t.prio.size() * sizeof(float));
  out.End();
  d->meta["chunks"] = t.chunks.size();
  d->meta["transitions"] = t.transitions;
  d->meta["rows"] = t.prio.size() / 2;
  out.Section("LEDG", d->ledger.dump());
  out.Section("CONF", SnapshotConfig(options).dump());
  out.Section("META", d->meta.dump());
  out.Section("END!", "");
  if (!out.Sync()) return Errorf("snapshot {}: write failed: {}", tmp.string(), std::strerror(errno));

  // publish atomically: rename over, then make the rename durable (best effort)
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) return Errorf("snapshot {}: rename failed: {}", path.string(), ec.message());
  (void)SyncDirectory(path.parent_path().string()).ok();
  SnapshotWriteResult r;
  r.path = path.string();
  r.chunks = t.chunks.size();
  r.transitions = t.transitions;
  r.bytes = out.size();
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return r;
}

}  // namespace coins
