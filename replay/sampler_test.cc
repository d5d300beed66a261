#include "replay/sampler.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>

#include "replay/shard.h"
#include "replay/test_stream.h"

namespace coins {
namespace {

using testing::TestStream;

ReplayOptions Options(int64_t capacity = 100000) {
  ReplayOptions o;
  o.capacity = capacity;
  o.capacity_mb = 16;
  return o;
}

msg::SampleRequest Request(uint32_t batch, uint8_t strategy = msg::SAMPLE_UNIFORM, uint32_t n_step = 1) {
  msg::SampleRequest q;
  q.schema_version(msg::SAMPLING_SCHEMA);
  q.correlation_id(1);
  q.shard_id(-1);
  q.batch_size(batch);
  q.strategy(strategy);
  q.skill_level(-1);
  q.n_step(n_step);
  q.gamma(0.5f);
  q.timeout_ms(100);
  return q;
}

// the next state of sample i, decoded from the reply's deltas
std::vector<float> NextState(const msg::SampleReply& r, uint32_t i) {
  std::vector<float> s(r.state().begin() + i * r.state_dim(), r.state().begin() + (i + 1) * r.state_dim());
  const uint32_t begin = i ? r.next_end()[i - 1] : 0;
  ApplyDeltas(r.next_index().data() + begin, r.next_value().data() + begin, r.next_end()[i] - begin, s.data());
  return s;
}

struct Fixture {
  Shard shard{0, Options()};
  TestStream stream{1, 42};
  Fixture(int batches, uint32_t rows) {
    for (int i = 0; i < batches; ++i) EXPECT_EQ(shard.Receive(*stream.Next(rows)), Shard::Outcome::kStored);
  }
};

TEST(Sampler, UniformSamplesAreTransitionsAsInserted) {
  Fixture f(10, 64);  // 630 steps, episodes of 100
  Sampler sampler({});
  std::mt19937_64 rng(1);
  msg::SampleReply r;
  ASSERT_TRUE(sampler.Sample(f.shard.store(), f.shard.priorities(), Request(512), &r, &rng).ok());
  ASSERT_EQ(r.n(), 512u);
  std::map<float, int> seen;
  for (uint32_t i = 0; i < r.n(); ++i) {
    const float* s = &r.state()[i * 4];
    auto next = NextState(r, i);
    float t = next[0];
    EXPECT_EQ(next[0], s[0] + 1) << "sample " << i;
    EXPECT_EQ(next[3], t);
    EXPECT_EQ(r.action()[i], float(int64_t(t) % 3));
    EXPECT_EQ(r.reward()[i], 0.5f * t);
    // the step that ended an episode has no bootstrap
    EXPECT_EQ(r.discount()[i], int64_t(t) % 100 == 0 ? 0.0f : 0.5f) << "t " << t;
    EXPECT_EQ(r.weight()[i], 1.0f);
    EXPECT_EQ(r.goal()[i * 2], s[1]);
    seen[t]++;
  }
  EXPECT_GT(seen.size(), 250u);  // spread over the 630 transitions
  EXPECT_LE(seen.rbegin()->first, float(f.stream.t()));
}

TEST(Sampler, NStepReturnsCrossChunksAndStopAtEpisodeEnd) {
  Fixture f(20, 16);  // chunk boundaries every 15 steps
  Sampler sampler({});
  std::mt19937_64 rng(2);
  msg::SampleReply r;
  ASSERT_TRUE(
      sampler.Sample(f.shard.store(), f.shard.priorities(), Request(1000, msg::SAMPLE_UNIFORM, 3), &r, &rng).ok());
  int crossed = 0;
  for (uint32_t i = 0; i < r.n(); ++i) {
    int64_t t0 = int64_t(r.state()[i * 4]) + 1;  // first step of the window
    auto next = NextState(r, i);
    int64_t k = int64_t(next[0]) - t0 + 1;
    int64_t end_of_episode = (t0 + 99) / 100 * 100;
    int64_t expected_k = std::min<int64_t>({3, end_of_episode - t0 + 1, f.stream.t() - t0 + 1});
    ASSERT_EQ(k, expected_k) << "t0 " << t0;
    float reward = 0, g = 1;
    for (int64_t j = 0; j < k; ++j, g *= 0.5f) reward += g * 0.5f * float(t0 + j);
    EXPECT_FLOAT_EQ(r.reward()[i], reward);
    bool done = t0 + k - 1 == end_of_episode;
    EXPECT_FLOAT_EQ(r.discount()[i], done ? 0.0f : std::pow(0.5f, float(k)));
    if ((t0 - 1) / 15 != (t0 + k - 2) / 15) crossed++;
  }
  EXPECT_GT(crossed, 50) << "n-step windows should cross chunk boundaries";
}

TEST(Sampler, HindsightFinalAndFutureUseTheSegmentsAchievedGoals) {
  Fixture f(20, 64);
  Sampler sampler({});
  std::mt19937_64 rng(3);
  for (uint8_t strategy : {msg::HER_FINAL, msg::HER_FUTURE}) {
    msg::SampleRequest q = Request(400);
    q.her_strategy(strategy);
    q.her_ratio(1.0f);
    q.goal_mask({0.0f, 1.0f});  // features 2..3: the goal is the step counter
    q.target_offset(2);
    q.goal_epsilon(0.5f);
    q.step_reward(-1.0f);  // the paddle skill's rewards: -1 a step, 0 on success
    msg::SampleReply r;
    ASSERT_TRUE(sampler.Sample(f.shard.store(), f.shard.priorities(), q, &r, &rng).ok());
    ASSERT_EQ(r.goal_dim(), 2u);
    for (uint32_t i = 0; i < r.n(); ++i) {
      int64_t t = int64_t(r.state()[i * 4]) + 1;
      int64_t end = std::min<int64_t>((t + 99) / 100 * 100, f.stream.t());
      float goal_t = r.goal()[i * 2 + 1];
      EXPECT_EQ(r.goal()[i * 2], 0.0f);  // masked out
      if (strategy == msg::HER_FINAL)
        EXPECT_EQ(goal_t, float(end)) << "t " << t;
      else
        EXPECT_TRUE(goal_t >= float(t) && goal_t <= float(end)) << "t " << t << " goal " << goal_t;
      bool reached = float(t) == goal_t;
      EXPECT_EQ(r.reward()[i], reached ? 0.0f : -1.0f);
      EXPECT_EQ(r.discount()[i], reached || t % 100 == 0 ? 0.0f : 0.5f);
    }
  }
}

TEST(Sampler, PrioritisedFollowsPrioritiesAndWeightsCorrect) {
  Fixture f(4, 64);
  Sampler sampler({});
  std::mt19937_64 rng(4);
  msg::SampleReply r;
  ASSERT_TRUE(
      sampler.Sample(f.shard.store(), f.shard.priorities(), Request(64, msg::SAMPLE_PRIORITIZED), &r, &rng).ok());
  // every key but one gets a tiny priority
  uint64_t hot = r.key()[0];
  for (uint64_t k = f.shard.store().first_row(); k < f.shard.store().end_row(); ++k)
    f.shard.priorities().SetPriority(k, k == hot ? 1000.0 : 0.001);
  ASSERT_TRUE(
      sampler.Sample(f.shard.store(), f.shard.priorities(), Request(1000, msg::SAMPLE_PRIORITIZED), &r, &rng).ok());
  int hits = 0;
  for (uint32_t i = 0; i < r.n(); ++i) {
    if (r.key()[i] == hot) {
      hits++;
      EXPECT_LT(r.weight()[i], 0.1f);  // over-sampled: small importance weight
    } else {
      EXPECT_FLOAT_EQ(r.weight()[i], 1.0f);
    }
  }
  EXPECT_GT(hits, 900);
  // weighted: one transition with all the weight
  for (uint64_t k = f.shard.store().first_row(); k < f.shard.store().end_row(); ++k)
    f.shard.priorities().SetWeight(k, k == hot + 1 ? 1.0 : 0.0);
  ASSERT_TRUE(sampler.Sample(f.shard.store(), f.shard.priorities(), Request(100, msg::SAMPLE_WEIGHTED), &r, &rng).ok());
  for (uint32_t i = 0; i < r.n(); ++i) EXPECT_EQ(r.key()[i], hot + 1);
}

TEST(Sampler, SkillLevelFilterAndBadRequests) {
  Shard shard(0, Options());
  TestStream a(1, 1, 100, 0), b(2, 1, 100, 2);
  for (int i = 0; i < 5; ++i) {
    ASSERT_EQ(shard.Receive(*a.Next(64)), Shard::Outcome::kStored);
    ASSERT_EQ(shard.Receive(*b.Next(64)), Shard::Outcome::kStored);
  }
  Sampler sampler({});
  std::mt19937_64 rng(5);
  msg::SampleReply r;
  msg::SampleRequest q = Request(200);
  q.skill_level(2);
  ASSERT_TRUE(sampler.Sample(shard.store(), shard.priorities(), q, &r, &rng).ok());
  for (uint32_t i = 0; i < r.n(); ++i) {
    size_t c = shard.store().ChunkOfRow(r.key()[i]);
    EXPECT_EQ(shard.store().chunk(c).actor_id, 2u);
  }
  q.skill_level(7);
  EXPECT_NE(sampler.Sample(shard.store(), shard.priorities(), q, &r, &rng).message().find("skill level 7"),
            std::string::npos);
  // malformed requests name the field
  auto bad = [&](auto mutate, const char* what) {
    msg::SampleRequest x = Request(16);
    mutate(x);
    Status s = ValidateSampleRequest(x, 4);
    EXPECT_FALSE(s.ok()) << what;
    EXPECT_NE(s.message().find(what), std::string::npos) << s.message();
  };
  bad([](auto& x) { x.schema_version(99); }, "schema_version");
  bad([](auto& x) { x.batch_size(0); }, "batch_size");
  bad([](auto& x) { x.gamma(std::nanf("")); }, "gamma");
  bad([](auto& x) { x.her_strategy(msg::HER_FUTURE); }, "goal_mask");
  bad(
      [](auto& x) {
        x.goal_mask({1, 1, 1});
        x.target_offset(3);
      },
      "exceeds state_dim");
  bad([](auto& x) { x.strategy(9); }, "strategy");
}

}  // namespace
}  // namespace coins
