// A reference for the Breakout variants' tables, not a learning method: what a task over a
// perfect ball skill could score.
//
// PlanAngles plays a Breakout env with an ideal ball controller, which reads the simulator's
// own state and places the paddle so that the ball leaves the next paddle bounce at the
// requested one of the four angles, and picks each angle by exhaustive search over the next
// `depth` bounces in copies of the simulator (SaveState/RestoreState). Depth 0 picks uniformly
// among the angles the paddle can still reach: a perfect skill under random angles. The
// learned chain's task sees none of this; the figures bound what foresight of `depth` bounces
// is worth on a variant, beside the random-actions and random-angles references.
//
// Angles are numbered by the paddle bounce table (actors/envs/README.md): 0 (vy -1, vx -1),
// 1 (-2, -1), 2 (-2, 1), 3 (-1, 1). An episode ends at the env's done, at a drop (which only
// happens when no angle is reachable), or after max_steps env steps.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "actors/envs/breakout.h"
#include "common/status.h"

namespace coins::envs {

struct AnglePlanOptions {
  std::string env = "breakout-hard";  // a Breakout env name
  int episodes = 100;
  int depth = 2;           // bounces searched ahead (0: random reachable angles); 4^depth leaves
  uint64_t seed = 1;       // episode e is Reset(seed + e); ties and depth 0 draw from seed too
  int max_steps = 20'000;  // env steps per episode at most
  Status Validate() const;
};

struct AnglePlanResult {
  std::vector<double> returns;  // one per episode
  int64_t bounces = 0;          // paddle bounces over all episodes
  int64_t drops = 0;            // episodes ended by a drop
  int64_t env_steps = 0;        // real env steps (the search's copies not counted)
  double mean() const;
  double sd() const;  // population standard deviation over episodes
};

// one controller move: the env is stepped until the next paddle bounce leaves at `angle`
struct BounceOutcome {
  bool reachable = false;  // false: the env is unchanged, no paddle position gives that angle
  bool bounced = false;    // false: the episode ended before the ball came back to the paddle
  float reward = 0.0f;     // summed over the steps taken
  bool done = false;       // the episode ended on the way (before or at the bounce)
  int steps = 0;
};

// Steps `env` with the ideal controller until the ball leaves the paddle at `angle` (or the
// episode ends first, e.g. a target hit). Tries paddle positions in copies of the env and
// replays the first that gives the angle. `scratch` is any env of the same variant.
BounceOutcome BounceAt(BreakoutEnv& env, BreakoutEnv& scratch, int angle, int max_steps);

Result<AnglePlanResult> PlanAngles(const AnglePlanOptions& o);

}  // namespace coins::envs
