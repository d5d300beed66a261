#include "actors/actor.h"

#include <gtest/gtest.h>

#include <map>

namespace coins {
namespace {

// keeps a copy of every published batch
class CapturingSink final : public BatchSink {
 public:
  msg::TransitionBatch* Acquire() override { return new msg::TransitionBatch(); }
  bool Publish(msg::TransitionBatch* b) override {
    batches.emplace_back(b);
    return true;
  }
  void Release(msg::TransitionBatch* b) override { delete b; }
  bool Flush(std::chrono::milliseconds) override { return true; }
  uint64_t retries() const override { return 0; }
  std::vector<std::unique_ptr<msg::TransitionBatch>> batches;
};

ActorOptions Options(int64_t envs, int64_t rows) {
  ActorOptions o;
  o.envs = envs;
  o.batch_rows = rows;
  return o;
}

// replays every env's recorded actions on a fresh env and checks each stored row against it
TEST(Actor, BatchesReplayExactlyOnFreshEnvs) {
  CapturingSink sink;
  auto actor = Actor::Create("breakout", Options(2, 50), 5, 42, &sink);
  ASSERT_TRUE(actor.ok()) << actor.status().message();
  (*actor)->Run(
      6000, [] { return false; }, [](const ActorCounters&) {}, std::chrono::seconds(100));
  const auto& c = (*actor)->counters();
  EXPECT_EQ(c.steps, 6000u);
  EXPECT_GT(c.episodes, 0u);

  std::map<uint32_t, std::unique_ptr<envs::Env>> replay;
  std::map<uint32_t, std::vector<float>> state;
  uint64_t transitions = 0, checksum = 0, seq = 0, done_rows = 0;
  for (const auto& b : sink.batches) {
    ASSERT_TRUE(ValidateBatch(*b, (*actor)->layout_hash()).ok());
    EXPECT_EQ(b->seq(), seq++);
    EXPECT_EQ(b->actor_id(), 5u);
    checksum += b->payload_hash();
    uint32_t dim = b->state_dim();
    auto& env = replay[b->env_id()];
    auto& s = state[b->env_id()];
    if (!env) {
      env = std::move(envs::MakeEnv("breakout").value());
      s.resize(dim);
      env->Reset(Actor::EnvSeed(42, 5, b->env_id() / COINS_MAX_LEVELS), s);
    }
    std::vector<float> states(size_t(b->n_rows()) * dim);
    DecodeStates(*b, states.data());
    for (uint32_t r = 0; r < b->n_rows(); ++r) {
      const float* row = states.data() + size_t(r) * dim;
      if (b->flags()[r] & msg::ROW_SEGMENT_START) {
        // a context row or an episode's first state: the env must be exactly there
        ASSERT_EQ(std::vector<float>(row, row + dim), s) << "batch " << b->seq() << " row " << r;
        continue;
      }
      envs::StepResult res;
      ASSERT_TRUE(env->Step({b->action().data() + size_t(r) * b->action_dim(), 1}, s, &res).ok());
      ASSERT_EQ(std::vector<float>(row, row + dim), s) << "batch " << b->seq() << " row " << r;
      EXPECT_EQ(b->reward()[r], res.reward);
      EXPECT_EQ(b->interactions()[r], res.interactions);
      EXPECT_EQ((b->flags()[r] & msg::ROW_DONE) != 0, res.done);
      ++transitions;
      if (res.done || res.truncated) {
        ++done_rows;
        env->ResetNext(s);
      }
    }
  }
  EXPECT_EQ(transitions, c.steps);
  EXPECT_EQ(transitions, c.transitions_published);
  EXPECT_EQ(checksum, c.payload_checksum);
  EXPECT_EQ(done_rows, c.episodes);
  EXPECT_EQ(sink.batches.size(), c.batches);
}

TEST(Actor, BatchesAreCompact) {
  CapturingSink sink;
  auto actor = Actor::Create("breakout", Options(1, 0), 0, 1, &sink);
  ASSERT_TRUE(actor.ok());
  (*actor)->Run(
      5000, [] { return false; }, [](const ActorCounters&) {}, std::chrono::seconds(100));
  ASSERT_GE(sink.batches.size(), 2u);
  // a Breakout step changes a handful of the 500-odd features: far fewer deltas than floats
  size_t rows = 0, deltas = 0;
  for (const auto& b : sink.batches) {
    rows += b->n_rows();
    deltas += b->delta_index().size();
  }
  double per_row = double(deltas) / double(rows);
  EXPECT_LT(per_row, 30.0) << "deltas per row";
  EXPECT_GT(per_row, 2.0) << "deltas per row";
  EXPECT_EQ(sink.batches[0]->n_rows(), COINS_BATCH_MAX_ROWS);
}

TEST(Actor, UnknownEnvIsAnError) {
  CapturingSink sink;
  auto actor = Actor::Create("brekout", Options(1, 0), 0, 1, &sink);
  ASSERT_FALSE(actor.ok());
  EXPECT_NE(actor.status().message().find("brekout"), std::string::npos);
}

}  // namespace
}  // namespace coins
