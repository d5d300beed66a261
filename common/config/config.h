// Config: options structs loaded from a YAML file plus command-line overrides.
//
// Every component has one options struct with documented defaults. The struct lists its fields
// once, in Visit(ConfigVisitor&), and checks cross-field rules in Validate(). From that one list
// the loader reads YAML (rejecting unknown keys, wrong types and out-of-range values with a
// one-line error that names the key), `--set section.key=value` overrides are applied, and the
// effective config is printed.
//
//   struct ReplayOptions {
//     int64_t capacity = 1'000'000;
//     void Visit(ConfigVisitor& v) { v.Int("capacity", capacity, 1, 1LL << 34, "transitions per shard"); }
//     Status Validate() const { return Status::Ok(); }
//   };
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "common/status.h"

namespace YAML {
class Node;
}

namespace coins {

class ConfigVisitor {
 public:
  virtual ~ConfigVisitor() = default;
  virtual void Int(std::string_view key, int64_t& value, int64_t min, int64_t max, std::string_view doc) = 0;
  virtual void Float(std::string_view key, double& value, double min, double max, std::string_view doc) = 0;
  virtual void Bool(std::string_view key, bool& value, std::string_view doc) = 0;
  // choices empty: any string
  virtual void String(std::string_view key, std::string& value, const std::vector<std::string>& choices,
                      std::string_view doc) = 0;
  // a list of floats; empty allowed
  virtual void FloatList(std::string_view key, std::vector<double>& value, std::string_view doc) = 0;
  // a list of integers, each within [min, max]; empty allowed
  virtual void IntList(std::string_view key, std::vector<int64_t>& value, int64_t min, int64_t max,
                       std::string_view doc) = 0;
};

// Fields narrower than the visitor's types (int, float, std::vector<int>, an enum's name) go
// through these: the value is widened, visited and narrowed back, so a reader's range check
// still decides what the field can hold.
void VisitInt(ConfigVisitor& v, std::string_view key, int& value, int64_t min, int64_t max, std::string_view doc);
void VisitFloat(ConfigVisitor& v, std::string_view key, float& value, double min, double max, std::string_view doc);
void VisitIntList(ConfigVisitor& v, std::string_view key, std::vector<int>& value, int64_t min, int64_t max,
                  std::string_view doc);

// checks that every field of a section lies in the range its Visit declares (and, for strings,
// among its choices); the error names the key: "lr must be in [1e-09, 10], got 0". For options
// structs that are also built in code (not only loaded), as the first step of their Validate().
template <typename Options>
Status CheckConfigRanges(Options& options);
Status CheckConfigRanges(const std::function<void(ConfigVisitor&)>& visit);

// A named section of the config file bound to an options struct. The options struct outlives it.
struct ConfigSection {
  std::string name;  // top-level key, e.g. "replay"
  std::function<void(ConfigVisitor&)> visit;
  std::function<Status()> validate;

  template <typename Options>
  static ConfigSection Of(std::string name, Options& options) {
    return {std::move(name), [&options](ConfigVisitor& v) { options.Visit(v); },
            [&options] { return options.Validate(); }};
  }
};

// The sections that may appear in a coins config file. A process binds the sections it uses;
// the others are allowed (another process reads them) but any other top-level key is an error.
const std::vector<std::string>& KnownConfigSections();

class ConfigLoader {
 public:
  explicit ConfigLoader(std::vector<ConfigSection> sections) : sections_(std::move(sections)) {}

  // reads a YAML file into the bound sections; a missing or malformed file is an error
  Status LoadFile(const std::string& path);
  // reads YAML text (used by tests and by LoadFile); `origin` names the source in errors
  Status LoadText(const std::string& text, const std::string& origin);
  // applies one "section.key=value" override; the value is parsed as YAML
  Status ApplyOverride(const std::string& assignment);
  // runs every section's Validate()
  Status Validate() const;
  // the effective config as YAML text (every bound section, every field)
  std::string Dump() const;

 private:
  Status LoadNode(const YAML::Node& root, const std::string& origin);
  Status LoadSections(const YAML::Node& root, const std::string& origin);
  ConfigSection* Find(std::string_view name);
  std::vector<ConfigSection> sections_;
};

// a section's fields as one JSON object (key -> number, bool, string or list), e.g. to record
// the options a report was made with
std::string ConfigJson(const ConfigSection& section);

// Keys that earlier versions of coins wrote and this one no longer reads, each with the value at
// which this version behaves as they did. A config (or a chain state's recorded config) holding
// one at that value is read as if the key were absent; at any other value it is refused, naming
// the key, since ignoring it would change what the run does. Takes "section.key" and the value's
// text.
bool IsRetiredAtItsValue(const std::string& section_key, const std::string& value);
// the retired key's value as text, or "" when the key is not retired
std::string RetiredKeyValue(const std::string& section_key);

// the closest candidate by edit distance, or "" when none is close
std::string ClosestMatch(std::string_view word, const std::vector<std::string>& candidates);

template <typename Options>
Status CheckConfigRanges(Options& options) {
  return CheckConfigRanges([&options](ConfigVisitor& v) { options.Visit(v); });
}

}  // namespace coins
