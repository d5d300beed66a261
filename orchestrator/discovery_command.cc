#include "orchestrator/discovery_command.h"

#include <iostream>
#include <memory>

#include <fmt/format.h>

#include "common/config/config.h"
#include "common/dds/discovery.h"
#include "common/dds/node.h"
#include "common/process.h"

namespace coins {

namespace {

struct DiscoveryFlags {
  std::string config;
  std::vector<std::string> overrides;
  int index = 0;
};

int RunDiscoveryServer(const DiscoveryFlags& f) {
  DdsOptions dds;
  ConfigLoader loader({ConfigSection::Of("dds", dds)});
  Status s = f.config.empty() ? Status::Ok() : loader.LoadFile(f.config);
  for (const auto& o : f.overrides)
    if (s.ok()) s = loader.ApplyOverride(o);
  if (s.ok()) s = loader.Validate();
  auto servers = dds::ParseServers(dds.discovery_server);
  if (s.ok() && size_t(f.index) >= servers->size())
    s = Errorf("--index {}: dds.discovery_server '{}' lists {} server(s)", f.index, dds.discovery_server,
               servers->size());
  if (!s.ok()) {
    std::cerr << "coins discovery-server: " << s.message() << "\n";
    return 2;
  }
  InstallStopSignals();
  SetupLogging(fmt::format("discovery-{}", f.index), "info");
  auto node = dds::Node::CreateDiscoveryServer(dds, f.index);
  if (!node.ok()) {
    std::cerr << "coins discovery-server: " << node.status().message() << "\n";
    return 1;
  }
  const auto& me = (*servers)[size_t(f.index)];
  std::cout << fmt::format("coins discovery-server: server {} of domain {} listening on {}:{}", f.index, dds.domain,
                           me.ip, me.port)
            << std::endl;
  while (!SleepUnlessStopped(std::chrono::seconds(1))) {
  }
  std::cout << "coins discovery-server: stopped" << std::endl;
  return 0;
}

}  // namespace

void AddDiscoveryServerCommand(CLI::App& app, int* exit_code) {
  auto flags = std::make_shared<DiscoveryFlags>();
  CLI::App* d = app.add_subcommand("discovery-server",
                                   "Run a DDS discovery server of dds.discovery_server (for dds.discovery: server).");
  d->add_option("--config", flags->config, "YAML config file (its dds section is used)")->check(CLI::ExistingFile);
  d->add_option("--set", flags->overrides, "override a config value: dds.key=value (repeatable)");
  d->add_option("--index", flags->index, "which entry of dds.discovery_server: 0 the server, 1 its backup")
      ->check(CLI::Range(0, 1));
  d->callback([flags, exit_code] { *exit_code = RunDiscoveryServer(*flags); });
}

}  // namespace coins
