// RunOptions: the "run" section of the config: what one training run is made of. Every
// process reads it, so the actor, the shards and the launcher agree on the env and the counts.
#pragma once

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "common/config/config.h"

namespace coins {

struct RunOptions {
  // environment name, as listed by `coins env list`
  std::string env = "breakout";
  // actor processes (actor i publishes to shard i mod shards)
  int64_t actors = 2;
  // replay shard processes
  int64_t shards = 2;
  // total environment steps over all actors; 0 runs until stopped
  int64_t steps = 0;
  // base seed of the run; each env derives its own from it
  int64_t seed = 1;
  // directory for the run's files (effective config, logs, snapshots, checkpoints)
  std::string dir = "runs/latest";
  // times `coins run` restarts a crashed child (each child counted alone) before it stops the run
  int64_t max_restarts = 3;
  // task eval returns whose first reaching the run's summary reports (env steps and wall time)
  std::vector<double> report_returns;

  void Visit(ConfigVisitor& v) {
    v.String("env", env, {}, "environment name");
    v.Int("actors", actors, 1, 1024, "actor processes");
    v.Int("shards", shards, 1, 256, "replay shard processes");
    v.Int("steps", steps, 0, int64_t(1) << 50, "total env steps (0: until stopped)");
    v.Int("seed", seed, 0, int64_t(1) << 62, "base seed");
    v.String("dir", dir, {}, "run directory");
    v.Int("max_restarts", max_restarts, 0, 1000, "restarts of a crashed child before the run stops");
    v.FloatList("report_returns", report_returns, "eval returns whose first reaching the summary reports");
  }
  Status Validate() const {
    if (env.empty()) return Errorf("env must name an environment");
    if (dir.empty()) return Errorf("dir must not be empty");
    for (double r : report_returns)
      if (!std::isfinite(r)) return Errorf("report_returns must hold finite returns, not {}", r);
    return Status::Ok();
  }
};

}  // namespace coins
