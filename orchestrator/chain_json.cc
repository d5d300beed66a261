// ChainState <-> JSON (chain_store.h). Non-finite numbers are written as null and read back as
// NaN; every field is type-checked on read, and the first wrong one is named.
#include <cmath>
#include <limits>

#include "orchestrator/chain_store.h"

namespace coins::chain {

namespace {

using nlohmann::json;

json Num(double x) { return std::isfinite(x) ? json(x) : json(nullptr); }

// reads typed fields of one JSON object, remembering the first error
class JsonIn {
 public:
  JsonIn(const json& j, std::string where, Status* status) : j_(j), where_(std::move(where)), status_(status) {
    if (!j_.is_object()) Fail("", "expected an object");
  }
  void U64(const char* k, uint64_t& v) {
    if (const json* x = Get(k, "a non-negative integer", [](const json& e) { return e.is_number_unsigned(); }))
      v = x->get<uint64_t>();
  }
  void F64(const char* k, double& v) {
    if (const json* x = Get(k, "a number", [](const json& e) { return e.is_number() || e.is_null(); }))
      v = x->is_null() ? std::numeric_limits<double>::quiet_NaN() : x->get<double>();
  }
  void Str(const char* k, std::string& v) {
    if (const json* x = Get(k, "a string", [](const json& e) { return e.is_string(); })) v = x->get<std::string>();
  }
  void Bool(const char* k, bool& v) {
    if (const json* x = Get(k, "true or false", [](const json& e) { return e.is_boolean(); })) v = x->get<bool>();
  }
  void Floats(const char* k, std::vector<float>& v) {
    const json* x = Get(k, "a list of numbers", [](const json& e) { return e.is_array(); });
    if (!x) return;
    v.clear();
    for (const json& e : *x) {
      if (!e.is_number() && !e.is_null()) return Fail(k, "expected a list of numbers");
      v.push_back(e.is_null() ? std::numeric_limits<float>::quiet_NaN() : e.get<float>());
    }
  }
  // a nested object or list, or nullptr (with the error recorded)
  const json* Object(const char* k) {
    return Get(k, "an object", [](const json& e) { return e.is_object(); });
  }
  const json* List(const char* k) {
    return Get(k, "a list", [](const json& e) { return e.is_array(); });
  }
  bool Has(const char* k) const { return j_.is_object() && j_.contains(k); }
  std::string Where(const std::string& k) const { return where_.empty() ? k : where_ + "." + k; }
  bool ok() const { return status_->ok(); }

 private:
  template <typename Check>
  const json* Get(const char* k, const char* what, Check check) {
    if (!ok() || !j_.is_object()) return nullptr;
    auto it = j_.find(k);
    if (it == j_.end()) return Fail(k, "is missing"), nullptr;
    if (!check(*it)) return Fail(k, std::string("expected ") + what), nullptr;
    return &*it;
  }
  void Fail(const std::string& k, const std::string& what) {
    if (ok()) *status_ = Errorf("field '{}' {}", Where(k), what);
  }
  const json& j_;
  std::string where_;
  Status* status_;
};

json ToJson(const LinkSpec& l) {
  return {{"source", l.source},
          {"target", l.target},
          {"score", Num(l.score)},
          {"mask", l.mask},
          {"goal_kind", l.goal_kind},
          {"goal_set", l.goal_set},
          {"interaction_rate", Num(l.interaction_rate)}};
}
void FromJson(JsonIn in, LinkSpec& l) {
  in.Str("source", l.source), in.Str("target", l.target), in.F64("score", l.score), in.Floats("mask", l.mask);
  in.Str("goal_kind", l.goal_kind), in.Floats("goal_set", l.goal_set), in.F64("interaction_rate", l.interaction_rate);
}

json ToJson(const SuccessTracker& t) {
  return {{"based", t.based},
          {"base_started", t.base_started},
          {"base_reached", t.base_reached},
          {"windows", t.windows},
          {"rate", Num(t.rate)},
          {"best", Num(t.best)},
          {"best_at", t.best_at},
          {"goals", t.goals},
          {"best_at_goals", t.best_at_goals}};
}
void FromJson(JsonIn in, SuccessTracker& t) {
  in.Bool("based", t.based), in.U64("base_started", t.base_started), in.U64("base_reached", t.base_reached);
  in.U64("windows", t.windows), in.F64("rate", t.rate), in.F64("best", t.best), in.U64("best_at", t.best_at);
  in.U64("goals", t.goals), in.U64("best_at_goals", t.best_at_goals);
}

json ToJson(const Link& l) {
  return {{"spec", ToJson(l.spec)},
          {"accepted_at_steps", l.accepted_at_steps},
          {"learned_at_steps", l.learned_at_steps},
          {"learned_by", l.learned_by},
          {"success", ToJson(l.success)}};
}
void FromJson(JsonIn in, Status* st, Link& l) {
  if (const json* s = in.Object("spec")) FromJson(JsonIn(*s, in.Where("spec"), st), l.spec);
  in.U64("accepted_at_steps", l.accepted_at_steps), in.U64("learned_at_steps", l.learned_at_steps);
  in.Str("learned_by", l.learned_by);
  if (const json* s = in.Object("success")) FromJson(JsonIn(*s, in.Where("success"), st), l.success);
}

json ToJson(const Score& s) {
  return {{"source", s.source},
          {"target", s.target},
          {"score", Num(s.score)},
          {"mg_score", Num(s.mg_score)},
          {"interactions", s.interactions},
          {"chance_interactions", Num(s.chance_interactions)},
          {"goal_interactions", s.goal_interactions},
          {"transitions", s.transitions},
          {"pass", s.pass},
          {"eligible", s.eligible},
          {"note", s.note},
          {"mask", s.mask},
          {"goal_kind", s.goal_kind},
          {"goal_set", s.goal_set},
          {"interaction_rate", Num(s.interaction_rate)},
          {"train_seconds", Num(s.train_seconds)}};
}
void FromJson(JsonIn in, Score& s) {
  in.Str("source", s.source), in.Str("target", s.target), in.F64("score", s.score), in.F64("mg_score", s.mg_score);
  in.U64("interactions", s.interactions), in.U64("transitions", s.transitions), in.Bool("pass", s.pass);
  in.Bool("eligible", s.eligible), in.Str("note", s.note), in.Floats("mask", s.mask), in.Str("goal_kind", s.goal_kind);
  in.Floats("goal_set", s.goal_set), in.F64("interaction_rate", s.interaction_rate);
  in.F64("train_seconds", s.train_seconds);
  // states written before the chance count was kept have none: 0
  if (in.Has("chance_interactions")) in.F64("chance_interactions", s.chance_interactions);
  // nor the count behind the mask and goal set (before it came from all the round's detections)
  if (in.Has("goal_interactions")) in.U64("goal_interactions", s.goal_interactions);
}

}  // namespace

json StateToJson(const ChainState& s) {
  json links = json::array(), scores = json::array();
  for (const Link& l : s.links) links.push_back(ToJson(l));
  for (const Score& x : s.last_scores) scores.push_back(ToJson(x));
  return {
      {"phase", PhaseName(s.phase)},
      {"seq", s.seq},
      {"source", s.source},
      {"links", links},
      {"round", s.round},
      {"source_start", s.source_start},
      {"next_detect", s.next_detect},
      {"phase_start", s.phase_start},
      {"env_steps", s.env_steps},
      {"last_scores", scores},
      {"lost_score_reports", s.lost_score_reports},
      {"ignored_scores", s.ignored_scores},
      {"eval",
       {{"env_steps", s.eval.env_steps},
        {"mean", Num(s.eval.mean)},
        {"sd", Num(s.eval.sd)},
        {"episodes", s.eval.episodes}}},
      {"task",
       {{"started", s.task.started}, {"evals", s.task.evals}, {"best", Num(s.task.best)}, {"best_at", s.task.best_at}}},
      {"epoch", s.epoch},
      {"last_cut_epoch", s.last_cut_epoch},
      {"note", s.note}};
}

Result<ChainState> StateFromJson(const json& j) {
  ChainState s;
  Status st;
  JsonIn in(j, "state", &st);
  std::string phase;
  in.Str("phase", phase);
  if (st.ok() && !ParsePhase(phase)) st = Errorf("field 'state.phase': unknown phase '{}'", phase);
  if (st.ok()) s.phase = *ParsePhase(phase);
  in.U64("seq", s.seq), in.Str("source", s.source), in.U64("round", s.round), in.U64("source_start", s.source_start);
  in.U64("next_detect", s.next_detect), in.U64("phase_start", s.phase_start), in.U64("env_steps", s.env_steps);
  in.U64("lost_score_reports", s.lost_score_reports), in.U64("ignored_scores", s.ignored_scores);
  in.U64("epoch", s.epoch), in.U64("last_cut_epoch", s.last_cut_epoch), in.Str("note", s.note);
  if (const json* links = in.List("links"))
    for (size_t i = 0; i < links->size() && st.ok(); ++i)
      FromJson(JsonIn((*links)[i], "state.links[" + std::to_string(i) + "]", &st), &st, s.links.emplace_back());
  if (const json* scores = in.List("last_scores"))
    for (size_t i = 0; i < scores->size() && st.ok(); ++i)
      FromJson(JsonIn((*scores)[i], "state.last_scores[" + std::to_string(i) + "]", &st), s.last_scores.emplace_back());
  if (const json* e = in.Object("eval")) {
    JsonIn ev(*e, "state.eval", &st);
    uint64_t episodes = 0;
    ev.U64("env_steps", s.eval.env_steps), ev.F64("mean", s.eval.mean), ev.F64("sd", s.eval.sd);
    ev.U64("episodes", episodes);
    s.eval.episodes = uint32_t(episodes);
  }
  if (const json* t = in.Object("task")) {
    JsonIn tk(*t, "state.task", &st);
    tk.Bool("started", s.task.started), tk.U64("evals", s.task.evals), tk.F64("best", s.task.best);
    tk.U64("best_at", s.task.best_at);
  }
  if (!st.ok()) return st;
  return s;
}

}  // namespace coins::chain
