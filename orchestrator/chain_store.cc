#include "orchestrator/chain_store.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cstring>
#include <fstream>
#include <regex>
#include <sstream>

namespace coins::chain {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// writes all of text to fd, retrying short writes and EINTR
bool WriteAll(int fd, const std::string& text) {
  size_t done = 0;
  while (done < text.size()) {
    ssize_t n = ::write(fd, text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    done += size_t(n);
  }
  return true;
}

Status FsyncDir(const fs::path& dir) {
  int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return Errorf("cannot open directory {}: {}", dir.string(), std::strerror(errno));
  int rc = ::fsync(fd);
  ::close(fd);
  if (rc != 0) return Errorf("cannot fsync directory {}: {}", dir.string(), std::strerror(errno));
  return Status::Ok();
}

// a string member of j, or "" when it is absent or not a string
std::string StringField(const json& j, const char* key) {
  auto it = j.find(key);
  return it != j.end() && it->is_string() ? it->get<std::string>() : std::string();
}

}  // namespace

Status WriteFileAtomic(const fs::path& path, const std::string& text) {
  std::error_code ec;
  const fs::path dir = path.has_parent_path() ? path.parent_path() : fs::path(".");
  fs::create_directories(dir, ec);
  if (ec) return Errorf("cannot create directory {}: {}", dir.string(), ec.message());
  const fs::path tmp = path.string() + ".tmp";
  int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) return Errorf("cannot create {}: {}", tmp.string(), std::strerror(errno));
  bool written = WriteAll(fd, text) && ::fsync(fd) == 0;
  int err = errno;
  ::close(fd);
  if (!written) {
    fs::remove(tmp, ec);
    return Errorf("cannot write {}: {}", tmp.string(), std::strerror(err));
  }
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    err = errno;
    fs::remove(tmp, ec);
    return Errorf("cannot rename {} to {}: {}", tmp.string(), path.string(), std::strerror(err));
  }
  return FsyncDir(dir);
}

ChainStore::ChainStore(fs::path dir, ConfigValues fingerprint)
    : dir_(std::move(dir)), fingerprint_(std::move(fingerprint)), hash_(HashConfig(fingerprint_)) {}

fs::path ChainStore::EpochPath(uint64_t epoch) const { return dir_ / ("chain-epoch-" + std::to_string(epoch) + ".json"); }

std::string ChainStore::Render(const ChainState& s) const {
  json j = {{"format", "coins-chain"}, {"schema", kChainStoreSchema}, {"config_hash", hash_},
            {"config", fingerprint_}, {"state", StateToJson(s)}};
  return j.dump(1) + "\n";
}

Status ChainStore::Save(const ChainState& s) const { return WriteFileAtomic(StatePath(), Render(s)); }

Status ChainStore::SaveEpoch(const ChainState& s) const { return WriteFileAtomic(EpochPath(s.epoch), Render(s)); }

Result<std::optional<ChainState>> ChainStore::Load() const {
  std::error_code ec;
  if (!fs::exists(StatePath(), ec)) return std::optional<ChainState>();
  auto s = LoadFile(StatePath());
  if (!s.ok()) return s.status();
  return std::optional<ChainState>(std::move(*s));
}

Result<ChainState> ChainStore::LoadEpoch(uint64_t epoch) const {
  std::error_code ec;
  if (!fs::exists(EpochPath(epoch), ec))
    return Errorf("no complete epoch {}: {} does not exist", epoch, EpochPath(epoch).string());
  return LoadFile(EpochPath(epoch));
}

Result<ChainState> ChainStore::LoadFile(const fs::path& path) const {
  std::ifstream in(path);
  if (!in) return Errorf("chain state {} cannot be read", path.string());
  std::stringstream text;
  text << in.rdbuf();
  const std::string keep = "; the file is left as it is";
  json j = json::parse(text.str(), nullptr, false);
  if (j.is_discarded() || !j.is_object()) return Errorf("chain state {} is corrupt (not a JSON object){}", path.string(), keep);
  if (StringField(j, "format") != "coins-chain")
    return Errorf("chain state {} is corrupt (format is not coins-chain){}", path.string(), keep);
  if (!j.contains("schema") || !j["schema"].is_number_integer() || j["schema"].get<int>() != kChainStoreSchema)
    return Errorf("chain state {} has schema {} (this orchestrator reads {})", path.string(),
                  j.contains("schema") ? j["schema"].dump() : "none", kChainStoreSchema);
  ConfigValues theirs;
  if (j.contains("config") && j["config"].is_object())
    for (const auto& [k, v] : j["config"].items())
      if (v.is_string()) theirs[k] = v.get<std::string>();
  if (StringField(j, "config_hash") != hash_ || theirs != fingerprint_) {
    std::string diff = FirstDifference(fingerprint_, theirs, path.string());
    return Errorf("chain state {} was written for another config: {}", path.string(),
                  diff.empty() ? "its config hash differs" : diff);
  }
  if (!j.contains("state")) return Errorf("chain state {} is corrupt (no state){}", path.string(), keep);
  auto s = StateFromJson(j["state"]);
  if (!s.ok()) return Errorf("chain state {} is corrupt ({}){}", path.string(), s.status().message(), keep);
  return s;
}

std::vector<uint64_t> ChainStore::Epochs(const fs::path& dir) {
  std::vector<uint64_t> out;
  std::error_code ec;
  static const std::regex kName(R"(chain-epoch-(\d+)\.json)");
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    std::smatch m;
    std::string name = e.path().filename().string();
    uint64_t n = 0;
    const std::string digits = std::regex_match(name, m, kName) ? m[1].str() : "";
    if (!digits.empty() && std::from_chars(digits.data(), digits.data() + digits.size(), n).ec == std::errc())
      out.push_back(n);
  }
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace coins::chain
