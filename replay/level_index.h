// LevelIndex: where each skill level's transitions are in a shard, so that a request for some
// levels (SampleRequest.level_mask) draws uniformly among exactly those rows instead of
// redrawing until one fits: a task's decisions can be one row in a hundred.
//
// Per level, a Fenwick tree over chunk slots (chunk id mod slots) counts the chunk's transition
// rows of that level (rows without ROW_SEGMENT_START). Trees are made on first use, 4 bytes a
// slot. Draw picks the k-th such row in slot order, k uniform. Not thread-safe: the shard's lock.
#pragma once

#include <cstdint>
#include <random>
#include <vector>

#include "replay/chunk_store.h"

namespace coins {

class LevelIndex {
 public:
  static constexpr int kLevels = 8;
  LevelIndex() = default;

  // chunk `index` of the store arrived / is about to leave
  void OnInsert(const ChunkStore& store, size_t index);
  void OnEvict(const ChunkStore& store, size_t index);
  // transitions held of the levels in the mask (bit L: level L)
  uint64_t Count(uint32_t level_mask) const;
  // a uniformly drawn transition of the mask's levels: chunk index and row; false when none
  bool Draw(const ChunkStore& store, uint32_t level_mask, std::mt19937_64* rng, size_t* chunk, uint32_t* row) const;

 private:
  struct Tree {
    std::vector<uint32_t> fenwick;  // 1-based
    uint64_t total = 0;
  };
  void Add(int level, size_t slot, int64_t delta);
  void Update(const ChunkStore& store, size_t index, int sign);
  // slot holding the k-th (0-based) counted row of level; k becomes the rank inside the slot
  size_t FindSlot(int level, uint64_t* k) const;

  size_t slots_ = 0;
  size_t top_bit_ = 0;
  std::vector<Tree> trees_ = std::vector<Tree>(kLevels);
};

}  // namespace coins
