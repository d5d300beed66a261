// reading, checking and restoring snapshots (format in snapshot.h)
#include <algorithm>
#include <charconv>
#include <cstring>
#include <fstream>
#include <set>

#include "common/checkpoint.h"
#include "replay/snapshot.h"

namespace coins {

namespace fs = std::filesystem;

namespace {

// the magic and the format version
Status ReadHeader(std::ifstream& in, const std::string& name, SnapshotImage& img) {
  char magic[8];
  uint32_t version[2];
  if (!in.read(magic, 8) || std::memcmp(magic, "COINSRPL", 8) != 0)
    return Errorf("snapshot {}: not a coins replay snapshot (bad magic)", name);
  if (!in.read(reinterpret_cast<char*>(version), 8)) return Errorf("snapshot {}: truncated header", name);
  if (version[0] != kSnapshotFormat)
    return Errorf("snapshot {}: format version {} (this build reads {})", name, version[0], kSnapshotFormat);
  if (version[1] != 0) return Errorf("snapshot {}: header is corrupt (reserved field set)", name);
  img.format = version[0];
  return Status::Ok();
}

// the header of section number `index`: a known tag, the reserved field 0, a payload length
// the file can hold
Status ReadSectionHeader(std::ifstream& in, const std::string& name, size_t index, uint64_t file_size, std::string* tag,
                         uint64_t* length, uint64_t* hash) {
  uint8_t h[24];
  if (!in.read(reinterpret_cast<char*>(h), 24))
    return Errorf("snapshot {}: truncated (no END section after {} sections)", name, index);
  tag->assign(reinterpret_cast<char*>(h), 4);
  uint32_t reserved;
  std::memcpy(&reserved, h + 4, 4);
  std::memcpy(length, h + 8, 8);
  std::memcpy(hash, h + 16, 8);
  static const std::set<std::string> kTags = {"DATA", "CHKD", "PRIO", "LEDG", "CONF", "META", "END!"};
  if (reserved != 0 || !kTags.count(*tag)) return Errorf("snapshot {}: section header {} is corrupt", name, index);
  if (*length > file_size)
    return Errorf("snapshot {}: truncated in section '{}' ({} bytes announced)", name, *tag, *length);
  return Status::Ok();
}

// keeps a checked section's payload (not DATA) in the image; *ended at END!
Status TakeSection(const std::string& name, const std::string& tag, std::vector<uint8_t>& buf, SnapshotImage& img,
                   bool* ended) {
  const uint64_t length = buf.size();
  if (tag == "END!") {
    *ended = true;
  } else if (tag == "CHKD") {
    if (length % sizeof(SnapshotChunk)) return Errorf("snapshot {}: section 'CHKD' has a partial record", name);
    img.chunks.resize(size_t(length / sizeof(SnapshotChunk)));
    std::memcpy(img.chunks.data(), buf.data(), size_t(length));
  } else if (tag == "PRIO") {
    img.priorities.resize(size_t(length / 4));
    std::memcpy(img.priorities.data(), buf.data(), size_t(length / 4 * 4));
  } else if (tag == "LEDG" || tag == "CONF" || tag == "META") {
    auto j = nlohmann::json::parse(buf.begin(), buf.end(), nullptr, false);
    if (j.is_discarded()) return Errorf("snapshot {}: section '{}' is not valid JSON", name, tag);
    (tag == "LEDG" ? img.ledger : tag == "CONF" ? img.config : img.meta) = std::move(j);
  }
  return Status::Ok();
}

// the sections up to END!, each checked against its hash except DATA (its hash in *data_hash)
Status ReadSections(std::ifstream& in, const std::string& name, uint64_t file_size, SnapshotImage& img,
                    uint64_t* data_hash) {
  std::vector<uint8_t> buf;
  for (bool ended = false; !ended;) {
    std::string tag;
    uint64_t length, hash;
    COINS_RETURN_IF_ERROR(ReadSectionHeader(in, name, img.sections.size(), file_size, &tag, &length, &hash));
    buf.resize(size_t(length));
    if (!in.read(reinterpret_cast<char*>(buf.data()), std::streamsize(length)))
      return Errorf("snapshot {}: truncated in section '{}'", name, tag);
    img.sections.push_back({tag, length, true});
    if (tag == "DATA") {
      // checked once the chunk records are known
      img.data = std::move(buf);
      buf = {};
      *data_hash = hash;
      continue;
    }
    if (HashBytes(buf.data(), buf.size()) != hash) {
      img.sections.back().ok = false;
      return Errorf("snapshot {}: section '{}' fails its checksum", name, tag);
    }
    COINS_RETURN_IF_ERROR(TakeSection(name, tag, buf, img, &ended));
  }
  return Status::Ok();
}

// what the sections must say together: all present, DATA as the chunk records describe it,
// a priority and a weight per row, META's layout
Status CheckImage(const std::string& name, uint64_t data_hash, SnapshotImage& img) {
  for (const char* need : {"DATA", "CHKD", "PRIO", "LEDG", "CONF", "META"})
    if (std::none_of(img.sections.begin(), img.sections.end(), [&](const auto& s) { return s.tag == need; }))
      return Errorf("snapshot {}: section '{}' is missing", name, need);
  // DATA: the chunk sizes must add up, and the hash of the per-chunk hashes must match
  uint64_t total = 0, rows = 0;
  std::vector<uint64_t> chunk_hashes;
  for (const auto& c : img.chunks) {
    if (c.bytes > img.data.size() - std::min<uint64_t>(total, img.data.size()))
      return Errorf("snapshot {}: chunk records describe more bytes than section 'DATA' holds", name);
    chunk_hashes.push_back(HashBytes(img.data.data() + total, size_t(c.bytes)));
    total += c.bytes;
    rows += c.rows;
  }
  auto data = std::find_if(img.sections.begin(), img.sections.end(), [](const auto& s) { return s.tag == "DATA"; });
  if (total != img.data.size() || HashBytes(chunk_hashes.data(), chunk_hashes.size() * 8) != data_hash) {
    data->ok = false;
    return Errorf("snapshot {}: section 'DATA' fails its checksum", name);
  }
  if (img.priorities.size() != rows * 2)
    return Errorf("snapshot {}: section 'PRIO' holds {} values for {} rows", name, img.priorities.size(), rows);
  for (const char* key : {"layout_hash", "state_dim", "action_dim", "goal_dim", "shard_id"})
    if (!img.meta.contains(key) || !img.meta[key].is_number_unsigned())
      return Errorf("snapshot {}: section 'META' lacks '{}'", name, key);
  return Status::Ok();
}

// opens a snapshot and checks its header; *file_size for the section reader
Status Open(const fs::path& path, std::ifstream& in, SnapshotImage& img, uint64_t* file_size) {
  in.open(path, std::ios::binary);
  if (!in) return Errorf("snapshot {}: cannot open", path.string());
  COINS_RETURN_IF_ERROR(ReadHeader(in, path.string(), img));
  in.seekg(0, std::ios::end);
  *file_size = uint64_t(in.tellg());
  in.seekg(16);
  return Status::Ok();
}

Status Read(const fs::path& path, SnapshotImage& img) {
  std::ifstream in;
  uint64_t file_size = 0;
  COINS_RETURN_IF_ERROR(Open(path, in, img, &file_size));
  const std::string name = path.string();
  uint64_t data_hash = 0;
  COINS_RETURN_IF_ERROR(ReadSections(in, name, file_size, img, &data_hash));
  return CheckImage(name, data_hash, img);
}

}  // namespace

Result<SnapshotImage> ReadSnapshot(const fs::path& path) {
  SnapshotImage img;
  Status s = Read(path, img);
  if (!s.ok()) return s;
  return img;
}

Status InspectSnapshot(const fs::path& path, SnapshotImage* img) { return Read(path, *img); }

Result<uint64_t> ReadSnapshotCommand(const fs::path& path) {
  std::ifstream in;
  SnapshotImage img;
  uint64_t file_size = 0;
  COINS_RETURN_IF_ERROR(Open(path, in, img, &file_size));
  const std::string name = path.string();
  std::vector<uint8_t> buf;
  for (size_t index = 0;; ++index) {
    std::string tag;
    uint64_t length, hash;
    COINS_RETURN_IF_ERROR(ReadSectionHeader(in, name, index, file_size, &tag, &length, &hash));
    if (tag == "END!") return Errorf("snapshot {}: section 'META' is missing", name);
    if (tag != "META") {
      if (!in.seekg(std::streamoff(length), std::ios::cur))
        return Errorf("snapshot {}: truncated in section '{}'", name, tag);
      continue;
    }
    buf.resize(size_t(length));
    if (!in.read(reinterpret_cast<char*>(buf.data()), std::streamsize(length)))
      return Errorf("snapshot {}: truncated in section 'META'", name);
    if (HashBytes(buf.data(), buf.size()) != hash)
      return Errorf("snapshot {}: section 'META' fails its checksum", name);
    bool ended = false;
    COINS_RETURN_IF_ERROR(TakeSection(name, tag, buf, img, &ended));
    return img.meta.value("command_id", uint64_t(0));
  }
}

Status RestoreShard(const SnapshotImage& img, Shard* shard, RateLimiter* limiter) {
  const auto& m = img.meta;
  ChunkStore& store = shard->mutable_store();
  COINS_RETURN_IF_ERROR(store.Configure(m["layout_hash"].get<uint32_t>(), m["state_dim"].get<uint32_t>(),
                                        m["action_dim"].get<uint32_t>(), m["goal_dim"].get<uint32_t>()));
  // chunks in order, under their old global numbers; each one's rows get their saved
  // priorities and weights
  store.SetNextIds(m.value("first_id", uint64_t(0)), m.value("first_row", uint64_t(0)));
  uint64_t offset = 0, row = 0;
  for (const SnapshotChunk& c : img.chunks) {
    ChunkInfo info{0,
                   int64_t(c.bytes),
                   uint32_t(c.rows),
                   uint32_t(c.transitions),
                   uint32_t(c.deltas),
                   uint32_t(c.actor),
                   uint32_t(c.env),
                   c.seq};
    info.incarnation = c.incarnation;
    info.episode_base = c.episode_base;
    info.continues = c.continues != 0;
    COINS_RETURN_IF_ERROR(store.InsertRaw(info, img.data.data() + offset));
    size_t last = store.chunks() - 1;
    const ChunkInfo& held = store.chunk(last);
    shard->priorities().OnInsert(held.row_base, store.flags(last), store.skill_levels(last), held.n_rows);
    shard->levels().OnInsert(store, last);
    for (uint32_t r = 0; r < held.n_rows; ++r)
      shard->priorities().SetRaw(held.row_base + r, img.priorities[2 * (row + r)], img.priorities[2 * (row + r) + 1]);
    offset += c.bytes;
    row += c.rows;
  }
  IngestLedger& ledger = shard->mutable_ledger();
  for (const auto& a : img.ledger) {
    ActorLedger l;
    l.incarnation = a.value("incarnation", uint64_t(0));
    l.next_seq = a.value("next_seq", uint64_t(0));
    l.batches = a.value("batches", uint64_t(0));
    l.transitions = a.value("transitions", uint64_t(0));
    l.checksum = a.value("checksum", uint64_t(0));
    l.incarnations = a.value("incarnations", uint64_t(1));
    l.seq_jumps = a.value("seq_jumps", uint64_t(0));
    ledger.Restore(a.value("actor_id", uint32_t(0)), l);
  }
  ledger.RestoreTotals(m.value("duplicates", uint64_t(0)), m.value("gaps", uint64_t(0)),
                       m.value("seq_jumps", uint64_t(0)));
  shard->RestoreCounters({m.value("inserted_transitions", uint64_t(0)), m.value("inserted_batches", uint64_t(0)),
                          m.value("rejected", uint64_t(0))});
  limiter->Restore({m.value("rate_inserted", uint64_t(0)), m.value("rate_sampled", uint64_t(0))});
  return Status::Ok();
}

namespace {

// the number of a snapshot file name of the shard; false for other names and for numbers that
// do not fit 64 bits (a stray file is skipped, never fatal)
bool SnapshotNumber(const std::string& file, uint32_t shard_id, uint64_t* n) {
  const std::string prefix = "shard-" + std::to_string(shard_id) + "-", suffix = ".snap";
  if (file.size() <= prefix.size() + suffix.size() || file.compare(0, prefix.size(), prefix) != 0 ||
      file.compare(file.size() - suffix.size(), suffix.size(), suffix) != 0)
    return false;
  const char* begin = file.data() + prefix.size();
  const char* end = file.data() + file.size() - suffix.size();
  if (*begin < '0' || *begin > '9') return false;
  auto [p, ec] = std::from_chars(begin, end, *n);
  return ec == std::errc() && p == end;
}

}  // namespace

std::vector<fs::path> ListSnapshots(const fs::path& dir, uint32_t shard_id) {
  std::vector<std::pair<uint64_t, fs::path>> found;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    uint64_t n = 0;
    if (SnapshotNumber(e.path().filename().string(), shard_id, &n)) found.emplace_back(n, e.path());
  }
  std::sort(found.begin(), found.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  std::vector<fs::path> out;
  for (auto& f : found) out.push_back(f.second);
  return out;
}

fs::path NextSnapshotPath(const fs::path& dir, uint32_t shard_id) {
  // one above the newest; numbers near the top of the range (stray files) are passed over
  uint64_t next = 0;
  for (const auto& f : ListSnapshots(dir, shard_id)) {
    uint64_t n = 0;
    if (SnapshotNumber(f.filename().string(), shard_id, &n) && n < (uint64_t(1) << 62)) next = std::max(next, n + 1);
  }
  return dir / fmt::format("shard-{}-{:08d}.snap", shard_id, next);
}

void PruneSnapshots(const fs::path& dir, uint32_t shard_id, int64_t keep) {
  auto list = ListSnapshots(dir, shard_id);
  int64_t epochs = 0;
  for (size_t i = 0; i < list.size(); ++i) {
    // a snapshot whose META cannot be read counts as no epoch's: it never holds back pruning
    auto command = ReadSnapshotCommand(list[i]);
    const bool epoch = command.ok() && IsCheckpointCommand(*command);
    const bool kept = int64_t(i) < keep || (epoch && epochs < keep);
    epochs += epoch;
    if (kept) continue;
    std::error_code ec;
    fs::remove(list[i], ec);
  }
}

}  // namespace coins
