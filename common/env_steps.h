// EnvStepCount: the env steps of a run from the actors' cumulative ActorStats.steps reports.
// Each actor process (incarnation) counts from its first step: 0 for a fresh actor, or the count
// `coins run` gave it on a resume or a restart. When a new incarnation starts below the count the
// earlier one reached (it restarted from 0, or from a count read before the last report arrived),
// the steps between its first step and that count are kept as a base, so the total never moves
// back and nothing is counted twice. Reports of an incarnation that was replaced are ignored.
// Replay counts are no substitute: shards store a transition per level stream, several per env
// step once skills act.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <map>

namespace coins {

// actor `actor_id`'s part of `all` run steps split among `actors`: the first all % actors actors
// take one more. The pacing and a resume's first steps split the run's steps this way.
inline uint64_t ActorShare(uint64_t all, uint64_t actor_id, uint64_t actors) {
  return all / actors + (actor_id < all % actors ? 1 : 0);
}

class EnvStepCount {
 public:
  // the newest cumulative count of one actor process
  void Report(uint32_t actor_id, uint64_t steps, uint64_t incarnation = 0, uint64_t first_step = 0) {
    Actor& a = actors_[actor_id];
    if (incarnation != 0 && std::find(a.retired.begin(), a.retired.end(), incarnation) != a.retired.end()) return;
    const bool replaced = a.seen && incarnation != a.incarnation;
    if (replaced || steps < a.last) a.base += a.last - std::min(first_step, a.last);
    if (replaced) a.retired[a.next_retired++ % a.retired.size()] = a.incarnation;
    a.seen = true;
    a.incarnation = incarnation;
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
    uint64_t base = 0, last = 0, incarnation = 0;
    bool seen = false;
    std::array<uint64_t, 4> retired{};  // the newest replaced incarnations (0: none)
    size_t next_retired = 0;
  };
  std::map<uint32_t, Actor> actors_;
};

}  // namespace coins
