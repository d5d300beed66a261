// Breakout batches from a real actor, captured in memory, for benchmarks that need realistic
// replay data without the env's speed limiting them (replay and learner benches).
#pragma once

#include <cstdlib>
#include <iostream>
#include <memory>
#include <vector>

#include "actors/actor.h"

namespace coins::bench {

// keeps copies of the batches an actor publishes, up to max
class CaptureSink final : public BatchSink {
 public:
  explicit CaptureSink(size_t max) : max_(max) {}
  msg::TransitionBatch* Acquire() override { return new msg::TransitionBatch(); }
  bool Publish(msg::TransitionBatch* b) override {
    if (full())
      delete b;
    else
      batches.emplace_back(b);
    return true;
  }
  void Release(msg::TransitionBatch* b) override { delete b; }
  bool Flush(std::chrono::milliseconds) override { return true; }
  uint64_t retries() const override { return 0; }
  bool full() const { return batches.size() >= max_; }
  std::vector<std::unique_ptr<msg::TransitionBatch>> batches;

 private:
  size_t max_;
};

// n batches of `rows` rows of one actor playing Breakout at random (exits on failure: a
// benchmark cannot go on without its data)
inline std::vector<std::unique_ptr<msg::TransitionBatch>> BreakoutBatches(size_t n, int rows = 256,
                                                                          envs::EnvSpec* spec = nullptr) {
  CaptureSink sink(n);
  ActorOptions o;
  o.batch_rows = rows;
  auto actor = Actor::Create("breakout", o, 0, 1, &sink);
  if (!actor.ok()) {
    std::cerr << "breakout batches: " << actor.status().message() << "\n";
    std::exit(2);
  }
  if (spec) *spec = (*actor)->spec();
  (*actor)->Run(
      0, [&] { return sink.full(); }, [](const ActorCounters&) {}, std::chrono::hours(1));
  return std::move(sink.batches);
}

}  // namespace coins::bench
