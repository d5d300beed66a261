#include "common/sum_tree.h"

#include <cassert>

namespace coins {

SumTree::SumTree(int64_t size) : size_(size) {
  assert(size > 0);
  while (leaves_ < size) leaves_ *= 2;
  nodes_.assign(size_t(2 * leaves_), 0.0);
}

void SumTree::Set(int64_t slot, double priority) {
  assert(slot >= 0 && slot < size_ && priority >= 0.0);
  int64_t i = leaves_ + slot;
  nodes_[size_t(i)] = priority;
  // refresh the sums on the path to the root
  for (i /= 2; i >= 1; i /= 2) nodes_[size_t(i)] = nodes_[size_t(2 * i)] + nodes_[size_t(2 * i + 1)];
}

int64_t SumTree::Find(double u) const {
  if (u < 0.0) u = 0.0;
  int64_t i = 1;
  while (i < leaves_) {
    const double left = nodes_[size_t(2 * i)];
    // go left when u falls inside the left sum (or the right side is empty)
    if (u < left || nodes_[size_t(2 * i + 1)] <= 0.0) {
      i = 2 * i;
    } else {
      u -= left;
      i = 2 * i + 1;
    }
  }
  int64_t slot = i - leaves_;
  // guard against rounding past the last non-empty slot
  while (slot > 0 && (slot >= size_ || nodes_[size_t(leaves_ + slot)] <= 0.0)) --slot;
  return slot;
}

}  // namespace coins
