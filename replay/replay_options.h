// ReplayOptions: the "replay" section of the config.
#pragma once

#include <cstdint>

#include "common/config/config.h"

namespace coins {

struct ReplayOptions {
  // rows a shard holds at most (a row is one transition, or an episode's / batch's first state)
  int64_t capacity = 1'000'000;
  // bytes a shard's ring may use at most, in MiB; the smaller of the two limits wins
  int64_t capacity_mb = 2048;
  // seconds between ReplayStats / heartbeat publications
  double status_period_s = 1.0;

  void Visit(ConfigVisitor& v) {
    v.Int("capacity", capacity, 1024, int64_t(1) << 34, "rows per shard");
    v.Int("capacity_mb", capacity_mb, 1, int64_t(1) << 20, "ring memory per shard (MiB)");
    v.Float("status_period_s", status_period_s, 0.05, 3600, "status period (s)");
  }
  Status Validate() const { return Status::Ok(); }
};

}  // namespace coins
