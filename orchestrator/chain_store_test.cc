// ChainStore: atomic writes, corrupt files, states of another config, epochs.
#include "orchestrator/chain_store.h"

#include <unistd.h>

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>

namespace coins::chain {
namespace {

namespace fs = std::filesystem;

fs::path FreshDir(const std::string& name) {
  fs::path dir = fs::temp_directory_path() / ("coins-chain-store-" + name + "-" + std::to_string(getpid()));
  fs::remove_all(dir);
  return dir;
}

std::string ReadText(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

ConfigValues Fingerprint(const std::string& eps = "3") {
  return {{"orchestrator.eps_si", eps}, {"run.env", "breakout"}, {"run.seed", "1"}};
}

ChainState SomeState() {
  ChainState s;
  s.phase = Phase::kTrainingSkill;
  s.seq = 7;
  s.source = "Action";
  Link l;
  l.spec = LinkSpec{"Action", "Paddle", 6.25, {1, 0, 0}, "continuous", {-1.0f, 1.0f}, 0.5};
  l.accepted_at_steps = 10'000;
  l.success = SuccessTracker{true, 300, 250, 3, 0.8, 0.85, 14'000};
  s.links.push_back(l);
  Score sc;
  sc.source = "Action";
  sc.target = "Ball";
  sc.score = std::nan("");
  sc.note = "no interactions";
  sc.interactions = 3;
  sc.chance_interactions = 2.5;
  sc.goal_interactions = 40;
  s.last_scores.push_back(sc);
  s.round = 2;
  s.next_detect = 20'000;
  s.phase_start = 20'000;
  s.env_steps = 23'456;
  s.eval = Eval{20'000, 1.5, 0.5, 10};
  s.epoch = 4;
  s.last_cut_epoch = 5;
  s.note = "Action->Paddle accepted";
  return s;
}

TEST(ChainStore, SavedStateLoadsBackWhole) {
  ChainStore store(FreshDir("roundtrip"), Fingerprint());
  ChainState s = SomeState();
  ASSERT_TRUE(store.Save(s).ok());
  auto loaded = store.Load();
  ASSERT_TRUE(loaded.ok()) << loaded.status().message();
  ASSERT_TRUE(loaded->has_value());
  const ChainState& l = **loaded;
  EXPECT_TRUE(std::isnan(l.last_scores.at(0).score));  // NaN travels as null
  ChainState expected = s;
  expected.last_scores[0].score = 0;
  ChainState got = l;
  got.last_scores[0].score = 0;
  EXPECT_EQ(got, expected);
  EXPECT_FALSE(fs::exists(store.StatePath().string() + ".tmp"));
}

TEST(ChainStore, NoStateFileMeansAFreshChain) {
  ChainStore store(FreshDir("absent"), Fingerprint());
  auto loaded = store.Load();
  ASSERT_TRUE(loaded.ok());
  EXPECT_FALSE(loaded->has_value());
}

TEST(ChainStore, AFailedWriteLeavesThePreviousStateWhole) {
  ChainStore store(FreshDir("atomic"), Fingerprint());
  ChainState a = SomeState();
  ASSERT_TRUE(store.Save(a).ok());
  const std::string before = ReadText(store.StatePath());
  // the temporary file cannot be created (a directory sits at its path)
  fs::create_directories(store.StatePath().string() + ".tmp");
  ChainState b = a;
  b.seq = 8;
  Status s = store.Save(b);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("chain.json.tmp"), std::string::npos) << s.message();
  EXPECT_EQ(ReadText(store.StatePath()), before);
  fs::remove_all(store.StatePath().string() + ".tmp");
  ASSERT_TRUE(store.Save(b).ok());
  EXPECT_EQ((*store.Load())->seq, 8u);
}

TEST(ChainStore, CorruptFilesAreRefusedAndNotOverwritten) {
  ChainStore store(FreshDir("corrupt"), Fingerprint());
  ASSERT_TRUE(store.Save(SomeState()).ok());
  const std::string good = ReadText(store.StatePath());
  for (const std::string& text : {good.substr(0, good.size() / 2), std::string("{\"format\": 3}"), std::string("")}) {
    std::ofstream(store.StatePath()) << text;
    auto loaded = store.Load();
    ASSERT_FALSE(loaded.ok()) << text;
    EXPECT_NE(loaded.status().message().find("corrupt"), std::string::npos) << loaded.status().message();
    EXPECT_NE(loaded.status().message().find(store.StatePath().string()), std::string::npos);
    EXPECT_EQ(ReadText(store.StatePath()), text);
  }
  // a field of the wrong type is named
  std::string bad = good;
  bad.replace(bad.find("\"seq\": 7"), 8, "\"seq\": \"7\"");
  std::ofstream(store.StatePath()) << bad;
  auto loaded = store.Load();
  ASSERT_FALSE(loaded.ok());
  EXPECT_NE(loaded.status().message().find("state.seq"), std::string::npos) << loaded.status().message();
}

TEST(ChainStore, AStateOfAnotherConfigIsRefusedNamingTheKey) {
  fs::path dir = FreshDir("config");
  ASSERT_TRUE(ChainStore(dir, Fingerprint("3")).Save(SomeState()).ok());
  auto loaded = ChainStore(dir, Fingerprint("5")).Load();
  ASSERT_FALSE(loaded.ok());
  EXPECT_NE(loaded.status().message().find("orchestrator.eps_si is 5 here, 3 in"), std::string::npos)
      << loaded.status().message();
  ConfigValues more = Fingerprint();
  more["learner.lr"] = "0.001";
  auto other = ChainStore(dir, more).Load();
  ASSERT_FALSE(other.ok());
  EXPECT_NE(other.status().message().find("learner.lr"), std::string::npos) << other.status().message();
}

// a key added to the config after the file was written: read as its default, so the older run
// still loads while the new key keeps its default, and is refused once it is changed
TEST(ChainStore, AFileThatPredatesAKeyLoadsWhileTheKeyHoldsItsDefault) {
  fs::path dir = FreshDir("added-key");
  ASSERT_TRUE(ChainStore(dir, Fingerprint()).Save(SomeState()).ok());
  ConfigValues now = Fingerprint(), defaults = Fingerprint();
  now["orchestrator.chain"] = defaults["orchestrator.chain"] = "coins";
  ChainStore store(dir, now);
  EXPECT_FALSE(store.Load().ok()) << "without the defaults the added key is a difference";
  store.AcceptKeysAddedSince(defaults);
  auto loaded = store.Load();
  ASSERT_TRUE(loaded.ok()) << loaded.status().message();
  EXPECT_EQ((*loaded)->seq, SomeState().seq);
  EXPECT_EQ((*loaded)->links, SomeState().links);
  now["orchestrator.chain"] = "none";
  ChainStore changed(dir, now);
  changed.AcceptKeysAddedSince(defaults);
  auto refused = changed.Load();
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().message().find("orchestrator.chain is none here, coins in"), std::string::npos)
      << refused.status().message();
}

// a file holding a key this version no longer reads: loads while the key holds its retired value,
// is refused naming the key otherwise
TEST(ChainStore, AFileWithARetiredKeyLoadsOnlyAtItsRetiredValue) {
  fs::path dir = FreshDir("retired-key");
  ConfigValues then = Fingerprint();
  then["learner.task_episode_end_reward"] = "0";
  ASSERT_TRUE(ChainStore(dir, then).Save(SomeState()).ok());
  auto loaded = ChainStore(dir, Fingerprint()).Load();
  ASSERT_TRUE(loaded.ok()) << loaded.status().message();
  EXPECT_EQ((*loaded)->links, SomeState().links);
  then["learner.task_episode_end_reward"] = "-1";
  ASSERT_TRUE(ChainStore(dir, then).Save(SomeState()).ok());
  auto refused = ChainStore(dir, Fingerprint()).Load();
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().message().find("learner.task_episode_end_reward"), std::string::npos)
      << refused.status().message();
}

// states written before scores kept their chance count (and the count behind their goal set)
// still load, with counts of 0
TEST(ChainStore, AScoreWithoutItsChanceCountLoadsAsZero) {
  ChainStore store(FreshDir("no-chance"), Fingerprint());
  ASSERT_TRUE(store.Save(SomeState()).ok());
  std::string text = ReadText(store.StatePath());
  for (const std::string field : {"\"chance_interactions\": 2.5,", "\"goal_interactions\": 40,"}) {
    const size_t at = text.find(field);
    ASSERT_NE(at, std::string::npos) << text;
    text.erase(at, field.size());
  }
  std::ofstream(store.StatePath()) << text;
  auto loaded = store.Load();
  ASSERT_TRUE(loaded.ok()) << loaded.status().message();
  EXPECT_EQ((*loaded)->last_scores.at(0).chance_interactions, 0.0);
  EXPECT_EQ((*loaded)->last_scores.at(0).goal_interactions, 0u);
  EXPECT_EQ((*loaded)->last_scores.at(0).interactions, 3u);
}

TEST(ChainStore, EpochFilesAreListedAndLoaded) {
  fs::path dir = FreshDir("epochs");
  ChainStore store(dir, Fingerprint());
  ChainState s = SomeState();
  for (uint64_t e : {10u, 2u}) {
    s.epoch = e;
    ASSERT_TRUE(store.SaveEpoch(s).ok());
  }
  std::ofstream(dir / "chain-epoch-x.json") << "{}";
  EXPECT_EQ(ChainStore::Epochs(dir), (std::vector<uint64_t>{2, 10}));
  auto two = store.LoadEpoch(2);
  ASSERT_TRUE(two.ok());
  EXPECT_EQ(two->epoch, 2u);
  auto missing = store.LoadEpoch(3);
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.status().message().find("no complete epoch 3"), std::string::npos);
}

}  // namespace
}  // namespace coins::chain
