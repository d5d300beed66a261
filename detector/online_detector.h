// OnlineDetector: the interaction test of one trained pair applied step by step, as actors use
// it to end skills (never the simulator's labels). Same encoding and test as
// PairDetector::Detect (eq. 8 with the proximity gate and the counterfactual check), on one
// transition of full states at a time: the proximity gate is checked first, so far-apart steps
// cost a few subtractions. The counterfactual check draws its other sources from the last
// `history` transitions this detector saw (Detect draws them from its data set).
// Allocates nothing after the first calls. One thread at a time.
#pragma once

#include <cstdint>
#include <random>
#include <span>
#include <vector>

#include <Eigen/Dense>

#include "detector/detector_spec.h"
#include "detector/interaction.h"

namespace coins::detector {

class OnlineDetector {
 public:
  OnlineDetector() = default;
  // builds the models of spec and loads the blob (PairDetector::WeightsBlob format)
  static Result<OnlineDetector> Create(const DetectorSpec& spec, std::span<const uint8_t> blob, uint64_t seed,
                                       int history = 1024);

  // h_ab of the transition (full states of spec.full_state_dim floats; the env's action)
  bool Test(const float* state, const float* action, const float* next_state);
  const DetectorSpec& spec() const { return spec_; }
  // what the models said about the last tested transition (for tests and diagnostics)
  float last_ll_act() const { return last_act_; }
  float last_ll_pas() const { return last_pas_; }

 private:
  bool TestInstance(int instance, const PairTransition& now);
  float ActiveLL(const PairTransition& src, const PairTransition& tgt, int instance);
  void Remember(const PairTransition& now);

  DetectorSpec spec_;
  PairDetector det_;
  std::mt19937_64 rng_;
  int history_ = 0, stored_ = 0, next_ = 0;
  std::vector<float> ring_state_, ring_action_, ring_next_;  // history x compact / action dims
  std::vector<float> state_, next_state_;                    // compact of the tested transition
  Eigen::MatrixXf pas_in_, act_in_, target_, scratch_pas_, scratch_target_;
  Eigen::VectorXf ll_, own_source_;
  float last_act_ = 0.0f, last_pas_ = 0.0f;
};

}  // namespace coins::detector
