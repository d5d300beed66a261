// A detection round of the chain (paper Algorithm 1, step 2): for every candidate target of the
// current source, sample primitive transitions from replay (only the pair's factors,
// detector/pair_space.h), train the passive and active models on most of them, and score the
// interaction test on the held-out rest (Sc_I, MG, mask, goal set). Held-out rows are chosen by
// a hash of their replay key, so a row sampled twice never lands on both sides.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "common/env_spec.h"
#include "detector/detector_spec.h"
#include "detector/interaction.h"
#include "detector/pair_space.h"
#include "idl/status.h"
#include "learner/replay_client/sample_source.h"

namespace coins {

struct DetectRoundOptions {
  int64_t max_samples = 200000;   // per target
  int64_t max_floats = 20000000;  // per target: samples x compact state floats
  double holdout = 0.2;
  uint32_t level_mask = 0b11;  // primitive rows: random steps and first-skill steps
  detector::DetectorOptions detector;
  // called between pieces of work and every 64 Adam steps of the models' training (a caller
  // keeps its status and heartbeat going from it)
  std::function<void()> tick = [] {};
};

struct DetectedTarget {
  msg::InteractionScore score;  // as published
  detector::DetectorSpec spec;  // the trained detector, when a model was trained
  std::unique_ptr<detector::PairDetector> detector;
};

// the transitions of a pair sampled from replay: train and held-out parts
struct PairData {
  detector::TransitionSet train, held_out;
};
// samples up to `wanted` distinct primitive transitions of the pair's compact state
Result<PairData> SamplePairData(SampleSource* source, const detector::PairSpace& space, int64_t wanted,
                                const DetectRoundOptions& options);

// rows_available: primitive transitions replay holds (sizes the sample: twice as many draws,
// since draws repeat rows). A process stop (StopRequested) ends the round between targets or
// within 64 Adam steps of a target's training with a "not ready" error: the round has no
// result, and the learner treats it as waiting, not failed.
Result<std::vector<DetectedTarget>> RunDetectRound(SampleSource* source, const envs::EnvSpec& env,
                                                   const std::string& source_factor,
                                                   const std::vector<std::string>& targets, int64_t rows_available,
                                                   const DetectRoundOptions& options);

// the InteractionScore fields of a scored pair
msg::InteractionScore ToScoreMessage(const detector::PairScores& s, const envs::EnvSpec& env, double train_seconds);

}  // namespace coins
