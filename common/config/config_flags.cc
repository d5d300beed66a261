#include "common/config/config_flags.h"

#include <algorithm>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "common/cli_checks.h"

namespace coins {

// adds one option per field, bound to a Flag of the owner
class ConfigFlags::Adder final : public ConfigVisitor {
 public:
  Adder(CLI::App* app, ConfigFlags* owner, const std::vector<std::string>& skip)
      : app_(app), owner_(owner), skip_(skip) {}

  void Int(std::string_view key, int64_t& value, int64_t min, int64_t max, std::string_view doc) override {
    if (CLI::Option* o = Add(key, doc, std::to_string(value), false)) o->check(cli::Integer(min, max));
  }
  void Float(std::string_view key, double& value, double min, double max, std::string_view doc) override {
    if (CLI::Option* o = Add(key, doc, fmt::format("{}", value), false)) o->check(cli::Finite(min, max));
  }
  void Bool(std::string_view key, bool& value, std::string_view doc) override {
    if (CLI::Option* o = Add(key, doc, value ? "true" : "false", false)) o->check(CLI::IsMember({"true", "false"}));
  }
  void String(std::string_view key, std::string& value, const std::vector<std::string>& choices,
              std::string_view doc) override {
    CLI::Option* o = Add(key, doc, value, false);
    if (o && !choices.empty()) o->check(CLI::IsMember(choices));
  }
  void FloatList(std::string_view key, std::vector<double>& value, std::string_view doc) override {
    CLI::Option* o = Add(key, doc, fmt::format("{}", fmt::join(value, ",")), true);
    if (o) o->check(cli::Finite(-1e300, 1e300));
  }
  void IntList(std::string_view key, std::vector<int64_t>& value, int64_t min, int64_t max,
               std::string_view doc) override {
    CLI::Option* o = Add(key, doc, fmt::format("{}", fmt::join(value, ",")), true);
    if (o) o->check(cli::Integer(min, max));
  }

 private:
  CLI::Option* Add(std::string_view key, std::string_view doc, const std::string& default_text, bool list) {
    std::string k(key);
    if (std::find(skip_.begin(), skip_.end(), k) != skip_.end()) return nullptr;
    std::string name = "--" + k;
    std::replace(name.begin(), name.end(), '_', '-');
    auto flag = std::make_unique<Flag>();
    flag->key = k;
    flag->list = list;
    CLI::Option* o = app_->add_option(name, flag->values, fmt::format("{} (default {})", doc, default_text));
    if (list) {
      o->delimiter(',');
    } else {
      o->expected(1);
    }
    flag->option = o;
    owner_->flags_.push_back(std::move(flag));
    return o;
  }

  CLI::App* app_;
  ConfigFlags* owner_;
  const std::vector<std::string>& skip_;
};

ConfigFlags::ConfigFlags(CLI::App* app, const ConfigSection& section, const std::vector<std::string>& skip)
    : section_(section.name) {
  Adder adder(app, this, skip);
  section.visit(adder);
}

Status ConfigFlags::Apply(ConfigLoader& loader) const {
  for (const auto& f : flags_) {
    if (f->option->count() == 0) continue;
    const std::string value =
        f->list ? fmt::format("[{}]", fmt::join(f->values, ", ")) : (f->values.empty() ? "" : f->values.back());
    COINS_RETURN_IF_ERROR(loader.ApplyOverride(section_ + "." + f->key + "=" + value));
  }
  return Status::Ok();
}

bool ConfigFlags::Given(const std::string& key) const {
  for (const auto& f : flags_)
    if (f->key == key) return f->option->count() > 0;
  return false;
}

}  // namespace coins
