// EnvStepCount: the env steps of a run from the actors' cumulative ActorStats.steps reports.
// A restarted actor counts from 0 again: what its earlier incarnation reported is kept as a
// base, so the total never moves back. Replay counts are no substitute: shards store a
// transition per level stream, several per env step once skills act.
#pragma once

#include <cstdint>
#include <map>

namespace coins {

class EnvStepCount {
 public:
  // the newest cumulative count of one actor
  void Report(uint32_t actor_id, uint64_t steps) {
    Actor& a = actors_[actor_id];
    if (steps < a.last) a.base += a.last;
    a.last = steps;
  }
  uint64_t total() const {
    uint64_t n = 0;
    for (const auto& [id, a] : actors_) n += a.base + a.last;
    return n;
  }
  bool empty() const { return actors_.empty(); }
  // the newest cumulative count actor_id reported (0: none yet): where a restart of it counts on from
  uint64_t last(uint32_t actor_id) const {
    auto it = actors_.find(actor_id);
    return it == actors_.end() ? 0 : it->second.last;
  }

 private:
  struct Actor {
    uint64_t base = 0, last = 0;
  };
  std::map<uint32_t, Actor> actors_;
};

}  // namespace coins
