// The skeleton shared by the coins process binaries (coins-actor, coins-replay, coins-learner,
// coins-orchestrator): command-line flags, config loading with overrides, logging, signals,
// and the heartbeat every process publishes.
//
//   ProcessMain main("coins-actor", "Runs environments and streams transitions to replay.");
//   main.AddSection(ConfigSection::Of("actor", actor_options));
//   main.app().add_option("--id", id, "...");
//   if (int rc = main.Parse(argc, argv); rc >= 0) return rc;   // --help, bad flags, bad config
//   auto dds = main.OpenNode("actor");                           // participant + heartbeat
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
#include "common/dds/heartbeat.h"
#include "common/dds/node.h"

namespace coins {

// installs SIGINT/SIGTERM handlers that only set the stop flag
void InstallStopSignals();
bool StopRequested();
void RequestStop();
// sleeps up to d, returning early (true) when a stop is requested
bool SleepUnlessStopped(std::chrono::milliseconds d);

// how a process main reports a failure after Parse: logs the error, returns the exit code
// (1: a runtime failure such as DDS; 2: bad input such as an unknown env or a bad checkpoint)
int ExitWithError(const Status& error, int code);

// sets up the default spdlog logger with the process name; level: trace..off
void SetupLogging(const std::string& name, const std::string& level = "info");

// The DDS side every process binary opens: its participant and the heartbeat of its role. The
// heartbeat is declared last, so it goes before the node it writes through.
struct ProcessNode {
  std::unique_ptr<dds::Node> node;
  dds::Heartbeat heartbeat;
};

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
  // after Parse: the participant (named name(), with the dds section's transports) and the
  // heartbeat of `role` ("actor", "replay", ...); the error names what could not be opened
  Result<ProcessNode> OpenNode(const std::string& role);

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
