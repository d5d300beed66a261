// The factored environment interface every simulator in coins implements.
//
// A state is a flat float vector: the factors of EnvSpec::factors laid out one after another,
// each factor `instances x features` floats (instance-major). Actions are float vectors too:
// a discrete action is one float holding the integer index. All values are in the env's own
// units; FactorSpec::low/high give the normalisation bounds the learners use.
//
// Hot-path contract: Reset and Step write into caller-provided buffers of spec().state_dim()
// floats and allocate nothing. Step validates the action first; an invalid action (out of
// range, NaN, not an integer for a discrete space) returns an error and leaves the env exactly
// as it was. Envs are deterministic: the same seed and actions give the same trajectory, also
// after SaveState/RestoreState. An Env is used by one thread at a time.
//
// Episodes: after a step that returns done or truncated, Step returns an error until the
// caller starts the next episode with ResetNext (or Reset). What persists across ResetNext is
// env-specific (Breakout keeps its board across drops, as its lives).
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "common/env_spec.h"
#include "common/status.h"

namespace coins::envs {

struct StepResult {
  float reward = 0.0f;
  bool done = false;          // the episode ended (terminal state)
  bool truncated = false;     // the episode was cut by a time limit (state not terminal)
  uint32_t interactions = 0;  // bit i set: spec().interactions[i] happened this step
};

class Env {
 public:
  virtual ~Env() = default;
  virtual const EnvSpec& spec() const = 0;
  // starts a new episode from the seed and writes the initial state
  virtual void Reset(uint64_t seed, std::span<float> state) = 0;
  // starts a new episode continuing the env's own random stream (after done/truncated)
  virtual void ResetNext(std::span<float> state) = 0;
  // validates the action, then advances one step and writes the next state
  virtual Status Step(std::span<const float> action, std::span<float> next_state, StepResult* result) = 0;
  // writes the current state without stepping
  virtual void GetState(std::span<float> state) const = 0;
  // full simulator state (including random generator) as bytes, and back
  virtual std::vector<uint8_t> SaveState() const = 0;
  virtual Status RestoreState(std::span<const uint8_t> bytes) = 0;
};

// names accepted by MakeEnv, in a stable order
std::vector<std::string> EnvNames();
// builds the env registered under name; the error lists the known names
Result<std::unique_ptr<Env>> MakeEnv(const std::string& name);

}  // namespace coins::envs
