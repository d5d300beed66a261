// LearnerCore: the learner's work without DDS. It follows ChainCommands (orchestrator/README.md):
// detect rounds over replay samples, training of the newest skill or of the task, periodic
// greedy evaluations and detector retraining, and says what to publish (InteractionScores,
// PolicyWeights) and how it is doing (LearnerStatus). coins-learner wires it to DDS; tests and
// in-process tools wire it to replay services in the same process.
//
// Weights versions are (generation << 40) | counter, where the generation grows with every
// start from a checkpoint, so that weights published after a restart are always newer than any
// published before it. One thread at a time.
#pragma once

#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "actors/envs/env.h"
#include "actors/hierarchy.h"
#include "common/env_spec.h"
#include "common/policy/level_spec.h"
#include "detector/detector_spec.h"
#include "idl/control.h"
#include "idl/status.h"
#include "idl/transition.h"
#include "idl/weights.h"
#include "learner/learner_options.h"
#include "learner/replay_client/sample_source.h"
#include "learner/skill_selection.h"
#include "learner/trainers/detect_round.h"
#include "learner/trainers/policy_trainer.h"

namespace coins {

class LearnerCore {
 public:
  LearnerCore(envs::EnvSpec env, LearnerOptions options, uint64_t seed);
  ~LearnerCore();

  struct Outputs {
    std::vector<msg::InteractionScores> scores;
    std::vector<msg::PolicyWeights> weights;
  };
  // follows a new command (a seq already followed is ignored); weights to publish right away
  // (the new level's spec and its link's detector) go to out
  Status OnCommand(const msg::ChainCommand& cmd, Outputs* out);
  // one slice of work: a detect round, or one update of the level being trained when the
  // pacing allows (env_steps: every actor's steps so far), plus an evaluation or a detector
  // retrain when due; or, first of all, a slice of choosing the weights of a skill whose training
  // just ended (learner/skill_selection.h; the new job waits for it). Returns false when there
  // was nothing to do.
  Result<bool> Work(SampleSource* source, uint64_t env_steps, Outputs* out);

  msg::LearnerStatus status() const { return status_; }
  // called every few seconds of a long piece of work inside Work (a detect round's model
  // training, a detector retrain), so that the caller can keep publishing status() and its
  // heartbeat while Work has not returned; it must not call back into this object but status()
  void SetProgressTick(std::function<void()> tick) { progress_tick_ = std::move(tick); }
  // the newest published weights of every name (to republish after a restart)
  std::vector<msg::PolicyWeights> Latest() const;
  uint64_t command_seq() const { return command_.seq(); }
  // false after a checkpoint resume until the orchestrator's (latched) command arrives
  bool has_command() const { return has_command_; }

  // checkpoints: a directory written whole or not at all
  Status SaveCheckpoint(const std::string& dir, uint64_t epoch, uint64_t command_id);
  // loads a checkpoint and starts a new generation of weights versions
  Status LoadCheckpoint(const std::string& dir);
  // transfer (learner/transfer_checkpoint.h): after LoadCheckpoint, keeps only the skills of
  // `links` (levels 1..links.size()) and their link detectors, each checked to be exactly what
  // those links build in `target` (the transfer run's learner then takes them as they are), and
  // forgets the task level, the job bookkeeping and the evaluation. A skill that trained under the
  // task keeps the acting weights the kept best task was evaluated over. Errors name the level.
  Status KeepSkillsFor(const envs::EnvSpec& target, const std::vector<msg::LinkSpec>& links);
  // fine-tuning (a run without a chain): after LoadCheckpoint, keeps only the task over primitive
  // actions, re-specified for `target` with its weights and optimiser state (a pair network over
  // the blocks fits any number of blocks; an Mlp over the whole state fits only the same layout)
  Status KeepTaskFor(const envs::EnvSpec& target);

  // the task policy whose evaluation scored the highest return so far (its acting weights, as
  // they were then): the run's final policy, which `coins eval` takes unless told --last. With
  // eval_confirm_episodes, a periodic evaluation above the best only nominates its weights: they
  // are scored, and compared, by the confirming episodes alone. None with keep_best_task false.
  // Kept in checkpoints; forgotten when the task level is rebuilt or a transfer starts.
  struct BestTask {
    int level = 0;
    uint64_t env_steps = 0;                 // of the evaluation
    double return_mean = 0, return_sd = 0;  // of the evaluation that scored it
    int64_t episodes = 0;                   // that evaluation's episodes, from Reset(seed) on
    uint64_t seed = 0;
    std::vector<uint8_t> acting;  // PolicyNet blob
    // with skill_updates_in_task: the acting weights of levels 1..level-1 as they were then (the
    // skills change under the task); empty when they did not train under it
    std::vector<std::vector<uint8_t>> skills;
  };
  const std::optional<BestTask>& best_task() const { return best_task_; }

  // the acting models of levels 1..n as actors would hold them (evaluation); with best_task, the
  // task level acts with the best task's weights (when there is one), over the skills' weights
  // it was evaluated with
  Result<std::unique_ptr<HierarchyModels>> Models(int levels, bool best_task = false) const;
  // the trainer of a level (null when none)
  PolicyTrainer* trainer(int level) const;
  // the snapshots of the skill being trained; the choice of a finished skill's weights under
  // way, and the last one made (null when none)
  const SkillSnapshots& snapshots() const { return snapshots_; }
  const SkillSelection* selection() const { return selection_ ? &*selection_ : nullptr; }
  const SkillSelection* last_choice() const { return chosen_ ? &*chosen_ : nullptr; }
  // every choice made, oldest first (kept in checkpoints)
  const std::vector<SkillChoice>& choices() const { return choices_; }

 private:
  struct LinkDetector {
    detector::DetectorSpec spec;
    std::unique_ptr<detector::PairDetector> det;
  };
  const LevelTrainOptions& Group(int level, bool task) const;
  Status BuildLevels(const msg::ChainCommand& cmd);
  Status EnsureTrainer(int level);
  msg::PolicyWeights Publish(const std::string& name, const std::string& spec, std::vector<uint8_t> blob,
                             uint64_t learner_step);
  void PublishLevel(int level, Outputs* out);
  void PublishDetector(const std::string& target, Outputs* out);
  Result<bool> DetectWork(SampleSource* source, uint64_t env_steps, Outputs* out);
  Result<bool> TrainWork(SampleSource* source, uint64_t env_steps, Outputs* out);
  // skill_updates_in_task: updates of the skill under the task, published every publish_every
  Status TrainSkillUnderTask(SampleSource* source, Outputs* out);
  // the weights a level acts with in the kept best task's models (the task's, or a skill's it was
  // evaluated with); null when there is no kept task or the level keeps no weights of its own there
  const std::vector<uint8_t>* KeptActing(int level) const;
  Status Evaluate(uint64_t env_steps);
  // a periodic task evaluation `r` at env_steps: keeps the weights when they score above the best
  // (confirmed on eval_confirm_episodes new episodes when that is set)
  Status ConsiderBestTask(envs::Env& env, const HierarchyModels& models, const EvalOptions& periodic,
                          const EvalResult& r, uint64_t env_steps);
  // a skill's evaluation: the skill on random goals plays eval_skill_episodes whole task episodes
  Status EvaluateSkillPlay(envs::Env& env, const HierarchyModels& models, uint64_t env_steps);
  // a skill's training ended (the new command moves on): choose its weights
  int EndedSkill(const msg::ChainCommand& next) const;
  std::vector<SkillSnapshot> Candidates(int level) const;  // its snapshots and its final weights
  void StartSelection(int level, std::vector<SkillSnapshot> candidates);
  Result<bool> SelectWork(Outputs* out);
  Result<EvalResult> EvaluateCandidate(int level, const std::vector<uint8_t>& acting, int64_t goals, int64_t max_steps,
                                       uint64_t seed) const;
  Status SaveSelection(const std::string& dir, nlohmann::json* state) const;
  Status LoadSelection(const std::string& dir, const nlohmann::json& state);  // from state.json
  void ClearEval();   // no evaluation reported (a new job starts)
  void ForgetJobs();  // a transfer's new run: no command, job, evaluation or update count
  Status LoadBestTask(const std::string& dir, const nlohmann::json& state);  // from state.json
  // an acting-weights file of a level with `spec` (a damaged or foreign one is refused, named)
  static Result<std::vector<uint8_t>> ReadActingFile(const policy::LevelSpec& spec, const std::string& file);
  Status RetrainDetector(SampleSource* source, uint64_t env_steps, Outputs* out);
  void RecordLag(const SampleColumns& c, int level);
  DetectRoundOptions RoundOptions() const;

  envs::EnvSpec env_;
  LearnerOptions options_;
  uint64_t seed_;
  msg::ChainCommand command_;
  bool has_command_ = false;
  std::vector<policy::LevelSpec> specs_;                    // index level - 1
  std::map<int, std::unique_ptr<PolicyTrainer>> trainers_;  // by level
  std::map<std::string, LinkDetector> detectors_;           // by target: newest of each
  std::map<std::string, msg::PolicyWeights> published_;     // by name: newest
  std::map<std::string, uint64_t> counters_;                // by name: versions published
  uint64_t generation_ = 0;
  int train_level_ = 0;  // level being trained (0: none)
  int64_t job_start_updates_ = 0;
  uint64_t detect_done_seq_ = 0;
  uint64_t next_eval_at_ = 0, next_retrain_at_ = 0;
  std::optional<BestTask> best_task_;
  std::deque<double> lags_;
  double loss_ = 0;
  msg::LearnerStatus status_;
  std::function<void()> progress_tick_ = [] {};
  SkillSnapshots snapshots_;                 // of the skill being trained
  std::optional<SkillSelection> selection_;  // of a skill whose training ended
  std::optional<SkillSelection> chosen_;     // the last choice made
  std::vector<SkillChoice> choices_;
};

}  // namespace coins
