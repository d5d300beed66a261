// `coins transfer` across real processes: a learned chain's skills carried to a Breakout variant,
// frozen while a new task policy trains over them; and the sources it refuses before starting.
//
// The source run is made here in one process (LocalRun: actors, replay, learner without DDS):
// the paddle skill, a Paddle->Ball detector and the ball skill trained briefly, checkpointed, and
// a chain.json whose links carry the values a real chain found. What the skills learned does not
// matter to these tests (learning results are experiments); that the transfer carries them over
// unchanged and trains only the task does.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>

#include <yaml-cpp/yaml.h>

#include "common/checkpoint.h"
#include "common/files.h"
#include "learner/checkpoint_dirs.h"
#include "learner/local_run.h"
#include "orchestrator/chain_messages.h"
#include "orchestrator/chain_store.h"
#include "orchestrator/config_values.h"
#include "orchestrator/experiment_command.h"
#include "orchestrator/system_config.h"
#include "tests/process_harness.h"

namespace coins {
namespace {

namespace fs = std::filesystem;
using testing::Bin;
using testing::CommandResult;
using testing::ReadJson;
using testing::RunCommand;
using testing::TempDir;
using testing::TestDomain;

constexpr const char* kConfig = R"(run:
  env: breakout
  actors: 1
  shards: 1
replay:
  capacity: 100000
  capacity_mb: 64
learner:
  eval_every_steps: 500
  eval_episodes: 2
  eval_max_steps: 3000
  checkpoint_keep: 20
  select_goals: 500
detector:
  passive_steps: 50
  passive_hard_steps: 50
  active_steps: 50
orchestrator:
  task_learning_starts: 500
  checkpoint_period_s: 2
  checkpoint_timeout_s: 2
)";

msg::ChainCommand Command(uint64_t seq, const std::string& job, int acting, uint64_t step_base,
                          const std::vector<msg::LinkSpec>& links) {
  msg::ChainCommand c;
  c.schema_version(msg::CHAIN_COMMAND_SCHEMA);
  c.seq(seq);
  c.job(job);
  c.acting_level(acting);
  c.step_base(step_base);
  c.steps_per_update(2);
  c.links(links);
  return c;
}

chain::LinkSpec PaddleLink() { return {"Action", "Paddle", 4.35, {0, 1, 0, 0, 0}, "continuous", {7.5f, 75.5f}, 0.97}; }
chain::LinkSpec BallLink() {
  return {"Paddle", "Ball", 11639.6, {0, 0, 1, 1, 0}, "discrete", {-2, -1, -2, 1, -1, -1, -1, 1}, 0.0037};
}
// trains until the learner has done `updates` more updates of its current job
void Train(LocalRun& r, int updates) {
  for (int i = 0; i < 200 && r.learner().status().updates() < uint64_t(updates); ++i) {
    ASSERT_TRUE(r.StepActors(500).ok());
    auto w = r.LearnerWork(200);
    ASSERT_TRUE(w.ok()) << w.status().message();
  }
  ASSERT_GE(r.learner().status().updates(), uint64_t(updates));
}

// RUN/config.yaml, RUN/checkpoints/learner-epoch-1 (both skills, the Ball detector)
void MakeSourceRun(const fs::path& run) {
  fs::create_directories(run);
  std::ofstream(run / "config.yaml") << kConfig;
  SystemConfig c;
  ConfigLoader loader = c.Loader();
  ASSERT_TRUE(loader.LoadFile((run / "config.yaml").string()).ok());
  ASSERT_TRUE(loader.Validate().ok());
  LocalRunOptions o;
  o.actors = 1;
  o.shards = 1;
  o.seed = 4;
  o.actor.batch_rows = 256;
  o.replay.capacity = 100000;
  o.replay.capacity_mb = 64;
  o.learner = c.learner;
  auto made = LocalRun::Create(o);
  ASSERT_TRUE(made.ok()) << made.status().message();
  LocalRun& r = **made;
  const msg::LinkSpec paddle = ToMessage(PaddleLink()), ball = ToMessage(BallLink());
  ASSERT_TRUE(r.Command(Command(1, "idle", 0, 4000, {})).ok());
  ASSERT_TRUE(r.StepActors(100000).ok());
  ASSERT_TRUE(r.Command(Command(2, "train-skill", 1, 5000, {paddle})).ok());
  Train(r, 300);
  msg::ChainCommand detect = Command(3, "detect", 1, r.env_steps(), {paddle});
  detect.source("Paddle");
  detect.targets({"Ball"});
  detect.round(1);
  ASSERT_TRUE(r.Command(detect).ok());
  // the paddle skill's weights are chosen first (learner/skill_selection.h), then the round runs
  ASSERT_NE(r.learner().selection(), nullptr);
  for (int i = 0; i < 100 && r.learner().selection(); ++i) ASSERT_TRUE(r.LearnerWork(1).ok());
  ASSERT_EQ(r.learner().selection(), nullptr);
  ASSERT_EQ(r.learner().choices().size(), 1u);
  auto detected = r.LearnerWork(1);
  ASSERT_TRUE(detected.ok()) << detected.status().message();
  ASSERT_TRUE(r.Command(Command(4, "train-skill", 2, r.env_steps() + 2000, {paddle, ball})).ok());
  Train(r, 200);
  ASSERT_TRUE(r.learner().SaveCheckpoint(CheckpointDir(run.string(), 1), 1, CheckpointCommandId(1)).ok());
  ASSERT_TRUE(fs::exists(fs::path(CheckpointDir(run.string(), 1)) / "detector-Ball.bin"));
}

// RUN/chain/chain.json: a finished chain with `links` (the last one learned when `learned`)
void WriteChain(const fs::path& run, std::vector<chain::LinkSpec> links, bool learned) {
  SystemConfig c;
  ConfigLoader loader = c.Loader();
  ASSERT_TRUE(loader.LoadFile((run / "config.yaml").string()).ok());
  chain::ChainState s;
  s.phase = learned ? chain::Phase::kDone : chain::Phase::kTrainingSkill;
  s.seq = 9;
  s.source = links.back().target;
  for (size_t i = 0; i < links.size(); ++i) {
    chain::Link l;
    l.spec = links[i];
    l.accepted_at_steps = 10000 * (i + 1);
    l.learned_at_steps = learned || i + 1 < links.size() ? 10000 * (i + 2) : 0;
    s.links.push_back(l);
  }
  ASSERT_TRUE(chain::ChainStore(run / "chain", ChainFingerprint(c.Values())).Save(s).ok());
}

// the source run, made once for every test of this file
const fs::path& SourceRun() {
  static const fs::path run = [] {
    fs::path dir = TempDir("transfer-source") / "run";
    MakeSourceRun(dir);
    WriteChain(dir, {PaddleLink(), BallLink()}, true);
    return dir;
  }();
  return run;
}

std::vector<uint8_t> Bytes(const fs::path& p) {
  auto b = ReadFileBytes(p.string());
  return b.ok() ? *b : std::vector<uint8_t>{};
}

bool OneLine(const CommandResult& r) { return std::count(r.output.begin(), r.output.end(), '\n') == 1; }

// the task trains on breakout-single over the source's paddle and ball skills; both skills' weights,
// targets and optimiser state are byte for byte the source's in every checkpoint the run wrote
TEST(Transfer, TrainsATaskOnAVariantOverFrozenSkills) {
  const fs::path src = SourceRun();
  ASSERT_FALSE(HasFatalFailure());
  const fs::path out = TempDir("transfer-single") / "run";
  const std::string domain = std::to_string(TestDomain());
  auto r =
      RunCommand(Bin("coins") + " transfer " + src.string() + " --env breakout-single --steps 3000 --quiet --dir " +
                     out.string() + " --set dds.domain=" + domain,
                 std::chrono::seconds(200));
  ASSERT_EQ(r.code, 0) << r.output;

  const nlohmann::json t = ReadJson(out / "transfer.json");
  ASSERT_TRUE(t.is_object()) << r.output;
  EXPECT_EQ(t["env"], "breakout-single");
  EXPECT_EQ(t["links"], nlohmann::json({"Action->Paddle", "Paddle->Ball"}));
  ASSERT_EQ(t["skills"].size(), 2u);
  EXPECT_EQ(t["skills"][1]["name"], "skill/Ball");

  const nlohmann::json chain = testing::ChainState(out);
  EXPECT_EQ(chain["phase"], "done") << chain.dump();
  EXPECT_GE(chain["env_steps"].get<uint64_t>(), 3000u);

  // every checkpoint of the transfer run: the skills as trained in the source, the task trained
  const std::vector<int64_t> epochs = CheckpointEpochs(out.string());
  ASSERT_GE(epochs.size(), 2u) << "epoch 0 (the seed) and at least one of the run";
  const fs::path source_ckpt = CheckpointDir(src.string(), 1);
  for (int64_t e : epochs) {
    const fs::path ckpt = CheckpointDir(out.string(), uint64_t(e));
    for (const char* file : {"trainer-1.bin", "trainer-2.bin", "detector-Ball.bin"}) {
      const std::vector<uint8_t> a = Bytes(source_ckpt / file), b = Bytes(ckpt / file);
      ASSERT_FALSE(a.empty()) << file;
      EXPECT_TRUE(a == b) << file << " of epoch " << e << " differs from the source's";
    }
  }
  const nlohmann::json last = ReadJson(fs::path(CheckpointDir(out.string(), uint64_t(epochs.back()))) / "state.json");
  ASSERT_EQ(last["trainers"].size(), 3u) << last.dump();
  EXPECT_EQ(last["trainers"][2]["name"], "task");
  EXPECT_GT(last["total_updates"].get<uint64_t>(), 300u) << "the task trained: (3000 - 500) / 4 updates paced";
  EXPECT_EQ(last["trainers"][0]["acting_checksum"], t["skills"][0]["acting_checksum"]);
  EXPECT_EQ(last["trainers"][1]["acting_checksum"], t["skills"][1]["acting_checksum"]);

  // `coins eval` runs the transferred task on the variant
  auto e = RunCommand(Bin("coins") + " eval " + out.string() + " --episodes 3 --json");
  ASSERT_EQ(e.code, 0) << e.output;
  const auto j = nlohmann::json::parse(e.output, nullptr, false);
  ASSERT_TRUE(j.is_object()) << e.output;
  EXPECT_EQ(j["env"], "breakout-single");
  EXPECT_EQ(j["policy"], "task");
  EXPECT_EQ(j["episodes"], 3);
}

TEST(Transfer, RefusesWithOneLineSourcesThatDoNotFit) {
  const fs::path src = SourceRun();
  ASSERT_FALSE(HasFatalFailure());
  const fs::path dir = TempDir("transfer-refused");
  const std::string coins = Bin("coins") + " transfer ";
  auto expect_refused = [&](const std::string& args, const std::string& what) {
    auto r = RunCommand(coins + args + " --dir " + (dir / "out").string());
    EXPECT_EQ(r.code, 2) << args << ": " << r.output;
    EXPECT_TRUE(OneLine(r)) << r.output;
    EXPECT_NE(r.output.find(what), std::string::npos) << args << ": " << r.output;
    EXPECT_FALSE(fs::exists(dir / "out" / "logs" / "learner.log")) << "nothing may start: " << args;
  };
  expect_refused(src.string() + " --env breakout-nope", "unknown env 'breakout-nope'");
  expect_refused(src.string() + " --env pushing", "env pushing has no factor Paddle");
  expect_refused((dir / "missing").string() + " --env breakout-single", "not a run directory");
  expect_refused(src.string() + " --env breakout-single --set learner.skill_hidden=[64,64]",
                 "skill 2 (Paddle->Ball): the trained skill differs");

  // a chain that found only the paddle, and one whose ball skill is still training
  const fs::path paddle_only = dir / "paddle-only";
  fs::copy(src, paddle_only, fs::copy_options::recursive);
  WriteChain(paddle_only, {PaddleLink()}, true);
  expect_refused(paddle_only.string() + " --env breakout-single",
                 "the chain has no Ball skill (its links: Action->Paddle)");
  WriteChain(paddle_only, {PaddleLink(), BallLink()}, false);
  expect_refused(paddle_only.string() + " --env breakout-single", "the chain's Ball skill is not learned yet");
}

// the vanilla baseline in the same harness: `coins run` with orchestrator.chain none trains the task
// alone over primitive actions (one level, the env's four actions) on the variant
TEST(Baseline, WithoutAChainTheTaskTrainsOverPrimitiveActions) {
  const fs::path dir = TempDir("baseline-vanilla");
  std::ofstream(dir / "config.yaml") << kConfig;
  const fs::path out = dir / "run";
  auto r = RunCommand(Bin("coins") + " run --config " + (dir / "config.yaml").string() +
                          " --env breakout-single --quiet --dir " + out.string() +
                          " --set dds.domain=" + std::to_string(TestDomain()) +
                          " --set orchestrator.chain=none --set run.steps=0 --set orchestrator.task_max_steps=3000 "
                          "--set orchestrator.task_min_steps=3000",
                      std::chrono::seconds(200));
  ASSERT_EQ(r.code, 0) << r.output;
  const nlohmann::json chain = testing::ChainState(out);
  EXPECT_EQ(chain["phase"], "done") << chain.dump();
  EXPECT_TRUE(chain["links"].empty()) << chain.dump();
  const std::vector<int64_t> epochs = CheckpointEpochs(out.string());
  ASSERT_FALSE(epochs.empty());
  const nlohmann::json last = ReadJson(fs::path(CheckpointDir(out.string(), uint64_t(epochs.back()))) / "state.json");
  ASSERT_EQ(last["trainers"].size(), 1u) << last.dump();
  const nlohmann::json& task = last["trainers"][0];
  EXPECT_EQ(task["name"], "task");
  EXPECT_EQ(task["level"], 1);
  EXPECT_EQ(task["spec"]["action_kind"], "primitive-discrete") << task["spec"].dump();
  EXPECT_EQ(task["spec"]["num_actions"], 4);
  EXPECT_EQ(task["spec"]["relative"].size(), 2u) << "Paddle-Ball y and x";
  EXPECT_GT(last["total_updates"].get<uint64_t>(), 300u);
  auto e = RunCommand(Bin("coins") + " eval " + out.string() + " --episodes 2 --json");
  ASSERT_EQ(e.code, 0) << e.output;
  EXPECT_NE(e.output.find("\"policy\":\"task\""), std::string::npos) << e.output;
}

// fine-tuning: a transfer from a run without a chain continues training its task policy (a pair
// network over the blocks, so it fits the variant's board); prox's extra Target factor gets new input weights
TEST(Baseline, FineTuningStartsFromTheVanillaRunsTaskPolicyAndTrainsIt) {
  const fs::path dir = TempDir("baseline-finetune");
  std::ofstream(dir / "config.yaml") << kConfig;
  const std::string domain = std::to_string(TestDomain());
  const fs::path pre = dir / "pre";
  auto r = RunCommand(Bin("coins") + " run --config " + (dir / "config.yaml").string() + " --quiet --dir " +
                          pre.string() + " --set dds.domain=" + domain +
                          " --set orchestrator.chain=none --set run.steps=0 --set orchestrator.task_max_steps=3000 "
                          "--set orchestrator.task_min_steps=3000 --set learner.task_pair_hidden=[16,16]",
                      std::chrono::seconds(200));
  ASSERT_EQ(r.code, 0) << r.output;
  const fs::path out = dir / "single";
  // epochs a minute apart: at 2 s, a slow run (a sanitizer's) pruned epoch 0 before it ended
  r = RunCommand(Bin("coins") + " transfer " + pre.string() + " --env breakout-single --steps 3000 --quiet --dir " +
                     out.string() + " --set dds.domain=" + domain + " --set orchestrator.checkpoint_period_s=60",
                 std::chrono::seconds(200));
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_EQ(ReadJson(out / "transfer.json")["finetune"], true);
  const std::vector<uint8_t> trained = Bytes(fs::path(*FindCheckpoint(pre.string(), -1)) / "trainer-1.bin");
  ASSERT_FALSE(trained.empty());
  EXPECT_TRUE(Bytes(fs::path(CheckpointDir(out.string(), 0)) / "trainer-1.bin") == trained)
      << "the fine-tuning starts from the vanilla run's network and optimiser state";
  const std::vector<int64_t> epochs = CheckpointEpochs(out.string());
  ASSERT_GE(epochs.size(), 2u);
  const fs::path last = CheckpointDir(out.string(), uint64_t(epochs.back()));
  EXPECT_FALSE(Bytes(last / "trainer-1.bin") == trained) << "and trains it";
  const nlohmann::json state = ReadJson(last / "state.json");
  EXPECT_EQ(state["trainers"][0]["spec"]["pair"]["instances"], 1) << "one block in breakout-single";
  EXPECT_GT(state["total_updates"].get<uint64_t>(), 300u);

  // breakout-prox adds a Target factor: the network is re-laid with zero weights on its inputs
  // (learner/trainers/input_remap.h) and trains on
  const fs::path prox = dir / "prox";
  r = RunCommand(Bin("coins") + " transfer " + pre.string() + " --env breakout-prox --steps 2000 --quiet --dir " +
                     prox.string() + " --set dds.domain=" + domain,
                 std::chrono::seconds(200));
  ASSERT_EQ(r.code, 0) << r.output;
  const std::vector<int64_t> prox_epochs = CheckpointEpochs(prox.string());
  ASSERT_FALSE(prox_epochs.empty());
  const nlohmann::json prox_state =
      ReadJson(fs::path(CheckpointDir(prox.string(), uint64_t(prox_epochs.back()))) / "state.json");
  EXPECT_EQ(prox_state["trainers"][0]["spec"]["pair"]["instances"], 60) << "prox's board";
  EXPECT_EQ(prox_state["trainers"][0]["spec"]["relative"].size(), 6u)
      << "paddle, ball and target: y and x of each pair";
  EXPECT_GT(prox_state["total_updates"].get<uint64_t>(), 100u);
}

// `coins experiment transfer`: one run per method on one variant, two at a time on two domains,
// the table from their final evaluations; a second call keeps the finished runs (an interrupted
// experiment continues)
TEST(Experiment, TransferTableFromCoinsAndVanillaRunsThatAreKeptWhenFinished) {
  const fs::path src = SourceRun();
  ASSERT_FALSE(HasFatalFailure());
  const fs::path out = TempDir("experiment-transfer") / "out";
  const int domains[2] = {TestDomain(), TestDomain()};
  const std::string cmd = Bin("coins") + " experiment transfer --chain " + src.string() +
                          " --variants single,prox --seeds 1 --steps 3000 --pretrain-steps 3000 --out " + out.string() +
                          " --set learner.task_pair_hidden=[16,16] --domains " + std::to_string(domains[0]) + "," +
                          std::to_string(domains[1]);
  auto r = RunCommand(cmd, std::chrono::seconds(300));
  ASSERT_EQ(r.code, 0) << r.output;
  // every run on one of the two domains, both used, and runs that overlapped in time (a run's
  // effective config is written as it starts, its summary as it ends)
  std::set<int> used;
  std::vector<std::pair<fs::file_time_type, fs::file_time_type>> spans;
  for (const char* v : {"single", "prox"})
    for (const char* m : {"coins", "vanilla", "finetune"}) {
      const fs::path run = out / v / (std::string(m) + "-seed1");
      const YAML::Node config = YAML::LoadFile((run / "config.yaml").string());
      used.insert(config["dds"]["domain"].as<int>());
      spans.emplace_back(fs::last_write_time(run / "config.yaml"), fs::last_write_time(run / "summary.json"));
    }
  EXPECT_EQ(used, (std::set<int>{domains[0], domains[1]})) << r.output;
  bool overlapped = false;
  for (size_t i = 0; i < spans.size(); ++i)
    for (size_t j = i + 1; j < spans.size(); ++j)
      overlapped |= spans[i].first < spans[j].second && spans[j].first < spans[i].second;
  EXPECT_TRUE(overlapped) << "two runs at once: " << r.output;
  const nlohmann::json t = ReadJson(out / "transfer.json");
  ASSERT_TRUE(t.is_object()) << r.output;
  for (const char* m : {"coins", "vanilla", "finetune"}) {
    const nlohmann::json& cell = t["variants"]["single"][m];
    ASSERT_EQ(cell["runs"].size(), 1u) << m;
    const fs::path run = out / "single" / (std::string(m) + "-seed1");
    EXPECT_EQ(ReadJson(run / "summary.json")["phase"], "done") << m;
    const nlohmann::json final_eval = ReadJson(run / "final-eval.json");  // `coins eval` of the final checkpoint
    ASSERT_TRUE(final_eval.is_object()) << m;
    EXPECT_EQ(final_eval["episodes"], 20) << m;
    EXPECT_EQ(final_eval["env"], "breakout-single") << m;
    EXPECT_DOUBLE_EQ(cell["runs"][0].get<double>(), final_eval["return_mean"].get<double>()) << m;
  }
  EXPECT_DOUBLE_EQ(t["variants"]["single"]["paper"]["coins"].get<double>(), -3.2);
  // the random-actions reference: 20 episodes per seed, mostly a drop (-10) after a bounce or two
  const nlohmann::json& random = t["variants"]["single"]["random_actions"];
  EXPECT_EQ(random["episodes"], 20);
  EXPECT_LT(random["mean"].get<double>(), -7.0) << random;
  EXPECT_GT(random["mean"].get<double>(), -12.0) << random;
  EXPECT_GT(random["sd"].get<double>(), 0.0) << "some episodes bounce the ball: " << random;
  // the ideal-ball bounds: a perfect ball skill never drops, so random angles cost only bounces
  // (-1 each) until the block is hit, and two bounces of foresight hit it within a bounce or two
  const nlohmann::json& angles = t["variants"]["single"]["ideal_ball_random_angles"];
  const nlohmann::json& search = t["variants"]["single"]["ideal_ball_search_2"];
  EXPECT_EQ(angles["episodes"], 20);
  EXPECT_GT(angles["mean"].get<double>(), random["mean"].get<double>()) << angles;
  EXPECT_GT(search["mean"].get<double>(), angles["mean"].get<double>() + 2.0) << search;
  EXPECT_GE(search["mean"].get<double>(), -1.0) << search;
  // a method's steps to vanilla's final are counted on one measurement: the periodic evaluations
  // (a run this short has none: its final evaluation stands in)
  auto vanilla = ReadRunResult((out / "single" / "vanilla-seed1").string());
  ASSERT_TRUE(vanilla.ok());
  const double vanilla_last = vanilla->curve.empty() ? t["variants"]["single"]["vanilla"]["runs"][0].get<double>()
                                                     : vanilla->curve.back().second;
  EXPECT_DOUBLE_EQ(t["variants"]["single"]["vanilla_final_periodic"].get<double>(), vanilla_last);
  EXPECT_EQ(t["variants"]["single"]["vanilla"]["steps_to_vanilla_final"][0].is_null(), vanilla->curve.empty())
      << "vanilla reaches its own last periodic evaluation";
  EXPECT_TRUE(fs::exists(out / "transfer.md"));
  EXPECT_TRUE(fs::exists(out / "single" / "coins-seed1" / "transfer.json")) << "the coins column is a transfer";
  EXPECT_FALSE(fs::exists(out / "single" / "vanilla-seed1" / "transfer.json"));
  EXPECT_EQ(ReadJson(out / "single" / "finetune-seed1" / "transfer.json")["from"],
            fs::absolute(out / "pretrain" / "vanilla-seed1").lexically_normal().string());
  // prox's target block is new to the pre-trained network: fine-tuned all the same
  for (const char* m : {"coins", "vanilla", "finetune"}) EXPECT_EQ(t["variants"]["prox"][m]["runs"].size(), 1u) << m;

  auto again = RunCommand(cmd, std::chrono::seconds(120));
  ASSERT_EQ(again.code, 0) << again.output;
  EXPECT_NE(again.output.find("coins seed 1: final eval return"), std::string::npos) << again.output;
  for (const char* run :
       {"single coins", "single vanilla", "single finetune", "prox coins", "prox vanilla", "prox finetune"})
    EXPECT_EQ(again.output.find(std::string(run) + " seed 1: running"), std::string::npos)
        << "finished runs are kept: " << again.output;
  EXPECT_EQ(again.output.find("pre-training"), std::string::npos) << again.output;

  auto bad = RunCommand(Bin("coins") + " experiment transfer --chain " + src.string() + " --variants tiny");
  EXPECT_EQ(bad.code, 2);
  EXPECT_NE(bad.output.find("unknown variant 'tiny'"), std::string::npos) << bad.output;
}

// `coins experiment pushing`: vanilla SAC on robot pushing in the same harness, evaluated as its
// config's learner.eval_task_explore says over the suite's episodes, with the goal and penalty
// fractions in the table; a --chain without a learned Block skill leaves the coins column not run,
// with the reason
TEST(Experiment, PushingTableFromAVanillaSacRunAndACoinsRunThatCannotStart) {
  const fs::path dir = TempDir("experiment-pushing");
  const fs::path chain = dir / "no-chain";
  fs::create_directories(chain);
  fs::copy_file(COINS_PUSHING_CONFIG, chain / "config.yaml");
  const fs::path out = dir / "out";
  auto r =
      RunCommand(Bin("coins") + " experiment pushing --chain " + chain.string() +
                     " --seeds 1 --steps 3000 --eval-episodes 4 --out " + out.string() +
                     " --set orchestrator.task_learning_starts=1000 --set dds.domain=" + std::to_string(TestDomain()),
                 std::chrono::seconds(300));
  ASSERT_EQ(r.code, 0) << r.output;
  const nlohmann::json t = ReadJson(out / "pushing.json");
  ASSERT_TRUE(t.is_object()) << r.output;
  EXPECT_EQ(t["suite"], "pushing");
  const fs::path run = out / "pushing" / "vanilla-seed1";
  const nlohmann::json summary = ReadJson(run / "summary.json");
  EXPECT_EQ(summary["phase"], "done");
  EXPECT_GE(summary["env_steps"].get<uint64_t>(), 3000u);
  const nlohmann::json final_eval = ReadJson(run / "final-eval.json");
  ASSERT_TRUE(final_eval.is_object());
  EXPECT_EQ(final_eval["env"], "pushing");
  EXPECT_EQ(final_eval["episodes"], 4);
  EXPECT_EQ(final_eval["explore"], 1.0) << "the run's learner.eval_task_explore (pushing.yaml: sample the sac task)";
  EXPECT_EQ(final_eval["level"], 1) << "vanilla acts on primitive actions";
  const nlohmann::json& vanilla = t["variants"]["pushing"]["vanilla"];
  ASSERT_EQ(vanilla["runs"].size(), 1u);
  EXPECT_DOUBLE_EQ(vanilla["runs"][0].get<double>(), final_eval["return_mean"].get<double>());
  EXPECT_LE(vanilla["runs"][0].get<double>(), -30.0 + 1e-3) << "at best -0.1 per step for 300 steps";
  ASSERT_EQ(vanilla["median_episode"].size(), 1u) << "the final evaluation's median episode, beside its mean";
  EXPECT_DOUBLE_EQ(vanilla["median_episode"][0].get<double>(), final_eval["return_median"].get<double>());
  ASSERT_EQ(vanilla["done_fraction"].size(), 1u);
  EXPECT_DOUBLE_EQ(vanilla["done_fraction"][0].get<double>(), final_eval["done_fraction"].get<double>());
  ASSERT_EQ(vanilla["penalty_fraction"].size(), 1u);
  EXPECT_DOUBLE_EQ(vanilla["penalty_fraction"][0].get<double>(), final_eval["penalty_fraction"].get<double>());
  EXPECT_DOUBLE_EQ(t["variants"]["pushing"]["paper"]["coins"].get<double>(), -21.6);
  const nlohmann::json& coins = t["variants"]["pushing"]["coins"];
  EXPECT_TRUE(coins["runs"].empty());
  EXPECT_NE(coins["not_run"].get<std::string>().find("no chain state"), std::string::npos) << coins;
  auto read = ReadFileText((out / "pushing.md").string());
  ASSERT_TRUE(read.ok()) << read.status().message();
  const std::string& md = read.value();
  EXPECT_NE(md.find("| pushing | not run |"), std::string::npos) << md;
  // random actions never bring the block to the goal: -0.1 a step or worse for 300 steps
  const nlohmann::json& random = t["variants"]["pushing"]["random_actions"];
  EXPECT_EQ(random["episodes"], 4);
  EXPECT_LE(random["mean"].get<double>(), -30.0 + 1e-3) << random;
  EXPECT_NE(md.find("random actions"), std::string::npos) << md;
  EXPECT_NE(md.find("episodes reaching the goal"), std::string::npos) << md;
  EXPECT_NE(md.find("vanilla: median episode"), std::string::npos) << md;
  EXPECT_NE(md.find(fmt::format(" {:.2f} +- 0.00 |", final_eval["return_median"].get<double>())), std::string::npos)
      << "vanilla's median episode in its column: " << md;

  // a second finished seed (a copy of the first) joins the table and the curves, drawn apart
  fs::copy(run, out / "pushing" / "vanilla-seed2", fs::copy_options::recursive);
  auto two = RunCommand(Bin("coins") + " experiment pushing --chain " + chain.string() +
                            " --seeds 2 --steps 3000 --eval-episodes 4 --out " + out.string() +
                            " --set dds.domain=" + std::to_string(TestDomain()),
                        std::chrono::seconds(300));
  ASSERT_EQ(two.code, 0) << two.output;
  EXPECT_EQ(ReadJson(out / "pushing.json")["variants"]["pushing"]["vanilla"]["runs"].size(), 2u);
  auto gp = ReadFileText((out / "curves-pushing.gp").string());
  ASSERT_TRUE(gp.ok()) << gp.status().message();
  const std::regex style(R"(with lines lw 2 (lc \d+ dt \d+) title 'vanilla seed \d')");
  std::set<std::string> styles;
  const std::string& script = gp.value();
  for (auto it = std::sregex_iterator(script.begin(), script.end(), style); it != std::sregex_iterator(); ++it)
    styles.insert((*it)[1]);
  EXPECT_EQ(styles.size(), 2u) << "one line style per seed: " << script;
}

}  // namespace
}  // namespace coins
