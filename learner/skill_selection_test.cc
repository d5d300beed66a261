// SkillSnapshots and SkillSelection with a scripted evaluation: which candidate wins, on which
// goals each is evaluated, and how the work is sliced.
#include "learner/skill_selection.h"

#include <gtest/gtest.h>

#include <map>
#include <set>

namespace coins {
namespace {

std::vector<uint8_t> Blob(uint8_t id) { return std::vector<uint8_t>(16, id); }

TEST(SkillSnapshots, KeepsTheNewestOnesOneEveryPeriodOfTheSkillBeingTrained) {
  SkillSnapshots s(3, 1000);
  s.Start(2, 5000);
  EXPECT_FALSE(s.Due(2, 5999));
  EXPECT_FALSE(s.Due(1, 7000)) << "another level's training takes no snapshot";
  for (uint64_t steps = 6000; steps <= 10500; steps += 500)
    if (s.Due(2, steps)) s.Add(steps, Blob(uint8_t(steps / 1000)));
  ASSERT_EQ(s.all().size(), 3u);
  EXPECT_EQ(s.all()[0].env_steps, 8000u);
  EXPECT_EQ(s.all()[2].env_steps, 10000u);
  EXPECT_EQ(s.all()[2].acting, Blob(10));
  EXPECT_EQ(s.next_at(), 11000u);
  s.Start(3, 20000);
  EXPECT_TRUE(s.all().empty());
  SkillSnapshots off(0, 1000);
  off.Start(2, 0);
  EXPECT_FALSE(off.Due(2, 5000));
}

// a scripted skill: candidate k reaches goals with rate reached[k] and ends them by an
// interaction with rate hit[k]; every call is recorded
struct Scripted {
  std::map<uint8_t, double> hit, reached;
  std::vector<std::pair<uint8_t, uint64_t>> calls;  // candidate id, seed
  Result<EvalResult> operator()(const std::vector<uint8_t>& acting, int64_t goals, int64_t, uint64_t seed) {
    calls.emplace_back(acting[0], seed);
    EvalResult r;
    r.goals_ended = uint64_t(goals);
    r.goals_interacted = uint64_t(double(goals) * hit[acting[0]]);
    r.goals_reached = uint64_t(double(goals) * reached[acting[0]]);
    r.steps = goals * 100;
    return r;
  }
};

TEST(SkillSelection, TheHighestInteractionRateWinsAndEveryCandidateSeesTheSameGoals) {
  Scripted script;
  script.hit = {{1, 0.95}, {2, 0.99}, {3, 0.97}};
  script.reached = {{1, 0.99}, {2, 0.90}, {3, 0.95}};
  SelectionOptions o;
  o.goals = 2500;
  o.chunk_goals = 1000;
  o.seed = 77;
  SkillSelection sel(2, {{100, Blob(1)}, {200, Blob(2)}, {300, Blob(3)}}, o);
  int steps = 0;
  for (;;) {
    auto done = sel.Step(std::ref(script));
    ASSERT_TRUE(done.ok());
    ++steps;
    if (*done) break;
  }
  EXPECT_EQ(steps, 9) << "three chunks (1000, 1000, 500 goals) per candidate";
  EXPECT_EQ(sel.best(), 1u);
  EXPECT_EQ(sel.scores()[1].goals, 2500u);
  EXPECT_EQ(sel.scores()[1].interacted, 990u + 990u + 495u);
  // the same three seeds, in the same order, for every candidate; no two chunks share one
  std::map<uint8_t, std::vector<uint64_t>> seeds;
  for (auto& [id, seed] : script.calls) seeds[id].push_back(seed);
  EXPECT_EQ(seeds[1], seeds[2]);
  EXPECT_EQ(seeds[1], seeds[3]);
  EXPECT_EQ(std::set<uint64_t>(seeds[1].begin(), seeds[1].end()).size(), 3u);
  EXPECT_EQ(seeds[1][0], 77u);
  EXPECT_NE(sel.Table().find("*       200 env steps"), std::string::npos) << sel.Table();
}

TEST(SkillSelection, WithoutAnInteractionSuccessRanksThenTheLaterCandidateWinsATie) {
  Scripted script;
  script.hit = {{1, 0}, {2, 0}, {3, 0}};
  script.reached = {{1, 0.80}, {2, 0.90}, {3, 0.90}};
  SelectionOptions o;
  o.goals = 100;
  o.by_interaction = false;
  SkillSelection sel(1, {{1, Blob(1)}, {2, Blob(2)}, {3, Blob(3)}}, o);
  while (!sel.done()) ASSERT_TRUE(sel.Step(std::ref(script)).ok());
  EXPECT_EQ(sel.best(), 2u);
}

TEST(SkillSelection, ACandidateThatEndsNoGoalIsDoneAndAFailureNamesTheCandidate) {
  int calls = 0;
  auto none = [&](const std::vector<uint8_t>& acting, int64_t, int64_t, uint64_t) -> Result<EvalResult> {
    ++calls;
    if (acting[0] == 9) return Errorf("env exploded");
    return EvalResult{};
  };
  SelectionOptions o;
  o.goals = 5000;
  SkillSelection sel(2, {{100, Blob(1)}, {450, Blob(9)}}, o);
  auto first = sel.Step(none);
  ASSERT_TRUE(first.ok());
  EXPECT_FALSE(*first);
  EXPECT_EQ(calls, 1) << "a chunk that ended no goal ends the candidate";
  auto failed = sel.Step(none);
  ASSERT_FALSE(failed.ok());
  EXPECT_NE(failed.status().message().find("candidate 2 of 2 (450 env steps)"), std::string::npos)
      << failed.status().message();
  EXPECT_NE(failed.status().message().find("env exploded"), std::string::npos);
}

}  // namespace
}  // namespace coins
