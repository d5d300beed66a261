// Rng: the small, seedable, serialisable random generator every env owns.
//
// xoshiro256** seeded through splitmix64. Its whole state is four words, so envs can save and
// restore it byte for byte; the same seed gives the same stream on every machine.
#pragma once

#include <cstdint>

#include "common/splitmix.h"

namespace coins::envs {

class Rng {
 public:
  explicit Rng(uint64_t seed = 0) { Seed(seed); }

  void Seed(uint64_t seed) {
    for (auto& w : s_) w = SplitMix64Next(seed);
  }

  uint64_t Next() {
    const uint64_t result = Rotl(s_[1] * 5, 7) * 9;
    const uint64_t t = s_[1] << 17;
    s_[2] ^= s_[0];
    s_[3] ^= s_[1];
    s_[1] ^= s_[2];
    s_[0] ^= s_[3];
    s_[2] ^= t;
    s_[3] = Rotl(s_[3], 45);
    return result;
  }

  // uniform integer in [lo, hi] (inclusive), lo <= hi, hi - lo < 2^31
  int UniformInt(int lo, int hi) {
    const uint64_t range = static_cast<uint64_t>(hi - lo) + 1;
    return lo + static_cast<int>(((Next() >> 32) * range) >> 32);
  }

  // uniform double in [0, 1)
  double Uniform() { return static_cast<double>(Next() >> 11) * 0x1.0p-53; }

  // uniform double in [lo, hi)
  double Uniform(double lo, double hi) { return lo + (hi - lo) * Uniform(); }

  // raw state, for save/restore
  const uint64_t* state() const { return s_; }
  uint64_t* mutable_state() { return s_; }

 private:
  static uint64_t Rotl(uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
  uint64_t s_[4];
};

}  // namespace coins::envs
