// Snapshots of a replay shard: a versioned file format, a writer that runs beside traffic, and
// a reader that validates everything before anything is restored.
//
// File: "COINSRPL", u32 format version, u32 reserved, then sections, each a 24-byte header
// (4-byte tag, u32 reserved (0), u64 payload length, u64 HashBytes of the payload; for DATA,
// HashBytes of the array of per-chunk HashBytes) and its payload:
//   DATA  chunk bytes, concatenated (the arena's compact delta chunks, as stored)
//   CHKD  one 80-byte record per chunk (10 x u64: bytes, rows, transitions, deltas, actor,
//         env, seq, incarnation, episode_base, continues)
//   PRIO  per row of those chunks: f32 priority^alpha, f32 weight
//   LEDG  JSON: per-actor ledger (incarnation, next_seq, batches, transitions, checksum)
//   CONF  JSON: the replay options that shape the data (capacity, rate limiter, exponents)
//   META  JSON: shard id, time, layout and dims, counts, shard and rate-limiter counters
//   END!  empty; a file without it is truncated
// Every section's hash is checked on read; a missing, short or corrupt section fails the read
// with one line naming the file and the section.
//
// Writing without stopping traffic: the chunk descriptors, ledger and counters are copied under
// the shard's lock (short), then chunk bytes are copied out of the arena in slices of 1 MiB,
// each slice under the lock and written to the file outside it. A chunk evicted before its
// slice is reached is left out (FIFO eviction makes that a prefix of the chunks), and the
// counts in META describe what was written. Atomic: temp file, fsync, rename, fsync of the dir.
#pragma once

#include <cstdint>
#include <filesystem>
#include <mutex>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/status.h"
#include "replay/rate_limiter.h"
#include "replay/replay_options.h"
#include "replay/shard.h"

namespace coins {

inline constexpr uint32_t kSnapshotFormat = 2;  // 2: chunks carry the provenance block

struct SnapshotChunk {
  uint64_t bytes, rows, transitions, deltas, actor, env, seq, incarnation, episode_base, continues;
};

struct SnapshotSection {
  std::string tag;
  uint64_t length = 0;
  bool ok = false;
};

// a snapshot read back and validated
struct SnapshotImage {
  uint32_t format = 0;
  nlohmann::json meta, config, ledger;
  std::vector<SnapshotChunk> chunks;
  std::vector<uint8_t> data;
  std::vector<float> priorities;  // rows x 2 (priority^alpha, weight)
  std::vector<SnapshotSection> sections;
};

struct SnapshotWriteResult {
  std::string path;
  uint64_t chunks = 0, transitions = 0, bytes = 0;
  double seconds = 0;
};

// the config keys a snapshot keeps, as JSON
nlohmann::json SnapshotConfig(const ReplayOptions& o);
// keys whose values differ between a snapshot's config and `o`, as "key: snapshot -> new"
std::vector<std::string> ConfigDifferences(const nlohmann::json& snapshot, const ReplayOptions& o);
// applies a snapshot's config to `o`
void ApplySnapshotConfig(const nlohmann::json& snapshot, ReplayOptions* o);

// lowers the calling thread's CPU priority (nice +10): a snapshot writer yields the CPU to
// ingest and sampling on a busy machine
void LowerThreadPriority();
// writes a snapshot of `shard` (guarded by `mu`) to `path` while others keep using it
Result<SnapshotWriteResult> WriteSnapshot(std::mutex& mu, const Shard& shard, const RateLimiter& limiter,
                                          const ReplayOptions& options, uint64_t command_id,
                                          const std::filesystem::path& path);
// reads and checks a whole snapshot
Result<SnapshotImage> ReadSnapshot(const std::filesystem::path& path);
// reads as far as it can into *img (sections seen, with ok flags), for `coins replay inspect`
Status InspectSnapshot(const std::filesystem::path& path, SnapshotImage* img);
// refills an empty shard and the rate limiter from an image
Status RestoreShard(const SnapshotImage& image, Shard* shard, RateLimiter* limiter);

// snapshot files of a shard in dir, newest first; the next file name to write
std::vector<std::filesystem::path> ListSnapshots(const std::filesystem::path& dir, uint32_t shard_id);
std::filesystem::path NextSnapshotPath(const std::filesystem::path& dir, uint32_t shard_id);
// the command a snapshot was written for (META's command_id; 0: periodic or final), reading
// only the section headers and META
Result<uint64_t> ReadSnapshotCommand(const std::filesystem::path& path);
// deletes the shard's snapshots beyond the newest `keep`, except those of the newest `keep`
// checkpoint epochs (IsCheckpointCommand): final and periodic snapshots never push out the epoch
// a resume needs
void PruneSnapshots(const std::filesystem::path& dir, uint32_t shard_id, int64_t keep);

}  // namespace coins
