#include "actors/weights_store.h"

#include <algorithm>

#include <nlohmann/json.hpp>

#include "common/policy/weights_msg.h"
#include "detector/online_detector.h"
#include "detector/transitions.h"

namespace coins {

std::vector<uint64_t> WeightsStore::versions() const {
  std::vector<uint64_t> v(8, 0);
  for (size_t i = 0; i < models_.levels.size() && i < v.size(); ++i)
    if (models_.levels[i]) v[i] = models_.levels[i]->version;
  return v;
}

Status WeightsStore::Apply(const msg::PolicyWeights& w) {
  auto it = held_.find(w.name());
  Status s = policy::CheckWeights(w, it == held_.end() ? 0 : it->second);
  if (s.ok()) s = w.name().rfind("detector/", 0) == 0 ? ApplyDetector(w) : ApplyLevel(w);
  if (!s.ok()) {
    ++rejected_;
    return s;
  }
  held_[w.name()] = w.version();
  return Status::Ok();
}

Status WeightsStore::ApplyLevel(const msg::PolicyWeights& w) {
  auto spec = policy::ParseLevelSpec(w.spec());
  if (!spec.ok()) return spec.status().WithContext("weights '" + w.name() + "'");
  if (spec->level < 1 || spec->level > 8) return Errorf("weights '{}': level {} out of range", w.name(), spec->level);
  if (!spec->obs_index.empty() && *std::max_element(spec->obs_index.begin(), spec->obs_index.end()) >= env_.state_dim())
    return Errorf("weights '{}': observation reads beyond the env's state", w.name());
  if (models_.levels.size() < size_t(spec->level)) models_.levels.resize(size_t(spec->level));
  std::unique_ptr<LevelModel>& slot = models_.levels[size_t(spec->level) - 1];
  const bool same_spec = slot && ToJson(slot->spec()) == ToJson(*spec);
  if (same_spec) {
    // new weights of the same network: load in place (the old ones stay on a bad blob)
    COINS_RETURN_IF_ERROR(slot->net.Load(w.blob(), "weights '" + w.name() + "'"));
  } else {
    auto net = policy::PolicyNet::Create(*spec);
    if (!net.ok()) return net.status().WithContext("weights '" + w.name() + "'");
    COINS_RETURN_IF_ERROR(net->Load(w.blob(), "weights '" + w.name() + "'"));
    auto m = std::make_unique<LevelModel>();
    m->net = std::move(*net);
    m->interaction_bit = detector::InteractionBit(env_, spec->source, spec->goal.factor);
    slot = std::move(m);
    ++structure_changes_;
  }
  slot->version = w.version();
  slot->trained = w.learner_step() > 0;
  AttachDetectors();
  return Status::Ok();
}

Status WeightsStore::ApplyDetector(const msg::PolicyWeights& w) {
  auto spec = detector::ParseDetectorSpec(w.spec());
  if (!spec.ok()) return spec.status().WithContext("weights '" + w.name() + "'");
  if (spec->full_state_dim != env_.state_dim())
    return Errorf("weights '{}': detector for a state of {} features, the env has {}", w.name(), spec->full_state_dim,
                  env_.state_dim());
  // build it once here, so a bad blob is refused now rather than when a level needs it
  auto probe = detector::OnlineDetector::Create(*spec, w.blob(), 0, 1);
  if (!probe.ok()) return probe.status().WithContext("weights '" + w.name() + "'");
  detectors_[w.name()] = {*spec, w.blob(), w.version()};
  AttachDetectors();
  return Status::Ok();
}

void WeightsStore::AttachDetectors() {
  for (auto& m : models_.levels) {
    if (!m || m->spec().detector.empty()) continue;
    auto it = detectors_.find(m->spec().detector);
    if (it == detectors_.end() || it->second.version == m->detector_version) continue;
    auto d = detector::OnlineDetector::Create(it->second.spec, it->second.blob, detector_seed_++);
    if (!d.ok()) continue;  // checked when it arrived
    if (!m->detector) ++structure_changes_;
    m->detector = std::make_unique<detector::OnlineDetector>(std::move(*d));
    m->detector_version = it->second.version;
  }
}

}  // namespace coins
