#include "replay/level_index.h"

#include "idl/transition.h"

namespace coins {

void LevelIndex::Add(int level, size_t slot, int64_t delta) {
  Tree& t = trees_[size_t(level)];
  if (t.fenwick.empty()) {
    t.fenwick.assign(slots_ + 1, 0);
    top_bit_ = 1;
    while (top_bit_ * 2 <= slots_) top_bit_ *= 2;
  }
  for (size_t i = slot + 1; i <= slots_; i += i & (~i + 1)) t.fenwick[i] = uint32_t(int64_t(t.fenwick[i]) + delta);
  t.total = uint64_t(int64_t(t.total) + delta);
}

void LevelIndex::Update(const ChunkStore& store, size_t index, int sign) {
  if (slots_ == 0) slots_ = store.chunk_slots();
  const ChunkInfo& c = store.chunk(index);
  const uint8_t* levels = store.skill_levels(index);
  const uint16_t* flags = store.flags(index);
  int64_t counts[kLevels] = {};
  for (uint32_t r = 0; r < c.n_rows; ++r)
    if (!(flags[r] & msg::ROW_SEGMENT_START) && levels[r] < kLevels) counts[levels[r]]++;
  const size_t slot = size_t(c.id % slots_);
  for (int L = 0; L < kLevels; ++L)
    if (counts[L]) Add(L, slot, sign * counts[L]);
}

void LevelIndex::OnInsert(const ChunkStore& store, size_t index) { Update(store, index, +1); }
void LevelIndex::OnEvict(const ChunkStore& store, size_t index) { Update(store, index, -1); }

uint64_t LevelIndex::Count(uint32_t mask) const {
  uint64_t n = 0;
  for (int L = 0; L < kLevels; ++L)
    if (mask >> L & 1u) n += trees_[size_t(L)].total;
  return n;
}

size_t LevelIndex::FindSlot(int level, uint64_t* k) const {
  const std::vector<uint32_t>& f = trees_[size_t(level)].fenwick;
  size_t pos = 0;
  for (size_t step = top_bit_; step > 0; step /= 2) {
    if (pos + step <= slots_ && f[pos + step] <= *k) {
      pos += step;
      *k -= f[pos];
    }
  }
  return pos;  // 0-based slot
}

bool LevelIndex::Draw(const ChunkStore& store, uint32_t mask, std::mt19937_64* rng, size_t* chunk,
                      uint32_t* row) const {
  const uint64_t total = Count(mask);
  if (total == 0 || store.chunks() == 0) return false;
  uint64_t k = std::uniform_int_distribution<uint64_t>(0, total - 1)(*rng);
  int level = 0;
  for (; level < kLevels; ++level) {
    if (!(mask >> level & 1u)) continue;
    if (k < trees_[size_t(level)].total) break;
    k -= trees_[size_t(level)].total;
  }
  const size_t slot = FindSlot(level, &k);
  // the chunk in that slot: ids held are contiguous and fewer than slots
  const uint64_t first = store.first_id();
  const uint64_t id = first + (slot + slots_ - size_t(first % slots_)) % slots_;
  const int64_t index = store.IndexOf(id);
  if (index < 0) return false;
  const ChunkInfo& c = store.chunk(size_t(index));
  const uint8_t* levels = store.skill_levels(size_t(index));
  const uint16_t* flags = store.flags(size_t(index));
  for (uint32_t r = 0; r < c.n_rows; ++r) {
    if ((flags[r] & msg::ROW_SEGMENT_START) || levels[r] != level) continue;
    if (k-- == 0) {
      *chunk = size_t(index);
      *row = r;
      return true;
    }
  }
  return false;
}

}  // namespace coins
