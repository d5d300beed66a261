// OrchestratorOptions: the "orchestrator" section of the config. The chain's thresholds join
// here as the chain is built.
#pragma once

#include "common/config/config.h"

namespace coins {

struct OrchestratorOptions {
  // seconds between ChainStatus publications
  double status_period_s = 1.0;

  void Visit(ConfigVisitor& v) { v.Float("status_period_s", status_period_s, 0.05, 3600, "status period (s)"); }
  Status Validate() const { return Status::Ok(); }
};

}  // namespace coins
