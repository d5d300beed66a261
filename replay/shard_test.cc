#include "replay/shard.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>

namespace coins {
namespace {

std::unique_ptr<TransitionBatch> Batch(uint32_t actor, uint64_t inc, uint64_t seq, uint32_t rows, float base) {
  auto b = std::make_unique<TransitionBatch>();
  BatchBuilder builder;
  builder.Begin(b.get(), {.actor_id = actor, .incarnation = inc, .seq = seq, .layout_hash = LayoutHash("t", 3, 1, 0),
                          .state_dim = 3, .action_dim = 1}, 0);
  for (uint32_t r = 0; r < rows; ++r) {
    float s[3] = {base + r, base * 2 + r, -1.0f * r};
    float a[1] = {float(r % 4)};
    builder.AddRow(s, a, {}, 0.5f * r, r == 0 ? msg::ROW_SEGMENT_START : 0, 0, r & 1);
  }
  builder.Finish();
  b->seq(seq);
  return b;
}

ReplayOptions Small(int64_t capacity) {
  ReplayOptions o;
  o.capacity = capacity;
  return o;
}

TEST(Shard, StoresOnceAndKeepsLedger) {
  Shard shard(0, Small(4096));
  uint64_t checksum = 0;
  for (uint64_t seq = 0; seq < 5; ++seq) {
    auto b = Batch(7, 99, seq, 10, float(seq));
    checksum += b->payload_hash();
    EXPECT_EQ(shard.Receive(*b), Shard::Outcome::kStored);
  }
  // a repeated batch is a duplicate; a jump is a gap
  EXPECT_EQ(shard.Receive(*Batch(7, 99, 3, 10, 3.0f)), Shard::Outcome::kDuplicate);
  EXPECT_EQ(shard.Receive(*Batch(7, 99, 8, 10, 8.0f)), Shard::Outcome::kStored);
  checksum += Batch(7, 99, 8, 10, 8.0f)->payload_hash();
  const auto& a = shard.ledger().actors().at(7);
  EXPECT_EQ(a.batches, 6u);
  EXPECT_EQ(a.transitions, 6u * 9);
  EXPECT_EQ(a.checksum, checksum);
  EXPECT_EQ(shard.ledger().duplicates(), 1u);
  EXPECT_EQ(shard.ledger().gaps(), 3u);  // 5, 6 and 7 never came
  EXPECT_EQ(shard.store().transitions(), 54);
  // a restarted actor (new incarnation) starts again from 0 without counting duplicates
  EXPECT_EQ(shard.Receive(*Batch(7, 100, 0, 10, 1.0f)), Shard::Outcome::kStored);
  EXPECT_EQ(shard.ledger().duplicates(), 1u);
}

TEST(Shard, RejectsMalformedAndMismatchedBatches) {
  Shard shard(0, Small(4096));
  ASSERT_EQ(shard.Receive(*Batch(1, 1, 0, 10, 0)), Shard::Outcome::kStored);
  auto nan = Batch(1, 1, 1, 10, 0);
  nan->values()[4] = std::nanf("");
  std::string why;
  EXPECT_EQ(shard.Receive(*nan, &why), Shard::Outcome::kRejected);
  EXPECT_NE(why.find("non-finite"), std::string::npos);
  auto other = std::make_unique<TransitionBatch>();
  BatchBuilder builder;
  builder.Begin(other.get(), {.actor_id = 2, .layout_hash = LayoutHash("u", 4, 1, 0), .state_dim = 4, .action_dim = 1}, 0);
  float s[4] = {0, 0, 0, 0}, a[1] = {0};
  builder.AddRow(s, a, {}, 0, msg::ROW_SEGMENT_START, 0, 0);
  builder.Finish();
  EXPECT_EQ(shard.Receive(*other, &why), Shard::Outcome::kRejected);
  EXPECT_NE(why.find("layout"), std::string::npos);
  EXPECT_EQ(shard.rejected(), 2u);
  EXPECT_EQ(shard.store().transitions(), 9);
}

TEST(Shard, RingEvictsOldestAndStoredCopyMatches) {
  // capacity 2048 rows, batches of 1000 rows: the third batch wraps early and evicts the first
  Shard shard(0, Small(2048));
  for (uint64_t seq = 0; seq < 3; ++seq) ASSERT_EQ(shard.Receive(*Batch(1, 1, seq, 1000, float(seq))), Shard::Outcome::kStored);
  EXPECT_EQ(shard.store().rows(), 2000);
  EXPECT_EQ(shard.store().transitions(), 2 * 999);
  // rows 0..999 now hold batch 2
  EXPECT_EQ(shard.store().state(5)[0], 2.0f + 5);
  EXPECT_EQ(shard.store().state(1005)[0], 1.0f + 5);
  uint64_t expected = 0;
  for (uint64_t seq = 0; seq < 3; ++seq) expected += Batch(1, 1, seq, 1000, float(seq))->payload_hash();
  EXPECT_EQ(shard.ledger().actors().at(1).checksum, expected);
}

}  // namespace
}  // namespace coins
