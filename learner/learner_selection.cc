// LearnerCore: the choice of a finished skill's weights (learner/skill_selection.h). Snapshots
// are taken in TrainWork; when a command moves on from a skill's training, the snapshots and the
// final weights become candidates, Work evaluates them in slices before anything else, and the
// chosen weights replace the skill's acting weights and are published. Checkpoints keep the
// snapshots (skill-candidate-K.bin) and a choice under way, which a resume runs again from its
// start (its evaluations are deterministic).
#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <nlohmann/json.hpp>

#include "actors/envs/env.h"
#include "common/files.h"
#include "learner/learner_core.h"

namespace coins {

namespace {
using nlohmann::json;
constexpr int64_t kSelectChunkGoals = 1000;
constexpr uint64_t kSelectSeedOffset = 4243;
}  // namespace

int LearnerCore::EndedSkill(const msg::ChainCommand& next) const {
  if (!snapshots_.enabled() || selection_ || train_level_ <= 0 || next.seq() == command_.seq()) return 0;
  const PolicyTrainer* t = trainer(train_level_);
  if (!t || t->spec().is_task() || int(next.links().size()) < train_level_) return 0;
  return train_level_;
}

std::vector<SkillSnapshot> LearnerCore::Candidates(int level) const {
  std::vector<SkillSnapshot> candidates;
  if (snapshots_.level() == level) candidates.assign(snapshots_.all().begin(), snapshots_.all().end());
  candidates.push_back({status_.env_steps(), trainer(level)->ActingBlob()});
  return candidates;
}

void LearnerCore::StartSelection(int level, std::vector<SkillSnapshot> candidates) {
  snapshots_.Clear();
  SelectionOptions o;
  o.goals = options_.select_goals;
  o.chunk_goals = kSelectChunkGoals;
  o.chunk_max_steps = options_.eval_max_steps * 10;  // as the periodic skill evaluations
  o.seed = seed_ + kSelectSeedOffset;
  o.by_interaction = trainer(level)->spec().require_interaction;
  selection_.emplace(level, std::move(candidates), o);
}

Result<EvalResult> LearnerCore::EvaluateCandidate(int level, const std::vector<uint8_t>& acting, int64_t goals,
                                                  int64_t max_steps, uint64_t seed) const {
  auto models = Models(level);
  if (!models.ok()) return models.status();
  COINS_RETURN_IF_ERROR((*models)->at(level)->net.Load(acting, "a candidate"));
  auto env = envs::MakeEnv(env_.name);
  if (!env.ok()) return env.status();
  EvalOptions o;
  o.episodes = int(goals);
  o.max_steps = max_steps;
  o.seed = seed;
  return coins::Evaluate(**env, **models, level, o);
}

Result<bool> LearnerCore::SelectWork(Outputs* out) {
  const int level = selection_->level();
  PolicyTrainer* t = trainer(level);
  if (!t) return Errorf("choosing the weights of level {}: the level has no trainer", level);
  auto eval = [&](const std::vector<uint8_t>& acting, int64_t goals, int64_t max_steps, uint64_t seed) {
    return EvaluateCandidate(level, acting, goals, max_steps, seed);
  };
  auto done = selection_->Step(eval);
  if (!done.ok()) return done.status().WithContext("choosing the weights of " + t->spec().name);
  status_.message(fmt::format("choosing the weights of {}: {}", t->spec().name, selection_->Progress()));
  if (!*done) return true;
  const SkillSnapshot& best = selection_->candidates()[selection_->best()];
  const CandidateScore& score = selection_->scores()[selection_->best()];
  COINS_RETURN_IF_ERROR(t->LoadActing(best.acting));
  PublishLevel(level, out);
  const std::string chosen =
      fmt::format("{} keeps its weights of {} env steps (hit rate {:.4f}, success {:.4f} over {} goals)",
                  t->spec().name, best.env_steps, score.hit_rate(), score.success(), score.goals);
  spdlog::info("{}; the candidates:\n{}", chosen, selection_->Table());
  status_.message(chosen);
  std::erase_if(choices_, [&](const SkillChoice& c) { return c.level >= level; });  // a level rebuilt
  choices_.push_back(selection_->Choice(t->spec().name));
  chosen_ = std::move(selection_);
  selection_.reset();
  return true;
}

Status LearnerCore::SaveSelection(const std::string& dir, json* state) const {
  for (const SkillChoice& c : choices_) (*state)["skill_choices"].push_back(ToJson(c));
  const bool selecting = selection_.has_value();
  json list = json::array();
  auto add = [&](const SkillSnapshot& s) {
    const std::string file = fmt::format("skill-candidate-{}.bin", list.size());
    list.push_back({{"env_steps", s.env_steps}, {"file", file}});
    return WriteFileAtomic(dir + "/" + file, s.acting);
  };
  if (selecting)
    for (const auto& s : selection_->candidates()) COINS_RETURN_IF_ERROR(add(s));
  else
    for (const auto& s : snapshots_.all()) COINS_RETURN_IF_ERROR(add(s));
  (*state)["skill_snapshots"] = {{"level", selecting ? selection_->level() : snapshots_.level()},
                                 {"next_at", snapshots_.next_at()},
                                 {"selecting", selecting},
                                 {"list", list}};
  return Status::Ok();
}

Status LearnerCore::LoadSelection(const std::string& dir, const json& state) {
  selection_.reset();
  snapshots_.Clear();
  auto choices = SkillChoicesFromJson(state.value("skill_choices", json::array()));
  if (!choices.ok()) return choices.status().WithContext(dir + "/state.json");
  choices_ = std::move(*choices);
  if (!state.contains("skill_snapshots")) return Status::Ok();
  const json& j = state.at("skill_snapshots");
  const int level = j.at("level").get<int>();
  const PolicyTrainer* t = trainer(level);
  if (j.at("list").empty()) return Status::Ok();
  if (!t || t->spec().is_task()) return Errorf("{}: skill snapshots of level {}, which holds no skill", dir, level);
  std::vector<SkillSnapshot> list;
  for (const json& sj : j.at("list")) {
    auto blob = ReadActingFile(t->spec(), dir + "/" + sj.at("file").get<std::string>());
    if (!blob.ok()) return blob.status();
    list.push_back({sj.at("env_steps").get<uint64_t>(), std::move(*blob)});
  }
  if (j.at("selecting").get<bool>()) {
    // loading alone runs nothing (`coins eval` loads checkpoints too): the learner's Work does
    spdlog::info(
        "the checkpoint was cut while {}'s weights were chosen among {} candidates: the choice starts over "
        "when training goes on",
        t->spec().name, list.size());
    StartSelection(level, std::move(list));
    return Status::Ok();
  }
  snapshots_.Restore(level, j.at("next_at").get<uint64_t>(), std::deque<SkillSnapshot>(list.begin(), list.end()));
  return Status::Ok();
}

}  // namespace coins
