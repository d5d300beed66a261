#include "replay/shard.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <memory>

namespace coins {
namespace {

// a batch of `rows` rows whose state feature 0 counts rows from `base`
std::unique_ptr<TransitionBatch> Batch(uint32_t actor, uint64_t inc, uint64_t seq, uint32_t rows, float base) {
  auto b = std::make_unique<TransitionBatch>();
  BatchBuilder builder;
  builder.Begin(b.get(),
                {.actor_id = actor,
                 .incarnation = inc,
                 .seq = seq,
                 .layout_hash = LayoutHash("t", 3, 1, 0),
                 .state_dim = 3,
                 .action_dim = 1},
                0);
  for (uint32_t r = 0; r < rows; ++r) {
    float s[3] = {base + r, 7.0f, -1.0f * (r % 2)};
    float a[1] = {float(r % 4)};
    builder.AddRow(s, a, {}, 0.5f * r, r == 0 ? msg::ROW_SEGMENT_START : 0, 0, r & 1);
  }
  builder.Finish();
  return b;
}

ReplayOptions Small(int64_t capacity, int64_t mb = 16) {
  ReplayOptions o;
  o.capacity = capacity;
  o.capacity_mb = mb;
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
  // a repeated batch is a duplicate; a jump is held until the next number confirms it, and
  // the numbers skipped are gaps
  EXPECT_EQ(shard.Receive(*Batch(7, 99, 3, 10, 3.0f)), Shard::Outcome::kDuplicate);
  EXPECT_EQ(shard.Receive(*Batch(7, 99, 8, 10, 8.0f)), Shard::Outcome::kHeld);
  EXPECT_EQ(shard.store().transitions(), 45);
  uint32_t also = 0;
  EXPECT_EQ(shard.Receive(*Batch(7, 99, 9, 10, 9.0f), nullptr, &also), Shard::Outcome::kStored);
  EXPECT_EQ(also, 9u);
  checksum += Batch(7, 99, 8, 10, 8.0f)->payload_hash() + Batch(7, 99, 9, 10, 9.0f)->payload_hash();
  const auto& a = shard.ledger().actors().at(7);
  EXPECT_EQ(a.batches, 7u);
  EXPECT_EQ(a.transitions, 7u * 9);
  EXPECT_EQ(a.checksum, checksum);
  EXPECT_EQ(a.next_seq, 10u);
  EXPECT_EQ(shard.ledger().duplicates(), 1u);
  EXPECT_EQ(shard.ledger().gaps(), 3u);  // 5, 6 and 7 never came
  EXPECT_EQ(shard.ledger().seq_jumps(), 1u);
  EXPECT_EQ(shard.store().transitions(), 63);
  // stored in sequence order: the held batch first
  EXPECT_EQ(shard.store().chunk(shard.store().chunks() - 2).seq, 8u);
  EXPECT_EQ(shard.store().chunk(shard.store().chunks() - 1).seq, 9u);
  // a restarted actor (new incarnation) starts again from 0 without counting duplicates
  EXPECT_EQ(shard.Receive(*Batch(7, 100, 0, 10, 1.0f)), Shard::Outcome::kStored);
  EXPECT_EQ(shard.ledger().duplicates(), 1u);
}

TEST(Shard, OneBatchFarAheadDoesNotPoisonTheBatchesAfterIt) {
  Shard shard(0, Small(1 << 20));
  uint64_t checksum = 0;
  auto send = [&](uint64_t seq) {
    auto b = Batch(4, 77, seq, 10, float(seq));
    auto o = shard.Receive(*b);
    if (o == Shard::Outcome::kStored) checksum += b->payload_hash();
    return o;
  };
  for (uint64_t seq = 0; seq < 5; ++seq) ASSERT_EQ(send(seq), Shard::Outcome::kStored);
  // a forged (or buggy) copy numbered far ahead, as seen on main: every later genuine batch
  // of the actor was counted a duplicate and dropped
  std::string why;
  EXPECT_EQ(shard.Receive(*Batch(4, 77, 1'000'000'000, 10, 0.0f), &why), Shard::Outcome::kHeld);
  EXPECT_NE(why.find("jumps to 1000000000 (expected 5)"), std::string::npos) << why;
  for (uint64_t seq = 5; seq < 200; ++seq) ASSERT_EQ(send(seq), Shard::Outcome::kStored) << "seq " << seq;
  const auto& a = shard.ledger().actors().at(4);
  EXPECT_EQ(a.next_seq, 200u);
  EXPECT_EQ(a.batches, 200u);
  EXPECT_EQ(a.transitions, 200u * 9);
  EXPECT_EQ(a.checksum, checksum);
  EXPECT_EQ(a.seq_jumps, 1u);
  EXPECT_EQ(shard.ledger().duplicates(), 0u);
  EXPECT_EQ(shard.ledger().gaps(), 0u);
  EXPECT_EQ(shard.rejected(), 1u);  // the held batch, proved wrong by seq 5
  EXPECT_EQ(shard.held(), 0u);
  EXPECT_EQ(shard.StoredByActor().at(4), std::make_pair(uint64_t(200 * 9), checksum));
  // a forged new incarnation numbered 0 takes the ledger over; the genuine stream then looks
  // like a jump, which its next batch confirms: nothing genuine is lost
  EXPECT_EQ(shard.Receive(*Batch(4, 12345, 0, 10, 0.0f)), Shard::Outcome::kStored);
  EXPECT_EQ(send(200), Shard::Outcome::kHeld);
  EXPECT_EQ(send(201), Shard::Outcome::kStored);
  EXPECT_EQ(send(202), Shard::Outcome::kStored);
  EXPECT_EQ(shard.ledger().actors().at(4).next_seq, 203u);
  EXPECT_EQ(shard.ledger().actors().at(4).incarnation, 77u);
  EXPECT_EQ(shard.ledger().duplicates(), 0u);
}

TEST(Shard, ARestartedShardTakesAStreamAlreadyUnderWay) {
  // a shard without a snapshot meets an actor at seq 5000: held, then confirmed by 5001
  Shard shard(0, Small(1 << 20));
  EXPECT_EQ(shard.Receive(*Batch(2, 9, 5000, 10, 0.0f)), Shard::Outcome::kHeld);
  EXPECT_EQ(shard.Receive(*Batch(2, 9, 5001, 10, 0.0f)), Shard::Outcome::kStored);
  EXPECT_EQ(shard.Receive(*Batch(2, 9, 5002, 10, 0.0f)), Shard::Outcome::kStored);
  EXPECT_EQ(shard.ledger().actors().at(2).batches, 3u);
  EXPECT_EQ(shard.ledger().gaps(), 5000u);
  // a duplicate of the held batch is dropped, not held again
  Shard other(0, Small(1 << 20));
  EXPECT_EQ(other.Receive(*Batch(2, 9, 70, 10, 0.0f)), Shard::Outcome::kHeld);
  EXPECT_EQ(other.Receive(*Batch(2, 9, 70, 10, 0.0f)), Shard::Outcome::kDuplicate);
  EXPECT_EQ(other.held(), 1u);
}

TEST(Shard, AHeaderChangedInTransitFailsTheHash) {
  Shard shard(0, Small(4096));
  ASSERT_EQ(shard.Receive(*Batch(1, 1, 0, 10, 0)), Shard::Outcome::kStored);
  std::string why;
  auto b = Batch(1, 1, 1, 10, 0);
  b->seq(1);  // the same value: still intact
  EXPECT_EQ(shard.Receive(*b), Shard::Outcome::kStored);
  // each header field changed after the hash was taken: rejected, never stored (nor held)
  const std::vector<std::function<void(TransitionBatch&)>> changes = {
      [](TransitionBatch& x) { x.env_id(5); },      [](TransitionBatch& x) { x.episode_base(3); },
      [](TransitionBatch& x) { x.actor_id(2); },    [](TransitionBatch& x) { x.seq(1000); },
      [](TransitionBatch& x) { x.incarnation(8); },
  };
  for (size_t i = 0; i < changes.size(); ++i) {
    auto c = Batch(1, 1, 2 + i, 10, 0);
    changes[i](*c);
    why.clear();
    EXPECT_EQ(shard.Receive(*c, &why), Shard::Outcome::kRejected) << "change " << i;
    EXPECT_NE(why.find("payload hash mismatch"), std::string::npos) << why;
  }
  EXPECT_EQ(shard.held(), 0u);
  EXPECT_EQ(shard.rejected(), changes.size());
  EXPECT_EQ(shard.store().chunks(), 2u);
}

TEST(Shard, RejectsMalformedAndMismatchedBatches) {
  Shard shard(0, Small(4096));
  ASSERT_EQ(shard.Receive(*Batch(1, 1, 0, 10, 0)), Shard::Outcome::kStored);
  auto nan = Batch(1, 1, 1, 10, 0);
  nan->delta_value()[0] = std::nanf("");
  std::string why;
  EXPECT_EQ(shard.Receive(*nan, &why), Shard::Outcome::kRejected);
  EXPECT_NE(why.find("non-finite"), std::string::npos);
  auto other = std::make_unique<TransitionBatch>();
  BatchBuilder builder;
  builder.Begin(other.get(), {.actor_id = 2, .layout_hash = LayoutHash("u", 4, 1, 0), .state_dim = 4, .action_dim = 1},
                0);
  float s[4] = {0, 0, 0, 0}, a[1] = {0};
  builder.AddRow(s, a, {}, 0, msg::ROW_SEGMENT_START, 0, 0);
  builder.Finish();
  EXPECT_EQ(shard.Receive(*other, &why), Shard::Outcome::kRejected);
  EXPECT_NE(why.find("layout"), std::string::npos);
  // a payload that does not match its hash is not kept
  auto flipped = Batch(1, 1, 2, 10, 0);
  flipped->action()[7] += 1.0f;
  EXPECT_EQ(shard.Receive(*flipped, &why), Shard::Outcome::kRejected);
  EXPECT_NE(why.find("payload hash mismatch"), std::string::npos);
  EXPECT_EQ(shard.rejected(), 3u);
  EXPECT_EQ(shard.store().transitions(), 9);
  EXPECT_EQ(shard.store().chunks(), 1u);
}

TEST(Shard, ChunksDecodeToWhatWasSent) {
  Shard shard(0, Small(100000));
  for (uint64_t seq = 0; seq < 3; ++seq)
    ASSERT_EQ(shard.Receive(*Batch(1, 1, seq, 50, 100.0f * seq)), Shard::Outcome::kStored);
  ASSERT_EQ(shard.store().chunks(), 3u);
  std::vector<float> states(50 * 3);
  shard.store().DecodeStates(2, states.data());
  for (uint32_t r = 0; r < 50; ++r) {
    EXPECT_EQ(states[r * 3 + 0], 200.0f + r);
    EXPECT_EQ(states[r * 3 + 1], 7.0f);
    EXPECT_EQ(states[r * 3 + 2], -1.0f * (r % 2));
    EXPECT_EQ(shard.store().rewards(2)[r], 0.5f * r);
    EXPECT_EQ(shard.store().actions(2)[r], float(r % 4));
  }
  EXPECT_EQ(shard.store().flags(2)[0], msg::ROW_SEGMENT_START);
}

TEST(Shard, EvictsOldestByTransitionsAndKeepsChecksums) {
  // room for 2000 transitions, batches of 1000 rows (999 transitions): the third evicts the first
  Shard shard(0, Small(2000));
  for (uint64_t seq = 0; seq < 3; ++seq)
    ASSERT_EQ(shard.Receive(*Batch(1, 1, seq, 1000, float(seq))), Shard::Outcome::kStored);
  EXPECT_EQ(shard.store().chunks(), 2u);
  EXPECT_EQ(shard.store().transitions(), 2 * 999);
  EXPECT_EQ(shard.store().chunk(0).seq, 1u);
  uint64_t expected = 0;
  for (uint64_t seq = 0; seq < 3; ++seq) expected += Batch(1, 1, seq, 1000, float(seq))->payload_hash();
  EXPECT_EQ(shard.ledger().actors().at(1).checksum, expected);
}

TEST(Shard, ArenaRingWrapsAndEvictsOnlyWhatItOverwrites) {
  // a 16 MiB arena holds a few hundred small chunks: push many laps through it
  Shard shard(0, Small(int64_t(1) << 30, 16));
  std::vector<float> states(64 * 3);
  for (uint64_t seq = 0; seq < 20000; ++seq) {
    ASSERT_EQ(shard.Receive(*Batch(1, 1, seq, 64, float(seq))), Shard::Outcome::kStored);
    // the newest and the oldest chunk held decode to what was sent
    const auto& store = shard.store();
    if (seq % 997 == 0 || seq == 19999) {
      for (size_t i : {size_t(0), store.chunks() - 1}) {
        store.DecodeStates(i, states.data());
        EXPECT_EQ(states[5 * 3], float(store.chunk(i).seq) + 5) << "seq " << seq << " chunk " << i;
      }
      EXPECT_EQ(store.chunk(store.chunks() - 1).seq, seq);
      // chunks are consecutive: nothing in the middle was overwritten
      for (size_t i = 1; i < store.chunks(); ++i) ASSERT_EQ(store.chunk(i).seq, store.chunk(i - 1).seq + 1);
    }
  }
  EXPECT_GT(shard.store().chunks(), 100u);
  EXPECT_LE(shard.store().bytes_used(), int64_t(16) << 20);
}

}  // namespace
}  // namespace coins
