#include "common/process.h"

#include <csignal>
#include <iostream>
#include <thread>

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "common/dds/security.h"

namespace coins {

namespace {
std::atomic<bool> g_stop{false};
extern "C" void OnStopSignal(int) { g_stop.store(true); }
}  // namespace

void InstallStopSignals() {
  struct sigaction sa {};
  sa.sa_handler = OnStopSignal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  std::signal(SIGPIPE, SIG_IGN);
}

bool StopRequested() { return g_stop.load(std::memory_order_relaxed); }
void RequestStop() { g_stop.store(true); }

bool SleepUnlessStopped(std::chrono::milliseconds d) {
  auto end = std::chrono::steady_clock::now() + d;
  while (!StopRequested()) {
    auto now = std::chrono::steady_clock::now();
    if (now >= end) return false;
    std::this_thread::sleep_for(
        std::min<std::chrono::steady_clock::duration>(end - now, std::chrono::milliseconds(20)));
  }
  return true;
}

int ExitWithError(const Status& error, int code) {
  spdlog::error("{}", error.message());
  return code;
}

void SetupLogging(const std::string& name, const std::string& level) {
  auto logger = spdlog::stderr_color_mt(name);
  logger->set_pattern("%H:%M:%S.%e %n %^%l%$: %v");
  logger->set_level(spdlog::level::from_str(level));
  spdlog::set_default_logger(logger);
}

ProcessMain::ProcessMain(std::string binary, std::string description)
    : binary_(std::move(binary)), app_(std::move(description), binary_) {
  app_.add_option("--config", config_path_, "YAML config file (sections dds, run, actor, replay, ...)")
      ->check(CLI::ExistingFile);
  app_.add_option("--set", overrides_, "override a config value: section.key=value (repeatable)");
  app_.add_option("--name", name_, "process name on DDS and in logs");
  app_.add_option("--log-level", log_level_, "trace, debug, info, warn, error")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error", "off"}));
  app_.add_flag("--quiet-config", quiet_config_, "do not print the effective config at start");
  sections_.push_back(ConfigSection::Of("dds", dds_));
}

int ProcessMain::Parse(int argc, char** argv) {
  try {
    app_.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app_.exit(e);
  }
  ConfigLoader loader(sections_);
  Status s = config_path_.empty() ? Status::Ok() : loader.LoadFile(config_path_);
  for (const auto& o : overrides_) {
    if (!s.ok()) break;
    s = loader.ApplyOverride(o);
  }
  if (s.ok()) s = loader.Validate();
  if (!s.ok()) {
    std::cerr << binary_ << ": " << s.message() << "\n";
    return 2;
  }
  if (name_.empty()) name_ = binary_;
  dds_.identity = dds::IdentityOfBinary(binary_);  // a coins process is what it is
  SetupLogging(name_, log_level_);
  if (!quiet_config_) spdlog::info("effective config:\n{}", loader.Dump());
  InstallStopSignals();
  return -1;
}

Result<ProcessNode> ProcessMain::OpenNode(const std::string& role) {
  auto node = dds::Node::Join(dds_, name_);
  if (!node.ok()) return node.status();
  auto heartbeat = dds::Heartbeat::Create(**node, name_, role);
  if (!heartbeat.ok()) return heartbeat.status().WithContext("cannot open DDS topics");
  return ProcessNode{std::move(*node), std::move(*heartbeat)};
}

}  // namespace coins
