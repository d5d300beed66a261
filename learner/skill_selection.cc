#include "learner/skill_selection.h"

#include <algorithm>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

namespace coins {

namespace {
// env seeds of consecutive chunks lie this far apart, so that no two chunks share an episode
constexpr uint64_t kChunkSeedStride = 100003;
}  // namespace

void SkillSnapshots::Start(int level, uint64_t env_steps) { Restore(level, env_steps + every_, {}); }

void SkillSnapshots::Add(uint64_t env_steps, std::vector<uint8_t> acting) {
  if (!enabled()) return;
  all_.push_back({env_steps, std::move(acting)});
  while (all_.size() > size_t(capacity_)) all_.pop_front();
  next_at_ = env_steps + every_;
}

void SkillSnapshots::Restore(int level, uint64_t next_at, std::deque<SkillSnapshot> all) {
  level_ = level;
  next_at_ = next_at;
  all_ = std::move(all);
  while (all_.size() > size_t(std::max(capacity_, 0))) all_.pop_front();
}

SkillSelection::SkillSelection(int level, std::vector<SkillSnapshot> candidates, SelectionOptions options)
    : level_(level), candidates_(std::move(candidates)), options_(options), scores_(candidates_.size()) {
  options_.goals = std::max<int64_t>(options_.goals, 1);
  options_.chunk_goals = std::clamp<int64_t>(options_.chunk_goals, 1, options_.goals);
}

Result<bool> SkillSelection::Step(const EvalFn& eval) {
  if (done()) return true;
  CandidateScore& s = scores_[current_];
  const int64_t goals = std::min<int64_t>(options_.chunk_goals, options_.goals - int64_t(s.goals));
  const uint64_t seed = options_.seed + uint64_t(chunk_) * kChunkSeedStride;
  auto r = eval(candidates_[current_].acting, goals, options_.chunk_max_steps, seed);
  if (!r.ok())
    return r.status().WithContext(fmt::format("candidate {} of {} ({} env steps)", current_ + 1, candidates_.size(),
                                              candidates_[current_].env_steps));
  s.goals += r->goals_ended;
  s.reached += r->goals_reached;
  s.interacted += r->goals_interacted;
  s.steps += r->steps;
  ++chunk_;
  if (int64_t(s.goals) >= options_.goals || r->goals_ended == 0) {
    ++current_;
    chunk_ = 0;
  }
  return done();
}

bool SkillSelection::Better(size_t a, size_t b) const {
  const CandidateScore &x = scores_[a], &y = scores_[b];
  const double x1 = options_.by_interaction ? x.hit_rate() : x.success();
  const double y1 = options_.by_interaction ? y.hit_rate() : y.success();
  if (x1 != y1) return x1 > y1;
  const double x2 = options_.by_interaction ? x.success() : x.hit_rate();
  const double y2 = options_.by_interaction ? y.success() : y.hit_rate();
  if (x2 != y2) return x2 > y2;
  return a > b;
}

size_t SkillSelection::best() const {
  size_t best = 0;
  for (size_t i = 1; i < scores_.size(); ++i)
    if (Better(i, best)) best = i;
  return best;
}

std::string SkillSelection::Progress() const {
  if (done()) return fmt::format("{} candidates evaluated", candidates_.size());
  return fmt::format("candidate {}/{} ({} env steps), {}/{} goals", current_ + 1, candidates_.size(),
                     candidates_[current_].env_steps, scores_[current_].goals, options_.goals);
}

std::string SkillSelection::Table() const {
  std::string out;
  const size_t chosen = done() ? best() : candidates_.size();
  for (size_t i = 0; i < candidates_.size(); ++i) {
    const CandidateScore& s = scores_[i];
    out += fmt::format("{} {:>9} env steps: {} goals, hit rate {:.4f}, success {:.4f}{}\n", i == chosen ? '*' : ' ',
                       candidates_[i].env_steps, s.goals, s.hit_rate(), s.success(),
                       i + 1 == candidates_.size() ? " (final)" : "");
  }
  return out;
}

SkillChoice SkillSelection::Choice(const std::string& skill) const {
  const size_t b = best(), f = candidates_.size() - 1;
  SkillChoice c;
  c.level = level_;
  c.skill = skill;
  c.candidates = candidates_.size();
  c.goals = scores_[b].goals;
  c.env_steps = candidates_[b].env_steps;
  c.hit_rate = scores_[b].hit_rate();
  c.success = scores_[b].success();
  c.final_env_steps = candidates_[f].env_steps;
  c.final_hit_rate = scores_[f].hit_rate();
  c.final_success = scores_[f].success();
  return c;
}

nlohmann::json ToJson(const SkillChoice& c) {
  return {{"level", c.level},
          {"skill", c.skill},
          {"candidates", c.candidates},
          {"goals", c.goals},
          {"env_steps", c.env_steps},
          {"hit_rate", c.hit_rate},
          {"success", c.success},
          {"final_env_steps", c.final_env_steps},
          {"final_hit_rate", c.final_hit_rate},
          {"final_success", c.final_success}};
}

Result<std::vector<SkillChoice>> SkillChoicesFromJson(const nlohmann::json& list) {
  std::vector<SkillChoice> out;
  try {
    for (const auto& j : list) {
      SkillChoice c;
      c.level = j.at("level").get<int>();
      c.skill = j.at("skill").get<std::string>();
      c.candidates = j.at("candidates").get<uint64_t>();
      c.goals = j.at("goals").get<uint64_t>();
      c.env_steps = j.at("env_steps").get<uint64_t>();
      c.hit_rate = j.at("hit_rate").get<double>();
      c.success = j.at("success").get<double>();
      c.final_env_steps = j.at("final_env_steps").get<uint64_t>();
      c.final_hit_rate = j.at("final_hit_rate").get<double>();
      c.final_success = j.at("final_success").get<double>();
      out.push_back(std::move(c));
    }
  } catch (const nlohmann::json::exception& e) {
    return Errorf("skill_choices: {}", e.what());
  }
  return out;
}

}  // namespace coins
