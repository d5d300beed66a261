// LearnerCore checkpoints: RUN_DIR/checkpoints/learner-epoch-N/ holding state.json (job
// bookkeeping, versions, specs, counters), trainer-L.bin (each level's networks, targets and
// optimiser moments, common/nn/serialize.h format), detector-T.bin (each target's newest
// detector), task-best.bin (the best-evaluated task policy's acting weights, when there is
// one) and skill-candidate-K.bin (a training skill's snapshots, or the candidates of a choice of
// a skill's weights under way: learner/skill_selection.h). The directory is written under a temporary name and renamed
// whole.
#include <filesystem>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "common/files.h"
#include "common/nn/serialize.h"
#include "common/policy/policy_net.h"
#include "common/policy/weights_msg.h"
#include "learner/learner_core.h"
#include "learner/trainers/input_remap.h"
#include "learner/trainers/level_builder.h"

namespace coins {

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

std::vector<uint8_t> StateBlob(const rl::AlgorithmState& st) {
  std::vector<const nn::ParamSet*> sets;
  for (const auto& s : st.sets) sets.push_back(&s);
  return nn::ToBlob(std::span<const nn::ParamSet* const>(sets.data(), sets.size()));
}

// reads a blob into sets shaped like `shape` (the trainer's own current state)
Status LoadStateBlob(std::span<const uint8_t> blob, rl::AlgorithmState* shape, const std::string& source) {
  std::vector<nn::ParamSet*> sets;
  for (auto& s : shape->sets) sets.push_back(&s);
  return nn::FromBlob(blob, std::span<nn::ParamSet* const>(sets.data(), sets.size()), source);
}

}  // namespace

Status LearnerCore::SaveCheckpoint(const std::string& dir, uint64_t epoch, uint64_t command_id) {
  const std::string tmp = dir + ".tmp";
  std::error_code ec;
  fs::remove_all(tmp, ec);
  fs::create_directories(tmp, ec);
  if (ec) return Errorf("{}: cannot create: {}", tmp, ec.message());
  json j = {{"format", 1},
            {"epoch", epoch},
            {"command_id", command_id},
            {"generation", generation_},
            {"command_seq", command_.seq()},
            {"train_level", train_level_},
            {"job_start_updates", job_start_updates_},
            {"detect_done_seq", detect_done_seq_},
            {"next_eval_at", next_eval_at_},
            {"next_retrain_at", next_retrain_at_},
            {"total_updates", status_.total_updates()},
            {"counters", counters_}};
  for (const auto& [level, t] : trainers_) {
    const rl::AlgorithmState st = t->ExportState();
    const std::string file = "trainer-" + std::to_string(level) + ".bin";
    COINS_RETURN_IF_ERROR(WriteFileAtomic(tmp + "/" + file, StateBlob(st)));
    // what the first weights published after a resume from this checkpoint carry
    const uint32_t acting = policy::WeightsChecksum(ToJson(t->spec()).dump(), t->ActingBlob());
    j["trainers"].push_back({{"level", level},
                             {"name", t->spec().name},
                             {"spec", ToJson(t->spec())},
                             {"counters", st.counters},
                             {"file", file},
                             {"acting_average", t->acting_average()},
                             {"acting_checksum", acting}});
  }
  if (best_task_) {
    COINS_RETURN_IF_ERROR(WriteFileAtomic(tmp + "/task-best.bin", best_task_->acting));
    j["best_task"] = {{"level", best_task_->level},
                      {"env_steps", best_task_->env_steps},
                      {"return_mean", best_task_->return_mean},
                      {"return_sd", best_task_->return_sd},
                      {"episodes", best_task_->episodes},
                      {"seed", best_task_->seed},
                      {"file", "task-best.bin"}};
    for (size_t i = 0; i < best_task_->skills.size(); ++i) {
      const std::string file = "task-best-skill-" + std::to_string(i + 1) + ".bin";
      COINS_RETURN_IF_ERROR(WriteFileAtomic(tmp + "/" + file, best_task_->skills[i]));
      j["best_task"]["skill_files"].push_back(file);
    }
  }
  COINS_RETURN_IF_ERROR(SaveSelection(tmp, &j));
  for (const auto& [target, d] : detectors_) {
    if (!d.det) continue;
    const std::string file = "detector-" + target + ".bin";
    COINS_RETURN_IF_ERROR(WriteFileAtomic(tmp + "/" + file, d.det->WeightsBlob()));
    j["detectors"].push_back({{"target", target}, {"spec", detector::ToJson(d.spec)}, {"file", file}});
  }
  for (const auto& [name, w] : published_)
    j["published"].push_back({{"name", name}, {"version", w.version()}, {"checksum", w.checksum()}});
  j["eval"] = {{"env_steps", status_.eval_env_steps()}, {"return_mean", status_.eval_return_mean()},
               {"return_sd", status_.eval_return_sd()}, {"episodes", status_.eval_episodes()},
               {"success", status_.eval_success()},     {"angle_accuracy", status_.eval_angle_accuracy()},
               {"hit_rate", status_.eval_hit_rate()}};
  COINS_RETURN_IF_ERROR(WriteFileAtomic(tmp + "/state.json", j.dump(1)));
  COINS_RETURN_IF_ERROR(ReplaceDirectory(tmp, dir));
  status_.checkpoint_epoch(epoch);
  status_.checkpoint_command(command_id);
  return Status::Ok();
}

Status LearnerCore::LoadCheckpoint(const std::string& dir) {
  auto text = ReadFileText(dir + "/state.json");
  if (!text.ok()) return text.status();
  json j = json::parse(*text, nullptr, false);
  if (j.is_discarded() || !j.is_object() || j.value("format", 0) != 1)
    return Errorf("{}/state.json: not a learner checkpoint", dir);
  try {
    trainers_.clear();
    for (const auto& tj : j.value("trainers", json::array())) {
      auto spec = policy::LevelSpecFromJson(tj.at("spec"));
      if (!spec.ok()) return spec.status().WithContext(dir);
      const int level = tj.at("level").get<int>();
      // the state file holds what the trainer that wrote it kept (a running average of its acting
      // weights or not), whatever the options of the process reading it (coins eval, transfer)
      LevelTrainOptions options = Group(level, spec->is_task());
      options.acting_average = tj.value("acting_average", 0.0);
      auto t = PolicyTrainer::Create(*spec, options, seed_ + 1000 * uint64_t(level));
      if (!t.ok()) return t.status().WithContext(dir);
      auto blob = ReadFileBytes(dir + "/" + tj.at("file").get<std::string>());
      if (!blob.ok()) return blob.status();
      rl::AlgorithmState st = (*t)->ExportState();
      COINS_RETURN_IF_ERROR(LoadStateBlob(*blob, &st, dir + "/" + tj.at("file").get<std::string>()));
      st.counters = tj.at("counters").get<std::vector<int64_t>>();
      COINS_RETURN_IF_ERROR((*t)->ImportState(st).WithContext(dir));
      trainers_[level] = std::move(*t);
    }
    detectors_.clear();
    for (const auto& dj : j.value("detectors", json::array())) {
      auto spec = detector::DetectorSpecFromJson(dj.at("spec"));
      if (!spec.ok()) return spec.status().WithContext(dir);
      auto det = detector::PairDetector::Create(spec->layout, spec->options);
      if (!det.ok()) return det.status().WithContext(dir);
      auto blob = ReadFileBytes(dir + "/" + dj.at("file").get<std::string>());
      if (!blob.ok()) return blob.status();
      COINS_RETURN_IF_ERROR(det->LoadWeights(*blob));
      detectors_[dj.at("target").get<std::string>()] = {*spec,
                                                        std::make_unique<detector::PairDetector>(std::move(*det))};
    }
    COINS_RETURN_IF_ERROR(LoadBestTask(dir, j));
    COINS_RETURN_IF_ERROR(LoadSelection(dir, j));
    counters_ = j.at("counters").get<std::map<std::string, uint64_t>>();
    generation_ = j.at("generation").get<uint64_t>() + 1;
    command_.seq(j.at("command_seq").get<uint64_t>());
    train_level_ = j.at("train_level").get<int>();
    job_start_updates_ = j.at("job_start_updates").get<int64_t>();
    detect_done_seq_ = j.at("detect_done_seq").get<uint64_t>();
    next_eval_at_ = j.at("next_eval_at").get<uint64_t>();
    next_retrain_at_ = j.at("next_retrain_at").get<uint64_t>();
    status_.total_updates(j.at("total_updates").get<uint64_t>());
    status_.checkpoint_epoch(j.at("epoch").get<uint64_t>());
    status_.checkpoint_command(j.at("command_id").get<uint64_t>());
    const json& e = j.at("eval");
    status_.eval_env_steps(e.at("env_steps").get<uint64_t>());
    status_.eval_return_mean(e.at("return_mean").get<double>());
    status_.eval_return_sd(e.at("return_sd").get<double>());
    status_.eval_episodes(e.at("episodes").get<uint32_t>());
    status_.eval_success(e.at("success").get<double>());
    status_.eval_angle_accuracy(e.at("angle_accuracy").get<double>());
    status_.eval_hit_rate(e.value("hit_rate", 0.0));
  } catch (const json::exception& ex) {
    return Errorf("{}/state.json: {}", dir, ex.what());
  }
  has_command_ = false;  // the orchestrator's command (re)starts the job; the same seq continues it
  published_.clear();
  return Status::Ok();
}

Status LearnerCore::LoadBestTask(const std::string& dir, const nlohmann::json& state) {
  best_task_.reset();
  if (!state.contains("best_task")) return Status::Ok();
  const json& b = state.at("best_task");
  BestTask best{b.at("level").get<int>(),
                b.at("env_steps").get<uint64_t>(),
                b.at("return_mean").get<double>(),
                b.at("return_sd").get<double>(),
                b.value("episodes", int64_t(0)),  // absent in checkpoints of older versions
                b.value("seed", uint64_t(0)),
                {},
                {}};
  const std::string file = dir + "/" + b.at("file").get<std::string>();
  PolicyTrainer* t = trainer(best.level);
  if (!t || !t->spec().is_task()) return Errorf("{}: the best task's level {} holds no task", file, best.level);
  auto blob = ReadActingFile(t->spec(), file);
  if (!blob.ok()) return blob.status();
  best.acting = std::move(*blob);
  // the skills' weights it was evaluated with (absent: the skills did not train under the task)
  const json files = b.value("skill_files", json::array());
  if (!files.empty() && files.size() != size_t(best.level) - 1)
    return Errorf("{}/state.json: the best task of level {} lists {} skill files", dir, best.level, files.size());
  for (size_t i = 0; i < files.size(); ++i) {
    PolicyTrainer* skill = trainer(int(i) + 1);
    if (!skill) return Errorf("{}/state.json: the best task's skill level {} has no trainer", dir, i + 1);
    auto skill_blob = ReadActingFile(skill->spec(), dir + "/" + files[i].get<std::string>());
    if (!skill_blob.ok()) return skill_blob.status();
    best.skills.push_back(std::move(*skill_blob));
  }
  best_task_ = std::move(best);
  return Status::Ok();
}

Result<std::vector<uint8_t>> LearnerCore::ReadActingFile(const policy::LevelSpec& spec, const std::string& file) {
  auto blob = ReadFileBytes(file);
  if (!blob.ok()) return blob.status();
  auto net = policy::PolicyNet::Create(spec);
  if (!net.ok()) return net.status();
  COINS_RETURN_IF_ERROR(net->Load(*blob, file));
  return std::move(*blob);
}

namespace {

// the path of the first difference between two specs' JSON ("/obs_high/3"), or ""
std::string FirstDifference(const json& a, const json& b) {
  const json patch = json::diff(a, b);
  return patch.empty() ? "" : patch.front().value("path", "?");
}

// a link detector trained in `trained` reads the same state features in `target` (its layout is
// over the pair's compact state; `gather` maps that to the full state)
Status FitDetector(detector::DetectorSpec& spec, const envs::EnvSpec& trained, const envs::EnvSpec& target) {
  const detector::PairLayout& l = spec.layout;
  for (int g : spec.gather)
    if (trained.feature_name(g) != target.feature_name(g))
      return Errorf("the {}->{} detector reads {} (state feature {}), which is {} in {}", l.source, l.target,
                    trained.feature_name(g), g, target.feature_name(g), target.name);
  spec.full_state_dim = target.state_dim();
  return Status::Ok();
}

}  // namespace

Status LearnerCore::KeepSkillsFor(const envs::EnvSpec& target, const std::vector<msg::LinkSpec>& links) {
  if (links.empty()) return Errorf("no skill to keep: the chain has no link");
  std::vector<policy::LevelSpec> built;
  std::map<std::string, LinkDetector> kept;
  for (int L = 1; L <= int(links.size()); ++L) {
    const msg::LinkSpec& link = links[size_t(L) - 1];
    const std::string what = fmt::format("skill {} ({}->{})", L, link.source(), link.target());
    PolicyTrainer* t = trainer(L);
    if (!t) return Errorf("{}: the checkpoint has no trained level {}", what, L);
    COINS_RETURN_IF_ERROR(policy::CheckLevelFits(t->spec(), env_, target).WithContext(what));
    auto spec = BuildSkillSpec(target, link, L, L > 1 ? &built.back() : nullptr, Group(L, false));
    if (!spec.ok()) return spec.status().WithContext(what + " in " + target.name);
    const std::string diff = FirstDifference(ToJson(t->spec()), ToJson(*spec));
    if (!diff.empty())
      return Errorf(
          "{}: the trained skill differs from the one the link builds in {} (at {}; a changed learner "
          "option or env bounds)",
          what, target.name, diff);
    built.push_back(std::move(*spec));
    if (built.back().detector.empty()) continue;
    auto d = detectors_.find(link.target());
    if (d == detectors_.end() || !d->second.det)
      return Errorf("{}: the checkpoint has no {} detector", what, link.target());
    COINS_RETURN_IF_ERROR(FitDetector(d->second.spec, env_, target).WithContext(what));
    kept[link.target()] = std::move(d->second);
  }
  // skills that trained under the task (skill_updates_in_task) are handed on as the kept best
  // task was evaluated over them: the skills `coins eval` plays the run's final policy with
  for (int L = 1; best_task_ && L <= int(links.size()) && L < best_task_->level; ++L)
    if (const std::vector<uint8_t>* acting = KeptActing(L))
      COINS_RETURN_IF_ERROR(trainer(L)->LoadActing(*acting).WithContext("the kept task's skill weights"));
  for (auto it = trainers_.begin(); it != trainers_.end();)
    it = it->first > int(links.size()) ? trainers_.erase(it) : std::next(it);
  detectors_ = std::move(kept);
  ForgetJobs();
  return Status::Ok();
}

namespace {

// the trained task's state into `fresh`, re-laid when the target observes more features
// (learner/trainers/input_remap.h)
Status ImportTrainedTask(const PolicyTrainer& trained, const envs::EnvSpec& trained_env, const envs::EnvSpec& target,
                         PolicyTrainer* fresh) {
  const rl::AlgorithmState st = trained.ExportState();
  if (fresh->ImportState(st).ok()) return Status::Ok();
  auto fail = [&](const std::string& why) {
    return Errorf(
        "the task network trained on {} does not fit {} ({}{})", trained_env.name, target.name, why,
        trained.spec().pair.enabled() ? "" : "; a pair network over the blocks, learner.task_pair_hidden, would");
  };
  auto input_of = MatchNetworkInputs(trained.spec(), trained_env, fresh->spec(), target);
  if (!input_of.ok()) return fail(input_of.status().message());
  auto relaid = RelayInputs(st, fresh->ExportState(), *input_of);
  if (!relaid.ok()) return fail(relaid.status().message());
  if (Status s = fresh->ImportState(*relaid); !s.ok()) return fail(s.message());
  return Status::Ok();
}

}  // namespace

Status LearnerCore::KeepTaskFor(const envs::EnvSpec& target) {
  PolicyTrainer* old = trainer(1);
  if (!old || !old->spec().is_task())
    return Errorf("no task policy over primitive actions to fine-tune (level 1 is {})",
                  old ? old->spec().name : std::string("missing"));
  auto spec = BuildPrimitiveTaskSpec(target, options_.task);
  if (!spec.ok()) return spec.status().WithContext("the task in " + target.name);
  auto fresh = PolicyTrainer::Create(*spec, options_.task, seed_ + 1000);
  if (!fresh.ok()) return fresh.status();
  COINS_RETURN_IF_ERROR(ImportTrainedTask(*old, env_, target, fresh->get()));
  trainers_.clear();
  trainers_[1] = std::move(*fresh);
  detectors_.clear();
  ForgetJobs();
  return Status::Ok();
}

void LearnerCore::ForgetJobs() {
  specs_.clear();
  selection_.reset();
  snapshots_.Clear();
  best_task_.reset();
  published_.clear();
  command_ = msg::ChainCommand();
  has_command_ = false;
  train_level_ = 0;
  job_start_updates_ = 0;
  detect_done_seq_ = 0;
  next_eval_at_ = next_retrain_at_ = 0;
  status_.total_updates(0);
  status_.checkpoint_epoch(0);
  status_.checkpoint_command(0);
  ClearEval();
}

}  // namespace coins
