// SkillSelection: the weights a skill keeps when its training ends, chosen among the acting
// weights it had along its training.
//
// A skill's greedy quality swings between nearby points of its training (the Breakout ball
// skill's return with random angles moved by 10-30 between checkpoints 100k env steps apart, and
// its final weights were rarely its best), so the learner keeps snapshots of the acting weights
// while a skill trains (SkillSnapshots) and, when the orchestrator moves on, evaluates each
// snapshot and the final weights on the same goals (the same env seeds for every candidate) and
// keeps the best. "Best" is intrinsic: for a skill whose goals need the link's interaction (the
// ball skill: the paddle meets the ball) the highest rate of goals ended by that interaction as
// the learned detector sees it, else the highest rate of goals reached; the other rate breaks a
// tie, then the later candidate wins. No env reward and no simulator label enters the choice.
//
// The work comes in slices (one evaluation of `chunk_goals` goals per Step) so that the learner
// keeps serving status and checkpoints while it chooses. One thread at a time.
#pragma once

#include <cstdint>
#include <deque>
#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "actors/evaluate.h"
#include "common/status.h"

namespace coins {

struct SkillSnapshot {
  uint64_t env_steps = 0;       // run env steps when it was taken
  std::vector<uint8_t> acting;  // PolicyNet blob
};

// the newest `capacity` snapshots of the skill being trained, one every `every` env steps
class SkillSnapshots {
 public:
  SkillSnapshots(int capacity, uint64_t every) : capacity_(capacity), every_(every) {}
  bool enabled() const { return capacity_ > 0; }
  // a new skill (level): the old snapshots are forgotten; the first is due `every` from now
  void Start(int level, uint64_t env_steps);
  bool Due(int level, uint64_t env_steps) const { return enabled() && level == level_ && env_steps >= next_at_; }
  void Add(uint64_t env_steps, std::vector<uint8_t> acting);
  // a restored list (checkpoints); capacity still bounds it
  void Restore(int level, uint64_t next_at, std::deque<SkillSnapshot> all);
  void Clear() { Restore(0, 0, {}); }

  int level() const { return level_; }
  uint64_t next_at() const { return next_at_; }
  const std::deque<SkillSnapshot>& all() const { return all_; }

 private:
  int capacity_;
  uint64_t every_;
  int level_ = 0;
  uint64_t next_at_ = 0;
  std::deque<SkillSnapshot> all_;
};

struct SelectionOptions {
  int64_t goals = 20000;             // goals per candidate
  int64_t chunk_goals = 1000;        // goals per Step
  int64_t chunk_max_steps = 200000;  // env steps per Step at most
  uint64_t seed = 1;                 // env seeds of the goals (the same for every candidate)
  bool by_interaction = true;        // rank by the interaction rate (else by success)
};

struct CandidateScore {
  uint64_t goals = 0, reached = 0, interacted = 0;
  int64_t steps = 0;
  double success() const { return goals ? double(reached) / double(goals) : 0.0; }
  double hit_rate() const { return goals ? double(interacted) / double(goals) : 0.0; }
};

// what a finished choice kept, beside what the final weights scored (checkpoints, run summary)
struct SkillChoice {
  int level = 0;
  std::string skill;
  uint64_t candidates = 0, goals = 0;  // goals: of the chosen candidate
  uint64_t env_steps = 0;              // of the kept weights
  double hit_rate = 0, success = 0;
  uint64_t final_env_steps = 0;
  double final_hit_rate = 0, final_success = 0;
};

nlohmann::json ToJson(const SkillChoice& c);
// a list of choices as ToJson writes them (checkpoints' state.json "skill_choices"); errors name the field
Result<std::vector<SkillChoice>> SkillChoicesFromJson(const nlohmann::json& list);

class SkillSelection {
 public:
  // evaluates `goals` goals of the level with the acting weights `acting` (at most `max_steps`
  // env steps; episodes from Reset(seed), Reset(seed + 1), ...): the learner's Evaluate
  using EvalFn = std::function<Result<EvalResult>(const std::vector<uint8_t>& acting, int64_t goals, int64_t max_steps,
                                                  uint64_t seed)>;

  // candidates in the order they were taken (the last: the final weights); at least one
  SkillSelection(int level, std::vector<SkillSnapshot> candidates, SelectionOptions options);

  // one slice: the next chunk of goals of the current candidate. Returns true when every
  // candidate is done. A candidate is done at `goals` goals or after a chunk that ended none.
  Result<bool> Step(const EvalFn& eval);
  bool done() const { return current_ >= candidates_.size(); }
  // the chosen candidate's index (once done)
  size_t best() const;

  int level() const { return level_; }
  const std::vector<SkillSnapshot>& candidates() const { return candidates_; }
  const std::vector<CandidateScore>& scores() const { return scores_; }
  // "candidate 3/9 (612000 env steps), 5000/20000 goals"
  std::string Progress() const;
  // one line per candidate: env steps, goals, hit rate, success; the chosen one marked
  std::string Table() const;
  // the choice (once done) of the skill named `skill`
  SkillChoice Choice(const std::string& skill) const;

 private:
  bool Better(size_t a, size_t b) const;  // a ranks above b

  int level_;
  std::vector<SkillSnapshot> candidates_;
  SelectionOptions options_;
  std::vector<CandidateScore> scores_;
  size_t current_ = 0;
  int64_t chunk_ = 0;  // chunks of the current candidate run so far
};

}  // namespace coins
