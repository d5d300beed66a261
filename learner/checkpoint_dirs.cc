#include "learner/checkpoint_dirs.h"

#include <algorithm>
#include <filesystem>

#include <fmt/format.h>

namespace coins {

namespace fs = std::filesystem;

namespace {
constexpr std::string_view kPrefix = "learner-epoch-";

// N of "learner-epoch-N", or -1
int64_t EpochOf(const std::string& name) {
  if (name.rfind(kPrefix, 0) != 0) return -1;
  const std::string digits = name.substr(kPrefix.size());
  if (digits.empty() || digits.size() > 15 || digits.find_first_not_of("0123456789") != std::string::npos) return -1;
  return std::stoll(digits);
}
}  // namespace

std::string CheckpointDir(const std::string& run_dir, uint64_t epoch) {
  return (fs::path(run_dir) / "checkpoints" / fmt::format("{}{}", kPrefix, epoch)).string();
}

std::vector<int64_t> CheckpointEpochs(const std::string& run_dir) {
  std::vector<int64_t> epochs;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(fs::path(run_dir) / "checkpoints", ec)) {
    const int64_t n = EpochOf(e.path().filename().string());
    if (n >= 0 && fs::exists(e.path() / "state.json")) epochs.push_back(n);
  }
  std::sort(epochs.begin(), epochs.end());
  return epochs;
}

int64_t NewestCheckpointEpoch(const std::string& run_dir) {
  const std::vector<int64_t> epochs = CheckpointEpochs(run_dir);
  return epochs.empty() ? -1 : epochs.back();
}

Result<std::string> FindCheckpoint(const std::string& run_dir, int64_t epoch) {
  if (epoch >= 0) {
    const std::string dir = CheckpointDir(run_dir, uint64_t(epoch));
    if (!fs::exists(fs::path(dir) / "state.json"))
      return Errorf("{}: no learner checkpoint of epoch {}", run_dir, epoch);
    return dir;
  }
  const int64_t newest = NewestCheckpointEpoch(run_dir);
  if (newest < 0) return Errorf("{}: no learner checkpoint (checkpoints/learner-epoch-N/state.json)", run_dir);
  return CheckpointDir(run_dir, uint64_t(newest));
}

void PruneCheckpoints(const std::string& run_dir, int64_t keep) {
  const std::vector<int64_t> epochs = CheckpointEpochs(run_dir);
  std::error_code ec;
  for (size_t i = 0; i + size_t(keep) < epochs.size(); ++i)
    fs::remove_all(CheckpointDir(run_dir, uint64_t(epochs[i])), ec);
}

}  // namespace coins
