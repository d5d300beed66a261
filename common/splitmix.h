// splitmix64 (Steele, Lea and Flood 2014), the one copy: its finaliser, a bijective 64-bit mixer
// in which every input bit reaches every output bit (hashes, seed derivation), and its generator
// step (seeding larger generators such as the envs' xoshiro256**).
#pragma once

#include <cstdint>

namespace coins {

// the golden-ratio increment of splitmix64
inline constexpr uint64_t kSplitMixGamma = 0x9e3779b97f4a7c15ULL;

// the splitmix64 finaliser
constexpr uint64_t SplitMix64Mix(uint64_t z) {
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

// one splitmix64 step: advances the state by the gamma and returns the mixed state
constexpr uint64_t SplitMix64Next(uint64_t& state) {
  state += kSplitMixGamma;
  return SplitMix64Mix(state);
}

}  // namespace coins
