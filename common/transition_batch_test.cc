#include "common/transition_batch.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <vector>

namespace coins {
namespace {

// fills a batch with rows whose values encode (row, column)
std::unique_ptr<TransitionBatch> MakeBatch(uint32_t rows, uint32_t s, uint32_t a, uint32_t g) {
  auto batch = std::make_unique<TransitionBatch>();
  BatchBuilder builder;
  BatchHeader h{.actor_id = 3, .seq = 7, .env_id = 1, .layout_hash = LayoutHash("test", s, a, g),
                .state_dim = s, .action_dim = a, .goal_dim = g, .episode_base = 2};
  builder.Begin(batch.get(), h, 0);
  for (uint32_t r = 0; r < rows; ++r) {
    std::vector<float> st(s), ac(a), go(g);
    for (uint32_t i = 0; i < s; ++i) st[i] = r * 1000.0f + i;
    for (uint32_t i = 0; i < a; ++i) ac[i] = -(r * 10.0f + i);
    for (uint32_t i = 0; i < g; ++i) go[i] = 0.5f * r + i;
    uint16_t flags = r == 0 ? msg::ROW_SEGMENT_START : (r % 5 == 0 ? msg::ROW_DONE : 0);
    EXPECT_TRUE(builder.AddRow(st, ac, go, r * 0.25f, flags, uint8_t(r % 3), r));
  }
  builder.Finish();
  return batch;
}

TEST(TransitionBatch, ColumnarLayoutAfterPartialFill) {
  auto b = MakeBatch(10, 4, 2, 3);
  EXPECT_EQ(b->n_rows(), 10u);
  for (uint32_t r = 0; r < 10; ++r) {
    EXPECT_EQ(BatchState(*b, r)[3], r * 1000.0f + 3);
    EXPECT_EQ(BatchAction(*b, r)[1], -(r * 10.0f + 1));
    EXPECT_EQ(BatchGoal(*b, r)[2], 0.5f * r + 2);
    EXPECT_EQ(b->reward()[r], r * 0.25f);
    EXPECT_EQ(b->skill_level()[r], r % 3);
  }
  // the action block starts right after the 10 state rows
  EXPECT_EQ(b->values()[40], -0.0f);
  EXPECT_EQ(b->values()[41], -1.0f);
  EXPECT_EQ(CountTransitions(*b), 9u);
  EXPECT_TRUE(ValidateBatch(*b, LayoutHash("test", 4, 2, 3)).ok());
}

TEST(TransitionBatch, FullBatchRespectsBounds) {
  uint32_t s = 515, a = 1;
  uint32_t max = MaxRows(s, a, 0);
  EXPECT_EQ(max, COINS_BATCH_MAX_VALUES / 516);
  auto b = std::make_unique<TransitionBatch>();
  BatchBuilder builder;
  builder.Begin(b.get(), {.layout_hash = 1, .state_dim = s, .action_dim = a}, 100000);
  std::vector<float> st(s, 1.0f), ac(a, 2.0f);
  uint32_t added = 0;
  while (builder.AddRow(st, ac, {}, 0, added == 0 ? msg::ROW_SEGMENT_START : 0, 0, 0)) ++added;
  EXPECT_EQ(added, max);
  EXPECT_TRUE(builder.full());
  builder.Finish();
  EXPECT_TRUE(ValidateBatch(*b).ok());
}

TEST(TransitionBatch, ValidationRejectsMalformedBatches) {
  auto b = MakeBatch(6, 4, 2, 0);
  uint32_t layout = LayoutHash("test", 4, 2, 0);
  ASSERT_TRUE(ValidateBatch(*b, layout).ok());

  auto bad = std::make_unique<TransitionBatch>(*b);
  bad->schema_version(99);
  EXPECT_NE(ValidateBatch(*bad).message().find("schema version 99"), std::string::npos);

  *bad = *b;
  bad->n_rows(COINS_BATCH_MAX_ROWS + 1);
  EXPECT_NE(ValidateBatch(*bad).message().find("bad size"), std::string::npos);

  *bad = *b;
  bad->state_dim(60000);
  EXPECT_NE(ValidateBatch(*bad).message().find("bad size"), std::string::npos);

  *bad = *b;
  bad->values()[5] = std::nanf("");
  EXPECT_NE(ValidateBatch(*bad).message().find("non-finite"), std::string::npos);

  *bad = *b;
  bad->reward()[2] = INFINITY;
  EXPECT_NE(ValidateBatch(*bad).message().find("non-finite"), std::string::npos);

  *bad = *b;
  bad->values()[1] += 1.0f;
  EXPECT_NE(ValidateBatch(*bad).message().find("payload hash mismatch"), std::string::npos);

  EXPECT_NE(ValidateBatch(*b, layout + 1).message().find("layout"), std::string::npos);
}

TEST(TransitionBatch, HashDependsOnEveryUsedColumnOnly) {
  auto a = MakeBatch(8, 3, 1, 2);
  uint64_t h = PayloadHash(*a);
  auto b = std::make_unique<TransitionBatch>(*a);
  b->values()[60000] = 123.0f;  // unused tail
  EXPECT_EQ(PayloadHash(*b), h);
  b->flags()[3] ^= msg::ROW_INTERACTION;
  EXPECT_NE(PayloadHash(*b), h);
  *b = *a;
  b->interactions()[7] ^= 1;
  EXPECT_NE(PayloadHash(*b), h);
}

TEST(TransitionBatch, LayoutHashSeparatesEnvsAndDims) {
  EXPECT_NE(LayoutHash("breakout", 515, 1, 0), LayoutHash("breakout", 515, 1, 1));
  EXPECT_NE(LayoutHash("breakout", 515, 1, 0), LayoutHash("breakout-single", 515, 1, 0));
  EXPECT_EQ(LayoutHash("pushing", 59, 3, 0), LayoutHash("pushing", 59, 3, 0));
}

}  // namespace
}  // namespace coins
namespace coins { namespace {
TEST(TransitionBatch, HashBytesSeesEveryWord) {
  float a[24] = {0}, b[24] = {0};
  a[1] = 1.0f;
  b[1] = 2.0f;
  EXPECT_NE(HashBytes(a, sizeof(a)), HashBytes(b, sizeof(b)));
  for (int i = 0; i < 24; ++i) {
    float c[24] = {0};
    c[i] = 1.0f;
    // an empty piece chained after it must not erase it
    EXPECT_NE(HashBytes(c, 0, HashBytes(c, sizeof(c))), HashBytes(b, 0, HashBytes(b, sizeof(b)))) << i;
    EXPECT_NE(HashBytes(c, sizeof(c)), HashBytes(b, sizeof(b))) << i;
  }
}
} }
