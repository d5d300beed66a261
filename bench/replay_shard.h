// One coins-replay shard process for the benchmarks that measure against a real shard (replay,
// transport): on a private DDS domain (a free one of the test range, or the --domain asked for,
// see common/dds/domain_lease.h), logging into a temporary directory of its own.
#pragma once

#include <unistd.h>

#include <filesystem>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "common/cli_checks.h"
#include "common/dds/dds_options.h"
#include "common/dds/domain_lease.h"
#include "orchestrator/child_process.h"

namespace coins::bench {

// --domain: the DDS domain of the benchmark's processes (-1, the default: a free one of the lease range)
inline void AddDomainOption(CLI::App& app, int64_t* domain) {
  app.add_option("--domain", *domain,
                 "DDS domain of the benchmark's processes (default: a free one of the test range, see "
                 "common/dds/domain_lease.h)")
      ->check(cli::Integer(0, 232));
}

struct ReplayShardProcess {
  dds::DomainLease lease;               // held while the shard runs
  DdsOptions dds;                       // the shard's domain
  std::filesystem::path dir;            // its log; the caller removes it
  std::vector<ChildProcess> processes;  // the shard (one), as StopAll takes it
};

// starts `coins-replay --id 0` (beside this binary) with run.shards=1, the domain and the extra
// `--set` values; `tool` names the benchmark in the log directory. Errors: no free domain (exit
// code 2 in the benchmarks), the process could not start (1).
inline Result<ReplayShardProcess> StartReplayShard(const std::string& tool, int domain,
                                                   const std::vector<std::string>& sets, int* exit_code) {
  auto lease = dds::DomainLease::Choose(domain);
  if (!lease.ok()) {
    *exit_code = 2;
    return lease.status();
  }
  ReplayShardProcess s{std::move(*lease), {}, {}, {}};
  s.dds.domain = s.lease.domain();
  s.dir = std::filesystem::temp_directory_path() / (tool + "-" + std::to_string(getpid()));
  std::filesystem::create_directories(s.dir);
  std::vector<std::string> argv = {
      SelfDirectory() + "/coins-replay",           "--id", "0", "--quiet-config", "--set", "run.shards=1", "--set",
      "dds.domain=" + std::to_string(s.dds.domain)};
  for (const auto& set : sets) argv.insert(argv.end(), {"--set", set});
  auto child = ChildProcess::Spawn("replay-0", argv, (s.dir / "replay-0.log").string());
  if (!child.ok()) {
    *exit_code = 1;
    return child.status();
  }
  s.processes.push_back(std::move(*child));
  return s;
}

}  // namespace coins::bench
