// The sampler's request fields of SAMPLING_SCHEMA 3 on hand-written rows with hand-worked
// numbers: feature subsets, level masks, goal-conditioned n-step rewards, hindsight goals from
// the masked next state, ROW_GOAL_END, and the per-row columns (provenance, flags, ...).
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <set>

#include "replay/sampler.h"
#include "replay/shard.h"
#include "replay/test_rows.h"

// rows are written with designated initializers that leave the other fields at their defaults
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"

namespace coins {
namespace {

using testing::MakeBatch;
using testing::TestLayout;
using testing::TestRow;

ReplayOptions Options() {
  ReplayOptions o;
  o.capacity = 10000;
  o.capacity_mb = 16;
  return o;
}

msg::SampleRequest Request(uint32_t batch, uint32_t n_step = 1) {
  msg::SampleRequest q;
  q.schema_version(msg::SAMPLING_SCHEMA);
  q.correlation_id(1);
  q.shard_id(-1);
  q.batch_size(batch);
  q.strategy(msg::SAMPLE_UNIFORM);
  q.skill_level(-1);
  q.n_step(n_step);
  q.gamma(0.5f);
  q.timeout_ms(100);
  return q;
}

// sample i's columns as the reply carries them, next_state decoded from its deltas
struct Got {
  std::vector<float> state, next, goal;
  std::vector<std::pair<uint16_t, float>> deltas;
  float reward, discount;
};
Got Column(const msg::SampleReply& r, uint32_t i) {
  const uint32_t F = r.feature_dim(), G = r.goal_dim();
  Got g;
  g.state.assign(r.state().begin() + i * F, r.state().begin() + (i + 1) * F);
  g.next = g.state;
  const uint32_t begin = i ? r.next_end()[i - 1] : 0, end = r.next_end()[i];
  ApplyDeltas(r.next_index().data() + begin, r.next_value().data() + begin, end - begin, g.next.data());
  for (uint32_t k = begin; k < end; ++k) g.deltas.push_back({r.next_index()[k], r.next_value()[k]});
  g.goal.assign(r.goal().begin() + i * G, r.goal().begin() + (i + 1) * G);
  g.reward = r.reward()[i];
  g.discount = r.discount()[i];
  return g;
}

struct Fixture {
  Shard shard{0, Options()};
  Sampler sampler{{}};
  std::mt19937_64 rng{7};
  msg::SampleReply reply;
  void Add(std::unique_ptr<TransitionBatch> b) { ASSERT_EQ(shard.Receive(*b), Shard::Outcome::kStored); }
  Status Sample(const msg::SampleRequest& q) {
    return sampler.Sample(shard.store(), shard.priorities(), q, &reply, &rng);
  }
  // samples a batch and returns the columns of one sample per key seen
  std::map<uint64_t, Got> ByKey(const msg::SampleRequest& q) {
    Status s = Sample(q);
    EXPECT_TRUE(s.ok()) << s.message();
    std::map<uint64_t, Got> out;
    for (uint32_t i = 0; s.ok() && i < reply.n(); ++i) out[reply.key()[i]] = Column(reply, i);
    return out;
  }
};

TEST(SamplerFields, FeatureSubsetInRequestedOrderWithDeltasOverFeatureColumns) {
  Fixture f;
  const TestLayout layout{6, 0};
  f.Add(MakeBatch(layout, 1, 0,
                  {{.state = {0, 10, 20, 30, 40, 50}, .flags = msg::ROW_SEGMENT_START},
                   {.state = {1, 10, 21, 30, 40, 50}, .reward = 1},
                   {.state = {2, 11, 21, 30, 40, 55}, .reward = 2},
                   {.state = {3, 11, 21, 30, 40, 55}, .flags = msg::ROW_DONE, .reward = 4}}));
  msg::SampleRequest q = Request(200);
  q.features({5, 0, 2});
  auto one = f.ByKey(q);
  EXPECT_EQ(f.reply.feature_dim(), 3u);
  EXPECT_EQ(f.reply.state_dim(), 6u);
  ASSERT_EQ(one.size(), 3u);  // keys 1..3; row 0 starts the segment
  using D = std::vector<std::pair<uint16_t, float>>;
  EXPECT_EQ(one[1].state, (std::vector<float>{50, 0, 20}));
  EXPECT_EQ(one[1].deltas, (D{{1, 1}, {2, 21}}));
  EXPECT_EQ(one[2].state, (std::vector<float>{50, 1, 21}));
  EXPECT_EQ(one[2].deltas, (D{{0, 55}, {1, 2}}));
  EXPECT_EQ(one[3].state, (std::vector<float>{55, 2, 21}));
  EXPECT_EQ(one[3].deltas, (D{{1, 3}}));
  EXPECT_EQ(one[1].reward, 1.0f);
  EXPECT_EQ(one[1].discount, 0.5f);
  EXPECT_EQ(one[3].discount, 0.0f);  // ROW_DONE

  // two steps: the deltas span both, the return sums them
  q.n_step(2);
  auto two = f.ByKey(q);
  EXPECT_EQ(two[1].deltas, (D{{0, 55}, {1, 2}, {2, 21}}));
  EXPECT_EQ(two[1].next, (std::vector<float>{55, 2, 21}));
  EXPECT_FLOAT_EQ(two[1].reward, 1 + 0.5f * 2);
  EXPECT_FLOAT_EQ(two[1].discount, 0.25f);
  EXPECT_EQ(two[2].next, (std::vector<float>{55, 3, 21}));
  EXPECT_FLOAT_EQ(two[2].reward, 2 + 0.5f * 4);
  EXPECT_EQ(two[2].discount, 0.0f);
}

TEST(SamplerFields, LevelMaskOverridesSkillLevel) {
  Fixture f;
  const TestLayout layout{1, 0};
  std::vector<TestRow> rows{{.state = {0}, .flags = msg::ROW_SEGMENT_START, .level = 0}};
  const uint8_t levels[] = {0, 1, 2, 3, 1, 2, 3, 0};
  for (int r = 0; r < 8; ++r) rows.push_back({.state = {float(r + 1)}, .level = levels[r]});
  f.Add(MakeBatch(layout, 1, 0, rows));
  msg::SampleRequest q = Request(300);
  q.skill_level(0);
  q.level_mask(0b1010);  // levels 1 and 3
  ASSERT_TRUE(f.Sample(q).ok());
  std::set<int> seen;
  for (uint32_t i = 0; i < f.reply.n(); ++i) {
    int level = f.reply.skill_level()[i];
    EXPECT_TRUE(level == 1 || level == 3) << level;
    EXPECT_EQ(level, levels[f.reply.key()[i] - 1]);
    seen.insert(level);
  }
  EXPECT_EQ(seen.size(), 2u);
  q.level_mask(1u << 5);
  Status s = f.Sample(q);
  EXPECT_NE(s.message().find("level_mask 0x20"), std::string::npos) << s.message();
}

// a chain's new skill level is rare among a shard's rows: a prioritised request for it draws
// among its rows alone (it used to redraw among all rows and give up)
TEST(SamplerFields, PrioritisedRequestForARareLevelDrawsOnlyItsRows) {
  Fixture f;
  for (uint64_t seq = 0; seq < 5; ++seq) f.Add(testing::MakeRun(seq, 1, 200, float(1000 * seq)));
  f.Add(testing::MakeRun(5, 2, 3, 9000));  // 3 transitions of level 2 among 1,003
  msg::SampleRequest q = Request(256);
  q.strategy(msg::SAMPLE_PRIORITIZED);
  q.level_mask(1u << 2);
  Status s = f.Sample(q);
  ASSERT_TRUE(s.ok()) << s.message();
  std::set<uint64_t> keys;
  for (uint32_t i = 0; i < f.reply.n(); ++i) {
    ASSERT_EQ(f.reply.skill_level()[i], 2);
    keys.insert(f.reply.key()[i]);
  }
  ASSERT_EQ(keys.size(), 3u) << "new rows share the largest priority";
  // one of the three far above the others: drawn (almost) alone
  const uint64_t hot = *keys.begin();
  for (uint64_t k : keys) f.shard.priorities().SetPriority(k, k == hot ? 100.0 : 0.01);
  s = f.Sample(q);
  ASSERT_TRUE(s.ok()) << s.message();
  int hits = 0;
  for (uint32_t i = 0; i < f.reply.n(); ++i) {
    ASSERT_TRUE(keys.count(f.reply.key()[i])) << f.reply.key()[i];
    hits += f.reply.key()[i] == hot;
  }
  EXPECT_GT(hits, 230);
  q.level_mask(1u << 3);
  EXPECT_NE(f.Sample(q).message().find("no transitions of level_mask 0x8"), std::string::npos);
}

TEST(SamplerFields, RowColumnsAndPolicyVersionFromProvenance) {
  Fixture f;
  const TestLayout layout{1, 0};
  auto rows = [](float base) {
    return std::vector<TestRow>{{.state = {base}, .flags = msg::ROW_SEGMENT_START, .level = 0},
                                {.state = {base + 1}, .level = 0, .interactions = 5},
                                {.state = {base + 2}, .flags = msg::ROW_INTERACTION, .level = 1, .interactions = 2},
                                {.state = {base + 3}, .flags = msg::ROW_TRUNCATED, .level = 2}};
  };
  f.Add(MakeBatch(layout, 1, 0, rows(0), {7, 9}, 3));
  f.Add(MakeBatch(layout, 1, 1, rows(3), {8, 10}, 4));
  ASSERT_TRUE(f.Sample(Request(400)).ok());
  // keys 0..3 are the first batch's rows, 4..7 the second's
  const std::map<uint64_t, std::tuple<uint64_t, uint16_t, uint32_t, int>> expected{
      {1, {0, 0, 5, 0}}, {2, {7, msg::ROW_INTERACTION, 2, 1}}, {3, {9, msg::ROW_TRUNCATED, 0, 2}},
      {5, {0, 0, 5, 0}}, {6, {8, msg::ROW_INTERACTION, 2, 1}}, {7, {10, msg::ROW_TRUNCATED, 0, 2}}};
  std::set<uint64_t> seen;
  for (uint32_t i = 0; i < f.reply.n(); ++i) {
    auto it = expected.find(f.reply.key()[i]);
    ASSERT_NE(it, expected.end()) << "key " << f.reply.key()[i];
    auto [version, flags, interactions, level] = it->second;
    EXPECT_EQ(f.reply.policy_version()[i], version) << "key " << it->first;
    EXPECT_EQ(f.reply.flags()[i], flags);
    EXPECT_EQ(f.reply.interactions()[i], interactions);
    EXPECT_EQ(f.reply.skill_level()[i], level);
    seen.insert(it->first);
  }
  EXPECT_EQ(seen.size(), expected.size());
}

// state [x, tx, ty, tz, w], target factor (tx, ty, tz) at offset 1, stored goals [5, 7, 99];
// the request's mask covers (tx, ty): the first 2 floats of the stored goal
struct GoalRows : Fixture {
  GoalRows() {
    const TestLayout layout{5, 3};
    const std::vector<float> g{5, 7, 99};
    Add(MakeBatch(layout, 1, 0,
                  {{.state = {0, 0, 0, 0, 0}, .flags = msg::ROW_SEGMENT_START, .goal = g},
                   {.state = {1, 1, 0, 0, 0}, .goal = g},
                   {.state = {2, 2, 3, 0, 0}, .flags = msg::ROW_INTERACTION, .goal = g},
                   {.state = {3, 5, 7, 0, 0}, .goal = g},
                   {.state = {4, 5.2f, 7.2f, 0, 0}, .goal = g},
                   {.state = {5, 6, 6, 0, 0}, .flags = msg::ROW_DONE, .goal = g}}));
  }
  static msg::SampleRequest Goal(uint32_t n_step, std::vector<float> mask = {1, 1}) {
    msg::SampleRequest q = Request(400, n_step);
    q.goal_mask(mask);
    q.target_offset(1);
    q.goal_epsilon(0.3f);
    q.goal_norm(msg::GOAL_NORM_LINF);
    q.step_reward(-1);
    q.success_reward(10);
    q.interaction_reward(-0.5f);
    return q;
  }
};

TEST(SamplerFields, GoalConditionedNStepRewards) {
  GoalRows f;
  // success at row 3 ends the window: -1 (row 1), -0.5 (row 2, interaction), 10 (row 3)
  auto a = f.ByKey(GoalRows::Goal(3));
  ASSERT_EQ(a.size(), 5u);
  EXPECT_EQ(a[1].goal, (std::vector<float>{5, 7}));
  EXPECT_FLOAT_EQ(a[1].reward, -1 + 0.5f * -0.5f + 0.25f * 10);
  EXPECT_EQ(a[1].discount, 0.0f);
  EXPECT_EQ(a[1].next[1], 5.0f);  // the window stopped at row 3
  EXPECT_FLOAT_EQ(a[2].reward, -0.5f + 0.5f * 10);
  EXPECT_EQ(a[3].reward, 10.0f);
  EXPECT_EQ(a[4].reward, 10.0f);  // Linf 0.2 <= 0.3
  EXPECT_EQ(a[4].discount, 0.0f);
  EXPECT_EQ(a[5].reward, -1.0f);  // ROW_DONE, goal missed: terminal, step reward
  EXPECT_EQ(a[5].discount, 0.0f);

  // success needs an interaction: rows 3 and 4 reach the goal without one
  msg::SampleRequest q = GoalRows::Goal(3);
  q.require_interaction(true);
  auto b = f.ByKey(q);
  EXPECT_FLOAT_EQ(b[1].reward, -1 + 0.5f * -0.5f + 0.25f * -1);
  EXPECT_FLOAT_EQ(b[1].discount, 0.125f);
  EXPECT_FLOAT_EQ(b[2].reward, -0.5f + 0.5f * -1 + 0.25f * -1);
  EXPECT_FLOAT_EQ(b[2].discount, 0.125f);
  EXPECT_FLOAT_EQ(b[3].reward, -1 + 0.5f * -1 + 0.25f * -1);
  EXPECT_EQ(b[3].discount, 0.0f);  // row 5 is ROW_DONE
  EXPECT_FLOAT_EQ(b[4].reward, -1 + 0.5f * -1);
  EXPECT_EQ(b[4].discount, 0.0f);

  // the episode's end without success costs episode_end_reward on top (a ball let drop)
  q.episode_end_reward(-3);
  auto dropped = f.ByKey(q);
  EXPECT_FLOAT_EQ(dropped[3].reward, -1 + 0.5f * -1 + 0.25f * (-1 - 3));
  EXPECT_FLOAT_EQ(dropped[5].reward, -1 - 3);
  EXPECT_FLOAT_EQ(dropped[1].reward, b[1].reward);  // its window ends before the episode does

  // an interaction ends the window
  q = GoalRows::Goal(3);
  q.terminate_on_interaction(true);
  auto c = f.ByKey(q);
  EXPECT_FLOAT_EQ(c[1].reward, -1 + 0.5f * -0.5f);
  EXPECT_EQ(c[1].discount, 0.0f);
  EXPECT_EQ(c[2].reward, -0.5f);
  EXPECT_EQ(c[2].discount, 0.0f);

  // L1: row 4 is 0.4 away, beyond 0.3
  q = GoalRows::Goal(1);
  q.goal_norm(msg::GOAL_NORM_L1);
  auto d = f.ByKey(q);
  EXPECT_EQ(d[4].reward, -1.0f);
  EXPECT_EQ(d[4].discount, 0.5f);
  EXPECT_EQ(d[3].reward, 10.0f);
}

TEST(SamplerFields, StoredGoalsAreMaskedAndHindsightGoalsComeFromTheMaskedNextState) {
  GoalRows f;
  // not relabelled: the stored goal's first 2 floats times the mask
  auto stored = f.ByKey(GoalRows::Goal(1, {1, 0}));
  for (auto& [key, g] : stored) EXPECT_EQ(g.goal, (std::vector<float>{5, 0})) << key;

  // final: the segment ends at row 5 (ROW_DONE), target (6, 6)
  msg::SampleRequest q = GoalRows::Goal(1, {1, 0});
  q.her_strategy(msg::HER_FINAL);
  q.her_ratio(1);
  auto fin = f.ByKey(q);
  ASSERT_EQ(fin.size(), 5u);
  for (auto& [key, g] : fin) EXPECT_EQ(g.goal, (std::vector<float>{6, 0})) << key;
  EXPECT_EQ(fin[5].reward, 10.0f);  // reached at its own next state
  EXPECT_EQ(fin[5].discount, 0.0f);
  msg::SampleRequest charged = q;
  charged.episode_end_reward(-3);
  EXPECT_EQ(f.ByKey(charged)[5].reward, 10.0f);  // reached at the episode's end: no drop
  EXPECT_EQ(fin[1].reward, -1.0f);
  EXPECT_EQ(fin[1].discount, 0.5f);
  EXPECT_EQ(fin[2].reward, -0.5f);  // interaction, not reached
  q.goal_mask({0, 1});
  auto fin_y = f.ByKey(q);
  for (auto& [key, g] : fin_y) EXPECT_EQ(g.goal, (std::vector<float>{0, 6})) << key;
  EXPECT_EQ(fin_y[4].reward, -1.0f);  // 7.2 vs 6

  // future: the masked target at the next state of a row from the sampled one on
  const float tx[] = {0, 1, 2, 5, 5.2f, 6};
  q = GoalRows::Goal(1, {1, 0});
  q.her_strategy(msg::HER_FUTURE);
  q.her_ratio(1);
  ASSERT_TRUE(f.Sample(q).ok());
  std::set<float> goals;
  for (uint32_t i = 0; i < f.reply.n(); ++i) {
    Got g = Column(f.reply, i);
    uint64_t key = f.reply.key()[i];
    std::set<float> allowed(tx + key, tx + 6);
    EXPECT_TRUE(allowed.count(g.goal[0])) << "key " << key << " goal " << g.goal[0];
    EXPECT_EQ(g.goal[1], 0.0f);
    bool reached = std::abs(tx[key] - g.goal[0]) <= 0.3f;
    EXPECT_EQ(g.reward, reached ? 10.0f : key == 2 ? -0.5f : -1.0f) << "key " << key;
    goals.insert(g.goal[0]);
  }
  EXPECT_GE(goals.size(), 5u);
}

TEST(SamplerFields, GoalEndEndsSegmentsWithoutTerminating) {
  Fixture f;
  const TestLayout layout{1, 1};
  std::vector<TestRow> rows{{.state = {0}, .flags = msg::ROW_SEGMENT_START}};
  for (int r = 1; r <= 5; ++r)
    rows.push_back({.state = {float(r)}, .flags = uint16_t(r == 3 ? msg::ROW_GOAL_END : 0), .reward = 1});
  f.Add(MakeBatch(layout, 1, 0, rows));
  auto plain = f.ByKey(Request(300, 3));
  ASSERT_EQ(plain.size(), 5u);
  EXPECT_FLOAT_EQ(plain[1].reward, 1.75f);
  EXPECT_FLOAT_EQ(plain[1].discount, 0.125f);
  EXPECT_FLOAT_EQ(plain[2].reward, 1.5f);  // rows 2 and 3, then the goal ended
  EXPECT_FLOAT_EQ(plain[2].discount, 0.25f);
  EXPECT_EQ(plain[2].next, (std::vector<float>{3}));
  EXPECT_FLOAT_EQ(plain[3].discount, 0.5f);
  EXPECT_EQ(plain[4].next, (std::vector<float>{5}));  // end of data

  msg::SampleRequest q = Request(300);
  q.goal_mask({1});
  q.her_strategy(msg::HER_FINAL);
  q.her_ratio(1);
  auto her = f.ByKey(q);
  for (uint64_t key : {1, 2, 3}) EXPECT_EQ(her[key].goal[0], 3.0f) << key;
  for (uint64_t key : {4, 5}) EXPECT_EQ(her[key].goal[0], 5.0f) << key;
}

TEST(SamplerFields, StoreWithoutGoalsRelabelsEverySampleAndShortGoalsAreRefused) {
  Fixture f;
  f.Add(MakeBatch({3, 0}, 1, 0,
                  {{.state = {0, 0, 0}, .flags = msg::ROW_SEGMENT_START}, {.state = {1, 0, 0}}, {.state = {2, 0, 0}}}));
  msg::SampleRequest q = Request(100);
  q.goal_mask({1});
  auto got = f.ByKey(q);  // HER_NONE: the segment's final goal
  for (auto& [key, g] : got) EXPECT_EQ(g.goal, (std::vector<float>{2})) << key;

  GoalRows short_goals;
  Status s = short_goals.Sample(GoalRows::Goal(1, {1, 1, 1, 1}));
  EXPECT_NE(s.message().find("goal_mask of 4 is longer than the stored goals (3 floats)"), std::string::npos)
      << s.message();
}

TEST(SamplerFields, ValidateNamesEachNewField) {
  auto bad = [](auto mutate, const char* what) {
    msg::SampleRequest x = Request(16);
    mutate(x);
    Status s = ValidateSampleRequest(x, 2000);
    EXPECT_FALSE(s.ok()) << what;
    EXPECT_NE(s.message().find(what), std::string::npos) << s.message();
  };
  bad([](auto& x) { x.features({3, 2000}); }, "features[1] = 2000 outside the state");
  bad([](auto& x) { x.level_mask(1u << 8); }, "level_mask");
  bad([](auto& x) { x.goal_norm(7); }, "goal_norm");
  bad([](auto& x) { x.step_reward(std::nanf("")); }, "step_reward");
  bad([](auto& x) { x.success_reward(INFINITY); }, "success_reward");
  bad([](auto& x) { x.interaction_reward(-INFINITY); }, "interaction_reward");
  bad([](auto& x) { x.episode_end_reward(NAN); }, "episode_end_reward");
  bad([](auto& x) { x.batch_size(4096); }, "feature_dim 2000 exceeds the reply bound");
  bad([](auto& x) { x.features(std::vector<uint16_t>(COINS_SAMPLE_MAX_MASK + 1, 0)); }, "features exceed");
  // a feature subset keeps a large batch within the bound
  msg::SampleRequest ok = Request(4096);
  ok.features({1, 2, 3});
  EXPECT_TRUE(ValidateSampleRequest(ok, 2000).ok());
}

}  // namespace
}  // namespace coins
