// Row selectors: how the sampler picks the rows of a batch, the selection half of sampling (the
// sampler then builds each sample from its row). One selector per file:
//   UniformSelector      (uniform.h)      every row held equally often
//   PrioritizedSelector  (prioritized.h)  in proportion to the rows' priorities (Priorities)
//   WeightedSelector     (weighted.h)     in proportion to the rows' sampling weights
//   LevelSelector        (level.h)        exactly uniform among the transitions of some skill
//                                         levels (LevelIndex)
//
// Contract: a selector is made per request over the shard's structures (it holds references
// and allocates nothing; the store must not change while it lives) and gives one candidate
// row per Select call:
//   kRow    *pick is a row held, with the probability this draw had of picking it
//   kMiss   no row this time (a slot outside the rows held): draw again
//   kEmpty  the selector has nothing to draw from: give up
// Candidates may be rows that are not transitions (ROW_SEGMENT_START) or rows of a level the
// request does not ask for; the sampler redraws those, unless the selector is exact (kExact:
// every row it picks is a transition of the asked levels).
//
// RowSelector is a concept, not a virtual base: the sampler's draw loop is compiled for each
// selector, so a batch costs no indirect call per row.
#pragma once

#include <concepts>
#include <cstdint>
#include <random>

#include "replay/chunk_store.h"

namespace coins {

struct Pick {
  uint32_t chunk = 0;  // index in the store (0 = oldest)
  uint32_t row = 0;    // row inside the chunk
  double prob = 0;     // probability of this row in one draw
};

enum class Selected { kRow, kMiss, kEmpty };

template <class S>
concept RowSelector = requires(const S& s, std::mt19937_64* rng, Pick* pick) {
  { s.Select(rng, pick) } -> std::same_as<Selected>;
  { S::kExact } -> std::convertible_to<bool>;
};

// the pick of global row `row`, a row the store holds (first_row() <= row < end_row())
inline void PickHeldRow(const ChunkStore& store, uint64_t row, double prob, Pick* pick) {
  const size_t c = store.ChunkOfRow(row);
  *pick = {uint32_t(c), uint32_t(row - store.chunk(c).row_base), prob};
}

}  // namespace coins
