#include "orchestrator/transfer.h"

#include <filesystem>
#include <iostream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "actors/envs/env.h"
#include "common/cli_checks.h"
#include "common/files.h"
#include "learner/checkpoint_dirs.h"
#include "learner/transfer_checkpoint.h"
#include "orchestrator/chain_messages.h"
#include "orchestrator/chain_store.h"
#include "orchestrator/config_values.h"
#include "orchestrator/system_config.h"

namespace coins {

namespace {

namespace fs = std::filesystem;

// what the transfer starts from, checked before anything starts
struct TransferSource {
  envs::EnvSpec trained, target;
  chain::ChainState chain;  // the transfer's chain (phase task)
  bool finetune = false;    // the source has no chain: its task policy is fine-tuned
};

Result<TransferSource> OpenSource(const TransferFlags& f) {
  const fs::path dir(f.source);
  const std::string config = (dir / "config.yaml").string();
  if (!fs::exists(config)) return Errorf("{}: not a run directory (no config.yaml)", f.source);
  SystemConfig source;
  ConfigLoader loader = source.Loader();
  COINS_RETURN_IF_ERROR(loader.LoadFile(config));
  COINS_RETURN_IF_ERROR(loader.Validate().WithContext(config));
  auto trained = envs::MakeEnv(source.run.env);
  if (!trained.ok()) return trained.status().WithContext(config);
  auto target = envs::MakeEnv(f.env);
  if (!target.ok()) return target.status().WithContext("--env");
  chain::ChainStore store = OpenChainStore(dir, source);
  auto learned = store.Load();
  if (!learned.ok()) return learned.status();
  if (!*learned) return Errorf("{}: no chain state ({})", f.source, store.StatePath().string());
  const bool finetune = source.orchestrator.chain == "none";
  auto chain = chain::TransferState(**learned, finetune ? std::string() : f.skill);
  if (!chain.ok()) return chain.status().WithContext(f.source);
  const envs::EnvSpec& spec = (*target)->spec();
  for (const chain::Link& l : chain->links)
    for (const std::string& factor : {l.spec.source, l.spec.target})
      if (factor != "Action" && spec.factor_index(factor) < 0)
        return Errorf("link {}->{} of {}: env {} has no factor {}", l.spec.source, l.spec.target, f.source, spec.name,
                      factor);
  return TransferSource{(*trained)->spec(), spec, std::move(*chain), finetune};
}

// the transfer run's chain, learner checkpoint (epoch 0) and transfer.json
Status SeedRun(const TransferFlags& f, const TransferSource& src, const SystemConfig& config) {
  SystemConfig c = config;
  const fs::path dir(c.run.dir);
  chain::ChainStore store = OpenChainStore(dir, c);
  COINS_RETURN_IF_ERROR(store.Save(src.chain));
  COINS_RETURN_IF_ERROR(store.SaveEpoch(src.chain));
  std::vector<msg::LinkSpec> links;
  for (const chain::Link& l : src.chain.links) links.push_back(ToMessage(l.spec));
  auto skills =
      WriteTransferCheckpoint(f.source, src.trained, src.target, c.learner, links, CheckpointDir(c.run.dir, 0));
  if (!skills.ok()) return skills.status();
  nlohmann::json j = {{"from", fs::absolute(f.source).lexically_normal().string()},
                      {"env", src.target.name},
                      {"trained_env", src.trained.name},
                      {"skill", src.finetune ? "" : f.skill},
                      {"finetune", src.finetune}};
  for (const chain::Link& l : src.chain.links) j["links"].push_back(l.spec.source + "->" + l.spec.target);
  j.update(ToJson(*skills));
  COINS_RETURN_IF_ERROR(WriteFileAtomic((dir / "transfer.json").string(), j.dump(1) + "\n"));
  if (src.finetune)
    std::cout << fmt::format("coins transfer: fine-tuning the task policy of {} (trained on {}) on {}", f.source,
                             src.trained.name, src.target.name)
              << "\n";
  else
    std::cout << fmt::format("coins transfer: the {} skill of {} (trained on {}, {} levels, frozen) on {}", f.skill,
                             f.source, src.trained.name, skills->levels.size(), src.target.name)
              << "\n";
  return Status::Ok();
}

}  // namespace

int RunTransfer(const TransferFlags& f) {
  RunFlags run = f.run;
  run.command = "coins transfer";
  if (!run.resume.empty()) return RunLocal(run);  // a transfer run resumes like any run
  auto src = OpenSource(f);
  if (!src.ok()) {
    std::cerr << "coins transfer: " << src.status().message() << "\n";
    return 2;
  }
  run.config = (fs::path(f.source) / "config.yaml").string();
  run.env = f.env;
  if (run.dir.empty()) run.dir = (fs::path(f.source) / "transfer" / f.env).string();
  // the source's snapshot directory is its own; the run stops when the task is done
  std::vector<std::string> sets = {"replay.snapshot_dir=" + (fs::path(run.dir) / "replay").string(), "run.steps=0"};
  if (f.steps >= 0) {
    sets.push_back(fmt::format("orchestrator.task_max_steps={}", f.steps));
    sets.push_back(fmt::format("orchestrator.task_min_steps={}", f.steps));
  }
  sets.insert(sets.end(), run.overrides.begin(), run.overrides.end());
  run.overrides = sets;
  return RunLocal(run, [&](const SystemConfig& c) { return SeedRun(f, *src, c); });
}

void AddTransferCommand(CLI::App& app, int* exit_code) {
  auto f = std::make_shared<TransferFlags>();
  CLI::App* cmd = app.add_subcommand(
      "transfer",
      "Train a new task policy over a run's learned skills (frozen) on another env, e.g. a Breakout variant.");
  cmd->add_option("run_dir", f->source, "the run whose chain is transferred");
  cmd->add_option("--env", f->env, "the env to transfer to, e.g. breakout-single (see `coins env list`)");
  cmd->add_option("--skill", f->skill, "the chain's top skill the task acts through (default Ball)");
  cmd->add_option("--steps", f->steps, "task env steps (default: the config's orchestrator.task_max_steps)")
      ->check(cli::Integer(1, int64_t(1) << 50));
  AddRunFlags(cmd, &f->run);
  cmd->footer(
      "The new run goes to RUN_DIR/transfer/ENV unless --dir says otherwise; `coins transfer --resume DIR` continues "
      "it. --set changes its config (the task's learner.task_* keys; the skills' keys must stay as trained).");
  cmd->callback([f, exit_code] {
    if (f->run.resume.empty() && (f->source.empty() || f->env.empty())) {
      std::cerr << "coins transfer: give RUN_DIR and --env (or --resume DIR to continue a transfer run)\n";
      *exit_code = 2;
      return;
    }
    *exit_code = RunTransfer(*f);
  });
}

}  // namespace coins
