#include "orchestrator/run_setup.h"

#include <filesystem>

#include <fmt/format.h>

#include "actors/envs/env.h"
#include "orchestrator/chain_store.h"

namespace coins {

namespace fs = std::filesystem;

namespace {

// the flags as overrides, after the --set ones (flags win)
std::vector<std::string> Overrides(const RunFlags& f, const std::string& forced_dir) {
  std::vector<std::string> sets = f.overrides;
  if (f.actors >= 0) sets.push_back(fmt::format("run.actors={}", f.actors));
  if (f.shards >= 0) sets.push_back(fmt::format("run.shards={}", f.shards));
  if (f.steps >= 0) sets.push_back(fmt::format("run.steps={}", f.steps));
  if (!f.env.empty()) sets.push_back("run.env=" + f.env);
  if (!forced_dir.empty())
    sets.push_back("run.dir=" + forced_dir);
  else if (!f.dir.empty())
    sets.push_back("run.dir=" + f.dir);
  return sets;
}

// loads `file` (if any) and the overrides into c, validates, checks the env
Status Load(SystemConfig& c, const std::string& file, const std::vector<std::string>& sets, std::string* effective) {
  ConfigLoader loader = c.Loader();
  if (!file.empty()) COINS_RETURN_IF_ERROR(loader.LoadFile(file));
  for (const auto& s : sets) COINS_RETURN_IF_ERROR(loader.ApplyOverride(s));
  if (c.replay.snapshot_dir.empty()) c.replay.snapshot_dir = (fs::path(c.run.dir) / "replay").string();
  COINS_RETURN_IF_ERROR(loader.Validate());
  // every shard of the run on this machine
  COINS_RETURN_IF_ERROR(CheckShardMemory(c.replay, c.run.shards));
  auto env = envs::MakeEnv(c.run.env);
  if (!env.ok()) return env.status().WithContext("run.env");
  if (c.orchestrator.chain == "none" && c.learner.task.decision_period > 1)
    return Errorf(
        "learner.task_decision_period {}: with orchestrator.chain none the task acts on primitive actions, "
        "every env step (0 or 1)",
        c.learner.task.decision_period);
  if (effective) *effective = loader.Dump();
  return Status::Ok();
}

// the newest complete epoch of the run whose file loads with this config, and its env steps
Result<std::pair<int64_t, uint64_t>> NewestEpoch(const fs::path& chain_dir, const ConfigValues& fingerprint,
                                                 std::vector<std::string>* notes) {
  chain::ChainStore store(chain_dir, fingerprint);
  store.AcceptKeysAddedSince(ChainFingerprint(SystemConfig{}.Values()));
  std::vector<uint64_t> epochs = chain::ChainStore::Epochs(chain_dir);
  for (auto it = epochs.rbegin(); it != epochs.rend(); ++it) {
    auto s = store.LoadEpoch(*it);
    if (s.ok()) return std::pair{int64_t(*it), s->env_steps};
    notes->push_back(fmt::format("coins run: skipping epoch {}: {}", *it, s.status().message()));
  }
  return Errorf("no complete checkpoint epoch in {} (nothing to resume from; start a new run)", chain_dir.string());
}

Status ParseRoles(const RunFlags& f, const SystemConfig& c, RunPlan* plan) {
  auto roles =
      RunRoles::Parse(f.roles, f.actor_ids, f.shard_ids, c.run.actors, c.run.shards, c.dds.discovery == "server");
  if (!roles.ok()) return roles.status();
  plan->roles = *roles;
  return Status::Ok();
}

Status PrepareResume(const RunFlags& f, SystemConfig& c, RunPlan* plan) {
  const std::string dir = f.resume;
  const std::string base_file = (fs::path(dir) / "config.yaml").string();
  if (!fs::exists(base_file)) return Errorf("{} not found: not a run directory", base_file);
  SystemConfig base;
  COINS_RETURN_IF_ERROR(Load(base, base_file, {"run.dir=" + dir}, nullptr));
  const ConfigValues theirs = ChainFingerprint(base.Values());
  if (!f.config.empty()) {
    SystemConfig other;
    COINS_RETURN_IF_ERROR(Load(other, f.config, Overrides(f, dir), nullptr));
    std::string diff = FirstDifference(ChainFingerprint(other.Values()), theirs, base_file);
    if (!diff.empty()) return Errorf("config {} differs from the run's: {}", f.config, diff);
  }
  COINS_RETURN_IF_ERROR(Load(c, base_file, Overrides(f, dir), &plan->effective));
  std::string diff = FirstDifference(ChainFingerprint(c.Values()), theirs, base_file);
  if (!diff.empty()) return Errorf("the flags change the run's config: {}", diff);
  plan->resuming = true;
  COINS_RETURN_IF_ERROR(ParseRoles(f, c, plan));
  // a host without the orchestrator has no chain state: its processes resume from their own
  // newest files (shards their snapshots, the learner its checkpoints)
  if (!plan->roles.Has("orchestrator")) return Status::Ok();
  auto epoch = NewestEpoch(fs::path(dir) / "chain", theirs, &plan->notes);
  if (!epoch.ok()) return epoch.status();
  plan->resume_epoch = epoch->first;
  plan->resume_env_steps = epoch->second;
  return Status::Ok();
}

}  // namespace

Status PrepareRun(const RunFlags& f, SystemConfig& c, RunPlan* plan) {
  if (!f.resume.empty()) return PrepareResume(f, c, plan).WithContext("--resume " + f.resume);
  COINS_RETURN_IF_ERROR(Load(c, f.config, Overrides(f, ""), &plan->effective));
  return ParseRoles(f, c, plan);
}

Status ClearPreviousRun(const SystemConfig& c, const RunRoles& roles, RunPlan* plan) {
  const fs::path dir(c.run.dir);
  std::vector<fs::path> old;
  if (roles.Has("orchestrator")) old.push_back(dir / "chain");
  if (roles.Has("learner")) old.push_back(dir / "checkpoints");
  if (roles.Has("replay") && fs::path(c.replay.snapshot_dir) == dir / "replay") old.push_back(dir / "replay");
  std::string removed;
  for (const auto& p : old) {
    std::error_code ec;
    if (!fs::exists(p, ec)) continue;
    fs::remove_all(p, ec);
    if (ec) return Errorf("cannot remove the previous run's {}: {}", p.string(), ec.message());
    removed += (removed.empty() ? "" : ", ") + p.filename().string() + "/";
  }
  if (!removed.empty())
    plan->notes.push_back(
        fmt::format("coins run: new run in {}: removed the previous run's {} (continue a run "
                    "with --resume {})",
                    c.run.dir, removed, c.run.dir));
  return Status::Ok();
}

}  // namespace coins
