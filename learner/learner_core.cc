#include "learner/learner_core.h"

#include <algorithm>
#include <cmath>

#include <spdlog/spdlog.h>
#include <nlohmann/json.hpp>

#include "actors/envs/env.h"
#include "actors/evaluate.h"
#include "common/policy/weights_msg.h"
#include "detector/online_detector.h"
#include "detector/transitions.h"
#include "learner/trainers/level_builder.h"

namespace coins {

namespace {
// updates the learner may run ahead of the env steps its pacing allows: the actors learn the
// update count from LearnerStatus and the learner the env steps from ActorStats, each about once
// a status period, so the slack must cover a period of updates or the two wait on each other
constexpr int64_t kPacingSlack = 1000;
constexpr int kVersionShift = 40;
constexpr size_t kLagWindow = 4096;
// a confirming task evaluation's env seeds start this far above the periodic one's: no other
// evaluation of the run draws them
constexpr uint64_t kConfirmSeedOffset = uint64_t(1) << 32;

// replay that cannot serve yet: shards without data or held by their rate limiter, and shards
// away (stopped, restarting; the replay client fails the job once one stays away too long)
bool IsWaiting(const Status& s) {
  const std::string& m = s.message();
  return m.find("no transitions") != std::string::npos || m.find("not ready") != std::string::npos ||
         m.find("NOT_READY") != std::string::npos || m.find("holds no") != std::string::npos ||
         m.find("no reply within the timeout") != std::string::npos;
}
}  // namespace

LearnerCore::LearnerCore(envs::EnvSpec env, LearnerOptions options, uint64_t seed)
    : env_(std::move(env)),
      options_(std::move(options)),
      seed_(seed),
      snapshots_(int(options_.select_snapshots), uint64_t(options_.select_snapshot_every_steps)) {
  status_.schema_version(msg::STATUS_SCHEMA);
  status_.job("idle");
  status_.state("waiting");
  status_.weight_versions(std::vector<uint64_t>(COINS_MAX_LEVELS, 0));
}

LearnerCore::~LearnerCore() = default;

const LevelTrainOptions& LearnerCore::Group(int level, bool task) const {
  if (task) return options_.task;
  return level == 1 ? options_.primitive : options_.skill;
}

PolicyTrainer* LearnerCore::trainer(int level) const {
  auto it = trainers_.find(level);
  return it == trainers_.end() ? nullptr : it->second.get();
}

DetectRoundOptions LearnerCore::RoundOptions() const {
  DetectRoundOptions o;
  o.max_samples = options_.detect_max_samples;
  o.max_floats = options_.detect_max_floats;
  o.holdout = options_.detect_holdout;
  o.detector = options_.detector;
  o.detector.seed = seed_ + 17;
  o.tick = progress_tick_;
  return o;
}

Status LearnerCore::BuildLevels(const msg::ChainCommand& cmd) {
  specs_.clear();
  const auto& links = cmd.links();
  for (size_t i = 0; i < links.size(); ++i) {
    const int L = int(i) + 1;
    auto s = BuildSkillSpec(env_, links[i], L, L > 1 ? &specs_.back() : nullptr, Group(L, false));
    if (!s.ok()) return s.status();
    specs_.push_back(std::move(*s));
  }
  if (cmd.job() == "train-task") {
    auto s = specs_.empty() ? BuildPrimitiveTaskSpec(env_, options_.task)
                            : BuildTaskSpec(env_, specs_.back(), options_.task);
    if (!s.ok()) return s.status();
    specs_.push_back(std::move(*s));
  }
  return Status::Ok();
}

Status LearnerCore::EnsureTrainer(int level) {
  const policy::LevelSpec& spec = specs_[size_t(level) - 1];
  PolicyTrainer* t = trainer(level);
  if (t && ToJson(t->spec()) == ToJson(spec)) return Status::Ok();
  auto made = PolicyTrainer::Create(spec, Group(level, spec.is_task()), seed_ + 1000 * uint64_t(level));
  if (!made.ok()) return made.status();
  trainers_[level] = std::move(*made);
  if (best_task_ && best_task_->level == level) best_task_.reset();  // another policy now
  return Status::Ok();
}

msg::PolicyWeights LearnerCore::Publish(const std::string& name, const std::string& spec, std::vector<uint8_t> blob,
                                        uint64_t learner_step) {
  const uint64_t version = (generation_ << kVersionShift) | ++counters_[name];
  msg::PolicyWeights w = policy::MakeWeights(name, version, learner_step, spec, std::move(blob));
  published_[name] = w;
  return w;
}

void LearnerCore::PublishLevel(int level, Outputs* out) {
  PolicyTrainer* t = trainer(level);
  if (!t) return;
  out->weights.push_back(Publish(t->spec().name, ToJson(t->spec()).dump(), t->ActingBlob(), uint64_t(t->updates())));
  auto versions = status_.weight_versions();
  versions[size_t(level) - 1] = out->weights.back().version();
  status_.weight_versions(versions);
}

void LearnerCore::PublishDetector(const std::string& target, Outputs* out) {
  auto it = detectors_.find(target);
  if (it == detectors_.end() || !it->second.det) return;
  const LinkDetector& d = it->second;
  out->weights.push_back(Publish(detector::DetectorWeightsName(d.spec.layout.source, d.spec.layout.target),
                                 detector::ToJson(d.spec).dump(), d.det->WeightsBlob(), 0));
}

Status LearnerCore::OnCommand(const msg::ChainCommand& cmd, Outputs* out) {
  if (has_command_ && cmd.seq() == command_.seq()) return Status::Ok();
  COINS_RETURN_IF_ERROR(BuildLevels(cmd).WithContext("command " + std::to_string(cmd.seq())));
  const bool same_job_restored = !has_command_ && cmd.seq() == command_.seq() && train_level_ > 0;
  if (const int ended = EndedSkill(cmd); ended > 0) {
    StartSelection(ended, Candidates(ended));
    spdlog::info("{} training ended: choosing its weights among {} candidates, {} goals each",
                 trainer(ended)->spec().name, selection_->candidates().size(), options_.select_goals);
  }
  command_ = cmd;
  has_command_ = true;
  status_.command_seq(cmd.seq());
  status_.job(cmd.job());
  status_.state(cmd.job() == "idle" ? "done" : "running");
  status_.message("");
  const bool training = cmd.job() == "train-skill" || cmd.job() == "train-task";
  if (!training) {
    train_level_ = 0;
    status_.updates(0);
    return Status::Ok();
  }
  const int level = int(specs_.size());
  COINS_RETURN_IF_ERROR(EnsureTrainer(level));
  if (!same_job_restored) {
    job_start_updates_ = trainer(level)->updates();
    next_eval_at_ = next_retrain_at_ = 0;
    ClearEval();  // the previous job's evaluation is not this job's
    if (!trainer(level)->spec().is_task()) snapshots_.Start(level, status_.env_steps());
  }
  train_level_ = level;
  status_.updates(uint64_t(trainer(level)->updates() - job_start_updates_));
  if (trainer(level)->spec().is_task() && level > 1 && options_.skill_updates_in_task > 0)
    spdlog::info("{} keeps training under the task: {} update(s) per task update", specs_[size_t(level) - 2].name,
                 options_.skill_updates_in_task);
  // every level the actors run: its spec and newest weights, and the link detectors they need
  for (int L = 1; L <= level; ++L) {
    if (!published_.count(specs_[size_t(L) - 1].name) || L == level) PublishLevel(L, out);
    if (!specs_[size_t(L) - 1].detector.empty()) PublishDetector(specs_[size_t(L) - 1].goal.factor, out);
  }
  return Status::Ok();
}

Result<bool> LearnerCore::Work(SampleSource* source, uint64_t env_steps, Outputs* out) {
  status_.env_steps(env_steps);
  if (selection_) return SelectWork(out);
  if (!has_command_) return false;
  if (command_.job() == "detect") {
    if (detect_done_seq_ == command_.seq()) return false;
    return DetectWork(source, env_steps, out);
  }
  if (train_level_ > 0) return TrainWork(source, env_steps, out);
  return false;
}

Result<bool> LearnerCore::DetectWork(SampleSource* source, uint64_t env_steps, Outputs* out) {
  std::vector<std::string> targets(command_.targets().begin(), command_.targets().end());
  // the round scores the data collected up to the detect point: the command's step_base. The
  // learner's own count comes from periodic actor reports and may still lag it (actors reach a
  // 10k detect point within a second)
  const uint64_t collected = std::max<uint64_t>(env_steps, command_.step_base());
  auto round = RunDetectRound(source, env_, command_.source(), targets, int64_t(collected), RoundOptions());
  if (!round.ok()) {
    if (IsWaiting(round.status())) {
      status_.message(round.status().message());
      return false;
    }
    // a failed round is not run again for the same command: the orchestrator reacts to the
    // failure (collects more and sends a new round)
    detect_done_seq_ = command_.seq();
    status_.state("failed");
    return round.status();
  }
  msg::InteractionScores scores;
  scores.schema_version(msg::STATUS_SCHEMA);
  scores.command_seq(command_.seq());
  scores.round(command_.round());
  scores.source(command_.source());
  scores.env_steps(env_steps);
  uint64_t total = 0;
  for (const auto& [level, t] : trainers_) total += uint64_t(t->updates());
  scores.learner_step(total);
  std::vector<msg::InteractionScore> list;
  for (DetectedTarget& t : *round) {
    list.push_back(t.score);
    if (t.detector) detectors_[t.score.target()] = {t.spec, std::move(t.detector)};
  }
  scores.scores(list);
  out->scores.push_back(scores);
  detect_done_seq_ = command_.seq();
  status_.scores_round(command_.round());
  status_.state("done");
  return true;
}

void LearnerCore::RecordLag(const SampleColumns& c, int level) {
  const uint64_t now = status_.weight_versions()[size_t(level) - 1];
  const uint64_t mask = (uint64_t(1) << kVersionShift) - 1;
  for (uint32_t i = 0; i < c.n; ++i) {
    const uint64_t v = c.policy_version[i];
    if (v == 0 || (v >> kVersionShift) != (now >> kVersionShift)) continue;
    lags_.push_back(double((now & mask) - std::min(now & mask, v & mask)));
    if (lags_.size() > kLagWindow) lags_.pop_front();
  }
  if (lags_.empty()) return;
  std::vector<double> sorted(lags_.begin(), lags_.end());
  std::sort(sorted.begin(), sorted.end());
  status_.lag_median(sorted[sorted.size() / 2]);
  status_.lag_p99(sorted[std::min(sorted.size() - 1, size_t(0.99 * double(sorted.size())))]);
}

Result<bool> LearnerCore::TrainWork(SampleSource* source, uint64_t env_steps, Outputs* out) {
  PolicyTrainer* t = trainer(train_level_);
  const int64_t job_updates = t->updates() - job_start_updates_;
  if (env_steps < command_.step_base()) return false;
  if (command_.steps_per_update() > 0) {
    const int64_t allowed =
        int64_t(double(env_steps - command_.step_base()) / command_.steps_per_update()) + kPacingSlack;
    if (job_updates >= allowed) return false;
  }
  auto step = t->Update(source);
  if (!step.ok()) {
    if (IsWaiting(step.status())) {
      if (status_.message() != step.status().message()) spdlog::info("waiting: {}", step.status().message());
      status_.message(step.status().message());
      return false;
    }
    return step.status();
  }
  loss_ = job_updates == 0 ? step->loss : 0.99 * loss_ + 0.01 * step->loss;
  status_.loss(loss_);
  status_.updates(uint64_t(job_updates + 1));
  status_.total_updates(status_.total_updates() + 1);
  RecordLag(t->last(), train_level_);
  if ((job_updates + 1) % Group(train_level_, t->spec().is_task()).publish_every == 0) PublishLevel(train_level_, out);
  COINS_RETURN_IF_ERROR(TrainSkillUnderTask(source, out));
  if (snapshots_.Due(train_level_, env_steps)) snapshots_.Add(env_steps, t->ActingBlob());
  if (next_eval_at_ == 0) next_eval_at_ = env_steps + uint64_t(options_.eval_every_steps);
  if (env_steps >= next_eval_at_) {
    PublishLevel(train_level_, out);
    COINS_RETURN_IF_ERROR(Evaluate(env_steps));
    next_eval_at_ = env_steps + uint64_t(options_.eval_every_steps);
  }
  const bool retrains = !t->spec().detector.empty() && options_.detector_retrain_steps > 0;
  if (retrains && next_retrain_at_ == 0) next_retrain_at_ = env_steps + uint64_t(options_.detector_retrain_steps);
  if (retrains && env_steps >= next_retrain_at_) {
    COINS_RETURN_IF_ERROR(RetrainDetector(source, env_steps, out));
    next_retrain_at_ = env_steps + uint64_t(options_.detector_retrain_steps);
  }
  return true;
}

Status LearnerCore::TrainSkillUnderTask(SampleSource* source, Outputs* out) {
  if (options_.skill_updates_in_task <= 0 || train_level_ < 2 || !specs_[size_t(train_level_) - 1].is_task())
    return Status::Ok();
  const int level = train_level_ - 1;
  PolicyTrainer* skill = trainer(level);
  if (!skill) return Status::Ok();
  const int64_t publish_every = Group(level, false).publish_every;
  for (int64_t i = 0; i < options_.skill_updates_in_task; ++i) {
    auto step = skill->Update(source);
    if (!step.ok()) return IsWaiting(step.status()) ? Status::Ok() : step.status().WithContext(skill->spec().name);
    status_.total_updates(status_.total_updates() + 1);
    if (skill->updates() % publish_every == 0) PublishLevel(level, out);
  }
  return Status::Ok();
}

void LearnerCore::ClearEval() {
  status_.eval_env_steps(0);
  status_.eval_episodes(0);
  status_.eval_return_mean(0.0);
  status_.eval_return_sd(0.0);
  status_.eval_success(0.0);
  status_.eval_angle_accuracy(0.0);
  status_.eval_hit_rate(0.0);
  status_.eval_play_return_mean(0.0);
  status_.eval_play_return_sd(0.0);
  status_.eval_play_episodes(0);
}

Status LearnerCore::Evaluate(uint64_t env_steps) {
  auto models = Models(train_level_);
  if (!models.ok()) return models.status().WithContext("evaluation");
  auto env = envs::MakeEnv(env_.name);
  if (!env.ok()) return env.status();
  EvalOptions o;
  const bool task = specs_[size_t(train_level_) - 1].is_task();
  o.episodes = int(task ? options_.eval_episodes : options_.eval_goals);
  o.max_steps = task ? options_.eval_max_steps : options_.eval_max_steps * 10;
  o.seed = seed_ + 7919 + env_steps;
  o.task_explore = float(options_.eval_task_explore);
  auto r = coins::Evaluate(**env, **models, train_level_, o);
  if (!r.ok()) return r.status().WithContext("evaluation");
  const policy::LevelSpec& spec = specs_[size_t(train_level_) - 1];
  const policy::LevelSpec& skill = spec.is_task() && train_level_ > 1 ? specs_[size_t(train_level_) - 2] : spec;
  status_.eval_env_steps(env_steps);
  status_.eval_episodes(uint32_t(spec.is_task() ? r->returns.size() : r->goals_ended));
  status_.eval_return_mean(r->return_mean);
  status_.eval_return_sd(r->return_sd);
  status_.eval_success(r->success);
  status_.eval_angle_accuracy(skill.require_interaction ? r->accuracy : 0.0);
  status_.eval_hit_rate(skill.require_interaction ? r->hit_rate : 0.0);
  spdlog::info(
      "eval of {} at {} env steps: return {:.2f} +- {:.2f}, success {:.3f}, hit rate {:.3f}, angle accuracy {:.3f}",
      spec.name, env_steps, r->return_mean, r->return_sd, r->success, status_.eval_hit_rate(),
      status_.eval_angle_accuracy());
  COINS_RETURN_IF_ERROR(EvaluateSkillPlay(**env, **models, env_steps));
  if (spec.is_task()) return ConsiderBestTask(**env, **models, o, *r, env_steps);
  return Status::Ok();
}

Status LearnerCore::ConsiderBestTask(envs::Env& env, const HierarchyModels& models, const EvalOptions& periodic,
                                     const EvalResult& r, uint64_t env_steps) {
  if (!options_.keep_best_task || r.returns.empty() || (best_task_ && r.return_mean <= best_task_->return_mean))
    return Status::Ok();
  EvalOptions o = periodic;
  EvalResult confirming = r;
  if (options_.eval_confirm_episodes > 0) {
    o.episodes = int(options_.eval_confirm_episodes);
    o.seed = periodic.seed + kConfirmSeedOffset;
    auto c = coins::Evaluate(env, models, train_level_, o);
    if (!c.ok()) return c.status().WithContext("confirming evaluation");
    confirming = std::move(*c);
    spdlog::info("confirming the task's evaluation of {:.2f} at {} env steps: {:.2f} +- {:.2f} over {} new episodes",
                 r.return_mean, env_steps, confirming.return_mean, confirming.return_sd, confirming.returns.size());
    if (best_task_ && confirming.return_mean <= best_task_->return_mean) return Status::Ok();
  }
  best_task_ = BestTask{train_level_,
                        env_steps,
                        confirming.return_mean,
                        confirming.return_sd,
                        int64_t(o.episodes),
                        o.seed,
                        trainer(train_level_)->ActingBlob(),
                        {}};
  if (options_.skill_updates_in_task > 0)
    for (int L = 1; L < train_level_; ++L) best_task_->skills.push_back(trainer(L)->ActingBlob());
  spdlog::info("the best task policy so far: return {:.2f} at {} env steps", confirming.return_mean, env_steps);
  return Status::Ok();
}

Status LearnerCore::EvaluateSkillPlay(envs::Env& env, const HierarchyModels& models, uint64_t env_steps) {
  status_.eval_play_episodes(0);
  if (specs_[size_t(train_level_) - 1].is_task() || options_.eval_skill_episodes <= 0) return Status::Ok();
  EvalOptions o;
  o.episodes = int(options_.eval_skill_episodes);
  o.max_steps = options_.eval_max_steps;
  o.seed = seed_ + 104729 + env_steps;
  o.skill_plays_task = true;
  auto r = coins::Evaluate(env, models, train_level_, o);
  if (!r.ok()) return r.status().WithContext("evaluation of the skill playing the task");
  status_.eval_play_return_mean(r->return_mean);
  status_.eval_play_return_sd(r->return_sd);
  status_.eval_play_episodes(uint32_t(r->returns.size()));
  spdlog::info("{} on random goals plays the task at {} env steps: return {:.2f} +- {:.2f} over {} episodes",
               specs_[size_t(train_level_) - 1].name, env_steps, r->return_mean, r->return_sd, r->returns.size());
  return Status::Ok();
}

Status LearnerCore::RetrainDetector(SampleSource* source, uint64_t env_steps, Outputs* out) {
  const policy::LevelSpec& spec = specs_[size_t(train_level_) - 1];
  auto round = RunDetectRound(source, env_, spec.source, {spec.goal.factor}, int64_t(env_steps), RoundOptions());
  if (!round.ok()) return IsWaiting(round.status()) ? Status::Ok() : round.status().WithContext("detector retrain");
  DetectedTarget& t = round->front();
  // a retrained detector that no longer finds the link would stop the skill: keep the old one
  if (!t.detector || !t.score.pass()) return Status::Ok();
  detectors_[spec.goal.factor] = {t.spec, std::move(t.detector)};
  PublishDetector(spec.goal.factor, out);
  return Status::Ok();
}

std::vector<msg::PolicyWeights> LearnerCore::Latest() const {
  std::vector<msg::PolicyWeights> all;
  for (const auto& [name, w] : published_) all.push_back(w);
  return all;
}

const std::vector<uint8_t>* LearnerCore::KeptActing(int level) const {
  if (!best_task_) return nullptr;
  if (level == best_task_->level) return &best_task_->acting;
  if (level < best_task_->level && !best_task_->skills.empty()) return &best_task_->skills[size_t(level) - 1];
  return nullptr;
}

Result<std::unique_ptr<HierarchyModels>> LearnerCore::Models(int levels, bool best_task) const {
  auto models = std::make_unique<HierarchyModels>();
  for (int L = 1; L <= levels; ++L) {
    PolicyTrainer* t = trainer(L);
    if (!t) return Errorf("level {} has no trainer", L);
    auto m = std::make_unique<LevelModel>();
    auto net = policy::PolicyNet::Create(t->spec());
    if (!net.ok()) return net.status();
    m->net = std::move(*net);
    const std::vector<uint8_t>* kept = best_task ? KeptActing(L) : nullptr;
    std::vector<uint8_t> newest;
    if (!kept) newest = t->ActingBlob();
    COINS_RETURN_IF_ERROR(m->net.Load(kept ? *kept : newest, t->spec().name));
    m->trained = t->updates() > 0;
    const std::string& dname = t->spec().detector;
    auto it = detectors_.find(t->spec().goal.factor);
    if (!dname.empty() && it != detectors_.end() && it->second.det) {
      auto d = detector::OnlineDetector::Create(it->second.spec, it->second.det->WeightsBlob(), seed_ + 31);
      if (!d.ok()) return d.status();
      m->detector = std::make_unique<detector::OnlineDetector>(std::move(*d));
      m->interaction_bit = detector::InteractionBit(env_, t->spec().source, t->spec().goal.factor);
    }
    models->levels.push_back(std::move(m));
  }
  return models;
}

}  // namespace coins
