#include "common/config/config.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <set>
#include <sstream>

#include <fmt/ranges.h>
#include <yaml-cpp/yaml.h>
#include <nlohmann/json.hpp>

namespace coins {
namespace {

// keys of earlier versions and where they went, so an old config file's error says where
std::string MovedKey(const std::string& section_key) {
  static const std::pair<const char*, const char*> kMoved[] = {
      {"learner.detect_passive_steps", "detector.passive_steps"},
      {"learner.detect_active_steps", "detector.active_steps"},
      {"learner.detect_eps_si", "detector.eps_si"},
  };
  for (const auto& [old_key, new_key] : kMoved)
    if (section_key == old_key) return new_key;
  return "";
}

// keys no longer read and the value this version behaves as (config.h, IsRetiredAtItsValue)
struct RetiredKey {
  const char* key;
  const char* value;
};
constexpr RetiredKey kRetired[] = {
    // the task level: no episode it ends early without success, and its goals are not a rare link's
    {"learner.task_episode_end_reward", "0"},
    {"learner.task_reach_needs_interaction", "true"},
};

// the same value written either way: the same text, or numbers that are equal ("0", "0.0")
bool SameValueText(const std::string& a, const std::string& b) {
  if (a == b) return true;
  char* end_a = nullptr;
  char* end_b = nullptr;
  const double x = std::strtod(a.c_str(), &end_a), y = std::strtod(b.c_str(), &end_b);
  return !a.empty() && !b.empty() && end_a == a.c_str() + a.size() && end_b == b.c_str() + b.size() && x == y;
}

const RetiredKey* FindRetired(const std::string& section_key) {
  for (const auto& r : kRetired)
    if (section_key == r.key) return &r;
  return nullptr;
}

// a map key as a name; keys that are lists, maps or null are not names
bool KeyName(const YAML::Node& key, std::string* name) {
  if (!key.IsScalar()) return false;
  *name = key.Scalar();
  return true;
}

// a scalar's text for error messages
std::string Show(const YAML::Node& node) {
  if (node.IsScalar()) return "'" + node.Scalar() + "'";
  if (node.IsSequence()) return "a list";
  if (node.IsMap()) return "a map";
  return "nothing";
}

// reads the fields of one section from a YAML map, recording which keys it used
class YamlReader final : public ConfigVisitor {
 public:
  YamlReader(const YAML::Node& map, std::string where) : map_(map), where_(std::move(where)) {}

  void Int(std::string_view key, int64_t& value, int64_t min, int64_t max, std::string_view) override {
    YAML::Node n = Take(key);
    if (!n || !status_.ok()) return;
    int64_t parsed = 0;
    if (!n.IsScalar() || !YAML::convert<int64_t>::decode(n, parsed)) {
      Fail(key, "expected an integer, got " + Show(n));
      return;
    }
    if (parsed < min || parsed > max) {
      Fail(key, fmt::format("must be in [{}, {}], got {}", min, max, parsed));
      return;
    }
    value = parsed;
  }
  void Float(std::string_view key, double& value, double min, double max, std::string_view) override {
    YAML::Node n = Take(key);
    if (!n || !status_.ok()) return;
    double parsed = 0;
    if (!n.IsScalar() || !YAML::convert<double>::decode(n, parsed) || !std::isfinite(parsed)) {
      Fail(key, "expected a finite number, got " + Show(n));
      return;
    }
    if (parsed < min || parsed > max) {
      Fail(key, fmt::format("must be in [{}, {}], got {}", min, max, parsed));
      return;
    }
    value = parsed;
  }
  void Bool(std::string_view key, bool& value, std::string_view) override {
    YAML::Node n = Take(key);
    if (!n || !status_.ok()) return;
    bool parsed = false;
    if (!n.IsScalar() || !YAML::convert<bool>::decode(n, parsed)) {
      Fail(key, "expected true or false, got " + Show(n));
      return;
    }
    value = parsed;
  }
  void String(std::string_view key, std::string& value, const std::vector<std::string>& choices,
              std::string_view) override {
    YAML::Node n = Take(key);
    if (!n || !status_.ok()) return;
    if (!n.IsScalar()) {
      Fail(key, "expected a string, got " + Show(n));
      return;
    }
    const std::string& s = n.Scalar();
    if (!choices.empty() && std::find(choices.begin(), choices.end(), s) == choices.end()) {
      std::string list;
      for (const auto& c : choices) list += (list.empty() ? "" : ", ") + c;
      Fail(key, fmt::format("'{}' is not one of: {}", s, list));
      return;
    }
    value = s;
  }
  void FloatList(std::string_view key, std::vector<double>& value, std::string_view) override {
    ReadList<double>(
        key, value, "numbers", "finite numbers", [](double x) { return std::isfinite(x); },
        [](double) { return std::string(); });
  }
  void IntList(std::string_view key, std::vector<int64_t>& value, int64_t min, int64_t max, std::string_view) override {
    ReadList<int64_t>(
        key, value, "integers", "integers", [](int64_t) { return true; },
        [&](int64_t x) {
          return x < min || x > max ? fmt::format("entries must be in [{}, {}], got {}", min, max, x) : std::string();
        });
  }

  // after visiting: any key of the map not used is unknown
  Status Finish() {
    if (!status_.ok()) return status_;
    for (const auto& kv : map_) {
      std::string key;
      if (!KeyName(kv.first, &key))
        return Errorf("{}: section '{}' has a key that is {}, not a name", origin_, where_, Show(kv.first));
      if (!used_.count(key)) {
        if (std::string moved = MovedKey(where_ + "." + key); !moved.empty())
          return Errorf("{}: '{}.{}' is now '{}'", origin_, where_, key, moved);
        const std::string full = where_ + "." + key;
        if (std::string retired = RetiredKeyValue(full); !retired.empty()) {
          if (kv.second.IsScalar() && SameValueText(kv.second.Scalar(), retired)) continue;
          return Errorf("{}: '{}' is no longer read: only its old value {} can be ignored, got {}", origin_, full,
                        retired, Show(kv.second));
        }
        std::string hint = ClosestMatch(key, fields_);
        return Errorf("{}: unknown key '{}.{}'{}", origin_, where_, key,
                      hint.empty() ? "" : " (did you mean '" + hint + "'?)");
      }
    }
    return Status::Ok();
  }
  void set_origin(std::string origin) { origin_ = std::move(origin); }

 private:
  YAML::Node Take(std::string_view key) {
    std::string k(key);
    fields_.push_back(k);
    if (!map_[k]) return YAML::Node(YAML::NodeType::Undefined);
    used_.insert(k);
    YAML::Node n = map_[k];
    if (n.IsNull()) {
      Fail(key, "has no value");
      return YAML::Node(YAML::NodeType::Undefined);
    }
    return n;
  }
  // a list of T ("expected a list of <kind>"): an item that does not read as T or fails
  // is_item is "expected a list of <item_kind>, found ..."; range(x) says what else is wrong
  // with an item ("" when nothing)
  template <typename T, typename IsItem, typename Range>
  void ReadList(std::string_view key, std::vector<T>& value, const char* kind, const char* item_kind, IsItem is_item,
                Range range) {
    YAML::Node n = Take(key);
    if (!n || !status_.ok()) return;
    if (!n.IsSequence()) {
      Fail(key, fmt::format("expected a list of {}, got {}", kind, Show(n)));
      return;
    }
    std::vector<T> parsed;
    for (const auto& item : n) {
      T x{};
      if (!item.IsScalar() || !YAML::convert<T>::decode(item, x) || !is_item(x)) {
        Fail(key, fmt::format("expected a list of {}, found {}", item_kind, Show(item)));
        return;
      }
      if (std::string wrong = range(x); !wrong.empty()) {
        Fail(key, wrong);
        return;
      }
      parsed.push_back(x);
    }
    value = std::move(parsed);
  }
  void Fail(std::string_view key, const std::string& what) {
    if (status_.ok()) status_ = Errorf("{}: {}.{}: {}", origin_, where_, key, what);
  }

  const YAML::Node& map_;
  std::string where_;
  std::string origin_;
  std::set<std::string> used_;
  std::vector<std::string> fields_;
  Status status_;
};

// writes the fields of one section as YAML
class YamlWriter final : public ConfigVisitor {
 public:
  explicit YamlWriter(YAML::Emitter& out) : out_(out) {}
  void Int(std::string_view key, int64_t& value, int64_t, int64_t, std::string_view) override {
    out_ << YAML::Key << std::string(key) << YAML::Value << value;
  }
  void Float(std::string_view key, double& value, double, double, std::string_view) override {
    out_ << YAML::Key << std::string(key) << YAML::Value << value;
  }
  void Bool(std::string_view key, bool& value, std::string_view) override {
    out_ << YAML::Key << std::string(key) << YAML::Value << value;
  }
  void String(std::string_view key, std::string& value, const std::vector<std::string>&, std::string_view) override {
    out_ << YAML::Key << std::string(key) << YAML::Value << YAML::DoubleQuoted << value;
  }
  void FloatList(std::string_view key, std::vector<double>& value, std::string_view) override {
    out_ << YAML::Key << std::string(key) << YAML::Value << YAML::Flow << value;
  }
  void IntList(std::string_view key, std::vector<int64_t>& value, int64_t, int64_t, std::string_view) override {
    out_ << YAML::Key << std::string(key) << YAML::Value << YAML::Flow << value;
  }

 private:
  YAML::Emitter& out_;
};

// checks the values a section holds against the ranges and choices its Visit declares
class RangeChecker final : public ConfigVisitor {
 public:
  void Int(std::string_view key, int64_t& value, int64_t min, int64_t max, std::string_view) override {
    if (value < min || value > max) Fail(fmt::format("{} must be in [{}, {}], got {}", key, min, max, value));
  }
  void Float(std::string_view key, double& value, double min, double max, std::string_view) override {
    if (!(value >= min && value <= max)) Fail(fmt::format("{} must be in [{}, {}], got {}", key, min, max, value));
  }
  void Bool(std::string_view, bool&, std::string_view) override {}
  void String(std::string_view key, std::string& value, const std::vector<std::string>& choices,
              std::string_view) override {
    if (!choices.empty() && std::find(choices.begin(), choices.end(), value) == choices.end())
      Fail(fmt::format("{} '{}' is not one of: {}", key, value, fmt::join(choices, ", ")));
  }
  void FloatList(std::string_view key, std::vector<double>& value, std::string_view) override {
    for (double x : value)
      if (!std::isfinite(x)) Fail(fmt::format("{} has a non-finite entry {}", key, x));
  }
  void IntList(std::string_view key, std::vector<int64_t>& value, int64_t min, int64_t max, std::string_view) override {
    for (int64_t x : value)
      if (x < min || x > max) Fail(fmt::format("{} entries must be in [{}, {}], got {}", key, min, max, x));
  }
  const Status& status() const { return status_; }

 private:
  void Fail(std::string message) {
    if (status_.ok()) status_ = Status::Error(std::move(message));
  }
  Status status_;
};

// collects a section's fields as a JSON object
class JsonWriter final : public ConfigVisitor {
 public:
  void Int(std::string_view key, int64_t& value, int64_t, int64_t, std::string_view) override { Put(key, value); }
  void Float(std::string_view key, double& value, double, double, std::string_view) override { Put(key, value); }
  void Bool(std::string_view key, bool& value, std::string_view) override { Put(key, value); }
  void String(std::string_view key, std::string& value, const std::vector<std::string>&, std::string_view) override {
    Put(key, value);
  }
  void FloatList(std::string_view key, std::vector<double>& value, std::string_view) override { Put(key, value); }
  void IntList(std::string_view key, std::vector<int64_t>& value, int64_t, int64_t, std::string_view) override {
    Put(key, value);
  }
  const nlohmann::json& json() const { return json_; }

 private:
  template <typename T>
  void Put(std::string_view key, const T& value) {
    json_[std::string(key)] = value;
  }
  nlohmann::json json_ = nlohmann::json::object();
};

size_t EditDistance(std::string_view a, std::string_view b) {
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diag = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (a[i - 1] != b[j - 1])});
      diag = up;
    }
  }
  return row[b.size()];
}

}  // namespace

bool IsRetiredAtItsValue(const std::string& section_key, const std::string& value) {
  const RetiredKey* r = FindRetired(section_key);
  return r && SameValueText(value, r->value);
}

std::string RetiredKeyValue(const std::string& section_key) {
  const RetiredKey* r = FindRetired(section_key);
  return r ? std::string(r->value) : std::string();
}

void VisitInt(ConfigVisitor& v, std::string_view key, int& value, int64_t min, int64_t max, std::string_view doc) {
  int64_t wide = value;
  v.Int(key, wide, min, max, doc);
  value = int(std::clamp<int64_t>(wide, INT32_MIN, INT32_MAX));
}

void VisitFloat(ConfigVisitor& v, std::string_view key, float& value, double min, double max, std::string_view doc) {
  // the double nearest the float's shortest decimal form: 0.01f is shown as 0.01, not
  // 0.009999999776482582, and narrows back to the same float
  double wide = std::strtod(fmt::format("{}", value).c_str(), nullptr);
  v.Float(key, wide, min, max, doc);
  value = float(wide);
}

void VisitIntList(ConfigVisitor& v, std::string_view key, std::vector<int>& value, int64_t min, int64_t max,
                  std::string_view doc) {
  std::vector<int64_t> wide(value.begin(), value.end());
  v.IntList(key, wide, min, max, doc);
  value.assign(wide.size(), 0);
  for (size_t i = 0; i < wide.size(); ++i) value[i] = int(std::clamp<int64_t>(wide[i], INT32_MIN, INT32_MAX));
}

Status CheckConfigRanges(const std::function<void(ConfigVisitor&)>& visit) {
  RangeChecker checker;
  visit(checker);
  return checker.status();
}

std::string ConfigJson(const ConfigSection& section) {
  JsonWriter writer;
  section.visit(writer);
  return writer.json().dump();
}

const std::vector<std::string>& KnownConfigSections() {
  static const std::vector<std::string> kSections = {"dds",     "run",      "actor",       "replay",
                                                     "learner", "detector", "orchestrator"};
  return kSections;
}

std::string ClosestMatch(std::string_view word, const std::vector<std::string>& candidates) {
  std::string best;
  size_t best_d = std::max<size_t>(2, word.size() / 3) + 1;
  for (const auto& c : candidates) {
    size_t d = EditDistance(word, c);
    if (d < best_d) {
      best_d = d;
      best = c;
    }
  }
  return best;
}

ConfigSection* ConfigLoader::Find(std::string_view name) {
  for (auto& s : sections_)
    if (s.name == name) return &s;
  return nullptr;
}

Status ConfigLoader::LoadFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) return Errorf("config file '{}' cannot be read", path);
  std::stringstream text;
  text << in.rdbuf();
  return LoadText(text.str(), "config " + path);
}

Status ConfigLoader::LoadText(const std::string& text, const std::string& origin) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    return Errorf("{}: not valid YAML at line {}: {}", origin, e.mark.line + 1, e.msg);
  }
  return LoadNode(root, origin);
}

Status ConfigLoader::LoadNode(const YAML::Node& root, const std::string& origin) {
  // yaml-cpp throws on conversions it cannot make; every one is checked below, and this is the
  // backstop that turns anything missed into a one-line error instead of an abort
  try {
    return LoadSections(root, origin);
  } catch (const YAML::Exception& e) {
    return Errorf("{}: cannot read the YAML at line {}: {}", origin, e.mark.line + 1, e.msg);
  }
}

Status ConfigLoader::LoadSections(const YAML::Node& root, const std::string& origin) {
  if (root.IsNull()) return Status::Ok();  // an empty file changes nothing
  if (!root.IsMap()) return Errorf("{}: expected a map of sections at the top level", origin);
  const auto& known = KnownConfigSections();
  for (const auto& kv : root) {
    std::string name;
    if (!KeyName(kv.first, &name))
      return Errorf("{}: a top-level key is {}, not a section name", origin, Show(kv.first));
    ConfigSection* section = Find(name);
    if (!section) {
      if (std::find(known.begin(), known.end(), name) != known.end()) continue;  // another process's
      std::string hint = ClosestMatch(name, known);
      return Errorf("{}: unknown section '{}'{}", origin, name, hint.empty() ? "" : " (did you mean '" + hint + "'?)");
    }
    if (kv.second.IsNull()) continue;
    if (!kv.second.IsMap()) return Errorf("{}: section '{}' must be a map of keys", origin, name);
    YamlReader reader(kv.second, name);
    reader.set_origin(origin);
    section->visit(reader);
    COINS_RETURN_IF_ERROR(reader.Finish());
  }
  return Status::Ok();
}

Status ConfigLoader::ApplyOverride(const std::string& assignment) {
  size_t eq = assignment.find('=');
  size_t dot = assignment.find('.');
  if (eq == std::string::npos || dot == std::string::npos || dot > eq || dot == 0 || dot + 1 == eq)
    return Errorf("override '{}': expected section.key=value", assignment);
  std::string section = assignment.substr(0, dot);
  std::string key = assignment.substr(dot + 1, eq - dot - 1);
  std::string value = assignment.substr(eq + 1);
  if (!Find(section)) {
    const auto& known = KnownConfigSections();
    if (std::find(known.begin(), known.end(), section) != known.end()) return Status::Ok();
    return Errorf("override '{}': unknown section '{}'", assignment, section);
  }
  YAML::Node root;
  try {
    root[section][key] = YAML::Load(value);
  } catch (const YAML::Exception& e) {
    return Errorf("override '{}': value is not valid YAML: {}", assignment, e.msg);
  }
  return LoadNode(root, "override " + assignment);
}

Status ConfigLoader::Validate() const {
  for (const auto& s : sections_) COINS_RETURN_IF_ERROR(s.validate().WithContext("config: " + s.name));
  return Status::Ok();
}

std::string ConfigLoader::Dump() const {
  YAML::Emitter out;
  out << YAML::BeginMap;
  for (const auto& s : sections_) {
    out << YAML::Key << s.name << YAML::Value << YAML::BeginMap;
    YamlWriter writer(out);
    s.visit(writer);
    out << YAML::EndMap;
  }
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

}  // namespace coins
