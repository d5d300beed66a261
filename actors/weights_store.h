// WeightsStore: what an actor holds of the learner's PolicyWeights (idl/weights.idl): one
// LevelModel per hierarchy level (spec, acting network, version) and the link detectors, kept
// in one HierarchyModels object that the actor's HierarchyRunners read.
//
// Weights are checked before use (schema, checksum, a version newer than the one held, a spec
// that parses and a blob whose layout matches it); rejected ones are counted and logged and the
// old weights stay. New weights of an unchanged spec load in place; a new spec, a new level or
// a detector a level needs changes the structure (structure_changes() grows), which the actor
// answers by opening new segments. Not thread-safe: apply between steps.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "actors/hierarchy.h"
#include "common/env_spec.h"
#include "idl/weights.h"

namespace coins {

class WeightsStore {
 public:
  explicit WeightsStore(const envs::EnvSpec& env) : env_(env) {}
  // applies one message; an error says why it was rejected (and it is counted)
  Status Apply(const msg::PolicyWeights& w);

  const HierarchyModels& models() const { return models_; }
  uint64_t rejected() const { return rejected_; }
  uint64_t structure_changes() const { return structure_changes_; }
  // weights version per level (index level - 1), 0 where none is held
  std::vector<uint64_t> versions() const;

 private:
  Status ApplyLevel(const msg::PolicyWeights& w);
  Status ApplyDetector(const msg::PolicyWeights& w);
  void AttachDetectors();

  const envs::EnvSpec& env_;
  HierarchyModels models_;
  std::map<std::string, uint64_t> held_;  // name -> version
  struct HeldDetector {
    detector::DetectorSpec spec;
    std::vector<uint8_t> blob;
    uint64_t version = 0;
  };
  std::map<std::string, HeldDetector> detectors_;  // by weights name
  uint64_t rejected_ = 0, structure_changes_ = 0, detector_seed_ = 1;
};

}  // namespace coins
