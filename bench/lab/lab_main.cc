// scratch experiment: the Breakout chain in one process with scripted phase changes
#include <cstdio>
#include <cstdlib>

#include "learner/local_run.h"

using namespace coins;

msg::ChainCommand Cmd(uint64_t seq, const std::string& job, int acting, uint64_t step_base, double spu = 0) {
  msg::ChainCommand c;
  c.schema_version(msg::CHAIN_COMMAND_SCHEMA);
  c.seq(seq);
  c.job(job);
  c.acting_level(acting);
  c.step_base(step_base);
  c.steps_per_update(spu);
  return c;
}
msg::LinkSpec LinkFrom(const msg::InteractionScore& s) {
  msg::LinkSpec l;
  l.source(s.source()); l.target(s.target()); l.score(s.score()); l.mask(s.mask());
  l.goal_kind(s.goal_kind()); l.goal_set(s.goal_set()); l.interaction_rate(s.interaction_rate());
  return l;
}
double Env(const char* k, double d) { return getenv(k) ? atof(getenv(k)) : d; }

int main() {
  LocalRunOptions o;
  o.seed = uint64_t(Env("SEED", 1));
  o.actor.batch_rows = 256;
  o.replay.capacity = 1000000;
  o.replay.capacity_mb = 256;
  o.learner.eval_every_steps = int64_t(Env("EVAL", 20000));
  o.learner.eval_goals = 100;
  o.learner.skill.explore = Env("SKILL_EXPLORE", o.learner.skill.explore);
  o.learner.skill.lr = Env("SKILL_LR", o.learner.skill.lr);
  o.learner.skill.n_step = int64_t(Env("SKILL_NSTEP", o.learner.skill.n_step));
  o.learner.skill.her_ratio = Env("SKILL_HER", o.learner.skill.her_ratio);
  o.learner.skill.decision_period = int64_t(Env("SKILL_PERIOD", o.learner.skill.decision_period));
  o.learner.detector_retrain_steps = int64_t(Env("RETRAIN", o.learner.detector_retrain_steps));
  o.learner.eval_episodes = int64_t(Env("EVAL_EPISODES", 10));
  auto made = LocalRun::Create(o);
  if (!made.ok()) { printf("%s\n", made.status().message().c_str()); return 1; }
  LocalRun& r = **made;
  uint64_t seq = 1;
  auto check = [](const Status& s) { if (!s.ok()) { printf("error: %s\n", s.message().c_str()); exit(1); } };
  auto work = [&](uint64_t until, int level) {
    uint64_t last = 0;
    while (r.env_steps() < until) {
      check(r.StepActors(200));
      auto w = r.LearnerWork(1000);
      if (!w.ok()) { printf("error %s\n", w.status().message().c_str()); exit(1); }
      const auto st = r.learner().status();
      if (st.eval_env_steps() != last) {
        last = st.eval_env_steps();
        const auto& c = r.actor(0).counters().hierarchy;
        printf("  [%lu] eval success %.3f hit %.3f acc %.3f return %.1f±%.1f | updates %lu loss %.3f | actor0 L%d ended %lu reached %lu | det fp %lu fn %lu truth %lu states %lu\n",
               last, st.eval_success(), st.eval_hit_rate(), st.eval_angle_accuracy(), st.eval_return_mean(), st.eval_return_sd(), st.updates(), st.loss(), level,
               c.goals_ended[level - 1], c.goals_reached[level - 1], c.detector_fp, c.detector_fn, c.detector_truth,
               c.detector_states);
        fflush(stdout);
      }
    }
  };
  // 1. random data, detect from the action
  check(r.Command(Cmd(seq++, "idle", 0, 10000)));
  check(r.StepActors(1 << 30));
  auto detect = Cmd(seq++, "detect", 0, r.env_steps());
  detect.source("Action"); detect.targets({"Paddle", "Ball", "Block"}); detect.round(1);
  check(r.Command(detect));
  auto w = r.LearnerWork(1);
  const auto& sc = r.scores().back().scores();
  const msg::InteractionScore* best = nullptr;
  for (const auto& s : sc) { printf("Action->%s Sc_I %.2f pass %d n %lu\n", s.target().c_str(), s.score(), s.pass(), s.interactions()); if (s.pass() && s.eligible() && (!best || s.score() > best->score())) best = &s; }
  std::vector<msg::LinkSpec> links = {LinkFrom(*best)};
  // 2. paddle skill
  auto train = Cmd(seq++, "train-skill", 1, r.env_steps() + 1000, 1.0);
  train.links(links);
  check(r.Command(train));
  work(r.env_steps() + uint64_t(Env("PADDLE_STEPS", 20000)), 1);
  // 3. collect with the paddle skill and detect from the paddle
  uint64_t round = 1;
  const msg::InteractionScore* ball = nullptr;
  while (!ball) {
    auto collect = Cmd(seq++, "idle", 1, r.env_steps() + 20000);
    collect.links(links);
    check(r.Command(collect));
    check(r.StepActors(1 << 30));
    auto d = Cmd(seq++, "detect", 1, r.env_steps());
    d.links(links); d.source("Paddle"); d.targets({"Ball", "Block"}); d.round(round++);
    check(r.Command(d));
    auto ww = r.LearnerWork(1);
    if (!ww.ok()) { printf("%s\n", ww.status().message().c_str()); return 1; }
    for (const auto& s : r.scores().back().scores()) {
      printf("%lu steps: Paddle->%s Sc_I %.2f pass %d n %lu kind %s goals %zu rate %.4f\n", r.env_steps(), s.target().c_str(), s.score(), s.pass(), s.interactions(), s.goal_kind().c_str(), s.goal_set().size(), s.interaction_rate());
      if (s.pass() && s.eligible()) ball = &s;
    }
  }
  links.push_back(LinkFrom(*ball));
  // 4. ball skill
  auto tb = Cmd(seq++, "train-skill", 2, r.env_steps() + uint64_t(Env("BALL_START", 5000)), Env("BALL_SPU", 2.0));
  tb.links(links);
  check(r.Command(tb));
  work(r.env_steps() + uint64_t(Env("BALL_STEPS", 150000)), 2);
  // 5. the task over the ball skill
  auto tt = Cmd(seq++, "train-task", 3, r.env_steps() + uint64_t(Env("TASK_START", 2000)), Env("TASK_SPU", 4.0));
  tt.links(links);
  check(r.Command(tt));
  work(r.env_steps() + uint64_t(Env("TASK_STEPS", 150000)), 2);
  return 0;
}
