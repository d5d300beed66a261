#include "orchestrator/config_values.h"

#include <algorithm>

#include <fmt/format.h>
#include <fmt/ranges.h>

namespace coins {

namespace {

// collects every field of one section as "section.key" -> text
class Flattener final : public ConfigVisitor {
 public:
  Flattener(std::string section, ConfigValues& out) : section_(std::move(section)), out_(out) {}
  void Int(std::string_view key, int64_t& v, int64_t, int64_t, std::string_view) override {
    Put(key, std::to_string(v));
  }
  void Float(std::string_view key, double& v, double, double, std::string_view) override {
    Put(key, fmt::format("{}", v));
  }
  void Bool(std::string_view key, bool& v, std::string_view) override { Put(key, v ? "true" : "false"); }
  void String(std::string_view key, std::string& v, const std::vector<std::string>&, std::string_view) override {
    Put(key, v);
  }
  void FloatList(std::string_view key, std::vector<double>& v, std::string_view) override {
    Put(key, fmt::format("[{}]", fmt::join(v, ", ")));
  }
  void IntList(std::string_view key, std::vector<int64_t>& v, int64_t, int64_t, std::string_view) override {
    Put(key, fmt::format("[{}]", fmt::join(v, ", ")));
  }

 private:
  void Put(std::string_view key, std::string value) { out_[section_ + "." + std::string(key)] = std::move(value); }
  std::string section_;
  ConfigValues& out_;
};

bool EndsWith(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

}  // namespace

ConfigValues FlattenConfig(const std::vector<ConfigSection>& sections) {
  ConfigValues out;
  for (const auto& s : sections) {
    Flattener f(s.name, out);
    s.visit(f);
  }
  return out;
}

bool IsOperationalKey(const std::string& key) {
  static const std::vector<std::string> kKeys = {"run.dir",
                                                 "run.steps",
                                                 "run.actors",
                                                 "run.max_restarts",
                                                 "orchestrator.checkpoint_period_s",
                                                 "orchestrator.checkpoint_timeout_s",
                                                 "actor.steps",
                                                 "actor.flush_timeout_s",
                                                 "learner.shard_wait_s",
                                                 "replay.snapshot_dir",
                                                 "replay.snapshot_period_s",
                                                 "replay.snapshot_keep",
                                                 "replay.prefer_new_config"};
  if (key.rfind("dds.", 0) == 0 || EndsWith(key, ".status_period_s")) return true;
  return std::find(kKeys.begin(), kKeys.end(), key) != kKeys.end();
}

ConfigValues ChainFingerprint(const ConfigValues& all) {
  ConfigValues out;
  for (const auto& [k, v] : all)
    if (!IsOperationalKey(k)) out[k] = v;
  return out;
}

std::string HashConfig(const ConfigValues& values) {
  // FNV-1a over "key=value\n" lines in key order
  uint64_t h = 0xcbf29ce484222325ULL;
  auto feed = [&](const std::string& s) {
    for (unsigned char c : s) h = (h ^ c) * 0x100000001b3ULL;
  };
  for (const auto& [k, v] : values) feed(k + "=" + v + "\n");
  return fmt::format("{:016x}", h);
}

std::string FirstDifference(const ConfigValues& here, const ConfigValues& there, const std::string& where) {
  for (const auto& [k, v] : here) {
    auto it = there.find(k);
    if (it == there.end()) return fmt::format("{} is {} here and not set in {}", k, v, where);
    if (it->second != v) return fmt::format("{} is {} here, {} in {}", k, v, it->second, where);
  }
  for (const auto& [k, v] : there)
    if (!here.count(k)) return fmt::format("{} is {} in {} and unknown here", k, v, where);
  return "";
}

}  // namespace coins
