#include "orchestrator/chain_store.h"

#include <algorithm>
#include <charconv>
#include <fstream>
#include <regex>
#include <sstream>

#include "common/files.h"

namespace coins::chain {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// a string member of j, or "" when it is absent or not a string
std::string StringField(const json& j, const char* key) {
  auto it = j.find(key);
  return it != j.end() && it->is_string() ? it->get<std::string>() : std::string();
}

// the file written atomically (common/files.h), its directory created first
Status WriteState(const fs::path& path, const std::string& text) {
  std::error_code ec;
  fs::create_directories(path.parent_path(), ec);
  if (ec) return Errorf("cannot create directory {}: {}", path.parent_path().string(), ec.message());
  return WriteFileAtomic(path.string(), text);
}

}  // namespace

ChainStore::ChainStore(fs::path dir, ConfigValues fingerprint)
    : dir_(std::move(dir)), fingerprint_(std::move(fingerprint)), hash_(HashConfig(fingerprint_)) {}

fs::path ChainStore::EpochPath(uint64_t epoch) const {
  return dir_ / ("chain-epoch-" + std::to_string(epoch) + ".json");
}

std::string ChainStore::Render(const ChainState& s) const {
  json j = {{"format", "coins-chain"},
            {"schema", kChainStoreSchema},
            {"config_hash", hash_},
            {"config", fingerprint_},
            {"state", StateToJson(s)}};
  return j.dump(1) + "\n";
}

Status ChainStore::Save(const ChainState& s) const { return WriteState(StatePath(), Render(s)); }

Status ChainStore::SaveEpoch(const ChainState& s) const { return WriteState(EpochPath(s.epoch), Render(s)); }

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
  if (j.is_discarded() || !j.is_object())
    return Errorf("chain state {} is corrupt (not a JSON object){}", path.string(), keep);
  if (StringField(j, "format") != "coins-chain")
    return Errorf("chain state {} is corrupt (format is not coins-chain){}", path.string(), keep);
  if (!j.contains("schema") || !j["schema"].is_number_integer() || j["schema"].get<int>() != kChainStoreSchema)
    return Errorf("chain state {} has schema {} (this orchestrator reads {})", path.string(),
                  j.contains("schema") ? j["schema"].dump() : "none", kChainStoreSchema);
  ConfigValues theirs;
  if (j.contains("config") && j["config"].is_object())
    for (const auto& [k, v] : j["config"].items())
      if (v.is_string()) theirs[k] = v.get<std::string>();
  bool rewritten = false;  // keys the file predates, or keys it holds that this version no longer reads
  for (auto it = theirs.begin(); it != theirs.end();)
    if (IsRetiredAtItsValue(it->first, it->second))
      it = theirs.erase(it), rewritten = true;
    else
      ++it;
  for (const auto& [k, v] : defaults_)
    if (!theirs.count(k)) theirs[k] = v, rewritten = true;
  if ((!rewritten && StringField(j, "config_hash") != hash_) || theirs != fingerprint_) {
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
