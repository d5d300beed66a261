#include "orchestrator/chain_messages.h"

#include <algorithm>

namespace coins {

msg::LinkSpec ToMessage(const chain::LinkSpec& l) {
  msg::LinkSpec m;
  m.source(l.source);
  m.target(l.target);
  m.score(l.score);
  m.mask(l.mask);
  m.goal_kind(l.goal_kind);
  m.goal_set(l.goal_set);
  m.interaction_rate(l.interaction_rate);
  return m;
}

namespace {

msg::ChainLink ToChainLink(const chain::Link& l, bool training) {
  msg::ChainLink m;
  m.source(l.spec.source);
  m.target(l.spec.target);
  m.score(l.spec.score);
  m.mask(l.spec.mask);
  m.goal_kind(l.spec.goal_kind);
  m.goal_set(l.spec.goal_set);
  m.skill_success(l.success.windows ? l.success.rate : 0.0);
  m.state(l.learned_at_steps ? "learned" : training ? "training" : "accepted");
  m.accepted_at_steps(l.accepted_at_steps);
  m.learned_at_steps(l.learned_at_steps);
  return m;
}

chain::Score FromMessage(const msg::InteractionScore& m) {
  chain::Score s;
  s.source = m.source();
  s.target = m.target();
  s.score = m.score();
  s.mg_score = m.mg_score();
  s.interactions = m.interactions();
  s.chance_interactions = m.chance_interactions();
  s.goal_interactions = m.goal_interactions();
  s.transitions = m.transitions();
  s.pass = m.pass();
  s.eligible = m.eligible();
  s.note = m.note();
  s.mask = m.mask();
  s.goal_kind = m.goal_kind();
  s.goal_set = m.goal_set();
  s.interaction_rate = m.interaction_rate();
  s.train_seconds = m.train_seconds();
  return s;
}

}  // namespace

msg::ChainCommand ToMessage(const chain::Command& c, const std::string& run_id) {
  msg::ChainCommand m;
  m.schema_version(msg::CHAIN_COMMAND_SCHEMA);
  m.run_id(run_id);
  m.seq(c.seq);
  m.phase(c.phase);
  m.job(c.job);
  m.source(c.source);
  m.targets(c.targets);
  m.round(c.round);
  for (const auto& l : c.links) m.links().push_back(ToMessage(l));
  m.acting_level(int32_t(c.acting_level));
  m.step_base(c.step_base);
  m.steps_per_update(c.steps_per_update);
  m.step_limit(c.step_limit);
  m.epoch(c.epoch);
  return m;
}

chain::ScoresReport FromMessage(const msg::InteractionScores& m) {
  chain::ScoresReport r;
  r.command_seq = m.command_seq();
  r.round = m.round();
  r.env_steps = m.env_steps();
  r.source = m.source();
  for (const auto& s : m.scores()) r.scores.push_back(FromMessage(s));
  return r;
}

chain::LearnerReport FromMessage(const msg::LearnerStatus& m) {
  chain::LearnerReport r;
  r.command_seq = m.command_seq();
  r.job = m.job();
  r.state = m.state();
  r.message = m.message();
  r.scores_round = m.scores_round();
  r.eval_env_steps = m.eval_env_steps();
  r.eval_return_mean = m.eval_return_mean();
  r.eval_return_sd = m.eval_return_sd();
  r.eval_episodes = m.eval_episodes();
  return r;
}

msg::InteractionScore ToMessage(const chain::Score& s) {
  msg::InteractionScore m;
  m.source(s.source);
  m.target(s.target);
  m.score(s.score);
  m.mg_score(s.mg_score);
  m.interactions(s.interactions);
  m.chance_interactions(s.chance_interactions);
  m.goal_interactions(s.goal_interactions);
  m.transitions(s.transitions);
  m.pass(s.pass);
  m.eligible(s.eligible);
  m.note(s.note);
  m.mask(s.mask);
  m.goal_kind(s.goal_kind);
  m.goal_set(s.goal_set);
  m.interaction_rate(s.interaction_rate);
  m.train_seconds(s.train_seconds);
  return m;
}

msg::ChainStatus ToChainStatus(const chain::ChainMachine& machine, const std::string& run_id,
                               const std::string& message) {
  const chain::ChainState& s = machine.state();
  msg::ChainStatus m;
  m.schema_version(msg::STATUS_SCHEMA);
  m.run_id(run_id);
  m.phase(chain::PhaseName(s.phase));
  m.env_steps(s.env_steps);
  for (size_t i = 0; i < s.links.size(); ++i)
    m.links().push_back(ToChainLink(s.links[i], s.phase == chain::Phase::kTrainingSkill && i + 1 == s.links.size()));
  m.source(s.source);
  m.round(s.round);
  for (const auto& sc : s.last_scores) m.last_scores().push_back(ToMessage(sc));
  m.eval_return_mean(s.eval.mean);
  m.eval_return_sd(s.eval.sd);
  m.eval_env_steps(s.eval.env_steps);
  m.epoch(s.epoch);
  m.message(message);
  return m;
}

void GoalCounter::Add(const msg::ActorStats& s) {
  Counts& c = actors_[s.actor_id()];
  const size_t n = std::max(s.goals_started().size(), s.goals_reached().size());
  for (auto* v : {&c.started, &c.reached, &c.carried_started, &c.carried_reached})
    if (v->size() < n) v->resize(n, 0);
  for (size_t i = 0; i < n; ++i) {
    uint64_t st = i < s.goals_started().size() ? s.goals_started()[i] : 0;
    uint64_t re = i < s.goals_reached().size() ? s.goals_reached()[i] : 0;
    // a drop: a new incarnation counting from 0; keep what the old one had counted
    if (st < c.started[i] || re < c.reached[i]) {
      c.carried_started[i] += c.started[i];
      c.carried_reached[i] += c.reached[i];
    }
    c.started[i] = st;
    c.reached[i] = re;
  }
}

std::pair<uint64_t, uint64_t> GoalCounter::Level(int level) const {
  uint64_t started = 0, reached = 0;
  const size_t i = size_t(level - 1);
  for (const auto& [id, c] : actors_) {
    if (level < 1 || i >= c.started.size()) continue;
    started += c.started[i] + c.carried_started[i];
    reached += c.reached[i] + c.carried_reached[i];
  }
  return {started, reached};
}

int GoalCounter::levels() const {
  size_t n = 0;
  for (const auto& [id, c] : actors_) n = std::max(n, c.started.size());
  return int(n);
}

}  // namespace coins
