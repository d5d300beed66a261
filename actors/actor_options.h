// ActorOptions: the "actor" section of the config.
#pragma once

#include <cstdint>

#include "common/config/config.h"

namespace coins {

struct ActorOptions {
  // environments stepped round-robin by one actor process
  int64_t envs = 1;
  // rows per TransitionBatch; 0 fills each batch as far as its fixed size allows
  int64_t batch_rows = 0;
  // steps for each actor; 0 splits run.steps evenly (or runs until stopped when that is 0 too)
  int64_t steps = 0;
  // seconds between ActorStats / heartbeat publications
  double status_period_s = 1.0;
  // seconds to wait at exit for the shard to acknowledge every batch
  double flush_timeout_s = 10.0;
  // follow the orchestrator's ChainCommand (hierarchy, pacing) and the learner's weights; false:
  // uniform random actions without pacing (transport tests and benchmarks)
  bool follow_chain = true;

  void Visit(ConfigVisitor& v) {
    v.Int("envs", envs, 1, 4096, "environments per actor");
    v.Int("batch_rows", batch_rows, 0, 1024, "rows per batch (0: as many as fit)");
    v.Int("steps", steps, 0, int64_t(1) << 50, "steps per actor (0: run.steps / run.actors)");
    v.Float("status_period_s", status_period_s, 0.05, 3600, "status period (s)");
    v.Float("flush_timeout_s", flush_timeout_s, 0, 3600, "exit flush timeout (s)");
    v.Bool("follow_chain", follow_chain, "follow ChainCommand and weights (false: random actions, no pacing)");
  }
  Status Validate() const {
    if (batch_rows == 1) return Errorf("batch_rows 1 leaves no room for a transition after the context row");
    return Status::Ok();
  }
};

}  // namespace coins
