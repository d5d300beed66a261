// ConfigFlags: command-line flags made from a config section's field list, so a command's flags
// and the config file's keys are one list and cannot drift.
//
// Each field `key` of the section becomes `--key` with underscores as dashes (`passive_steps` ->
// `--passive-steps`), its doc and default as help, and the check its range implies (integers,
// finite numbers in [min, max], a string's choices, true/false, comma-separated lists). After
// parsing, Apply() turns the flags given into `section.key=value` overrides of a loader bound to
// the same section, so a flag and a config file's key go through the same reader.
//
//   DetectorOptions o;
//   ConfigFlags flags(cmd, ConfigSection::Of("detector", o));
//   ... parse ...
//   ConfigLoader loader({ConfigSection::Of("detector", o)});
//   Status s = flags.Apply(loader);  // then loader.Validate()
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "common/config/config.h"
#include "common/status.h"

namespace coins {

class ConfigFlags {
 public:
  // adds the section's flags to app; skip lists keys that get no flag (the command sets them)
  ConfigFlags(CLI::App* app, const ConfigSection& section, const std::vector<std::string>& skip = {});

  // applies the flags given on the command line, in the section's field order
  Status Apply(ConfigLoader& loader) const;
  // true when --key (a field name with underscores) was given
  bool Given(const std::string& key) const;

 private:
  class Adder;
  struct Flag {
    std::string key;
    bool list = false;
    std::vector<std::string> values;
    CLI::Option* option = nullptr;
  };
  std::string section_;
  // the options bind to these values: stable addresses while the app lives
  std::vector<std::unique_ptr<Flag>> flags_;
};

}  // namespace coins
