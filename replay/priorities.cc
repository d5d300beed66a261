#include "replay/priorities.h"

#include <cmath>
#include <cstring>

#include "idl/transition.h"

namespace coins {

Priorities::Priorities(int64_t slots, double alpha)
    : slots_(slots), alpha_(alpha), prio_(slots), is_transition_(new uint8_t[size_t(slots)]) {
  std::memset(is_transition_.get(), 0, size_t(slots));
}

void Priorities::OnInsert(uint64_t row_base, const uint16_t* flags, uint32_t n) {
  const double p = std::pow(max_priority_, alpha_);
  for (uint32_t r = 0; r < n; ++r) {
    int64_t s = Slot(row_base + r);
    bool t = !(flags[r] & msg::ROW_SEGMENT_START);
    is_transition_[size_t(s)] = t;
    prio_.Set(s, t ? p : 0.0);
    if (weight_) weight_->Set(s, t ? 1.0 : 0.0);
  }
}

void Priorities::OnEvict(uint64_t row_base, uint32_t n) {
  for (uint32_t r = 0; r < n; ++r) {
    int64_t s = Slot(row_base + r);
    is_transition_[size_t(s)] = 0;
    prio_.Set(s, 0.0);
    if (weight_) weight_->Set(s, 0.0);
  }
}

void Priorities::SetPriority(uint64_t row, double p) {
  int64_t s = Slot(row);
  if (!is_transition_[size_t(s)]) return;
  if (p > max_priority_) max_priority_ = p;
  prio_.Set(s, std::pow(p, alpha_));
}

void Priorities::EnsureWeights() {
  if (weight_) return;
  // allocated on first use: uniform and prioritised runs never pay for it
  weight_ = std::make_unique<SumTree>(slots_);
  for (int64_t s = 0; s < slots_; ++s)
    if (is_transition_[size_t(s)]) weight_->Set(s, 1.0);
}

void Priorities::SetWeight(uint64_t row, double w) {
  int64_t s = Slot(row);
  if (!is_transition_[size_t(s)]) return;
  EnsureWeights();
  weight_->Set(s, w);
}

void Priorities::SetRaw(uint64_t row, float priority, float weight) {
  int64_t s = Slot(row);
  if (!is_transition_[size_t(s)]) return;
  prio_.Set(s, priority);
  if (alpha_ > 0 && priority > 0) max_priority_ = std::max(max_priority_, std::pow(double(priority), 1.0 / alpha_));
  if (weight != 1.0f || weight_) {
    EnsureWeights();
    weight_->Set(s, weight);
  }
}

}  // namespace coins
