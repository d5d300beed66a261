#include "learner/rl/exploration.h"

#include <algorithm>

namespace coins::rl {

float LinearSchedule::Value(int64_t t) const {
  if (steps <= 0 || t >= steps) return end;
  const float f = float(t) / float(steps);
  return start + f * (end - start);
}

int EpsilonGreedy(const Eigen::Ref<const Eigen::VectorXf>& q, float epsilon, std::mt19937_64* rng) {
  std::uniform_real_distribution<float> coin(0.0f, 1.0f);
  if (coin(*rng) < epsilon) return std::uniform_int_distribution<int>(0, int(q.size()) - 1)(*rng);
  Eigen::Index best = 0;
  q.maxCoeff(&best);
  return int(best);
}

void AddGaussianNoise(std::span<float> action, float sigma, float low, float high, std::mt19937_64* rng) {
  std::normal_distribution<float> noise(0.0f, sigma);
  for (float& a : action) a = std::clamp(a + noise(*rng), low, high);
}

}  // namespace coins::rl
