#include "orchestrator/run_queue.h"

#include <mutex>
#include <set>
#include <thread>

#include <fmt/format.h>

#include "common/dds/dds_options.h"

namespace coins {

Status RunQueue(size_t jobs, const std::vector<int>& domains, const RunJob& run) {
  if (domains.empty()) {
    for (size_t j = 0; j < jobs; ++j) COINS_RETURN_IF_ERROR(run(j, std::nullopt));
    return Status::Ok();
  }
  std::mutex mu;
  size_t next = 0;  // the next job to start
  Status first_error = Status::Ok();
  auto worker = [&](int domain) {
    for (;;) {
      size_t job = 0;
      {
        std::lock_guard<std::mutex> lock(mu);
        if (!first_error.ok() || next >= jobs) return;
        job = next++;
      }
      Status s = run(job, domain);
      if (!s.ok()) {
        std::lock_guard<std::mutex> lock(mu);
        if (first_error.ok()) first_error = std::move(s);
        return;
      }
    }
  };
  std::vector<std::thread> workers;
  for (size_t i = 0; i < domains.size() && i < jobs; ++i) workers.emplace_back(worker, domains[i]);
  for (auto& w : workers) w.join();
  return first_error;
}

Status CheckDomains(const std::vector<int>& domains) {
  std::set<int> seen;
  for (int d : domains) {
    if (d < 0 || d > kMaxDdsDomain) return Errorf("--domains: {} is not a DDS domain id (0-{})", d, kMaxDdsDomain);
    if (!seen.insert(d).second) return Errorf("--domains: {} is listed twice (one domain per concurrent run)", d);
  }
  return Status::Ok();
}

}  // namespace coins
