#include "orchestrator/chain_machine.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

namespace coins::chain {

namespace {

// "12.0k", "1.20M"
std::string Steps(uint64_t n) {
  if (n >= 1'000'000) return fmt::format("{:.2f}M", double(n) / 1e6);
  if (n >= 1'000) return fmt::format("{:.1f}k", double(n) / 1e3);
  return std::to_string(n);
}

bool NeverATarget(const std::string& name) { return name == "Action" || name == "Done" || name == "Reward"; }

// "Paddle 6.20, Ball 0.40, Block 7.10 (not eligible)"
std::string ListScores(const std::vector<Score>& scores) {
  std::string out;
  for (const Score& s : scores)
    out +=
        fmt::format("{}{} {:.2f}{}", out.empty() ? "" : ", ", s.target, s.score, s.eligible ? "" : " (not eligible)");
  return out.empty() ? "no scores" : out;
}

}  // namespace

const char* PhaseName(Phase p) {
  switch (p) {
    case Phase::kCollecting: return "collecting";
    case Phase::kDetecting: return "detecting";
    case Phase::kTrainingSkill: return "training-skill";
    case Phase::kTask: return "task";
    case Phase::kDone: return "done";
  }
  return "?";
}

std::optional<Phase> ParsePhase(std::string_view name) {
  for (Phase p : {Phase::kCollecting, Phase::kDetecting, Phase::kTrainingSkill, Phase::kTask, Phase::kDone})
    if (name == PhaseName(p)) return p;
  return std::nullopt;
}

ChainMachine::ChainMachine(envs::EnvSpec spec, OrchestratorOptions options) : spec_(std::move(spec)), o_(options) {
  s_.next_detect = uint64_t(o_.detect_every_steps);
  s_.note = "collecting random-action data for source Action";
  if (o_.chain == "none") {
    s_.phase = Phase::kTask;
    s_.task.started = true;
    s_.note = "no chain (orchestrator.chain none): training the task over primitive actions";
  }
}

Result<ChainMachine> ChainMachine::Restore(envs::EnvSpec spec, OrchestratorOptions options, ChainState state) {
  auto known = [&](const std::string& f) { return f == "Action" || spec.factor_index(f) >= 0; };
  if (!known(state.source))
    return Errorf("chain state: source '{}' is not a factor of env {}", state.source, spec.name);
  for (const Link& l : state.links)
    if (!known(l.spec.source) || !known(l.spec.target))
      return Errorf("chain state: link {}->{} names a factor env {} does not have", l.spec.source, l.spec.target,
                    spec.name);
  // the task acts through the top skill; only a run without a chain has it over primitive actions
  bool needs_link = state.phase == Phase::kTrainingSkill || (state.phase == Phase::kTask && options.chain != "none");
  if (needs_link && state.links.empty()) return Errorf("chain state: phase {} without a link", PhaseName(state.phase));
  if (state.seq == 0) return Errorf("chain state: seq 0 (commands start at 1)");
  ChainMachine m(std::move(spec), options);
  m.s_ = std::move(state);
  return m;
}

std::vector<std::string> ChainMachine::Targets() const {
  std::vector<std::string> out;
  for (const auto& f : spec_.factors) {
    if (NeverATarget(f.name) || f.name == s_.source) continue;
    bool controlled =
        std::any_of(s_.links.begin(), s_.links.end(), [&](const Link& l) { return l.spec.target == f.name; });
    if (!controlled) out.push_back(f.name);
  }
  return out;
}

bool ChainMachine::AnyCandidate() const {
  const std::vector<std::string> targets = Targets();
  return std::any_of(targets.begin(), targets.end(), [&](const std::string& t) {
    const int i = spec_.factor_index(t);
    return i >= 0 && !spec_.factors[size_t(i)].multi_instance;
  });
}

Command ChainMachine::command() const {
  Command c;
  c.seq = s_.seq;
  c.phase = PhaseName(s_.phase);
  c.source = s_.source;
  c.round = s_.round;
  c.epoch = s_.epoch;
  for (const Link& l : s_.links) c.links.push_back(l.spec);
  const int64_t levels = int64_t(s_.links.size());
  c.acting_level = levels;
  c.job = "idle";
  switch (s_.phase) {
    case Phase::kCollecting: c.step_base = s_.next_detect; break;
    case Phase::kDetecting:
      c.job = "detect";
      c.targets = Targets();
      c.step_base = s_.next_detect;
      break;
    case Phase::kTrainingSkill:
      c.job = "train-skill";
      c.step_base = s_.phase_start + uint64_t(o_.skill_learning_starts);
      c.steps_per_update = o_.skill_steps_per_update;
      c.step_limit = s_.phase_start + uint64_t(o_.skill_max_steps);
      break;
    case Phase::kTask:
      c.job = "train-task";
      c.acting_level = levels + 1;
      c.step_base = s_.phase_start + uint64_t(o_.task_learning_starts);
      c.steps_per_update = o_.task_steps_per_update;
      c.step_limit = s_.phase_start + uint64_t(o_.task_max_steps);
      break;
    case Phase::kDone:
      c.acting_level = s_.task.started ? levels + 1 : levels;
      c.step_base = c.step_limit = s_.phase_start;
      break;
  }
  return c;
}

void ChainMachine::SetEpoch(uint64_t epoch) {
  s_.epoch = std::max(s_.epoch, epoch);
  s_.last_cut_epoch = std::max(s_.last_cut_epoch, s_.epoch);
}

bool ChainMachine::Transition(Phase next, const std::string& note) {
  s_.phase = next;
  s_.phase_start = s_.env_steps;
  s_.seq++;
  s_.note = note;
  return true;
}

bool ChainMachine::OnEnvSteps(uint64_t env_steps) {
  s_.env_steps = std::max(s_.env_steps, env_steps);
  switch (s_.phase) {
    case Phase::kCollecting: return s_.env_steps >= s_.next_detect && StartDetecting();
    case Phase::kTrainingSkill: return CheckSkill();
    case Phase::kTask: return CheckTask();
    default: return false;
  }
}

bool ChainMachine::StartDetecting() {
  if (Targets().empty()) return EndChain(fmt::format("no uncontrolled factor left to score for source {}", s_.source));
  s_.round++;
  s_.lost_score_reports = 0;
  return Transition(Phase::kDetecting, fmt::format("detect round {} of source {} at {} env steps", s_.round, s_.source,
                                                   Steps(s_.env_steps)));
}

bool ChainMachine::OnScores(const ScoresReport& r) {
  if (s_.phase != Phase::kDetecting || r.command_seq != s_.seq || r.round != s_.round || r.source != s_.source) {
    s_.ignored_scores++;
    return false;
  }
  s_.last_scores = r.scores;
  return Decide(r);
}

const Score* ChainMachine::BestScore(const std::vector<Score>& scores) const {
  const std::vector<std::string> targets = Targets();
  const Score* best = nullptr;
  for (const Score& sc : scores) {
    if (sc.source != s_.source || !sc.eligible || !std::isfinite(sc.score) || !(sc.score > o_.eps_si)) continue;
    if (std::find(targets.begin(), targets.end(), sc.target) == targets.end()) continue;
    int i = spec_.factor_index(sc.target);
    if (i < 0 || spec_.factors[size_t(i)].multi_instance) continue;
    if (!best || sc.score > best->score) best = &sc;
  }
  return best;
}

bool ChainMachine::Decide(const ScoresReport& r) {
  if (const Score* best = BestScore(r.scores)) return Accept(*best);
  return NoLinkThisRound(fmt::format("no eligible target passes eps_SI {} ({})", o_.eps_si, ListScores(r.scores)));
}

bool ChainMachine::Accept(const Score& best) {
  Link l;
  l.spec =
      LinkSpec{best.source, best.target, best.score, best.mask, best.goal_kind, best.goal_set, best.interaction_rate};
  l.accepted_at_steps = s_.env_steps;
  s_.links.push_back(std::move(l));
  return Transition(Phase::kTrainingSkill,
                    fmt::format("{}->{} accepted in round {}: Sc_I {:.2f} > eps_SI {} ({} detections; mask and goal "
                                "set from {}); training its skill as level {}",
                                best.source, best.target, s_.round, best.score, o_.eps_si, best.interactions,
                                best.goal_interactions, s_.links.size()));
}

bool ChainMachine::NoLinkThisRound(const std::string& why) {
  const uint64_t collected = s_.next_detect - s_.source_start;
  const uint64_t every = uint64_t(o_.detect_every_steps);
  if (collected + every <= uint64_t(o_.detect_budget_steps)) {
    s_.next_detect += every;
    return Transition(Phase::kCollecting, fmt::format("round {}: {}; collecting {} more steps for source {}", s_.round,
                                                      why, Steps(every), s_.source));
  }
  return EndChain(fmt::format("round {}: {}; the detect budget of source {} ({} steps) is spent", s_.round, why,
                              s_.source, Steps(uint64_t(o_.detect_budget_steps))));
}

bool ChainMachine::EndChain(const std::string& why) {
  if (s_.links.empty()) return Transition(Phase::kDone, "done without a link: " + why);
  s_.task = TaskTracker{};
  s_.task.started = true;
  s_.task.best_at = s_.env_steps;
  return Transition(Phase::kTask, fmt::format("chain ended ({}); training the task over the {} skill", why,
                                              s_.links.back().spec.target));
}

bool ChainMachine::OnSkillCounts(int level, uint64_t started, uint64_t reached) {
  if (level < 1 || size_t(level) > s_.links.size()) return false;
  bool closed = UpdateSuccess(s_.links[size_t(level - 1)].success, started, reached, s_.env_steps,
                              o_.success_window_goals, o_.success_tolerance);
  bool current = s_.phase == Phase::kTrainingSkill && size_t(level) == s_.links.size();
  return closed && current && CheckSkill();
}

bool UpdateSuccess(SuccessTracker& t, uint64_t started, uint64_t reached, uint64_t env_steps, int64_t window_goals,
                   double tolerance) {
  // the first count, or counts that dropped (an actor restarted): a new window starts here
  if (!t.based || started < t.base_started || reached < t.base_reached) {
    t.based = true;
    t.base_started = started;
    t.base_reached = reached;
    return false;
  }
  const uint64_t ds = started - t.base_started;
  if (ds < uint64_t(window_goals)) return false;
  t.rate = std::min(1.0, double(reached - t.base_reached) / double(ds));
  t.windows++;
  t.goals += ds;
  if (t.windows == 1 || t.rate > t.best + tolerance) {
    t.best = t.rate;
    t.best_at = env_steps;
    t.best_at_goals = t.goals;
  }
  t.base_started = started;
  t.base_reached = reached;
  return true;
}

int64_t ChainMachine::Patience() const {
  return s_.links.size() == 1 ? o_.primitive_n_complete_goals : o_.n_complete_goals;
}

bool ChainMachine::CheckSkill() {
  Link& l = s_.links.back();
  const uint64_t in_phase = s_.env_steps - s_.phase_start;
  std::string why;
  if (in_phase >= uint64_t(o_.skill_max_steps)) {
    l.learned_by = "budget";
    why = fmt::format("its budget of {} steps is spent (success {:.3f})", Steps(uint64_t(o_.skill_max_steps)),
                      l.success.rate);
  } else if (l.success.windows > 0 && l.success.goals >= uint64_t(o_.skill_min_goals) &&
             l.success.goals - l.success.best_at_goals >= uint64_t(Patience())) {
    l.learned_by = "converged";
    why = fmt::format("success {:.3f} has not risen by more than {} for {} goals ({} steps)", l.success.rate,
                      o_.success_tolerance, l.success.goals - l.success.best_at_goals,
                      Steps(s_.env_steps - l.success.best_at));
  } else {
    return false;
  }
  l.learned_at_steps = s_.env_steps;
  const std::string target = l.spec.target;
  s_.source = target;
  // rounds that cannot accept anything would only spend the detect budget
  if (!AnyCandidate())
    return EndChain(
        fmt::format("{} skill learned ({}): {}; no target a skill could control remains", target, l.learned_by, why));
  s_.source_start = s_.env_steps;
  s_.next_detect = s_.env_steps + uint64_t(o_.detect_every_steps);
  s_.round = 0;
  return Transition(Phase::kCollecting, fmt::format("{} skill learned ({}): {}; collecting with it for source {}",
                                                    target, l.learned_by, why, target));
}

bool ChainMachine::OnLearner(const LearnerReport& r) {
  TrackEval(r);
  if (r.command_seq != s_.seq) return false;
  if (r.state == "failed") return LearnerFailed(r);
  if (s_.phase == Phase::kDetecting) return MissedScores(r);
  if (s_.phase == Phase::kTask) return CheckTask();
  return false;
}

void ChainMachine::TrackEval(const LearnerReport& r) {
  // only the task policy's evaluations (skills report their own: eval_success)
  if (r.job != "train-task" || r.eval_episodes == 0 || r.eval_env_steps <= s_.eval.env_steps ||
      !std::isfinite(r.eval_return_mean))
    return;
  s_.eval = Eval{r.eval_env_steps, r.eval_return_mean, r.eval_return_sd, r.eval_episodes};
  if (s_.phase != Phase::kTask || r.command_seq != s_.seq || r.eval_env_steps < s_.phase_start) return;
  TaskTracker& t = s_.task;
  t.evals++;
  if (t.evals == 1 || r.eval_return_mean > t.best + o_.task_tolerance) {
    t.best = r.eval_return_mean;
    t.best_at = r.eval_env_steps;
  }
}

bool ChainMachine::CheckTask() {
  const uint64_t in_phase = s_.env_steps - s_.phase_start;
  const TaskTracker& t = s_.task;
  if (in_phase >= uint64_t(o_.task_max_steps))
    return Transition(Phase::kDone, fmt::format("done: the task budget of {} steps is spent (best eval return {:.2f})",
                                                Steps(uint64_t(o_.task_max_steps)), t.evals ? t.best : 0.0));
  if (t.evals > 0 && in_phase >= uint64_t(o_.task_min_steps) &&
      s_.env_steps - t.best_at >= uint64_t(o_.task_n_complete_steps))
    return Transition(
        Phase::kDone,
        fmt::format("done: the task converged (eval return {:.2f} has not risen by more than {} for {} steps)", t.best,
                    o_.task_tolerance, Steps(s_.env_steps - t.best_at)));
  return false;
}

bool ChainMachine::LearnerFailed(const LearnerReport& r) {
  const std::string what = fmt::format("learner job {} failed: {}", r.job, r.message);
  switch (s_.phase) {
    case Phase::kDetecting: return NoLinkThisRound(what);
    case Phase::kTrainingSkill: {
      const LinkSpec dropped = s_.links.back().spec;
      s_.links.pop_back();
      return EndChain(fmt::format("{}; link {}->{} dropped", what, dropped.source, dropped.target));
    }
    case Phase::kTask: return Transition(Phase::kDone, "done: " + what);
    default: return false;
  }
}

bool ChainMachine::MissedScores(const LearnerReport& r) {
  // the learner says it is done with this command, having published this round's scores, yet
  // none came (else the phase changed). A learner still running the command may report the
  // round of an earlier source's scores: that is no answer to this one
  if (r.job != "detect" || r.state != "done" || r.scores_round < s_.round) return false;
  if (++s_.lost_score_reports < 3) return false;
  s_.lost_score_reports = 0;
  s_.round++;
  return Transition(Phase::kDetecting, fmt::format("the scores of round {} did not arrive; scoring again as round {}",
                                                   s_.round - 1, s_.round));
}

std::string ChainMachine::Describe() const {
  const uint64_t in_phase = s_.env_steps - s_.phase_start;
  switch (s_.phase) {
    case Phase::kCollecting:
      return fmt::format("collecting for source {}: {} of {} env steps (detect budget used {} of {})", s_.source,
                         Steps(s_.env_steps), Steps(s_.next_detect), Steps(s_.next_detect - s_.source_start),
                         Steps(uint64_t(o_.detect_budget_steps)));
    case Phase::kDetecting: {
      std::string targets;
      for (const auto& t : Targets()) targets += (targets.empty() ? "" : ", ") + t;
      return fmt::format("detecting {} -> {{{}}}: round {}", s_.source, targets, s_.round);
    }
    case Phase::kTrainingSkill: {
      const Link& l = s_.links.back();
      return fmt::format("training {}->{} (level {}): success {:.3f} (best {:.3f}, {} windows), {} of {} steps",
                         l.spec.source, l.spec.target, s_.links.size(), l.success.rate, l.success.best,
                         l.success.windows, Steps(in_phase), Steps(uint64_t(o_.skill_max_steps)));
    }
    case Phase::kTask:
      return fmt::format(
          "training the task over {}: eval return {:.2f} +- {:.2f} (best {:.2f}, {} evals), {} of {} steps",
          s_.links.empty() ? std::string("primitive actions") : s_.links.back().spec.target, s_.eval.mean, s_.eval.sd,
          s_.task.best, s_.task.evals, Steps(in_phase), Steps(uint64_t(o_.task_max_steps)));
    case Phase::kDone: return s_.note;
  }
  return s_.note;
}

Result<ChainState> TransferState(const ChainState& learned, const std::string& skill) {
  if (skill.empty()) {  // a run without a chain: its task policy, fine-tuned
    if (!learned.links.empty()) return Errorf("the run has a chain: name the skill to transfer");
    if (learned.phase != Phase::kTask && learned.phase != Phase::kDone)
      return Errorf("the run's task has not started (phase {})", PhaseName(learned.phase));
    ChainState s;
    s.phase = Phase::kTask;
    s.task.started = true;
    s.note = "fine-tuning the task policy over primitive actions";
    return s;
  }
  std::string names;
  for (const Link& l : learned.links) names += (names.empty() ? "" : ", ") + l.spec.source + "->" + l.spec.target;
  if (names.empty()) names = "none";
  size_t n = 0;
  while (n < learned.links.size() && learned.links[n].spec.target != skill) ++n;
  if (n == learned.links.size()) return Errorf("the chain has no {} skill (its links: {})", skill, names);
  if (learned.links[n].learned_at_steps == 0)
    return Errorf("the chain's {} skill is not learned yet (phase {}; links: {})", skill, PhaseName(learned.phase),
                  names);
  ChainState s;
  s.phase = Phase::kTask;
  s.source = skill;
  s.links.assign(learned.links.begin(), learned.links.begin() + std::ptrdiff_t(n + 1));
  s.task.started = true;
  s.note = fmt::format("transfer: training the task over the {} skill", skill);
  return s;
}

}  // namespace coins::chain
