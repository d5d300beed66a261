// Exploration: epsilon-greedy over action values and Gaussian action noise, with a linear
// schedule for either rate.
#pragma once

#include <cstdint>
#include <random>
#include <span>

#include <Eigen/Dense>

namespace coins::rl {

// value(t) goes linearly from start to end over steps, then stays at end
struct LinearSchedule {
  float start = 1.0f;
  float end = 0.05f;
  int64_t steps = 10000;
  float Value(int64_t t) const;
};

// argmax of q with probability 1 - epsilon, else a uniform action; ties go to the lowest index
int EpsilonGreedy(const Eigen::Ref<const Eigen::VectorXf>& q, float epsilon, std::mt19937_64* rng);

// action += N(0, sigma^2) per dimension, then clipped to [low, high]
void AddGaussianNoise(std::span<float> action, float sigma, float low, float high, std::mt19937_64* rng);

}  // namespace coins::rl
