// The skill hierarchy an actor runs in one environment (paper section 3.4, Algorithm 1): each
// level picks goals for the level below and holds them until the child's goal ends or its own
// decision period runs out; level 1 picks primitive actions. The top acting level of a skill
// being trained draws its own goals at random; the task level (above the top skill) has none.
//
// A goal ends when it is reached (with the link's interaction when the level requires one and
// terminates on interactions; when it does not, the target at the goal is enough, though only a
// reach with the interaction is a success), at any link interaction when the level terminates
// on interactions, at its timeout, when the parent chooses anew, or at the episode's end.
// Interactions come from the learned detector (detector/online_detector.h), never from the
// simulator's labels; those are only counted against the detector for the figures.
//
// Rows go to a RowSink per stream (see idl/transition.idl): stream 0 gets every env step,
// stream L >= 2 one row per decision of level L. Plain C++: no DDS. One thread at a time.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <random>
#include <span>
#include <vector>

#include "common/env_spec.h"
#include "common/policy/level_spec.h"
#include "common/policy/policy_net.h"
#include "detector/online_detector.h"

namespace coins {

// What the actor has received for each level: its spec, network and detector. Shared by the
// actor's envs; replaced between steps.
struct LevelModel {
  policy::PolicyNet net;
  uint64_t version = 0;                                // weights version (0: none)
  bool trained = false;                                // false: act at random (spec only, or no learner updates yet)
  std::unique_ptr<detector::OnlineDetector> detector;  // the link's detector, when loaded
  uint64_t detector_version = 0;
  int interaction_bit = -1;  // the env's ground-truth bit of the link, -1 when unlabelled
  const policy::LevelSpec& spec() const { return net.spec(); }
};

struct HierarchyModels {
  std::vector<std::unique_ptr<LevelModel>> levels;  // index level - 1; null: not received
  LevelModel* at(int level) const {
    return level >= 1 && size_t(level) <= levels.size() ? levels[size_t(level) - 1].get() : nullptr;
  }
  // the highest level L such that levels 1..L all have a spec, and the detector their spec
  // names (a level never acts without the detector that ends its goals and rewards it)
  int contiguous() const;
};

class RowSink {
 public:
  virtual ~RowSink() = default;
  // stream 0: env steps; stream L >= 2: decisions of level L. goal has the layout's goal_dim
  // floats (the target factor's features, masked ones set), action its action_dim floats.
  virtual void Row(int stream, std::span<const float> state, std::span<const float> action, std::span<const float> goal,
                   float reward, uint16_t flags, uint8_t skill_level, uint32_t interactions) = 0;
};

struct HierarchyCounters {
  // per level (index level - 1): goals that ended as attempts (reached, an interaction, the
  // timeout, or an episode's end for a level whose goals are interactions), and of them reached
  uint64_t goals_ended[8] = {}, goals_reached[8] = {};
  // of the attempts, those ended by a detected link interaction (a bounce, reached or not)
  uint64_t goals_interacted[8] = {};
  // of the attempts, those whose target was at the goal when it ended, with or without a detected
  // interaction (a block placed within the tolerance; goals_reached also needs the interaction)
  uint64_t goals_arrived[8] = {};
  // goals of a level whose goals are interactions that an episode end with a positive reward
  // cut before any interaction (Breakout: the ball skill's goal when the last block breaks): no
  // chance to be met, so not attempts (not in goals_ended)
  uint64_t goals_cut_by_win[8] = {};
  // child goals a level chose outside the child's goal space, clipped to it (per child level)
  uint64_t goals_clipped[8] = {};
  // the top acting link's detector against the env's labels
  uint64_t detector_states = 0, detector_truth = 0, detector_fp = 0, detector_fn = 0;
};

class HierarchyRunner {
 public:
  // layout: the row widths (action_dim, goal_dim) of the actor's batches
  HierarchyRunner(const envs::EnvSpec& spec, int action_dim, int goal_dim, uint64_t seed);

  // levels 1..acting run (acting 0: uniform random primitive actions; acting = top skill + 1 with
  // a task spec: the task on top); explore false: greedy everywhere (evaluation), except that
  // the acting level then explores with `eval_explore` (a task's evaluation epsilon)
  void Configure(const HierarchyModels* models, int acting, bool explore, float eval_explore = 0.0f);
  int acting() const { return acting_; }
  // the acting skill's random continuous goals drawn with this sample ratio instead of its
  // spec's (policy::RandomGoal; a skill evaluated on other goals); negative: the spec's
  void SetGoalSampleRatio(float ratio) { goal_sample_ratio_ = ratio; }

  // opens new segments in every active stream at `state` (ROW_SEGMENT_START rows, with
  // ROW_EPISODE_START at an episode's first state); goals and decisions start afresh
  void StartEpisode(std::span<const float> state, RowSink* sink, bool episode_start = true);
  // chooses the env action for `state` (goals top-down, then the primitive action)
  void Decide(std::span<const float> state, std::span<float> env_action);
  // after env.Step: ends goals and decisions, emits rows. done: the episode ended (terminal or
  // truncated: `truncated` tells which)
  void Observe(std::span<const float> state, std::span<const float> env_action, std::span<const float> next,
               float reward, bool done, bool truncated, uint32_t interactions, RowSink* sink);

  const HierarchyCounters& counters() const { return counters_; }
  // the goal (masked values) of a level in force now, for rendering and tests
  std::span<const float> goal(int level) const;

 private:
  struct LevelState {
    bool has_goal = false;
    std::vector<float> goal;  // masked values
    int goal_steps = 0;
    bool action_active = false;
    std::vector<float> action;  // the level's own action (row width)
    int action_steps = 0;
    float reward_sum = 0.0f;
    bool interaction_seen = false;
  };
  struct Ends {  // per level, this step
    bool terminated = false, success = false, natural = false, goal_end = false, action_end = false;
    bool interaction = false, reached = false;
  };

  bool is_skill(int level) const;
  void ChooseAction(int level, std::span<const float> state);
  void Act(int level, const float* obs, float* action);
  void DetectInteractions(std::span<const float> state, std::span<const float> env_action, std::span<const float> next,
                          uint32_t interactions);
  void EndGoals(std::span<const float> next, bool done);
  void EmitRows(std::span<const float> next, std::span<const float> env_action, float reward, bool done, bool truncated,
                uint32_t interactions, RowSink* sink);
  std::span<const float> FullGoal(int level);

  const envs::EnvSpec& env_;
  int action_dim_, goal_dim_;
  std::mt19937_64 rng_;
  const HierarchyModels* models_ = nullptr;
  int acting_ = 0;
  bool explore_ = true;
  float eval_explore_ = 0.0f;
  float goal_sample_ratio_ = -1.0f;
  std::vector<LevelState> levels_;  // index level - 1
  std::vector<Ends> ends_;
  std::vector<float> features_, obs_, achieved_, full_goal_, zero_action_, row_action_;
  HierarchyCounters counters_;
};

}  // namespace coins
