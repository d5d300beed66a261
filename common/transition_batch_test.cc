#include "common/transition_batch.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <memory>
#include <vector>

namespace coins {
namespace {

// row r's state: feature i is r*1000+i for i < changing, the rest stay constant
std::vector<float> State(uint32_t r, uint32_t dim, uint32_t changing) {
  std::vector<float> s(dim);
  for (uint32_t i = 0; i < dim; ++i) s[i] = i < changing ? r * 1000.0f + i : -1.0f * i;
  return s;
}

std::unique_ptr<TransitionBatch> MakeBatch(uint32_t rows, uint32_t s, uint32_t a, uint32_t g, uint32_t changing = 2) {
  auto batch = std::make_unique<TransitionBatch>();
  BatchBuilder builder;
  BatchHeader h{.actor_id = 3,
                .seq = 7,
                .env_id = 1,
                .layout_hash = LayoutHash("test", s, a, g),
                .state_dim = s,
                .action_dim = a,
                .goal_dim = g,
                .episode_base = 2};
  builder.Begin(batch.get(), h, 0);
  for (uint32_t r = 0; r < rows; ++r) {
    std::vector<float> ac(a), go(g);
    for (uint32_t i = 0; i < a; ++i) ac[i] = -(r * 10.0f + i);
    for (uint32_t i = 0; i < g; ++i) go[i] = 0.5f * r + i;
    uint16_t flags = r == 0 ? msg::ROW_SEGMENT_START : (r % 5 == 0 ? msg::ROW_DONE : 0);
    EXPECT_FALSE(builder.full());
    builder.AddRow(State(r, s, changing), ac, go, r * 0.25f, flags, uint8_t(r % 3), r);
  }
  builder.Finish();
  return batch;
}

TEST(TransitionBatch, DeltaEncodingDecodesEveryRow) {
  auto b = MakeBatch(10, 6, 2, 3, 2);
  EXPECT_EQ(b->n_rows(), 10u);
  // two features change per row after the first
  EXPECT_EQ(b->delta_index().size(), 2u * 9);
  std::vector<float> states(10 * 6);
  DecodeStates(*b, states.data());
  for (uint32_t r = 0; r < 10; ++r) {
    EXPECT_EQ(std::vector<float>(states.begin() + r * 6, states.begin() + r * 6 + 6), State(r, 6, 2)) << r;
    EXPECT_EQ(b->action()[r * 2 + 1], -(r * 10.0f + 1));
    EXPECT_EQ(b->goal()[r * 3 + 2], 0.5f * r + 2);
    EXPECT_EQ(b->reward()[r], r * 0.25f);
    EXPECT_EQ(b->skill_level()[r], r % 3);
  }
  EXPECT_EQ(CountTransitions(*b), 9u);
  EXPECT_TRUE(ValidateBatch(*b, LayoutHash("test", 6, 2, 3)).ok());
}

TEST(TransitionBatch, NegativeZeroCountsAsAChange) {
  auto batch = std::make_unique<TransitionBatch>();
  BatchBuilder builder;
  builder.Begin(batch.get(), {.layout_hash = 1, .state_dim = 2, .action_dim = 1}, 0);
  float a[1] = {0}, s0[2] = {0.0f, 1.0f}, s1[2] = {-0.0f, 1.0f};
  builder.AddRow(s0, a, {}, 0, msg::ROW_SEGMENT_START, 0, 0);
  builder.AddRow(s1, a, {}, 0, 0, 0, 0);
  builder.Finish();
  std::vector<float> out(4);
  DecodeStates(*batch, out.data());
  EXPECT_TRUE(std::signbit(out[2]));
}

TEST(TransitionBatch, FullWhenRowsOrDeltaRoomRunOut) {
  // rows bound
  auto b = std::make_unique<TransitionBatch>();
  BatchBuilder builder;
  builder.Begin(b.get(), {.layout_hash = 1, .state_dim = 4, .action_dim = 1}, 100);
  std::vector<float> a(1);
  uint32_t added = 0;
  for (; !builder.full(); ++added)
    builder.AddRow(State(added, 4, 4), a, {}, 0, added == 0 ? msg::ROW_SEGMENT_START : 0, 0, 0);
  EXPECT_EQ(added, 100u);
  // delta bound: a 4000-feature state that changes whole each row fills 65536 deltas in 17 rows
  builder.Begin(b.get(), {.layout_hash = 1, .state_dim = 4000, .action_dim = 1}, 0);
  added = 0;
  for (; !builder.full(); ++added)
    builder.AddRow(State(added, 4000, 4000), a, {}, 0, added == 0 ? msg::ROW_SEGMENT_START : 0, 0, 0);
  EXPECT_EQ(added, 17u);
  builder.Finish();
  EXPECT_LE(b->delta_index().size(), COINS_BATCH_MAX_DELTAS);
  EXPECT_TRUE(ValidateBatch(*b).ok());
}

TEST(TransitionBatch, ValidationRejectsMalformedBatches) {
  auto b = MakeBatch(6, 4, 2, 0);
  uint32_t layout = LayoutHash("test", 4, 2, 0);
  ASSERT_TRUE(ValidateBatch(*b, layout).ok());
  auto expect = [&](auto mutate, const std::string& what) {
    TransitionBatch bad = *b;
    mutate(bad);
    Status s = ValidateBatch(bad);
    EXPECT_NE(s.message().find(what), std::string::npos) << "wanted '" << what << "', got '" << s.message() << "'";
    EXPECT_NE(s.message().find("actor 3 seq 7"), std::string::npos) << s.message();
  };
  expect([](TransitionBatch& x) { x.schema_version(99); }, "schema version 99");
  expect([](TransitionBatch& x) { x.n_rows(COINS_BATCH_MAX_ROWS + 1); }, "bad size");
  expect([](TransitionBatch& x) { x.state_dim(60000); }, "bad size");
  expect([](TransitionBatch& x) { x.n_rows(5); }, "column lengths");
  expect([](TransitionBatch& x) { x.action().pop_back(); }, "column lengths");
  expect([](TransitionBatch& x) { x.delta_value().pop_back(); }, "column lengths");
  expect([](TransitionBatch& x) { x.delta_index()[0] = 4; }, "delta index 4 outside the state");
  expect([](TransitionBatch& x) { x.delta_end()[2] = 0; }, "delta_end decreases");
  expect([](TransitionBatch& x) { x.delta_end()[0] = 1; }, "delta_end[0] must be 0");
  expect([](TransitionBatch& x) { x.flags()[0] = 0; }, "row 0 must start a segment");
  expect([](TransitionBatch& x) { x.first_state()[1] = std::nanf(""); }, "non-finite");
  expect([](TransitionBatch& x) { x.delta_value()[3] = INFINITY; }, "non-finite");
  expect([](TransitionBatch& x) { x.reward()[2] = -INFINITY; }, "non-finite");
  expect([](TransitionBatch& x) { x.delta_value()[1] += 1.0f; }, "payload hash mismatch");
  expect([](TransitionBatch& x) { x.interactions()[5] ^= 1; }, "payload hash mismatch");
  EXPECT_NE(ValidateBatch(*b, layout + 1).message().find("layout"), std::string::npos);
}

TEST(TransitionBatch, HashCoversEveryColumn) {
  auto a = MakeBatch(8, 3, 1, 2);
  uint64_t h = PayloadHash(*a);
  TransitionBatch b = *a;
  b.flags()[3] ^= msg::ROW_INTERACTION;
  EXPECT_NE(PayloadHash(b), h);
  b = *a;
  b.skill_level()[7] ^= 1;
  EXPECT_NE(PayloadHash(b), h);
  b = *a;
  std::swap(b.delta_value()[0], b.delta_value()[1]);
  EXPECT_NE(PayloadHash(b), h);
}

TEST(TransitionBatch, HashCoversEveryHeaderField) {
  auto a = MakeBatch(8, 3, 1, 2);
  const uint64_t h = PayloadHash(*a);
  ASSERT_EQ(h, a->payload_hash());
  const std::vector<std::function<void(TransitionBatch&)>> changes = {
      [](TransitionBatch& x) { x.schema_version(x.schema_version() + 1); },
      [](TransitionBatch& x) { x.actor_id(x.actor_id() + 1); },
      [](TransitionBatch& x) { x.incarnation(x.incarnation() ^ (uint64_t(1) << 63)); },
      [](TransitionBatch& x) { x.seq(x.seq() + 1); },
      [](TransitionBatch& x) { x.env_id(x.env_id() + 1); },
      [](TransitionBatch& x) { x.layout_hash(x.layout_hash() ^ 1); },
      [](TransitionBatch& x) { x.n_rows(x.n_rows() - 1); },
      [](TransitionBatch& x) { x.state_dim(x.state_dim() + 1); },
      [](TransitionBatch& x) { x.action_dim(x.action_dim() + 1); },
      [](TransitionBatch& x) { x.goal_dim(x.goal_dim() + 1); },
      [](TransitionBatch& x) { x.episode_base(x.episode_base() + 1); },
  };
  for (size_t i = 0; i < changes.size(); ++i) {
    TransitionBatch b = *a;
    changes[i](b);
    EXPECT_NE(PayloadHash(b), h) << "header field " << i << " is not covered";
  }
  // a sequence number changed in transit fails validation
  TransitionBatch b = *a;
  b.seq(b.seq() + 1000);
  EXPECT_NE(ValidateBatch(b).message().find("payload hash mismatch"), std::string::npos);
  // set_seq stamps the number before the hash is taken
  auto c = std::make_unique<TransitionBatch>();
  BatchBuilder builder;
  builder.Begin(c.get(), {.layout_hash = 1, .state_dim = 1, .action_dim = 1}, 0);
  float s[1] = {0}, act[1] = {0};
  builder.AddRow(s, act, {}, 0, msg::ROW_SEGMENT_START, 0, 0);
  builder.set_seq(42);
  builder.Finish();
  EXPECT_EQ(c->seq(), 42u);
  EXPECT_TRUE(ValidateBatch(*c).ok());
}

TEST(TransitionBatch, HashBytesSeesEveryWordAndChainsThroughEmptyPieces) {
  float base[24] = {0};
  for (int i = 0; i < 24; ++i) {
    float c[24] = {0};
    c[i] = 1.0f;
    EXPECT_NE(HashBytes(c, sizeof(c)), HashBytes(base, sizeof(base))) << i;
    // an empty piece chained after it must not erase it
    EXPECT_NE(HashBytes(c, 0, HashBytes(c, sizeof(c))), HashBytes(base, 0, HashBytes(base, sizeof(base)))) << i;
  }
}

TEST(TransitionBatch, HashSeesEverySeedBit) {
  // a difference in the seed reaches every lane the same way; the fold must not cancel it
  float data[64] = {0};
  for (int bit = 0; bit < 64; ++bit) {
    uint64_t seed = 0x0123456789abcdefULL;
    EXPECT_NE(HashBytes(data, sizeof(data), seed), HashBytes(data, sizeof(data), seed ^ (uint64_t(1) << bit))) << bit;
  }
  // and a single flipped bit anywhere in the data changes the hash
  uint8_t bytes[200] = {0};
  uint64_t h = HashBytes(bytes, sizeof(bytes));
  for (int i = 0; i < 200 * 8; ++i) {
    bytes[i / 8] ^= uint8_t(1 << (i % 8));
    ASSERT_NE(HashBytes(bytes, sizeof(bytes)), h) << "bit " << i;
    bytes[i / 8] ^= uint8_t(1 << (i % 8));
  }
}

TEST(TransitionBatch, LayoutHashSeparatesEnvsAndDims) {
  EXPECT_NE(LayoutHash("breakout", 515, 1, 0), LayoutHash("breakout", 515, 1, 1));
  EXPECT_NE(LayoutHash("breakout", 515, 1, 0), LayoutHash("breakout-single", 515, 1, 0));
  EXPECT_EQ(LayoutHash("pushing", 59, 3, 0), LayoutHash("pushing", 59, 3, 0));
}

}  // namespace
}  // namespace coins
