#include "replay/priorities.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "idl/transition.h"

namespace coins {

static_assert(Priorities::kLevels == COINS_MAX_LEVELS);

Priorities::Priorities(int64_t slots, double alpha)
    : slots_(slots), alpha_(alpha), prio_(slots), level_(new uint8_t[size_t(slots)]), level_blocks_(kLevels) {
  std::memset(level_.get(), kNotTransition, size_t(slots));
}

void Priorities::AddBlockMass(uint8_t level, int64_t slot, double delta) {
  SumTree& blocks = level_blocks_[level];
  if (blocks.size() == 0) blocks = SumTree((slots_ + kBlock - 1) / kBlock);
  const int64_t b = slot / kBlock;
  // a block's mass follows by adding each change; rounding never makes it negative
  blocks.Set(b, std::max(0.0, blocks.Get(b) + delta));
}

void Priorities::AssignSlot(int64_t slot, uint8_t level, double mass) {
  const uint8_t old = level_[size_t(slot)];
  if (old < kLevels) AddBlockMass(old, slot, -prio_.Get(slot));
  level_[size_t(slot)] = level;
  if (level < kLevels) AddBlockMass(level, slot, mass);
  prio_.Set(slot, mass);
}

namespace {

// sums the block-mass changes of consecutive slots, so that a chunk of rows (consecutive slots,
// one or two blocks, mostly one level) costs a few block updates rather than one a row
template <class Apply>
class BlockMassBatch {
 public:
  explicit BlockMassBatch(Apply apply) : apply_(apply) {}
  ~BlockMassBatch() { Flush(); }
  void Add(uint8_t level, int64_t slot, double delta) {
    const int64_t block = slot / Priorities::kBlock;
    if (level != level_ || block != block_) {
      Flush();
      level_ = level;
      block_ = block;
    }
    delta_ += delta;
  }
  void Flush() {
    if (block_ >= 0 && delta_ != 0) apply_(level_, block_ * Priorities::kBlock, delta_);
    delta_ = 0;
  }

 private:
  Apply apply_;
  uint8_t level_ = 0;
  int64_t block_ = -1;
  double delta_ = 0;
};

}  // namespace

void Priorities::OnInsert(uint64_t row_base, const uint16_t* flags, const uint8_t* levels, uint32_t n) {
  const double p = std::pow(max_priority_, alpha_);
  BlockMassBatch blocks([this](uint8_t level, int64_t slot, double delta) { AddBlockMass(level, slot, delta); });
  for (uint32_t r = 0; r < n; ++r) {
    int64_t s = Slot(row_base + r);
    bool t = !(flags[r] & msg::ROW_SEGMENT_START);
    // a slot is evicted before it is reused; a level still there leaves with its mass
    if (level_[size_t(s)] < kLevels) AssignSlot(s, kNotTransition, 0.0);
    const uint8_t level = !t ? kNotTransition : levels[r] < kLevels ? levels[r] : kOtherLevel;
    level_[size_t(s)] = level;
    prio_.Set(s, t ? p : 0.0);
    if (level < kLevels) blocks.Add(level, s, p);
    if (weight_) weight_->Set(s, t ? 1.0 : 0.0);
  }
}

void Priorities::OnEvict(uint64_t row_base, uint32_t n) {
  BlockMassBatch blocks([this](uint8_t level, int64_t slot, double delta) { AddBlockMass(level, slot, delta); });
  for (uint32_t r = 0; r < n; ++r) {
    int64_t s = Slot(row_base + r);
    if (level_[size_t(s)] < kLevels) blocks.Add(level_[size_t(s)], s, -prio_.Get(s));
    level_[size_t(s)] = kNotTransition;
    prio_.Set(s, 0.0);
    if (weight_) weight_->Set(s, 0.0);
  }
}

void Priorities::SetPriority(uint64_t row, double p) {
  int64_t s = Slot(row);
  if (!IsTransition(s)) return;
  if (p > max_priority_) max_priority_ = p;
  AssignSlot(s, level_[size_t(s)], std::pow(p, alpha_));
}

void Priorities::EnsureWeights() {
  if (weight_) return;
  // allocated on first use: uniform and prioritised runs never pay for it
  weight_ = std::make_unique<SumTree>(slots_);
  for (int64_t s = 0; s < slots_; ++s)
    if (IsTransition(s)) weight_->Set(s, 1.0);
}

void Priorities::SetWeight(uint64_t row, double w) {
  int64_t s = Slot(row);
  if (!IsTransition(s)) return;
  EnsureWeights();
  weight_->Set(s, w);
}

void Priorities::SetRaw(uint64_t row, float priority, float weight) {
  int64_t s = Slot(row);
  if (!IsTransition(s)) return;
  AssignSlot(s, level_[size_t(s)], priority);
  if (alpha_ > 0 && priority > 0) max_priority_ = std::max(max_priority_, std::pow(double(priority), 1.0 / alpha_));
  if (weight != 1.0f || weight_) {
    EnsureWeights();
    weight_->Set(s, weight);
  }
}

double Priorities::LevelMass(uint32_t level_mask) const {
  double mass = 0;
  for (int L = 0; L < kLevels; ++L)
    if ((level_mask >> L & 1u) && level_blocks_[size_t(L)].size() > 0) mass += level_blocks_[size_t(L)].Total();
  return mass;
}

int64_t Priorities::DrawLevelSlot(uint32_t level_mask, std::mt19937_64* rng, double* prob) const {
  const double total = LevelMass(level_mask);
  if (total <= 0) return -1;
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  // the level, then the block, in proportion to their masses
  double u = unit(*rng) * total;
  int level = -1;
  for (int L = 0; L < kLevels; ++L) {
    if (!(level_mask >> L & 1u) || level_blocks_[size_t(L)].size() == 0) continue;
    level = L;
    if (u < level_blocks_[size_t(L)].Total()) break;
    u -= level_blocks_[size_t(L)].Total();
  }
  const SumTree& blocks = level_blocks_[size_t(level)];
  const int64_t b = blocks.Find(unit(*rng) * blocks.Total());
  // the slot inside the block, from the leaves themselves (exact even if the block's running
  // mass has drifted by rounding)
  const int64_t begin = b * kBlock, end = std::min(slots_, begin + kBlock);
  double block_mass = 0;
  for (int64_t s = begin; s < end; ++s)
    if (level_[size_t(s)] == level) block_mass += prio_.Get(s);
  if (block_mass <= 0) return -1;
  double v = unit(*rng) * block_mass;
  int64_t slot = -1;
  for (int64_t s = begin; s < end; ++s) {
    if (level_[size_t(s)] != level || prio_.Get(s) <= 0) continue;
    slot = s;
    if (v < prio_.Get(s)) break;
    v -= prio_.Get(s);
  }
  *prob = blocks.Get(b) / total * (prio_.Get(slot) / block_mass);
  return slot;
}

}  // namespace coins
