#include "learner/local_run.h"

#include "actors/envs/env.h"

namespace coins {

// inserts published batches into one shard (the pool of buffers comes from a MemoryBatchSink)
class LocalRun::ShardSink final : public BatchSink {
 public:
  explicit ShardSink(ReplayService* shard) : shard_(shard) {}
  msg::TransitionBatch* Acquire() override { return pool_.Acquire(); }
  bool Publish(msg::TransitionBatch* batch) override {
    std::string why;
    const auto r = shard_->Insert(*batch, std::chrono::seconds(10), &why);
    if (r != ReplayService::InsertResult::kStored) error = "shard refused a batch: " + why;
    pool_.Release(batch);
    return r == ReplayService::InsertResult::kStored;
  }
  void Release(msg::TransitionBatch* batch) override { pool_.Release(batch); }
  bool Flush(std::chrono::milliseconds) override { return true; }
  uint64_t retries() const override { return 0; }
  std::string error;

 private:
  ReplayService* shard_;
  MemoryBatchSink pool_;
};

struct LocalRun::LocalActor {
  std::unique_ptr<ShardSink> sink;
  std::unique_ptr<Actor> actor;
  std::unique_ptr<WeightsStore> store;
  uint64_t id = 0;
};

LocalRun::~LocalRun() = default;

Actor& LocalRun::actor(int i) { return *actors_[size_t(i)]->actor; }
const envs::EnvSpec& LocalRun::spec() const { return actors_.front()->actor->spec(); }

Result<std::unique_ptr<LocalRun>> LocalRun::Create(const LocalRunOptions& o) {
  std::unique_ptr<LocalRun> run(new LocalRun());
  run->options_ = o;
  std::vector<ReplayService*> services;
  for (int k = 0; k < o.shards; ++k) {
    ResumeReport report;
    auto s = ReplayService::Open(uint32_t(k), o.replay, &report);
    if (!s.ok()) return s.status();
    services.push_back(s->get());
    run->shards_.push_back(std::move(*s));
  }
  run->source_ = std::make_unique<InProcessSource>(services);
  for (int i = 0; i < o.actors; ++i) {
    auto a = std::make_unique<LocalActor>();
    a->id = uint64_t(i);
    a->sink = std::make_unique<ShardSink>(services[size_t(i % o.shards)]);
    auto actor = Actor::Create(o.env, o.actor, uint32_t(i), o.seed, a->sink.get());
    if (!actor.ok()) return actor.status();
    a->actor = std::move(*actor);
    a->store = std::make_unique<WeightsStore>(a->actor->spec());
    run->actors_.push_back(std::move(a));
  }
  run->learner_ = std::make_unique<LearnerCore>(run->actors_.front()->actor->spec(), o.learner, o.seed);
  return run;
}

void LocalRun::Deliver(std::vector<msg::PolicyWeights>& weights) {
  for (const auto& w : weights)
    for (auto& a : actors_) {
      const uint64_t before = a->store->structure_changes();
      if (!a->store->Apply(w).ok()) continue;
      a->actor->Configure(&a->store->models(), int(command_.acting_level()), command_.seq(), a->store->versions(),
                          a->store->structure_changes() != before);
    }
  weights.clear();
}

Status LocalRun::Command(const msg::ChainCommand& command) {
  const bool acting_changed = command.acting_level() != command_.acting_level();
  command_ = command;
  LearnerCore::Outputs out;
  COINS_RETURN_IF_ERROR(learner_->OnCommand(command, &out));
  Deliver(out.weights);
  for (auto& a : actors_)
    a->actor->Configure(&a->store->models(), int(command.acting_level()), command.seq(), a->store->versions(),
                        acting_changed);
  return Status::Ok();
}

Status LocalRun::StepActors(uint64_t steps) {
  const uint64_t n = uint64_t(actors_.size());
  for (auto& a : actors_) {
    double total = double(command_.step_base()) + command_.steps_per_update() * double(learner_->status().updates());
    if (command_.step_base() == 0 && command_.steps_per_update() == 0) total = 1e18;
    if (command_.step_limit() > 0) total = std::min(total, double(command_.step_limit()));
    const uint64_t all = uint64_t(total);
    const uint64_t share = all / n + (a->id < all % n ? 1 : 0);
    const uint64_t target = std::min(share, a->actor->counters().steps + steps);
    if (target <= a->actor->counters().steps) continue;
    a->actor->Run(target, Actor::Hooks{});
    if (!a->sink->error.empty()) return Errorf("actor {}: {}", a->id, a->sink->error);
  }
  return Status::Ok();
}

Result<int> LocalRun::LearnerWork(int slices, std::optional<uint64_t> counted_steps) {
  int done = 0;
  LearnerCore::Outputs out;
  for (int i = 0; i < slices; ++i) {
    auto worked = learner_->Work(source_.get(), counted_steps.value_or(env_steps()), &out);
    if (!worked.ok()) return worked.status();
    scores_.insert(scores_.end(), out.scores.begin(), out.scores.end());
    out.scores.clear();
    Deliver(out.weights);
    if (!*worked) break;
    ++done;
  }
  return done;
}

uint64_t LocalRun::env_steps() const {
  uint64_t n = 0;
  for (const auto& a : actors_) n += a->actor->counters().steps;
  return n;
}

uint64_t LocalRun::rejected() const {
  uint64_t n = 0;
  for (const auto& a : actors_) n += a->store->rejected();
  return n;
}

}  // namespace coins
