// The learning path in one process (actors, replay shards, learner; no DDS): a detect round on
// random data finds Action -> Paddle and no other link, and the paddle skill, trained from
// replay with hindsight and run by the actors' hierarchy with the learner's weights, reaches
// its goals in a greedy evaluation.
#include "learner/local_run.h"

#include "actors/envs/env.h"
#include "actors/evaluate.h"

#include <unistd.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>

namespace coins {
namespace {

msg::ChainCommand Command(uint64_t seq, const std::string& job, int acting, uint64_t step_base) {
  msg::ChainCommand c;
  c.schema_version(msg::CHAIN_COMMAND_SCHEMA);
  c.seq(seq);
  c.job(job);
  c.acting_level(acting);
  c.step_base(step_base);
  return c;
}

msg::LinkSpec LinkFrom(const msg::InteractionScore& s) {
  msg::LinkSpec l;
  l.source(s.source());
  l.target(s.target());
  l.score(s.score());
  l.mask(s.mask());
  l.goal_kind(s.goal_kind());
  l.goal_set(s.goal_set());
  l.interaction_rate(s.interaction_rate());
  return l;
}

// rewrites a file with `damage` applied to its bytes
void Damage(const std::filesystem::path& file, const std::function<void(std::vector<char>&)>& damage) {
  std::vector<char> bytes;
  {
    std::ifstream in(file, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  ASSERT_GT(bytes.size(), 100u) << file;
  damage(bytes);
  std::ofstream(file, std::ios::binary | std::ios::trunc).write(bytes.data(), std::streamsize(bytes.size()));
}

LocalRunOptions Options() {
  LocalRunOptions o;
  o.actors = 2;
  o.shards = 2;
  o.seed = 3;
  o.actor.batch_rows = 256;
  o.replay.capacity = 200000;
  o.replay.capacity_mb = 64;
  o.learner.detector.passive_steps = o.learner.detector.passive_hard_steps = 1500;
  o.learner.detector.active_steps = 3000;
  o.learner.eval_every_steps = 4000;
  o.learner.eval_goals = 100;
  if (getenv("EXPLORE")) o.learner.primitive.explore = atof(getenv("EXPLORE"));
  return o;
}

TEST(LocalRun, FindsActionToPaddleAndTrainsThePaddleSkill) {
  auto made = LocalRun::Create(Options());
  ASSERT_TRUE(made.ok()) << made.status().message();
  LocalRun& r = **made;
  ASSERT_TRUE(r.Command(Command(1, "idle", 0, 6000)).ok());
  ASSERT_TRUE(r.StepActors(100000).ok());
  EXPECT_EQ(r.env_steps(), 6000u);

  // detect: every target of the primitive action; only the paddle passes
  msg::ChainCommand detect = Command(2, "detect", 0, 6000);
  detect.source("Action");
  detect.targets({"Paddle", "Ball", "Block"});
  detect.round(1);
  ASSERT_TRUE(r.Command(detect).ok());
  auto worked = r.LearnerWork(1);
  ASSERT_TRUE(worked.ok()) << worked.status().message();
  ASSERT_EQ(r.scores().size(), 1u);
  const auto& scores = r.scores()[0].scores();
  ASSERT_EQ(scores.size(), 3u);
  const msg::InteractionScore* paddle = nullptr;
  for (const auto& s : scores) {
    if (s.target() == "Paddle")
      paddle = &s;
    else
      EXPECT_FALSE(s.pass()) << s.target() << " Sc_I " << s.score();
  }
  ASSERT_NE(paddle, nullptr);
  EXPECT_TRUE(paddle->pass()) << paddle->score();
  EXPECT_TRUE(paddle->eligible());
  EXPECT_EQ(std::vector<float>(paddle->mask().begin(), paddle->mask().end()), (std::vector<float>{0, 1, 0, 0, 0}));
  // Sc_I from the held-out share; the mask and goal set from every detection of the round's data
  EXPECT_GT(paddle->goal_interactions(), 3 * paddle->interactions()) << paddle->interactions();

  // train the paddle skill, paced at one update per env step after 1000 random-goal steps
  msg::ChainCommand train = Command(3, "train-skill", 1, 7000);
  train.steps_per_update(1.0);
  train.links({LinkFrom(*paddle)});
  ASSERT_TRUE(r.Command(train).ok());
  while (r.env_steps() < 26000) {
    ASSERT_TRUE(r.StepActors(250).ok());
    auto w = r.LearnerWork(1000);
    ASSERT_TRUE(w.ok()) << w.status().message();
    static uint64_t last_eval = 0;
    if (r.learner().status().eval_env_steps() != last_eval) {
      last_eval = r.learner().status().eval_env_steps();
      printf("eval at %lu: %.2f (updates %lu loss %.3f)\n", last_eval, r.learner().status().eval_success(),
             r.learner().status().updates(), r.learner().status().loss());
    }
  }
  const msg::LearnerStatus st = r.learner().status();
  EXPECT_GT(st.updates(), 15000u);
  EXPECT_GE(st.eval_env_steps(), 20000u);
  EXPECT_GE(st.eval_success(), 0.9) << "greedy goal-reaching rate at " << st.eval_env_steps() << " steps";
  // the same evaluation let the skill play 20 whole Breakout episodes on random goals: each ends
  // at its first drop (-10) after the blocks the ball broke
  EXPECT_EQ(st.eval_play_episodes(), 20u);
  EXPECT_GE(st.eval_play_return_mean(), -10.0);
  EXPECT_LE(st.eval_play_return_mean(), 100.0);
  EXPECT_EQ(r.rejected(), 0u);
  // the actors ran the skill: level-1 goals ended, most reached by the end
  const HierarchyCounters& c = r.actor(0).counters().hierarchy;
  EXPECT_GT(c.goals_ended[0], 100u);
}

// the options of a task over primitive actions evaluated every 1000 env steps on 3 episodes
LocalRunOptions TaskEvalOptions() {
  LocalRunOptions o = Options();
  o.actors = o.shards = 1;
  o.learner.eval_every_steps = 1000;
  o.learner.eval_episodes = 3;
  o.learner.eval_max_steps = 400;
  return o;
}

// trains the task over primitive actions until `n` periodic evaluations: (env steps, mean return)
void TrainTaskForEvaluations(LocalRun& r, size_t n, std::vector<std::pair<uint64_t, double>>* evals) {
  msg::ChainCommand task = Command(1, "train-task", 1, 1000);  // 1000 random steps, then paced
  task.steps_per_update(4.0);
  ASSERT_TRUE(r.Command(task).ok());
  while (evals->size() < n) {
    ASSERT_TRUE(r.StepActors(250).ok());
    ASSERT_TRUE(r.LearnerWork(100).ok());
    const msg::LearnerStatus st = r.learner().status();
    if (st.eval_env_steps() && (evals->empty() || st.eval_env_steps() != evals->back().first))
      evals->emplace_back(st.eval_env_steps(), st.eval_return_mean());
  }
}

// saves the run's learner into a new checkpoint directory named after `tag` and loads it into a
// new learner that holds a kept task
void CheckpointAndReload(LocalRun& r, const LocalRunOptions& o, const std::string& tag, std::filesystem::path* dir,
                         std::unique_ptr<LearnerCore>* loaded) {
  *dir = std::filesystem::temp_directory_path() / (tag + "-" + std::to_string(getpid()));
  std::filesystem::remove_all(*dir);
  ASSERT_TRUE(r.learner().SaveCheckpoint(dir->string(), 1, 1).ok());
  *loaded = std::make_unique<LearnerCore>(r.spec(), o.learner, 9);
  ASSERT_TRUE((*loaded)->LoadCheckpoint(dir->string()).ok());
  ASSERT_TRUE((*loaded)->best_task().has_value());
}

// the task over primitive actions, evaluated every 1000 env steps: the learner keeps the weights
// of its best evaluation, its checkpoint carries them (a damaged copy is refused, naming the
// file), and the best-task models act with them
TEST(LocalRun, TheBestEvaluatedTaskPolicyIsKeptAndCheckpointed) {
  LocalRunOptions o = TaskEvalOptions();
  auto made = LocalRun::Create(o);
  ASSERT_TRUE(made.ok()) << made.status().message();
  LocalRun& r = **made;
  std::vector<std::pair<uint64_t, double>> evals;
  ASSERT_NO_FATAL_FAILURE(TrainTaskForEvaluations(r, 8, &evals));
  auto best = std::max_element(evals.begin(), evals.end(), [](auto& a, auto& b) { return a.second < b.second; });
  ASSERT_GT(best->second,
            std::min_element(evals.begin(), evals.end(), [](auto& a, auto& b) { return a.second < b.second; })->second)
      << "evaluations that all score the same choose nothing";
  const auto& kept = r.learner().best_task();
  ASSERT_TRUE(kept.has_value());
  EXPECT_EQ(kept->level, 1);
  EXPECT_EQ(kept->env_steps, best->first);  // the first of equal bests
  EXPECT_DOUBLE_EQ(kept->return_mean, best->second);
  const bool best_is_newest = best->first == evals.back().first;
  EXPECT_EQ(kept->acting == r.learner().trainer(1)->ActingBlob(), best_is_newest);

  namespace fs = std::filesystem;
  fs::path dir;
  std::unique_ptr<LearnerCore> loaded;
  ASSERT_NO_FATAL_FAILURE(CheckpointAndReload(r, o, "coins-best-task", &dir, &loaded));
  EXPECT_EQ(loaded->best_task()->env_steps, kept->env_steps);
  EXPECT_DOUBLE_EQ(loaded->best_task()->return_mean, kept->return_mean);
  EXPECT_TRUE(loaded->best_task()->acting == kept->acting);
  auto models = loaded->Models(1, /*best_task=*/true);
  ASSERT_TRUE(models.ok()) << models.status().message();

  // a damaged best-task file fails the load, named
  Damage(dir / "task-best.bin", [](std::vector<char>& b) { b[b.size() / 2] ^= 0x5a; });
  LearnerCore damaged(r.spec(), o.learner, 9);
  const Status s = damaged.LoadCheckpoint(dir.string());
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("task-best.bin"), std::string::npos) << s.message();
  fs::remove_all(dir);
}

// with keep_best_task false no weights are kept beside the newest: the task's final policy (the
// best-task models) acts with the newest weights
TEST(LocalRun, WithoutKeepingTheBestTheTaskActsWithItsNewestWeights) {
  LocalRunOptions o = TaskEvalOptions();
  o.learner.keep_best_task = false;
  auto made = LocalRun::Create(o);
  ASSERT_TRUE(made.ok()) << made.status().message();
  LocalRun& r = **made;
  std::vector<std::pair<uint64_t, double>> evals;
  ASSERT_NO_FATAL_FAILURE(TrainTaskForEvaluations(r, 3, &evals));
  EXPECT_FALSE(r.learner().best_task().has_value());
  EXPECT_GT(r.learner().trainer(1)->updates(), 0);  // newest weights that differ from the first
  auto models = r.learner().Models(1, /*best_task=*/true);
  ASSERT_TRUE(models.ok()) << models.status().message();
}

// with eval_confirm_episodes, the kept task weights are scored by new episodes of their own: the
// kept mean is what those weights return on exactly those episodes, not the periodic evaluation
// that nominated them, and a checkpoint keeps which episodes they were
TEST(LocalRun, AKeptTaskPolicyIsScoredByItsConfirmingEpisodes) {
  LocalRunOptions o = TaskEvalOptions();
  o.learner.eval_confirm_episodes = 5;
  auto made = LocalRun::Create(o);
  ASSERT_TRUE(made.ok()) << made.status().message();
  LocalRun& r = **made;
  std::vector<std::pair<uint64_t, double>> evals;
  ASSERT_NO_FATAL_FAILURE(TrainTaskForEvaluations(r, 8, &evals));
  const auto& kept = r.learner().best_task();
  ASSERT_TRUE(kept.has_value());
  EXPECT_EQ(kept->episodes, 5);
  auto nominated = std::find_if(evals.begin(), evals.end(), [&](auto& e) { return e.first == kept->env_steps; });
  ASSERT_NE(nominated, evals.end()) << "kept weights of " << kept->env_steps << " env steps, not evaluated then";

  auto models = r.learner().Models(1, /*best_task=*/true);
  ASSERT_TRUE(models.ok()) << models.status().message();
  auto env = envs::MakeEnv(r.spec().name);
  ASSERT_TRUE(env.ok());
  EvalOptions again;
  again.episodes = int(kept->episodes);
  again.max_steps = o.learner.eval_max_steps;
  again.seed = kept->seed;
  again.task_explore = float(o.learner.eval_task_explore);
  auto replay = Evaluate(**env, **models, 1, again);
  ASSERT_TRUE(replay.ok()) << replay.status().message();
  ASSERT_EQ(replay->returns.size(), 5u);
  EXPECT_DOUBLE_EQ(replay->return_mean, kept->return_mean);
  for (const auto& [steps, mean] : evals)  // no periodic evaluation drew the confirming episodes
    EXPECT_GE(kept->seed, o.seed + 7919 + steps + uint64_t(o.learner.eval_episodes)) << steps;

  std::filesystem::path dir;
  std::unique_ptr<LearnerCore> loaded;
  ASSERT_NO_FATAL_FAILURE(CheckpointAndReload(r, o, "coins-confirmed-task", &dir, &loaded));
  EXPECT_EQ(loaded->best_task()->episodes, 5);
  EXPECT_EQ(loaded->best_task()->seed, kept->seed);
  std::filesystem::remove_all(dir);
}

// 6000 random steps, a detect round that accepts Action -> Paddle, and the paddle skill trained
// (one update per env step from 6500) until `until` env steps; `train` is its command (seq 3)
void TrainThePaddleSkill(LocalRun& r, uint64_t until, msg::ChainCommand* train) {
  ASSERT_TRUE(r.Command(Command(1, "idle", 0, 6000)).ok());
  ASSERT_TRUE(r.StepActors(100000).ok());
  msg::ChainCommand detect = Command(2, "detect", 0, 6000);
  detect.source("Action");
  detect.targets({"Paddle"});
  detect.round(1);
  ASSERT_TRUE(r.Command(detect).ok());
  ASSERT_TRUE(r.LearnerWork(1).ok());
  ASSERT_EQ(r.scores().size(), 1u);
  ASSERT_TRUE(r.scores()[0].scores()[0].pass());
  *train = Command(3, "train-skill", 1, 6500);
  train->steps_per_update(1.0);
  train->links({LinkFrom(r.scores()[0].scores()[0])});
  ASSERT_TRUE(r.Command(*train).ok());
  while (r.env_steps() < until) {
    ASSERT_TRUE(r.StepActors(250).ok());
    ASSERT_TRUE(r.LearnerWork(1000).ok());
  }
}

// a task over a briefly trained paddle skill (the paddle skill is level 1, the task level 2),
// trained until `evals` periodic evaluations; the skill's weights and updates when the task started
void TrainTaskOverThePaddleSkill(LocalRun& r, size_t evals, std::vector<uint8_t>* skill_before,
                                 int64_t* skill_updates_before, std::vector<msg::LinkSpec>* links = nullptr) {
  msg::ChainCommand train;
  ASSERT_NO_FATAL_FAILURE(TrainThePaddleSkill(r, 9000, &train));
  msg::ChainCommand task = Command(4, "train-task", 2, 9500);
  task.steps_per_update(4.0);
  task.links(train.links());
  if (links) *links = train.links();
  ASSERT_TRUE(r.Command(task).ok());
  while (r.learner().selection()) ASSERT_TRUE(r.LearnerWork(1).ok());
  *skill_before = r.learner().trainer(1)->ActingBlob();
  *skill_updates_before = r.learner().trainer(1)->updates();
  std::vector<uint64_t> seen;
  while (seen.size() < evals) {
    ASSERT_TRUE(r.StepActors(250).ok());
    ASSERT_TRUE(r.LearnerWork(100).ok());
    const uint64_t at = r.learner().status().eval_env_steps();
    if (at && (seen.empty() || seen.back() != at)) seen.push_back(at);
  }
}

LocalRunOptions TaskOverSkillOptions(int64_t skill_updates_in_task) {
  LocalRunOptions o = TaskEvalOptions();
  o.learner.select_snapshots = 0;
  o.learner.skill_updates_in_task = skill_updates_in_task;
  return o;
}

// by default a learned skill stays as its phase left it while the task trains over it
TEST(LocalRun, ALearnedSkillStaysAsItWasUnderTheTask) {
  auto made = LocalRun::Create(TaskOverSkillOptions(0));
  ASSERT_TRUE(made.ok()) << made.status().message();
  LocalRun& r = **made;
  std::vector<uint8_t> before;
  int64_t updates_before = 0;
  ASSERT_NO_FATAL_FAILURE(TrainTaskOverThePaddleSkill(r, 3, &before, &updates_before));
  EXPECT_GT(r.learner().trainer(2)->updates(), 200);
  EXPECT_EQ(r.learner().trainer(1)->updates(), updates_before);
  EXPECT_EQ(r.learner().trainer(1)->ActingBlob(), before);
  ASSERT_TRUE(r.learner().best_task().has_value());
  EXPECT_TRUE(r.learner().best_task()->skills.empty());
}

// with skill_updates_in_task the skill under the task takes that many updates per task update,
// the actors get its new weights, and the kept task keeps the skill's weights it was evaluated
// with, through a checkpoint (a damaged copy is refused, named) and into a transfer. The skill
// acts with a running average of its weights, which a checkpoint read with other options (coins
// eval's) still acts with.
TEST(LocalRun, ASkillTrainingUnderTheTaskIsPublishedAndKeptWithTheBestTask) {
  LocalRunOptions o = TaskOverSkillOptions(2);
  o.learner.primitive.acting_average = 0.05;
  auto made = LocalRun::Create(o);
  ASSERT_TRUE(made.ok()) << made.status().message();
  LocalRun& r = **made;
  std::vector<uint8_t> before;
  int64_t updates_before = 0;
  std::vector<msg::LinkSpec> links;
  ASSERT_NO_FATAL_FAILURE(TrainTaskOverThePaddleSkill(r, 3, &before, &updates_before, &links));
  const int64_t task_updates = r.learner().trainer(2)->updates();
  const int64_t skill_updates = r.learner().trainer(1)->updates() - updates_before;
  EXPECT_GT(task_updates, 200);
  EXPECT_GE(skill_updates, 2 * task_updates - 2);
  EXPECT_LE(skill_updates, 2 * task_updates);
  EXPECT_NE(r.learner().trainer(1)->ActingBlob(), before);
  const std::string skill_name = r.learner().trainer(1)->spec().name;
  bool published = false;
  for (const msg::PolicyWeights& w : r.learner().Latest())
    if (w.name() == skill_name) {
      published = true;
      EXPECT_NE(w.blob(), before) << "the actors get the skill's new weights";
    }
  EXPECT_TRUE(published);

  const auto& kept = r.learner().best_task();
  ASSERT_TRUE(kept.has_value());
  ASSERT_EQ(kept->skills.size(), 1u);
  EXPECT_NE(kept->skills[0], before) << "weights of an evaluation after the first skill updates";
  std::filesystem::path dir;
  std::unique_ptr<LearnerCore> loaded;
  ASSERT_NO_FATAL_FAILURE(CheckpointAndReload(r, o, "coins-skill-under-task", &dir, &loaded));
  ASSERT_EQ(loaded->best_task()->skills.size(), 1u);
  EXPECT_EQ(loaded->best_task()->skills[0], kept->skills[0]);
  EXPECT_EQ(loaded->trainer(1)->ActingBlob(), r.learner().trainer(1)->ActingBlob());
  ASSERT_TRUE(loaded->Models(2, /*best_task=*/true).ok());
  LearnerCore as_eval(r.spec(), LearnerOptions{}, 9);  // the checkpoint says its skill acts with an average
  ASSERT_TRUE(as_eval.LoadCheckpoint(dir.string()).ok());
  EXPECT_EQ(as_eval.trainer(1)->acting_average(), 0.05);
  EXPECT_EQ(as_eval.trainer(1)->ActingBlob(), r.learner().trainer(1)->ActingBlob());

  // a transfer from this run starts from the skill the kept task was evaluated over, not the newest
  ASSERT_NE(loaded->trainer(1)->ActingBlob(), kept->skills[0]) << "the skill trained on after the best evaluation";
  ASSERT_TRUE(loaded->KeepSkillsFor(r.spec(), links).ok());
  EXPECT_EQ(loaded->trainer(1)->ActingBlob(), kept->skills[0]);

  Damage(dir / "task-best-skill-1.bin", [](std::vector<char>& b) { b[b.size() / 3] ^= 0x21; });
  LearnerCore damaged(r.spec(), o.learner, 9);
  const Status s = damaged.LoadCheckpoint(dir.string());
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("task-best-skill-1.bin"), std::string::npos) << s.message();
  std::filesystem::remove_all(dir);
}

// the paddle skill's training ends: its snapshots and its final weights are evaluated on the same
// goals and the best kept, published and checkpointed. A checkpoint taken while training keeps
// the snapshots; one taken mid-choice resumes the choice, which then makes the same choice.
TEST(LocalRun, AFinishedSkillKeepsTheBestOfItsSnapshotsAndAResumedChoiceMakesTheSameOne) {
  LocalRunOptions o = Options();
  o.actors = o.shards = 1;
  o.learner.eval_every_steps = 1000000;  // no periodic evaluation: only the choice evaluates
  o.learner.select_snapshots = 3;
  o.learner.select_snapshot_every_steps = 1500;
  o.learner.select_goals = 400;
  auto made = LocalRun::Create(o);
  ASSERT_TRUE(made.ok()) << made.status().message();
  LocalRun& r = **made;
  msg::ChainCommand train;
  ASSERT_NO_FATAL_FAILURE(TrainThePaddleSkill(r, 14000, &train));
  const SkillSnapshots& snaps = r.learner().snapshots();
  ASSERT_EQ(snaps.all().size(), 3u) << "one every 1500 env steps from 6000, the newest 3";
  EXPECT_EQ(snaps.level(), 1);
  EXPECT_GE(snaps.all().back().env_steps, 12000u);
  EXPECT_NE(snaps.all().front().acting, snaps.all().back().acting);

  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("coins-skill-choice-" + std::to_string(getpid()));
  fs::remove_all(dir);
  ASSERT_TRUE(r.learner().SaveCheckpoint((dir / "training").string(), 1, 1).ok());
  {
    LearnerCore loaded(r.spec(), o.learner, o.seed);
    ASSERT_TRUE(loaded.LoadCheckpoint((dir / "training").string()).ok());
    ASSERT_EQ(loaded.snapshots().all().size(), 3u);
    for (size_t i = 0; i < 3; ++i) {
      EXPECT_EQ(loaded.snapshots().all()[i].env_steps, snaps.all()[i].env_steps);
      EXPECT_EQ(loaded.snapshots().all()[i].acting, snaps.all()[i].acting);
    }
    EXPECT_EQ(loaded.snapshots().next_at(), snaps.all().back().env_steps + 1500);
  }

  // the orchestrator moves on (collecting from the paddle): the choice starts
  msg::ChainCommand collect = Command(4, "idle", 1, 30000);
  collect.links(train.links());
  const std::vector<uint8_t> final_weights = r.learner().trainer(1)->ActingBlob();
  ASSERT_TRUE(r.Command(collect).ok());
  ASSERT_NE(r.learner().selection(), nullptr);
  ASSERT_EQ(r.learner().selection()->candidates().size(), 4u);
  EXPECT_EQ(r.learner().selection()->candidates().back().acting, final_weights);
  ASSERT_TRUE(r.LearnerWork(1).ok());  // the first candidate (one slice of 400 goals), then a checkpoint
  ASSERT_NE(r.learner().selection(), nullptr);
  ASSERT_TRUE(r.learner().SaveCheckpoint((dir / "choosing").string(), 2, 2).ok());
  while (r.learner().selection()) ASSERT_TRUE(r.LearnerWork(1).ok());
  const SkillSelection* choice = r.learner().last_choice();
  ASSERT_NE(choice, nullptr);
  for (size_t i = 0; i < 4; ++i) {
    EXPECT_GE(choice->scores()[i].goals, 400u) << i;
    EXPECT_LE(choice->scores()[i].success(), choice->scores()[choice->best()].success()) << choice->Table();
  }
  const std::vector<uint8_t>& chosen = choice->candidates()[choice->best()].acting;
  EXPECT_EQ(r.learner().trainer(1)->ActingBlob(), chosen);
  bool published = false;
  for (const msg::PolicyWeights& w : r.learner().Latest())
    if (w.name() == r.learner().trainer(1)->spec().name) {
      published = true;
      EXPECT_EQ(w.blob(), chosen) << "the actors get the chosen weights";
    }
  EXPECT_TRUE(published);

  LearnerCore resumed(r.spec(), o.learner, o.seed);
  ASSERT_TRUE(resumed.LoadCheckpoint((dir / "choosing").string()).ok());
  ASSERT_NE(resumed.selection(), nullptr);
  LearnerCore::Outputs out;
  while (resumed.selection()) ASSERT_TRUE(resumed.Work(nullptr, 30000, &out).ok());
  ASSERT_NE(resumed.last_choice(), nullptr);
  EXPECT_EQ(resumed.last_choice()->best(), choice->best()) << resumed.last_choice()->Table() << choice->Table();
  EXPECT_EQ(resumed.last_choice()->Table(), choice->Table());
  EXPECT_EQ(resumed.trainer(1)->ActingBlob(), chosen);
  ASSERT_EQ(out.weights.size(), 1u);
  EXPECT_EQ(out.weights[0].blob(), chosen);

  // a damaged candidate file fails the load, named
  Damage(dir / "choosing" / "skill-candidate-1.bin", [](std::vector<char>& b) { b.resize(b.size() - 7); });
  LearnerCore damaged(r.spec(), o.learner, o.seed);
  const Status s = damaged.LoadCheckpoint((dir / "choosing").string());
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("skill-candidate-1.bin"), std::string::npos) << s.message();
  fs::remove_all(dir);
}

}  // namespace
}  // namespace coins
