// SumTree: proportional sampling over n slots in O(log n) (prioritised replay).
//
// Leaves hold non-negative priorities; Find(u) for u in [0, Total()) returns the slot whose
// prefix-sum interval contains u, so a uniform u draws slot i with probability p_i / Total().
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace coins {

class SumTree {
 public:
  SumTree() = default;
  explicit SumTree(int64_t size);

  int64_t size() const { return size_; }
  void Set(int64_t slot, double priority);  // priority >= 0
  double Get(int64_t slot) const { return nodes_[size_t(leaves_ + slot)]; }
  double Total() const { return nodes_[1]; }
  // slot with prefix(slot) <= u < prefix(slot) + p_slot; u is clamped into [0, Total())
  int64_t Find(double u) const;

 private:
  int64_t size_ = 0;
  int64_t leaves_ = 1;         // a power of two >= size_
  std::vector<double> nodes_;  // heap order, root at 1
};

}  // namespace coins
