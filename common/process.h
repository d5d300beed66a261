// The skeleton shared by the coins process binaries (coins-actor, coins-replay, coins-learner,
// coins-orchestrator): command-line flags, config loading with overrides, logging, signals,
// and the heartbeat every process publishes.
//
//   ProcessMain main("coins-actor", "Runs environments and streams transitions to replay.");
//   main.AddSection(ConfigSection::Of("actor", actor_options));
//   main.app().add_option("--id", id, "...");
//   if (int rc = main.Parse(argc, argv); rc >= 0) return rc;   // --help, bad flags, bad config
//   ... run until StopRequested() ...
#pragma once

#include <atomic>
#include <chrono>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "common/config/config.h"
#include "common/dds/dds_options.h"

namespace coins {

// installs SIGINT/SIGTERM handlers that only set the stop flag
void InstallStopSignals();
bool StopRequested();
void RequestStop();
// sleeps up to d, returning early (true) when a stop is requested
bool SleepUnlessStopped(std::chrono::milliseconds d);

// sets up the default spdlog logger with the process name; level: trace..off
void SetupLogging(const std::string& name, const std::string& level = "info");

class ProcessMain {
 public:
  ProcessMain(std::string binary, std::string description);
  CLI::App& app() { return app_; }
  void AddSection(ConfigSection section) { sections_.push_back(std::move(section)); }
  // parses flags, loads --config, applies --set, validates; prints the effective config.
  // Returns -1 to go on, or the exit code to return now (0 after --help, 2 on errors).
  int Parse(int argc, char** argv);
  DdsOptions& dds() { return dds_; }
  // the process's name on DDS and in logs (e.g. "actor-3")
  std::string& name() { return name_; }

 private:
  std::string binary_;
  CLI::App app_;
  DdsOptions dds_;
  std::vector<ConfigSection> sections_;
  std::string config_path_;
  std::vector<std::string> overrides_;
  std::string name_;
  std::string log_level_ = "info";
  bool quiet_config_ = false;
};

}  // namespace coins
