// `coins env ...`: list the envs, write rollouts as JSON lines, render pictures.
//
//   env list [--json]
//   env rollout --env NAME --seed N (--actions FILE | --policy random --steps S) --out FILE
//   env render  --env NAME --seed N --policy random --steps S --out FILE.png|FILE.gif
//   env plan    --env breakout-VARIANT [--depth D] [--episodes N] [--seed S] [--json]   (breakout_planner.h)
//
// A rollout line is one transition: {"t", "episode", "state", "action", "next_state",
// "reward", "done", "truncated", "interactions"}; "t" counts transitions from 0 across the
// whole rollout, "episode" counts from 0 and increments after a done or truncated step (the
// env then starts its next episode). States map each factor name to its feature list, or to
// a list of feature lists for multi-instance classes (Block, Obstacle). An actions file holds
// one action per line: an integer for discrete spaces, comma-separated floats for continuous.
// A .png gets the last frame; a .gif gets every frame (the initial state and each step).
#pragma once

#include <string>

#include <CLI/CLI.hpp>

#include "common/status.h"

namespace coins::envs {

// adds the `env` subcommand with list, rollout and render; failures print one line
// "error: ..." on stderr and exit non-zero through CLI::RuntimeError
void AddEnvCommands(CLI::App& app);

struct RolloutOptions {
  std::string env;
  uint64_t seed = 0;
  std::string actions_file;  // empty: use policy
  std::string policy;        // "random"
  int steps = 0;
  std::string out;
};
Status RunRollout(const RolloutOptions& o);

struct RenderOptions {
  std::string env;
  uint64_t seed = 0;
  std::string policy = "random";
  int steps = 100;
  std::string out;
  int scale = 4;    // Breakout pixels per game pixel
  int width = 320;  // pushing image size
  int height = 240;
  int delay_cs = 5;  // gif frame delay, hundredths of a second
};
Status RunRender(const RenderOptions& o);

Status RunList(bool json);

}  // namespace coins::envs
