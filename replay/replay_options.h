// ReplayOptions: the "replay" section of the config.
#pragma once

#include <cstdint>

#include "common/config/config.h"

namespace coins {

struct ReplayOptions {
  // transitions a shard holds at most
  int64_t capacity = 1'000'000;
  // memory of a shard's chunk arena, in MiB (Breakout rows take about 60 bytes); whichever
  // limit is reached first evicts the oldest batches
  int64_t capacity_mb = 512;
  // seconds between ReplayStats / heartbeat publications
  double status_period_s = 1.0;

  void Visit(ConfigVisitor& v) {
    v.Int("capacity", capacity, 1024, int64_t(1) << 34, "transitions per shard");
    v.Int("capacity_mb", capacity_mb, 16, int64_t(1) << 20, "chunk arena per shard (MiB)");
    v.Float("status_period_s", status_period_s, 0.05, 3600, "status period (s)");
  }
  Status Validate() const { return Status::Ok(); }
};

}  // namespace coins
