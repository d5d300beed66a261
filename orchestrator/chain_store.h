// ChainStore: the orchestrator's persisted chain state. RUN_DIR/chain/chain.json holds the newest
// state (written after every transition); chain-epoch-N.json holds the state of complete
// checkpoint epoch N. Plain C++ (no DDS).
//
// File (JSON): {"format": "coins-chain", "schema": 1, "config_hash": H, "config": {key: value},
// "state": {...}}; "config" is the chain fingerprint of the config that wrote it
// (config_values.h). Writes are atomic: a temporary file beside the target, fsync, rename, fsync
// of the directory; a crash leaves the old file or the new one, never a mix.
// Loading validates the format, the schema and every field's type; a state written for another
// config is refused with one line naming the first key that differs; a corrupt file is an error
// (and is never overwritten by the load).
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/status.h"
#include "orchestrator/chain_state.h"
#include "orchestrator/config_values.h"

namespace coins::chain {

inline constexpr int kChainStoreSchema = 1;

nlohmann::json StateToJson(const ChainState& s);
Result<ChainState> StateFromJson(const nlohmann::json& j);

class ChainStore {
 public:
  // dir: RUN_DIR/chain; fingerprint: ChainFingerprint of the running config
  ChainStore(std::filesystem::path dir, ConfigValues fingerprint);
  // a file written before a config key existed is read as holding that key's default here
  // (defaults: the ChainFingerprint of the default config), so adding a key does not orphan
  // every older run; a key changed from its default still refuses the file. Likewise a key the
  // file holds that this version no longer reads is dropped when it holds its retired value
  // (common/config/config.h, IsRetiredAtItsValue) and refuses the file otherwise
  void AcceptKeysAddedSince(ConfigValues defaults) { defaults_ = std::move(defaults); }

  std::filesystem::path StatePath() const { return dir_ / "chain.json"; }
  std::filesystem::path EpochPath(uint64_t epoch) const;
  Status Save(const ChainState& s) const;
  // chain-epoch-N.json with N = s.epoch
  Status SaveEpoch(const ChainState& s) const;
  // chain.json: nullopt when there is none; an error when corrupt or of another config
  Result<std::optional<ChainState>> Load() const;
  Result<ChainState> LoadEpoch(uint64_t epoch) const;
  // the epochs with a chain-epoch-N.json in dir, ascending (files are not validated)
  static std::vector<uint64_t> Epochs(const std::filesystem::path& dir);

 private:
  Result<ChainState> LoadFile(const std::filesystem::path& path) const;
  std::string Render(const ChainState& s) const;

  std::filesystem::path dir_;
  ConfigValues fingerprint_;
  ConfigValues defaults_;
  std::string hash_;
};

}  // namespace coins::chain
